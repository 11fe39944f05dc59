//! The light transport table: quantised storage (Iwasaki et al. 2005 §6) and its artifact.
//!
//! Per sample, as the paper: the exit position as 3 × 16 bits within the object's bounding box,
//! the exit direction as two 16-bit angles (polar φ ∈ [0, π] from +z, azimuth θ ∈ [0, 2π)), the
//! transmittance in 16 bits: 12 bytes. We keep the two flags (self-occluded, trapped) in the top
//! two bits of the transmittance word, which leaves it 14 bits (steps of 6·10⁻⁵). Beyond the
//! paper, each sample adds its path's 16-bit signature (the patches it crossed, see
//! [`super::Sample::path`]), so that the render interpolates only between samples that left on
//! the same path: 14 bytes. A tinted (absorbing) object adds the path length inside as 16 bits
//! of the table's longest path, so that the render recovers the RGB transmittance F·exp(−σL)
//! exactly in colour: 16 bytes. The header keeps the table's fit ([`TransportTable::fit`]).
//!
//! ```text
//! header   magic "LTTABLE\0" (8) · version u32 · vertices u32 · rings u32 · azimuths u32
//!          max depth u32 · flags u32 (bit 0: path lengths stored) · source hash u64
//!          params hash u64 · bounds lo 3×f32 · bounds hi 3×f32 · longest path f32
//!          fit error f32 (NaN: not checked) · light lost at path splits f32 (NaN: idem)
//! records  vertices × directions × (position 3×u16 · φ u16 · θ u16 · transmittance|flags u16
//!          · path signature u16 [· path length u16])
//! trailer  FNV-1a 64 of every byte before it (u64)
//! ```
//!
//! Identical inputs give identical bytes (no times are stored).

use super::{Sample, TransportParams, TransportStats};
use crate::bake::Fnv64;
use crate::cancel::Canceled;
use glam::Vec3;
use std::f32::consts::{PI, TAU};
use thiserror::Error;

pub const MAGIC: [u8; 8] = *b"LTTABLE\0";
pub const VERSION: u32 = 2;
const HEADER: usize = 8 + 6 * 4 + 2 * 8 + 9 * 4;
const OCCLUDED: u16 = 1 << 14;
const TRAPPED: u16 = 1 << 15;
const T_MAX: f32 = ((1 << 14) - 1) as f32;

/// Why bytes are not a valid transport table.
#[derive(Debug, Error, PartialEq)]
pub enum TableError {
    #[error("not a light transport table (bad magic)")]
    BadMagic,
    #[error(
        "transport table format version {0} is not supported (expected {VERSION}): bake it again"
    )]
    UnsupportedVersion(u32),
    #[error("transport table truncated: {got} bytes, expected {expected}")]
    Truncated { got: usize, expected: usize },
    #[error("transport table checksum mismatch (corrupted artifact)")]
    Checksum,
    #[error("invalid transport table: {0}")]
    Invalid(String),
}

/// One quantised sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    pub position: [u16; 3],
    /// (φ, θ).
    pub direction: [u16; 2],
    /// 14 bits of transmittance, bit 14 occluded, bit 15 trapped.
    pub transmittance: u16,
    /// Path length inside in units of the table's longest path / 65535 (0 when not stored).
    pub path: u16,
    /// The path's signature ([`super::Sample::path`]).
    pub signature: u16,
}

/// Largest quantisation errors over the table (the paper's Fig. 12 figures).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuantErrors {
    /// Largest exit-position error, as a fraction of the bounding box diagonal.
    pub position: f32,
    /// Largest exit-direction error ‖d − d̂‖ (unit vectors; ≈ the angle in radians).
    pub direction: f32,
    /// Largest transmittance error.
    pub transmittance: f32,
    /// Largest path-length error, metres.
    pub path: f32,
}

/// A baked, quantised light transport table.
#[derive(Clone, Debug)]
pub struct TransportTable {
    pub source_hash: u64,
    pub params: TransportParams,
    /// Bounding box of the object in its rigid frame.
    pub lo: Vec3,
    pub hi: Vec3,
    pub vertex_count: u32,
    /// Path lengths stored (the object absorbs).
    pub absorbing: bool,
    /// Longest path inside (m): the scale of the stored path lengths.
    pub max_path: f32,
    /// vertex-major, `params.directions()` per vertex.
    pub records: Vec<Record>,
    /// Quantisation errors (known only right after a bake; zero for a loaded table).
    pub errors: QuantErrors,
    pub stats: TransportStats,
    /// How well the table predicts fresh photons (`bake::transport::verify`), checked by the
    /// bake and stored with it; `None` for a table nobody checked.
    pub fit: Option<Fit>,
}

impl TransportTable {
    /// Bytes it holds in memory (its records; the rest is a few hundred bytes).
    pub fn heap_bytes(&self) -> usize {
        std::mem::size_of::<TransportTable>() + self.records.len() * std::mem::size_of::<Record>()
    }
}

/// A table's fit against photons traced through the object (`bake::transport::verify`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// Relative L1 of the caustic the table predicts on a plane below the object against the
    /// photons' (3 × 3 blur), the worst of the light directions checked.
    pub error: f32,
    /// Fraction of the light entering the lit triangles that no volume carries because the
    /// triangle's corners leave on different paths and splitting it could not place that
    /// light, the largest of the light directions.
    pub split_loss: f32,
}

fn q16(x: f32) -> u16 {
    (x.clamp(0.0, 1.0) * 65535.0).round() as u16
}

fn dir_angles(d: Vec3) -> [u16; 2] {
    let d = d.normalize_or(Vec3::Z);
    // atan2, not acos: acos of a single-precision z near ±1 loses most of its digits.
    let phi = d.x.hypot(d.y).atan2(d.z);
    let theta = d.y.atan2(d.x).rem_euclid(TAU);
    [
        q16(phi / PI),
        ((theta / TAU * 65536.0).round() as u32 % 65536) as u16,
    ]
}

fn angles_dir([p, t]: [u16; 2]) -> Vec3 {
    let phi = p as f32 / 65535.0 * PI;
    let theta = t as f32 / 65536.0 * TAU;
    Vec3::new(phi.sin() * theta.cos(), phi.sin() * theta.sin(), phi.cos())
}

/// Samples [`TransportTable::quantise_with`] handles between two questions to its
/// `keep_going` (a few milliseconds of work).
pub const QUANTISE_CHUNK: usize = 1 << 16;

impl TransportTable {
    /// Quantise `samples` (vertex-major) into a table.
    pub fn quantise(
        source_hash: u64,
        params: TransportParams,
        bounds: (Vec3, Vec3),
        vertex_count: u32,
        absorbing: bool,
        samples: &[Sample],
    ) -> TransportTable {
        Self::quantise_with(
            source_hash,
            params,
            bounds,
            vertex_count,
            absorbing,
            samples,
            &|| true,
        )
        .expect("never asked to stop")
    }

    /// [`Self::quantise`] that asks `keep_going` every [`QUANTISE_CHUNK`] samples of each
    /// pass over them; Err(Canceled) once it says stop.
    pub fn quantise_with(
        source_hash: u64,
        params: TransportParams,
        (lo, hi): (Vec3, Vec3),
        vertex_count: u32,
        absorbing: bool,
        samples: &[Sample],
        keep_going: &dyn Fn() -> bool,
    ) -> Result<TransportTable, Canceled> {
        let check = || if keep_going() { Ok(()) } else { Err(Canceled) };
        let max_path = if absorbing {
            // Trapped rays' paths (light that never leaves) do not set the scale.
            let mut m = 0.0f32;
            for chunk in samples.chunks(QUANTISE_CHUNK) {
                check()?;
                m = chunk
                    .iter()
                    .filter(|s| !s.trapped)
                    .map(|s| s.path_length)
                    .fold(m, f32::max);
            }
            m
        } else {
            0.0
        };
        let extent = (hi - lo).max(Vec3::splat(1e-12));
        let mut records = Vec::with_capacity(samples.len());
        for chunk in samples.chunks(QUANTISE_CHUNK) {
            check()?;
            records.extend(chunk.iter().map(|s| {
                let rel = (s.position - lo) / extent;
                let t = (s.transmittance.clamp(0.0, 1.0) * T_MAX).round() as u16;
                Record {
                    position: [q16(rel.x), q16(rel.y), q16(rel.z)],
                    direction: dir_angles(s.direction),
                    transmittance: t
                        | if s.occluded { OCCLUDED } else { 0 }
                        | if s.trapped { TRAPPED } else { 0 },
                    path: if max_path > 0.0 {
                        q16(s.path_length / max_path)
                    } else {
                        0
                    },
                    signature: s.path,
                }
            }));
        }
        let mut table = TransportTable {
            source_hash,
            params,
            lo,
            hi,
            vertex_count,
            absorbing,
            max_path,
            records,
            errors: QuantErrors::default(),
            stats: TransportStats::default(),
            fit: None,
        };
        let diag = (hi - lo).length().max(1e-12);
        let mut e = QuantErrors::default();
        for (k, s) in samples.iter().enumerate() {
            if k.is_multiple_of(QUANTISE_CHUNK) {
                check()?;
            }
            let q = table.sample_at(k);
            e.position = e.position.max((q.position - s.position).length() / diag);
            e.direction = e
                .direction
                .max((q.direction - s.direction.normalize_or(Vec3::Z)).length());
            e.transmittance = e
                .transmittance
                .max((q.transmittance - s.transmittance.clamp(0.0, 1.0)).abs());
            if absorbing && !s.trapped {
                e.path = e.path.max((q.path_length - s.path_length).abs());
            }
        }
        table.errors = e;
        check()?;
        table.count_samples();
        Ok(table)
    }

    /// Bytes per stored sample: 14, or 16 with path lengths.
    pub fn bytes_per_sample(&self) -> usize {
        if self.absorbing { 16 } else { 14 }
    }

    /// Bytes the samples would take unquantised (f32 position, direction, transmittance, and
    /// path length when absorbing; flags as a byte).
    pub fn uncompressed_bytes(&self) -> usize {
        self.records.len() * (7 * 4 + if self.absorbing { 4 } else { 0 } + 1)
    }

    /// The decoded sample `j` (a sampling-direction index) of vertex `v`.
    pub fn sample(&self, v: usize, j: usize) -> Sample {
        self.sample_at(v * self.params.directions() + j)
    }

    fn sample_at(&self, k: usize) -> Sample {
        let r = &self.records[k];
        let rel = Vec3::new(
            r.position[0] as f32,
            r.position[1] as f32,
            r.position[2] as f32,
        ) / 65535.0;
        Sample {
            position: self.lo + rel * (self.hi - self.lo),
            direction: angles_dir(r.direction),
            transmittance: (r.transmittance & !(OCCLUDED | TRAPPED)) as f32 / T_MAX,
            path_length: r.path as f32 / 65535.0 * self.max_path,
            occluded: r.transmittance & OCCLUDED != 0,
            trapped: r.transmittance & TRAPPED != 0,
            path: r.signature,
        }
    }

    /// The artifact bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(HEADER + self.records.len() * 16 + 8);
        b.extend_from_slice(&MAGIC);
        for v in [
            VERSION,
            self.vertex_count,
            self.params.rings,
            self.params.azimuths,
            self.params.max_depth,
            self.absorbing as u32,
        ] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&self.source_hash.to_le_bytes());
        b.extend_from_slice(&self.params.hash().to_le_bytes());
        for v in self
            .lo
            .to_array()
            .into_iter()
            .chain(self.hi.to_array())
            .chain([self.max_path])
            .chain(match self.fit {
                Some(f) => [f.error, f.split_loss],
                None => [f32::NAN; 2],
            })
        {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for r in &self.records {
            for v in r.position.into_iter().chain(r.direction) {
                b.extend_from_slice(&v.to_le_bytes());
            }
            b.extend_from_slice(&r.transmittance.to_le_bytes());
            b.extend_from_slice(&r.signature.to_le_bytes());
            if self.absorbing {
                b.extend_from_slice(&r.path.to_le_bytes());
            }
        }
        let sum = Fnv64::hash(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    /// Parse and verify an artifact.
    pub fn from_bytes(bytes: &[u8]) -> Result<TransportTable, TableError> {
        if bytes.len() < 8 || bytes[..8] != MAGIC {
            return Err(TableError::BadMagic);
        }
        if bytes.len() < HEADER + 8 {
            return Err(TableError::Truncated {
                got: bytes.len(),
                expected: HEADER + 8,
            });
        }
        let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4"));
        let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().expect("8"));
        let f32_at = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().expect("4"));
        let version = u32_at(8);
        if version != VERSION {
            return Err(TableError::UnsupportedVersion(version));
        }
        let vertex_count = u32_at(12);
        let params = TransportParams {
            rings: u32_at(16),
            azimuths: u32_at(20),
            max_depth: u32_at(24),
        };
        params
            .validate()
            .map_err(|e| TableError::Invalid(e.to_string()))?;
        let flags = u32_at(28);
        if flags > 1 {
            return Err(TableError::Invalid(format!("unknown flags {flags:#x}")));
        }
        let absorbing = flags & 1 != 0;
        let per = if absorbing { 16 } else { 14 };
        let count = vertex_count as u64 * params.directions() as u64;
        let expected = (HEADER as u64)
            .saturating_add(count.saturating_mul(per))
            .saturating_add(8);
        if bytes.len() as u64 != expected {
            return Err(TableError::Truncated {
                got: bytes.len(),
                expected: usize::try_from(expected).unwrap_or(usize::MAX),
            });
        }
        let body = bytes.len() - 8;
        if Fnv64::hash(&bytes[..body]) != u64_at(body) {
            return Err(TableError::Checksum);
        }
        let source_hash = u64_at(32);
        if u64_at(40) != params.hash() {
            return Err(TableError::Invalid("parameter hash mismatch".into()));
        }
        let v3 = |at: usize| Vec3::new(f32_at(at), f32_at(at + 4), f32_at(at + 8));
        let (lo, hi, max_path) = (v3(48), v3(60), f32_at(72));
        if !(lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()) {
            return Err(TableError::Invalid("bad bounding box".into()));
        }
        if !(max_path.is_finite() && max_path >= 0.0) {
            return Err(TableError::Invalid("bad path length scale".into()));
        }
        let (fit_error, split_loss) = (f32_at(76), f32_at(80));
        let fit = match (fit_error.is_nan(), split_loss.is_nan()) {
            (true, true) => None,
            (false, false) if fit_error >= 0.0 && (0.0..=1.0).contains(&split_loss) => Some(Fit {
                error: fit_error,
                split_loss,
            }),
            _ => return Err(TableError::Invalid("bad fit figures".into())),
        };
        let u16_at = |at: usize| u16::from_le_bytes([bytes[at], bytes[at + 1]]);
        let records: Vec<Record> = (0..count as usize)
            .map(|k| {
                let at = HEADER + k * per as usize;
                Record {
                    position: [u16_at(at), u16_at(at + 2), u16_at(at + 4)],
                    direction: [u16_at(at + 6), u16_at(at + 8)],
                    transmittance: u16_at(at + 10),
                    signature: u16_at(at + 12),
                    path: if absorbing { u16_at(at + 14) } else { 0 },
                }
            })
            .collect();
        let mut table = TransportTable {
            source_hash,
            params,
            lo,
            hi,
            vertex_count,
            absorbing,
            max_path,
            records,
            errors: QuantErrors::default(),
            stats: TransportStats::default(),
            fit,
        };
        table.count_samples();
        Ok(table)
    }

    /// Fill the sample counts of `stats` (vertices, samples, occluded, trapped) from the records.
    fn count_samples(&mut self) {
        let flagged = |bit: u16| {
            self.records
                .iter()
                .filter(|r| r.transmittance & bit != 0)
                .count() as u64
        };
        self.stats.occluded = flagged(OCCLUDED);
        self.stats.trapped = flagged(TRAPPED);
        self.stats.vertices = self.vertex_count as u64;
        self.stats.samples = self.records.len() as u64;
    }
}
