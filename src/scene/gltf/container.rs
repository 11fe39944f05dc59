//! The bytes of a glTF file up to the document and its data: GLB framing (magic, version,
//! lengths, chunk order and alignment, checked before anything is allocated from a declared
//! length) or JSON text, the extensions a file may require, and the buffers, read from the BIN
//! chunk, base64 `data:` URIs (size-checked before decoding) or relative paths through the
//! [`AssetSource`](super::AssetSource), with schemes, absolute paths, `..` and bad
//! percent-encoding refused and all buffers together bounded by `max_buffer_bytes`. Buffer
//! views are bounds-checked here too, so that later stages read data only through `view_bytes`
//! and URIs only through `read_uri`.

use super::{Doc, GltfError, State, invalid};
use gltf::json;
use std::borrow::Cow;

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// The JSON text and the BIN chunk, if any.
pub(super) fn split_container<'a>(
    bytes: &'a [u8],
    st: &mut State,
) -> Result<(&'a [u8], Option<&'a [u8]>), GltfError> {
    if bytes.starts_with(GLB_MAGIC) {
        return parse_glb(bytes, st);
    }
    let mut j = bytes;
    if let Some(rest) = j.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
        st.warn("JSON starts with a byte order mark (not allowed by glTF); ignored".into());
        j = rest;
    }
    match j.iter().find(|b| !b.is_ascii_whitespace()) {
        Some(b'{') => Ok((j, None)),
        None if bytes.is_empty() => Err(GltfError::Glb(
            "the input is empty (0 bytes): neither a GLB nor glTF JSON".into(),
        )),
        None => Err(GltfError::Glb(
            "the input is blank: neither a GLB nor glTF JSON".into(),
        )),
        Some(_) => Err(GltfError::Glb(format!(
            "magic is {:02x?}, not 'glTF', and the input is not glTF JSON either",
            &bytes[..bytes.len().min(4)]
        ))),
    }
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// Check the GLB header and chunk table; nothing here allocates from a declared length.
fn parse_glb<'a>(b: &'a [u8], st: &mut State) -> Result<(&'a [u8], Option<&'a [u8]>), GltfError> {
    let glb = |m: String| GltfError::Glb(m);
    if b.len() < 12 {
        return Err(glb(format!(
            "{} bytes is shorter than the 12-byte header",
            b.len()
        )));
    }
    let version = u32_at(b, 4);
    if version != 2 {
        return Err(glb(format!(
            "version {version}, only version 2 is supported"
        )));
    }
    let declared = u32_at(b, 8) as u64;
    if declared != b.len() as u64 {
        return Err(glb(format!(
            "header declares {declared} bytes but the file has {}",
            b.len()
        )));
    }
    if b.len() < 20 {
        return Err(glb(
            "no chunks after the header (a JSON chunk is required)".into()
        ));
    }
    let mut pos = 12usize;
    let mut json: Option<&[u8]> = None;
    let mut bin: Option<&[u8]> = None;
    let mut idx = 0usize;
    while pos < b.len() {
        if b.len() - pos < 8 {
            return Err(glb(format!(
                "chunk {idx} at byte {pos}: truncated chunk header ({} bytes left)",
                b.len() - pos
            )));
        }
        let len = u32_at(b, pos) as u64;
        let ty = u32_at(b, pos + 4);
        let start = pos + 8;
        let end = start as u64 + len;
        if end > b.len() as u64 {
            return Err(glb(format!(
                "chunk {idx} (type {ty:#010x}) declares {len} bytes but only {} remain",
                b.len() - start
            )));
        }
        if !len.is_multiple_of(4) {
            return Err(glb(format!(
                "chunk {idx} (type {ty:#010x}) length {len} is not a multiple of 4"
            )));
        }
        let end = end as usize;
        let data = &b[start..end];
        match ty {
            CHUNK_JSON if idx == 0 => json = Some(data),
            CHUNK_JSON => return Err(glb(format!("chunk {idx}: a second JSON chunk"))),
            _ if idx == 0 => {
                return Err(glb(format!(
                    "the first chunk must be JSON, found type {ty:#010x}"
                )));
            }
            CHUNK_BIN if bin.is_some() => {
                return Err(glb(format!("chunk {idx}: a second BIN chunk")));
            }
            CHUNK_BIN if idx == 1 => bin = Some(data),
            CHUNK_BIN => return Err(glb(format!("chunk {idx}: BIN must directly follow JSON"))),
            _ => st.warn(format!(
                "GLB chunk {idx} of unknown type {ty:#010x} ignored"
            )),
        }
        pos = end;
        idx += 1;
    }
    match json {
        Some(j) => Ok((j, bin)),
        None => Err(glb("no JSON chunk".into())),
    }
}

pub(super) fn check_extensions(root: &json::Root, st: &mut State) -> Result<(), GltfError> {
    const SUPPORTED: [&str; 4] = [
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
        "KHR_lights_punctual",
    ];
    for e in &root.extensions_required {
        if SUPPORTED.contains(&e.as_str()) {
            continue;
        }
        if e.starts_with("KHR_materials_") || e.starts_with("KHR_texture_") {
            st.warn(format!(
                "required extension {e} is not supported; materials are approximated"
            ));
        } else {
            return Err(invalid(format!(
                "the file requires extension {e}, which is not supported"
            )));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// URIs and buffers

pub(super) fn short(uri: &str) -> String {
    if uri.len() <= 80 {
        uri.to_string()
    } else {
        let mut end = 60;
        while !uri.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}... ({} bytes)", &uri[..end], uri.len())
    }
}

fn decode_base64(s: &[u8]) -> Result<Vec<u8>, String> {
    let mut s = s;
    for _ in 0..2 {
        if let Some(r) = s.strip_suffix(b"=") {
            s = r;
        }
    }
    let mut out = Vec::with_capacity(s.len() / 4 * 3 + 3);
    let mut acc: u32 = 0;
    let mut bits = 0u32;
    for (i, &c) in s.iter().enumerate() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return Err(format!("invalid base64 character at offset {i}")),
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    if bits >= 6 {
        return Err("truncated base64 data".into());
    }
    Ok(out)
}

fn hex(c: u8) -> Option<u8> {
    (c as char).to_digit(16).map(|d| d as u8)
}

fn percent_decode(s: &str) -> Result<String, String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let h = b.get(i + 1).copied().and_then(hex);
            let l = b.get(i + 2).copied().and_then(hex);
            match (h, l) {
                (Some(h), Some(l)) => out.push(h * 16 + l),
                _ => return Err(format!("bad percent-encoding at byte {i}")),
            }
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| "not UTF-8 after percent-decoding".to_string())
}

/// The relative path a URI names, or why it is refused.
fn relative_path(uri: &str) -> Result<String, String> {
    if uri.is_empty() {
        return Err("empty URI".into());
    }
    if let Some(colon) = uri.find(':') {
        let before = &uri[..colon];
        if !before.contains(['/', '?', '#']) {
            return Err(format!(
                "the scheme or drive '{before}:' is not allowed (only relative paths and data: URIs)"
            ));
        }
    }
    if uri.starts_with('/') || uri.starts_with('\\') {
        return Err("absolute paths are not allowed".into());
    }
    if uri.contains('\\') {
        return Err("backslashes are not allowed in URIs".into());
    }
    if uri.contains(['?', '#']) {
        return Err("queries and fragments are not allowed in URIs".into());
    }
    let path = percent_decode(uri)?;
    if path.starts_with('/') || path.contains(['\\', '\0']) {
        return Err("absolute paths, backslashes and NUL are not allowed".into());
    }
    for (k, seg) in path.split('/').enumerate() {
        if seg == ".." {
            return Err("'..' segments are not allowed".into());
        }
        if seg.is_empty() {
            return Err("empty path segments are not allowed".into());
        }
        if k == 0 && seg.contains(':') {
            return Err("a ':' in the first path segment is not allowed".into());
        }
    }
    Ok(path)
}

/// Bytes named by a buffer or image URI (`what`: "buffer 2", "image 0").
pub(super) fn read_uri(
    uri: &str,
    what: &str,
    max_bytes: usize,
    st: &State,
) -> Result<Vec<u8>, GltfError> {
    let refuse = |reason: String| GltfError::Uri {
        what: what.to_string(),
        uri: short(uri),
        reason,
    };
    if uri.len() >= 5 && uri[..5].eq_ignore_ascii_case("data:") {
        let comma = uri
            .find(',')
            .ok_or_else(|| refuse("data URI without ','".into()))?;
        let header = &uri[5..comma];
        if !header.to_ascii_lowercase().ends_with(";base64") {
            return Err(refuse("only base64 data URIs are supported".into()));
        }
        let payload = &uri.as_bytes()[comma + 1..];
        let estimate = payload.len() / 4 * 3;
        if estimate > max_bytes.saturating_add(3) {
            return Err(GltfError::Limit(format!(
                "{what}: data URI holds about {estimate} bytes, the limit is {max_bytes}"
            )));
        }
        return decode_base64(payload).map_err(refuse);
    }
    let path = relative_path(uri).map_err(refuse)?;
    let assets = st.assets.ok_or_else(|| {
        refuse(
            "external files are not allowed here (no asset source: use a GLB or data: URIs)".into(),
        )
    })?;
    assets
        .read(&path, max_bytes)
        .map_err(|e| refuse(format!("cannot read '{path}': {e}")))
}

pub(super) fn load_buffers<'a>(
    root: &json::Root,
    bin: Option<&'a [u8]>,
    st: &mut State,
) -> Result<Vec<Cow<'a, [u8]>>, GltfError> {
    let max = st.limits.max_buffer_bytes;
    let mut total: u64 = 0;
    let mut out = Vec::with_capacity(root.buffers.len().min(1024));
    for (i, b) in root.buffers.iter().enumerate() {
        let declared = b.byte_length.0;
        total = total.saturating_add(declared);
        if total > max as u64 {
            return Err(GltfError::Limit(format!(
                "buffers declare more than {max} bytes in total (buffer {i}: {declared})"
            )));
        }
        let left = max - (total - declared) as usize;
        let data: Cow<'a, [u8]> = match (&b.uri, bin) {
            (Some(uri), _) => Cow::Owned(read_uri(uri, &format!("buffer {i}"), left, st)?),
            (None, Some(bin)) if i == 0 => Cow::Borrowed(bin),
            (None, _) => {
                return Err(invalid(format!(
                    "buffer {i} has no uri and is not the GLB BIN chunk (no data)"
                )));
            }
        };
        let actual = data.len() as u64;
        if actual < declared {
            return Err(invalid(format!(
                "buffer {i}: byteLength is {declared} but only {actual} bytes of data exist"
            )));
        }
        let padding = if b.uri.is_none() { 3 } else { 0 };
        if actual > declared + padding {
            st.warn(format!(
                "buffer {i}: {actual} bytes of data, byteLength says {declared}; the rest is ignored"
            ));
        }
        out.push(match data {
            Cow::Borrowed(s) => Cow::Borrowed(&s[..declared as usize]),
            Cow::Owned(mut v) => {
                v.truncate(declared as usize);
                Cow::Owned(v)
            }
        });
    }
    Ok(out)
}

/// Offset and length of buffer view `v` within its buffer (already checked by `check_views`).
pub(super) fn view_bytes<'d>(
    doc: &'d Doc,
    v: usize,
) -> Result<(&'d [u8], Option<usize>), GltfError> {
    let view = doc
        .root
        .buffer_views
        .get(v)
        .ok_or_else(|| invalid(format!("bufferView {v} does not exist")))?;
    let buf = doc.buffers.get(view.buffer.value()).ok_or_else(|| {
        invalid(format!(
            "bufferView {v}: buffer {} does not exist",
            view.buffer.value()
        ))
    })?;
    let off = view.byte_offset.map_or(0, |o| o.0);
    let len = view.byte_length.0;
    let end = off.checked_add(len).filter(|&e| e <= buf.len() as u64);
    match end {
        Some(end) => Ok((
            &buf[off as usize..end as usize],
            view.byte_stride.map(|s| s.0),
        )),
        None => Err(invalid(format!(
            "bufferView {v}: bytes {off}..{} lie outside buffer {} ({} bytes): out of bounds",
            off as u128 + len as u128,
            view.buffer.value(),
            buf.len()
        ))),
    }
}

pub(super) fn check_views(doc: &Doc) -> Result<(), GltfError> {
    for (i, view) in doc.root.buffer_views.iter().enumerate() {
        view_bytes(doc, i)?;
        if let Some(s) = view.byte_stride
            && (s.0 < 4 || s.0 > 252 || !s.0.is_multiple_of(4))
        {
            return Err(invalid(format!(
                "bufferView {i}: byteStride {} must be a multiple of 4 in 4..=252",
                s.0
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::gltf::GltfLimits;

    #[test]
    fn base64_round_trip() {
        assert_eq!(decode_base64(b"AAECAw==").unwrap(), vec![0, 1, 2, 3]);
        assert_eq!(decode_base64(b"AAECAwQ").unwrap(), vec![0, 1, 2, 3, 4]);
        assert!(decode_base64(b"AA*A").is_err());
        assert!(decode_base64(b"AAECA").is_err());
    }

    #[test]
    fn uris_are_checked() {
        assert_eq!(relative_path("a%20b.bin").unwrap(), "a b.bin");
        assert_eq!(relative_path("dir/x.bin").unwrap(), "dir/x.bin");
        for bad in [
            "../x.bin",
            "a/../../x",
            "%2E%2E/x",
            "/etc/passwd",
            "file:///etc/passwd",
            "http://example.com/a.bin",
            "C:\\x.bin",
            "%zz.bin",
            "a%",
            "%2Fetc%2Fpasswd",
            "",
        ] {
            assert!(relative_path(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn glb_framing() {
        let mut st = State {
            limits: &GltfLimits::default(),
            assets: None,
            warnings: vec![],
            suppressed: 0,
            decoded: 0,
            image_bytes_left: 0,
        };
        let json = br#"{"asset":{"version":"2.0"}} "#; // 28 bytes
        let mut glb = b"glTF".to_vec();
        glb.extend(2u32.to_le_bytes());
        glb.extend((20 + json.len() as u32).to_le_bytes());
        glb.extend((json.len() as u32).to_le_bytes());
        glb.extend(CHUNK_JSON.to_le_bytes());
        glb.extend(json);
        let (j, bin) = parse_glb(&glb, &mut st).unwrap();
        assert_eq!(j, json);
        assert!(bin.is_none());
        let mut huge = glb.clone();
        huge[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(parse_glb(&huge, &mut st).is_err());
        let mut big_chunk = glb.clone();
        big_chunk[12..16].copy_from_slice(&(u32::MAX - 3).to_le_bytes());
        assert!(parse_glb(&big_chunk, &mut st).is_err());
    }
}
