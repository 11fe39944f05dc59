//! Accessors, checked and read by hand. Every accessor is checked up front for its types and
//! the bounds of its buffer view and sparse parts (element sizes with the padding glTF requires
//! for small matrices, strides, offsets, all in u128 so nothing overflows), before any data is
//! read. Positions, normals and indices are then decoded with each read bounds-checked and each
//! count held against the vertex and triangle caps (and the decode budget) before anything is
//! allocated.

use super::container::view_bytes;
use super::{Doc, GltfError, State, invalid};
use glam::Vec3;
use gltf::json;
use json::accessor::{ComponentType, Type};
use json::validation::Checked;

fn comp_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// Bytes of one element, with the column padding glTF requires for small matrices.
fn elem_size(c: ComponentType, t: Type) -> usize {
    let cs = comp_size(c);
    match t {
        Type::Scalar => cs,
        Type::Vec2 => 2 * cs,
        Type::Vec3 => 3 * cs,
        Type::Vec4 => 4 * cs,
        // Matrix columns start on 4-byte boundaries.
        Type::Mat2 => 2 * (2 * cs).next_multiple_of(4),
        Type::Mat3 => 3 * (3 * cs).next_multiple_of(4),
        Type::Mat4 => 16 * cs,
    }
}

fn layout<'a>(
    doc: &Doc<'a>,
    i: usize,
) -> Result<(&'a json::Accessor, ComponentType, Type), GltfError> {
    let a = doc
        .root
        .accessors
        .get(i)
        .ok_or_else(|| invalid(format!("accessor {i} does not exist")))?;
    match (&a.component_type, &a.type_) {
        (Checked::Valid(c), Checked::Valid(t)) => Ok((a, c.0, *t)),
        _ => Err(invalid(format!(
            "accessor {i}: unknown componentType or type"
        ))),
    }
}

/// `offset + stride·(count-1) + elem ≤ len`, in u128 so nothing overflows.
fn fits(offset: u64, stride: usize, count: u64, elem: usize, len: usize) -> bool {
    count == 0
        || offset as u128 + stride as u128 * (count as u128 - 1) + elem as u128 <= len as u128
}

/// Structural checks of accessor `i` (types, bounds, sparse layout); reads no data.
pub(super) fn check_accessor(doc: &Doc, i: usize, st: &mut State) -> Result<(), GltfError> {
    let (a, c, t) = layout(doc, i)?;
    let elem = elem_size(c, t);
    let count = a.count.0;
    if count == 0 {
        return Err(invalid(format!("accessor {i}: count must be at least 1")));
    }
    if let Some(v) = a.buffer_view {
        let (data, stride) =
            view_bytes(doc, v.value()).map_err(|e| invalid(format!("accessor {i}: {e}")))?;
        let stride = stride.unwrap_or(elem);
        if stride < elem {
            return Err(invalid(format!(
                "accessor {i}: byteStride {stride} is smaller than the element size {elem}"
            )));
        }
        let off = a.byte_offset.map_or(0, |o| o.0);
        if !fits(off, stride, count, elem, data.len()) {
            return Err(invalid(format!(
                "accessor {i}: offset {off} + stride {stride} × ({count} - 1) + {elem} bytes is out of bounds of bufferView {} ({} bytes)",
                v.value(),
                data.len()
            )));
        }
        if !off.is_multiple_of(comp_size(c) as u64) {
            st.warn(format!(
                "accessor {i}: byteOffset {off} is not a multiple of the component size"
            ));
        }
    }
    if let Some(s) = &a.sparse {
        let sc = s.count.0;
        if sc == 0 || sc > count {
            return Err(invalid(format!(
                "accessor {i}: sparse count {sc} must lie in 1..={count}"
            )));
        }
        let ic = match &s.indices.component_type {
            Checked::Valid(ic) => ic.0,
            Checked::Invalid => {
                return Err(invalid(format!(
                    "accessor {i}: sparse indices componentType must be an unsigned integer"
                )));
            }
        };
        for (what, view, off, size) in [
            (
                "indices",
                s.indices.buffer_view,
                s.indices.byte_offset.0,
                comp_size(ic),
            ),
            ("values", s.values.buffer_view, s.values.byte_offset.0, elem),
        ] {
            let (data, stride) = view_bytes(doc, view.value())
                .map_err(|e| invalid(format!("accessor {i}: sparse {what}: {e}")))?;
            if stride.is_some() {
                return Err(invalid(format!(
                    "accessor {i}: sparse {what} bufferView {} must not have a byteStride",
                    view.value()
                )));
            }
            if !fits(off, size, sc, size, data.len()) {
                return Err(invalid(format!(
                    "accessor {i}: sparse {what} ({sc} × {size} bytes at offset {off}) are out of bounds of bufferView {} ({} bytes)",
                    view.value(),
                    data.len()
                )));
            }
        }
    }
    Ok(())
}

fn f32_at(d: &[u8], o: usize) -> Option<f32> {
    d.get(o..o + 4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn uint_at(d: &[u8], o: usize, c: ComponentType) -> Option<u32> {
    match c {
        ComponentType::U8 => d.get(o).map(|&b| u32::from(b)),
        ComponentType::U16 => d
            .get(o..o + 2)
            .map(|b| u32::from(u16::from_le_bytes([b[0], b[1]]))),
        ComponentType::U32 => d
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        _ => None,
    }
}

fn oob(what: &str) -> GltfError {
    invalid(format!("{what}: read out of bounds"))
}

/// Count of accessor `a`, checked against `cap` before anything is allocated.
fn checked_count(a: &json::Accessor, cap: usize, what: &str) -> Result<usize, GltfError> {
    let n = a.count.0;
    if n > cap as u64 {
        return Err(GltfError::Limit(format!(
            "{what}: accessor count {n} exceeds the limit {cap}"
        )));
    }
    Ok(n as usize)
}

/// Sparse indices of `a` (each < `count`).
fn sparse_indices(
    doc: &Doc,
    s: &json::accessor::sparse::Sparse,
    count: usize,
    what: &str,
) -> Result<Vec<usize>, GltfError> {
    let ic = match &s.indices.component_type {
        Checked::Valid(ic) => ic.0,
        Checked::Invalid => return Err(invalid(format!("{what}: bad sparse index type"))),
    };
    let (data, _) = view_bytes(doc, s.indices.buffer_view.value())?;
    let base = s.indices.byte_offset.0 as usize;
    let n = s.count.0 as usize; // checked ≤ accessor count by check_accessor
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let ix = uint_at(data, base + k * comp_size(ic), ic).ok_or_else(|| oob(what))? as usize;
        if ix >= count {
            return Err(invalid(format!(
                "{what}: sparse index {ix} is out of bounds (count {count})"
            )));
        }
        out.push(ix);
    }
    Ok(out)
}

/// A VEC3 FLOAT accessor (positions, normals).
pub(super) fn read_vec3(
    doc: &Doc,
    st: &mut State,
    i: usize,
    what: &str,
) -> Result<Vec<Vec3>, GltfError> {
    let (a, c, t) = layout(doc, i)?;
    if c != ComponentType::F32 || t != Type::Vec3 || a.normalized {
        return Err(invalid(format!(
            "{what}: accessor {i} must be VEC3 FLOAT (not normalized), found {t:?} {c:?}"
        )));
    }
    let count = checked_count(a, st.limits.max_vertices, what)?;
    st.decode_budget(count, what)?;
    let mut out = vec![Vec3::ZERO; count];
    let read = |d: &[u8], o: usize| -> Option<Vec3> {
        Some(Vec3::new(
            f32_at(d, o)?,
            f32_at(d, o + 4)?,
            f32_at(d, o + 8)?,
        ))
    };
    if let Some(v) = a.buffer_view {
        let (data, stride) = view_bytes(doc, v.value())?;
        let stride = stride.unwrap_or(12);
        let base = a.byte_offset.map_or(0, |o| o.0) as usize;
        for (k, p) in out.iter_mut().enumerate() {
            *p = read(data, base + k * stride).ok_or_else(|| oob(what))?;
        }
    }
    if let Some(s) = &a.sparse {
        let idx = sparse_indices(doc, s, count, what)?;
        let (data, _) = view_bytes(doc, s.values.buffer_view.value())?;
        let base = s.values.byte_offset.0 as usize;
        for (k, ix) in idx.into_iter().enumerate() {
            out[ix] = read(data, base + k * 12).ok_or_else(|| oob(what))?;
        }
    }
    Ok(out)
}

/// A SCALAR unsigned byte/short/int accessor (indices).
pub(super) fn read_indices(
    doc: &Doc,
    st: &mut State,
    i: usize,
    what: &str,
) -> Result<Vec<u32>, GltfError> {
    let (a, c, t) = layout(doc, i)?;
    if t != Type::Scalar
        || !matches!(
            c,
            ComponentType::U8 | ComponentType::U16 | ComponentType::U32
        )
        || a.normalized
    {
        return Err(invalid(format!(
            "{what}: accessor {i} must be SCALAR unsigned byte/short/int, found {t:?} {c:?}"
        )));
    }
    let cap = st.limits.max_triangles.saturating_mul(3).saturating_add(2);
    let count = checked_count(a, cap, what)?;
    st.decode_budget(count, what)?;
    let mut out = vec![0u32; count];
    let cs = comp_size(c);
    if let Some(v) = a.buffer_view {
        let (data, stride) = view_bytes(doc, v.value())?;
        let stride = stride.unwrap_or(cs);
        let base = a.byte_offset.map_or(0, |o| o.0) as usize;
        for (k, x) in out.iter_mut().enumerate() {
            *x = uint_at(data, base + k * stride, c).ok_or_else(|| oob(what))?;
        }
    }
    if let Some(s) = &a.sparse {
        let idx = sparse_indices(doc, s, count, what)?;
        let (data, _) = view_bytes(doc, s.values.buffer_view.value())?;
        let base = s.values.byte_offset.0 as usize;
        for (k, ix) in idx.into_iter().enumerate() {
            out[ix] = uint_at(data, base + k * cs, c).ok_or_else(|| oob(what))?;
        }
    }
    Ok(out)
}
