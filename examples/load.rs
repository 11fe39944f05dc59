//! Load harness: N concurrent clients render a stored (cached) scene over loopback and the
//! harness reports renders/s, p50/p99 latency, each Server-Timing stage's median and the
//! median time a render spent outside the GPU passes. Bounded in requests and time.
//!
//! cargo run --example load -- [--clients 16] [--requests 400] [--method direct|reference|csl]
//!     [--size 64] [--seconds 60] [--csl-grid 1280] [--url http://HOST:PORT]
//! With `--method csl` the warm-up render bakes the sphere's CSL set (paper settings, grid
//! `--csl-grid`) and every timed render finds that bake by content hash: renders on a cached
//! bake.
//! Without --url it starts a server in process on 127.0.0.1:0 with a temporary data dir.

use caustica::http::{AppState, HttpConfig};
use caustica::jobs::JobConfig;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

const SCENE: &str = include_str!("../scenes/glass-sphere-directional.json");

fn arg(name: &str, default: &str) -> String {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
        .unwrap_or_else(|| default.to_string())
}

#[tokio::main]
async fn main() {
    let clients: usize = arg("--clients", "16").parse().unwrap();
    let requests: usize = arg("--requests", "400").parse().unwrap();
    let method = arg("--method", "direct");
    let size: u32 = arg("--size", "64").parse().unwrap();
    let seconds: u64 = arg("--seconds", "60").parse().unwrap();
    let base = match std::env::args().position(|a| a == "--url") {
        Some(_) => arg("--url", ""),
        None => {
            let dir = std::env::temp_dir().join(format!("caustica-load-{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            let state = tokio::task::spawn_blocking(move || {
                AppState::start(JobConfig::new(&dir), HttpConfig::default()).unwrap()
            })
            .await
            .unwrap();
            let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
            let base = format!("http://{}", listener.local_addr().unwrap());
            tokio::spawn(caustica::http::serve(
                listener,
                state,
                std::future::pending(),
            ));
            base
        }
    };
    let c = reqwest::Client::new();
    let v: serde_json::Value = c
        .post(format!("{base}/v1/scenes"))
        .header("content-type", "application/json")
        .body(SCENE)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let mut body = serde_json::json!({
        "scene": v["id"], "method": method, "width": size, "height": size,
    });
    match method.as_str() {
        "reference" => {
            body["photons"] = 20000.into();
            body["spp"] = 1.into();
        }
        "csl" => {
            let grid: u32 = arg("--csl-grid", "1280").parse().unwrap();
            body["csl"] = serde_json::json!({ "grid": grid });
        }
        _ => {}
    }
    let body = Arc::new(body);
    // Warm-up: the GPU worker creates its device on first use.
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(&*body)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200, "{}", r.text().await.unwrap());
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(&*body)
        .send()
        .await
        .unwrap();
    println!(
        "Server-Timing of one render: {:?}",
        r.headers()["server-timing"]
    );
    let next = Arc::new(AtomicUsize::new(0));
    let deadline = Instant::now() + Duration::from_secs(seconds);
    let t0 = Instant::now();
    let mut tasks = Vec::new();
    for _ in 0..clients {
        let (c, base, body, next) = (c.clone(), base.clone(), body.clone(), next.clone());
        tasks.push(tokio::spawn(async move {
            let mut lat = Vec::new();
            let mut errors = 0usize;
            let mut timings = Vec::new();
            while next.fetch_add(1, Ordering::SeqCst) < requests && Instant::now() < deadline {
                let t = Instant::now();
                let r = c
                    .post(format!("{base}/v1/renders"))
                    .json(&*body)
                    .send()
                    .await;
                match r {
                    Ok(r) if r.status() == 200 => {
                        if let Some(v) = r.headers().get("server-timing") {
                            timings.push(server_timing(v.to_str().unwrap_or("")));
                        }
                        let _ = r.bytes().await;
                        lat.push(t.elapsed());
                    }
                    _ => errors += 1,
                }
            }
            (lat, errors, timings)
        }));
    }
    let mut lat = Vec::new();
    let mut errors = 0;
    let mut timings = Vec::new();
    for t in tasks {
        let (l, e, st) = t.await.unwrap();
        lat.extend(l);
        errors += e;
        timings.extend(st);
    }
    let wall = t0.elapsed();
    lat.sort();
    let pct = |p: f64| lat[((lat.len() as f64 - 1.0) * p).round() as usize];
    println!(
        "{} renders ({method}, {size}x{size}) by {clients} clients in {:.2} s: {:.1} renders/s, \
         p50 {:.1} ms, p99 {:.1} ms, errors {errors}",
        lat.len(),
        wall.as_secs_f64(),
        lat.len() as f64 / wall.as_secs_f64(),
        pct(0.5).as_secs_f64() * 1e3,
        pct(0.99).as_secs_f64() * 1e3,
    );
    // Per render, from its Server-Timing: the median of each stage, and of the time the
    // server worked on it outside the GPU passes: `request` less the waits for other renders
    // (`queue`, `gpu_lock`) and the `gpu-*` stages.
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let mut names: Vec<&str> = Vec::new();
    for t in &timings {
        for (n, _) in t {
            if !names.contains(&n.as_str()) {
                names.push(n);
            }
        }
    }
    let stages: Vec<String> = names
        .iter()
        .map(|n| {
            let v = timings
                .iter()
                .filter_map(|t| t.iter().find(|(m, _)| m == n).map(|(_, d)| *d))
                .collect();
            format!("{n} {:.3}", median(v))
        })
        .collect();
    println!("median Server-Timing stages (ms): {}", stages.join(", "));
    let outside = timings
        .iter()
        .filter_map(|t| {
            let request = t.iter().find(|(n, _)| n == "request")?.1;
            let other: f64 = t
                .iter()
                .filter(|(n, _)| n.starts_with("gpu-") || n == "queue" || n == "gpu_lock")
                .map(|(_, d)| d)
                .sum();
            Some(request - other)
        })
        .collect::<Vec<_>>();
    println!(
        "per render outside the GPU passes (request less queue, gpu_lock and gpu-*): median \
         {:.2} ms over {} renders",
        median(outside.clone()),
        outside.len()
    );
}

/// The (name, milliseconds) of a Server-Timing header.
fn server_timing(v: &str) -> Vec<(String, f64)> {
    v.split(',')
        .filter_map(|m| {
            let mut parts = m.trim().split(';');
            let name = parts.next()?.trim().to_string();
            let dur = parts.find_map(|p| p.trim().strip_prefix("dur="))?;
            Some((name, dur.parse().ok()?))
        })
        .collect()
}
