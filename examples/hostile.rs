//! Hostile-client figures against a running `caustica serve` (the hardening and hostile-load
//! issues' "done when"): `/healthz` latency under a slow-connection flood, small-render latency
//! under a bake flood, the server's resident memory around hostile JSON bodies; then one
//! client against another (the attacker connects from 127.0.0.2, so a keyless loopback server
//! sees two clients): slow uploads, a flood of event streams, heavy scenes for the cache.
//! `--only lanes --keys ATTACKER,VICTIM` (two user keys of a server started with them): one
//! key's long photon renders against another key's GPU renders and bake, 300 renders of one
//! key at once, 16 clients reading one byte of a large EXR in a loop.
//!
//! cargo run --release --example hostile -- --url http://127.0.0.1:8080 [--pid PID]
//!     [--slow 200] [--idle 2000] [--bakes 64] [--renders 50] [--only clients|lanes]
//!     [--keys ATTACKER,VICTIM]
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
    if arg("--only", "") == "clients" {
        one_client_against_another(&base, &pid).await;
        return;
    }
    if arg("--only", "") == "lanes" {
        let keys = arg("--keys", "");
        let (a, v) = keys
            .split_once(',')
            .expect("--keys ATTACKER,VICTIM: two user keys of the server");
        one_key_against_another(&base, a, v).await;
        return;
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
    one_client_against_another(&base, &pid).await;
}

/// A connection from 127.0.0.2: another client than the victim's 127.0.0.1.
async fn attacker(addr: &str) -> std::io::Result<TcpStream> {
    let sock = tokio::net::TcpSocket::new_v4()?;
    sock.bind("127.0.0.2:0".parse().unwrap())?;
    sock.connect(addr.parse().map_err(std::io::Error::other)?)
        .await
}

/// The victim's requests for `span`, one every 50 ms: latencies and statuses.
async fn victim(
    c: &reqwest::Client,
    base: &str,
    post: bool,
    span: Duration,
) -> (Vec<Duration>, std::collections::BTreeMap<u16, usize>) {
    let mut lat = Vec::new();
    let mut statuses = std::collections::BTreeMap::new();
    let t = Instant::now();
    while t.elapsed() < span {
        let h = Instant::now();
        let r = if post {
            c.post(format!("{base}/v1/scenes"))
                .header("content-type", "application/json")
                .body(SCENE)
                .send()
                .await
        } else {
            c.get(format!("{base}/v1/renders")).send().await
        };
        lat.push(h.elapsed());
        *statuses
            .entry(r.map(|r| r.status().as_u16()).unwrap_or(0))
            .or_insert(0) += 1;
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    (lat, statuses)
}

/// Whether the server answered on `s` within `wait`, and the status it gave.
async fn answered(s: &mut TcpStream, wait: Duration) -> Option<String> {
    use tokio::io::AsyncReadExt;
    let mut b = [0u8; 64];
    match tokio::time::timeout(wait, s.read(&mut b)).await {
        Ok(Ok(n)) if n > 12 => Some(String::from_utf8_lossy(&b[9..12]).into_owned()),
        _ => None,
    }
}

async fn one_client_against_another(base: &str, pid: &str) {
    let addr = base.trim_start_matches("http://").to_string();
    let c = reqwest::Client::builder()
        .timeout(Duration::from_secs(120))
        .build()
        .unwrap();
    let span = Duration::from_secs(10);

    // 4. Eight uploads declaring 64 MiB each, a byte a second.
    let (lat, st) = victim(&c, base, true, span).await;
    println!(
        "victim's scene POSTs, baseline: {} {st:?}",
        percentiles(lat)
    );
    let mut slow = Vec::new();
    for _ in 0..8 {
        if let Ok(mut s) = attacker(&addr).await {
            let _ = s
                .write_all(
                    b"POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/gltf-binary\r\n\
                      Content-Length: 67108864\r\n\r\ng",
                )
                .await;
            slow.push(s);
        }
    }
    let drip = {
        let t = Instant::now();
        async move {
            let mut refused = 0;
            let mut i = 0;
            while t.elapsed() < span {
                for s in slow.iter_mut() {
                    let _ = s.write_all(b"l").await;
                }
                tokio::time::sleep(Duration::from_secs(1)).await;
                i += 1;
            }
            for s in slow.iter_mut() {
                if answered(s, Duration::from_millis(100)).await.as_deref() == Some("429") {
                    refused += 1;
                }
            }
            (refused, i)
        }
    };
    let ((lat, st), (refused, _)) = tokio::join!(victim(&c, base, true, span), drip);
    println!(
        "victim's scene POSTs under 8 slow 64 MiB uploads: {} {st:?}; attacker: {refused} of 8 \
         refused 429",
        percentiles(lat)
    );

    // 5. A flood of event streams on one long bake.
    let r = c
        .post(format!("{base}/v1/bakes"))
        .json(
            &serde_json::json!({"scene": serde_json::from_str::<serde_json::Value>(SCENE).unwrap(),
            "object": "glass", "method": "reference",
            "params": {"photons": 1000, "spp": 1024, "width": 1024, "height": 1024, "seed": 99}}),
        )
        .send()
        .await
        .unwrap();
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let (lat, st) = victim(&c, base, false, span).await;
    println!("victim's GETs, baseline: {} {st:?}", percentiles(lat));
    let mut streams = Vec::new();
    for _ in 0..1100 {
        if let Ok(mut s) = attacker(&addr).await {
            let req = format!("GET {loc}/events HTTP/1.1\r\nHost: x\r\n\r\n");
            let _ = s.write_all(req.as_bytes()).await;
            streams.push(s);
        }
    }
    let mut by_status = std::collections::BTreeMap::<String, usize>::new();
    for s in streams.iter_mut() {
        let st = answered(s, Duration::from_millis(200))
            .await
            .unwrap_or_else(|| "none".into());
        *by_status.entry(st).or_insert(0) += 1;
    }
    let (lat, st) = victim(&c, base, false, span).await;
    println!(
        "victim's GETs under {} event streams of the attacker (answers: {by_status:?}): {} {st:?}",
        streams.len(),
        percentiles(lat)
    );
    drop(streams);
    let _ = c.delete(format!("{base}{loc}")).send().await;

    // 6. Heavy scenes for the cache: 40 spheres of 2000 segments (587 bytes each).
    let before = (!pid.is_empty()).then(|| memory(pid));
    let mut statuses = std::collections::BTreeMap::<u16, usize>::new();
    for i in 0..40 {
        let scene = serde_json::json!({
            "camera": {"eye": [0, 2, 3], "target": [0, 0, 0], "width": 8, "height": 8},
            "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": 1.0}],
            "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
            "objects": [{"name": "s", "shape": {"type": "sphere", "radius": 0.5 + i as f64 * 1e-3,
                                                 "segments": 2000}, "material": "glass"}]
        });
        let r = c
            .post(format!("{base}/v1/scenes"))
            .json(&scene)
            .send()
            .await
            .unwrap();
        *statuses.entry(r.status().as_u16()).or_insert(0) += 1;
    }
    println!(
        "40 scenes of 2000-segment spheres: {statuses:?}; before: {}; after: {}",
        before.unwrap_or_default(),
        if pid.is_empty() {
            String::new()
        } else {
            memory(pid)
        }
    );
}

/// A render or bake of `key` posted with `wait: false`: its location, or the status refused.
async fn submit(
    c: &reqwest::Client,
    base: &str,
    key: &str,
    path: &str,
    body: serde_json::Value,
) -> Result<String, u16> {
    let r = c
        .post(format!("{base}{path}"))
        .bearer_auth(key)
        .json(&body)
        .send()
        .await
        .map_err(|_| 0u16)?;
    match r.headers().get("location") {
        Some(l) if r.status().is_success() => Ok(l.to_str().unwrap().to_string()),
        _ => Err(r.status().as_u16()),
    }
}

/// The state of the job at `loc` once it is not `queued` (or `running`, with `end`), and how
/// long that took.
async fn until(
    c: &reqwest::Client,
    base: &str,
    key: &str,
    loc: &str,
    end: bool,
) -> (String, Duration) {
    let t = Instant::now();
    loop {
        let v: serde_json::Value = c
            .get(format!("{base}{loc}"))
            .bearer_auth(key)
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        let s = v["state"].as_str().unwrap_or("?").to_string();
        if s != "queued" && !(end && s == "running") {
            return (s, t.elapsed());
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The victim's `n` GPU renders one after another (1025 × 1024 `direct`: past the small
/// renders' 2^20 pixels): time from submission to the end, and the states they ended in.
async fn victim_renders(
    c: &reqwest::Client,
    base: &str,
    key: &str,
    n: usize,
) -> (Vec<Duration>, std::collections::BTreeMap<String, usize>) {
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["camera"]["width"] = 1025.into();
    scene["camera"]["height"] = 1024.into();
    let mut lat = Vec::new();
    let mut states = std::collections::BTreeMap::new();
    for seed in 0..n {
        let body = serde_json::json!({"scene": scene, "method": "direct", "wait": false,
            "exposure": seed as f64 * 1e-3});
        let t = Instant::now();
        let state = match submit(c, base, key, "/v1/renders", body).await {
            Ok(loc) => until(c, base, key, &loc, true).await.0,
            Err(s) => s.to_string(),
        };
        lat.push(t.elapsed());
        *states.entry(state).or_insert(0) += 1;
    }
    (lat, states)
}

/// Attack 5 of the hostile-load issue: one key's long photon renders hold GPU workers (and
/// its long reference renders the CPU's) while another key renders and bakes.
async fn one_key_against_another(base: &str, attacker: &str, victim: &str) {
    let c = reqwest::Client::builder()
        .timeout(Duration::from_secs(120))
        .build()
        .unwrap();
    let (lat, st) = victim_renders(&c, base, victim, 5).await;
    println!(
        "victim's GPU renders, baseline: {} {st:?}",
        percentiles(lat)
    );
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["camera"]["width"] = 2048.into();
    scene["camera"]["height"] = 2048.into();
    let mut held = Vec::new();
    for seed in 0..2 {
        let body = serde_json::json!({"scene": scene, "method": "photons",
            "photons": 100_000_000u64, "seed": seed, "wait": false,
            "progressive": {"error_target": 0.001}});
        if let Ok(loc) = submit(&c, base, attacker, "/v1/renders", body).await {
            held.push(loc);
        }
    }
    let Some(first) = held.first() else {
        println!("the attacker's renders were refused");
        return;
    };
    until(&c, base, attacker, first, false).await;
    let (lat, st) = victim_renders(&c, base, victim, 3).await;
    let mut theirs = Vec::new();
    for loc in &held {
        let v = state_now(&c, base, attacker, loc).await;
        theirs.push(v["state"].as_str().unwrap_or("?").to_string());
    }
    println!(
        "victim's GPU renders under 2 photon renders of the attacker (1e8 photons, 2048², \
         error target 0.001; their states meanwhile: {theirs:?}): {} {st:?}",
        percentiles(lat)
    );
    for loc in held.drain(..) {
        let _ = c
            .delete(format!("{base}{loc}"))
            .bearer_auth(attacker)
            .send()
            .await;
    }
    // Two long reference renders of the attacker, then a small bake of the victim.
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["camera"]["width"] = 256.into();
    scene["camera"]["height"] = 256.into();
    for seed in 0..2 {
        let body = serde_json::json!({"scene": scene, "method": "reference",
            "photons": 100_000_000u64, "seed": seed, "wait": false});
        if let Ok(loc) = submit(&c, base, attacker, "/v1/renders", body).await {
            until(&c, base, attacker, &loc, false).await;
            held.push(loc);
        }
    }
    let mut small: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    small["camera"]["width"] = 8.into();
    small["camera"]["height"] = 8.into();
    let bake = serde_json::json!({"scene": small, "object": "glass", "method": "reference",
        "params": {"photons": 1000, "spp": 1, "width": 8, "height": 8, "seed": 7}});
    let t = Instant::now();
    let state = match submit(&c, base, victim, "/v1/bakes", bake).await {
        Ok(loc) => until(&c, base, victim, &loc, true).await.0,
        Err(s) => s.to_string(),
    };
    println!(
        "victim's small bake under 2 reference renders of the attacker (1e8 photons, 256²): \
         {state} after {:.1} s",
        t.elapsed().as_secs_f64()
    );
    for loc in held {
        let _ = c
            .delete(format!("{base}{loc}"))
            .bearer_auth(attacker)
            .send()
            .await;
    }
    quota_and_range_reads(&c, base, attacker, victim).await;
}

/// The record of the job at `loc` as `key` sees it, read once.
async fn state_now(c: &reqwest::Client, base: &str, key: &str, loc: &str) -> serde_json::Value {
    c.get(format!("{base}{loc}"))
        .bearer_auth(key)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

/// `/healthz` and the victim's GETs (its job list) for `span`, one of each every 50 ms.
async fn probes(
    c: &reqwest::Client,
    base: &str,
    victim: &str,
    span: Duration,
) -> (
    Vec<Duration>,
    Vec<Duration>,
    std::collections::BTreeMap<u16, usize>,
) {
    let (mut health, mut gets) = (Vec::new(), Vec::new());
    let mut statuses = std::collections::BTreeMap::new();
    let t = Instant::now();
    while t.elapsed() < span {
        let h = Instant::now();
        let _ = c.get(format!("{base}/healthz")).send().await;
        health.push(h.elapsed());
        let h = Instant::now();
        let r = c
            .get(format!("{base}/v1/renders"))
            .bearer_auth(victim)
            .send()
            .await;
        gets.push(h.elapsed());
        *statuses
            .entry(r.map(|r| r.status().as_u16()).unwrap_or(0))
            .or_insert(0) += 1;
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    (health, gets, statuses)
}

/// Attacks 9 and 7 of the hostile-load issue: 300 renders of one key sent at once (its job
/// quota, 32), then 16 clients of that key reading one byte of its 4096² EXR in a loop; the
/// victim's GETs and `/healthz` meanwhile.
async fn quota_and_range_reads(c: &reqwest::Client, base: &str, attacker: &str, victim: &str) {
    let span = Duration::from_secs(10);
    let (h, g, st) = probes(c, base, victim, span).await;
    println!(
        "baseline: /healthz {}; victim's GETs {} {st:?}",
        percentiles(h),
        percentiles(g)
    );
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["camera"]["width"] = 64.into();
    scene["camera"]["height"] = 64.into();
    let burst = async {
        let mut tasks = tokio::task::JoinSet::new();
        for seed in 0..300u64 {
            let (c, base, key) = (c.clone(), base.to_string(), attacker.to_string());
            // 5 M photons: not small, and ~0.2 GB of the job memory budget each.
            let body = serde_json::json!({"scene": scene, "method": "reference",
                "photons": 5_000_000u64, "seed": seed, "wait": false});
            tasks.spawn(async move { submit(&c, &base, &key, "/v1/renders", body).await });
        }
        let mut by = std::collections::BTreeMap::<u16, usize>::new();
        let mut accepted = Vec::new();
        while let Some(r) = tasks.join_next().await {
            match r.unwrap() {
                Ok(loc) => {
                    *by.entry(202).or_insert(0) += 1;
                    accepted.push(loc);
                }
                Err(s) => *by.entry(s).or_insert(0) += 1,
            }
        }
        (by, accepted)
    };
    let ((by, accepted), (h, g, st)) = tokio::join!(burst, probes(c, base, victim, span));
    let mut active = 0;
    for loc in &accepted {
        let v = state_now(c, base, attacker, loc).await;
        active += usize::from(v["state"] == "queued" || v["state"] == "running");
    }
    println!(
        "300 renders of the attacker at once: {by:?}, {active} queued or running; meanwhile \
         /healthz {}; victim's GETs {} {st:?}",
        percentiles(h),
        percentiles(g)
    );
    for loc in accepted {
        let _ = c
            .delete(format!("{base}{loc}"))
            .bearer_auth(attacker)
            .send()
            .await;
    }
    // A 4096² layered EXR of the attacker's, then 16 clients reading its first byte in a loop.
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["camera"]["width"] = 4096.into();
    scene["camera"]["height"] = 4096.into();
    let body = serde_json::json!({"scene": scene, "method": "direct", "format": "exr",
        "layers": true, "wait": false});
    let Ok(loc) = submit(c, base, attacker, "/v1/renders", body).await else {
        println!("the attacker's EXR render was refused");
        return;
    };
    until(c, base, attacker, &loc, true).await;
    let v = state_now(c, base, attacker, &loc).await;
    let Some(art) = v["artifact"].as_str().map(str::to_string) else {
        println!("the attacker's EXR render has no artifact: {v}");
        return;
    };
    let url = format!("{base}{art}");
    let size = c
        .get(&url)
        .bearer_auth(attacker)
        .send()
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap()
        .len();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let mut readers = tokio::task::JoinSet::new();
    for _ in 0..16 {
        let (c, url, key, stop) = (c.clone(), url.clone(), attacker.to_string(), stop.clone());
        readers.spawn(async move {
            let mut n = 0u64;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                let r = c
                    .get(&url)
                    .bearer_auth(&key)
                    .header("range", "bytes=0-0")
                    .send()
                    .await;
                if let Ok(r) = r {
                    let _ = r.bytes().await;
                    n += 1;
                }
            }
            n
        });
    }
    let (h, g, st) = probes(c, base, victim, span).await;
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let mut reads = 0;
    while let Some(n) = readers.join_next().await {
        reads += n.unwrap();
    }
    println!(
        "16 clients reading byte 0 of a {:.1} MB EXR ({reads} reads in {} s): /healthz {}; \
         victim's GETs {} {st:?}",
        size as f64 / 1e6,
        span.as_secs(),
        percentiles(h),
        percentiles(g)
    );
    let _ = c
        .delete(format!("{base}{loc}"))
        .bearer_auth(attacker)
        .send()
        .await;
}
