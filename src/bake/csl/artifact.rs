//! The CSL set artifact: little-endian binary, versioned, checksummed.
//!
//! ```text
//! header   magic "CSLSET\0\0" (8) · version u32 · csl count u32 · largest image size u32 ·
//!          reserved u32
//!          source hash u64 · params hash u64
//!          light dir 3×f32 · centre 3×f32 · radius f32 · spacing f32
//!          stats: rays traced, rays hit, caustic rays, dismissed rays (4×u64),
//!                 energy traced, covered, dropped (3×f64), rejected bundles, iterations (2×u32)
//! per CSL  image size u32 · origin 3×f32 · axis 3×f32 · x axis 3×f32 ·
//!          κ γ half_extent scale flux grain (6×f32) · texels size²×3×u16 (row-major RGB)
//! trailer  FNV-1a 64 of every byte before it (u64)
//! ```
//!
//! Only deterministic data is written (no times), so identical inputs give identical bytes.

use super::{BakeStats, Csl, CslSet};
use crate::bake::Fnv64;
use glam::Vec3;
use thiserror::Error;

pub const MAGIC: [u8; 8] = *b"CSLSET\0\0";
pub const VERSION: u32 = 3;
const HEADER: usize = 8 + 4 * 4 + 2 * 8 + 8 * 4 + 4 * 8 + 3 * 8 + 2 * 4;
const PER_CSL: usize = 16 * 4;

/// Why bytes are not a valid CSL set.
#[derive(Debug, Error, PartialEq)]
pub enum ArtifactError {
    #[error("not a CSL set (bad magic)")]
    BadMagic,
    #[error("CSL set format version {0} is not supported (expected {VERSION})")]
    UnsupportedVersion(u32),
    #[error("CSL set truncated: {got} bytes, expected {expected}")]
    Truncated { got: usize, expected: usize },
    #[error("CSL set checksum mismatch (corrupted artifact)")]
    Checksum,
    #[error("invalid CSL set: {0}")]
    Invalid(String),
}

struct Writer(Vec<u8>);

impl Writer {
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f32(&mut self, v: f32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn vec3(&mut self, v: Vec3) {
        for c in v.to_array() {
            self.f32(c);
        }
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let a = self.b[self.at..self.at + N]
            .try_into()
            .expect("length checked");
        self.at += N;
        a
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
    fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
}

impl CslSet {
    /// Serialise (deterministic: no timings are written).
    pub fn to_bytes(&self) -> Vec<u8> {
        let largest = self.csls.iter().map(|c| c.size).max().unwrap_or(0);
        let texels: usize = self.csls.iter().map(|c| c.texels.len() * 6).sum();
        let mut w = Writer(Vec::with_capacity(
            HEADER + self.csls.len() * PER_CSL + texels + 8,
        ));
        w.0.extend_from_slice(&MAGIC);
        w.u32(VERSION);
        w.u32(self.csls.len() as u32);
        w.u32(largest);
        w.u32(0);
        w.u64(self.source_hash);
        w.u64(self.params_hash);
        w.vec3(self.light_dir);
        w.vec3(self.centre);
        w.f32(self.radius);
        w.f32(self.spacing);
        let s = &self.stats;
        for v in [s.rays_traced, s.rays_hit, s.caustic_rays, s.dismissed_rays] {
            w.u64(v);
        }
        for v in [s.energy_traced, s.energy_covered, s.energy_dropped] {
            w.f64(v);
        }
        w.u32(s.rejected_bundles);
        w.u32(s.iterations);
        for c in &self.csls {
            assert_eq!(c.texels.len(), (c.size * c.size) as usize, "size² texels");
            w.u32(c.size);
            w.vec3(c.origin);
            w.vec3(c.axis);
            w.vec3(c.x_axis);
            for v in [c.kappa, c.gamma, c.half_extent, c.scale, c.flux, c.grain] {
                w.f32(v);
            }
            for t in &c.texels {
                for v in t {
                    w.0.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
        let sum = Fnv64::hash(&w.0);
        w.u64(sum);
        w.0
    }

    /// Parse and validate (magic, version, length, checksum, finite and unit vectors).
    pub fn from_bytes(bytes: &[u8]) -> Result<CslSet, ArtifactError> {
        if bytes.len() < 12 || bytes[..8] != MAGIC {
            return Err(if bytes.len() >= 8 && bytes[..8] != MAGIC {
                ArtifactError::BadMagic
            } else {
                ArtifactError::Truncated {
                    got: bytes.len(),
                    expected: HEADER + 8,
                }
            });
        }
        let mut r = Reader { b: bytes, at: 8 };
        let version = r.u32();
        if version != VERSION {
            return Err(ArtifactError::UnsupportedVersion(version));
        }
        if bytes.len() < HEADER + 8 {
            return Err(ArtifactError::Truncated {
                got: bytes.len(),
                expected: HEADER + 8,
            });
        }
        let count = r.u32() as usize;
        let _largest = r.u32();
        let _reserved = r.u32();
        // Each CSL's record length from its image size, before anything is read from it.
        let body = bytes.len() - 8;
        let mut at = HEADER as u128;
        for i in 0..count {
            if at + PER_CSL as u128 > body as u128 {
                return Err(ArtifactError::Truncated {
                    got: bytes.len(),
                    expected: (at + PER_CSL as u128 + 8).min(usize::MAX as u128) as usize,
                });
            }
            let k = at as usize;
            let size = u32::from_le_bytes(bytes[k..k + 4].try_into().expect("4 bytes")) as u128;
            if !(1..=4096).contains(&size) {
                return Err(ArtifactError::Invalid(format!(
                    "CSL {i}: image size {size}"
                )));
            }
            at += PER_CSL as u128 + size * size * 6;
        }
        if at != body as u128 {
            return Err(ArtifactError::Truncated {
                got: bytes.len(),
                expected: (at + 8).min(usize::MAX as u128) as usize,
            });
        }
        let stored = u64::from_le_bytes(bytes[body..].try_into().expect("8 bytes"));
        if Fnv64::hash(&bytes[..body]) != stored {
            return Err(ArtifactError::Checksum);
        }
        let source_hash = r.u64();
        let params_hash = r.u64();
        let light_dir = r.vec3();
        let centre = r.vec3();
        let radius = r.f32();
        let spacing = r.f32();
        let mut stats = BakeStats {
            rays_traced: r.u64(),
            rays_hit: r.u64(),
            caustic_rays: r.u64(),
            dismissed_rays: r.u64(),
            energy_traced: r.f64(),
            energy_covered: r.f64(),
            energy_dropped: r.f64(),
            rejected_bundles: r.u32(),
            iterations: r.u32(),
            ..Default::default()
        };
        let unit = |v: Vec3| v.is_finite() && (v.length() - 1.0).abs() < 1e-3;
        if !unit(light_dir)
            || !centre.is_finite()
            || radius.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            || spacing.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        {
            return Err(ArtifactError::Invalid("header geometry".into()));
        }
        let mut csls = Vec::with_capacity(count);
        for i in 0..count {
            let size = r.u32() as usize;
            let origin = r.vec3();
            let axis = r.vec3();
            let x_axis = r.vec3();
            let [kappa, gamma, half_extent, scale, flux, grain] = std::array::from_fn(|_| r.f32());
            if !origin.is_finite()
                || !unit(axis)
                || !unit(x_axis)
                || axis.dot(x_axis).abs() > 1e-3
                || !kappa.is_finite()
                || !gamma.is_finite()
                || !(half_extent > 0.0 && half_extent.is_finite())
                || !(scale >= 0.0 && scale.is_finite())
                || !flux.is_finite()
                || !(grain >= 0.0 && grain.is_finite())
            {
                return Err(ArtifactError::Invalid(format!("CSL {i}")));
            }
            let texels = (0..size * size)
                .map(|_| std::array::from_fn(|_| u16::from_le_bytes(r.take())))
                .collect();
            csls.push(Csl {
                origin,
                axis,
                x_axis,
                kappa,
                gamma,
                half_extent,
                size: size as u32,
                scale,
                flux,
                grain,
                texels,
            });
        }
        stats.csls = count as u32;
        Ok(CslSet {
            source_hash,
            params_hash,
            light_dir,
            centre,
            radius,
            spacing,
            csls,
            stats,
        })
    }
}
