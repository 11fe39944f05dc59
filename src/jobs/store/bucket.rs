//! Artifacts in S3-compatible object storage (`--artifacts s3://BUCKET/PREFIX`): every job's
//! artifact under `PREFIX/artifacts/` and the bakes renders find under `PREFIX/bakes/`, with
//! the data directory as a local cache of them. A PUT makes an object appear whole, and a
//! bake's key is its content hash, so two workers finishing one bake converge on one object.
//! Endpoint and credentials come from the usual `AWS_*` variables (`AWS_ENDPOINT`,
//! `AWS_ACCESS_KEY_ID`, `AWS_SECRET_ACCESS_KEY`, `AWS_DEFAULT_REGION`, `AWS_ALLOW_HTTP`).
//!
//! The client is asynchronous and the store's callers are not (workers are threads, and the
//! HTTP handlers call the store without awaiting it): each call runs on a runtime of the
//! bucket's own and its answer is waited for on a channel, which works from any thread.

use object_store::path::Path as ObjectPath;
use object_store::{ObjectStore, ObjectStoreExt};
use std::sync::Arc;

pub struct Bucket {
    url: String,
    store: Arc<dyn ObjectStore>,
    prefix: String,
    /// Taken when dropped: a runtime dropped on a thread that drives async tasks panics, so
    /// it is shut down in the background instead.
    rt: Option<tokio::runtime::Runtime>,
}

impl std::fmt::Debug for Bucket {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bucket").field("url", &self.url).finish()
    }
}

impl Drop for Bucket {
    fn drop(&mut self) {
        if let Some(rt) = self.rt.take() {
            rt.shutdown_background();
        }
    }
}

impl Bucket {
    /// The bucket at `url` (`s3://BUCKET` or `s3://BUCKET/PREFIX`).
    pub fn open(url: &str) -> Result<Bucket, String> {
        let rest = url
            .strip_prefix("s3://")
            .ok_or_else(|| format!("artifact location {url:?}: not an s3:// URL"))?;
        let (bucket, prefix) = rest.split_once('/').unwrap_or((rest, ""));
        if bucket.is_empty() {
            return Err(format!("artifact location {url:?}: no bucket"));
        }
        let store = object_store::aws::AmazonS3Builder::from_env()
            .with_bucket_name(bucket)
            .build()
            .map_err(|e| format!("artifact location {url}: {e}"))?;
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("caustica-s3")
            .enable_all()
            .build()
            .map_err(|e| e.to_string())?;
        Ok(Bucket {
            url: url.to_string(),
            store: Arc::new(store),
            prefix: prefix.trim_matches('/').to_string(),
            rt: Some(rt),
        })
    }

    fn path(&self, key: &str) -> ObjectPath {
        if self.prefix.is_empty() {
            ObjectPath::from(key)
        } else {
            ObjectPath::from(format!("{}/{key}", self.prefix))
        }
    }

    /// Runs `f` on the bucket's runtime and waits for it (from any thread).
    fn run<T: Send + 'static>(
        &self,
        f: impl std::future::Future<Output = Result<T, object_store::Error>> + Send + 'static,
    ) -> Result<T, object_store::Error> {
        let (tx, rx) = std::sync::mpsc::sync_channel(1);
        if let Some(rt) = &self.rt {
            rt.spawn(async move {
                let _ = tx.send(f.await);
            });
        }
        rx.recv().unwrap_or_else(|_| {
            Err(object_store::Error::Generic {
                store: "S3",
                source: "the bucket's runtime stopped".into(),
            })
        })
    }

    /// Stores `bytes` as `key` (whole or not at all).
    pub fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String> {
        let (s, p, b) = (self.store.clone(), self.path(key), bytes.to_vec());
        self.run(async move { s.put(&p, b.into()).await.map(|_| ()) })
            .map_err(|e| format!("{}: put {key}: {e}", self.url))
    }

    /// The bytes of `key`, or None when there is no such object.
    pub fn get(&self, key: &str) -> Result<Option<Vec<u8>>, String> {
        let (s, p) = (self.store.clone(), self.path(key));
        match self.run(async move { s.get(&p).await?.bytes().await }) {
            Ok(b) => Ok(Some(b.to_vec())),
            Err(object_store::Error::NotFound { .. }) => Ok(None),
            Err(e) => Err(format!("{}: get {key}: {e}", self.url)),
        }
    }

    /// Deletes `key` (no error when it is not there).
    pub fn delete(&self, key: &str) -> Result<(), String> {
        let (s, p) = (self.store.clone(), self.path(key));
        match self.run(async move { s.delete(&p).await }) {
            Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
            Err(e) => Err(format!("{}: delete {key}: {e}", self.url)),
        }
    }
}

impl crate::bake::store::Remote for Bucket {
    fn put(&self, key: &str, bytes: &[u8]) -> Result<(), String> {
        Bucket::put(self, key, bytes)
    }
    fn get(&self, key: &str) -> Result<Option<Vec<u8>>, String> {
        Bucket::get(self, key)
    }
}
