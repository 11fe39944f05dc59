//! Hostile-client figures against a running `caustica serve` (the hardening issue's "done
//! when"): `/healthz` latency under a slow-connection flood, small-render latency under a bake
//! flood, and the server's resident memory around hostile JSON bodies.
//!
//! cargo run --release --example hostile -- --url http://127.0.0.1:8080 [--pid PID]
//!     [--slow 200] [--idle 2000] [--bakes 64] [--renders 50]
//! `--pid` (the server's process id, same machine) adds its resident memory (VmRSS, VmHWM).
//! Bounded: every phase stops after its requests; nothing here waits on a timer to
//! synchronise (the pauses pace the attack).

use std::time::{Duration, Instant};
use tokio::io::AsyncWriteExt;
use tokio::net::TcpStream;

const SCENE: &str = include_str!("../scenes/glass-sphere-directional.json");

fn arg(name: &str, default: &str) -> String {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
        .unwrap_or_else(|| default.to_string())
}

fn memory(pid: &str) -> String {
    let Ok(s) = std::fs::read_to_string(format!("/proc/{pid}/status")) else {
        return "?".into();
    };
    let get = |k: &str| {
        s.lines()
            .find(|l| l.starts_with(k))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<u64>().ok())
            .map_or("?".to_string(), |kb| format!("{} MiB", kb >> 10))
    };
    format!("resident {}, peak {}", get("VmRSS:"), get("VmHWM:"))
}

fn percentiles(mut v: Vec<Duration>) -> String {
    v.sort();
    let at = |q: f64| v[((v.len() as f64 - 1.0) * q).round() as usize];
    format!(
        "p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms (n = {})",
        at(0.5).as_secs_f64() * 1e3,
        at(0.99).as_secs_f64() * 1e3,
        v[v.len() - 1].as_secs_f64() * 1e3,
        v.len()
    )
}

#[tokio::main]
async fn main() {
    let base = arg("--url", "http://127.0.0.1:8080");
    let pid = arg("--pid", "");
    let slow: usize = arg("--slow", "200").parse().unwrap();
    let idle: usize = arg("--idle", "2000").parse().unwrap();
    let bakes: u64 = arg("--bakes", "64").parse().unwrap();
    let renders: usize = arg("--renders", "50").parse().unwrap();
    let addr = base.trim_start_matches("http://").to_string();
    let c = reqwest::Client::new();
    let scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    if !pid.is_empty() {
        println!("idle server: {}", memory(&pid));
    }

    // 1. Hostile JSON: a million lights (53 MB) and, under the JSON limit, 120 000.
    for n in [1_000_000usize, 120_000] {
        let light = r#"{"type":"point","position":[0,1,0],"intensity":[1,1,1]}"#;
        let body = format!(
            "{{\"scene\": {SCENE}, \"lights\": [{}]}}",
            vec![light; n].join(",")
        );
        let t = Instant::now();
        let r = c
            .post(format!("{base}/v1/renders"))
            .header("content-type", "application/json")
            .body(body.clone())
            .send()
            .await;
        let status = r.map(|r| r.status().as_u16()).unwrap_or(0);
        println!(
            "{n} lights ({} MB): {status} in {:.0} ms{}",
            body.len() >> 20,
            t.elapsed().as_secs_f64() * 1e3,
            if pid.is_empty() {
                String::new()
            } else {
                format!("; {}", memory(&pid))
            }
        );
    }

    // 2. Slow connections: `slow` dripping a request head, `idle` silent.
    let mut dripping = Vec::new();
    for _ in 0..slow {
        if let Ok(mut s) = TcpStream::connect(&addr).await {
            let _ = s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n").await;
            dripping.push(s);
        }
    }
    let mut silent = Vec::new();
    for _ in 0..idle {
        match TcpStream::connect(&addr).await {
            Ok(s) => silent.push(s),
            Err(e) => {
                println!("idle socket {}: {e}", silent.len());
                break;
            }
        }
    }
    let mut lat = Vec::new();
    let mut failed = 0;
    let mut first_error = String::new();
    let mut last_failure = Duration::ZERO;
    let t = Instant::now();
    while lat.len() < 200 {
        for s in dripping.iter_mut() {
            let _ = s.write_all(b"X").await;
        }
        // A fresh connection each time, as a prober's would be.
        let probe = reqwest::Client::builder()
            .timeout(Duration::from_secs(10))
            .build()
            .unwrap();
        let h = Instant::now();
        match probe.get(format!("{base}/healthz")).send().await {
            Ok(r) if r.status() == 200 => lat.push(h.elapsed()),
            other => {
                failed += 1;
                if first_error.is_empty() {
                    first_error = format!("{other:?}");
                }
                last_failure = t.elapsed();
                lat.push(Duration::from_secs(10));
            }
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    println!(
        "/healthz under {} dripping + {} silent connections over {:.0} s: {} ({failed} failed, \
         the last {:.1} s into the flood: {first_error})",
        dripping.len(),
        silent.len(),
        t.elapsed().as_secs_f64(),
        percentiles(lat),
        last_failure.as_secs_f64()
    );
    drop((dripping, silent));

    // 3. A bake flood, then small renders.
    let mut flood = Vec::new();
    let mut refused = std::collections::BTreeMap::<u16, usize>::new();
    for seed in 0..bakes {
        let r = c
            .post(format!("{base}/v1/bakes"))
            .json(
                &serde_json::json!({"scene": scene, "object": "glass", "method": "reference",
                // Long on camera samples, light on memory (few stored photons), so that the
                // flood fills the bake queue rather than the job memory budget.
                "params": {"photons": 10_000, "spp": 1024, "seed": 1000 + seed, "width": 256,
                           "height": 256}}),
            )
            .send()
            .await
            .unwrap();
        match r.status().as_u16() {
            202 => flood.push(r.headers()["location"].to_str().unwrap().to_string()),
            s => *refused.entry(s).or_default() += 1,
        }
    }
    let mut lat = Vec::new();
    for seed in 0..renders {
        let t = Instant::now();
        let r = c
            .post(format!("{base}/v1/renders"))
            .json(
                &serde_json::json!({"scene": scene, "method": "reference", "width": 64,
                "height": 48, "photons": 20_000, "spp": 1, "seed": seed}),
            )
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200, "{}", r.text().await.unwrap());
        r.bytes().await.unwrap();
        lat.push(t.elapsed());
    }
    println!(
        "{renders} small reference renders (64×48, 20k photons) under {} queued bakes (refused, \
         by status: {refused:?}): {}",
        flood.len(),
        percentiles(lat)
    );
    for loc in flood {
        let _ = c.delete(format!("{base}{loc}")).send().await;
    }
    if !pid.is_empty() {
        println!("after: {}", memory(&pid));
    }
}
