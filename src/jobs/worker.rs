//! The workers: threads that take jobs from a lane's queue and run them, what a running job
//! sees ([`JobCtx`]: progress, cancellation, its deadline, the GPU, the artifact store), and
//! how a job's end is recorded.

use super::job::{Artifact, ErrorCode, JobError, JobKind, JobState};
use super::queue::{Queued, Take};
use super::{JobHandle, JobSystem, Readiness, panic_message, scenes};
use crate::methods::{Env, Gpu, Lane, MethodError};
use crate::render::Renderer;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The device the GPU workers share: created on first use; its error is kept when there is
/// none. wgpu's device and queue take work from several threads (error scopes are per thread).
#[derive(Default)]
pub struct GpuDevice(Mutex<Option<Result<Arc<crate::gpu::GpuContext>, String>>>);

impl GpuDevice {
    fn get(&self) -> Result<Arc<crate::gpu::GpuContext>, String> {
        let mut d = self.0.lock().unwrap_or_else(|e| e.into_inner());
        d.get_or_insert_with(|| {
            catch_unwind(|| {
                let cfg = crate::gpu::GpuConfig::from_env();
                crate::gpu::GpuContext::new(&cfg)
                    .map(Arc::new)
                    .map_err(|e| e.to_string())
            })
            .unwrap_or_else(|p| Err(panic_message(p)))
        })
        .clone()
    }
}

/// A GPU worker's renderer (its pipelines and caches) on the shared device: created on first
/// use; its error is kept when there is none.
pub struct GpuSlot {
    device: Arc<GpuDevice>,
    renderer: Option<Renderer>,
    error: Option<String>,
}

impl GpuSlot {
    /// A slot whose renderer will be made on `device`.
    pub fn on(device: Arc<GpuDevice>) -> GpuSlot {
        GpuSlot {
            device,
            renderer: None,
            error: None,
        }
    }

    /// The renderer, or why there is none.
    fn get(&mut self) -> Result<&mut Renderer, String> {
        if self.renderer.is_none() && self.error.is_none() {
            let made = self.device.get().and_then(|ctx| {
                catch_unwind(AssertUnwindSafe(|| {
                    Renderer::new(ctx).map_err(|e| e.to_string())
                }))
                .unwrap_or_else(|p| Err(panic_message(p)))
            });
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
            (None, Some(e)) => Err(e.clone()),
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
        self.handle.report(f, stage);
        let mut last = self.last_store.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed() > Duration::from_millis(250) {
            *last = Instant::now();
            let (p, s) = self.handle.progress();
            if let Err(e) = self.system.store.set_progress(&self.handle.id, p, &s) {
                tracing::warn!(error = %e, job = %self.handle.id, "progress not stored");
            }
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

    /// Queues a bake of `method` with the canonical `params` for each of `objects`, in this
    /// job's scene with its lights replaced by `lights` (that scene stored too), held by the
    /// key this job runs for; the bakes' ids. A bake already queued, running or done is not
    /// queued again.
    pub fn queue_bakes(
        &self,
        lights: Option<&[crate::scene::types::LightDesc]>,
        method: crate::methods::Method,
        objects: &[String],
        params: &serde_json::Value,
    ) -> Result<Vec<String>, String> {
        use super::job::JobSpec;
        use super::store::Held;
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let store = &self.system.store;
        let id = &self.handle.id;
        let rec = store
            .get_job(id)
            .map_err(|e| err(&e))?
            .ok_or("the job's record is gone")?;
        let owner = store
            .first_holder(Held::Job, id)
            .map_err(|e| err(&e))?
            .unwrap_or_default();
        let scene = store
            .get_scene(&rec.scene_id)
            .map_err(|e| err(&e))?
            .ok_or("the job's scene is gone")?;
        let mut json = scene.scene_json;
        if let Some(lights) = lights {
            let mut v: serde_json::Value = serde_json::from_slice(&json).map_err(|e| err(&e))?;
            v["lights"] = serde_json::to_value(lights).map_err(|e| err(&e))?;
            json = serde_json::to_vec(&v).map_err(|e| err(&e))?;
        }
        // The scene with these lights is kept only while the bakes need it (a scene nobody
        // holds is swept once no queued or running job uses it), unless the key held it already.
        let derived = scenes::json_scene_id(&json, &scene.files).map_err(|e| err(&e))?;
        let held = store
            .holds(Held::Scene, &derived, &owner)
            .map_err(|e| err(&e))?;
        let input = scenes::SceneInput::Json {
            scene: json,
            files: scene.files,
        };
        let info = self
            .system
            .scenes
            .ingest(input, &owner)
            .map_err(|e| err(&e))?;
        let queue = |object: &String| -> Result<String, String> {
            let spec = JobSpec {
                kind: JobKind::Bake,
                method,
                scene_id: info.id.clone(),
                object: Some(object.clone()),
                params: params.clone(),
            };
            let bake = spec.bake_id();
            let had = store.holds(Held::Job, &bake, &owner).map_err(|e| err(&e))?;
            // Within the key's quota, as the bakes it asks for itself.
            self.system
                .hold_job(&bake, &owner)
                .map_err(|e| err(&e))?
                .map_err(|n| {
                    format!("key '{owner}' holds {n} queued or running jobs, its quota")
                })?;
            let submitted = self.system.submit(&bake, &spec);
            if submitted.is_err() && !had {
                let _ = store.release(Held::Job, &bake, &owner);
            }
            submitted.map_err(|e| err(&e))?;
            Ok(bake)
        };
        let ids = objects.iter().map(queue).collect::<Result<Vec<_>, _>>();
        if !held && let Err(e) = store.release(Held::Scene, &info.id, &owner) {
            tracing::warn!(error = %e, scene = %info.id, "the bakes' scene is still held");
        }
        ids
    }

    /// The job error for a method's error: a cancelled method stopped for the reason
    /// [`Self::check`] gives.
    pub fn method_error(&self, e: MethodError) -> JobError {
        match e {
            MethodError::Canceled => self.check().err().unwrap_or(JobError::Canceled),
            other => other.into(),
        }
    }

    /// `f` with the [`Env`] a method runs in: this job's progress and cancellation, the GPU,
    /// and the data directory's artifact store.
    pub fn with_env<T>(&self, f: impl FnOnce(&Env) -> T) -> T {
        let progress = |fraction: f32, stage: &str| self.progress(fraction, stage);
        let keep_going = || self.keep_going();
        f(&Env {
            progress: &progress,
            keep_going: &keep_going,
            gpu: self,
            store: &self.system.bakes,
        })
    }
}

impl Gpu for JobCtx<'_> {
    /// The GPU renderer, created on first use; held for the duration of `f`.
    fn with_renderer(
        &self,
        f: &mut dyn FnMut(&mut Renderer) -> Result<(), MethodError>,
    ) -> Result<(), MethodError> {
        let slot = self
            .gpu
            .ok_or_else(|| MethodError::NoGpu("this job is not on the GPU worker".into()))?;
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        f(slot.get().map_err(MethodError::NoGpu)?)
    }
}

impl JobSystem {
    /// Takes jobs by `take` until the queues close.
    /// Each CPU worker runs its jobs in a thread pool of its own (as many threads as cores),
    /// so that jobs on different workers share the cores through the operating system's
    /// scheduler: in one shared pool, a render's parallel loop waits until a bake's loop has
    /// left a thread idle, which for a bake's camera pass (one loop over the whole image) is
    /// the whole pass (a 64×48 render waited 25 s behind a 256² × 1024-sample bake).
    pub(super) fn worker(&self, take: Take, gpu: Option<&Mutex<GpuSlot>>) {
        let name = std::thread::current()
            .name()
            .unwrap_or("caustica-cpu")
            .to_string();
        let own_pool = (take.lane == Lane::Cpu)
            .then(|| {
                rayon::ThreadPoolBuilder::new()
                    .thread_name(move |i| format!("{name}-{i}"))
                    .build()
                    .map_err(|e| tracing::warn!(error = %e, "no pool of its own for a worker"))
                    .ok()
            })
            .flatten();
        while let Some(q) = self.next(&take) {
            let counted = q.counted.then(|| q.owner.clone());
            match &own_pool {
                Some(pool) => pool.install(|| self.run_one(q, gpu)),
                None => self.run_one(q, gpu),
            }
            if let Some(owner) = counted {
                // Its key may start its next job now, on any worker of the lane.
                self.queues
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .finished(&owner, take.lane);
                self.wake.notify_all();
            }
        }
    }

    /// Renders a tiny frame to learn whether the GPU works (for `/readyz`).
    pub(super) fn probe(&self, slot: &Mutex<GpuSlot>) {
        let r = (|| -> Result<String, JobError> {
            let world = scenes::probe_world()?;
            let mut s = slot.lock().unwrap_or_else(|e| e.into_inner());
            let renderer = s.get().map_err(JobError::NoGpu)?;
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

    fn run_one(&self, q: Queued, gpu: Option<&Mutex<GpuSlot>>) {
        let h = q.handle.clone();
        let id = h.id.clone();
        let kind = q.job.kind();
        let queue_wait = q.claimed.unwrap_or_else(|| h.enqueued.elapsed());
        h.local.store(true, Ordering::SeqCst);
        if q.claimed.is_none() {
            match self
                .store
                .set_running(&id, &self.worker_id, self.cfg.lease.as_millis() as i64)
            {
                Ok(true) => {}
                Ok(false) => {
                    // Its record moved on while it waited here (deleted, or ended elsewhere).
                    tracing::warn!(job = %id, "not queued in the store any more; skipped");
                    let state = self
                        .store
                        .get_job(&id)
                        .ok()
                        .flatten()
                        .map_or(JobState::Canceled, |r| r.state);
                    self.retire(&h, state);
                    return;
                }
                Err(e) => tracing::error!(job = %id, error = %e, "cannot mark running"),
            }
        }
        h.state.send_replace(JobState::Running);
        let timeout = match kind {
            JobKind::Bake => self.cfg.bake_timeout,
            JobKind::Render => self.cfg.render_timeout,
        };
        let ctx = JobCtx {
            handle: &h,
            system: self,
            deadline: Instant::now() + timeout,
            timeout,
            gpu,
            last_store: Mutex::new(Instant::now()),
        };
        let span = tracing::info_span!(
            "job",
            id = %id,
            kind = kind.as_str(),
            method = q.job.method().name()
        );
        let _g = span.enter();
        tracing::info!(
            queue_ms = queue_wait.as_secs_f64() * 1e3,
            memory_mib = q.memory.bytes >> 20,
            "job started"
        );
        let t = Instant::now();
        let result = ctx.check().and_then(|()| {
            catch_unwind(AssertUnwindSafe(|| q.job.run(&ctx)))
                .unwrap_or_else(|p| Err(JobError::Panic(panic_message(p))))
        });
        let run_time = t.elapsed();
        let (progress, _) = h.progress();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let short = [
            ("queue".to_string(), ms(queue_wait)),
            ("run".to_string(), ms(run_time)),
        ];
        let (state, rec) = match result {
            Ok(a) => self.record_success(&id, a, ms(queue_wait), progress),
            Err(JobError::Interrupted) => {
                tracing::info!("interrupted by shutdown; left queued for the next start");
                let r = self.store.set_queued(&id, &self.worker_id);
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
                    &self.worker_id,
                    JobState::Canceled,
                    progress,
                    &short,
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
                        &self.worker_id,
                        JobState::Failed,
                        progress,
                        &short,
                        &serde_json::json!({ "error_code": e.code() }),
                        Some(&e.to_string()),
                        None,
                    ),
                )
            }
        };
        let state = match rec {
            Ok(true) => state,
            Ok(false) => {
                // Its lease ran out and the store gave it to another worker (or it was
                // deleted): that worker's end stands.
                tracing::warn!(
                    "the job is no longer this worker's (its lease ran out); its end here is \
                     not recorded"
                );
                let now = self.store.get_job(&id).ok().flatten().map(|r| r.state);
                if let Some(s) = now.filter(|s| !s.is_terminal()) {
                    // Another worker runs it: this process's handle follows its record from
                    // now on, so that whoever waits here sees that worker's end.
                    tracing::info!(state = s.as_str(), "job handed over");
                    h.local.store(false, Ordering::SeqCst);
                    self.refresh(&id);
                    return;
                }
                now.unwrap_or(state)
            }
            Err(e) => {
                tracing::error!(error = %e, "cannot record the job's end");
                state
            }
        };
        tracing::info!(
            state = state.as_str(),
            run_ms = ms(run_time),
            "job finished"
        );
        self.metrics
            .job_finished(state.as_str(), kind.as_str(), run_time);
        self.retire(&h, state);
    }

    /// Writes a succeeded job's artifact, then its record (so a record never names a missing
    /// file); a failure to store is the job's failure.
    fn record_success(
        &self,
        id: &str,
        a: Artifact,
        queue_ms: f64,
        progress: f32,
    ) -> (JobState, Result<bool, super::store::StoreError>) {
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mut timings = vec![("queue".to_string(), queue_ms)];
        timings.extend(a.timings.iter().map(|(n, d)| (n.clone(), ms(*d))));
        let gpu_ms: f64 = a
            .timings
            .iter()
            .filter(|(n, _)| n.starts_with("gpu:"))
            .map(|(_, d)| ms(*d))
            .sum();
        self.metrics.gpu_time(gpu_ms / 1e3);
        let t = Instant::now();
        let r = self
            .store
            .write_artifact(id, a.ext, &a.bytes)
            .and_then(|stored| {
                // The artifact's atomic write (file, fsync, rename, fsync of the folder).
                timings.push(("store".to_string(), ms(t.elapsed())));
                self.store.finish(
                    id,
                    &self.worker_id,
                    JobState::Succeeded,
                    1.0,
                    &timings,
                    &a.info,
                    None,
                    Some((a.content_type, &stored)),
                )
            });
        match r {
            Ok(done) => (JobState::Succeeded, Ok(done)),
            Err(e) => {
                let msg = format!("storing the artifact failed: {e}");
                let info = serde_json::json!({ "error_code": ErrorCode::Store });
                (
                    JobState::Failed,
                    self.store.finish(
                        id,
                        &self.worker_id,
                        JobState::Failed,
                        progress,
                        &timings,
                        &info,
                        Some(&msg),
                        None,
                    ),
                )
            }
        }
    }
}
