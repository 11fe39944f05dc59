//! The PostgreSQL back-end of [`JobDb`], shared by API and worker processes
//! (`--database postgres://…`).
//!
//! One file over 1,000 lines: the schema and one short SQL statement for each of the
//! interface's methods, beside the connection pool they all go through; its seam, should it
//! grow further, is the pool (`Conn`, `Health`, `PgDb::call`) into a module of its own.
//!
//! The synchronous `postgres` client must not run inside an async runtime, and the store's
//! callers include the HTTP handlers; so each connection lives on a thread of its own (a small
//! pool, [`POOL`] threads) and a call is a closure sent to whichever is free, its answer sent
//! back. A call that finds its connection lost (the server restarted, a network blip) connects
//! again and runs once more, for up to [`RECONNECT_FOR`]; every state change is conditional
//! (on the state, and on the worker that holds the job), so running one twice changes nothing
//! the first did not.
//!
//! A call made for an HTTP request (on the async runtime, or a blocking task of it) never
//! holds its thread longer than [`API_WAIT`] without a connection: it gives up while queued
//! behind busy connections or while reconnecting, and answers `store-unavailable` (503 with
//! `Retry-After`); while the database is known to be down ([`Health`]) such calls fail at
//! once, save one probe a second that finds out when it is back. The wait itself is made in
//! `block_in_place`, so the runtime moves its other tasks (`/healthz` among them) to another
//! thread. Workers' calls (their own threads) keep trying for [`RECONNECT_FOR`], so that a
//! restart of the database does not fail the jobs they run.
//!
//! Claiming is `SELECT … FOR UPDATE SKIP LOCKED` in one transaction with the update, so two
//! workers never take one job and neither waits for the other's lock. Leases are compared
//! with the database's clock, not the workers'. A trigger sends `NOTIFY caustica_jobs` (the
//! job's id) when a job's state or progress changes, `NOTIFY caustica_cancel` (its id) when
//! its cancellation is asked for, and `NOTIFY caustica_queue` (its lane) when one is queued:
//! workers wake on the last and stop a job on the second, and the API replica that holds a
//! client's connection follows the first ([`JobDb::listen`]).

use super::sqlite::{fair_order, lane_str, lost_message, parse_lane, parse_priority};
use super::{FilterArg, wait_outside_runtime};
use super::{
    Held, JobDb, JobFilter, JobRecord, MAX_ATTEMPTS, Reaped, StoreError, StoreEvent,
    StoredArtifact, StoredScene, now_ms,
};
use crate::jobs::job::{ErrorCode, JobKind, JobState, Priority};
use crate::methods::{Lane, Method};
use postgres::{Client, NoTls, Row};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

/// Connections (threads) in the pool.
pub const POOL: usize = 4;
/// How long a worker's call keeps trying to reach a database that went away.
pub const RECONNECT_FOR: Duration = Duration::from_secs(60);
/// How long a call made for an HTTP request waits for a connection (queued, or reconnecting)
/// before it gives up with [`StoreError::Unavailable`].
pub const API_WAIT: Duration = Duration::from_secs(2);
/// How long connecting may take (a database host that drops packets, not one that refuses).
const CONNECT_TIMEOUT: Duration = Duration::from_secs(2);
/// While the database is down, how often an HTTP request's call may try it.
const PROBE_EVERY: Duration = Duration::from_secs(1);
/// Longest an HTTP request waits for the answer of a call a connection has taken (a
/// statement behind a lock, a connection that stopped answering); the call itself goes on.
const API_ANSWER: Duration = Duration::from_secs(20);

/// Whether the database was reachable at the last call: set down by a lost connection, up by
/// any call that succeeds.
#[derive(Default)]
struct Health {
    /// When the current outage was first seen.
    down_since: Mutex<Option<Instant>>,
    /// When an HTTP request's call last tried the database during the outage.
    last_probe: Mutex<Option<Instant>>,
}

impl Health {
    fn lost(&self) {
        let mut d = self.down_since.lock().unwrap_or_else(|e| e.into_inner());
        d.get_or_insert_with(Instant::now);
    }

    fn ok(&self) {
        *self.down_since.lock().unwrap_or_else(|e| e.into_inner()) = None;
    }

    /// How long the database has been down, when it is and no probe is due: the call should
    /// not try it.
    fn skip(&self) -> Option<Duration> {
        let since = (*self.down_since.lock().unwrap_or_else(|e| e.into_inner()))?;
        let mut probe = self.last_probe.lock().unwrap_or_else(|e| e.into_inner());
        if probe.is_some_and(|t| t.elapsed() < PROBE_EVERY) {
            return Some(since.elapsed());
        }
        *probe = Some(Instant::now());
        None
    }
}

thread_local! {
    /// Set while [`as_worker`] runs: this thread's calls wait as a worker's do.
    static WORKER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `f` with this thread's store calls made as a worker's (retried for
/// [`RECONNECT_FOR`]), even on the async runtime: starting and stopping the job system.
pub fn as_worker<T>(f: impl FnOnce() -> T) -> T {
    let before = WORKER.with(|w| w.replace(true));
    let r = f();
    WORKER.with(|w| w.set(before));
    r
}

/// Whether the caller is the async runtime (an HTTP request) rather than a worker's thread.
fn for_a_request() -> bool {
    !WORKER.with(|w| w.get()) && tokio::runtime::Handle::try_current().is_ok()
}

/// A queued call's state: queued, taken by a connection, or given up by its caller.
const QUEUED: u8 = 0;
const TAKEN: u8 = 1;
const ABANDONED: u8 = 2;

/// Schema migrations, applied in order under an advisory lock (several processes may start
/// at once); `caustica_migrations` records which ran.
const MIGRATIONS: &[&str] = &[
    r#"
    CREATE TABLE scenes (
        id TEXT PRIMARY KEY,
        seq BIGSERIAL NOT NULL,
        scene_json BYTEA NOT NULL,
        created_at BIGINT NOT NULL
    );
    CREATE TABLE scene_files (
        scene_id TEXT NOT NULL REFERENCES scenes(id),
        name TEXT NOT NULL,
        bytes BYTEA NOT NULL,
        PRIMARY KEY (scene_id, name)
    );
    CREATE SEQUENCE jobs_seq;
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
        created_at BIGINT NOT NULL,
        started_at BIGINT,
        finished_at BIGINT,
        seq BIGINT NOT NULL DEFAULT nextval('jobs_seq'),
        artifact_len BIGINT,
        artifact_sha256 TEXT,
        accessed_at BIGINT,
        lane TEXT NOT NULL DEFAULT 'cpu',
        priority INTEGER NOT NULL DEFAULT 2,
        worker TEXT,
        lease_until BIGINT,
        attempts INTEGER NOT NULL DEFAULT 0,
        cancel_requested BOOLEAN NOT NULL DEFAULT false
    );
    CREATE INDEX jobs_claim ON jobs(state, lane, priority, seq);
    CREATE INDEX jobs_kind_state ON jobs(kind, state);
    CREATE INDEX jobs_worker ON jobs(worker) WHERE worker IS NOT NULL;
    CREATE TABLE idempotency (
        key TEXT PRIMARY KEY,
        request_hash TEXT NOT NULL,
        job_id TEXT NOT NULL
    );
    CREATE TABLE holds (
        kind TEXT NOT NULL,
        id TEXT NOT NULL,
        owner TEXT NOT NULL,
        seq BIGSERIAL NOT NULL,
        PRIMARY KEY (kind, id, owner)
    );
    CREATE FUNCTION caustica_now_ms() RETURNS BIGINT LANGUAGE sql VOLATILE AS
        $$ SELECT (extract(epoch FROM clock_timestamp()) * 1000)::BIGINT $$;
    CREATE FUNCTION caustica_notify() RETURNS trigger LANGUAGE plpgsql AS $$
    BEGIN
        IF TG_OP = 'INSERT' OR NEW.state IS DISTINCT FROM OLD.state
           OR NEW.progress IS DISTINCT FROM OLD.progress OR NEW.stage IS DISTINCT FROM OLD.stage THEN
            PERFORM pg_notify('caustica_jobs', NEW.id);
        END IF;
        IF TG_OP = 'UPDATE' AND NEW.cancel_requested AND NOT OLD.cancel_requested THEN
            PERFORM pg_notify('caustica_cancel', NEW.id);
        END IF;
        IF NEW.state = 'queued' AND (TG_OP = 'INSERT' OR OLD.state <> 'queued') THEN
            PERFORM pg_notify('caustica_queue', NEW.lane);
        END IF;
        RETURN NULL;
    END $$;
    CREATE TRIGGER jobs_notify AFTER INSERT OR UPDATE ON jobs
        FOR EACH ROW EXECUTE FUNCTION caustica_notify();
"#,
    r#"
    ALTER TABLE holds ADD COLUMN created_at BIGINT NOT NULL DEFAULT 0;
    CREATE INDEX holds_owner ON holds(owner, kind, created_at, id);
    CREATE INDEX jobs_kind_seq ON jobs(kind, seq);
    CREATE INDEX jobs_kind_state_seq ON jobs(kind, state, seq);
    CREATE INDEX jobs_scene_state ON jobs(scene_id, state);
    ALTER TABLE idempotency ADD COLUMN created_at BIGINT NOT NULL DEFAULT 0;
    UPDATE idempotency SET created_at = caustica_now_ms();
    CREATE INDEX idempotency_job ON idempotency(job_id);
    CREATE INDEX idempotency_created ON idempotency(created_at);
"#,
];

/// The columns [`row_to_record`] reads, in its order.
const COLUMNS: &str = "id, kind, method, scene_id, object, params, state, progress, stage,
    timings, info, error, artifact_type, artifact_path, created_at, started_at, finished_at,
    artifact_len, artifact_sha256, lane, priority, worker, attempts";

type Task = Box<dyn FnOnce(&mut Conn) + Send>;

/// One pooled connection, made when first needed and again after it is lost.
struct Conn {
    url: String,
    client: Option<Client>,
}

impl Conn {
    fn client(&mut self) -> Result<&mut Client, postgres::Error> {
        if self.client.as_ref().is_none_or(|c| c.is_closed()) {
            self.client = Some(connect(&self.url)?);
        }
        Ok(self.client.as_mut().expect("connected above"))
    }
}

/// A connection to `url`, giving up after [`CONNECT_TIMEOUT`] unless the URL sets its own.
fn connect(url: &str) -> Result<Client, postgres::Error> {
    let mut cfg: postgres::Config = url.parse()?;
    if cfg.get_connect_timeout().is_none() {
        cfg.connect_timeout(CONNECT_TIMEOUT);
    }
    cfg.connect(NoTls)
}

/// Whether `e` means the connection is gone (worth connecting again), not that the statement
/// was refused.
fn is_connection_error(e: &postgres::Error) -> bool {
    if e.is_closed() {
        return true;
    }
    match e.code() {
        // Class 08: connection exceptions; 57P01..03: the server is shutting down or starting.
        Some(c) => c.code().starts_with("08") || matches!(c.code(), "57P01" | "57P02" | "57P03"),
        // No SQLSTATE: an I/O error on the socket, or the server could not be reached (not a
        // type mismatch or another mistake of the caller's, which no retry mends).
        None => {
            std::error::Error::source(e).is_some_and(|s| s.is::<std::io::Error>())
                || e.to_string().starts_with("error connecting")
                || e.to_string().starts_with("connection closed")
        }
    }
}

pub struct PgDb {
    url: String,
    tasks: Mutex<Option<mpsc::Sender<Task>>>,
    /// Set when the store is dropped: the listener stops.
    stop: Arc<AtomicBool>,
    health: Arc<Health>,
}

impl Drop for PgDb {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Dropping the sender ends the pool's threads once their current task is done.
        self.tasks.lock().unwrap_or_else(|e| e.into_inner()).take();
    }
}

impl PgDb {
    /// Connects to `url` (waiting up to [`RECONNECT_FOR`] for the server to accept) and runs
    /// the migrations.
    pub fn open(url: &str) -> Result<PgDb, StoreError> {
        let (tx, rx) = mpsc::channel::<Task>();
        let rx = Arc::new(Mutex::new(rx));
        for i in 0..POOL {
            let rx = rx.clone();
            let url = url.to_string();
            std::thread::Builder::new()
                .name(format!("caustica-pg-{i}"))
                .spawn(move || {
                    let mut conn = Conn { url, client: None };
                    loop {
                        let task = rx.lock().unwrap_or_else(|e| e.into_inner()).recv();
                        match task {
                            Ok(t) => t(&mut conn),
                            Err(_) => return,
                        }
                    }
                })
                .map_err(StoreError::Io)?;
        }
        let db = PgDb {
            url: url.to_string(),
            tasks: Mutex::new(Some(tx)),
            stop: Arc::new(AtomicBool::new(false)),
            health: Arc::default(),
        };
        // However it is called, opening waits for the database as a worker does.
        db.call(false, |c| {
            let mut tx = c.transaction()?;
            tx.execute("SELECT pg_advisory_xact_lock(72431)", &[])?;
            tx.batch_execute(
                "CREATE TABLE IF NOT EXISTS caustica_migrations (version INTEGER PRIMARY KEY)",
            )?;
            let done: i32 = tx
                .query_one(
                    "SELECT COALESCE(MAX(version), 0) FROM caustica_migrations",
                    &[],
                )?
                .get(0);
            for (i, m) in MIGRATIONS.iter().enumerate().skip(done as usize) {
                tx.batch_execute(m)?;
                tx.execute(
                    "INSERT INTO caustica_migrations (version) VALUES ($1)",
                    &[&((i + 1) as i32)],
                )?;
            }
            tx.commit()
        })?;
        Ok(db)
    }

    /// Points idempotency key `key` at `job_id`; `on_conflict` says what an existing key does
    /// (keeps its job, or is replaced).
    fn write_idempotency(
        &self,
        on_conflict: &'static str,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        let (k, h, j) = (
            key.to_string(),
            request_hash.to_string(),
            job_id.to_string(),
        );
        self.run(move |c| {
            c.execute(
                &format!(
                    "INSERT INTO idempotency (key, request_hash, job_id, created_at) \
                     VALUES ($1, $2, $3, caustica_now_ms()) {on_conflict}"
                ),
                &[&k, &h, &j],
            )?;
            Ok(())
        })
    }

    /// Runs `f` on a pooled connection; on a lost connection, connects again and runs it once
    /// more, for up to [`RECONNECT_FOR`] (a worker's call) or [`API_WAIT`] (an HTTP
    /// request's, which also gives up queued that long, and fails at once while the database
    /// is known to be down).
    fn run<T: Send + 'static>(
        &self,
        f: impl FnMut(&mut Client) -> Result<T, postgres::Error> + Send + 'static,
    ) -> Result<T, StoreError> {
        self.call(for_a_request(), f)
    }

    /// [`PgDb::run`], for an HTTP request (`api`) or a worker.
    fn call<T: Send + 'static>(
        &self,
        api: bool,
        f: impl FnMut(&mut Client) -> Result<T, postgres::Error> + Send + 'static,
    ) -> Result<T, StoreError> {
        use std::sync::atomic::AtomicU8;
        if api && let Some(down) = self.health.skip() {
            return Err(StoreError::Unavailable(format!(
                "the database has been unreachable for {:.0} s",
                down.as_secs_f64()
            )));
        }
        let deadline = Instant::now() + if api { API_WAIT } else { RECONNECT_FOR };
        let state = Arc::new(AtomicU8::new(QUEUED));
        let (back, answer) = mpsc::sync_channel(1);
        let (mut f, task_state, health) = (f, state.clone(), self.health.clone());
        let task: Task = Box::new(move |conn: &mut Conn| {
            if task_state
                .compare_exchange(QUEUED, TAKEN, Ordering::SeqCst, Ordering::SeqCst)
                .is_err()
            {
                return;
            }
            let mut wait = Duration::from_millis(50);
            let r = loop {
                let r = conn.client().and_then(&mut f);
                match r {
                    Err(e) if is_connection_error(&e) => {
                        health.lost();
                        if Instant::now() + wait >= deadline {
                            break Err(e);
                        }
                        tracing::warn!(
                            error = %super::pg_detail(&e),
                            "database connection lost; connecting again"
                        );
                        conn.client = None;
                        std::thread::sleep(wait);
                        wait = (wait * 2).min(Duration::from_secs(2));
                    }
                    r => {
                        health.ok();
                        break r;
                    }
                }
            };
            let _ = back.send(r);
        });
        let sent = self
            .tasks
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
            .map(|t| t.send(task).is_ok());
        if sent != Some(true) {
            return Err(StoreError::Unavailable("the store is closed".into()));
        }
        let got = wait_outside_runtime(|| {
            loop {
                match answer.recv_timeout(Duration::from_millis(25)) {
                    Ok(r) => return Some(r),
                    Err(mpsc::RecvTimeoutError::Disconnected) => return None,
                    Err(mpsc::RecvTimeoutError::Timeout) => {
                        // An HTTP request stops waiting for a taken call after API_ANSWER.
                        if api && Instant::now() >= deadline + API_ANSWER {
                            return None;
                        }
                        // Still queued past the deadline: give it up (a connection that takes
                        // it now skips it); taken: wait for its answer.
                        if Instant::now() >= deadline
                            && state
                                .compare_exchange(
                                    QUEUED,
                                    ABANDONED,
                                    Ordering::SeqCst,
                                    Ordering::SeqCst,
                                )
                                .is_ok()
                        {
                            return None;
                        }
                    }
                }
            }
        });
        match got {
            Some(Ok(v)) => Ok(v),
            Some(Err(e)) if is_connection_error(&e) => {
                Err(StoreError::Unavailable(super::pg_detail(&e)))
            }
            Some(Err(e)) => Err(e.into()),
            None if state.load(Ordering::SeqCst) == ABANDONED => {
                Err(StoreError::Unavailable(format!(
                    "no database connection was free within {} s",
                    API_WAIT.as_secs()
                )))
            }
            None if api && state.load(Ordering::SeqCst) == TAKEN => {
                Err(StoreError::Unavailable(format!(
                    "the database did not answer within {} s",
                    (API_WAIT + API_ANSWER).as_secs()
                )))
            }
            None => Err(StoreError::Unavailable(
                "the database thread stopped".into(),
            )),
        }
    }

    /// The record of job `id`, if there is one.
    fn record(&self, id: &str) -> Result<Option<JobRecord>, StoreError> {
        let id = id.to_string();
        let row = self.run(move |c| {
            c.query_opt(&format!("SELECT {COLUMNS} FROM jobs WHERE id = $1"), &[&id])
        })?;
        row.map(|r| row_to_record(&r)).transpose()
    }
}

fn row_to_record(r: &Row) -> Result<JobRecord, StoreError> {
    let parse = |what: &str, s: &str| -> Result<serde_json::Value, StoreError> {
        serde_json::from_str(s).map_err(|e| StoreError::Corrupt(format!("{what}: {e}")))
    };
    let get = |i: usize| -> Result<String, StoreError> { Ok(r.try_get::<_, String>(i)?) };
    let kind = get(1)?;
    let method = get(2)?;
    let state = get(6)?;
    let timings = get(9)?;
    Ok(JobRecord {
        id: get(0)?,
        kind: JobKind::parse(&kind).ok_or_else(|| StoreError::Corrupt(format!("kind '{kind}'")))?,
        method: Method::parse(&method).map_err(|e| StoreError::Corrupt(e.to_string()))?,
        scene_id: get(3)?,
        object: r.try_get(4)?,
        params: parse("params", &get(5)?)?,
        state: JobState::parse(&state)
            .ok_or_else(|| StoreError::Corrupt(format!("state '{state}'")))?,
        progress: r.try_get(7)?,
        stage: get(8)?,
        timings: serde_json::from_str(&timings)
            .map_err(|e| StoreError::Corrupt(format!("timings: {e}")))?,
        info: parse("info", &get(10)?)?,
        error: r.try_get(11)?,
        artifact_type: r.try_get(12)?,
        artifact_path: r.try_get(13)?,
        created_at: r.try_get(14)?,
        started_at: r.try_get(15)?,
        finished_at: r.try_get(16)?,
        artifact_len: r.try_get::<_, Option<i64>>(17)?.map(|n| n as u64),
        artifact_sha256: r.try_get(18)?,
        lane: parse_lane(&get(19)?)?,
        priority: parse_priority(r.try_get::<_, i32>(20)? as i64)?,
        worker: r.try_get(21)?,
        attempts: r.try_get::<_, i32>(22)?.max(0) as u32,
    })
}

impl JobDb for PgDb {
    fn backend(&self) -> &'static str {
        "postgres"
    }

    fn reachable(&self) -> Result<(), StoreError> {
        self.run(|c| c.simple_query("SELECT 1").map(|_| ()))
    }

    fn put_scene(
        &self,
        id: &str,
        scene_json: &[u8],
        files: &[(String, Vec<u8>)],
        owner: &str,
    ) -> Result<(), StoreError> {
        let (id, json, files, owner) = (
            id.to_string(),
            scene_json.to_vec(),
            files.to_vec(),
            owner.to_string(),
        );
        self.run(move |c| {
            let mut tx = c.transaction()?;
            tx.execute(
                "INSERT INTO holds (kind, id, owner) VALUES ('scene', $1, $2)
                 ON CONFLICT DO NOTHING",
                &[&id, &owner],
            )?;
            let n = tx.execute(
                "INSERT INTO scenes (id, scene_json, created_at) VALUES ($1, $2, $3)
                 ON CONFLICT DO NOTHING",
                &[&id, &json, &now_ms()],
            )?;
            if n == 1 {
                for (name, bytes) in &files {
                    tx.execute(
                        "INSERT INTO scene_files (scene_id, name, bytes) VALUES ($1, $2, $3)",
                        &[&id, name, bytes],
                    )?;
                }
            }
            tx.commit()
        })
    }

    fn scene_exists(&self, id: &str) -> Result<bool, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            Ok(c.query_opt("SELECT 1 FROM scenes WHERE id = $1", &[&id])?
                .is_some())
        })
    }

    fn get_scene(&self, id: &str) -> Result<Option<StoredScene>, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let mut tx = c.transaction()?;
            let Some(row) = tx.query_opt(
                "SELECT scene_json, created_at FROM scenes WHERE id = $1",
                &[&id],
            )?
            else {
                return Ok(None);
            };
            let files = tx
                .query(
                    "SELECT name, bytes FROM scene_files WHERE scene_id = $1 ORDER BY name",
                    &[&id],
                )?
                .iter()
                .map(|r| (r.get(0), r.get(1)))
                .collect();
            tx.commit()?;
            Ok(Some(StoredScene {
                id: id.clone(),
                scene_json: row.get(0),
                files,
                created_at: row.get(1),
            }))
        })
    }

    fn insert_job(&self, r: &JobRecord) -> Result<(), StoreError> {
        let r = r.clone();
        self.run(move |c| {
            c.execute(
                "INSERT INTO jobs (id, kind, method, scene_id, object, params, state, created_at,
                                   lane, priority)
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10)",
                &[
                    &r.id,
                    &r.kind.as_str(),
                    &r.method.name(),
                    &r.scene_id,
                    &r.object,
                    &r.params.to_string(),
                    &r.state.as_str(),
                    &r.created_at,
                    &lane_str(r.lane),
                    &(r.priority as i32),
                ],
            )?;
            Ok(())
        })
    }

    fn requeue(&self, id: &str) -> Result<(), StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            c.execute(
                "UPDATE jobs SET state = 'queued', progress = 0, stage = '', error = NULL,
                     started_at = NULL, finished_at = NULL, timings = '[]', worker = NULL,
                     lease_until = NULL, attempts = 0, cancel_requested = false,
                     seq = nextval('jobs_seq')
                 WHERE id = $1 AND state IN ('failed', 'canceled')",
                &[&id],
            )?;
            Ok(())
        })
    }

    fn get_job(&self, id: &str) -> Result<Option<JobRecord>, StoreError> {
        self.record(id)
    }

    fn list_jobs(&self, f: &JobFilter) -> Result<Vec<(i64, JobRecord)>, StoreError> {
        use postgres::types::ToSql;
        // Only the conditions asked for (as the SQLite back-end), so that the planner walks
        // an index: a key's holds for a key's list, jobs by (kind, state, seq) otherwise.
        let f = f.clone();
        let rows = self.run(move |c| {
            let mut args: Vec<Box<dyn ToSql + Sync>> = vec![Box::new(f.kind.as_str())];
            let mut sql = match &f.owner {
                Some(o) => {
                    args.push(Box::new(o.clone()));
                    format!(
                        "SELECT {}, j.seq FROM holds h JOIN jobs j ON j.id = h.id
                         WHERE j.kind = $1 AND h.kind = 'job' AND h.owner = $2",
                        super::sqlite::qualified("j")
                    )
                }
                None => format!(
                    "SELECT {}, j.seq FROM jobs j WHERE j.kind = $1",
                    super::sqlite::qualified("j")
                ),
            };
            for (c, v) in f.conditions() {
                args.push(match v {
                    FilterArg::Text(t) => Box::new(t),
                    FilterArg::Int(i) => Box::new(i),
                });
                sql.push_str(&format!(" AND j.{c} ${}", args.len()));
            }
            args.push(Box::new(f.limit as i64));
            sql.push_str(&format!(" ORDER BY j.seq DESC LIMIT ${}", args.len()));
            let refs: Vec<&(dyn ToSql + Sync)> = args.iter().map(|a| a.as_ref()).collect();
            c.query(&sql, &refs)
        })?;
        Ok(super::readable(
            rows.iter().map(|r| (r.get::<_, i64>(23), row_to_record(r))),
        ))
    }

    fn list_scenes(
        &self,
        owner: Option<&str>,
        created_since: Option<i64>,
        before: Option<i64>,
        limit: usize,
    ) -> Result<Vec<(i64, String, String, i64)>, StoreError> {
        let owner = owner.map(str::to_string);
        self.run(move |c| {
            let rows = c.query(
                "SELECT seq, id,
                        COALESCE(convert_from(scene_json, 'UTF8')::jsonb ->> 'name', ''),
                        created_at
                 FROM scenes s
                 WHERE ($1::TEXT IS NULL OR EXISTS (SELECT 1 FROM holds h
                        WHERE h.kind = 'scene' AND h.id = s.id AND h.owner = $1))
                   AND ($2::BIGINT IS NULL OR created_at >= $2)
                   AND ($3::BIGINT IS NULL OR seq < $3)
                 ORDER BY seq DESC
                 LIMIT $4",
                &[&owner, &created_since, &before, &(limit as i64)],
            )?;
            Ok(rows
                .iter()
                .map(|r| (r.get(0), r.get(1), r.get(2), r.get(3)))
                .collect())
        })
    }

    fn unfinished_jobs(&self) -> Result<Vec<JobRecord>, StoreError> {
        let ids: Vec<String> = self.run(|c| {
            Ok(c.query(
                "SELECT id FROM jobs WHERE state IN ('queued', 'running') ORDER BY seq",
                &[],
            )?
            .iter()
            .map(|r| r.get(0))
            .collect())
        })?;
        let mut out = Vec::new();
        for id in ids {
            match self.record(&id) {
                Ok(Some(r)) => out.push(r),
                Ok(None) => {}
                Err(StoreError::Corrupt(e)) => {
                    tracing::error!(job = %id, error = %e, "quarantining an unreadable job record");
                    let msg = format!("quarantined at start: corrupt record: {e}");
                    self.run(move |c| {
                        c.execute(
                            "UPDATE jobs SET state = 'failed', finished_at = $2, stage = 'failed',
                                 error = $3
                             WHERE id = $1",
                            &[&id, &now_ms(), &msg],
                        )
                    })?;
                }
                Err(e) => return Err(e),
            }
        }
        Ok(out)
    }

    fn set_running(&self, id: &str, worker: &str, lease_ms: i64) -> Result<bool, StoreError> {
        let (id, worker) = (id.to_string(), worker.to_string());
        self.run(move |c| {
            let n = c.execute(
                "UPDATE jobs SET state = 'running', started_at = $2, worker = $3,
                     lease_until = caustica_now_ms() + $4, attempts = attempts + 1
                 WHERE id = $1 AND state = 'queued'",
                &[&id, &now_ms(), &worker, &lease_ms],
            )?;
            Ok(n == 1)
        })
    }

    fn claim(
        &self,
        lane: Lane,
        up_to: Priority,
        worker: &str,
        lease_ms: i64,
    ) -> Result<Option<JobRecord>, StoreError> {
        let worker = worker.to_string();
        let row = self.run(move |c| {
            // The row the subquery picks may be claimed and committed by another worker between
            // its snapshot and its lock, which leaves nothing to update though other jobs wait:
            // look again then.
            for _ in 0..8 {
                let r = c.query_opt(
                    &format!(
                        "UPDATE jobs SET state = 'running', started_at = $4, worker = $3,
                             lease_until = caustica_now_ms() + $5, attempts = attempts + 1
                         WHERE id = (SELECT id FROM jobs j
                                     WHERE state = 'queued' AND lane = $1 AND priority <= $2
                                     ORDER BY priority, {fair}, seq
                                     LIMIT 1
                                     FOR UPDATE SKIP LOCKED)
                         RETURNING {COLUMNS}",
                        fair = fair_order("seq")
                    ),
                    &[
                        &lane_str(lane),
                        &(up_to as i32),
                        &worker,
                        &now_ms(),
                        &lease_ms,
                    ],
                )?;
                if r.is_some() {
                    return Ok(r);
                }
                let waiting = c.query_opt(
                    "SELECT 1 FROM jobs WHERE state = 'queued' AND lane = $1 AND priority <= $2
                     LIMIT 1",
                    &[&lane_str(lane), &(up_to as i32)],
                )?;
                if waiting.is_none() {
                    return Ok(None);
                }
            }
            Ok(None)
        })?;
        row.map(|r| row_to_record(&r)).transpose()
    }

    fn heartbeat(
        &self,
        worker: &str,
        running: &[String],
        lease_ms: i64,
    ) -> Result<Vec<String>, StoreError> {
        let (worker, running) = (worker.to_string(), running.to_vec());
        self.run(move |c| {
            Ok(c.query(
                "UPDATE jobs SET lease_until = caustica_now_ms() + $2
                 WHERE worker = $1 AND state = 'running' AND id = ANY($3)
                 RETURNING id, cancel_requested",
                &[&worker, &lease_ms, &running],
            )?
            .iter()
            .filter(|r| r.get::<_, bool>(1))
            .map(|r| r.get(0))
            .collect())
        })
    }

    fn reap_expired(&self) -> Result<Reaped, StoreError> {
        let info = serde_json::json!({ "error_code": ErrorCode::WorkerLost }).to_string();
        self.run(move |c| {
            let mut tx = c.transaction()?;
            let expired = tx.query(
                "SELECT id, attempts FROM jobs
                 WHERE state = 'running' AND lease_until < caustica_now_ms()
                 ORDER BY seq
                 FOR UPDATE SKIP LOCKED",
                &[],
            )?;
            let mut out = Reaped::default();
            for r in expired {
                let id: String = r.get(0);
                let attempts: i32 = r.get(1);
                if attempts as u32 >= MAX_ATTEMPTS {
                    tx.execute(
                        "UPDATE jobs SET state = 'failed', stage = 'failed', finished_at = $2,
                             error = $3, info = $4, worker = NULL, lease_until = NULL
                         WHERE id = $1",
                        &[&id, &now_ms(), &lost_message(attempts as i64), &info],
                    )?;
                    out.failed.push(id);
                } else {
                    tx.execute(
                        "UPDATE jobs SET state = 'queued', progress = 0, stage = '',
                             worker = NULL, lease_until = NULL
                         WHERE id = $1",
                        &[&id],
                    )?;
                    out.requeued.push(id);
                }
            }
            tx.commit()?;
            Ok(out)
        })
    }

    fn request_cancel(&self, id: &str) -> Result<Option<JobState>, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let n = c.execute(
                "UPDATE jobs SET state = 'canceled', stage = 'canceled', error = 'canceled',
                     finished_at = $2
                 WHERE id = $1 AND state = 'queued'",
                &[&id, &now_ms()],
            )?;
            if n == 1 {
                return Ok(Some(JobState::Canceled));
            }
            let n = c.execute(
                "UPDATE jobs SET cancel_requested = true WHERE id = $1 AND state = 'running'",
                &[&id],
            )?;
            Ok((n == 1).then_some(JobState::Running))
        })
    }

    fn count_queued(&self, kind: JobKind) -> Result<usize, StoreError> {
        self.run(move |c| {
            let n: i64 = c
                .query_one(
                    "SELECT COUNT(*) FROM jobs WHERE kind = $1 AND state = 'queued'",
                    &[&kind.as_str()],
                )?
                .get(0);
            Ok(n as usize)
        })
    }

    fn set_progress(&self, id: &str, progress: f32, stage: &str) -> Result<(), StoreError> {
        let (id, stage) = (id.to_string(), stage.to_string());
        self.run(move |c| {
            c.execute(
                "UPDATE jobs SET progress = $2, stage = $3 WHERE id = $1 AND state = 'running'",
                &[&id, &progress, &stage],
            )?;
            Ok(())
        })
    }

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
        let (id, worker, info, error) = (
            id.to_string(),
            worker.to_string(),
            info.to_string(),
            error.map(str::to_string),
        );
        let artifact = artifact.map(|(t, a)| (t.to_string(), a.clone()));
        let stage = if state == JobState::Succeeded {
            "done"
        } else {
            state.as_str()
        };
        self.run(move |c| {
            let n = c.execute(
                "UPDATE jobs SET state = $2, progress = $3, timings = $4, info = $5, error = $6,
                     artifact_type = $7, artifact_path = $8, finished_at = $9, stage = $10,
                     artifact_len = $11, artifact_sha256 = $12, worker = NULL,
                     lease_until = NULL
                 WHERE id = $1
                   AND (state = 'queued' OR (state = 'running' AND COALESCE(worker, '') = $13))",
                &[
                    &id,
                    &state.as_str(),
                    &progress,
                    &timings,
                    &info,
                    &error,
                    &artifact.as_ref().map(|a| a.0.as_str()),
                    &artifact.as_ref().map(|a| a.1.name.as_str()),
                    &now_ms(),
                    &stage,
                    &artifact.as_ref().map(|a| a.1.len as i64),
                    &artifact.as_ref().map(|a| a.1.sha256.as_str()),
                    &worker,
                ],
            )?;
            Ok(n == 1)
        })
    }

    fn set_queued(&self, id: &str, worker: &str) -> Result<(), StoreError> {
        let (id, worker) = (id.to_string(), worker.to_string());
        self.run(move |c| {
            c.execute(
                "UPDATE jobs SET state = 'queued', progress = 0, stage = '', worker = NULL,
                     lease_until = NULL, attempts = GREATEST(attempts - 1, 0)
                 WHERE id = $1 AND state = 'running' AND COALESCE(worker, '') = $2",
                &[&id, &worker],
            )?;
            Ok(())
        })
    }

    fn hold(&self, what: Held, id: &str, owner: &str) -> Result<(), StoreError> {
        let (id, owner) = (id.to_string(), owner.to_string());
        self.run(move |c| {
            c.execute(
                "INSERT INTO holds (kind, id, owner, created_at)
                 VALUES ($1, $2, $3, caustica_now_ms()) ON CONFLICT DO NOTHING",
                &[&what.as_str(), &id, &owner],
            )?;
            Ok(())
        })
    }

    fn holds(&self, what: Held, id: &str, owner: &str) -> Result<bool, StoreError> {
        let (id, owner) = (id.to_string(), owner.to_string());
        self.run(move |c| {
            Ok(c.query_opt(
                "SELECT 1 FROM holds WHERE kind = $1 AND id = $2 AND owner = $3",
                &[&what.as_str(), &id, &owner],
            )?
            .is_some())
        })
    }

    fn fail_lost(&self, id: &str, sha256: Option<&str>, error: &str) -> Result<bool, StoreError> {
        let info = serde_json::json!({ "error_code": ErrorCode::Store }).to_string();
        let (id, sha, error) = (
            id.to_string(),
            sha256.map(str::to_string),
            error.to_string(),
        );
        self.run(move |c| {
            let n = c.execute(
                "UPDATE jobs SET state = 'failed', stage = 'failed', error = $3, info = $4,
                     finished_at = $5, artifact_type = NULL, artifact_path = NULL
                 WHERE id = $1 AND state = 'succeeded' AND artifact_sha256 IS NOT DISTINCT FROM $2",
                &[&id, &sha, &error, &info, &now_ms()],
            )?;
            Ok(n == 1)
        })
    }

    fn first_holder(&self, what: Held, id: &str) -> Result<Option<String>, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            Ok(c.query_opt(
                "SELECT owner FROM holds WHERE kind = $1 AND id = $2 ORDER BY seq LIMIT 1",
                &[&what.as_str(), &id],
            )?
            .map(|r| r.get(0)))
        })
    }

    fn hold_job_within(
        &self,
        id: &str,
        owner: &str,
        cap: usize,
    ) -> Result<Result<(), usize>, StoreError> {
        let (id, owner) = (id.to_string(), owner.to_string());
        self.run(move |c| {
            let mut tx = c.transaction()?;
            // One submission of a key at a time, across every process: the count and the hold
            // are one step.
            tx.execute(
                "SELECT pg_advisory_xact_lock(72432, hashtext($1))",
                &[&owner],
            )?;
            // As the SQLite back-end: a hold of a finished job counts as a new submission.
            let held = tx
                .query_opt(
                    "SELECT 1 FROM holds h LEFT JOIN jobs j ON j.id = h.id
                     WHERE h.kind = 'job' AND h.id = $1 AND h.owner = $2
                       AND (j.id IS NULL OR j.state IN ('queued', 'running'))",
                    &[&id, &owner],
                )?
                .is_some();
            if !held {
                let n: i64 = tx
                    .query_one(
                        "SELECT COUNT(*) FROM holds h LEFT JOIN jobs j ON j.id = h.id
                         WHERE h.owner = $1 AND h.kind = 'job'
                           AND (j.state IN ('queued', 'running')
                                OR (j.id IS NULL AND h.created_at > caustica_now_ms() - $2))",
                        &[&owner, &super::SUBMITTING_MS],
                    )?
                    .get(0);
                if n as usize >= cap {
                    return Ok(Err(n as usize));
                }
                tx.execute(
                    "INSERT INTO holds (kind, id, owner, created_at)
                     VALUES ('job', $1, $2, caustica_now_ms()) ON CONFLICT DO NOTHING",
                    &[&id, &owner],
                )?;
            }
            tx.commit()?;
            Ok(Ok(()))
        })
    }

    fn expire_idempotency(&self, before_ms: i64) -> Result<usize, StoreError> {
        self.run(move |c| {
            let n = c.execute(
                "DELETE FROM idempotency WHERE created_at < $1",
                &[&before_ms],
            )?;
            Ok(n as usize)
        })
    }

    fn active_jobs_of(&self, owner: &str) -> Result<usize, StoreError> {
        let owner = owner.to_string();
        self.run(move |c| {
            let n: i64 = c
                .query_one(
                    "SELECT COUNT(*) FROM holds h JOIN jobs j ON j.id = h.id
                     WHERE h.kind = 'job' AND h.owner = $1 AND j.state IN ('queued', 'running')",
                    &[&owner],
                )?
                .get(0);
            Ok(n as usize)
        })
    }

    fn holders(&self, what: Held, id: &str) -> Result<usize, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let n: i64 = c
                .query_one(
                    "SELECT COUNT(*) FROM holds WHERE kind = $1 AND id = $2",
                    &[&what.as_str(), &id],
                )?
                .get(0);
            Ok(n as usize)
        })
    }

    fn held_bytes(&self, owner: &str) -> Result<u64, StoreError> {
        let owner = owner.to_string();
        self.run(move |c| {
            let n: i64 = c
                .query_one(
                    "SELECT (
                       (SELECT COALESCE(SUM(j.artifact_len), 0) FROM holds h
                         JOIN jobs j ON j.id = h.id WHERE h.owner = $1 AND h.kind = 'job')
                     + (SELECT COALESCE(SUM(octet_length(s.scene_json)), 0) FROM holds h
                         JOIN scenes s ON s.id = h.id WHERE h.owner = $1 AND h.kind = 'scene')
                     + (SELECT COALESCE(SUM(octet_length(f.bytes)), 0) FROM holds h
                         JOIN scene_files f ON f.scene_id = h.id
                         WHERE h.owner = $1 AND h.kind = 'scene'))::BIGINT",
                    &[&owner],
                )?
                .get(0);
            Ok(n.max(0) as u64)
        })
    }

    fn release_all(&self, what: Held, id: &str) -> Result<(), StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            c.execute(
                "DELETE FROM holds WHERE kind = $1 AND id = $2",
                &[&what.as_str(), &id],
            )?;
            Ok(())
        })
    }

    fn unheld_scenes(&self, before_ms: i64) -> Result<Vec<String>, StoreError> {
        self.run(move |c| {
            Ok(c.query(
                "SELECT id FROM scenes s WHERE created_at < $1
                     AND NOT EXISTS (SELECT 1 FROM holds h WHERE h.kind = 'scene' AND h.id = s.id)",
                &[&before_ms],
            )?
            .iter()
            .map(|r| r.get(0))
            .collect())
        })
    }

    fn release(&self, what: Held, id: &str, owner: &str) -> Result<usize, StoreError> {
        let (id, owner) = (id.to_string(), owner.to_string());
        self.run(move |c| {
            let mut tx = c.transaction()?;
            tx.execute(
                "DELETE FROM holds WHERE kind = $1 AND id = $2 AND owner = $3",
                &[&what.as_str(), &id, &owner],
            )?;
            let n: i64 = tx
                .query_one(
                    "SELECT COUNT(*) FROM holds WHERE kind = $1 AND id = $2",
                    &[&what.as_str(), &id],
                )?
                .get(0);
            tx.commit()?;
            Ok(n as usize)
        })
    }

    fn touch(&self, uses: &[(String, i64)]) -> Result<(), StoreError> {
        let uses = uses.to_vec();
        self.run(move |c| {
            let mut tx = c.transaction()?;
            for (id, at) in &uses {
                tx.execute(
                    "UPDATE jobs SET accessed_at = GREATEST(COALESCE(accessed_at, 0), $2)
                     WHERE id = $1",
                    &[id, at],
                )?;
            }
            tx.commit()
        })
    }

    fn delete_job_record(&self, id: &str) -> Result<Option<Option<String>>, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let mut tx = c.transaction()?;
            let Some(row) = tx.query_opt(
                "SELECT artifact_path FROM jobs
                 WHERE id = $1 AND state IN ('succeeded', 'failed', 'canceled')
                 FOR UPDATE",
                &[&id],
            )?
            else {
                return Ok(None);
            };
            tx.execute("DELETE FROM jobs WHERE id = $1", &[&id])?;
            tx.execute("DELETE FROM holds WHERE kind = 'job' AND id = $1", &[&id])?;
            tx.execute("DELETE FROM idempotency WHERE job_id = $1", &[&id])?;
            tx.commit()?;
            Ok(Some(row.get(0)))
        })
    }

    fn finished_before(&self, kind: JobKind, before_ms: i64) -> Result<Vec<String>, StoreError> {
        self.run(move |c| {
            Ok(c.query(
                "SELECT id FROM jobs WHERE kind = $1
                     AND state IN ('succeeded', 'failed', 'canceled')
                     AND COALESCE(finished_at, created_at) < $2",
                &[&kind.as_str(), &before_ms],
            )?
            .iter()
            .map(|r| r.get(0))
            .collect())
        })
    }

    fn renders_by_last_use(&self) -> Result<Vec<(String, u64)>, StoreError> {
        self.run(|c| {
            Ok(c.query(
                "SELECT id, COALESCE(artifact_len, 0) FROM jobs
                 WHERE kind = 'render' AND state = 'succeeded'
                 ORDER BY COALESCE(accessed_at, finished_at, created_at), seq",
                &[],
            )?
            .iter()
            .map(|r| (r.get(0), r.get::<_, i64>(1) as u64))
            .collect())
        })
    }

    fn delete_scene(&self, id: &str) -> Result<bool, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let mut tx = c.transaction()?;
            // Lock the scene's row so that no job or hold takes it while it goes.
            if tx
                .query_opt("SELECT 1 FROM scenes WHERE id = $1 FOR UPDATE", &[&id])?
                .is_none()
            {
                return Ok(true);
            }
            let busy: i64 = tx
                .query_one(
                    "SELECT (SELECT COUNT(*) FROM holds WHERE kind = 'scene' AND id = $1)
                          + (SELECT COUNT(*) FROM jobs WHERE scene_id = $1
                                 AND state IN ('queued', 'running'))",
                    &[&id],
                )?
                .get(0);
            if busy > 0 {
                return Ok(false);
            }
            tx.execute("DELETE FROM scene_files WHERE scene_id = $1", &[&id])?;
            tx.execute("DELETE FROM scenes WHERE id = $1", &[&id])?;
            tx.commit()?;
            Ok(true)
        })
    }

    fn scene_in_use(&self, id: &str) -> Result<bool, StoreError> {
        let id = id.to_string();
        self.run(move |c| {
            let n: i64 = c
                .query_one(
                    "SELECT COUNT(*) FROM jobs WHERE scene_id = $1
                         AND state IN ('queued', 'running')",
                    &[&id],
                )?
                .get(0);
            Ok(n > 0)
        })
    }

    fn idempotency(&self, key: &str) -> Result<Option<(String, String)>, StoreError> {
        let key = key.to_string();
        self.run(move |c| {
            Ok(c.query_opt(
                "SELECT request_hash, job_id FROM idempotency WHERE key = $1",
                &[&key],
            )?
            .map(|r| (r.get(0), r.get(1))))
        })
    }

    fn put_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.write_idempotency("ON CONFLICT DO NOTHING", key, request_hash, job_id)
    }

    fn replace_idempotency(
        &self,
        key: &str,
        request_hash: &str,
        job_id: &str,
    ) -> Result<(), StoreError> {
        self.write_idempotency(
            "ON CONFLICT (key) DO UPDATE SET request_hash = $2, job_id = $3, \
             created_at = EXCLUDED.created_at",
            key,
            request_hash,
            job_id,
        )
    }

    fn listen(&self, on: Box<dyn Fn(StoreEvent) + Send + Sync>) -> Result<bool, StoreError> {
        let url = self.url.clone();
        let stop = self.stop.clone();
        // The first connection is made on the thread (the synchronous client must not run on a
        // thread that drives async tasks) and its result sent back, so that a caller learns at
        // once when it cannot listen; later losses are retried on the thread.
        let (first, started) = mpsc::sync_channel::<Result<(), StoreError>>(1);
        std::thread::Builder::new()
            .name("caustica-pg-listen".into())
            .spawn(move || {
                let mut client = match listen_client(&url) {
                    Ok(c) => {
                        let _ = first.send(Ok(()));
                        Some(c)
                    }
                    Err(e) => {
                        let _ = first.send(Err(e));
                        return;
                    }
                };
                let mut wait = Duration::from_millis(100);
                while !stop.load(Ordering::SeqCst) {
                    let c = match client.as_mut() {
                        Some(c) => c,
                        None => match listen_client(&url) {
                            Ok(c) => {
                                wait = Duration::from_millis(100);
                                on(StoreEvent::Reconnected);
                                client.insert(c)
                            }
                            Err(e) => {
                                tracing::warn!(error = %e, "cannot listen to the database yet");
                                std::thread::sleep(wait);
                                wait = (wait * 2).min(Duration::from_secs(2));
                                continue;
                            }
                        },
                    };
                    let mut lost = false;
                    {
                        let mut n = c.notifications();
                        let mut it = n.timeout_iter(Duration::from_millis(500));
                        loop {
                            match postgres::fallible_iterator::FallibleIterator::next(&mut it) {
                                Ok(Some(m)) => on(match m.channel() {
                                    "caustica_queue" => StoreEvent::Queued(
                                        parse_lane(m.payload()).unwrap_or(Lane::Cpu),
                                    ),
                                    "caustica_cancel" => {
                                        StoreEvent::Cancel(m.payload().to_string())
                                    }
                                    _ => StoreEvent::Job(m.payload().to_string()),
                                }),
                                Ok(None) => break,
                                Err(e) => {
                                    tracing::warn!(
                                        error = %super::pg_detail(&e),
                                        "listening connection lost"
                                    );
                                    lost = true;
                                    break;
                                }
                            }
                        }
                    }
                    if lost || c.is_closed() {
                        client = None;
                    }
                }
            })
            .map_err(StoreError::Io)?;
        started
            .recv()
            .map_err(|_| StoreError::Unavailable("the listening thread stopped".into()))??;
        Ok(true)
    }
}

/// A connection that listens on the three channels.
fn listen_client(url: &str) -> Result<Client, StoreError> {
    let mut c = connect(url)?;
    c.batch_execute("LISTEN caustica_jobs; LISTEN caustica_queue; LISTEN caustica_cancel")?;
    Ok(c)
}
