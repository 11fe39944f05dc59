//! Jobs: a bounded priority queue, a CPU pool for bakes and reference renders, GPU workers each
//! owning a [`Renderer`](crate::render::Renderer) on one shared device, progress, cancellation,
//! timeouts and persistence.
//!
//! - [`job`]: what a job is ([`Job`], [`JobKind`], [`JobState`], [`JobSpec`], [`JobError`] and
//!   its [`ErrorCode`]); the two job types, [`render::RenderJob`] and [`bake::BakeJob`], are
//!   thin over [`crate::methods`], which knows every method.
//! - [`JobSystem`] (here): submits, queues (renders before bakes; bounded), records; the
//!   [`queue`]s and the [`worker`]s that run jobs; its tunables in [`config`].
//! - [`store`]: SQLite records and atomic artifact files under the data directory;
//!   [`scenes`]: content-addressed scenes and the cache of resolved worlds; [`metrics`].
//!
//! Nothing here knows HTTP; errors are domain enums and `http` picks the status codes.
//!
//! This file (~1,150 lines) is [`JobSystem`] alone — submission, memory holds, cancellation,
//! the lease keeper, the janitor and the workers' roles — all over one set of fields; the
//! queue, the workers' loop and the job types live in their own modules.

pub mod bake;
pub mod config;
pub mod job;
pub mod metrics;
pub mod queue;
pub mod render;
pub mod scenes;
pub mod store;
pub mod worker;

pub use crate::methods::Lane;
pub use config::{JobConfig, RequestCaps, Retention, env_num};
pub use job::{
    Artifact, ErrorCode, Job, JobError, JobKind, JobSpec, JobState, Priority, build_job,
};
pub use worker::{GpuDevice, GpuSlot, JobCtx};

use crate::methods::ArtifactStore;
use metrics::Metrics;
use queue::{Queued, Queues, Take};
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};
use store::{JobRecord, Store, StoreError};

/// Live state of one job, shared by its worker and the HTTP handlers.
pub struct JobHandle {
    pub id: String,
    cancel: AtomicBool,
    live: Mutex<(f32, String)>,
    state: tokio::sync::watch::Sender<JobState>,
    /// Marked changed when the progress moves by half a per cent or the stage changes (what
    /// live progress streams wait on).
    progressed: tokio::sync::watch::Sender<()>,
    /// When it was put in the queue (for the queue-wait timing).
    enqueued: Instant,
    /// A worker of this process runs it (with a shared store, the other handles follow the
    /// record).
    local: AtomicBool,
}

impl JobHandle {
    fn new(id: String) -> Arc<JobHandle> {
        Arc::new(JobHandle {
            id,
            cancel: AtomicBool::new(false),
            live: Mutex::new((0.0, String::new())),
            state: tokio::sync::watch::Sender::new(JobState::Queued),
            progressed: tokio::sync::watch::Sender::new(()),
            enqueued: Instant::now(),
            local: AtomicBool::new(false),
        })
    }

    pub fn state(&self) -> JobState {
        *self.state.borrow()
    }

    /// Progress 0..1 and stage name, as last reported.
    pub fn progress(&self) -> (f32, String) {
        self.live.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// A receiver that sees every state change.
    pub fn subscribe(&self) -> tokio::sync::watch::Receiver<JobState> {
        self.state.subscribe()
    }

    /// A receiver that is marked changed when the progress moves visibly (half a per cent) or
    /// the stage changes.
    pub fn subscribe_progress(&self) -> tokio::sync::watch::Receiver<()> {
        self.progressed.subscribe()
    }

    /// Records progress `f` (0..1, never lowered) and `stage`; wakes the progress receivers
    /// when either changed visibly.
    pub(crate) fn report(&self, f: f32, stage: &str) {
        let moved = {
            let mut l = self.live.lock().unwrap_or_else(|e| e.into_inner());
            let step = |p: f32| (p * 200.0).floor() as i32;
            let before = step(l.0);
            l.0 = l.0.max(f);
            let mut moved = step(l.0) != before;
            if l.1 != stage {
                l.1 = stage.to_string();
                moved = true;
            }
            moved
        };
        if moved {
            self.progressed.send_replace(());
        }
    }

    pub fn request_cancel(&self) {
        self.cancel.store(true, Ordering::SeqCst);
    }

    pub fn is_cancel_requested(&self) -> bool {
        self.cancel.load(Ordering::SeqCst)
    }

    /// The kind of job, from its id.
    fn kind(&self) -> JobKind {
        if self.id.starts_with(JobKind::Bake.id_prefix()) {
            JobKind::Bake
        } else {
            JobKind::Render
        }
    }
}

/// Whether the GPU worker found an adapter and rendered the probe frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Readiness {
    Starting,
    /// This process runs no GPU worker (an API process over a shared store, or a worker
    /// without the GPU lane): ready for what it does.
    NoGpuLane,
    Ready {
        adapter: String,
    },
    NoGpu {
        error: String,
    },
}

#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error("the {kind} queue is full ({1} waiting)", kind = .0.as_str())]
    QueueFull(JobKind, usize),
    /// The jobs queued and running hold the job memory budget (`need`, `free`, `total` MiB).
    #[error(
        "the jobs queued and running hold the server's job memory: this one needs {need} MiB, \
         {free} MiB of {total} MiB are free"
    )]
    NoMemory { need: u64, free: u64, total: u64 },
    /// This job alone needs more than the whole budget.
    #[error("this job needs about {need} MiB, more than the {total} MiB this server gives jobs")]
    TooBig { need: u64, total: u64 },
    #[error("the server is shutting down")]
    ShuttingDown,
    #[error(transparent)]
    Job(#[from] JobError),
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// A job's share of [`JobConfig::job_memory`], given back when dropped.
pub struct MemoryHold {
    bytes: u64,
    pool: Arc<Mutex<u64>>,
}

impl Drop for MemoryHold {
    fn drop(&mut self) {
        let mut used = self.pool.lock().unwrap_or_else(|e| e.into_inner());
        *used = used.saturating_sub(self.bytes);
    }
}

/// Why a succeeded job's artifact cannot be served.
#[derive(Debug, thiserror::Error)]
pub enum ArtifactError {
    /// It failed its check; `requeued`: the job runs again.
    #[error("the stored artifact failed its check: {why}")]
    Lost { why: String, requeued: bool },
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// The queue, the workers and the records.
pub struct JobSystem {
    pub store: Arc<Store>,
    pub scenes: scenes::Scenes,
    pub metrics: Arc<Metrics>,
    /// Bakes that renders find by content hash (`DATA_DIR/bakes`).
    pub bakes: ArtifactStore,
    cfg: JobConfig,
    queues: Mutex<Queues>,
    wake: Condvar,
    live: Mutex<HashMap<String, Arc<JobHandle>>>,
    seq: AtomicU64,
    /// Set at the shutdown deadline: running jobs stop and go back to the queue.
    abort: AtomicBool,
    readiness: Mutex<Readiness>,
    threads: Mutex<Vec<std::thread::JoinHandle<()>>>,
    /// The device the GPU workers share, each with a renderer of its own.
    device: Arc<GpuDevice>,
    /// The first GPU worker's renderer; a CPU job that ends on the GPU (a `csl` render: bake on
    /// the CPU pool, then one frame) borrows it through the same lock, so a long bake never
    /// holds a renderer.
    gpu: Arc<Mutex<GpuSlot>>,
    /// Bytes of [`JobConfig::job_memory`] that queued and running jobs hold.
    memory: Arc<Mutex<u64>>,
    /// This process's name as a worker (host, process id, start time): what its leases are
    /// held under.
    worker_id: String,
    /// The store is shared with other processes (PostgreSQL): workers claim jobs from it, and
    /// handles of jobs run elsewhere follow their records.
    shared: bool,
    /// How many queued or running jobs a key may hold (none: no quota), set by the service
    /// ([`JobSystem::set_quota`]); what [`JobSystem::hold_job`] holds to.
    quota: std::sync::OnceLock<Quota>,
}

/// The job quota of a key, by its name: `None` for no quota.
pub type Quota = Box<dyn Fn(&str) -> Option<usize> + Send + Sync>;

impl JobSystem {
    /// Sets the job quota of keys (once; later calls change nothing).
    pub fn set_quota(&self, q: Quota) {
        let _ = self.quota.set(q);
    }

    /// Holds job `id` for `owner`, within the owner's quota ([`JobDb::hold_job_within`]: the
    /// check and the hold are one step): `Err(n)` when the owner already holds `n`, its quota.
    pub fn hold_job(&self, id: &str, owner: &str) -> Result<Result<(), usize>, StoreError> {
        match self.quota.get().and_then(|q| q(owner)) {
            Some(cap) => self.store.hold_job_within(id, owner, cap),
            None => self.store.hold(store::Held::Job, id, owner).map(Ok),
        }
    }

    /// Opens the store, re-queues what a previous process left unfinished and starts the
    /// workers.
    /// Its store calls are a worker's (they wait out a database restart), wherever it runs.
    pub fn start(cfg: JobConfig) -> Result<Arc<JobSystem>, SubmitError> {
        store::postgres::as_worker(|| Self::start_here(cfg))
    }

    fn start_here(cfg: JobConfig) -> Result<Arc<JobSystem>, SubmitError> {
        let store = Arc::new(Store::open_with(
            &cfg.data_dir,
            cfg.database.as_deref(),
            cfg.artifacts.as_deref(),
        )?);
        let shared = cfg.database.is_some();
        let worker_id = format!(
            "{}-{}-{}",
            store::host_tag(),
            std::process::id(),
            store::now_ms()
        );
        // Bakes renders find by content hash; with a bucket, kept there too.
        let bakes = match store.bucket() {
            Some(b) => ArtifactStore::new(cfg.data_dir.join("bakes")).with_remote(b),
            None => ArtifactStore::new(cfg.data_dir.join("bakes")),
        };
        let device = Arc::new(GpuDevice::default());
        let sys = Arc::new(JobSystem {
            scenes: scenes::Scenes::new(store.clone(), cfg.limits.clone(), cfg.scene_cache_bytes),
            store,
            metrics: Arc::new(Metrics::new(cfg.bake_timeout, cfg.render_timeout)),
            bakes,
            queues: Mutex::new(Queues::default()),
            wake: Condvar::new(),
            live: Mutex::new(HashMap::new()),
            seq: AtomicU64::new(0),
            abort: AtomicBool::new(false),
            readiness: Mutex::new(if cfg.probe_gpu {
                Readiness::Starting
            } else {
                Readiness::NoGpu {
                    error: "GPU probe disabled".into(),
                }
            }),
            threads: Mutex::new(Vec::new()),
            gpu: Arc::new(Mutex::new(GpuSlot::on(device.clone()))),
            device,
            memory: Arc::new(Mutex::new(0)),
            worker_id,
            shared,
            quota: std::sync::OnceLock::new(),
            cfg,
        });
        // With a shared store, jobs left running by a process that died go back to the queue
        // when their lease runs out (the keeper, below), not at the start of another process.
        let unfinished = if shared {
            vec![]
        } else {
            sys.store.unfinished_jobs()?
        };
        for rec in unfinished {
            let spec = rec.spec();
            tracing::info!(job = %rec.id, kind = rec.kind.as_str(), "re-queueing unfinished job");
            let r = sys
                .scenes
                .world(&rec.scene_id)
                .and_then(|w| build_job(&spec, w, &sys.cfg.limits, sys.cfg.render_budget()));
            match r {
                Ok(job) => {
                    sys.store
                        .set_queued(&rec.id, rec.worker.as_deref().unwrap_or_default())?;
                    // Accepted before the restart: taken back whatever the budget says.
                    let hold = sys.hold_memory(job.memory(), true)?;
                    sys.enqueue(rec.id.clone(), job, hold);
                }
                Err(e) => {
                    sys.store.finish(
                        &rec.id,
                        rec.worker.as_deref().unwrap_or_default(),
                        JobState::Failed,
                        0.0,
                        &[],
                        &rec.info,
                        Some(&e.to_string()),
                        None,
                    )?;
                }
            }
        }
        let mut threads = Vec::new();
        if shared {
            let s = sys.clone();
            let wake = sys.clone();
            sys.store.listen(Box::new(move |e| wake.heard(e)))?;
            threads.push(
                std::thread::Builder::new()
                    .name("caustica-leases".into())
                    .spawn(move || s.keeper())
                    .expect("spawn lease keeper"),
            );
        }
        sys.spawn_workers(&mut threads);
        *sys.threads.lock().unwrap_or_else(|e| e.into_inner()) = threads;
        Ok(sys)
    }

    /// Starts the workers of this process's lanes (their roles below) and the janitor.
    fn spawn_workers(self: &Arc<Self>, threads: &mut Vec<std::thread::JoinHandle<()>>) {
        let (cpu_lane, gpu_lane) = self.cfg.lanes;
        let n = if cpu_lane {
            self.cfg.cpu_workers.max(1)
        } else {
            0
        };
        // With more than one CPU worker, the first takes only renders, so that a render never
        // waits behind long bakes, and one more takes only bakes, so that a bake never waits
        // behind renders either; one more takes only small renders, so that a preview never
        // waits behind big renders (it shares the cores for its short run). The others take
        // a bake that waited past `bake_after` before renders.
        let cpu = |up_to| Take {
            bake_after: (up_to == Priority::Bake).then_some(self.cfg.bake_after),
            ..Take::by_priority(Lane::Cpu, up_to)
        };
        let roles = (0..n)
            .map(|i| {
                let up_to = if n > 1 && i == 0 {
                    Priority::Render
                } else {
                    Priority::Bake
                };
                (format!("caustica-cpu-{i}"), cpu(up_to))
            })
            .chain(cpu_lane.then(|| ("caustica-cpu-small".to_string(), cpu(Priority::Small))))
            .chain((n > 1).then(|| {
                let bakes = Take {
                    from: Priority::Bake,
                    ..cpu(Priority::Bake)
                };
                ("caustica-cpu-bake".to_string(), bakes)
            }));
        for (name, take) in roles {
            let s = self.clone();
            threads.push(
                std::thread::Builder::new()
                    .name(name)
                    .spawn(move || {
                        let gpu = s.gpu.clone();
                        s.worker(take, Some(&gpu))
                    })
                    .expect("spawn worker"),
            );
        }
        let s = self.clone();
        threads.push(
            std::thread::Builder::new()
                .name("caustica-janitor".into())
                .spawn(move || s.janitor())
                .expect("spawn janitor"),
        );
        if gpu_lane {
            // Several GPU workers, each with a renderer of its own on the one device, a key
            // running at most `gpu_jobs_per_key` of their jobs at once: one key's long render
            // leaves the other workers to the other keys (the GPU interleaves their work). One
            // more takes only small renders.
            let gpu = |up_to| Take {
                per_key: Some(self.cfg.gpu_jobs_per_key),
                bake_after: (up_to == Priority::Bake).then_some(self.cfg.bake_after),
                ..Take::by_priority(Lane::Gpu, up_to)
            };
            let roles = (0..self.cfg.gpu_workers.max(1))
                .map(|i| (format!("caustica-gpu-{i}"), gpu(Priority::Bake)))
                .chain([("caustica-gpu-small".to_string(), gpu(Priority::Small))]);
            for (i, (name, take)) in roles.enumerate() {
                let s = self.clone();
                threads.push(
                    std::thread::Builder::new()
                        .name(name)
                        .spawn(move || {
                            let slot = match i {
                                0 => s.gpu.clone(),
                                _ => Arc::new(Mutex::new(GpuSlot::on(s.device.clone()))),
                            };
                            if i == 0 && s.cfg.probe_gpu {
                                s.probe(&slot);
                            }
                            s.worker(take, Some(&slot));
                        })
                        .expect("spawn GPU worker"),
                );
            }
        } else {
            *self.readiness.lock().unwrap_or_else(|e| e.into_inner()) = Readiness::NoGpuLane;
        }
    }

    pub fn config(&self) -> &JobConfig {
        &self.cfg
    }

    /// This process's name as a worker: what its leases are held under.
    pub fn worker_id(&self) -> &str {
        &self.worker_id
    }

    pub fn readiness(&self) -> Readiness {
        self.readiness
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Jobs waiting, per lane (cpu, gpu).
    pub fn queue_depth(&self) -> (usize, usize) {
        self.queues
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .depth()
    }

    /// Jobs queued, per kind (bake, render): in this process, or in the shared store.
    pub fn queued(&self) -> (usize, usize) {
        if self.shared {
            let n = |k| self.store.count_queued(k).unwrap_or(0);
            return (n(JobKind::Bake), n(JobKind::Render));
        }
        let q = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        (q.count(JobKind::Bake), q.count(JobKind::Render))
    }

    /// Jobs running in this process, per kind (bake, render).
    pub fn running(&self) -> (usize, usize) {
        let live = self.live.lock().unwrap_or_else(|e| e.into_inner());
        let mut n = (0, 0);
        for h in live.values().filter(|h| h.state() == JobState::Running) {
            match h.kind() {
                JobKind::Bake => n.0 += 1,
                JobKind::Render => n.1 += 1,
            }
        }
        n
    }

    /// The handle of `id` in the live map, if any.
    fn live_handle(&self, id: &str) -> Option<Arc<JobHandle>> {
        self.live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(id)
            .cloned()
    }

    /// The live handle of a job queued or running in this process; with a shared store, of
    /// one queued or running anywhere (a handle that follows its record).
    pub fn handle(&self, id: &str) -> Option<Arc<JobHandle>> {
        let h = self.live_handle(id);
        if h.is_some() || !self.shared {
            return h;
        }
        let rec = self.store.get_job(id).ok().flatten()?;
        if rec.state.is_terminal() {
            return None;
        }
        let h = self
            .live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(id.to_string())
            .or_insert_with(|| JobHandle::new(id.to_string()))
            .clone();
        // The record may have moved on between the read and the insertion.
        self.refresh(id);
        Some(h)
    }

    /// Brings the handle of job `id` (one not run here) up to its record; retires it once the
    /// job ended. A handle never leaves a terminal state.
    pub(super) fn refresh(&self, id: &str) {
        let Some(h) = self.live_handle(id) else {
            return;
        };
        if h.local.load(Ordering::SeqCst) {
            return;
        }
        let rec = match self.store.get_job(id) {
            Ok(Some(r)) => r,
            Ok(None) => {
                // Deleted: nothing more will happen to it.
                self.live
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .remove(id);
                return;
            }
            Err(e) => {
                tracing::warn!(job = %id, error = %e, "cannot follow the job's record");
                return;
            }
        };
        h.report(rec.progress, &rec.stage);
        if rec.state.is_terminal() {
            self.live
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .remove(id);
        }
        h.state.send_if_modified(|s| {
            if s.is_terminal() || *s == rec.state {
                false
            } else {
                *s = rec.state;
                true
            }
        });
    }

    /// What the shared store said another process did.
    fn heard(&self, e: store::StoreEvent) {
        match e {
            // `refresh` passes over the jobs run here.
            store::StoreEvent::Job(id) => self.refresh(&id),
            store::StoreEvent::Cancel(id) => {
                if let Some(h) = self
                    .live_handle(&id)
                    .filter(|h| h.local.load(Ordering::SeqCst))
                {
                    h.request_cancel();
                }
            }
            store::StoreEvent::Queued(_) => {
                let _q = self.queues.lock().unwrap_or_else(|e| e.into_inner());
                self.wake.notify_all();
            }
            store::StoreEvent::Reconnected => {
                self.refresh_followed();
                let _q = self.queues.lock().unwrap_or_else(|e| e.into_inner());
                self.wake.notify_all();
            }
        }
    }

    /// Brings every handle of a job run elsewhere up to its record.
    fn refresh_followed(&self) {
        let ids: Vec<String> = self
            .live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .filter(|(_, h)| !h.local.load(Ordering::SeqCst))
            .map(|(id, _)| id.clone())
            .collect();
        for id in ids {
            self.refresh(&id);
        }
    }

    /// Extends the leases of the jobs this process runs; passes on cancellations asked of
    /// them.
    fn beat(&self) {
        let running: Vec<String> = self
            .live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .values()
            .filter(|h| h.local.load(Ordering::SeqCst))
            .map(|h| h.id.clone())
            .collect();
        if running.is_empty() {
            return;
        }
        match self
            .store
            .heartbeat(&self.worker_id, &running, self.cfg.lease.as_millis() as i64)
        {
            Ok(cancel) => {
                for h in cancel.iter().filter_map(|id| self.live_handle(id)) {
                    h.request_cancel();
                }
            }
            Err(e) => tracing::warn!(error = %e, "lease heartbeat failed"),
        }
    }

    /// With a shared store: every third of a lease, extends this process's leases, re-queues
    /// (or fails) jobs whose worker's lease ran out, and brings the handles of jobs run
    /// elsewhere up to their records (in case a notification was missed); until shutdown.
    fn keeper(&self) {
        self.every(self.cfg.lease / 3, || {
            self.beat();
            match self.store.reap_expired() {
                Ok(r) => {
                    for id in &r.requeued {
                        tracing::warn!(job = %id, "its worker's lease ran out; queued again");
                    }
                    for id in &r.failed {
                        tracing::error!(job = %id, "its workers' leases ran out too often; failed");
                    }
                }
                Err(e) => tracing::warn!(error = %e, "cannot reap expired leases"),
            }
            self.refresh_followed();
        });
    }

    /// Runs `f` every `period` until the queues close (from the thread that calls it).
    fn every(&self, period: Duration, mut f: impl FnMut()) {
        let mut qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            let (q, _) = self
                .wake
                .wait_timeout_while(qs, period, |q| !q.closed)
                .unwrap_or_else(|e| e.into_inner());
            if q.closed {
                return;
            }
            drop(q);
            f();
            qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Submits a job under `id`. If a record with this id exists and is queued, running or
    /// succeeded, nothing new is started (`Ok((handle or None, false))`); a failed or canceled
    /// one runs again.
    pub fn submit(
        &self,
        id: &str,
        spec: &JobSpec,
    ) -> Result<(Option<Arc<JobHandle>>, bool), SubmitError> {
        if self.queues.lock().unwrap_or_else(|e| e.into_inner()).closed {
            return Err(SubmitError::ShuttingDown);
        }
        if let Some(h) = self.handle(id) {
            return Ok((Some(h), false));
        }
        let existing = self.store.get_job(id)?;
        if let Some(r) = &existing
            && matches!(
                r.state,
                JobState::Succeeded | JobState::Queued | JobState::Running
            )
        {
            return Ok((self.handle(id), false));
        }
        {
            let n = if self.shared {
                self.store.count_queued(spec.kind)?
            } else {
                self.queues
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .count(spec.kind)
            };
            let cap = match spec.kind {
                JobKind::Render => self.cfg.max_queued,
                JobKind::Bake => self.cfg.max_queued_bakes,
            };
            if n >= cap {
                return Err(SubmitError::QueueFull(spec.kind, n));
            }
        }
        let world = self.scenes.world(&spec.scene_id)?;
        let job = build_job(spec, world, &self.cfg.limits, self.cfg.render_budget())?;
        if spec.kind == JobKind::Render {
            self.cfg.caps.check(&spec.params).map_err(JobError::from)?;
        }
        // With a shared store, the workers that claim it hold its memory (each its own budget,
        // this process's settings presumed theirs): this process refuses only a job bigger
        // than a whole budget, and follows the record.
        let hold = if self.shared {
            self.fits_budget(job.memory())?;
            None
        } else {
            Some(self.hold_memory(job.memory(), false)?)
        };
        if existing.is_some() {
            self.store.requeue(id)?;
        } else {
            self.store
                .insert_job(&JobRecord::new(id, spec, job.lane(), job.priority()))?;
        }
        match hold {
            Some(hold) => Ok((Some(self.enqueue(id.to_string(), job, hold)), true)),
            None => Ok((self.handle(id), true)),
        }
    }

    /// Refuses a job of `bytes` that alone needs more than the whole job memory budget.
    fn fits_budget(&self, bytes: u64) -> Result<(), SubmitError> {
        let total = self.cfg.job_memory;
        if bytes > total {
            return Err(SubmitError::TooBig {
                need: bytes >> 20,
                total: total >> 20,
            });
        }
        Ok(())
    }

    /// Takes `bytes` of the job memory budget for work a request does itself (a comparison
    /// of two renders): `NoMemory` when it does not fit beside the jobs', `TooBig` when it
    /// never would.
    pub fn hold_request_memory(&self, bytes: u64) -> Result<MemoryHold, SubmitError> {
        self.hold_memory(bytes, false)
    }

    /// Takes `bytes` of the job memory budget (with `force`, even past it).
    fn hold_memory(&self, bytes: u64, force: bool) -> Result<MemoryHold, SubmitError> {
        let total = self.cfg.job_memory;
        let mib = |b: u64| b >> 20;
        if !force {
            self.fits_budget(bytes)?;
        }
        let mut used = self.memory.lock().unwrap_or_else(|e| e.into_inner());
        if *used + bytes > total && !force {
            return Err(SubmitError::NoMemory {
                need: mib(bytes),
                free: mib(total.saturating_sub(*used)),
                total: mib(total),
            });
        }
        *used += bytes;
        Ok(MemoryHold {
            bytes,
            pool: self.memory.clone(),
        })
    }

    fn enqueue(&self, id: String, job: Box<dyn Job>, memory: MemoryHold) -> Arc<JobHandle> {
        // Fair queueing runs it for the key that asked for it first.
        let owner = self
            .store
            .first_holder(store::Held::Job, &id)
            .ok()
            .flatten()
            .unwrap_or_default();
        let handle = JobHandle::new(id.clone());
        self.live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(id, handle.clone());
        let q = Queued {
            priority: job.priority(),
            owner,
            tag: 0,
            seq: self.seq.fetch_add(1, Ordering::SeqCst),
            handle: handle.clone(),
            job,
            memory,
            claimed: None,
            counted: false,
        };
        self.queues
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(q);
        self.wake.notify_all();
        handle
    }

    /// Cancels a job: a queued one is dropped at once, a running one stops at its next check.
    /// Returns false when the job is not queued or running here.
    pub fn cancel(&self, id: &str) -> Result<bool, StoreError> {
        let Some(h) = self.handle(id) else {
            return Ok(false);
        };
        if self.shared && !h.local.load(Ordering::SeqCst) {
            // Queued: canceled in the store at once; running elsewhere: its worker sees the
            // request at its next heartbeat (at once, when it hears the notification).
            return Ok(match self.store.request_cancel(id)? {
                Some(JobState::Canceled) => {
                    self.metrics
                        .job_finished("canceled", h.kind().as_str(), Duration::ZERO);
                    self.retire(&h, JobState::Canceled);
                    true
                }
                Some(_) => true,
                None => {
                    self.refresh(id);
                    false
                }
            });
        }
        h.request_cancel();
        let removed = self
            .queues
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(id);
        if removed {
            self.store.finish(
                id,
                &self.worker_id,
                JobState::Canceled,
                h.progress().0,
                &[],
                &serde_json::json!({}),
                Some("canceled"),
                None,
            )?;
            self.metrics
                .job_finished("canceled", h.kind().as_str(), Duration::ZERO);
            self.retire(&h, JobState::Canceled);
        }
        Ok(true)
    }

    fn retire(&self, h: &Arc<JobHandle>, state: JobState) {
        self.live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&h.id);
        h.state.send_replace(state);
    }

    /// The next job by `take` ([`Queues::take`]), or claimed from a shared store (by lane and
    /// priority alone). Waits for one; None once the queues are closed.
    fn next(&self, take: &Take) -> Option<Queued> {
        let mut qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if qs.closed {
                return None;
            }
            if let Some(q) = qs.take(take) {
                return Some(q);
            }
            if self.shared {
                drop(qs);
                if let Some(q) = self.claim(take.lane, take.up_to) {
                    return Some(q);
                }
                qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
                if qs.closed {
                    return None;
                }
                // Woken by a notification that a job was queued; the timeout covers one
                // that was missed.
                qs = self
                    .wake
                    .wait_timeout(qs, CLAIM_POLL)
                    .unwrap_or_else(|e| e.into_inner())
                    .0;
                continue;
            }
            qs = self.wake.wait(qs).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Claims a job of `lane` from the shared store and builds it; one that cannot be built
    /// (its scene gone, its spec no longer valid) is failed with the reason.
    fn claim(&self, lane: Lane, up_to: Priority) -> Option<Queued> {
        loop {
            let rec = match self.store.claim(
                lane,
                up_to,
                &self.worker_id,
                self.cfg.lease.as_millis() as i64,
            ) {
                Ok(Some(r)) => r,
                Ok(None) => return None,
                Err(e) => {
                    tracing::warn!(error = %e, "cannot claim a job");
                    return None;
                }
            };
            let built = self.scenes.world(&rec.scene_id).and_then(|w| {
                build_job(&rec.spec(), w, &self.cfg.limits, self.cfg.render_budget())
            });
            let job = match built {
                Ok(j) => j,
                Err(e) => {
                    tracing::warn!(job = %rec.id, error = %e, "claimed job cannot be built");
                    let r = self.store.finish(
                        &rec.id,
                        &self.worker_id,
                        JobState::Failed,
                        0.0,
                        &[],
                        &serde_json::json!({ "error_code": e.code() }),
                        Some(&e.to_string()),
                        None,
                    );
                    if let Err(e) = r {
                        tracing::error!(job = %rec.id, error = %e, "cannot record the failure");
                    }
                    continue;
                }
            };
            // Claimed, so taken whatever this process's budget says.
            let memory = self
                .hold_memory(job.memory(), true)
                .expect("a forced hold always succeeds");
            let handle = self
                .live
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .entry(rec.id.clone())
                .or_insert_with(|| JobHandle::new(rec.id.clone()))
                .clone();
            handle.local.store(true, Ordering::SeqCst);
            return Some(Queued {
                priority: job.priority(),
                owner: String::new(),
                tag: 0,
                seq: self.seq.fetch_add(1, Ordering::SeqCst),
                handle,
                job,
                memory,
                claimed: Some(Duration::from_millis(
                    (rec.started_at.unwrap_or(rec.created_at) - rec.created_at).max(0) as u64,
                )),
                counted: false,
            });
        }
    }

    /// Stops taking jobs and waits up to `grace` for running ones; past it, running jobs are
    /// interrupted and left queued for the next start. Queued jobs stay queued in the store.
    /// A job that does not stop within [`ABORT_WAIT`] of the interruption (a loop that never
    /// checks) is abandoned: this returns anyway, so that the process ends, and the store
    /// still has the job as running, which the next start re-queues. Returns how many worker
    /// threads were abandoned.
    pub fn shutdown(&self, grace: Duration) -> usize {
        store::postgres::as_worker(|| self.shutdown_here(grace))
    }

    fn shutdown_here(&self, grace: Duration) -> usize {
        self.queues.lock().unwrap_or_else(|e| e.into_inner()).closed = true;
        self.wake.notify_all();
        let threads: Vec<_> =
            std::mem::take(&mut *self.threads.lock().unwrap_or_else(|e| e.into_inner()));
        let deadline = Instant::now() + grace;
        while threads.iter().any(|t| !t.is_finished()) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.abort.store(true, Ordering::SeqCst);
        let deadline = Instant::now() + ABORT_WAIT;
        while threads.iter().any(|t| !t.is_finished()) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        let mut abandoned = 0;
        for t in threads {
            if t.is_finished() {
                let _ = t.join();
            } else {
                abandoned += 1;
                tracing::error!(
                    thread = t.thread().name().unwrap_or("?"),
                    "a job did not stop after the shutdown grace; abandoning it (it is re-queued \
                     at the next start)"
                );
            }
        }
        if let Err(e) = self.store.flush_uses() {
            tracing::warn!(error = %e, "the last uses of results were not recorded");
        }
        abandoned
    }

    /// The artifact of succeeded job `r`, opened and checked ([`Store::open_artifact`]), with
    /// its length. One that fails its check (missing, a link, truncated, altered) is not
    /// served: the job is marked failed with the reason and submitted again from its recorded
    /// inputs, and the error says whether it was.
    pub fn artifact(&self, r: &JobRecord) -> Result<(std::fs::File, u64), ArtifactError> {
        let Some(path) = &r.artifact_path else {
            return Err(ArtifactError::Store(StoreError::Corrupt(
                "succeeded job without an artifact".into(),
            )));
        };
        let expect = r.artifact_len.zip(r.artifact_sha256.as_deref());
        match self.store.open_artifact(path, expect) {
            Ok(b) => {
                if let Err(e) = self.store.used(&r.id) {
                    tracing::warn!(job = %r.id, error = %e, "last use not recorded");
                }
                Ok(b)
            }
            Err(StoreError::Integrity(why)) => {
                tracing::error!(job = %r.id, %why, "artifact failed its check; re-running the job");
                let error = format!("the stored artifact failed its check: {why}");
                // Only the reader that marks it failed runs it again (not a second reader, nor
                // after the job was deleted).
                if !self
                    .store
                    .fail_lost(&r.id, r.artifact_sha256.as_deref(), &error)?
                {
                    let requeued = self.handle(&r.id).is_some();
                    return Err(ArtifactError::Lost { why, requeued });
                }
                let requeued = match self.submit(&r.id, &r.spec()) {
                    Ok((_, started)) => started,
                    Err(e) => {
                        tracing::warn!(job = %r.id, error = %e, "cannot re-run the job");
                        false
                    }
                };
                Err(ArtifactError::Lost { why, requeued })
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Runs [`Self::sweep`] every `retention.sweep_every` until the queues close.
    fn janitor(&self) {
        self.every(self.cfg.retention.sweep_every, || match self.sweep() {
            Ok(n) if n > 0 => tracing::info!(deleted = n, "retention sweep"),
            Ok(_) => {}
            Err(e) => tracing::warn!(error = %e, "retention sweep failed"),
        });
    }

    /// Deletes finished jobs past their time to live, idempotency records past theirs, then
    /// the least recently served renders while render images take more than the cap
    /// ([`Retention`]). Returns how many went.
    pub fn sweep(&self) -> Result<usize, StoreError> {
        let r = &self.cfg.retention;
        let now = store::now_ms();
        let mut deleted = 0;
        // The uses served since the last sweep, before the eviction by last use reads them.
        self.store.flush_uses()?;
        for (kind, ttl) in [(JobKind::Render, r.render_ttl), (JobKind::Bake, r.bake_ttl)] {
            let Some(ttl) = ttl else { continue };
            for id in self
                .store
                .finished_before(kind, now - ttl.as_millis() as i64)?
            {
                deleted += usize::from(self.store.delete_job(&id)?);
            }
        }
        let expired = self
            .store
            .expire_idempotency(now - r.idempotency_ttl.as_millis() as i64)?;
        if expired > 0 {
            tracing::info!(expired, "idempotency records expired");
        }
        for id in self.store.unheld_scenes(now - 600_000)? {
            if self.store.delete_scene(&id)? {
                self.scenes.forget(&id);
                deleted += 1;
            }
        }
        if let Some(cap) = r.max_render_bytes {
            let renders = self.store.renders_by_last_use()?;
            let mut total: u64 = renders.iter().map(|(_, n)| n).sum();
            for (id, n) in renders {
                if total <= cap {
                    break;
                }
                if self.store.delete_job(&id)? {
                    total -= n;
                    deleted += 1;
                }
            }
        }
        Ok(deleted)
    }

    /// Adds a thread for [`Self::shutdown`] to wait for (tests: a job that never stops).
    #[cfg(test)]
    fn adopt(&self, t: std::thread::JoinHandle<()>) {
        self.threads
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(t);
    }
}

/// How often an idle worker asks a shared store for a job when no notification woke it.
const CLAIM_POLL: Duration = Duration::from_secs(1);

/// How long [`JobSystem::shutdown`] waits for interrupted jobs to stop before it abandons
/// them.
pub const ABORT_WAIT: Duration = Duration::from_secs(3);

/// The text of a caught panic.
pub fn panic_message(p: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A job that never checks for cancellation cannot hold the process past the grace:
    /// shutdown abandons its thread after [`ABORT_WAIT`] and returns.
    #[test]
    fn shutdown_returns_though_a_job_never_stops() {
        let dir = std::env::temp_dir().join(format!("caustica-shutdown-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut cfg = JobConfig::new(&dir);
        cfg.probe_gpu = false;
        let sys = JobSystem::start(cfg).unwrap();
        let (release, blocked) = std::sync::mpsc::channel::<()>();
        sys.adopt(
            std::thread::Builder::new()
                .name("caustica-stubborn".into())
                .spawn(move || {
                    let _ = blocked.recv();
                })
                .unwrap(),
        );
        assert_eq!(sys.shutdown(Duration::from_millis(50)), 1);
        release.send(()).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }
}
