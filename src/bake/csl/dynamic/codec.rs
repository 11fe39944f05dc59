//! The dynamic bake's artifact ([`MAGIC`]): a header and deflated chunks, one per direction
//! (its set, the images in a square-root code no finer than their noise needs, delta-coded)
//! and one of the blacks and the triples.

use super::{DynamicSet, DynamicStats, Icosphere, Member, Share, Triple};
use crate::bake::Fnv64;
use crate::bake::csl::{ArtifactError, Csl, CslSet};
use glam::Vec3;
use rayon::prelude::*;

/// Magic of a dynamic CSL bake artifact.
pub const MAGIC: [u8; 8] = *b"CSLDYN\0\0";
/// Format version of the dynamic artifact.
pub const VERSION: u32 = 3;
/// Largest body a dynamic artifact may declare (decompressed), 4 GiB.
pub(super) const MAX_BODY: u64 = 1 << 32;

/// How coarsely the artifact may code an image, against its sampling noise: the rounding error
/// of the code (RMS) is at most this fraction of the noise a texel's rays leave in it, at every
/// level. Independent errors add in squares, so 0.1 adds 0.5 % to the noise.
pub const CODE_NOISE: f32 = 0.1;

/// Most levels of a square-root code: with more, the lowest codes would stand for the same
/// 16-bit texel, and decoding then coding again would not give the same codes.
const MAX_LEVELS: u16 = 256;

/// Levels of the square-root code of `c`'s image (`sqrt_code`); 0 where its grain is unknown
/// or its noise too faint for `MAX_LEVELS`, 256 levels (the image is then kept as it is).
///
/// A texel of value v holds about v / g rays' worth for the grain g, so its noise is √(v·g).
/// The code c = round(L·√(v / M)) (M the brightest texel, `scale`) has steps of 2√(v·M) / L
/// at v, whose rounding error is √(v·M) / (L√3) RMS: the same fraction √(M/g) / (L√3) of the
/// noise at every level (the variance-stabilising root of a count). Solving for that fraction
/// = [`CODE_NOISE`] gives L. The grain is kept relative to M, so the levels do not change when
/// the code's flux correction changes the scale.
pub fn code_levels(c: &Csl) -> u16 {
    if !(c.grain > 0.0 && c.scale > 0.0) {
        return 0;
    }
    let l = (1.0 / c.grain as f64).sqrt() / (3f64.sqrt() * CODE_NOISE as f64);
    if l > MAX_LEVELS as f64 {
        return 0;
    }
    l.ceil().max(1.0) as u16
}

/// The 16-bit texel each code of a `levels`-level square-root code stands for:
/// round(65535 · (code / levels)²).
fn sqrt_levels(levels: u16) -> Vec<u16> {
    let l = levels as f64;
    (0..=levels)
        .map(|c| (65535.0 * (c as f64 / l).powi(2)).round() as u16)
        .collect()
}

/// `c`'s image coded with `levels` levels of a square-root code (each texel the code nearest
/// its root), and the scale that keeps the image's flux (the sum of the decoded texels times
/// it equals the sum of the texels times `c.scale`).
fn sqrt_code(c: &Csl, levels: u16) -> (f32, Vec<[u16; 3]>) {
    let table = sqrt_levels(levels);
    let l = levels as f64;
    let (mut before, mut after) = (0u64, 0u64);
    let codes = c
        .texels
        .iter()
        .map(|t| {
            t.map(|v| {
                let k = (l * (v as f64 / 65535.0).sqrt()).round() as u16;
                before += v as u64;
                after += table[k as usize] as u64;
                k
            })
        })
        .collect();
    let scale = if after > 0 {
        (c.scale as f64 * before as f64 / after as f64) as f32
    } else {
        c.scale
    };
    (scale, codes)
}

/// Texels coded for deflate: the channels decorrelated (R, G − R, B − G: the tint of a CSL's
/// light varies slowly across its image) and each then as the wrapping difference from the
/// previous texel (row-major), so that smooth images deflate to a fraction of their size. All
/// arithmetic wraps, so decoding restores every bit.
fn delta_code(texels: &mut [[u16; 3]], decode: bool) {
    let mut prev = [0u16; 3];
    for t in texels.iter_mut() {
        if decode {
            let u = [0, 1, 2].map(|ch| t[ch].wrapping_add(prev[ch]));
            prev = u;
            let g = u[1].wrapping_add(u[0]);
            *t = [u[0], g, u[2].wrapping_add(g)];
        } else {
            let u = [t[0], t[1].wrapping_sub(t[0]), t[2].wrapping_sub(t[1])];
            *t = [0, 1, 2].map(|ch| u[ch].wrapping_sub(prev[ch]));
            prev = u;
        }
    }
}

/// Deflate level of the artifact's chunks.
const DEFLATE_LEVEL: u32 = 6;

/// `raw` deflated (raw deflate, no zlib header) at [`DEFLATE_LEVEL`], by zlib-rs: at the same
/// level it took half miniz_oxide's time and wrote 2.4 % less (the chunks of a 12-direction
/// teapot bake: 1.06 s → 0.51 s, 5.50 → 5.37 MB). Deterministic: the same bytes in, the same
/// bytes out.
fn deflate(raw: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::DeflateEncoder::new(
        Vec::with_capacity(raw.len() / 8),
        flate2::Compression::new(DEFLATE_LEVEL),
    );
    e.write_all(raw).expect("writing to memory");
    e.finish().expect("writing to memory")
}

impl DynamicSet {
    /// Serialise: a header, deflated chunks (one per direction: its set, the images coded no
    /// finer than their noise needs ([`code_levels`]) and delta-coded, compressed in parallel;
    /// then one of the blacks and the triples) and an FNV-1a checksum. Deterministic; reading
    /// the bytes back and writing them again gives the same bytes.
    ///
    /// ```text
    /// header  magic "CSLDYN\0\0" · version u32 · subdivisions u32 · directions u32 · faces u32
    ///         source, object, params hash (3×u64)
    ///         stats: csls, blacks, matched, edges, triples, consistent triples (6×u32),
    ///                tracking rays u64
    ///         per chunk (directions + 1): length u64 · deflated length u64
    ///         the deflated chunks, in that order
    /// chunk   per direction: CSLs n u32 · per CSL the levels of its image's code u16
    ///         ([`code_levels`]; 0: the texels as they are) · its CSL set artifact, the
    ///         texels replaced by their codes ([`sqrt_code`]) and coded by `delta_code`
    /// last    per direction: blacks u32 · per black: origin, axis, x axis, κ, γ, half extent
    ///                        (12×f32) · image size u32
    ///         per face: triples u32 · per triple 3 × (CSL u16 · image share u8: 0 none,
    ///                   1 half, 2 all) · second CSL of a pair triple's third corner u16
    ///                   (0xFFFF: none)
    /// trailer FNV-1a 64 of every byte before it
    /// ```
    pub fn to_bytes(&self) -> Vec<u8> {
        // One chunk per direction, deflated in parallel, then the blacks and triples.
        let mut chunks: Vec<(u64, Vec<u8>)> = self
            .sets
            .par_iter()
            .map(|set| {
                let mut s = set.clone();
                let mut b = Vec::with_capacity(4 + 2 * s.csls.len());
                b.extend_from_slice(&(s.csls.len() as u32).to_le_bytes());
                for c in &mut s.csls {
                    let levels = code_levels(c);
                    if levels > 0 {
                        (c.scale, c.texels) = sqrt_code(c, levels);
                    }
                    b.extend_from_slice(&levels.to_le_bytes());
                    delta_code(&mut c.texels, false);
                }
                b.extend(s.to_bytes());
                (b.len() as u64, deflate(&b))
            })
            .collect();
        let mut body = Vec::new();
        let f32s = |body: &mut Vec<u8>, v: &[f32]| {
            for x in v {
                body.extend_from_slice(&x.to_le_bytes());
            }
        };
        for bl in &self.blacks {
            body.extend_from_slice(&(bl.len() as u32).to_le_bytes());
            for c in bl {
                f32s(&mut body, &c.origin.to_array());
                f32s(&mut body, &c.axis.to_array());
                f32s(&mut body, &c.x_axis.to_array());
                f32s(&mut body, &[c.kappa, c.gamma, c.half_extent]);
                body.extend_from_slice(&c.size.to_le_bytes());
            }
        }
        for ts in &self.triples {
            body.extend_from_slice(&(ts.len() as u32).to_le_bytes());
            for t in ts {
                for m in &t.members {
                    body.extend_from_slice(&m.csl.to_le_bytes());
                    body.push(match m.image {
                        Share::None => 0,
                        Share::Half => 1,
                        Share::Full => 2,
                    });
                }
                body.extend_from_slice(&t.split.unwrap_or(u16::MAX).to_le_bytes());
            }
        }
        chunks.push((body.len() as u64, deflate(&body)));
        let packed: usize = chunks.iter().map(|c| c.1.len()).sum();
        let mut out = Vec::with_capacity(packed + 16 * chunks.len() + 128);
        out.extend_from_slice(&MAGIC);
        let s = &self.stats;
        for v in [
            VERSION,
            self.subdivisions,
            self.sets.len() as u32,
            self.triples.len() as u32,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [self.source_hash, self.object_hash, self.params_hash] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in [
            s.csls,
            s.blacks,
            s.matched,
            s.edges,
            s.triples,
            s.consistent_triples,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&s.tracking_rays.to_le_bytes());
        for (raw, packed) in &chunks {
            out.extend_from_slice(&raw.to_le_bytes());
            out.extend_from_slice(&(packed.len() as u64).to_le_bytes());
        }
        for (_, packed) in &chunks {
            out.extend_from_slice(packed);
        }
        let sum = Fnv64::hash(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Parse and validate: magic, version, lengths, checksum, the direction and face counts of
    /// the icosahedron, every set (as [`CslSet::from_bytes`]) and every triple's indices.
    pub fn from_bytes(bytes: &[u8]) -> Result<DynamicSet, ArtifactError> {
        const HEAD: usize = 8 + 4 * 4 + 3 * 8 + 6 * 4 + 8;
        if bytes.len() >= 8 && bytes[..8] != MAGIC {
            return Err(ArtifactError::BadMagic);
        }
        if bytes.len() < HEAD + 8 {
            return Err(ArtifactError::Truncated {
                got: bytes.len(),
                expected: HEAD + 8,
            });
        }
        let mut r = Cursor { b: bytes, at: 8 };
        let version = r.u32()?;
        if version != VERSION {
            return Err(ArtifactError::UnsupportedVersion(version));
        }
        let subdivisions = r.u32()?;
        let (nv, nf) = (r.u32()? as usize, r.u32()? as usize);
        if subdivisions > 3 {
            return Err(ArtifactError::Invalid(format!(
                "{subdivisions} subdivisions"
            )));
        }
        let ico = Icosphere::new(subdivisions);
        if nv != ico.vertices.len() || nf != ico.faces.len() {
            return Err(ArtifactError::Invalid(format!(
                "{nv} directions and {nf} faces for {subdivisions} subdivisions"
            )));
        }
        let (source_hash, object_hash, params_hash) = (r.u64()?, r.u64()?, r.u64()?);
        let mut st = [0u32; 6];
        for v in &mut st {
            *v = r.u32()?;
        }
        let tracking_rays = r.u64()?;
        // The chunk table: a chunk per direction and one of blacks and triples.
        let table = HEAD + 16 * (nv + 1);
        if bytes.len() < table + 8 {
            return Err(ArtifactError::Truncated {
                got: bytes.len(),
                expected: table + 8,
            });
        }
        let mut chunks = Vec::with_capacity(nv + 1);
        let (mut at, mut raw_total) = (table as u64, 0u64);
        for _ in 0..=nv {
            let (raw, packed) = (r.u64()?, r.u64()?);
            raw_total = raw_total.saturating_add(raw);
            let end = at.saturating_add(packed);
            chunks.push((raw, at, end));
            at = end;
        }
        let expected = at.saturating_add(8);
        if bytes.len() as u64 != expected {
            return Err(ArtifactError::Truncated {
                got: bytes.len(),
                expected: expected.min(usize::MAX as u64) as usize,
            });
        }
        let end = bytes.len() - 8;
        let stored = u64::from_le_bytes(bytes[end..].try_into().expect("8 bytes"));
        if Fnv64::hash(&bytes[..end]) != stored {
            return Err(ArtifactError::Checksum);
        }
        if raw_total > MAX_BODY {
            return Err(ArtifactError::Invalid(format!("body of {raw_total} bytes")));
        }
        let inflate = |&(raw, from, to): &(u64, u64, u64)| {
            let body = miniz_oxide::inflate::decompress_to_vec_with_limit(
                &bytes[from as usize..to as usize],
                raw as usize,
            )
            .map_err(|e| ArtifactError::Invalid(format!("chunk does not inflate: {e:?}")))?;
            if body.len() as u64 != raw {
                return Err(ArtifactError::Invalid("chunk length".into()));
            }
            Ok(body)
        };
        let sets: Vec<CslSet> = chunks[..nv]
            .par_iter()
            .map(|c| {
                let chunk = inflate(c)?;
                let mut r = Cursor { b: &chunk, at: 0 };
                let n = r.u32()? as usize;
                let levels: Vec<u16> = (0..n)
                    .map(|_| Ok(u16::from_le_bytes(r.slice(2)?.try_into().expect("2 bytes"))))
                    .collect::<Result<_, ArtifactError>>()?;
                let mut set = CslSet::from_bytes(&chunk[r.at..])?;
                if set.csls.len() != n {
                    return Err(ArtifactError::Invalid(format!(
                        "{n} code levels for {} CSLs",
                        set.csls.len()
                    )));
                }
                for (c, &l) in set.csls.iter_mut().zip(&levels) {
                    delta_code(&mut c.texels, true);
                    if l == 0 {
                        continue;
                    }
                    if l > MAX_LEVELS {
                        return Err(ArtifactError::Invalid(format!("{l} code levels")));
                    }
                    let table = sqrt_levels(l);
                    for t in &mut c.texels {
                        for v in t {
                            *v = *table.get(*v as usize).ok_or_else(|| {
                                ArtifactError::Invalid(format!("code {v} of {l} levels"))
                            })?;
                        }
                    }
                }
                Ok(set)
            })
            .collect::<Result<_, ArtifactError>>()?;
        let body = inflate(&chunks[nv])?;
        let mut r = Cursor { b: &body, at: 0 };
        let mut blacks = Vec::with_capacity(nv);
        for set in &sets {
            let n = r.u32()? as usize;
            let mut bl = Vec::with_capacity(n.min(4096));
            for _ in 0..n {
                let mut f = [0f32; 12];
                for v in &mut f {
                    *v = r.f32()?;
                }
                let size = r.u32()?;
                let c = Csl {
                    origin: Vec3::new(f[0], f[1], f[2]),
                    axis: Vec3::new(f[3], f[4], f[5]),
                    x_axis: Vec3::new(f[6], f[7], f[8]),
                    kappa: f[9],
                    gamma: f[10],
                    half_extent: f[11],
                    size,
                    scale: 0.0,
                    flux: 0.0,
                    grain: 0.0,
                    texels: Vec::new(),
                };
                if !f.iter().all(|v| v.is_finite()) || !c.axis.is_normalized() {
                    return Err(ArtifactError::Invalid("black CSL not finite".into()));
                }
                bl.push(c);
            }
            if set.csls.len() + bl.len() >= u16::MAX as usize {
                return Err(ArtifactError::Invalid(
                    "too many CSLs at one direction".into(),
                ));
            }
            blacks.push(bl);
        }
        let mut triples = Vec::with_capacity(nf);
        for f in &ico.faces {
            let n = r.u32()? as usize;
            let len = f.map(|v| sets[v as usize].csls.len() + blacks[v as usize].len());
            let mut ts = Vec::with_capacity(n.min(1 << 16));
            let beyond = |csl: u16, k: usize| {
                ArtifactError::Invalid(format!(
                    "triple member {csl} beyond the {} CSLs of its direction",
                    len[k]
                ))
            };
            for _ in 0..n {
                let mut members = [Member {
                    csl: 0,
                    image: Share::None,
                }; 3];
                for (k, m) in members.iter_mut().enumerate() {
                    let csl = u16::from_le_bytes(r.slice(2)?.try_into().expect("2 bytes"));
                    let image = match r.slice(1)?[0] {
                        0 => Share::None,
                        1 => Share::Half,
                        2 => Share::Full,
                        x => return Err(ArtifactError::Invalid(format!("image share {x}"))),
                    };
                    if csl as usize >= len[k] {
                        return Err(beyond(csl, k));
                    }
                    *m = Member { csl, image };
                }
                let split = u16::from_le_bytes(r.slice(2)?.try_into().expect("2 bytes"));
                let split = if split == u16::MAX {
                    None
                } else {
                    // A pair triple: one corner adds no image, and that corner has the CSL.
                    let none: Vec<usize> = (0..3)
                        .filter(|&k| members[k].image == Share::None)
                        .collect();
                    let [k] = none[..] else {
                        return Err(ArtifactError::Invalid(
                            "pair triple without exactly one geometry-only member".into(),
                        ));
                    };
                    if split as usize >= len[k] {
                        return Err(beyond(split, k));
                    }
                    Some(split)
                };
                ts.push(Triple { members, split });
            }
            triples.push(ts);
        }
        if r.at != body.len() {
            return Err(ArtifactError::Invalid("trailing bytes in the body".into()));
        }
        Ok(DynamicSet {
            source_hash,
            object_hash,
            params_hash,
            subdivisions,
            sets,
            blacks,
            triples,
            stats: DynamicStats {
                directions: nv as u32,
                csls: st[0],
                blacks: st[1],
                matched: st[2],
                edges: st[3],
                triples: st[4],
                consistent_triples: st[5],
                tracking_rays,
                ..Default::default()
            },
        })
    }
}

/// Bounds-checked little-endian reads.
struct Cursor<'a> {
    b: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn slice(&mut self, n: usize) -> Result<&'a [u8], ArtifactError> {
        if self.b.len() - self.at < n {
            return Err(ArtifactError::Invalid("body truncated".into()));
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, ArtifactError> {
        Ok(u32::from_le_bytes(self.slice(4)?.try_into().expect("4")))
    }
    fn u64(&mut self) -> Result<u64, ArtifactError> {
        Ok(u64::from_le_bytes(self.slice(8)?.try_into().expect("8")))
    }
    fn f32(&mut self) -> Result<f32, ArtifactError> {
        Ok(f32::from_le_bytes(self.slice(4)?.try_into().expect("4")))
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::rotated_copies;
    use super::*;
    use crate::bake::csl::trace::CausticRay;
    use crate::sampling::Pcg;

    #[test]
    fn texel_coding_restores_every_bit() {
        let mut rng = Pcg::new(1, 0);
        let mut next = || rng.next_u32() as u16;
        let mut texels: Vec<[u16; 3]> = (0..4096).map(|_| [next(), next(), next()]).collect();
        texels.extend([
            [0, 65535, 0],
            [65535, 0, 65535],
            [65535; 3],
            [0; 3],
            [1, 0, 65535],
        ]);
        let mut coded = texels.clone();
        delta_code(&mut coded, false);
        assert!(coded != texels);
        delta_code(&mut coded, true);
        assert_eq!(coded, texels);
    }

    /// Decoded texels of `c` coded with `levels` levels: (scale, texels).
    fn sqrt_round_trip(c: &Csl, levels: u16) -> (f32, Vec<[u16; 3]>) {
        let (scale, codes) = sqrt_code(c, levels);
        let table = sqrt_levels(levels);
        (
            scale,
            codes.iter().map(|t| t.map(|k| table[k as usize])).collect(),
        )
    }

    #[test]
    fn the_image_code_errs_by_a_tenth_of_the_sampling_noise() {
        // Two images of the same tinted light from independent rays: half their squared
        // difference is the sampling noise's variance. Coding one with the levels its grain
        // gives errs by about CODE_NOISE of that noise (RMS) at every level of brightness, in
        // every channel (the dimmest, whose grain is finest, sets the levels), and keeps its flux.
        let mut rng = Pcg::new(3, 0);
        let mut next = move || rng.f32();
        let mut image = || {
            let mut rays: Vec<CausticRay> = (0..60_000)
                .map(|_| {
                    // A core on a wide disc an eighth as bright; energies vary as Fresnel's do.
                    let (r, t) = (next(), std::f32::consts::TAU * next());
                    let r = if next() < 0.5 {
                        0.15 * r.sqrt()
                    } else {
                        0.4 * r.sqrt()
                    };
                    CausticRay {
                        origin: Vec3::new(r * t.cos(), r * t.sin(), -1.0),
                        dir: Vec3::Z,
                        energy: Vec3::new(1.0, 0.9, 0.7) * (0.5 + 0.5 * next()),
                    }
                })
                .collect();
            // The same extent for both images.
            for k in 0..4 {
                let t = std::f32::consts::FRAC_PI_2 * k as f32;
                rays.push(CausticRay {
                    origin: Vec3::new(0.45 * t.cos(), 0.45 * t.sin(), -1.0),
                    dir: Vec3::Z,
                    energy: Vec3::splat(1e-3),
                });
            }
            let kept: Vec<u32> = (0..rays.len() as u32).collect();
            let img = crate::bake::csl::image::splat(
                &rays,
                &kept,
                Vec3::ZERO,
                Vec3::Z,
                Vec3::X,
                Vec3::Y,
                0.004,
                1e-4,
                0.008,
                128,
            );
            let (scale, texels) = crate::bake::csl::image::quantise(&img.texels);
            Csl {
                origin: Vec3::ZERO,
                axis: Vec3::Z,
                x_axis: Vec3::X,
                kappa: 0.0,
                gamma: 0.0,
                half_extent: img.half,
                size: img.size,
                scale,
                flux: img.flux as f32,
                grain: (img.grain / scale as f64) as f32,
                texels,
            }
        };
        let (a, b) = (image(), image());
        assert_eq!((a.size, a.half_extent), (b.size, b.half_extent));
        let levels = code_levels(&a);
        assert!((8..=MAX_LEVELS).contains(&levels), "{levels} levels");
        let (scale, coded) = sqrt_round_trip(&a, levels);
        let value = |t: [u16; 3], s: f32| Vec3::from(t.map(|v| v as f32)) * (s / 65535.0);
        // Squared error and noise per band of brightness (RGB mean, against the brightest) and
        // channel.
        let mut bands = [[(0.0f64, 0.0f64, 0u32); 3]; 2];
        let (mut before, mut after) = (0.0f64, 0.0f64);
        for ((&ta, &tb), &tc) in a.texels.iter().zip(&b.texels).zip(&coded) {
            let (va, vb, vc) = (value(ta, a.scale), value(tb, b.scale), value(tc, scale));
            before += va.element_sum() as f64;
            after += vc.element_sum() as f64;
            let level = va.element_sum() / (3.0 * a.scale);
            let band = match level {
                l if l < 0.01 => continue,
                l if l < 0.3 => 0,
                _ => 1,
            };
            for ch in 0..3 {
                let b = &mut bands[band][ch];
                b.0 += ((vc[ch] - va[ch]) as f64).powi(2);
                b.1 += 0.5 * ((vb[ch] - va[ch]) as f64).powi(2);
                b.2 += 1;
            }
        }
        assert!(
            (after / before - 1.0).abs() < 1e-5,
            "flux {}",
            after / before
        );
        for (k, band) in bands.iter().enumerate() {
            for (ch, (err, noise, n)) in band.iter().enumerate() {
                let ratio = (err / noise).sqrt();
                eprintln!(
                    "band {k}, channel {ch}: {n} texels, error / noise {ratio:.3} ({levels} levels)"
                );
                assert!(*n >= 100, "band {k}: {n} texels");
                assert!(
                    (0.5 * CODE_NOISE as f64..=1.3 * CODE_NOISE as f64).contains(&ratio),
                    "band {k}, channel {ch}: error / noise {ratio:.3}"
                );
            }
        }
    }

    #[test]
    fn coded_images_read_back_to_the_same_bytes() {
        // With a grain the images are coded: smaller, each texel within half a code step of
        // its value, and decoding then coding again gives the same bytes.
        let mut d = rotated_copies(0, 0.25);
        let exact = d.to_bytes().len();
        for s in &mut d.sets {
            for c in &mut s.csls {
                c.grain = 2e-3;
            }
        }
        let bytes = d.to_bytes();
        let back = DynamicSet::from_bytes(&bytes).unwrap();
        assert!(back.to_bytes() == bytes);
        assert!(bytes.len() * 2 < exact, "{} against {exact}", bytes.len());
        let c = &d.sets[0].csls[0];
        let levels = code_levels(c);
        assert_eq!(levels, 130);
        let (scale, coded) = sqrt_round_trip(c, levels);
        assert_eq!(back.sets[0].csls[0].texels, coded);
        assert_eq!(back.sets[0].csls[0].scale, scale);
        for (t, u) in c.texels.iter().zip(&coded) {
            for k in 0..3 {
                // v against the brightest: |√v − k/L| ≤ 1/(2L), so |v − (k/L)²| ≤
                // (√v + 1/(4L)) / L; and the table's rounding to 16 bits.
                let v = t[k] as f32 / 65535.0;
                let step = (v.sqrt() + 0.5 / levels as f32) / levels as f32 * 65535.0;
                assert!(
                    (t[k] as f32 - u[k] as f32).abs() <= step + 1.0,
                    "{} against {}",
                    t[k],
                    u[k]
                );
            }
        }
    }

    #[test]
    fn artifact_round_trip_and_corruption() {
        let d = rotated_copies(0, 0.25);
        let bytes = d.to_bytes();
        let back = DynamicSet::from_bytes(&bytes).unwrap();
        assert!(back.sets.iter().zip(&d.sets).all(|(a, b)| a.csls == b.csls));
        assert!(back.triples == d.triples);
        assert!(back.to_bytes() == bytes);
        // 12 directions × 2 images of 64² RGB u16 = 590 kB raw; deflated far smaller.
        assert!(bytes.len() < 200_000, "{}", bytes.len());
        let mut bad = bytes.clone();
        let mid = bad.len() / 2;
        bad[mid] ^= 1;
        assert_eq!(DynamicSet::from_bytes(&bad), Err(ArtifactError::Checksum));
        assert!(matches!(
            DynamicSet::from_bytes(&bytes[..bytes.len() - 9]),
            Err(ArtifactError::Truncated { .. })
        ));
        assert_eq!(
            DynamicSet::from_bytes(b"CSLSET\0\0rest"),
            Err(ArtifactError::BadMagic)
        );
        // Any byte of the header and the chunk table changed: an error, never a panic.
        for k in 0..8 + 4 * 4 + 3 * 8 + 6 * 4 + 8 + 16 * 13 {
            for bit in [0x01, 0x80] {
                let mut bad = bytes.clone();
                bad[k] ^= bit;
                assert!(DynamicSet::from_bytes(&bad).is_err(), "byte {k}");
            }
        }
        let mut v1 = bytes.clone();
        v1[8] = 1;
        assert_eq!(
            DynamicSet::from_bytes(&v1),
            Err(ArtifactError::UnsupportedVersion(1))
        );
    }
}
