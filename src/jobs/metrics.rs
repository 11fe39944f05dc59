//! Counters and histograms for `/metrics`, written out in the Prometheus text format by hand
//! (a handful of series does not need a metrics crate).

use std::collections::BTreeMap;
use std::fmt::Write;
use std::sync::Mutex;
use std::time::Duration;

/// Upper bounds (seconds) of the latency histogram buckets.
const BUCKETS: &[f64] = &[
    0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0,
];

#[derive(Default, Clone)]
struct Histogram {
    counts: Vec<u64>,
    sum: f64,
    count: u64,
}

impl Histogram {
    fn observe(&mut self, v: f64) {
        if self.counts.is_empty() {
            self.counts = vec![0; BUCKETS.len()];
        }
        for (i, b) in BUCKETS.iter().enumerate() {
            if v <= *b {
                self.counts[i] += 1;
            }
        }
        self.sum += v;
        self.count += 1;
    }

    fn write(&self, out: &mut String, name: &str, labels: &str) {
        let sep = if labels.is_empty() { "" } else { "," };
        for (i, b) in BUCKETS.iter().enumerate() {
            let c = self.counts.get(i).copied().unwrap_or(0);
            let _ = writeln!(out, "{name}_bucket{{{labels}{sep}le=\"{b}\"}} {c}");
        }
        let _ = writeln!(
            out,
            "{name}_bucket{{{labels}{sep}le=\"+Inf\"}} {}",
            self.count
        );
        let braces = if labels.is_empty() {
            String::new()
        } else {
            format!("{{{labels}}}")
        };
        let _ = writeln!(out, "{name}_sum{braces} {}", self.sum);
        let _ = writeln!(out, "{name}_count{braces} {}", self.count);
    }
}

#[derive(Default)]
struct Inner {
    /// (kind, state) → count.
    jobs: BTreeMap<(String, String), u64>,
    /// kind → run time histogram.
    job_seconds: BTreeMap<String, Histogram>,
    /// method → end-to-end latency of `POST /v1/renders` answered with an image.
    render_latency: BTreeMap<String, Histogram>,
    gpu_seconds: f64,
    /// (route, status) → count.
    requests: BTreeMap<(String, u16), u64>,
}

#[derive(Default)]
pub struct Metrics {
    inner: Mutex<Inner>,
}

impl Metrics {
    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn job_finished(&self, state: &str, kind: &str, run: Duration) {
        let mut m = self.lock();
        *m.jobs.entry((kind.into(), state.into())).or_default() += 1;
        if state == "succeeded" {
            m.job_seconds
                .entry(kind.into())
                .or_default()
                .observe(run.as_secs_f64());
        }
    }

    pub fn gpu_time(&self, seconds: f64) {
        self.lock().gpu_seconds += seconds;
    }

    pub fn render_latency(&self, method: &str, d: Duration) {
        self.lock()
            .render_latency
            .entry(method.into())
            .or_default()
            .observe(d.as_secs_f64());
    }

    pub fn request(&self, route: &str, status: u16) {
        *self
            .lock()
            .requests
            .entry((route.into(), status))
            .or_default() += 1;
    }

    /// The exposition, given the current queue depths (cpu, gpu).
    pub fn render(&self, queue: (usize, usize)) -> String {
        let m = self.lock();
        let mut s = String::new();
        s.push_str("# HELP caustica_queue_depth Jobs waiting for a worker.\n");
        s.push_str("# TYPE caustica_queue_depth gauge\n");
        let _ = writeln!(s, "caustica_queue_depth{{lane=\"cpu\"}} {}", queue.0);
        let _ = writeln!(s, "caustica_queue_depth{{lane=\"gpu\"}} {}", queue.1);
        s.push_str("# HELP caustica_jobs_total Jobs finished, by kind and final state.\n");
        s.push_str("# TYPE caustica_jobs_total counter\n");
        for ((k, st), n) in &m.jobs {
            let _ = writeln!(s, "caustica_jobs_total{{kind=\"{k}\",state=\"{st}\"}} {n}");
        }
        s.push_str("# HELP caustica_job_duration_seconds Run time of succeeded jobs.\n");
        s.push_str("# TYPE caustica_job_duration_seconds histogram\n");
        for (k, h) in &m.job_seconds {
            h.write(
                &mut s,
                "caustica_job_duration_seconds",
                &format!("kind=\"{k}\""),
            );
        }
        s.push_str(
            "# HELP caustica_render_latency_seconds POST /v1/renders answered with an image, \
             end to end.\n",
        );
        s.push_str("# TYPE caustica_render_latency_seconds histogram\n");
        for (k, h) in &m.render_latency {
            h.write(
                &mut s,
                "caustica_render_latency_seconds",
                &format!("method=\"{k}\""),
            );
        }
        s.push_str("# HELP caustica_gpu_seconds_total GPU pass time from timestamp queries.\n");
        s.push_str("# TYPE caustica_gpu_seconds_total counter\n");
        let _ = writeln!(s, "caustica_gpu_seconds_total {}", m.gpu_seconds);
        s.push_str("# HELP caustica_http_requests_total HTTP requests by route and status.\n");
        s.push_str("# TYPE caustica_http_requests_total counter\n");
        for ((r, st), n) in &m.requests {
            let _ = writeln!(
                s,
                "caustica_http_requests_total{{route=\"{r}\",status=\"{st}\"}} {n}"
            );
        }
        s
    }
}
