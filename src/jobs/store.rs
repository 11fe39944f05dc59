//! Persistence: scenes, job records and artifacts under the data directory.
//!
//! SQLite (bundled, WAL) keeps scenes, their uploaded files and job records; artifacts are
//! files under `artifacts/`, written atomically (temp file, fsync, rename, fsync of the
//! directory) before the record that points at them is marked succeeded, so a record never
//! names a half-written file. One connection behind a mutex: every statement is short, and
//! SQLite serialises writers anyway.

use super::job::{ErrorCode, JobKind, JobSpec, JobState};
use crate::methods::Method;
use rusqlite::{Connection, OptionalExtension, params};
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{SystemTime, UNIX_EPOCH};

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("database: {0}")]
    Db(#[from] rusqlite::Error),
    #[error("file system: {0}")]
    Io(#[from] std::io::Error),
    #[error("corrupt record: {0}")]
    Corrupt(String),
    /// A stored artifact is missing, a link, or not the bytes that were written.
    #[error("artifact failed its check: {0}")]
    Integrity(String),
}

/// Schema migrations, applied in order; `PRAGMA user_version` records how many ran.
const MIGRATIONS: &[&str] = &[
    r#"
    CREATE TABLE scenes (
        id TEXT PRIMARY KEY,
        scene_json BLOB NOT NULL,
        created_at INTEGER NOT NULL
    );
    CREATE TABLE scene_files (
        scene_id TEXT NOT NULL REFERENCES scenes(id),
        name TEXT NOT NULL,
        bytes BLOB NOT NULL,
        PRIMARY KEY (scene_id, name)
    );
    CREATE TABLE jobs (
        id TEXT PRIMARY KEY,
        kind TEXT NOT NULL,
        method TEXT NOT NULL,
        scene_id TEXT NOT NULL,
        object TEXT,
        params TEXT NOT NULL,
        state TEXT NOT NULL,
        progress REAL NOT NULL DEFAULT 0,
        stage TEXT NOT NULL DEFAULT '',
        timings TEXT NOT NULL DEFAULT '[]',
        info TEXT NOT NULL DEFAULT '{}',
        error TEXT,
        artifact_type TEXT,
        artifact_path TEXT,
        created_at INTEGER NOT NULL,
        started_at INTEGER,
        finished_at INTEGER,
        seq INTEGER NOT NULL DEFAULT 0
    );
    CREATE INDEX jobs_state ON jobs(state);
    CREATE TABLE idempotency (
        key TEXT PRIMARY KEY,
        request_hash TEXT NOT NULL,
        job_id TEXT NOT NULL
    );
"#,
    // 2: each artifact's length and SHA-256, checked when it is served.
    r#"
    ALTER TABLE jobs ADD COLUMN artifact_len INTEGER;
    ALTER TABLE jobs ADD COLUMN artifact_sha256 TEXT;
"#,
    // 3: who holds each scene and job (API keys); '' is the anonymous client.
    r#"
    CREATE TABLE holds (
        kind TEXT NOT NULL,
        id TEXT NOT NULL,
        owner TEXT NOT NULL,
        PRIMARY KEY (kind, id, owner)
    );
    INSERT INTO holds (kind, id, owner) SELECT 'scene', id, '' FROM scenes;
    INSERT INTO holds (kind, id, owner) SELECT 'job', id, '' FROM jobs;
"#,
    // 4: when each result was last served, for evicting the least recently used renders.
    r#"
    ALTER TABLE jobs ADD COLUMN accessed_at INTEGER;
    CREATE INDEX jobs_kind_state ON jobs(kind, state);
"#,
];

/// Which jobs [`Store::list_jobs`] returns.
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

/// What a hold is on: a scene or a job.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Held {
    Scene,
    Job,
}

impl Held {
    fn as_str(self) -> &'static str {
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
}

impl JobRecord {
    /// A new, queued job's record.
    pub fn new(id: &str, spec: &JobSpec) -> JobRecord {
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

/// Milliseconds since the Unix epoch.
pub fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}

pub struct Store {
    conn: Mutex<Connection>,
    artifacts: PathBuf,
    /// What looked wrong with the data directory at start (logged, and shown by `/readyz`).
    pub warnings: Vec<String>,
}

/// The SQLite WAL header magic (big-endian; the low bit is the checksum byte order).
const WAL_MAGIC: [u32; 2] = [0x377f_0682, 0x377f_0683];

impl Store {
    /// Opens (creating if needed) the database and artifact folder under `dir` and runs the
    /// migrations.
    pub fn open(dir: &Path) -> Result<Store, StoreError> {
        let artifacts = dir.join("artifacts");
        std::fs::create_dir_all(&artifacts)?;
        let db = dir.join("caustica.sqlite3");
        let mut warnings = Vec::new();
        if std::fs::metadata(&db).is_ok_and(|m| m.len() == 0) {
            warnings.push(format!(
                "the database {} is an empty file: every scene and job record is gone \
                 (starting with an empty store)",
                db.display()
            ));
        }
        let wal = dir.join("caustica.sqlite3-wal");
        if let Ok(b) = std::fs::read(&wal)
            && !b.is_empty()
        {
            let magic = b
                .get(..4)
                .map(|m| u32::from_be_bytes([m[0], m[1], m[2], m[3]]));
            if !magic.is_some_and(|m| WAL_MAGIC.contains(&m)) {
                warnings.push(format!(
                    "the write-ahead log {} is not a SQLite WAL ({} bytes of something else): \
                     transactions it held are lost",
                    wal.display(),
                    b.len()
                ));
            }
        }
        let removed = remove_temp_files(&artifacts);
        if removed > 0 {
            tracing::warn!(
                removed,
                "removed temporary artifact files left by an earlier run"
            );
        }
        let conn = Connection::open(&db)?;
        conn.busy_timeout(std::time::Duration::from_secs(5))?;
        conn.pragma_update(None, "journal_mode", "WAL")?;
        // WAL + NORMAL: a committed transaction survives a process crash (kill -9); only a
        // power loss may drop the last few, which re-run as bakes are deterministic.
        conn.pragma_update(None, "synchronous", "NORMAL")?;
        conn.pragma_update(None, "foreign_keys", "ON")?;
        let version: i64 = conn.query_row("PRAGMA user_version", [], |r| r.get(0))?;
        for (i, m) in MIGRATIONS.iter().enumerate().skip(version as usize) {
            let tx = conn.unchecked_transaction()?;
            tx.execute_batch(m)?;
            tx.pragma_update(None, "user_version", (i + 1) as i64)?;
            tx.commit()?;
        }
        let jobs: i64 = conn.query_row("SELECT COUNT(*) FROM jobs", [], |r| r.get(0))?;
        let files = std::fs::read_dir(&artifacts).map_or(0, |d| d.count());
        if jobs == 0 && files > 0 {
            warnings.push(format!(
                "the database holds no jobs but {} holds {files} artifacts: the database was \
                 lost or replaced",
                artifacts.display()
            ));
        }
        for w in &warnings {
            tracing::error!(warning = %w, "data directory");
        }
        Ok(Store {
            conn: Mutex::new(conn),
            artifacts,
            warnings,
        })
    }

    fn conn(&self) -> std::sync::MutexGuard<'_, Connection> {
        self.conn.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stores a scene unless one with this id exists (ids are content hashes).
    /// `owner` holds the scene from the same transaction on, so that no sweep of unheld scenes
    /// can take it in between.
    pub fn put_scene(
        &self,
        id: &str,
        scene_json: &[u8],
        files: &[(String, Vec<u8>)],
        owner: &str,
    ) -> Result<(), StoreError> {
        let mut c = self.conn();
        let tx = c.transaction()?;
        tx.execute(
            "INSERT OR IGNORE INTO holds (kind, id, owner) VALUES ('scene', ?1, ?2)",
            params![id, owner],
        )?;
        let n = tx.execute(
            "INSERT OR IGNORE INTO scenes (id, scene_json, created_at) VALUES (?1, ?2, ?3)",
            params![id, scene_json, now_ms()],
        )?;
        if n == 1 {
            for (name, bytes) in files {
                tx.execute(
                    "INSERT INTO scene_files (scene_id, name, bytes) VALUES (?1, ?2, ?3)",
                    params![id, name, bytes],
                )?;
            }
        }
        tx.commit()?;
        Ok(())
    }

    /// Whether scene `id` is stored (without reading it).
    pub fn scene_exists(&self, id: &str) -> Result<bool, StoreError> {
        Ok(self
            .conn()
            .query_row("SELECT 1 FROM scenes WHERE id = ?1", [id], |_| Ok(()))
            .optional()?
            .is_some())
    }

    pub fn get_scene(&self, id: &str) -> Result<Option<StoredScene>, StoreError> {
        let c = self.conn();
        let Some((scene_json, created_at)) = c
            .query_row(
                "SELECT scene_json, created_at FROM scenes WHERE id = ?1",
                [id],
                |r| Ok((r.get::<_, Vec<u8>>(0)?, r.get::<_, i64>(1)?)),
            )
            .optional()?
        else {
            return Ok(None);
        };
        let mut st =
            c.prepare("SELECT name, bytes FROM scene_files WHERE scene_id = ?1 ORDER BY name")?;
        let files = st
            .query_map([id], |r| Ok((r.get(0)?, r.get(1)?)))?
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Some(StoredScene {
            id: id.into(),
            scene_json,
            files,
            created_at,
        }))
    }

    pub fn insert_job(&self, r: &JobRecord) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT INTO jobs (id, kind, method, scene_id, object, params, state, progress, stage,
                               created_at, seq)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 0, '', ?8,
                     (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs))",
            params![
                r.id,
                r.kind.as_str(),
                r.method.name(),
                r.scene_id,
                r.object,
                r.params.to_string(),
                r.state.as_str(),
                r.created_at
            ],
        )?;
        Ok(())
    }

    /// Puts a finished (failed or canceled) job back in the queue.
    pub fn requeue(&self, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET state = 'queued', progress = 0, stage = '', error = NULL,
                 started_at = NULL, finished_at = NULL, timings = '[]'
             WHERE id = ?1",
            [id],
        )?;
        Ok(())
    }

    pub fn get_job(&self, id: &str) -> Result<Option<JobRecord>, StoreError> {
        let c = self.conn();
        let r = c
            .query_row(
                "SELECT id, kind, method, scene_id, object, params, state, progress, stage,
                        timings, info, error, artifact_type, artifact_path, created_at,
                        started_at, finished_at, artifact_len, artifact_sha256
                 FROM jobs WHERE id = ?1",
                [id],
                row_to_record,
            )
            .optional()?;
        r.transpose()
    }

    /// One page of jobs, newest first: those of `f.kind` that `f.owner` holds (every one when
    /// `None`: an admin), filtered, with sequence numbers below `f.before_seq`; each with its
    /// sequence number (the next page's cursor). A record that cannot be read is left out
    /// (logged; `unfinished_jobs` quarantines such rows at start).
    pub fn list_jobs(&self, f: &JobFilter) -> Result<Vec<(i64, JobRecord)>, StoreError> {
        let c = self.conn();
        let mut st = c.prepare(
            "SELECT id, kind, method, scene_id, object, params, state, progress, stage,
                    timings, info, error, artifact_type, artifact_path, created_at,
                    started_at, finished_at, artifact_len, artifact_sha256, seq
             FROM jobs j
             WHERE kind = ?1
               AND (?2 IS NULL OR EXISTS (SELECT 1 FROM holds h
                                          WHERE h.kind = 'job' AND h.id = j.id AND h.owner = ?2))
               AND (?3 IS NULL OR state = ?3)
               AND (?4 IS NULL OR method = ?4)
               AND (?5 IS NULL OR created_at >= ?5)
               AND (?6 IS NULL OR seq < ?6)
             ORDER BY seq DESC
             LIMIT ?7",
        )?;
        let rows = st.query_map(
            params![
                f.kind.as_str(),
                f.owner,
                f.state.map(|s| s.as_str()),
                f.method.map(|m| m.name()),
                f.created_since,
                f.before_seq,
                f.limit as i64
            ],
            |r| Ok((r.get::<_, i64>(19)?, row_to_record(r)?)),
        )?;
        let mut out = Vec::new();
        for row in rows {
            let (seq, rec) = row?;
            match rec {
                Ok(rec) => out.push((seq, rec)),
                Err(e) => {
                    tracing::error!(seq, error = %e, "unreadable job record left out of a list")
                }
            }
        }
        Ok(out)
    }

    /// One page of scenes, newest first: those `owner` holds (every one when `None`),
    /// created at or after `created_since`, stored before row `before` (the cursor); each as
    /// (row, id, name, created_at).
    pub fn list_scenes(
        &self,
        owner: Option<&str>,
        created_since: Option<i64>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<(i64, String, String, i64)>, StoreError> {
        let c = self.conn();
        let mut st = c.prepare(
            "SELECT rowid, id, COALESCE(json_extract(CAST(scene_json AS TEXT), '$.name'), ''),
                    created_at
             FROM scenes s
             WHERE (?1 IS NULL OR EXISTS (SELECT 1 FROM holds h
                                          WHERE h.kind = 'scene' AND h.id = s.id AND h.owner = ?1))
               AND (?2 IS NULL OR created_at >= ?2)
               AND (?3 IS NULL OR rowid < ?3)
             ORDER BY rowid DESC
             LIMIT ?4",
        )?;
        let rows = st.query_map(params![owner, created_since, before, limit as i64], |r| {
            Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?))
        })?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Jobs left queued or running by a previous process, oldest first. A record that cannot
    /// be read (invalid JSON in a column, an unknown method) is quarantined: marked failed with
    /// the reason, logged, and left out, so that one bad row does not stop the server.
    pub fn unfinished_jobs(&self) -> Result<Vec<JobRecord>, StoreError> {
        let ids: Vec<String> = {
            let c = self.conn();
            let mut st =
                c.prepare("SELECT id FROM jobs WHERE state IN ('queued', 'running') ORDER BY seq")?;
            st.query_map([], |r| r.get(0))?
                .collect::<Result<Vec<_>, _>>()?
        };
        let mut out = Vec::new();
        for id in ids {
            match self.get_job(&id) {
                Ok(Some(r)) => out.push(r),
                Ok(None) => {}
                Err(e) => {
                    tracing::error!(job = %id, error = %e, "quarantining an unreadable job record");
                    self.conn().execute(
                        "UPDATE jobs SET state = 'failed', finished_at = ?2, stage = 'failed',
                             error = ?3
                         WHERE id = ?1",
                        params![id, now_ms(), format!("quarantined at start: {e}")],
                    )?;
                }
            }
        }
        Ok(out)
    }

    pub fn set_running(&self, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET state = 'running', started_at = ?2 WHERE id = ?1",
            params![id, now_ms()],
        )?;
        Ok(())
    }

    pub fn set_progress(&self, id: &str, progress: f32, stage: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET progress = ?2, stage = ?3 WHERE id = ?1",
            params![id, progress, stage],
        )?;
        Ok(())
    }

    /// Records the end of a job. `artifact`: content type and the written artifact.
    #[allow(clippy::too_many_arguments)]
    pub fn finish(
        &self,
        id: &str,
        state: JobState,
        progress: f32,
        timings: &[(String, f64)],
        info: &serde_json::Value,
        error: Option<&str>,
        artifact: Option<(&str, &StoredArtifact)>,
    ) -> Result<(), StoreError> {
        let timings = serde_json::to_string(timings).expect("timings serialise");
        self.conn().execute(
            "UPDATE jobs SET state = ?2, progress = ?3, timings = ?4, info = ?5, error = ?6,
                 artifact_type = ?7, artifact_path = ?8, finished_at = ?9, stage = ?10,
                 artifact_len = ?11, artifact_sha256 = ?12
             WHERE id = ?1",
            params![
                id,
                state.as_str(),
                progress,
                timings,
                info.to_string(),
                error,
                artifact.map(|a| a.0),
                artifact.map(|a| a.1.name.as_str()),
                now_ms(),
                if state == JobState::Succeeded {
                    "done"
                } else {
                    state.as_str()
                },
                artifact.map(|a| a.1.len as i64),
                artifact.map(|a| a.1.sha256.as_str()),
            ],
        )?;
        Ok(())
    }

    /// Back to queued (a job interrupted by shutdown runs again at the next start).
    pub fn set_queued(&self, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET state = 'queued', progress = 0, stage = '' WHERE id = ?1",
            [id],
        )?;
        Ok(())
    }

    /// Records that `owner` holds scene or job `id` (again: no change).
    pub fn hold(&self, what: Held, id: &str, owner: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR IGNORE INTO holds (kind, id, owner) VALUES (?1, ?2, ?3)",
            params![what.as_str(), id, owner],
        )?;
        Ok(())
    }

    /// Whether `owner` holds `id`.
    pub fn holds(&self, what: Held, id: &str, owner: &str) -> Result<bool, StoreError> {
        Ok(self
            .conn()
            .query_row(
                "SELECT 1 FROM holds WHERE kind = ?1 AND id = ?2 AND owner = ?3",
                params![what.as_str(), id, owner],
                |_| Ok(()),
            )
            .optional()?
            .is_some())
    }

    /// Marks succeeded job `id` failed with `error`, only if it is still the succeeded job
    /// whose artifact had `sha256`; whether it was (so that two readers of one lost artifact,
    /// or a reader and a deletion, do not both act on it).
    pub fn fail_lost(
        &self,
        id: &str,
        sha256: Option<&str>,
        error: &str,
    ) -> Result<bool, StoreError> {
        let info = serde_json::json!({ "error_code": ErrorCode::Store }).to_string();
        let n = self.conn().execute(
            "UPDATE jobs SET state = 'failed', stage = 'failed', error = ?3, info = ?4,
                 finished_at = ?5, artifact_type = NULL, artifact_path = NULL
             WHERE id = ?1 AND state = 'succeeded' AND artifact_sha256 IS ?2",
            params![id, sha256, error, info, now_ms()],
        )?;
        Ok(n == 1)
    }

    /// The first key that held `id` (the one that asked for it first), if any holds it.
    pub fn first_holder(&self, what: Held, id: &str) -> Result<Option<String>, StoreError> {
        Ok(self
            .conn()
            .query_row(
                "SELECT owner FROM holds WHERE kind = ?1 AND id = ?2 ORDER BY rowid LIMIT 1",
                params![what.as_str(), id],
                |r| r.get(0),
            )
            .optional()?)
    }

    /// Queued or running jobs `owner` holds.
    pub fn active_jobs_of(&self, owner: &str) -> Result<usize, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM holds h JOIN jobs j ON j.id = h.id
             WHERE h.kind = 'job' AND h.owner = ?1 AND j.state IN ('queued', 'running')",
            [owner],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    /// How many hold `id`.
    pub fn holders(&self, what: Held, id: &str) -> Result<usize, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM holds WHERE kind = ?1 AND id = ?2",
            params![what.as_str(), id],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    /// Drops every hold on `id`.
    pub fn release_all(&self, what: Held, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "DELETE FROM holds WHERE kind = ?1 AND id = ?2",
            params![what.as_str(), id],
        )?;
        Ok(())
    }

    /// Scenes stored before `before_ms` that nobody holds (left over when a job used one past
    /// its last hold; the age leaves an upload the moment between storing and holding it).
    pub fn unheld_scenes(&self, before_ms: i64) -> Result<Vec<String>, StoreError> {
        let c = self.conn();
        let mut st = c.prepare(
            "SELECT id FROM scenes WHERE created_at < ?1
                 AND id NOT IN (SELECT id FROM holds WHERE kind = 'scene')",
        )?;
        let ids = st
            .query_map([before_ms], |r| r.get(0))?
            .collect::<Result<Vec<String>, _>>()?;
        Ok(ids)
    }

    /// Drops `owner`'s hold on `id`; how many holds remain.
    pub fn release(&self, what: Held, id: &str, owner: &str) -> Result<usize, StoreError> {
        let c = self.conn();
        c.execute(
            "DELETE FROM holds WHERE kind = ?1 AND id = ?2 AND owner = ?3",
            params![what.as_str(), id, owner],
        )?;
        let n: i64 = c.query_row(
            "SELECT COUNT(*) FROM holds WHERE kind = ?1 AND id = ?2",
            params![what.as_str(), id],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    /// Notes that job `id`'s result was just served (for [`Self::evict_renders`]).
    pub fn touch(&self, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET accessed_at = ?2 WHERE id = ?1",
            params![id, now_ms()],
        )?;
        Ok(())
    }

    /// Deletes a finished job: its artifact file, its record, its holds and the idempotency
    /// keys that name it. False when it is not finished (or not there).
    pub fn delete_job(&self, id: &str) -> Result<bool, StoreError> {
        let mut c = self.conn();
        let tx = c.transaction()?;
        let path: Option<Option<String>> = tx
            .query_row(
                "SELECT artifact_path FROM jobs
                 WHERE id = ?1 AND state IN ('succeeded', 'failed', 'canceled')",
                [id],
                |r| r.get(0),
            )
            .optional()?;
        let Some(path) = path else {
            return Ok(false);
        };
        tx.execute("DELETE FROM jobs WHERE id = ?1", [id])?;
        tx.execute("DELETE FROM holds WHERE kind = 'job' AND id = ?1", [id])?;
        tx.execute("DELETE FROM idempotency WHERE job_id = ?1", [id])?;
        tx.commit()?;
        drop(c);
        // After the record is gone: a crash in between leaves a file without a record, which
        // the next start reports, never a record without its file.
        if let Some(p) = path.filter(|p| !p.contains('/') && !p.contains(".."))
            && let Err(e) = std::fs::remove_file(self.artifacts.join(&p))
            && e.kind() != std::io::ErrorKind::NotFound
        {
            tracing::warn!(file = %p, error = %e, "artifact not removed");
        }
        Ok(true)
    }

    /// Finished jobs of `kind` that ended before `before_ms` (for the time to live).
    pub fn finished_before(
        &self,
        kind: JobKind,
        before_ms: i64,
    ) -> Result<Vec<String>, StoreError> {
        let c = self.conn();
        let mut st = c.prepare(
            "SELECT id FROM jobs WHERE kind = ?1 AND state IN ('succeeded', 'failed', 'canceled')
                 AND COALESCE(finished_at, created_at) < ?2",
        )?;
        let ids = st
            .query_map(params![kind.as_str(), before_ms], |r| r.get(0))?
            .collect::<Result<Vec<String>, _>>()?;
        Ok(ids)
    }

    /// Succeeded renders, least recently served (or made) first, with their artifact bytes.
    pub fn renders_by_last_use(&self) -> Result<Vec<(String, u64)>, StoreError> {
        let c = self.conn();
        let mut st = c.prepare(
            "SELECT id, COALESCE(artifact_len, 0) FROM jobs
             WHERE kind = 'render' AND state = 'succeeded'
             ORDER BY COALESCE(accessed_at, finished_at, created_at), seq",
        )?;
        let rows = st
            .query_map([], |r| Ok((r.get(0)?, r.get::<_, i64>(1)? as u64)))?
            .collect::<Result<Vec<_>, _>>()?;
        Ok(rows)
    }

    /// Deletes a scene and its files once nobody holds it and no queued or running job uses
    /// it; false (and nothing deleted) when one does.
    pub fn delete_scene(&self, id: &str) -> Result<bool, StoreError> {
        let mut c = self.conn();
        let tx = c.transaction()?;
        let busy: i64 = tx.query_row(
            "SELECT (SELECT COUNT(*) FROM holds WHERE kind = 'scene' AND id = ?1)
                  + (SELECT COUNT(*) FROM jobs WHERE scene_id = ?1
                         AND state IN ('queued', 'running'))",
            [id],
            |r| r.get(0),
        )?;
        if busy > 0 {
            return Ok(false);
        }
        tx.execute("DELETE FROM scene_files WHERE scene_id = ?1", [id])?;
        tx.execute("DELETE FROM scenes WHERE id = ?1", [id])?;
        tx.commit()?;
        Ok(true)
    }

    /// Whether a queued or running job uses scene `id`.
    pub fn scene_in_use(&self, id: &str) -> Result<bool, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM jobs WHERE scene_id = ?1 AND state IN ('queued', 'running')",
            [id],
            |r| r.get(0),
        )?;
        Ok(n > 0)
    }

    /// The job an idempotency key was first used for, with the hash of that request.
    pub fn idempotency(&self, key: &str) -> Result<Option<(String, String)>, StoreError> {
        Ok(self
            .conn()
            .query_row(
                "SELECT request_hash, job_id FROM idempotency WHERE key = ?1",
                [key],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .optional()?)
    }

    pub fn put_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR IGNORE INTO idempotency (key, request_hash, job_id) VALUES (?1, ?2, ?3)",
            params![key, request_hash, job_id],
        )?;
        Ok(())
    }

    /// Points `key` at `job_id` for requests hashing to `request_hash`, replacing what it
    /// pointed at (a job since deleted).
    pub fn replace_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR REPLACE INTO idempotency (key, request_hash, job_id) VALUES (?1, ?2, ?3)",
            params![key, request_hash, job_id],
        )?;
        Ok(())
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
        let tmp = self.artifacts.join(format!(".{name}.tmp"));
        let written = (|| -> std::io::Result<()> {
            let mut f = std::fs::File::create(&tmp)?;
            f.write_all(bytes)?;
            f.sync_all()?;
            std::fs::rename(&tmp, self.artifacts.join(&name))
        })();
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(e.into());
        }
        // Make the rename itself durable.
        if let Ok(d) = std::fs::File::open(&self.artifacts) {
            let _ = d.sync_all();
        }
        Ok(StoredArtifact {
            name,
            len: bytes.len() as u64,
            sha256: super::scenes::sha256_hex(bytes),
        })
    }

    /// Opens artifact `name` (a plain file in the artifact directory, never a link) and checks
    /// it against `expect` (its length, then its SHA-256, read through a fixed buffer: the
    /// artifact is never held in memory). The file comes back with its length; reads of it
    /// should be positional (`read_exact_at`).
    pub fn open_artifact(
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
        }
        Ok((f, meta.len()))
    }
}

/// Removes `.*.tmp` files (artifact writes a crash interrupted); how many.
fn remove_temp_files(dir: &Path) -> usize {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return 0;
    };
    rd.filter_map(Result::ok)
        .filter(|e| {
            let n = e.file_name();
            let n = n.to_string_lossy();
            n.starts_with('.') && n.ends_with(".tmp")
        })
        .filter(|e| std::fs::remove_file(e.path()).is_ok())
        .count()
}

type RowResult = Result<JobRecord, StoreError>;

fn row_to_record(r: &rusqlite::Row<'_>) -> rusqlite::Result<RowResult> {
    let params: String = r.get(5)?;
    let timings: String = r.get(9)?;
    let info: String = r.get(10)?;
    let parse = |what: &str, s: &str| -> Result<serde_json::Value, StoreError> {
        serde_json::from_str(s).map_err(|e| StoreError::Corrupt(format!("{what}: {e}")))
    };
    let kind: String = r.get(1)?;
    let method: String = r.get(2)?;
    let state: String = r.get(6)?;
    let rec = (|| -> RowResult {
        Ok(JobRecord {
            id: r.get(0)?,
            kind: JobKind::parse(&kind)
                .ok_or_else(|| StoreError::Corrupt(format!("kind '{kind}'")))?,
            method: Method::parse(&method).map_err(|e| StoreError::Corrupt(e.to_string()))?,
            scene_id: r.get(3)?,
            object: r.get(4)?,
            params: parse("params", &params)?,
            state: JobState::parse(&state)
                .ok_or_else(|| StoreError::Corrupt(format!("state '{state}'")))?,
            progress: r.get::<_, f64>(7)? as f32,
            stage: r.get(8)?,
            timings: serde_json::from_str(&timings)
                .map_err(|e| StoreError::Corrupt(format!("timings: {e}")))?,
            info: parse("info", &info)?,
            error: r.get(11)?,
            artifact_type: r.get(12)?,
            artifact_path: r.get(13)?,
            created_at: r.get(14)?,
            started_at: r.get(15)?,
            finished_at: r.get(16)?,
            artifact_len: r.get::<_, Option<i64>>(17)?.map(|n| n as u64),
            artifact_sha256: r.get(18)?,
        })
    })();
    Ok(rec)
}
