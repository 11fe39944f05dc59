//! Tunables of the job system and their environment overrides.

use std::path::PathBuf;
use std::time::Duration;

/// Tunables of the job system.
#[derive(Clone, Debug)]
pub struct JobConfig {
    pub data_dir: PathBuf,
    /// Threads taking CPU jobs (each job may use rayon's pool inside). With more than one,
    /// the first is kept for renders.
    pub cpu_workers: usize,
    /// Threads taking GPU jobs, each with a renderer of its own on the one device (besides
    /// one that takes only small renders).
    pub gpu_workers: usize,
    /// Most GPU jobs one key runs at once (small renders aside); its next waits meanwhile.
    pub gpu_jobs_per_key: usize,
    /// A bake that has waited this long goes ahead of renders on the workers that take bakes.
    pub bake_after: Duration,
    /// Most renders waiting; past it render submissions are refused (429).
    pub max_queued: usize,
    /// Most bakes waiting; past it bake submissions are refused (429). Counted apart from
    /// renders, so a flood of bakes leaves renders room.
    pub max_queued_bakes: usize,
    /// What one render may ask for on this server.
    pub caps: RequestCaps,
    /// How long results are kept.
    pub retention: Retention,
    /// Memory that queued and running jobs may hold together, by their estimates
    /// ([`super::Job::memory`]); past it a submission is refused (503), and a job that alone
    /// needs more is refused outright (422).
    pub job_memory: u64,
    pub bake_timeout: Duration,
    pub render_timeout: Duration,
    /// Scene limits applied to uploads and renders.
    pub limits: crate::scene::Limits,
    /// Most bytes of resolved scenes kept in memory between jobs
    /// ([`crate::scene::World::heap_bytes`]); a scene over it is resolved for each job.
    pub scene_cache_bytes: u64,
    /// Skip the GPU readiness probe at start (tests of the queue alone).
    pub probe_gpu: bool,
    /// The shared job store (`postgres://…`); `None`: SQLite in the data directory, one
    /// process.
    pub database: Option<String>,
    /// Object storage for artifacts (`s3://BUCKET/PREFIX`), the data directory its cache;
    /// `None`: the data directory alone (a shared volume when several processes use it).
    pub artifacts: Option<String>,
    /// Which lanes this process takes jobs from: (CPU, GPU). An API process with a shared
    /// store may take none (`--no-workers`).
    pub lanes: (bool, bool),
    /// A worker's hold on a job it runs, extended by its heartbeat every third of it; a job
    /// whose worker stops answering for this long goes back to the queue (shared store).
    pub lease: Duration,
}

impl JobConfig {
    pub fn new(data_dir: impl Into<PathBuf>) -> JobConfig {
        JobConfig {
            data_dir: data_dir.into(),
            cpu_workers: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(2),
            gpu_workers: 2,
            gpu_jobs_per_key: 1,
            bake_after: Duration::from_secs(30),
            max_queued: 256,
            max_queued_bakes: 64,
            caps: RequestCaps::default(),
            retention: Retention::default(),
            job_memory: default_job_memory(),
            bake_timeout: Duration::from_secs(3600),
            render_timeout: Duration::from_secs(300),
            // Image side capped below the library's 8192: a reference frame holds several
            // float layers (~100 bytes a pixel), so 4096² is already ~1.7 GB.
            limits: crate::scene::Limits {
                max_image_side: 4096,
                ..Default::default()
            },
            scene_cache_bytes: 512 << 20,
            probe_gpu: true,
            database: None,
            artifacts: None,
            lanes: (true, true),
            lease: Duration::from_secs(30),
        }
    }
}

impl JobConfig {
    /// How long a progressive render (`photons`, `reference`) traces at most: half the render
    /// timeout, the rest left to its last frame, the self-check and storing the image.
    pub fn render_budget(&self) -> Duration {
        self.render_timeout / 2
    }

    /// Overrides from the environment (`get` looks a variable up; `caustica serve` passes
    /// `std::env::var`): `CAUSTICA_CPU_WORKERS`, `CAUSTICA_MAX_QUEUED`,
    /// `CAUSTICA_MAX_QUEUED_BAKES`, `CAUSTICA_MAX_PHOTONS`, `CAUSTICA_MAX_SPP`,
    /// `CAUSTICA_GPU_WORKERS`, `CAUSTICA_GPU_JOBS_PER_KEY`, `CAUSTICA_BAKE_AFTER_S`,
    /// `CAUSTICA_RENDER_TTL_S`, `CAUSTICA_BAKE_TTL_S`, `CAUSTICA_MAX_RENDER_BYTES` (0: keep),
    /// `CAUSTICA_IDEMPOTENCY_TTL_S`,
    /// `CAUSTICA_JOB_MEMORY`, `CAUSTICA_SCENE_CACHE_BYTES` (bytes),
    /// `CAUSTICA_BAKE_TIMEOUT_S`, `CAUSTICA_RENDER_TIMEOUT_S`, `CAUSTICA_MAX_IMAGE_SIDE`,
    /// `CAUSTICA_MAX_TRIANGLES`, `CAUSTICA_LEASE_S`. An unparsable or out-of-range value is an
    /// error naming it.
    pub fn apply_env(&mut self, get: &dyn Fn(&str) -> Option<String>) -> Result<(), String> {
        if let Some(v) = env_num(get, "CAUSTICA_LEASE_S", 0.5, 3600.0, false)? {
            self.lease = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_CPU_WORKERS", 1.0, 1024.0, true)? {
            self.cpu_workers = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_GPU_WORKERS", 1.0, 64.0, true)? {
            self.gpu_workers = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_GPU_JOBS_PER_KEY", 1.0, 1024.0, true)? {
            self.gpu_jobs_per_key = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_BAKE_AFTER_S", 0.0, 1e7, false)? {
            self.bake_after = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_QUEUED", 1.0, 1e6, true)? {
            self.max_queued = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_QUEUED_BAKES", 1.0, 1e6, true)? {
            self.max_queued_bakes = v as usize;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_PHOTONS", 1.0, 1e9, true)? {
            self.caps.max_photons = v as u64;
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_SPP", 1.0, 1024.0, true)? {
            self.caps.max_spp = v as u32;
        }
        if let Some(v) = env_num(get, "CAUSTICA_SCENE_CACHE_BYTES", 0.0, 1e15, true)? {
            self.scene_cache_bytes = v as u64;
        }
        if let Some(v) = env_num(get, "CAUSTICA_JOB_MEMORY", 1e6, 1e15, true)? {
            self.job_memory = v as u64;
        }
        if let Some(v) = env_num(get, "CAUSTICA_RENDER_TTL_S", 0.0, 1e10, false)? {
            self.retention.render_ttl = (v > 0.0).then(|| Duration::from_secs_f64(v));
        }
        if let Some(v) = env_num(get, "CAUSTICA_BAKE_TTL_S", 0.0, 1e10, false)? {
            self.retention.bake_ttl = (v > 0.0).then(|| Duration::from_secs_f64(v));
        }
        if let Some(v) = env_num(get, "CAUSTICA_IDEMPOTENCY_TTL_S", 1.0, 1e10, false)? {
            self.retention.idempotency_ttl = Duration::from_secs_f64(v);
        }
        if let Some(v) = env_num(get, "CAUSTICA_MAX_RENDER_BYTES", 0.0, 1e15, true)? {
            self.retention.max_render_bytes = (v > 0.0).then_some(v as u64);
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

/// Half the machine's memory (`MemTotal` of `/proc/meminfo`), at least 1 GiB; 4 GiB when it
/// cannot be read.
fn default_job_memory() -> u64 {
    let total = std::fs::read_to_string("/proc/meminfo").ok().and_then(|m| {
        let line = m.lines().find(|l| l.starts_with("MemTotal:"))?;
        line.split_whitespace().nth(1)?.parse::<u64>().ok()
    });
    total.map_or(4 << 30, |kb| (kb * 1024 / 2).max(1 << 30))
}

/// How long finished jobs and their results are kept. A sweep every [`Retention::sweep_every`]
/// deletes finished renders and bakes past their time to live, then the least recently served
/// renders while their images take more than `max_render_bytes`. Deleted jobs answer 404.
#[derive(Clone, Debug, PartialEq)]
pub struct Retention {
    /// Finished renders are deleted this long after they end (None: kept).
    pub render_ttl: Option<Duration>,
    /// Finished bake jobs likewise (None: kept; their bakes in `DATA_DIR/bakes` stay).
    pub bake_ttl: Option<Duration>,
    /// Most bytes of render images kept (None: no cap).
    pub max_render_bytes: Option<u64>,
    /// Idempotency records are deleted this long after they were made (a retry after it
    /// makes a new job).
    pub idempotency_ttl: Duration,
    pub sweep_every: Duration,
}

impl Default for Retention {
    fn default() -> Self {
        Retention {
            render_ttl: Some(Duration::from_secs(7 * 24 * 3600)),
            bake_ttl: None,
            max_render_bytes: Some(10 << 30),
            idempotency_ttl: Duration::from_secs(24 * 3600),
            sweep_every: Duration::from_secs(60),
        }
    }
}

/// What one render may ask for on this server, below what the methods themselves accept
/// (`reference`: 1e9 photons, 1024 samples a pixel), so that one request cannot hold a worker
/// for long; its time is bounded by [`JobConfig::render_timeout`] besides.
#[derive(Clone, Debug, PartialEq)]
pub struct RequestCaps {
    /// Most `photons` a render may trace.
    pub max_photons: u64,
    /// Most camera samples a pixel (`spp`).
    pub max_spp: u32,
}

impl Default for RequestCaps {
    fn default() -> Self {
        RequestCaps {
            max_photons: 100_000_000,
            max_spp: 256,
        }
    }
}

impl RequestCaps {
    /// Checks a render's parameters (the request's fields besides the scene and method).
    pub fn check(&self, params: &serde_json::Value) -> Result<(), crate::methods::ParamError> {
        use crate::methods::ParamError;
        let over = |field: &str, max: u64, var: &str| -> Result<(), ParamError> {
            match params.get(field).and_then(|v| v.as_f64()) {
                Some(n) if n > max as f64 => Err(ParamError::new(
                    field,
                    format!("at most {max} on this server ({var})"),
                )),
                _ => Ok(()),
            }
        };
        over("photons", self.max_photons, "CAUSTICA_MAX_PHOTONS")?;
        over("spp", self.max_spp as u64, "CAUSTICA_MAX_SPP")
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
