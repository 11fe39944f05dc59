//! The SQLite back-end of [`JobDb`]: one file under the data directory (bundled SQLite, WAL),
//! one writing connection behind a mutex (every statement is short, and SQLite serialises
//! writers anyway) and four read-only ones for the API's lookups and lists, which WAL lets
//! read beside the writer. Leases and claims work as on PostgreSQL, so the same suite passes;
//! only one process uses the file.
//!
//! One file of ~1,040 lines: it is one implementation of [`JobDb`], each method a statement or
//! two beside its siblings (as `postgres.rs`); the migrations at its top are its schema.

use super::{
    Held, JobDb, JobFilter, JobRecord, MAX_ATTEMPTS, Reaped, StoreError, StoreEvent,
    StoredArtifact, StoredScene, now_ms,
};
use crate::jobs::job::{ErrorCode, JobKind, JobState, Priority};
use crate::methods::{Lane, Method};
use rusqlite::{Connection, OptionalExtension, params};
use std::path::Path;
use std::sync::Mutex;

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
    // 5: where each job runs (lane, priority) and who holds it (worker, lease, attempts,
    // a cancellation asked of its worker).
    r#"
    ALTER TABLE jobs ADD COLUMN lane TEXT NOT NULL DEFAULT 'cpu';
    ALTER TABLE jobs ADD COLUMN priority INTEGER NOT NULL DEFAULT 2;
    ALTER TABLE jobs ADD COLUMN worker TEXT;
    ALTER TABLE jobs ADD COLUMN lease_until INTEGER;
    ALTER TABLE jobs ADD COLUMN attempts INTEGER NOT NULL DEFAULT 0;
    ALTER TABLE jobs ADD COLUMN cancel_requested INTEGER NOT NULL DEFAULT 0;
    CREATE INDEX jobs_claim ON jobs(state, lane, priority, seq);
"#,
    // 6: indexes for every list, quota, sequence and idempotency query (a key's list, or a
    // submission, reads that key's rows, not the table); when each hold and idempotency
    // record was made (quotas count holds whose job is being submitted; records expire).
    r#"
    ALTER TABLE holds ADD COLUMN created_at INTEGER NOT NULL DEFAULT 0;
    CREATE INDEX holds_owner ON holds(owner, kind, created_at, id);
    CREATE INDEX jobs_seq ON jobs(seq);
    CREATE INDEX jobs_kind_seq ON jobs(kind, seq);
    CREATE INDEX jobs_kind_state_seq ON jobs(kind, state, seq);
    CREATE INDEX jobs_scene_state ON jobs(scene_id, state);
    ALTER TABLE idempotency ADD COLUMN created_at INTEGER NOT NULL DEFAULT 0;
    UPDATE idempotency SET created_at = CAST(strftime('%s', 'now') AS INTEGER) * 1000;
    CREATE INDEX idempotency_job ON idempotency(job_id);
    CREATE INDEX idempotency_created ON idempotency(created_at);
"#,
];

/// The SQLite WAL header magic (big-endian; the low bit is the checksum byte order).
const WAL_MAGIC: [u32; 2] = [0x377f_0682, 0x377f_0683];

/// The columns [`row_to_record`] reads, in its order.
const COLUMNS: &str = "id, kind, method, scene_id, object, params, state, progress, stage,
    timings, info, error, artifact_type, artifact_path, created_at, started_at, finished_at,
    artifact_len, artifact_sha256, lane, priority, worker, attempts";

pub struct SqliteDb {
    /// The one connection that writes (SQLite takes one writer at a time).
    conn: Mutex<Connection>,
    /// Read-only connections for the API's lookups and lists: in WAL mode they read the last
    /// committed state beside the writer and each other.
    readers: Vec<Mutex<Connection>>,
    /// The reader to wait for when all are taken (round robin).
    next_reader: std::sync::atomic::AtomicUsize,
}

/// How many read-only connections [`SqliteDb`] keeps.
const READERS: usize = 4;

impl SqliteDb {
    /// Opens (creating if needed) `dir/caustica.sqlite3` and runs the migrations; what looks
    /// wrong with the files is added to `warnings`.
    pub fn open(dir: &Path, warnings: &mut Vec<String>) -> Result<SqliteDb, StoreError> {
        std::fs::create_dir_all(dir)?;
        let db = dir.join("caustica.sqlite3");
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
        let artifacts = dir.join("artifacts");
        let files = std::fs::read_dir(&artifacts).map_or(0, |d| d.count());
        if jobs == 0 && files > 0 {
            warnings.push(format!(
                "the database holds no jobs but {} holds {files} artifacts: the database was \
                 lost or replaced",
                artifacts.display()
            ));
        }
        let readers = (0..READERS)
            .map(|_| {
                use rusqlite::OpenFlags;
                let flags = OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX;
                let r = Connection::open_with_flags(&db, flags)?;
                r.busy_timeout(std::time::Duration::from_secs(5))?;
                Ok(Mutex::new(r))
            })
            .collect::<Result<Vec<_>, StoreError>>()?;
        Ok(SqliteDb {
            conn: Mutex::new(conn),
            readers,
            next_reader: Default::default(),
        })
    }

    /// A read-only connection: a free one, else the next in turn, waited for outside the
    /// async runtime as [`Self::conn`].
    fn read(&self) -> std::sync::MutexGuard<'_, Connection> {
        for r in &self.readers {
            match r.try_lock() {
                Ok(g) => return g,
                Err(std::sync::TryLockError::Poisoned(e)) => return e.into_inner(),
                Err(std::sync::TryLockError::WouldBlock) => {}
            }
        }
        let i = self
            .next_reader
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed)
            % self.readers.len();
        let r = &self.readers[i];
        super::wait_outside_runtime(|| r.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// The connection; when another call holds it, waited for outside the async runtime
    /// ([`super::wait_outside_runtime`]), so that requests queued behind a
    /// statement do not stall the runtime's other tasks. The statement itself runs where it
    /// is called (indexed: milliseconds at a million rows, see `benches/store.rs`).
    fn conn(&self) -> std::sync::MutexGuard<'_, Connection> {
        match self.conn.try_lock() {
            Ok(g) => g,
            Err(std::sync::TryLockError::Poisoned(e)) => e.into_inner(),
            Err(std::sync::TryLockError::WouldBlock) => {
                super::wait_outside_runtime(|| self.conn.lock().unwrap_or_else(|e| e.into_inner()))
            }
        }
    }
}

impl JobDb for SqliteDb {
    fn backend(&self) -> &'static str {
        "sqlite"
    }

    fn put_scene(
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

    fn scene_exists(&self, id: &str) -> Result<bool, StoreError> {
        Ok(self
            .read()
            .query_row("SELECT 1 FROM scenes WHERE id = ?1", [id], |_| Ok(()))
            .optional()?
            .is_some())
    }

    fn get_scene(&self, id: &str) -> Result<Option<StoredScene>, StoreError> {
        let c = self.read();
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

    fn insert_job(&self, r: &JobRecord) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT INTO jobs (id, kind, method, scene_id, object, params, state, progress, stage,
                               created_at, seq, lane, priority)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 0, '', ?8,
                     (SELECT COALESCE(MAX(seq), 0) + 1 FROM jobs), ?9, ?10)",
            params![
                r.id,
                r.kind.as_str(),
                r.method.name(),
                r.scene_id,
                r.object,
                r.params.to_string(),
                r.state.as_str(),
                r.created_at,
                lane_str(r.lane),
                r.priority as i64
            ],
        )?;
        Ok(())
    }

    fn requeue(&self, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET state = 'queued', progress = 0, stage = '', error = NULL,
                 started_at = NULL, finished_at = NULL, timings = '[]', worker = NULL,
                 lease_until = NULL, attempts = 0, cancel_requested = 0
             WHERE id = ?1 AND state IN ('failed', 'canceled')",
            [id],
        )?;
        Ok(())
    }

    fn get_job(&self, id: &str) -> Result<Option<JobRecord>, StoreError> {
        let c = self.read();
        let r = c
            .query_row(
                &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
                [id],
                row_to_record,
            )
            .optional()?;
        r.transpose()
    }

    fn list_jobs(&self, f: &JobFilter) -> Result<Vec<(i64, JobRecord)>, StoreError> {
        // Only the conditions asked for, so that the planner walks an index: a key's holds
        // (holds_owner) for a key's list, jobs by (kind, state, seq) otherwise.
        // A key's page is chosen from its holds by (id, seq) alone; only the page's rows are
        // read whole.
        let mut args: Vec<Box<dyn rusqlite::ToSql>> = vec![Box::new(f.kind.as_str())];
        let mut sql = match &f.owner {
            Some(o) => {
                args.push(Box::new(o.clone()));
                "SELECT j.id FROM holds h INDEXED BY holds_owner CROSS JOIN jobs j ON j.id = h.id
                 WHERE j.kind = ?1 AND h.kind = 'job' AND h.owner = ?2"
                    .to_string()
            }
            None => format!(
                "SELECT {}, j.seq FROM jobs j WHERE j.kind = ?1",
                qualified("j")
            ),
        };
        for (c, v) in f.conditions() {
            args.push(match v {
                super::FilterArg::Text(t) => Box::new(t),
                super::FilterArg::Int(i) => Box::new(i),
            });
            sql.push_str(&format!(" AND j.{c} ?{}", args.len()));
        }
        args.push(Box::new(f.limit as i64));
        sql.push_str(&format!(" ORDER BY j.seq DESC LIMIT ?{}", args.len()));
        if f.owner.is_some() {
            sql = format!(
                "SELECT {}, j.seq FROM jobs j WHERE j.id IN ({sql}) ORDER BY j.seq DESC",
                qualified("j")
            );
        }
        let c = self.read();
        let mut st = c.prepare(&sql)?;
        let rows = st.query_map(rusqlite::params_from_iter(args.iter()), |r| {
            Ok((r.get::<_, i64>(23)?, row_to_record(r)?))
        })?;
        Ok(super::readable(rows.collect::<Result<Vec<_>, _>>()?))
    }

    fn list_scenes(
        &self,
        owner: Option<&str>,
        created_since: Option<i64>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<(i64, String, String, i64)>, StoreError> {
        let c = self.read();
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

    fn unfinished_jobs(&self) -> Result<Vec<JobRecord>, StoreError> {
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

    fn set_running(&self, id: &str, worker: &str, lease_ms: i64) -> Result<bool, StoreError> {
        let now = now_ms();
        let n = self.conn().execute(
            "UPDATE jobs SET state = 'running', started_at = ?2, worker = ?3, lease_until = ?4,
                 attempts = attempts + 1
             WHERE id = ?1 AND state = 'queued'",
            params![id, now, worker, now + lease_ms],
        )?;
        Ok(n == 1)
    }

    fn claim(
        &self,
        lane: Lane,
        up_to: Priority,
        worker: &str,
        lease_ms: i64,
    ) -> Result<Option<JobRecord>, StoreError> {
        let mut c = self.conn();
        // IMMEDIATE: the write lock from the start, so the row read is the row updated.
        let tx = c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
        let id: Option<String> = tx
            .query_row(
                &format!(
                    "SELECT id FROM jobs j WHERE state = 'queued' AND lane = ?1 AND priority <= ?2
                     ORDER BY priority, {}, seq LIMIT 1",
                    fair_order("rowid")
                ),
                params![lane_str(lane), up_to as i64],
                |r| r.get(0),
            )
            .optional()?;
        let Some(id) = id else {
            return Ok(None);
        };
        let now = now_ms();
        tx.execute(
            "UPDATE jobs SET state = 'running', started_at = ?2, worker = ?3, lease_until = ?4,
                 attempts = attempts + 1
             WHERE id = ?1",
            params![id, now, worker, now + lease_ms],
        )?;
        let r = tx
            .query_row(
                &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
                [&id],
                row_to_record,
            )
            .optional()?;
        tx.commit()?;
        r.transpose()
    }

    fn heartbeat(
        &self,
        worker: &str,
        running: &[String],
        lease_ms: i64,
    ) -> Result<Vec<String>, StoreError> {
        let ids = serde_json::to_string(running).expect("ids serialise");
        let c = self.conn();
        c.execute(
            "UPDATE jobs SET lease_until = ?2 WHERE worker = ?1 AND state = 'running'
                 AND id IN (SELECT value FROM json_each(?3))",
            params![worker, now_ms() + lease_ms, ids],
        )?;
        let mut st = c.prepare(
            "SELECT id FROM jobs WHERE worker = ?1 AND state = 'running' AND cancel_requested
                 AND id IN (SELECT value FROM json_each(?2))",
        )?;
        let ids = st
            .query_map(params![worker, ids], |r| r.get(0))?
            .collect::<Result<Vec<String>, _>>()?;
        Ok(ids)
    }

    fn reap_expired(&self) -> Result<Reaped, StoreError> {
        let mut c = self.conn();
        let tx = c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
        let now = now_ms();
        let expired: Vec<(String, i64)> = {
            let mut st = tx.prepare(
                "SELECT id, attempts FROM jobs
                 WHERE state = 'running' AND lease_until IS NOT NULL AND lease_until < ?1
                 ORDER BY seq",
            )?;
            st.query_map([now], |r| Ok((r.get(0)?, r.get(1)?)))?
                .collect::<Result<Vec<_>, _>>()?
        };
        let mut out = Reaped::default();
        let info = serde_json::json!({ "error_code": ErrorCode::WorkerLost }).to_string();
        for (id, attempts) in expired {
            if attempts >= MAX_ATTEMPTS as i64 {
                tx.execute(
                    "UPDATE jobs SET state = 'failed', stage = 'failed', finished_at = ?2,
                         error = ?3, info = ?4, worker = NULL, lease_until = NULL
                     WHERE id = ?1",
                    params![id, now, lost_message(attempts), info],
                )?;
                out.failed.push(id);
            } else {
                tx.execute(
                    "UPDATE jobs SET state = 'queued', progress = 0, stage = '', worker = NULL,
                         lease_until = NULL
                     WHERE id = ?1",
                    [&id],
                )?;
                out.requeued.push(id);
            }
        }
        tx.commit()?;
        Ok(out)
    }

    fn request_cancel(&self, id: &str) -> Result<Option<JobState>, StoreError> {
        let c = self.conn();
        let n = c.execute(
            "UPDATE jobs SET state = 'canceled', stage = 'canceled', error = 'canceled',
                 finished_at = ?2
             WHERE id = ?1 AND state = 'queued'",
            params![id, now_ms()],
        )?;
        if n == 1 {
            return Ok(Some(JobState::Canceled));
        }
        let n = c.execute(
            "UPDATE jobs SET cancel_requested = 1 WHERE id = ?1 AND state = 'running'",
            [id],
        )?;
        Ok((n == 1).then_some(JobState::Running))
    }

    fn count_queued(&self, kind: JobKind) -> Result<usize, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM jobs WHERE kind = ?1 AND state = 'queued'",
            [kind.as_str()],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    fn listen(&self, _on: Box<dyn Fn(StoreEvent) + Send + Sync>) -> Result<bool, StoreError> {
        Ok(false)
    }

    fn set_progress(&self, id: &str, progress: f32, stage: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET progress = ?2, stage = ?3 WHERE id = ?1",
            params![id, progress, stage],
        )?;
        Ok(())
    }

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
    ) -> Result<bool, StoreError> {
        let timings = serde_json::to_string(timings).expect("timings serialise");
        let n = self.conn().execute(
            "UPDATE jobs SET state = ?2, progress = ?3, timings = ?4, info = ?5, error = ?6,
                 artifact_type = ?7, artifact_path = ?8, finished_at = ?9, stage = ?10,
                 artifact_len = ?11, artifact_sha256 = ?12, worker = NULL, lease_until = NULL
             WHERE id = ?1
               AND (state = 'queued' OR (state = 'running' AND COALESCE(worker, '') = ?13))",
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
                worker,
            ],
        )?;
        Ok(n == 1)
    }

    fn set_queued(&self, id: &str, worker: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "UPDATE jobs SET state = 'queued', progress = 0, stage = '', worker = NULL,
                 lease_until = NULL, attempts = MAX(attempts - 1, 0)
             WHERE id = ?1 AND state = 'running' AND COALESCE(worker, '') = ?2",
            params![id, worker],
        )?;
        Ok(())
    }

    fn hold(&self, what: Held, id: &str, owner: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR IGNORE INTO holds (kind, id, owner, created_at) VALUES (?1, ?2, ?3, ?4)",
            params![what.as_str(), id, owner, now_ms()],
        )?;
        Ok(())
    }

    fn holds(&self, what: Held, id: &str, owner: &str) -> Result<bool, StoreError> {
        Ok(self
            .read()
            .query_row(
                "SELECT 1 FROM holds WHERE kind = ?1 AND id = ?2 AND owner = ?3",
                params![what.as_str(), id, owner],
                |_| Ok(()),
            )
            .optional()?
            .is_some())
    }

    fn fail_lost(&self, id: &str, sha256: Option<&str>, error: &str) -> Result<bool, StoreError> {
        let info = serde_json::json!({ "error_code": ErrorCode::Store }).to_string();
        let n = self.conn().execute(
            "UPDATE jobs SET state = 'failed', stage = 'failed', error = ?3, info = ?4,
                 finished_at = ?5, artifact_type = NULL, artifact_path = NULL
             WHERE id = ?1 AND state = 'succeeded' AND artifact_sha256 IS ?2",
            params![id, sha256, error, info, now_ms()],
        )?;
        Ok(n == 1)
    }

    fn first_holder(&self, what: Held, id: &str) -> Result<Option<String>, StoreError> {
        Ok(self
            .read()
            .query_row(
                "SELECT owner FROM holds WHERE kind = ?1 AND id = ?2 ORDER BY rowid LIMIT 1",
                params![what.as_str(), id],
                |r| r.get(0),
            )
            .optional()?)
    }

    fn hold_job_within(
        &self,
        id: &str,
        owner: &str,
        cap: usize,
    ) -> Result<Result<(), usize>, StoreError> {
        let mut c = self.conn();
        let tx = c.transaction_with_behavior(rusqlite::TransactionBehavior::Immediate)?;
        // Held and queued, running or being submitted: counted already. Held but finished
        // (a failed bake asked for again runs again): a new job, counted like one.
        let held = tx
            .query_row(
                "SELECT 1 FROM holds h LEFT JOIN jobs j ON j.id = h.id
                 WHERE h.kind = 'job' AND h.id = ?1 AND h.owner = ?2
                   AND (j.id IS NULL OR j.state IN ('queued', 'running'))",
                params![id, owner],
                |_| Ok(()),
            )
            .optional()?
            .is_some();
        if !held {
            let now = now_ms();
            // The jobs queued or running anywhere (a few hundred at most: the queues are
            // capped) held by the key, and the key's recent holds whose job is being
            // submitted: neither reads the key's finished jobs.
            let n: i64 = tx.query_row(
                "SELECT (SELECT COUNT(*) FROM jobs j CROSS JOIN holds h
                         ON h.kind = 'job' AND h.id = j.id AND h.owner = ?1
                         WHERE j.state IN ('queued', 'running'))
                      + (SELECT COUNT(*) FROM holds h
                         WHERE h.owner = ?1 AND h.kind = 'job' AND h.created_at > ?2
                           AND NOT EXISTS (SELECT 1 FROM jobs j WHERE j.id = h.id))",
                params![owner, now - super::SUBMITTING_MS],
                |r| r.get(0),
            )?;
            if n as usize >= cap {
                return Ok(Err(n as usize));
            }
            tx.execute(
                "INSERT OR IGNORE INTO holds (kind, id, owner, created_at)
                 VALUES ('job', ?1, ?2, ?3)",
                params![id, owner, now],
            )?;
        }
        tx.commit()?;
        Ok(Ok(()))
    }

    fn expire_idempotency(&self, before_ms: i64) -> Result<usize, StoreError> {
        Ok(self
            .conn()
            .execute("DELETE FROM idempotency WHERE created_at < ?1", [before_ms])?)
    }

    fn active_jobs_of(&self, owner: &str) -> Result<usize, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM holds h JOIN jobs j ON j.id = h.id
             WHERE h.kind = 'job' AND h.owner = ?1 AND j.state IN ('queued', 'running')",
            [owner],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    fn holders(&self, what: Held, id: &str) -> Result<usize, StoreError> {
        let n: i64 = self.read().query_row(
            "SELECT COUNT(*) FROM holds WHERE kind = ?1 AND id = ?2",
            params![what.as_str(), id],
            |r| r.get(0),
        )?;
        Ok(n as usize)
    }

    fn held_bytes(&self, owner: &str) -> Result<u64, StoreError> {
        let n: i64 = self.read().query_row(
            "SELECT
               (SELECT COALESCE(SUM(j.artifact_len), 0) FROM holds h JOIN jobs j ON j.id = h.id
                 WHERE h.owner = ?1 AND h.kind = 'job')
             + (SELECT COALESCE(SUM(length(s.scene_json)), 0) FROM holds h
                 JOIN scenes s ON s.id = h.id WHERE h.owner = ?1 AND h.kind = 'scene')
             + (SELECT COALESCE(SUM(length(f.bytes)), 0) FROM holds h
                 JOIN scene_files f ON f.scene_id = h.id WHERE h.owner = ?1 AND h.kind = 'scene')",
            params![owner],
            |r| r.get(0),
        )?;
        Ok(n.max(0) as u64)
    }

    fn release_all(&self, what: Held, id: &str) -> Result<(), StoreError> {
        self.conn().execute(
            "DELETE FROM holds WHERE kind = ?1 AND id = ?2",
            params![what.as_str(), id],
        )?;
        Ok(())
    }

    fn unheld_scenes(&self, before_ms: i64) -> Result<Vec<String>, StoreError> {
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

    fn release(&self, what: Held, id: &str, owner: &str) -> Result<usize, StoreError> {
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

    fn touch(&self, uses: &[(String, i64)]) -> Result<(), StoreError> {
        let mut c = self.conn();
        let tx = c.transaction()?;
        for (id, at) in uses {
            tx.execute(
                "UPDATE jobs SET accessed_at = MAX(COALESCE(accessed_at, 0), ?2) WHERE id = ?1",
                params![id, at],
            )?;
        }
        tx.commit()?;
        Ok(())
    }

    fn delete_job_record(&self, id: &str) -> Result<Option<Option<String>>, StoreError> {
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
            return Ok(None);
        };
        tx.execute("DELETE FROM jobs WHERE id = ?1", [id])?;
        tx.execute("DELETE FROM holds WHERE kind = 'job' AND id = ?1", [id])?;
        tx.execute("DELETE FROM idempotency WHERE job_id = ?1", [id])?;
        tx.commit()?;
        Ok(Some(path))
    }

    fn finished_before(&self, kind: JobKind, before_ms: i64) -> Result<Vec<String>, StoreError> {
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

    fn renders_by_last_use(&self) -> Result<Vec<(String, u64)>, StoreError> {
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

    fn delete_scene(&self, id: &str) -> Result<bool, StoreError> {
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

    fn scene_in_use(&self, id: &str) -> Result<bool, StoreError> {
        let n: i64 = self.conn().query_row(
            "SELECT COUNT(*) FROM jobs WHERE scene_id = ?1 AND state IN ('queued', 'running')",
            [id],
            |r| r.get(0),
        )?;
        Ok(n > 0)
    }

    fn idempotency(&self, key: &str) -> Result<Option<(String, String)>, StoreError> {
        Ok(self
            .read()
            .query_row(
                "SELECT request_hash, job_id FROM idempotency WHERE key = ?1",
                [key],
                |r| Ok((r.get(0)?, r.get(1)?)),
            )
            .optional()?)
    }

    fn put_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR IGNORE INTO idempotency (key, request_hash, job_id, created_at)
             VALUES (?1, ?2, ?3, ?4)",
            params![key, request_hash, job_id, now_ms()],
        )?;
        Ok(())
    }

    fn replace_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.conn().execute(
            "INSERT OR REPLACE INTO idempotency (key, request_hash, job_id, created_at)
             VALUES (?1, ?2, ?3, ?4)",
            params![key, request_hash, job_id, now_ms()],
        )?;
        Ok(())
    }
}

type RowResult = Result<JobRecord, StoreError>;

/// [`COLUMNS`], each prefixed with `table.`.
pub(super) fn qualified(table: &str) -> String {
    COLUMNS
        .split(',')
        .map(|c| format!("{table}.{}", c.trim()))
        .collect::<Vec<_>>()
        .join(", ")
}

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
    let lane: String = r.get(19)?;
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
            lane: parse_lane(&lane)?,
            priority: parse_priority(r.get(20)?)?,
            worker: r.get(21)?,
            attempts: r.get::<_, i64>(22)?.max(0) as u32,
        })
    })();
    Ok(rec)
}

/// A lane as stored.
pub(super) fn lane_str(l: Lane) -> &'static str {
    match l {
        Lane::Cpu => "cpu",
        Lane::Gpu => "gpu",
    }
}

pub(super) fn parse_lane(s: &str) -> Result<Lane, StoreError> {
    match s {
        "cpu" => Ok(Lane::Cpu),
        "gpu" => Ok(Lane::Gpu),
        _ => Err(StoreError::Corrupt(format!("lane '{s}'"))),
    }
}

pub(super) fn parse_priority(p: i64) -> Result<Priority, StoreError> {
    match p {
        0 => Ok(Priority::Small),
        1 => Ok(Priority::Render),
        2 => Ok(Priority::Bake),
        _ => Err(StoreError::Corrupt(format!("priority {p}"))),
    }
}

/// The error of a job failed because its workers' leases ran out `attempts` times.
pub(super) fn lost_message(attempts: i64) -> String {
    format!(
        "the worker running it stopped answering {attempts} times (its lease ran out each \
         time); not tried again"
    )
}

/// The claim order's middle term: how many jobs of the job's key (its first holder) are
/// running, so that within a priority the key running fewest goes first (and among its jobs,
/// the oldest); `order` is what orders a job's holds (`rowid` in SQLite, `seq` in
/// PostgreSQL). The queue of one process orders keys by start-time fair queueing
/// ([`crate::jobs::queue`]); across processes this is its equivalent: a key that queued a
/// hundred jobs does not hold the workers while another key's one job waits.
pub(super) fn fair_order(order: &str) -> String {
    let owner = |job: &str| {
        format!(
            "(SELECT h.owner FROM holds h WHERE h.kind = 'job' AND h.id = {job}.id \
             ORDER BY h.{order} LIMIT 1)"
        )
    };
    format!(
        "(SELECT COUNT(*) FROM jobs r WHERE r.state = 'running' \
          AND {} IS NOT DISTINCT FROM {})",
        owner("r"),
        owner("j")
    )
}
