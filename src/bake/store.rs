//! The artifact store: bakes kept between renders by content hash. A bake's artifact depends
//! only on its inputs, so the hash of those inputs (the artifact's `source_hash`) names it:
//! `{dir}/{kind}-{hash:016x}.{ext}`. Every method that bakes finds or makes its artifacts
//! through [`ArtifactStore::find_or_bake`]; the CLI keeps its store in `$CAUSTICA_CACHE` (or a
//! folder under the system's temporary directory), the service under its data directory.

use std::path::PathBuf;

/// What an artifact is: its file name prefix and extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArtifactKind {
    /// A static CSL set (`bake::csl::CslSet`).
    Csl,
    /// A dynamic CSL bake (`bake::csl::dynamic::DynamicSet`).
    CslDynamic,
    /// A light transport table (`bake::transport::TransportTable`).
    Transport,
}

impl ArtifactKind {
    fn prefix(self) -> &'static str {
        match self {
            ArtifactKind::Csl => "csl",
            ArtifactKind::CslDynamic => "csl-dynamic",
            ArtifactKind::Transport => "transport",
        }
    }

    /// The file extension the CLI and the service give this artifact.
    pub fn ext(self) -> &'static str {
        match self {
            ArtifactKind::Csl => "csl",
            ArtifactKind::CslDynamic => "csld",
            ArtifactKind::Transport => "ltt",
        }
    }
}

/// A folder of artifacts by content hash, or nothing (every lookup misses, nothing is kept).
#[derive(Clone, Debug, Default)]
pub struct ArtifactStore {
    dir: Option<PathBuf>,
}

impl ArtifactStore {
    /// A store in `dir` (created on the first save).
    pub fn new(dir: impl Into<PathBuf>) -> ArtifactStore {
        ArtifactStore {
            dir: Some(dir.into()),
        }
    }

    /// A store that keeps nothing: every render bakes.
    pub fn none() -> ArtifactStore {
        ArtifactStore { dir: None }
    }

    /// The CLI's store: `$CAUSTICA_CACHE`, else `caustica-bakes` in the temporary directory.
    pub fn from_env() -> ArtifactStore {
        let dir = std::env::var_os("CAUSTICA_CACHE")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .unwrap_or_else(|| std::env::temp_dir().join("caustica-bakes"));
        ArtifactStore::new(dir)
    }

    /// Where the artifact `kind` of source hash `hash` is kept (None: a store of nothing).
    pub fn path(&self, kind: ArtifactKind, hash: u64) -> Option<PathBuf> {
        let d = self.dir.as_ref()?;
        Some(d.join(format!("{}-{hash:016x}.{}", kind.prefix(), kind.ext())))
    }

    /// The bytes kept for (`kind`, `hash`), if any.
    pub fn load(&self, kind: ArtifactKind, hash: u64) -> Option<Vec<u8>> {
        std::fs::read(self.path(kind, hash)?).ok()
    }

    /// Keeps `bytes` as (`kind`, `hash`): a temporary file, then a rename, so that a reader
    /// never sees half a file. Failing to keep it is logged, not an error: the caller has the
    /// bake in hand, and the next render bakes again.
    pub fn save(&self, kind: ArtifactKind, hash: u64, bytes: &[u8]) {
        let (Some(dir), Some(path)) = (&self.dir, self.path(kind, hash)) else {
            return;
        };
        // Unique per process and call: two renders saving the same artifact never share a file.
        static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = path.with_extension(format!("tmp{}-{n}", std::process::id()));
        let r = std::fs::create_dir_all(dir)
            .and_then(|_| std::fs::write(&tmp, bytes))
            .and_then(|_| std::fs::rename(&tmp, &path));
        if let Err(e) = r {
            let _ = std::fs::remove_file(&tmp);
            tracing::warn!("could not keep the bake in {}: {e}", path.display());
        }
    }

    /// The artifact (`kind`, `hash`): decoded from the store when kept and intact (`decode`
    /// returns None for a damaged file or one of another hash, which is then baked over), else
    /// made by `bake`, kept (as `encode` writes it) and returned. The flag says whether it came
    /// from the store.
    pub fn find_or_bake<T, E>(
        &self,
        kind: ArtifactKind,
        hash: u64,
        decode: impl FnOnce(&[u8]) -> Option<T>,
        bake: impl FnOnce() -> Result<T, E>,
        encode: impl FnOnce(&T) -> Vec<u8>,
    ) -> Result<(T, bool), E> {
        if let Some(t) = self.load(kind, hash).and_then(|b| decode(&b)) {
            return Ok((t, true));
        }
        let t = bake()?;
        if self.dir.is_some() {
            self.save(kind, hash, &encode(&t));
        }
        Ok((t, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_what_it_kept_and_bakes_over_damage() {
        let dir = std::env::temp_dir().join(format!("caustica-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = ArtifactStore::new(&dir);
        let decode = |b: &[u8]| (b.first() == Some(&7)).then(|| b.to_vec());
        let bake = |v: u8| move || Ok::<_, ()>(vec![v, 1, 2]);
        let enc = |t: &Vec<u8>| t.clone();
        let k = ArtifactKind::Transport;
        assert_eq!(
            store.find_or_bake(k, 9, decode, bake(7), enc),
            Ok((vec![7, 1, 2], false))
        );
        assert_eq!(
            store.find_or_bake(k, 9, decode, bake(8), enc),
            Ok((vec![7, 1, 2], true))
        );
        // Another kind or hash is another file.
        assert!(
            !store
                .find_or_bake(ArtifactKind::Csl, 9, decode, bake(7), enc)
                .unwrap()
                .1
        );
        assert!(!store.find_or_bake(k, 10, decode, bake(7), enc).unwrap().1);
        // A damaged file is baked over.
        std::fs::write(store.path(k, 9).unwrap(), b"junk").unwrap();
        assert_eq!(
            store.find_or_bake(k, 9, decode, bake(7), enc),
            Ok((vec![7, 1, 2], false))
        );
        assert!(store.find_or_bake(k, 9, decode, bake(7), enc).unwrap().1);
        // A store of nothing keeps nothing.
        let none = ArtifactStore::none();
        none.save(k, 9, b"x");
        assert!(!none.find_or_bake(k, 9, decode, bake(7), enc).unwrap().1);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
