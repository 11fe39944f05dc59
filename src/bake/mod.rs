//! Bakes: deterministic CPU precomputation for the methods that need it, one module per method.
//! A bake knows nothing of wgpu or HTTP; its artifact is a versioned, checksummed byte string
//! whose content depends only on its inputs (scene geometry, object, light, parameters), so
//! that it can be cached by content hash.

pub mod csl;
pub(crate) mod plane;
pub mod store;
pub mod transport;

use thiserror::Error;

/// Why a bake did not produce an artifact.
#[derive(Debug, Error)]
pub enum BakeError {
    #[error("no object named {0:?} in the scene")]
    UnknownObject(String),
    #[error("object {0:?} has no reflective or refractive material: it casts no caustics")]
    NotSpecular(String),
    #[error("object {0:?} has no refractive (dielectric) part: a light transport table needs one")]
    NotRefractive(String),
    #[error("object {0:?} has no triangles")]
    EmptyObject(String),
    #[error("invalid bake parameter: {0}")]
    InvalidParams(String),
    #[error("invalid light direction {0:?}: must be finite and non-zero")]
    InvalidLight([f32; 3]),
    #[error("bake canceled")]
    Canceled,
}

/// Progress of a running bake, reported to the caller's callback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Name of the running stage (e.g. "trace", "bundles").
    pub stage: &'static str,
    /// Overall completion in [0, 1].
    pub fraction: f32,
}

/// 64-bit FNV-1a, used for content hashes and artifact checksums (stable across platforms and
/// releases, unlike `std::hash`).
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Self::new()
    }
}

impl Fnv64 {
    pub const fn new() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }

    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub fn write_u32(&mut self, v: u32) {
        self.write(&v.to_le_bytes());
    }

    pub fn write_f32(&mut self, v: f32) {
        self.write(&v.to_bits().to_le_bytes());
    }

    pub fn finish(&self) -> u64 {
        self.0
    }

    /// Hash of a byte string.
    pub fn hash(bytes: &[u8]) -> u64 {
        let mut h = Self::new();
        h.write(bytes);
        h.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::Fnv64;

    #[test]
    fn fnv64_known_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(Fnv64::hash(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(Fnv64::hash(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(Fnv64::hash(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
