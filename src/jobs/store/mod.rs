//! Persistence: scenes, job records and artifacts.
//!
//! Records live in a database behind one interface, [`JobDb`], with two back-ends: SQLite
//! ([`sqlite`], the embedded default: one file under the data directory, one process) and
//! PostgreSQL ([`postgres`]: shared by API and worker processes, `--database postgres://…`).
//! Both pass one test suite (the integration tests' `store_suite`). Artifacts are files under
//! `artifacts/` in the data directory (a local folder, or a volume the processes share),
//! written atomically (a temporary file of the writer's own, fsync, rename, fsync of the
//! directory) before the record that points at them is marked succeeded, so a record never
//! names a half-written file; a bake's name is its content hash, so two workers that finish
//! the same bake converge on one file.
//!
//! Workers take jobs by **claiming** them ([`JobDb::claim`]): the record turns `running`
//! under the worker's id with a lease that the worker's heartbeat ([`JobDb::heartbeat`])
//! extends; a job whose lease ran out (its worker died) goes back to the queue
//! ([`JobDb::reap_expired`]) until it has been taken [`MAX_ATTEMPTS`] times. A worker's
//! state changes are conditional on still holding the job, so a late worker cannot overwrite
//! a newer state.

pub mod bucket;
pub mod postgres;
pub mod sqlite;

use super::job::{ErrorCode, JobKind, JobSpec, JobState, Priority};
use crate::methods::{Lane, Method};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("database: {0}")]
    Db(#[from] rusqlite::Error),
    #[error("database: {}", pg_detail(.0))]
    Pg(#[from] ::postgres::Error),
    /// The database cannot be reached (after the retries a call makes).
    #[error("database unavailable: {0}")]
    Unavailable(String),
    #[error("file system: {0}")]
    Io(#[from] std::io::Error),
    #[error("corrupt record: {0}")]
    Corrupt(String),
    /// A stored artifact is missing, a link, or not the bytes that were written.
    #[error("artifact failed its check: {0}")]
    Integrity(String),
}

/// How long a hold without a job record counts against its key's quota: its job is being
/// submitted (a hold left by a crash between the two stops counting after it).
pub const SUBMITTING_MS: i64 = 10 * 60 * 1000;

/// Which jobs [`JobDb::list_jobs`] returns.
#[derive(Clone, Debug)]
pub struct JobFilter {
    pub kind: JobKind,
    /// Only jobs this key holds; `None`: every job.
    pub owner: Option<String>,
    pub state: Option<JobState>,
    pub method: Option<Method>,
    /// Created at or after (ms since the epoch).
    pub created_since: Option<i64>,
    /// Only jobs with a lower sequence number (the cursor of the previous page).
    pub before_seq: Option<i64>,
    pub limit: usize,
}

/// A value a [`JobFilter`] condition compares with.
pub(super) enum FilterArg {
    Text(String),
    Int(i64),
}

impl JobFilter {
    /// The optional conditions (state, method, time, cursor) that are set, as a column with
    /// its operator and the value: what both back-ends add to their lists' `WHERE`.
    pub(super) fn conditions(&self) -> Vec<(&'static str, FilterArg)> {
        let text = |s: &str| FilterArg::Text(s.to_string());
        [
            self.state.map(|s| ("state =", text(s.as_str()))),
            self.method.map(|m| ("method =", text(m.name()))),
            self.created_since
                .map(|t| ("created_at >=", FilterArg::Int(t))),
            self.before_seq.map(|b| ("seq <", FilterArg::Int(b))),
        ]
        .into_iter()
        .flatten()
        .collect()
    }
}

/// Waits in `block_in_place` when on a worker thread of a multi-threaded runtime (its other
/// tasks move on), directly otherwise.
pub(super) fn wait_outside_runtime<T>(f: impl FnOnce() -> T) -> T {
    match tokio::runtime::Handle::try_current() {
        Ok(h) if h.runtime_flavor() == tokio::runtime::RuntimeFlavor::MultiThread => {
            tokio::task::block_in_place(f)
        }
        _ => f(),
    }
}

/// What a hold is on: a scene or a job.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Held {
    Scene,
    Job,
}

impl Held {
    pub(super) fn as_str(self) -> &'static str {
        match self {
            Held::Scene => "scene",
            Held::Job => "job",
        }
    }
}

/// An artifact as written: its file name under `artifacts/`, length and SHA-256 (hex).
#[derive(Clone, Debug, PartialEq)]
pub struct StoredArtifact {
    pub name: String,
    pub len: u64,
    pub sha256: String,
}

/// A stored scene: canonical JSON and the files it names.
#[derive(Clone, Debug)]
pub struct StoredScene {
    pub id: String,
    pub scene_json: Vec<u8>,
    pub files: Vec<(String, Vec<u8>)>,
    pub created_at: i64,
}

/// A job record, as persisted.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobRecord {
    pub id: String,
    pub kind: JobKind,
    pub method: Method,
    pub scene_id: String,
    pub object: Option<String>,
    pub params: serde_json::Value,
    pub state: JobState,
    pub progress: f32,
    pub stage: String,
    /// Stage name and milliseconds, in order.
    pub timings: Vec<(String, f64)>,
    /// Adapter, statistics and whatever else the job reports.
    pub info: serde_json::Value,
    pub error: Option<String>,
    pub artifact_type: Option<String>,
    pub artifact_path: Option<String>,
    /// Length and SHA-256 of the artifact as written (absent for records older than the
    /// check).
    pub artifact_len: Option<u64>,
    pub artifact_sha256: Option<String>,
    pub created_at: i64,
    pub started_at: Option<i64>,
    pub finished_at: Option<i64>,
    /// Where it runs: the lane and the priority within it (what workers claim by).
    #[serde(default = "default_lane")]
    pub lane: Lane,
    #[serde(default = "default_priority")]
    pub priority: Priority,
    /// The worker that holds it while it runs (its lease), if any.
    #[serde(default)]
    pub worker: Option<String>,
    /// How many times a worker has taken it.
    #[serde(default)]
    pub attempts: u32,
}

fn default_lane() -> Lane {
    Lane::Cpu
}

fn default_priority() -> Priority {
    Priority::Bake
}

impl JobRecord {
    /// A new, queued job's record.
    pub fn new(id: &str, spec: &JobSpec, lane: Lane, priority: Priority) -> JobRecord {
        JobRecord {
            id: id.into(),
            kind: spec.kind,
            method: spec.method,
            scene_id: spec.scene_id.clone(),
            object: spec.object.clone(),
            params: spec.params.clone(),
            state: JobState::Queued,
            progress: 0.0,
            stage: String::new(),
            timings: vec![],
            info: serde_json::json!({}),
            error: None,
            artifact_type: None,
            artifact_path: None,
            artifact_len: None,
            artifact_sha256: None,
            created_at: now_ms(),
            started_at: None,
            finished_at: None,
            lane,
            priority,
            worker: None,
            attempts: 0,
        }
    }

    /// The spec the job was submitted with (to rebuild it after a restart).
    pub fn spec(&self) -> JobSpec {
        JobSpec {
            kind: self.kind,
            method: self.method,
            scene_id: self.scene_id.clone(),
            object: self.object.clone(),
            params: self.params.clone(),
        }
    }

    /// The kind of failure of a failed job, as its worker recorded it.
    pub fn error_code(&self) -> Option<ErrorCode> {
        serde_json::from_value(self.info.get("error_code")?.clone()).ok()
    }
}

/// The records of a list's rows that read back, with their sequence numbers; each one that does
/// not is logged and left out (a list never fails on one corrupt record).
fn readable<E: std::fmt::Display>(
    rows: impl IntoIterator<Item = (i64, Result<JobRecord, E>)>,
) -> Vec<(i64, JobRecord)> {
    rows.into_iter()
        .filter_map(|(seq, rec)| {
            rec.map_err(
                |e| tracing::error!(seq, error = %e, "unreadable job record left out of a list"),
            )
            .ok()
            .map(|rec| (seq, rec))
        })
        .collect()
}

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}

/// How many times a job is taken by a worker before a lease running out fails it (a job that
/// kills its worker every time must not take the cluster down one worker after another).
pub const MAX_ATTEMPTS: u32 = 3;

/// What [`JobDb::reap_expired`] did with jobs whose worker's lease ran out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reaped {
    /// Back in the queue.
    pub requeued: Vec<String>,
    /// Failed: taken [`MAX_ATTEMPTS`] times.
    pub failed: Vec<String>,
}

/// What a process learns from the database about jobs other processes change.
#[derive(Clone, Debug, PartialEq)]
pub enum StoreEvent {
    /// Job `id` changed state or progress.
    Job(String),
    /// Job `id`'s cancellation was asked for (its worker stops it).
    Cancel(String),
    /// A job was queued in this lane.
    Queued(Lane),
    /// The connection that listens was lost and made again: changes in between were missed.
    Reconnected,
}

/// The records: scenes, jobs, holds, idempotency keys. Every method is one short transaction;
/// all of them may be called from any thread (they block it briefly).
pub trait JobDb: Send + Sync {
    /// Which back-end, for logs and `/readyz`.
    fn backend(&self) -> &'static str;
    /// Whether the database answers now (`/readyz`); an embedded one always does.
    fn reachable(&self) -> Result<(), StoreError> {
        Ok(())
    }
    /// Stores a scene unless one with this id exists (ids are content hashes).
    /// `owner` holds the scene from the same transaction on, so that no sweep of unheld scenes
    /// can take it in between.
    fn put_scene(
        &self,
        id: &str,
        scene_json: &[u8],
        files: &[(String, Vec<u8>)],
        owner: &str,
    ) -> Result<(), StoreError>;
    /// Whether scene `id` is stored (without reading it).
    fn scene_exists(&self, id: &str) -> Result<bool, StoreError>;
    fn get_scene(&self, id: &str) -> Result<Option<StoredScene>, StoreError>;
    /// Inserts a new job record (queued).
    fn insert_job(&self, r: &JobRecord) -> Result<(), StoreError>;
    /// Puts a finished (failed or canceled) job back in the queue (its attempts start again).
    fn requeue(&self, id: &str) -> Result<(), StoreError>;
    fn get_job(&self, id: &str) -> Result<Option<JobRecord>, StoreError>;
    /// One page of jobs, newest first: those of `f.kind` that `f.owner` holds (every one when
    /// `None`: an admin), filtered, with sequence numbers below `f.before_seq`; each with its
    /// sequence number (the next page's cursor). A record that cannot be read is left out
    /// (logged).
    fn list_jobs(&self, f: &JobFilter) -> Result<Vec<(i64, JobRecord)>, StoreError>;
    /// One page of scenes, newest first: those `owner` holds (every one when `None`),
    /// created at or after `created_since`, stored before row `before` (the cursor); each as
    /// (row, id, name, created_at).
    fn list_scenes(
        &self,
        owner: Option<&str>,
        created_since: Option<i64>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<(i64, String, String, i64)>, StoreError>;
    /// Jobs left queued or running, oldest first (the embedded server re-queues them at
    /// start). A record that cannot be read is quarantined: marked failed with the reason,
    /// logged, and left out, so that one bad row does not stop the server.
    fn unfinished_jobs(&self) -> Result<Vec<JobRecord>, StoreError>;
    /// Queued job `id` starts running under `worker` with a lease of `lease_ms`; false (and
    /// nothing changed) when it is not queued.
    fn set_running(&self, id: &str, worker: &str, lease_ms: i64) -> Result<bool, StoreError>;
    /// Claims a queued job in `lane` of priority at most `up_to` for `worker`, with a lease of
    /// `lease_ms`: the highest priority (lowest number) first, then the job whose key (its
    /// first holder) has the fewest jobs running, then the oldest. It turns running under the
    /// worker's id, its attempts counted. Two workers never claim the same job.
    fn claim(
        &self,
        lane: Lane,
        up_to: Priority,
        worker: &str,
        lease_ms: i64,
    ) -> Result<Option<JobRecord>, StoreError>;
    /// Extends to `lease_ms` from now the leases `worker` holds on the jobs `running` (those it
    /// really runs: a job the store says it holds but it does not run, say a claim whose
    /// answer was lost with the connection, is left to run out); the ids of those whose
    /// cancellation was asked for.
    fn heartbeat(
        &self,
        worker: &str,
        running: &[String],
        lease_ms: i64,
    ) -> Result<Vec<String>, StoreError>;
    /// Running jobs whose lease has run out go back to the queue, or fail once taken
    /// [`MAX_ATTEMPTS`] times.
    fn reap_expired(&self) -> Result<Reaped, StoreError>;
    /// Asks for job `id` to stop: a queued one is canceled at once (`Some(Canceled)`), a
    /// running one is marked for its worker to see at its next heartbeat (`Some(Running)`);
    /// `None` when it is neither.
    fn request_cancel(&self, id: &str) -> Result<Option<JobState>, StoreError>;
    /// Jobs of `kind` waiting in the queue.
    fn count_queued(&self, kind: JobKind) -> Result<usize, StoreError>;
    /// Records progress of running job `id`.
    fn set_progress(&self, id: &str, progress: f32, stage: &str) -> Result<(), StoreError>;
    /// Records the end of a job, only while it is queued, or running under `worker` (so a
    /// worker whose lease ran out cannot overwrite what another made of the job); whether it
    /// did. `artifact`: content type and the written artifact.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        id: &str,
        worker: &str,
        state: JobState,
        progress: f32,
        timings: &[(String, f64)],
        info: &serde_json::Value,
        error: Option<&str>,
        artifact: Option<(&str, &StoredArtifact)>,
    ) -> Result<bool, StoreError>;
    /// Running job `id` goes back to queued (interrupted by a shutdown), if `worker` holds it.
    /// Here and in [`Self::finish`], the worker `""` holds a running job no worker is recorded
    /// for (one left running by a version without leases).
    fn set_queued(&self, id: &str, worker: &str) -> Result<(), StoreError>;
    /// Records that `owner` holds scene or job `id` (again: no change).
    fn hold(&self, what: Held, id: &str, owner: &str) -> Result<(), StoreError>;
    /// Whether `owner` holds `id`.
    fn holds(&self, what: Held, id: &str, owner: &str) -> Result<bool, StoreError>;
    /// Marks succeeded job `id` failed with `error`, only if it is still the succeeded job
    /// whose artifact had `sha256`; whether it was (so that two readers of one lost artifact,
    /// or a reader and a deletion, do not both act on it).
    fn fail_lost(&self, id: &str, sha256: Option<&str>, error: &str) -> Result<bool, StoreError>;
    /// The first key that held `id` (the one that asked for it first), if any holds it.
    fn first_holder(&self, what: Held, id: &str) -> Result<Option<String>, StoreError>;
    /// Queued or running jobs `owner` holds.
    fn active_jobs_of(&self, owner: &str) -> Result<usize, StoreError>;
    /// Holds job `id` for `owner` if it holds fewer than `cap` queued or running jobs (a hold
    /// whose job is not recorded yet, made in the last [`SUBMITTING_MS`], counts: it is being
    /// submitted), checked and held in one transaction, so that submissions at once cannot
    /// pass the cap together; an existing hold is kept. `Err(n)`: it holds `n`, not held.
    fn hold_job_within(
        &self,
        id: &str,
        owner: &str,
        cap: usize,
    ) -> Result<Result<(), usize>, StoreError>;
    /// Deletes the idempotency records made before `before_ms`; how many.
    fn expire_idempotency(&self, before_ms: i64) -> Result<usize, StoreError>;
    /// How many hold `id`.
    fn holders(&self, what: Held, id: &str) -> Result<usize, StoreError>;
    /// Bytes `owner` holds: its scenes (JSON and files) and its jobs' artifacts, each counted
    /// whole whoever else holds it too. Walks the owner's holds.
    fn held_bytes(&self, owner: &str) -> Result<u64, StoreError>;
    /// Drops every hold on `id`.
    fn release_all(&self, what: Held, id: &str) -> Result<(), StoreError>;
    /// Scenes stored before `before_ms` that nobody holds.
    fn unheld_scenes(&self, before_ms: i64) -> Result<Vec<String>, StoreError>;
    /// Drops `owner`'s hold on `id`; how many holds remain.
    fn release(&self, what: Held, id: &str, owner: &str) -> Result<usize, StoreError>;
    /// Records when each job's result was last served (`(id, ms)`; a later time stands).
    fn touch(&self, uses: &[(String, i64)]) -> Result<(), StoreError>;
    /// Deletes a finished job's record, its holds and the idempotency keys that name it;
    /// `Some(artifact file name, if any)` when it did, `None` when the job is not finished (or
    /// not there). [`Store::delete_job`] removes the file after.
    fn delete_job_record(&self, id: &str) -> Result<Option<Option<String>>, StoreError>;
    /// Finished jobs of `kind` that ended before `before_ms`.
    fn finished_before(&self, kind: JobKind, before_ms: i64) -> Result<Vec<String>, StoreError>;
    /// Succeeded renders, least recently served (or made) first, with their artifact bytes.
    fn renders_by_last_use(&self) -> Result<Vec<(String, u64)>, StoreError>;
    /// Deletes a scene and its files once nobody holds it and no queued or running job uses
    /// it; false (and nothing deleted) when one does.
    fn delete_scene(&self, id: &str) -> Result<bool, StoreError>;
    /// Whether a queued or running job uses scene `id`.
    fn scene_in_use(&self, id: &str) -> Result<bool, StoreError>;
    /// The job an idempotency key was first used for, with the hash of that request.
    fn idempotency(&self, key: &str) -> Result<Option<(String, String)>, StoreError>;
    fn put_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError>;
    /// Points `key` at `job_id` for requests hashing to `request_hash`, replacing what it
    /// pointed at (a job since deleted).
    fn replace_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError>;
    /// Calls `on` for each change other processes make (from a thread of its own) until the
    /// store is dropped; false when this back-end has no other processes to hear (SQLite).
    fn listen(&self, on: Box<dyn Fn(StoreEvent) + Send + Sync>) -> Result<bool, StoreError>;
}

/// The records ([`JobDb`], reached through `Deref`) and the artifact files.
pub struct Store {
    db: Box<dyn JobDb>,
    artifacts: PathBuf,
    /// Object storage the artifact folder caches (`--artifacts s3://…`).
    bucket: Option<std::sync::Arc<bucket::Bucket>>,
    /// What looked wrong with the data directory at start (logged, and shown by `/readyz`).
    pub warnings: Vec<String>,
    /// Artifacts whose hash was checked in this process, by name: the file as it was then.
    verified: std::sync::Mutex<HashMap<String, FileSeen>>,
    /// When each job's result was last served, not yet written ([`Store::used`]), ms.
    used_at: std::sync::Mutex<HashMap<String, i64>>,
}

/// A file as [`Store::open_artifact`] checked it: device, inode, length, modification and
/// change times (ns) and the SHA-256 it was held to. A file with all of these unchanged has
/// not been written since (its change time cannot be set back), so it is not hashed again.
#[derive(Clone, PartialEq)]
struct FileSeen {
    id: (u64, u64, u64, i128, i128),
    sha256: String,
}

impl FileSeen {
    fn of(meta: &std::fs::Metadata, sha256: &str) -> FileSeen {
        use std::os::unix::fs::MetadataExt;
        let ns = |s: i64, n: i64| s as i128 * 1_000_000_000 + n as i128;
        FileSeen {
            id: (
                meta.dev(),
                meta.ino(),
                meta.len(),
                ns(meta.mtime(), meta.mtime_nsec()),
                ns(meta.ctime(), meta.ctime_nsec()),
            ),
            sha256: sha256.to_string(),
        }
    }
}

/// Most artifacts [`Store`] remembers as checked (then it forgets them all and checks again).
const MAX_VERIFIED: usize = 100_000;
/// Most uses [`Store::used`] keeps before it writes them.
const MAX_USES: usize = 10_000;

impl std::ops::Deref for Store {
    type Target = dyn JobDb;
    fn deref(&self) -> &Self::Target {
        &*self.db
    }
}

impl Store {
    /// Opens the embedded store: SQLite and artifacts under `dir`.
    pub fn open(dir: &Path) -> Result<Store, StoreError> {
        Store::open_with(dir, None, None)
    }

    /// Opens the store: records in the database at `database` (a `postgres://` URL), or in
    /// SQLite under `dir` when `None`; artifacts under `dir/artifacts`, a cache of the bucket
    /// `artifacts` (`s3://BUCKET/PREFIX`) when there is one. Runs the migrations.
    pub fn open_with(
        dir: &Path,
        database: Option<&str>,
        artifacts_url: Option<&str>,
    ) -> Result<Store, StoreError> {
        let bucket = artifacts_url
            .map(bucket::Bucket::open)
            .transpose()
            .map_err(StoreError::Unavailable)?
            .map(std::sync::Arc::new);
        let artifacts = dir.join("artifacts");
        std::fs::create_dir_all(&artifacts)?;
        // Temporary files are the writer's own; on a shared volume another process may be
        // writing one, so only those older than an hour go (before the SQLite
        // back-end counts the folder's files).
        let removed = remove_temp_files(&artifacts, database.is_some());
        if removed > 0 {
            tracing::warn!(
                removed,
                "removed temporary artifact files left by an earlier run"
            );
        }
        let mut warnings = Vec::new();
        let db: Box<dyn JobDb> = match database {
            None => Box::new(sqlite::SqliteDb::open(dir, &mut warnings)?),
            Some(url) => Box::new(postgres::PgDb::open(url)?),
        };
        for w in &warnings {
            tracing::error!(warning = %w, "data directory");
        }
        Ok(Store {
            db,
            artifacts,
            bucket,
            warnings,
            verified: Default::default(),
            used_at: Default::default(),
        })
    }

    /// Notes that job `id`'s result was served: kept in memory and written with the others
    /// by [`Store::flush_uses`] (the retention sweep, shutdown), or once [`MAX_USES`] jobs
    /// wait, so that serving is not a database write per request.
    pub fn used(&self, id: &str) -> Result<(), StoreError> {
        let full = {
            let mut m = self.used_at.lock().unwrap_or_else(|e| e.into_inner());
            m.insert(id.to_string(), now_ms());
            m.len() >= MAX_USES
        };
        if full { self.flush_uses() } else { Ok(()) }
    }

    /// Writes the uses [`Store::used`] kept ([`JobDb::touch`], one transaction).
    pub fn flush_uses(&self) -> Result<(), StoreError> {
        let uses: Vec<(String, i64)> =
            std::mem::take(&mut *self.used_at.lock().unwrap_or_else(|e| e.into_inner()))
                .into_iter()
                .collect();
        if uses.is_empty() {
            return Ok(());
        }
        self.db.touch(&uses)
    }

    /// The bucket the artifacts are kept in, if any.
    pub fn bucket(&self) -> Option<std::sync::Arc<bucket::Bucket>> {
        self.bucket.clone()
    }

    /// Deletes a finished job: its record, its holds and the idempotency keys that name it,
    /// then its artifact file (and object). False when it is not finished (or not there).
    pub fn delete_job(&self, id: &str) -> Result<bool, StoreError> {
        let Some(path) = self.db.delete_job_record(id)? else {
            return Ok(false);
        };
        // After the record is gone: a crash in between leaves a file without a record, which
        // the next start reports, never a record without its file. A bake's file may be
        // another record's too (the same content hash) only if that record is the same job.
        let Some(p) = path.filter(|p| !p.contains('/') && !p.contains("..")) else {
            return Ok(true);
        };
        if let Err(e) = std::fs::remove_file(self.artifacts.join(&p))
            && e.kind() != std::io::ErrorKind::NotFound
        {
            tracing::warn!(file = %p, error = %e, "artifact not removed");
        }
        if let Some(b) = &self.bucket
            && let Err(e) = b.delete(&format!("artifacts/{p}"))
        {
            tracing::warn!(error = %e, "artifact not removed from the bucket");
        }
        Ok(true)
    }

    /// Writes an artifact atomically (temporary file, fsync, rename, fsync of the folder); on
    /// an error (a full disk) the temporary file is removed and the error returned.
    pub fn write_artifact(
        &self,
        id: &str,
        ext: &str,
        bytes: &[u8],
    ) -> Result<StoredArtifact, StoreError> {
        let name = format!("{id}.{ext}");
        self.write_local(&name, bytes)?;
        if let Some(b) = &self.bucket
            && let Err(e) = b.put(&format!("artifacts/{name}"), bytes)
        {
            let _ = std::fs::remove_file(self.artifacts.join(&name));
            return Err(StoreError::Unavailable(e));
        }
        Ok(StoredArtifact {
            name,
            len: bytes.len() as u64,
            sha256: super::scenes::sha256_hex(bytes),
        })
    }

    /// Writes `bytes` as artifact file `name` atomically.
    fn write_local(&self, name: &str, bytes: &[u8]) -> Result<(), StoreError> {
        // A temporary name of this writer's own: two workers writing the same artifact on a
        // shared volume each rename a whole file into place, and the last rename wins with
        // the same bytes.
        static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = self.artifacts.join(format!(
            ".{name}.{}.{}.{n}.tmp",
            host_tag(),
            std::process::id()
        ));
        let written = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_all()?;
            std::fs::rename(&tmp, self.artifacts.join(name))
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(e.into());
        }
        // Make the rename itself durable.
        if let Ok(d) = std::fs::File::open(&self.artifacts) {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// Opens artifact `name` (a plain file in the artifact directory, never a link) and checks
    /// it against `expect` (its length, then its SHA-256, read through a fixed buffer: the
    /// artifact is never held in memory). The file comes back with its length; reads of it
    /// should be positional (`read_exact_at`).
    /// With a bucket, the folder is its cache: an artifact missing there (or failing its
    /// check) is fetched from the bucket and checked again.
    pub fn open_artifact(
        &self,
        name: &str,
        expect: Option<(u64, &str)>,
    ) -> Result<(std::fs::File, u64), StoreError> {
        let local = self.open_local(name, expect);
        let (Err(StoreError::Integrity(why)), Some(b)) = (&local, &self.bucket) else {
            return local;
        };
        if name.contains('/') || name.contains("..") {
            return local;
        }
        match b.get(&format!("artifacts/{name}")) {
            Ok(Some(bytes)) => {
                self.write_local(name, &bytes)?;
                self.open_local(name, expect)
            }
            Ok(None) => Err(StoreError::Integrity(format!(
                "{why}, and the bucket has no such object"
            ))),
            Err(e) => Err(StoreError::Unavailable(e)),
        }
    }

    fn open_local(
        &self,
        name: &str,
        expect: Option<(u64, &str)>,
    ) -> Result<(std::fs::File, u64), StoreError> {
        use sha2::Digest;
        use std::io::Read;
        use std::os::unix::fs::OpenOptionsExt;
        if name.contains('/') || name.contains("..") {
            return Err(StoreError::Corrupt(format!("artifact path {name:?}")));
        }
        let mut f = std::fs::OpenOptions::new()
            .read(true)
            .custom_flags(libc::O_NOFOLLOW)
            .open(self.artifacts.join(name))
            .map_err(|e| match e.raw_os_error() {
                Some(libc::ELOOP) => StoreError::Integrity(format!("{name} is a symbolic link")),
                _ if e.kind() == std::io::ErrorKind::NotFound => {
                    StoreError::Integrity(format!("{name} is missing"))
                }
                _ => StoreError::Io(e),
            })?;
        let meta = f.metadata()?;
        if !meta.is_file() {
            return Err(StoreError::Integrity(format!("{name} is not a file")));
        }
        if let Some((len, _)) = expect
            && meta.len() != len
        {
            return Err(StoreError::Integrity(format!(
                "{name} is {} bytes, {len} were written",
                meta.len()
            )));
        }
        if let Some((_, sha)) = expect {
            let seen = FileSeen::of(&meta, sha);
            let mut verified = self.verified.lock().unwrap_or_else(|e| e.into_inner());
            if verified.get(name) == Some(&seen) {
                return Ok((f, meta.len()));
            }
            verified.remove(name);
            drop(verified);
            let mut h = sha2::Sha256::new();
            let mut buf = vec![0u8; 256 << 10];
            loop {
                let n = f.read(&mut buf)?;
                if n == 0 {
                    break;
                }
                h.update(&buf[..n]);
            }
            if super::scenes::hex(&h.finalize()) != sha {
                return Err(StoreError::Integrity(format!(
                    "{name} does not hash to the SHA-256 recorded when it was written"
                )));
            }
            let mut verified = self.verified.lock().unwrap_or_else(|e| e.into_inner());
            if verified.len() >= MAX_VERIFIED {
                verified.clear();
            }
            verified.insert(name.to_string(), seen);
        }
        Ok((f, meta.len()))
    }
}

/// Removes `.*.tmp` files (artifact writes a crash interrupted); with `shared`, only those
/// older than an hour (another process may be writing the others). How many.
fn remove_temp_files(dir: &Path, shared: bool) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    rd.filter_map(Result::ok)
        .filter(|e| {
            let n = e.file_name();
            let n = n.to_string_lossy();
            n.starts_with('.') && n.ends_with(".tmp")
        })
        .filter(|e| {
            !shared
                || e.metadata()
                    .and_then(|m| m.modified())
                    .is_ok_and(|t| t.elapsed().is_ok_and(|a| a.as_secs() > 3600))
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}
/// What a PostgreSQL error says: the server's message, or the cause of a connection error
/// (its `Display` alone is "db error" or "error connecting to server").
pub fn pg_detail(e: &::postgres::Error) -> String {
    match (e.as_db_error(), std::error::Error::source(e)) {
        (Some(d), _) => format!("{}: {}", d.severity(), d.message()),
        (None, Some(cause)) => format!("{e}: {cause}"),
        (None, None) => e.to_string(),
    }
}

/// The host's name (for temporary file names and worker ids), or `host` when unknown.
pub fn host_tag() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: gethostname writes at most `buf.len()` bytes into the buffer it is given.
    let r = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) };
    let n = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    let s: String = String::from_utf8_lossy(&buf[..n])
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
        .take(63)
        .collect();
    if r != 0 || s.is_empty() {
        "host".into()
    } else {
        s
    }
}
