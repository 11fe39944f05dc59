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

/// `compute()`, remembered for as long as every mesh of `meshes` lives and `extra` (a hash of
/// whatever else `compute` reads) is the same: content hashes of large meshes computed once
/// for renders of one stored scene (the service keeps each scene's world, its meshes shared)
/// instead of at every bake look-up (1.9 ms for the canonical 131k-triangle sphere). Sound
/// because a mesh behind an `Arc` that has a `Weak` to it cannot change: `Arc::get_mut`
/// refuses, `Arc::make_mut` moves it to a new allocation, and the `Weak` keeps the old address
/// from being reused.
pub fn memo_by_meshes(
    meshes: &[&std::sync::Arc<crate::scene::Mesh>],
    extra: u64,
    compute: impl FnOnce() -> u64,
) -> u64 {
    use crate::scene::Mesh;
    use std::sync::{Arc, Mutex, Weak};
    type Entry = (Vec<Weak<Mesh>>, u64, u64);
    /// Entries kept at most (the oldest forgotten first).
    const KEEP: usize = 64;
    static MEMO: Mutex<Vec<Entry>> = Mutex::new(Vec::new());
    let same = |e: &Entry| {
        e.1 == extra
            && e.0.len() == meshes.len()
            && e.0
                .iter()
                .zip(meshes)
                .all(|(w, m)| w.as_ptr() == Arc::as_ptr(m) && w.strong_count() > 0)
    };
    let memo = || MEMO.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(e) = memo().iter().find(|e| same(e)) {
        return e.2;
    }
    let h = compute();
    let mut memo = memo();
    memo.retain(|e| e.0.iter().all(|w| w.strong_count() > 0));
    if !memo.iter().any(same) {
        if memo.len() >= KEEP {
            memo.remove(0);
        }
        memo.push((meshes.iter().map(|m| Arc::downgrade(m)).collect(), extra, h));
    }
    h
}

#[cfg(test)]
mod tests {
    use super::Fnv64;

    /// A remembered value serves the same meshes and extra; other meshes (even of the same
    /// content), another extra, and a mesh changed through `Arc::make_mut` after it was
    /// remembered compute again.
    #[test]
    fn memo_by_meshes_serves_only_the_same_live_meshes() {
        use crate::scene::shapes;
        use std::cell::Cell;
        use std::sync::Arc;
        let calls = Cell::new(0);
        let hash = |m: &Arc<crate::scene::Mesh>, extra: u64| {
            super::memo_by_meshes(&[m], extra, || {
                calls.set(calls.get() + 1);
                m.positions.len() as u64 * 1000 + m.indices[0][0] as u64 + extra
            })
        };
        let a = Arc::new(shapes::sphere(0.5, 16));
        let first = hash(&a, 7);
        assert_eq!((hash(&a, 7), calls.get()), (first, 1), "remembered");
        assert_eq!(hash(&a, 8), first + 1, "another extra");
        assert_eq!(calls.get(), 2);
        let copy = Arc::new((*a).clone());
        hash(&copy, 7);
        assert_eq!(calls.get(), 3, "another mesh is computed");
        let mut b = a.clone();
        drop(a);
        Arc::make_mut(&mut b).indices[0][0] = 5;
        let want = b.positions.len() as u64 * 1000 + 5 + 7;
        assert_eq!(
            hash(&b, 7),
            want,
            "a mesh changed in place is computed again"
        );
        assert_eq!(calls.get(), 4);
    }

    #[test]
    fn fnv64_known_values() {
        // Published FNV-1a 64 test vectors.
        assert_eq!(Fnv64::hash(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(Fnv64::hash(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(Fnv64::hash(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
