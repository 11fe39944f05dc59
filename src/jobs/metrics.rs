//! What `/metrics` exposes, on `prometheus-client` (OpenMetrics text): counters and histograms
//! kept as jobs and requests happen, and a [`Snapshot`] of what is read at scrape time (queue
//! depths, running jobs, connections, the process).

use prometheus_client::collector::Collector;
use prometheus_client::encoding::{DescriptorEncoder, EncodeLabelSet, EncodeMetric};
use prometheus_client::metrics::MetricType;
use prometheus_client::metrics::counter::{ConstCounter, Counter};
use prometheus_client::metrics::family::{Family, MetricConstructor};
use prometheus_client::metrics::gauge::ConstGauge;
use prometheus_client::metrics::histogram::Histogram;
use prometheus_client::registry::Registry;
use std::sync::Arc;
use std::sync::atomic::AtomicU64;
use std::time::Duration;

/// Upper bounds (seconds) from 5 ms up; a histogram keeps those up to its limit, and the limit.
const BOUNDS: &[f64] = &[
    0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0,
    1200.0, 1800.0, 3600.0, 7200.0, 14400.0, 43200.0, 86400.0,
];

/// Buckets up to `limit` seconds: the bounds below it and the limit itself, so that every
/// observation within the limit lands in a finite bucket.
fn buckets_to(limit: Duration) -> Arc<[f64]> {
    let limit = limit.as_secs_f64().max(BOUNDS[0]);
    let mut b: Vec<f64> = BOUNDS.iter().copied().filter(|&x| x < limit).collect();
    b.push(limit);
    b.into()
}

/// Makes the histograms of a family, with its buckets.
#[derive(Clone)]
struct Buckets(Arc<[f64]>);

impl MetricConstructor<Histogram> for Buckets {
    fn new_metric(&self) -> Histogram {
        Histogram::new(self.0.iter().copied())
    }
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct KindState {
    kind: String,
    state: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct Kind {
    kind: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct MethodLabel {
    method: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct RouteCode {
    route: String,
    code: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct Route {
    route: String,
}

pub struct Metrics {
    jobs: Family<KindState, Counter>,
    job_seconds: Family<Kind, Histogram, Buckets>,
    render_latency: Family<MethodLabel, Histogram, Buckets>,
    gpu_seconds: Counter<f64, AtomicU64>,
    requests: Family<RouteCode, Counter>,
    request_seconds: Family<Route, Histogram, Buckets>,
}

impl Default for Metrics {
    fn default() -> Self {
        Metrics::new(Duration::from_secs(3600), Duration::from_secs(300))
    }
}

impl Metrics {
    /// Job run-time buckets reach `bake_timeout` (no bake runs longer); render latency and
    /// request buckets reach `render_timeout`.
    pub fn new(bake_timeout: Duration, render_timeout: Duration) -> Metrics {
        let render = Buckets(buckets_to(render_timeout));
        Metrics {
            jobs: Family::default(),
            job_seconds: Family::new_with_constructor(Buckets(buckets_to(
                bake_timeout.max(render_timeout),
            ))),
            render_latency: Family::new_with_constructor(render.clone()),
            gpu_seconds: Counter::default(),
            requests: Family::default(),
            request_seconds: Family::new_with_constructor(render),
        }
    }

    pub fn job_finished(&self, state: &str, kind: &str, run: Duration) {
        self.jobs
            .get_or_create(&KindState {
                kind: kind.into(),
                state: state.into(),
            })
            .inc();
        if state == "succeeded" {
            self.job_seconds
                .get_or_create(&Kind { kind: kind.into() })
                .observe(run.as_secs_f64());
        }
    }

    pub fn gpu_time(&self, seconds: f64) {
        self.gpu_seconds.inc_by(seconds);
    }

    pub fn render_latency(&self, method: &str, d: Duration) {
        self.render_latency
            .get_or_create(&MethodLabel {
                method: method.into(),
            })
            .observe(d.as_secs_f64());
    }

    /// A request answered: its route (the matched template), status and time to the answer's
    /// head (a streamed body, e.g. an event stream, is not included).
    pub fn request(&self, route: &str, status: u16, took: Duration) {
        self.requests
            .get_or_create(&RouteCode {
                route: route.into(),
                code: status.to_string(),
            })
            .inc();
        self.request_seconds
            .get_or_create(&Route {
                route: route.into(),
            })
            .observe(took.as_secs_f64());
    }

    /// The OpenMetrics text of everything, with `now`'s values.
    pub fn render(&self, now: Snapshot) -> String {
        let mut r = Registry::default();
        r.register(
            "caustica_jobs",
            "Jobs finished, by kind and final state",
            self.jobs.clone(),
        );
        r.register(
            "caustica_job_duration_seconds",
            "Run time of succeeded jobs (buckets up to the job time limit)",
            self.job_seconds.clone(),
        );
        r.register(
            "caustica_render_latency_seconds",
            "POST /v1/renders answered with an image, end to end",
            self.render_latency.clone(),
        );
        r.register(
            "caustica_gpu_seconds",
            "GPU pass time from timestamp queries",
            self.gpu_seconds.clone(),
        );
        r.register(
            "caustica_http_requests",
            "HTTP requests by route and status code",
            self.requests.clone(),
        );
        r.register(
            "caustica_http_request_duration_seconds",
            "Time from a request to its answer's head, by route",
            self.request_seconds.clone(),
        );
        r.register_collector(Box::new(now));
        let mut s = String::new();
        // Writing to a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut s, &r);
        s
    }
}

/// What `/metrics` reads at scrape time.
#[derive(Debug, Default)]
pub struct Snapshot {
    /// Jobs waiting, per lane (cpu, gpu).
    pub queue: (usize, usize),
    /// Jobs running, per kind (bake, render).
    pub running: (usize, usize),
    pub connections_open: u64,
    /// Connections accepted by outcome: served, shed, dropped.
    pub connections: [u64; 3],
}

/// This process, from `/proc/self` (Linux; absent elsewhere).
struct Process {
    cpu_seconds: f64,
    resident_bytes: u64,
    virtual_bytes: u64,
    open_fds: u64,
    start_time_seconds: f64,
}

impl Process {
    fn read() -> Option<Process> {
        // USER_HZ, the unit of /proc's times, is 100 on Linux; pages are 4 KiB on the
        // platforms we build for.
        const TICKS: f64 = 100.0;
        const PAGE: u64 = 4096;
        let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
        // Fields after the command name, which is in parentheses and may hold spaces.
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        // stat(5) numbers fields from 1 with the state third: utime 14, stime 15, starttime 22.
        let field = |n: usize| f.get(n - 3).and_then(|v| v.parse::<f64>().ok());
        let cpu_seconds = (field(14)? + field(15)?) / TICKS;
        let boot = std::fs::read_to_string("/proc/stat")
            .ok()?
            .lines()
            .find_map(|l| l.strip_prefix("btime "))?
            .trim()
            .parse::<f64>()
            .ok()?;
        let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
        let mut pages = statm.split_whitespace().map(|v| v.parse::<u64>().ok());
        let virtual_pages = pages.next()??;
        let resident_pages = pages.next()??;
        let open_fds = std::fs::read_dir("/proc/self/fd").ok()?.count() as u64;
        Some(Process {
            cpu_seconds,
            resident_bytes: resident_pages * PAGE,
            virtual_bytes: virtual_pages * PAGE,
            open_fds,
            start_time_seconds: boot + field(22)? / TICKS,
        })
    }
}

/// A family of constant metrics of `kind` (gauge or counter): one per label set, or one
/// without labels.
fn family<M: EncodeMetric>(
    e: &mut DescriptorEncoder,
    name: &str,
    help: &str,
    kind: MetricType,
    values: Vec<(&[(&str, &str)], M)>,
) -> Result<(), std::fmt::Error> {
    let mut d = e.encode_descriptor(name, help, None, kind)?;
    if values.len() == 1 && values[0].0.is_empty() {
        let (_, m) = values.into_iter().next().expect("one value");
        return m.encode(d);
    }
    for (labels, m) in values {
        m.encode(d.encode_family(&labels)?)?;
    }
    Ok(())
}

fn gauge(
    e: &mut DescriptorEncoder,
    name: &str,
    help: &str,
    values: &[(&[(&str, &str)], i64)],
) -> Result<(), std::fmt::Error> {
    let v = values
        .iter()
        .map(|(l, n)| (*l, ConstGauge::new(*n)))
        .collect();
    family(e, name, help, MetricType::Gauge, v)
}

impl Collector for Snapshot {
    fn encode(&self, mut e: DescriptorEncoder) -> Result<(), std::fmt::Error> {
        let n = |v: usize| v as i64;
        gauge(
            &mut e,
            "caustica_queue_depth",
            "Jobs waiting for a worker",
            &[
                (&[("lane", "cpu")], n(self.queue.0)),
                (&[("lane", "gpu")], n(self.queue.1)),
            ],
        )?;
        gauge(
            &mut e,
            "caustica_jobs_running",
            "Jobs running now",
            &[
                (&[("kind", "bake")], n(self.running.0)),
                (&[("kind", "render")], n(self.running.1)),
            ],
        )?;
        gauge(
            &mut e,
            "caustica_connections_open",
            "HTTP connections being served",
            &[(&[], self.connections_open as i64)],
        )?;
        let served = [("outcome", "served")];
        let shed = [("outcome", "shed")];
        let dropped = [("outcome", "dropped")];
        family(
            &mut e,
            "caustica_connections",
            "HTTP connections accepted, by outcome (served; shed with 503 past the connection \
             cap; dropped unanswered past the shedding cap)",
            MetricType::Counter,
            vec![
                (&served[..], ConstCounter::new(self.connections[0])),
                (&shed[..], ConstCounter::new(self.connections[1])),
                (&dropped[..], ConstCounter::new(self.connections[2])),
            ],
        )?;
        gauge(
            &mut e,
            "caustica_build_info",
            "The server's version (always 1)",
            &[(&[("version", env!("CARGO_PKG_VERSION"))], 1)],
        )?;
        if let Some(p) = Process::read() {
            family(
                &mut e,
                "process_cpu_seconds",
                "User and system CPU time of the process",
                MetricType::Counter,
                vec![(&[][..], ConstCounter::new(p.cpu_seconds))],
            )?;
            for (name, help, v) in [
                (
                    "process_resident_memory_bytes",
                    "Resident memory",
                    p.resident_bytes,
                ),
                (
                    "process_virtual_memory_bytes",
                    "Virtual memory",
                    p.virtual_bytes,
                ),
                ("process_open_fds", "Open file descriptors", p.open_fds),
            ] {
                gauge(&mut e, name, help, &[(&[], v as i64)])?;
            }
            family(
                &mut e,
                "process_start_time_seconds",
                "Start time since the Unix epoch",
                MetricType::Gauge,
                vec![(&[][..], ConstGauge::new(p.start_time_seconds))],
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_reach_the_limit_and_no_further() {
        assert_eq!(
            *buckets_to(Duration::from_secs(3600)).last().unwrap(),
            3600.0
        );
        let b = buckets_to(Duration::from_secs(100));
        assert_eq!(&b[b.len() - 2..], &[60.0, 100.0]);
        assert!(b.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn the_exposition_has_every_family_and_long_bakes_land_in_a_finite_bucket() {
        let m = Metrics::new(Duration::from_secs(3600), Duration::from_secs(300));
        m.job_finished("succeeded", "bake", Duration::from_secs(1000));
        m.job_finished("canceled", "bake", Duration::ZERO);
        m.request("/v1/renders", 422, Duration::from_millis(3));
        m.gpu_time(0.25);
        let text = m.render(Snapshot {
            queue: (2, 1),
            running: (1, 0),
            connections_open: 3,
            connections: [10, 1, 0],
        });
        for line in [
            "caustica_jobs_total{kind=\"bake\",state=\"canceled\"} 1",
            "caustica_job_duration_seconds_bucket{le=\"1200.0\",kind=\"bake\"} 1",
            "caustica_job_duration_seconds_bucket{le=\"600.0\",kind=\"bake\"} 0",
            "caustica_http_requests_total{route=\"/v1/renders\",code=\"422\"} 1",
            "caustica_http_request_duration_seconds_count{route=\"/v1/renders\"} 1",
            "caustica_gpu_seconds_total 0.25",
            "caustica_queue_depth{lane=\"cpu\"} 2",
            "caustica_jobs_running{kind=\"bake\"} 1",
            "caustica_connections_open 3\n",
            "caustica_connections_total{outcome=\"served\"} 10",
            "caustica_build_info{version=",
            "process_resident_memory_bytes ",
            "process_cpu_seconds_total ",
            "# EOF",
        ] {
            assert!(text.contains(line), "no {line} in\n{text}");
        }
    }
}
