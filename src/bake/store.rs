//! The artifact store: bakes kept between renders by content hash. A bake's artifact depends
//! only on its inputs, so the hash of those inputs (the artifact's `source_hash`) names it:
//! `{dir}/{kind}-{hash:016x}.{ext}`. Every method that bakes finds or makes its artifacts
//! through [`ArtifactStore::find_or_bake`]; the CLI keeps its store in `$CAUSTICA_CACHE` (or a
//! folder under the system's temporary directory), the service under its data directory.
//!
//! What a store decodes it also keeps in memory ([`DECODED_BUDGET`] bytes of decoded artifacts,
//! by each one's own count of its heap; the least recently used dropped past it), so that a render on a bake it has seen does not read and
//! check the file again: artifacts are named by the hash of their inputs, so a kept one is never
//! stale. Clones of a store share what it keeps.

use std::any::Any;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Bytes of decoded artifacts (their heap, as each counts it) a store keeps in memory.
pub const DECODED_BUDGET: usize = 512 << 20;

/// What an artifact is: its file name prefix and extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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
    decoded: Arc<Mutex<Decoded>>,
    /// Object storage the folder caches ([`Self::with_remote`]).
    remote: Option<Arc<dyn Remote>>,
}

/// A decoded artifact, its decoded bytes and when it was last used.
type Kept = (Arc<dyn Any + Send + Sync>, usize, u64);

/// Decoded artifacts by (kind, hash); the least recently used go past the budget.
#[derive(Default)]
struct Decoded {
    budget: usize,
    used: usize,
    tick: u64,
    map: HashMap<(ArtifactKind, u64), Kept>,
}

impl std::fmt::Debug for Decoded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} decoded artifacts, {} of {} bytes",
            self.map.len(),
            self.used,
            self.budget
        )
    }
}

impl Decoded {
    fn get<T: Any + Send + Sync>(&mut self, key: (ArtifactKind, u64)) -> Option<Arc<T>> {
        self.tick += 1;
        let tick = self.tick;
        let e = self.map.get_mut(&key)?;
        e.2 = tick;
        e.0.clone().downcast::<T>().ok()
    }

    fn put(&mut self, key: (ArtifactKind, u64), value: Arc<dyn Any + Send + Sync>, bytes: usize) {
        if bytes > self.budget {
            return;
        }
        if let Some(old) = self.map.remove(&key) {
            self.used -= old.1;
        }
        while self.used + bytes > self.budget {
            let Some(oldest) = self.map.iter().min_by_key(|(_, e)| e.2).map(|(k, _)| *k) else {
                break;
            };
            let e = self.map.remove(&oldest).expect("just found");
            self.used -= e.1;
        }
        self.tick += 1;
        self.map.insert(key, (value, bytes, self.tick));
        self.used += bytes;
    }
}

/// Object storage shared by several processes (a bucket): what [`ArtifactStore`] keeps is also
/// put there, and what it lacks locally is looked for there.
pub trait Remote: Send + Sync + std::fmt::Debug {
    fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String>;
    /// None when there is no such object.
    fn get(&self, key: &str) -> Result<Option<Vec<u8>>, String>;
}

impl ArtifactStore {
    /// The same store, also keeping its artifacts in `remote` under `bakes/` (its folder the
    /// local cache of them).
    pub fn with_remote(mut self, remote: Arc<dyn Remote>) -> ArtifactStore {
        self.remote = Some(remote);
        self
    }

    /// The key of (`kind`, `hash`) in the remote store.
    fn remote_key(kind: ArtifactKind, hash: u64) -> String {
        format!("bakes/{}-{hash:016x}.{}", kind.prefix(), kind.ext())
    }

    /// A store in `dir` (created on the first save), keeping up to [`DECODED_BUDGET`] of what it
    /// decodes in memory.
    pub fn new(dir: impl Into<PathBuf>) -> ArtifactStore {
        ArtifactStore::with_budget(dir, DECODED_BUDGET)
    }

    /// A store in `dir` keeping up to `bytes` of artifacts decoded in memory.
    pub fn with_budget(dir: impl Into<PathBuf>, bytes: usize) -> ArtifactStore {
        ArtifactStore {
            dir: Some(dir.into()),
            decoded: Arc::new(Mutex::new(Decoded {
                budget: bytes,
                ..Decoded::default()
            })),
            remote: None,
        }
    }

    /// A store that keeps nothing: every render bakes.
    pub fn none() -> ArtifactStore {
        ArtifactStore::default()
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

    /// The bytes kept for (`kind`, `hash`), if any: from the folder, else from the remote store
    /// (then kept in the folder too).
    pub fn load(&self, kind: ArtifactKind, hash: u64) -> Option<Vec<u8>> {
        if let Ok(b) = std::fs::read(self.path(kind, hash)?) {
            return Some(b);
        }
        let remote = self.remote.as_ref()?;
        match remote.get(&Self::remote_key(kind, hash)) {
            Ok(Some(b)) => {
                self.save_local(kind, hash, &b);
                Some(b)
            }
            Ok(None) => None,
            Err(e) => {
                tracing::warn!(error = %e, "cannot read a bake from the object store");
                None
            }
        }
    }

    /// Keeps `bytes` as (`kind`, `hash`): a temporary file, then a rename, so that a reader
    /// never sees half a file. Failing to keep it is logged, not an error: the caller has the
    /// bake in hand, and the next render bakes again.
    pub fn save(&self, kind: ArtifactKind, hash: u64, bytes: &[u8]) {
        self.save_local(kind, hash, bytes);
        if let Some(remote) = &self.remote
            && let Err(e) = remote.put(&Self::remote_key(kind, hash), bytes)
        {
            tracing::warn!(error = %e, "could not keep the bake in the object store");
        }
    }

    fn save_local(&self, kind: ArtifactKind, hash: u64, bytes: &[u8]) {
        let (Some(dir), Some(path)) = (&self.dir, self.path(kind, hash)) else {
            return;
        };
        // Unique per host, process and call: two renders saving the same artifact never share
        // a file, nor do two workers on a shared volume (in containers, process ids repeat).
        static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = path.with_extension(format!(
            "tmp{}-{}-{n}",
            crate::jobs::store::host_tag(),
            std::process::id()
        ));
        let r = std::fs::create_dir_all(dir)
            .and_then(|_| std::fs::write(&tmp, bytes))
            .and_then(|_| std::fs::rename(&tmp, &path));
        if let Err(e) = r {
            let _ = std::fs::remove_file(&tmp);
            tracing::warn!("could not keep the bake in {}: {e}", path.display());
        }
    }

    /// The artifact (`kind`, `hash`) if it is kept and intact (decoded as by
    /// [`Self::find_or_bake`]); never bakes.
    pub fn find<T: Any + Send + Sync>(
        &self,
        kind: ArtifactKind,
        hash: u64,
        decode: impl FnOnce(&[u8]) -> Option<T>,
        size: impl Fn(&T) -> usize,
    ) -> Option<Arc<T>> {
        self.find_or_bake(kind, hash, decode, || Err(()), |_| Vec::new(), size)
            .ok()
            .map(|(t, _)| t)
    }

    /// The artifact (`kind`, `hash`): decoded from the store when kept and intact (`decode`
    /// returns None for a damaged file or one of another hash, which is then baked over), else
    /// made by `bake`, kept (as `encode` writes it) and returned. The flag says whether it came
    /// from the store. What is decoded or baked is also kept in memory, where the next call
    /// finds it without reading the file (a store of nothing keeps nothing there either),
    /// counted by `size` (its bytes in memory) against the store's budget.
    pub fn find_or_bake<T: Any + Send + Sync, E>(
        &self,
        kind: ArtifactKind,
        hash: u64,
        decode: impl FnOnce(&[u8]) -> Option<T>,
        bake: impl FnOnce() -> Result<T, E>,
        encode: impl FnOnce(&T) -> Vec<u8>,
        size: impl Fn(&T) -> usize,
    ) -> Result<(Arc<T>, bool), E> {
        let key = (kind, hash);
        let decoded = || self.decoded.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = decoded().get::<T>(key) {
            return Ok((t, true));
        }
        if let Some(b) = self.load(kind, hash)
            && let Some(t) = decode(&b)
        {
            let t = Arc::new(t);
            decoded().put(key, t.clone(), size(&t));
            return Ok((t, true));
        }
        let t = Arc::new(bake()?);
        if self.dir.is_some() {
            let bytes = encode(&t);
            self.save(kind, hash, &bytes);
            decoded().put(key, t.clone(), size(&t));
        }
        Ok((t, false))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Object storage in memory.
    #[derive(Debug, Default)]
    struct Memory(Mutex<std::collections::HashMap<String, Vec<u8>>>);

    impl Remote for Memory {
        fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String> {
            self.0.lock().unwrap().insert(key.into(), bytes.to_vec());
            Ok(())
        }
        fn get(&self, key: &str) -> Result<Option<Vec<u8>>, String> {
            Ok(self.0.lock().unwrap().get(key).cloned())
        }
    }

    /// Two processes with folders of their own and one bucket: what one bakes, the other finds
    /// without baking, and keeps in its folder.
    #[test]
    fn a_store_finds_what_another_kept_in_the_shared_remote() {
        let root = std::env::temp_dir().join(format!("caustica-remote-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let remote: Arc<dyn Remote> = Arc::new(Memory::default());
        let a = ArtifactStore::new(root.join("a")).with_remote(remote.clone());
        let b = ArtifactStore::new(root.join("b")).with_remote(remote);
        let k = ArtifactKind::Csl;
        let (v, cached) = a
            .find_or_bake(
                k,
                7,
                |b| Some(b.to_vec()),
                || Ok::<_, ()>(b"set".to_vec()),
                |t| t.clone(),
                Vec::len,
            )
            .unwrap();
        assert!(!cached);
        assert_eq!(*v, b"set");
        let (v, cached) = b
            .find_or_bake(
                k,
                7,
                |b| Some(b.to_vec()),
                || Err(()),
                |t: &Vec<u8>| t.clone(),
                Vec::len,
            )
            .unwrap();
        assert!(cached, "found in the remote, not baked");
        assert_eq!(*v, b"set");
        assert!(b.path(k, 7).unwrap().exists(), "kept in b's folder too");
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn finds_what_it_kept_and_bakes_over_damage() {
        let dir = std::env::temp_dir().join(format!("caustica-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = ArtifactStore::new(&dir);
        let decode = |b: &[u8]| (b.first() == Some(&7)).then(|| b.to_vec());
        let bake = |v: u8| move || Ok::<_, ()>(vec![v, 1, 2]);
        let enc = |t: &Vec<u8>| t.clone();
        let k = ArtifactKind::Transport;
        let got = |r: Result<(Arc<Vec<u8>>, bool), ()>| r.map(|(t, c)| ((*t).clone(), c));
        assert_eq!(
            got(store.find_or_bake(k, 9, decode, bake(7), enc, Vec::len)),
            Ok((vec![7, 1, 2], false))
        );
        // Found in memory: the file is not read (nor decoded) again.
        let unread = |_: &[u8]| -> Option<Vec<u8>> { panic!("decoded again") };
        assert_eq!(
            got(store.find_or_bake(k, 9, unread, bake(8), enc, Vec::len)),
            Ok((vec![7, 1, 2], true))
        );
        // A second store of the folder finds it on disk.
        let store = ArtifactStore::new(&dir);
        assert_eq!(
            got(store.find_or_bake(k, 9, decode, bake(8), enc, Vec::len)),
            Ok((vec![7, 1, 2], true))
        );
        // Another kind or hash is another file.
        assert!(
            !store
                .find_or_bake(ArtifactKind::Csl, 9, decode, bake(7), enc, Vec::len)
                .unwrap()
                .1
        );
        assert!(
            !store
                .find_or_bake(k, 10, decode, bake(7), enc, Vec::len)
                .unwrap()
                .1
        );
        // A damaged file is baked over (by a store that has not decoded it).
        std::fs::write(store.path(k, 9).unwrap(), b"junk").unwrap();
        let store = ArtifactStore::new(&dir);
        assert_eq!(
            got(store.find_or_bake(k, 9, decode, bake(7), enc, Vec::len)),
            Ok((vec![7, 1, 2], false))
        );
        assert!(
            store
                .find_or_bake(k, 9, decode, bake(7), enc, Vec::len)
                .unwrap()
                .1
        );
        // A store of nothing keeps nothing.
        let none = ArtifactStore::none();
        none.save(k, 9, b"x");
        assert!(
            !none
                .find_or_bake(k, 9, decode, bake(7), enc, Vec::len)
                .unwrap()
                .1
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// What is kept decoded stays within the budget of artifact bytes, the least recently used
    /// going first.
    #[test]
    fn decoded_artifacts_stay_within_their_budget() {
        let dir = std::env::temp_dir().join(format!("caustica-lru-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = ArtifactStore::with_budget(&dir, 250);
        let k = ArtifactKind::Csl;
        let bake = |h: u64| move || Ok::<_, ()>(vec![h as u8; 100]);
        let decode = |b: &[u8]| Some(b.to_vec());
        let enc = |t: &Vec<u8>| t.clone();
        for h in [1, 2] {
            store
                .find_or_bake(k, h, decode, bake(h), enc, Vec::len)
                .unwrap();
        }
        // 1 used last: 2 goes when 3 comes.
        store
            .find_or_bake(k, 1, decode, bake(1), enc, Vec::len)
            .unwrap();
        store
            .find_or_bake(k, 3, decode, bake(3), enc, Vec::len)
            .unwrap();
        let kept = |h: u64| store.decoded.lock().unwrap().map.contains_key(&(k, h));
        assert!(kept(1) && !kept(2) && kept(3));
        assert_eq!(store.decoded.lock().unwrap().used, 200);
        // Past the budget alone: not kept, still served from the file.
        let big = || Ok::<_, ()>(vec![9u8; 300]);
        store
            .find_or_bake(k, 4, decode, big, enc, Vec::len)
            .unwrap();
        assert!(!kept(4));
        let (t, cached) = store
            .find_or_bake(k, 4, decode, big, enc, Vec::len)
            .unwrap();
        assert!(cached && t.len() == 300);
        // Counted by what it holds decoded, not by its file: 100 bytes that decode to ten
        // times as many are past the budget.
        let tenfold = |t: &Vec<u8>| t.len() * 10;
        store
            .find_or_bake(k, 5, decode, bake(5), enc, tenfold)
            .unwrap();
        assert!(!kept(5));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
