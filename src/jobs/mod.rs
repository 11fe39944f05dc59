//! Jobs: a bounded priority queue, a CPU pool for bakes and reference renders, one GPU worker
//! owning the [`Renderer`], progress, cancellation, timeouts and persistence.
//!
//! - [`Job`]: one type per method behind a small trait (crates.io-worker style): the
//!   [`reference_bake`] bake and the [`render`] jobs; the CSL and transport bakes plug in as
//!   further impls registered in [`build_job`].
//! - [`JobSystem`]: submits, queues (renders before bakes; bounded), runs, records.
//! - [`store`]: SQLite records and atomic artifact files under the data directory.
//! - [`scenes`]: content-addressed scenes and the cache of resolved worlds.
//!
//! Nothing here knows HTTP; errors are domain enums and `http` picks the status codes.

pub mod csl_bake;
pub mod metrics;
pub mod reference_bake;
pub mod render;
pub mod scenes;
pub mod store;
pub mod transport_bake;

use crate::render::Renderer;
use crate::scene::{SceneError, World};
use metrics::Metrics;
use serde::{Deserialize, Serialize};
use std::collections::{BinaryHeap, HashMap};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};
use store::{JobRecord, Store, StoreError};

/// Where a job runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    /// The CPU pool (bakes, reference renders).
    Cpu,
    /// The single GPU worker.
    Gpu,
}

/// Lower runs first: interactive renders before bakes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Priority {
    Render = 0,
    Bake = 1,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    Queued,
    Running,
    Succeeded,
    Failed,
    Canceled,
}

impl JobState {
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Canceled => "canceled",
        }
    }

    pub fn parse(s: &str) -> Option<JobState> {
        Some(match s {
            "queued" => JobState::Queued,
            "running" => JobState::Running,
            "succeeded" => JobState::Succeeded,
            "failed" => JobState::Failed,
            "canceled" => JobState::Canceled,
            _ => return None,
        })
    }

    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Canceled
        )
    }
}

/// What a job produces: bytes to store and serve, plus timings and facts for the record.
#[derive(Clone, Debug)]
pub struct Artifact {
    pub content_type: &'static str,
    /// File extension of the stored artifact.
    pub ext: &'static str,
    pub bytes: Vec<u8>,
    pub timings: Vec<(String, Duration)>,
    /// Adapter, statistics...: shown in the job record.
    pub info: serde_json::Value,
}

#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("canceled")]
    Canceled,
    #[error("the job ran past its time limit of {0:?}")]
    Timeout(Duration),
    /// The server is shutting down; the job goes back to the queue for the next start.
    #[error("interrupted by shutdown")]
    Interrupted,
    #[error("scene: {0}")]
    Scene(#[from] SceneError),
    #[error("scene {0} is not stored")]
    UnknownScene(String),
    #[error("no object named '{0}' in the scene")]
    UnknownObject(String),
    #[error("invalid parameters: {0}")]
    Params(String),
    #[error("no usable GPU: {0}")]
    NoGpu(String),
    #[error("render failed: {0}")]
    Render(String),
    #[error(transparent)]
    Encode(#[from] crate::encode::EncodeError),
    #[error("the job panicked: {0}")]
    Panic(String),
    #[error(transparent)]
    Store(#[from] StoreError),
}

impl JobError {
    /// A stable name for the kind of failure (kept in the record, mapped to a status by
    /// `http`).
    pub fn code(&self) -> &'static str {
        match self {
            JobError::Canceled => "canceled",
            JobError::Timeout(_) => "timeout",
            JobError::Interrupted => "interrupted",
            JobError::Scene(_) | JobError::UnknownScene(_) | JobError::UnknownObject(_) => {
                "invalid_input"
            }
            JobError::Params(_) => "invalid_params",
            JobError::NoGpu(_) => "no_gpu",
            JobError::Render(_) => "render",
            JobError::Encode(_) => "encode",
            JobError::Panic(_) => "panic",
            JobError::Store(_) => "store",
        }
    }
}

/// One kind of work. Implementations hold their inputs (the resolved world and their params)
/// and must poll [`JobCtx::check`] (or [`JobCtx::keep_going`]) often enough for cancellation
/// and timeouts to be prompt.
pub trait Job: Send + Sync {
    /// "bake" or "render".
    fn kind(&self) -> &'static str;
    /// The method name ("reference", "direct", ...).
    fn method(&self) -> &'static str;
    fn lane(&self) -> Lane;
    fn priority(&self) -> Priority {
        if self.kind() == "bake" {
            Priority::Bake
        } else {
            Priority::Render
        }
    }
    fn run(&self, ctx: &JobCtx<'_>) -> Result<Artifact, JobError>;
}

/// What is persisted about a job's inputs; enough to rebuild it after a restart.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct JobSpec {
    pub kind: String,
    pub method: String,
    pub scene_id: String,
    pub object: Option<String>,
    pub params: serde_json::Value,
}

/// Builds the job for a spec: the one registry of job types.
pub fn build_job(
    spec: &JobSpec,
    world: Arc<World>,
    limits: &crate::scene::Limits,
) -> Result<Box<dyn Job>, JobError> {
    match (spec.kind.as_str(), spec.method.as_str()) {
        ("bake", "reference") => Ok(Box::new(reference_bake::ReferenceBake::new(
            world,
            spec.object.as_deref(),
            &spec.params,
            limits,
        )?)),
        ("bake", "csl") => Ok(Box::new(csl_bake::CslBake::new(
            world,
            spec.object.as_deref(),
            &spec.params,
        )?)),
        ("bake", "transport") => Ok(Box::new(transport_bake::TransportBake::new(
            world,
            spec.object.as_deref(),
            &spec.params,
        )?)),
        ("render", _) => Ok(Box::new(render::RenderJob::new(
            world,
            &spec.method,
            &spec.params,
            limits,
        )?)),
        ("bake", m) => Err(JobError::Params(format!(
            "method: unknown bake method '{m}' (available: reference, csl, transport)"
        ))),
        (k, _) => Err(JobError::Params(format!("unknown job kind '{k}'"))),
    }
}

/// Live state of one job, shared by its worker and the HTTP handlers.
pub struct JobHandle {
    pub id: String,
    cancel: AtomicBool,
    live: Mutex<(f32, String)>,
    state: tokio::sync::watch::Sender<JobState>,
    /// When it was put in the queue (for the queue-wait timing).
    enqueued: Instant,
}

impl JobHandle {
    fn new(id: String) -> Arc<JobHandle> {
        Arc::new(JobHandle {
            id,
            cancel: AtomicBool::new(false),
            live: Mutex::new((0.0, String::new())),
            state: tokio::sync::watch::Sender::new(JobState::Queued),
            enqueued: Instant::now(),
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

    pub fn request_cancel(&self) {
        self.cancel.store(true, Ordering::SeqCst);
    }

    pub fn is_cancel_requested(&self) -> bool {
        self.cancel.load(Ordering::SeqCst)
    }
}

/// The GPU worker's device: created on first use; its error is kept when there is none.
#[derive(Default)]
pub struct GpuSlot {
    renderer: Option<Renderer>,
    error: Option<String>,
}

impl GpuSlot {
    fn get(&mut self) -> Result<&mut Renderer, JobError> {
        if self.renderer.is_none() && self.error.is_none() {
            let made = catch_unwind(|| -> Result<Renderer, String> {
                let cfg = crate::gpu::GpuConfig::from_env();
                let ctx = crate::gpu::GpuContext::new(&cfg).map_err(|e| e.to_string())?;
                Renderer::new(Arc::new(ctx)).map_err(|e| e.to_string())
            })
            .unwrap_or_else(|p| Err(panic_message(p)));
            match made {
                Ok(r) => self.renderer = Some(r),
                Err(e) => {
                    tracing::error!(error = %e, "no GPU renderer: GPU renders will fail");
                    self.error = Some(e);
                }
            }
        }
        match (&mut self.renderer, &self.error) {
            (Some(r), _) => Ok(r),
            (None, Some(e)) => Err(JobError::NoGpu(e.clone())),
            (None, None) => unreachable!("set above"),
        }
    }
}

/// What a running job sees: progress reporting, cancellation, its deadline, the GPU.
pub struct JobCtx<'a> {
    handle: &'a JobHandle,
    system: &'a JobSystem,
    deadline: Instant,
    timeout: Duration,
    gpu: Option<&'a Mutex<GpuSlot>>,
    last_store: Mutex<Instant>,
}

impl JobCtx<'_> {
    /// Reports progress (0..1) and the current stage; persisted at most a few times a second.
    pub fn progress(&self, fraction: f32, stage: &str) {
        let f = fraction.clamp(0.0, 1.0);
        {
            let mut l = self.handle.live.lock().unwrap_or_else(|e| e.into_inner());
            l.0 = l.0.max(f);
            if l.1 != stage {
                l.1 = stage.to_string();
            }
        }
        let mut last = self.last_store.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed() > Duration::from_millis(250) {
            *last = Instant::now();
            let (p, s) = self.handle.progress();
            if let Err(e) = self.system.store.set_progress(&self.handle.id, p, &s) {
                tracing::warn!(error = %e, job = %self.handle.id, "progress not stored");
            }
        }
    }

    /// The job error for a bake's error: a cancelled bake stopped for the reason [`Self::check`]
    /// gives, an unknown object is named, anything else is a parameter problem.
    pub fn bake_error(&self, e: crate::bake::BakeError) -> JobError {
        use crate::bake::BakeError;
        match e {
            BakeError::Canceled => self.check().err().unwrap_or(JobError::Canceled),
            BakeError::UnknownObject(o) => JobError::UnknownObject(o),
            other => JobError::Params(other.to_string()),
        }
    }

    /// Ok while the job should go on; the reason to stop otherwise.
    pub fn check(&self) -> Result<(), JobError> {
        if self.handle.is_cancel_requested() {
            Err(JobError::Canceled)
        } else if self.system.abort.load(Ordering::SeqCst) {
            Err(JobError::Interrupted)
        } else if Instant::now() > self.deadline {
            Err(JobError::Timeout(self.timeout))
        } else {
            Ok(())
        }
    }

    pub fn keep_going(&self) -> bool {
        self.check().is_ok()
    }

    /// Where a job may keep files between runs (caches keyed by content hash).
    pub fn data_dir(&self) -> &std::path::Path {
        &self.system.cfg.data_dir
    }

    /// The GPU renderer, created on first use; held for the duration of `f`.
    pub fn with_renderer<T>(
        &self,
        f: impl FnOnce(&mut Renderer) -> Result<T, JobError>,
    ) -> Result<T, JobError> {
        let slot = self
            .gpu
            .ok_or_else(|| JobError::NoGpu("this job is not on the GPU worker".into()))?;
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        f(slot.get()?)
    }
}

/// Tunables of the job system.
#[derive(Clone, Debug)]
pub struct JobConfig {
    pub data_dir: PathBuf,
    /// Threads taking CPU jobs (each job may use rayon's pool inside). With more than one,
    /// the first is kept for renders.
    pub cpu_workers: usize,
    /// Most jobs waiting in the queues together; past it submissions are refused.
    pub max_queued: usize,
    pub bake_timeout: Duration,
    pub render_timeout: Duration,
    /// Scene limits applied to uploads and renders.
    pub limits: crate::scene::Limits,
    /// Skip the GPU readiness probe at start (tests of the queue alone).
    pub probe_gpu: bool,
}

impl JobConfig {
    pub fn new(data_dir: impl Into<PathBuf>) -> JobConfig {
        JobConfig {
            data_dir: data_dir.into(),
            cpu_workers: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(2),
            max_queued: 256,
            bake_timeout: Duration::from_secs(3600),
            render_timeout: Duration::from_secs(300),
            // Image side capped below the library's 8192: a reference frame holds several
            // float layers (~100 bytes a pixel), so 4096² is already ~1.7 GB.
            limits: crate::scene::Limits {
                max_image_side: 4096,
                ..Default::default()
            },
            probe_gpu: true,
        }
    }
}

impl JobConfig {
    /// Overrides from the environment (`get` looks a variable up; `caustica serve` passes
    /// `std::env::var`): `CAUSTICA_CPU_WORKERS`, `CAUSTICA_MAX_QUEUED`,
    /// `CAUSTICA_BAKE_TIMEOUT_S`, `CAUSTICA_RENDER_TIMEOUT_S`, `CAUSTICA_MAX_IMAGE_SIDE`,
    /// `CAUSTICA_MAX_TRIANGLES`. An unparsable or out-of-range value is an error naming it.
    pub fn apply_env(&mut self, get: &dyn Fn(&str) -> Option<String>) -> Result<(), String> {
        if let Some(v) = env_num(get, "CAUSTICA_CPU_WORKERS", 1.0, 1024.0, true)? {
            self.cpu_workers = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_QUEUED", 1.0, 1e6, true)? {
            self.max_queued = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_BAKE_TIMEOUT_S", 1e-3, 1e7, false)? {
            self.bake_timeout = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_RENDER_TIMEOUT_S", 1e-3, 1e7, false)? {
            self.render_timeout = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_IMAGE_SIDE", 1.0, 8192.0, true)? {
            self.limits.max_image_side = v as u32;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_TRIANGLES", 1.0, 1e9, true)? {
            self.limits.max_triangles = v as usize;
        }
        Ok(())
    }
}

/// Variable `name` as a number in [lo, hi] (a whole one when `integer`), if set and not blank.
pub fn env_num(
    get: &dyn Fn(&str) -> Option<String>,
    name: &str,
    lo: f64,
    hi: f64,
    integer: bool,
) -> Result<Option<f64>, String> {
    let Some(raw) = get(name).filter(|v| !v.trim().is_empty()) else {
        return Ok(None);
    };
    let v: f64 = raw
        .trim()
        .parse()
        .map_err(|_| format!("{name}={raw:?}: not a number"))?;
    if !(lo..=hi).contains(&v) || (integer && v.fract() != 0.0) {
        let kind = if integer {
            "a whole number"
        } else {
            "a number"
        };
        return Err(format!("{name}={raw:?}: must be {kind} in {lo}..={hi}"));
    }
    Ok(Some(v))
}

/// A queued job waiting for a worker.
struct Queued {
    priority: Priority,
    seq: u64,
    job: Box<dyn Job>,
    handle: Arc<JobHandle>,
}

impl PartialEq for Queued {
    fn eq(&self, o: &Self) -> bool {
        (self.priority, self.seq) == (o.priority, o.seq)
    }
}
impl Eq for Queued {}
impl PartialOrd for Queued {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Queued {
    /// BinaryHeap pops the greatest: invert so the lowest (priority, seq) comes first.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (o.priority, o.seq).cmp(&(self.priority, self.seq))
    }
}

#[derive(Default)]
struct Queues {
    cpu: BinaryHeap<Queued>,
    gpu: BinaryHeap<Queued>,
    /// No more jobs are taken; workers exit when they see it.
    closed: bool,
}

impl Queues {
    fn len(&self) -> usize {
        self.cpu.len() + self.gpu.len()
    }
}

/// Whether the GPU worker found an adapter and rendered the probe frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Readiness {
    Starting,
    Ready { adapter: String },
    NoGpu { error: String },
}

#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error("the queue is full ({0} jobs waiting)")]
    QueueFull(usize),
    #[error("the server is shutting down")]
    ShuttingDown,
    #[error(transparent)]
    Job(#[from] JobError),
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// The queue, the workers and the records.
pub struct JobSystem {
    pub store: Arc<Store>,
    pub scenes: scenes::Scenes,
    pub metrics: Arc<Metrics>,
    cfg: JobConfig,
    queues: Mutex<Queues>,
    wake: Condvar,
    live: Mutex<HashMap<String, Arc<JobHandle>>>,
    seq: AtomicU64,
    /// Set at the shutdown deadline: running jobs stop and go back to the queue.
    abort: AtomicBool,
    readiness: Mutex<Readiness>,
    threads: Mutex<Vec<std::thread::JoinHandle<()>>>,
    /// The one renderer. The GPU worker takes its jobs; a CPU job that ends on the GPU (a `csl`
    /// render: bake on the CPU pool, then one frame) borrows it through the same lock, so the
    /// device is never used by two threads at once and a long bake never holds it.
    gpu: Arc<Mutex<GpuSlot>>,
}

impl JobSystem {
    /// Opens the store, re-queues what a previous process left unfinished and starts the
    /// workers.
    pub fn start(cfg: JobConfig) -> Result<Arc<JobSystem>, SubmitError> {
        let store = Arc::new(Store::open(&cfg.data_dir)?);
        let sys = Arc::new(JobSystem {
            scenes: scenes::Scenes::new(store.clone(), cfg.limits.clone()),
            store,
            metrics: Arc::new(Metrics::default()),
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
            gpu: Arc::new(Mutex::new(GpuSlot::default())),
            cfg,
        });
        for rec in sys.store.unfinished_jobs()? {
            let spec = spec_of(&rec);
            tracing::info!(job = %rec.id, kind = %rec.kind, "re-queueing unfinished job");
            let r = sys
                .scenes
                .world(&rec.scene_id)
                .and_then(|w| build_job(&spec, w, &sys.cfg.limits));
            match r {
                Ok(job) => {
                    sys.store.set_queued(&rec.id)?;
                    sys.enqueue(rec.id.clone(), job);
                }
                Err(e) => {
                    sys.store.finish(
                        &rec.id,
                        "failed",
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
        let n = sys.cfg.cpu_workers.max(1);
        for i in 0..n {
            let s = sys.clone();
            // With more than one CPU worker, the first takes only renders, so that an
            // interactive reference render never waits behind long bakes.
            let renders_only = n > 1 && i == 0;
            threads.push(
                std::thread::Builder::new()
                    .name(format!("caustica-cpu-{i}"))
                    .spawn(move || {
                        let gpu = s.gpu.clone();
                        s.worker(Lane::Cpu, Some(&gpu), renders_only)
                    })
                    .expect("spawn worker"),
            );
        }
        let s = sys.clone();
        threads.push(
            std::thread::Builder::new()
                .name("caustica-gpu".into())
                .spawn(move || {
                    let slot = s.gpu.clone();
                    if s.cfg.probe_gpu {
                        s.probe(&slot);
                    }
                    s.worker(Lane::Gpu, Some(&slot), false);
                })
                .expect("spawn GPU worker"),
        );
        *sys.threads.lock().unwrap_or_else(|e| e.into_inner()) = threads;
        Ok(sys)
    }

    pub fn config(&self) -> &JobConfig {
        &self.cfg
    }

    pub fn readiness(&self) -> Readiness {
        self.readiness
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Jobs waiting, per lane (cpu, gpu).
    pub fn queue_depth(&self) -> (usize, usize) {
        let q = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        (q.cpu.len(), q.gpu.len())
    }

    /// Renders a tiny frame to learn whether the GPU works (for `/readyz`).
    fn probe(&self, slot: &Mutex<GpuSlot>) {
        let r = (|| -> Result<String, JobError> {
            let world = scenes::probe_world()?;
            let mut s = slot.lock().unwrap_or_else(|e| e.into_inner());
            let renderer = s.get()?;
            let out = renderer
                .render(&world, &crate::render::RenderOptions::default())
                .map_err(|e| JobError::Render(e.to_string()))?;
            Ok(out.adapter)
        })();
        let state = match r {
            Ok(adapter) => {
                tracing::info!(%adapter, "GPU ready");
                Readiness::Ready { adapter }
            }
            Err(e) => Readiness::NoGpu {
                error: e.to_string(),
            },
        };
        *self.readiness.lock().unwrap_or_else(|e| e.into_inner()) = state;
    }

    /// The live handle of a job queued or running in this process.
    pub fn handle(&self, id: &str) -> Option<Arc<JobHandle>> {
        self.live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(id)
            .cloned()
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
            && matches!(r.state.as_str(), "succeeded" | "queued" | "running")
        {
            return Ok((self.handle(id), false));
        }
        {
            let q = self.queues.lock().unwrap_or_else(|e| e.into_inner());
            if q.len() >= self.cfg.max_queued {
                return Err(SubmitError::QueueFull(q.len()));
            }
        }
        let world = self.scenes.world(&spec.scene_id)?;
        let job = build_job(spec, world, &self.cfg.limits)?;
        if existing.is_some() {
            self.store.requeue(id)?;
        } else {
            self.store.insert_job(&JobRecord {
                id: id.into(),
                kind: spec.kind.clone(),
                method: spec.method.clone(),
                scene_id: spec.scene_id.clone(),
                object: spec.object.clone(),
                params: spec.params.clone(),
                state: "queued".into(),
                progress: 0.0,
                stage: String::new(),
                timings: vec![],
                info: serde_json::json!({}),
                error: None,
                artifact_type: None,
                artifact_path: None,
                created_at: store::now_ms(),
                started_at: None,
                finished_at: None,
            })?;
        }
        let h = self.enqueue(id.to_string(), job);
        Ok((Some(h), true))
    }

    fn enqueue(&self, id: String, job: Box<dyn Job>) -> Arc<JobHandle> {
        let handle = JobHandle::new(id.clone());
        self.live
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(id, handle.clone());
        let q = Queued {
            priority: job.priority(),
            seq: self.seq.fetch_add(1, Ordering::SeqCst),
            handle: handle.clone(),
            job,
        };
        let mut qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        match q.job.lane() {
            Lane::Cpu => qs.cpu.push(q),
            Lane::Gpu => qs.gpu.push(q),
        }
        drop(qs);
        self.wake.notify_all();
        handle
    }

    /// Cancels a job: a queued one is dropped at once, a running one stops at its next check.
    /// Returns false when the job is not queued or running here.
    pub fn cancel(&self, id: &str) -> Result<bool, StoreError> {
        let Some(h) = self.handle(id) else {
            return Ok(false);
        };
        h.request_cancel();
        let removed = {
            let mut qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
            let before = qs.len();
            qs.cpu.retain(|q| q.handle.id != id);
            qs.gpu.retain(|q| q.handle.id != id);
            before != qs.len()
        };
        if removed {
            self.store.finish(
                id,
                "canceled",
                h.progress().0,
                &[],
                &serde_json::json!({}),
                Some("canceled"),
                None,
            )?;
            self.metrics
                .job_finished("canceled", h.job_kind_hint(), Duration::ZERO);
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

    /// The next job of `lane` (highest priority, then oldest); with `renders_only`, only a
    /// render. None once the queues are closed.
    fn next(&self, lane: Lane, renders_only: bool) -> Option<Queued> {
        let mut qs = self.queues.lock().unwrap_or_else(|e| e.into_inner());
        loop {
            if qs.closed {
                return None;
            }
            let heap = match lane {
                Lane::Cpu => &mut qs.cpu,
                Lane::Gpu => &mut qs.gpu,
            };
            let take = heap
                .peek()
                .is_some_and(|q| !renders_only || q.priority == Priority::Render);
            if take && let Some(q) = heap.pop() {
                return Some(q);
            }
            qs = self.wake.wait(qs).unwrap_or_else(|e| e.into_inner());
        }
    }

    fn worker(&self, lane: Lane, gpu: Option<&Mutex<GpuSlot>>, renders_only: bool) {
        while let Some(q) = self.next(lane, renders_only) {
            self.run_one(q, gpu);
        }
    }

    fn run_one(&self, q: Queued, gpu: Option<&Mutex<GpuSlot>>) {
        let h = q.handle.clone();
        let id = h.id.clone();
        let kind = q.job.kind();
        let queue_wait = h.enqueued.elapsed();
        if let Err(e) = self.store.set_running(&id) {
            tracing::error!(job = %id, error = %e, "cannot mark running");
        }
        h.state.send_replace(JobState::Running);
        let timeout = if kind == "bake" {
            self.cfg.bake_timeout
        } else {
            self.cfg.render_timeout
        };
        let ctx = JobCtx {
            handle: &h,
            system: self,
            deadline: Instant::now() + timeout,
            timeout,
            gpu,
            last_store: Mutex::new(Instant::now()),
        };
        let span = tracing::info_span!("job", id = %id, kind, method = q.job.method());
        let _g = span.enter();
        tracing::info!(queue_ms = queue_wait.as_secs_f64() * 1e3, "job started");
        let t = Instant::now();
        let result = ctx.check().and_then(|()| {
            catch_unwind(AssertUnwindSafe(|| q.job.run(&ctx)))
                .unwrap_or_else(|p| Err(JobError::Panic(panic_message(p))))
        });
        let run_time = t.elapsed();
        let (progress, _) = h.progress();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let (state, rec) = match result {
            Ok(a) => {
                let mut timings = vec![("queue".to_string(), ms(queue_wait))];
                timings.extend(a.timings.iter().map(|(n, d)| (n.clone(), ms(*d))));
                let gpu_ms: f64 = a
                    .timings
                    .iter()
                    .filter(|(n, _)| n.starts_with("gpu:"))
                    .map(|(_, d)| ms(*d))
                    .sum();
                self.metrics.gpu_time(gpu_ms / 1e3);
                let r = self
                    .store
                    .write_artifact(&id, a.ext, &a.bytes)
                    .and_then(|path| {
                        self.store.finish(
                            &id,
                            "succeeded",
                            1.0,
                            &timings,
                            &a.info,
                            None,
                            Some((a.content_type, &path)),
                        )
                    });
                match r {
                    Ok(()) => (JobState::Succeeded, Ok(())),
                    Err(e) => {
                        let msg = format!("storing the artifact failed: {e}");
                        (
                            JobState::Failed,
                            self.store.finish(
                                &id,
                                "failed",
                                progress,
                                &timings,
                                &a.info,
                                Some(&msg),
                                None,
                            ),
                        )
                    }
                }
            }
            Err(JobError::Interrupted) => {
                tracing::info!("interrupted by shutdown; left queued for the next start");
                let r = self.store.set_queued(&id);
                if let Err(e) = r {
                    tracing::error!(error = %e, "cannot re-queue");
                }
                // The handle goes away with the process; waiters see "queued".
                self.live
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .remove(&id);
                return;
            }
            Err(JobError::Canceled) => (
                JobState::Canceled,
                self.store.finish(
                    &id,
                    "canceled",
                    progress,
                    &[
                        ("queue".into(), ms(queue_wait)),
                        ("run".into(), ms(run_time)),
                    ],
                    &serde_json::json!({}),
                    Some("canceled"),
                    None,
                ),
            ),
            Err(e) => {
                tracing::warn!(error = %e, "job failed");
                (
                    JobState::Failed,
                    self.store.finish(
                        &id,
                        "failed",
                        progress,
                        &[
                            ("queue".into(), ms(queue_wait)),
                            ("run".into(), ms(run_time)),
                        ],
                        &serde_json::json!({ "error_code": e.code() }),
                        Some(&e.to_string()),
                        None,
                    ),
                )
            }
        };
        if let Err(e) = rec {
            tracing::error!(error = %e, "cannot record the job's end");
        }
        tracing::info!(
            state = state.as_str(),
            run_ms = ms(run_time),
            "job finished"
        );
        self.metrics.job_finished(state.as_str(), kind, run_time);
        self.retire(&h, state);
    }

    /// Stops taking jobs and waits up to `grace` for running ones; past it, running jobs are
    /// interrupted and left queued for the next start. Queued jobs stay queued in the store.
    pub fn shutdown(&self, grace: Duration) {
        self.queues.lock().unwrap_or_else(|e| e.into_inner()).closed = true;
        self.wake.notify_all();
        let threads: Vec<_> =
            std::mem::take(&mut *self.threads.lock().unwrap_or_else(|e| e.into_inner()));
        let deadline = Instant::now() + grace;
        while threads.iter().any(|t| !t.is_finished()) && Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        self.abort.store(true, Ordering::SeqCst);
        for t in threads {
            let _ = t.join();
        }
    }
}

impl JobHandle {
    fn job_kind_hint(&self) -> &'static str {
        if self.id.starts_with("bk_") {
            "bake"
        } else {
            "render"
        }
    }
}

/// The spec stored in a record.
pub fn spec_of(r: &JobRecord) -> JobSpec {
    JobSpec {
        kind: r.kind.clone(),
        method: r.method.clone(),
        scene_id: r.scene_id.clone(),
        object: r.object.clone(),
        params: r.params.clone(),
    }
}

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

    #[test]
    fn environment_overrides_limits_and_names_bad_values() {
        let vars = |pairs: &'static [(&'static str, &'static str)]| {
            move |k: &str| {
                pairs
                    .iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| v.to_string())
            }
        };
        let mut c = JobConfig::new("/tmp/unused");
        c.apply_env(&vars(&[
            ("CAUSTICA_CPU_WORKERS", "3"),
            ("CAUSTICA_RENDER_TIMEOUT_S", "2.5"),
            ("CAUSTICA_MAX_IMAGE_SIDE", " 1024 "),
            ("CAUSTICA_MAX_QUEUED", ""),
        ]))
        .unwrap();
        assert_eq!(c.cpu_workers, 3);
        assert_eq!(c.render_timeout, Duration::from_millis(2500));
        assert_eq!(c.limits.max_image_side, 1024);
        assert_eq!(c.max_queued, 256, "blank keeps the default");
        let e = c
            .apply_env(&vars(&[("CAUSTICA_MAX_QUEUED", "lots")]))
            .unwrap_err();
        assert!(
            e.contains("CAUSTICA_MAX_QUEUED") && e.contains("not a number"),
            "{e}"
        );
        let e = c
            .apply_env(&vars(&[("CAUSTICA_CPU_WORKERS", "1.5")]))
            .unwrap_err();
        assert!(e.contains("whole number"), "{e}");
        let e = c
            .apply_env(&vars(&[("CAUSTICA_MAX_IMAGE_SIDE", "100000")]))
            .unwrap_err();
        assert!(e.contains("1..=8192"), "{e}");
    }
}
