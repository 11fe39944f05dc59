//! Throughput of small renders and of bakes against the number of worker processes sharing a
//! PostgreSQL store (1, 2, 3 `caustica worker` processes, one CPU worker thread each, behind
//! one `caustica serve --no-workers`), beside the single-process server (SQLite, its default
//! workers). Each sample submits a batch and waits until every job ended; then the queue
//! latency (submission to start, from each job's `queue` timing) over every job of that
//! set-up is printed as p50/p99 under load (a whole batch submitted at once, so it includes
//! waiting behind the batch) and idle (one job at a time: submission to claim alone). Needs
//! PostgreSQL installed (a throwaway cluster is started).
//!
//! `cargo bench --bench cluster`

// The tests' throwaway cluster (not all of it is used here).
#[allow(dead_code)]
#[path = "../tests/it/support/pg.rs"]
mod pg;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

const RENDERS: u64 = 24;
const BAKES: u64 = 4;

struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn spawn(args: &[&str], dir: &std::path::Path) -> (Proc, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(args)
        .arg("--data-dir")
        .arg(dir)
        .env("CAUSTICA_LOG", "error")
        .env("CAUSTICA_CPU_WORKERS", "1")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    (Proc(child), line.trim().to_string())
}

fn scene(w: u32) -> serde_json::Value {
    let mut s: serde_json::Value =
        serde_json::from_str(include_str!("../scenes/glass-sphere-directional.json")).unwrap();
    s["camera"]["width"] = w.into();
    s["camera"]["height"] = w.into();
    s
}

/// Submits `bodies` to `path` and waits until each job ended; the jobs' locations.
async fn batch(
    c: &reqwest::Client,
    base: &str,
    path: &str,
    bodies: Vec<serde_json::Value>,
) -> Vec<String> {
    let mut locs = vec![];
    for b in bodies {
        let r = c
            .post(format!("{base}{path}"))
            .json(&b)
            .send()
            .await
            .unwrap();
        assert!(r.status().is_success(), "{}", r.text().await.unwrap());
        locs.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    for l in &locs {
        loop {
            let v: serde_json::Value = c
                .get(format!("{base}{l}"))
                .send()
                .await
                .unwrap()
                .json()
                .await
                .unwrap();
            match v["state"].as_str().unwrap() {
                "succeeded" => break,
                "failed" | "canceled" => panic!("{v}"),
                _ => tokio::time::sleep(Duration::from_millis(5)).await,
            }
        }
    }
    locs
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn bench(c: &mut Criterion) {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let pg = pg::PgCluster::start("bench");
    let client = reqwest::Client::new();
    let seed = AtomicU64::new(1);
    let mut g = c.benchmark_group("cluster");
    g.sample_size(10);
    g.warm_up_time(Duration::from_secs(1));
    for setup in ["single", "1", "2", "3"] {
        let dir = std::env::temp_dir().join(format!(
            "caustica-bench-cluster-{setup}-{}",
            std::process::id()
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let mut procs = vec![];
        let base = if setup == "single" {
            let (p, line) = spawn(&["serve", "--addr", "127.0.0.1:0"], &dir);
            procs.push(p);
            line.strip_prefix("caustica listening on ")
                .unwrap()
                .to_string()
        } else {
            let db = pg.url(&format!("bench{setup}"));
            let (p, line) = spawn(
                &[
                    "serve",
                    "--addr",
                    "127.0.0.1:0",
                    "--no-workers",
                    "--database",
                    &db,
                ],
                &dir,
            );
            procs.push(p);
            for _ in 0..setup.parse::<usize>().unwrap() {
                procs.push(spawn(&["worker", "--lanes", "cpu", "--database", &db], &dir).0);
            }
            line.strip_prefix("caustica listening on ")
                .unwrap()
                .to_string()
        };
        let mut all = vec![];
        let label = if setup == "single" {
            "single process".to_string()
        } else {
            format!("{setup} workers")
        };
        g.throughput(Throughput::Elements(RENDERS));
        g.bench_function(format!("renders/{label}"), |b| {
            b.iter_custom(|iters| {
                let mut t = Duration::ZERO;
                for _ in 0..iters {
                    let bodies = (0..RENDERS)
                        .map(|_| {
                            serde_json::json!({"scene": scene(8), "method": "reference",
                                "photons": 2_000, "spp": 1, "wait": false,
                                "seed": seed.fetch_add(1, Ordering::Relaxed)})
                        })
                        .collect();
                    let s = Instant::now();
                    all.extend(rt.block_on(batch(&client, &base, "/v1/renders", bodies)));
                    t += s.elapsed();
                }
                t
            })
        });
        g.throughput(Throughput::Elements(BAKES));
        g.bench_function(format!("bakes/{label}"), |b| {
            b.iter_custom(|iters| {
                let mut t = Duration::ZERO;
                for _ in 0..iters {
                    let bodies = (0..BAKES)
                        .map(|_| {
                            serde_json::json!({"scene": scene(16), "object": "glass",
                                "method": "reference",
                                "params": {"photons": 300_000, "spp": 1, "width": 32,
                                           "height": 32,
                                           "seed": seed.fetch_add(1, Ordering::Relaxed)}})
                        })
                        .collect();
                    let s = Instant::now();
                    all.extend(rt.block_on(batch(&client, &base, "/v1/bakes", bodies)));
                    t += s.elapsed();
                }
                t
            })
        });
        let mut idle = vec![];
        for _ in 0..40 {
            let body = serde_json::json!({"scene": scene(8), "method": "reference",
                "photons": 2_000, "spp": 1, "wait": false,
                "seed": seed.fetch_add(1, Ordering::Relaxed)});
            idle.extend(rt.block_on(batch(&client, &base, "/v1/renders", vec![body])));
        }
        let queue_waits = |jobs: &[String]| -> Vec<f64> {
            rt.block_on(async {
                let mut w = vec![];
                for l in jobs {
                    let v: serde_json::Value = client
                        .get(format!("{base}{l}"))
                        .send()
                        .await
                        .unwrap()
                        .json()
                        .await
                        .unwrap();
                    let q = v["timings"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .find(|t| t["stage"] == "queue")
                        .and_then(|t| t["ms"].as_f64())
                        .unwrap_or(f64::NAN);
                    w.push(q);
                }
                w.retain(|w| w.is_finite());
                w
            })
        };
        for (what, jobs) in [("under load", &all), ("idle", &idle)] {
            let mut waits = queue_waits(jobs);
            let n = waits.len();
            let p50 = percentile(&mut waits, 0.5);
            let p99 = percentile(&mut waits, 0.99);
            println!(
                "cluster/{label}: queue wait {what}, {n} jobs: p50 {p50:.1} ms, p99 {p99:.1} ms"
            );
        }
        drop(procs);
        let _ = std::fs::remove_dir_all(&dir);
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
