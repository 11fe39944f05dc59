//! Scheduling under load (issue: hardening): a small render flows while big renders hold every
//! CPU worker, a flood of bakes leaves renders room in the queue, and one render cannot ask
//! for more than the server's caps.

use crate::support::scenes::{long_bake, scene_sized};
use crate::support::server::*;
use std::time::{Duration, Instant};

async fn delete(srv: &Server, loc: &str) -> serde_json::Value {
    let r = srv.client.delete(srv.url(loc)).send().await.unwrap();
    r.json().await.unwrap()
}

async fn state_is(srv: &Server, loc: &str, want: &str, limit: Duration) {
    poll(&format!("{loc} to be {want}"), limit, || async {
        let (_, v) = srv.get_json(loc).await;
        (v["state"] == want).then_some(())
    })
    .await;
}

/// A small reference render answered with its image (asserting 200), and how long it took.
async fn small_render(srv: &Server, seed: u64) -> Duration {
    let t = Instant::now();
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                "photons": 2000, "spp": 1, "seed": seed}),
        )
        .await;
    assert_eq!(r.status(), 200, "{}", r.text().await.unwrap());
    image::load_from_memory(&r.bytes().await.unwrap()).unwrap();
    t.elapsed()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_small_render_flows_while_big_renders_hold_every_worker() {
    let srv = Server::start("fair-small", |j, _| j.cpu_workers = 2).await;
    let mut big = Vec::new();
    for seed in 0..2 {
        let r = srv
            .post_json(
                "/v1/renders",
                &serde_json::json!({"scene": scene_sized(64, 64), "method": "reference",
                    "photons": 100_000_000u64, "seed": seed, "wait": false}),
            )
            .await;
        assert_eq!(r.status(), 202);
        big.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    for loc in &big {
        state_is(&srv, loc, "running", Duration::from_secs(60)).await;
    }
    small_render(&srv, 1).await;
    for loc in &big {
        let (_, v) = srv.get_json(loc).await;
        assert_eq!(
            v["state"], "running",
            "the big renders still hold both workers: {v}"
        );
    }
    for loc in &big {
        delete(&srv, loc).await;
        state_is(&srv, loc, "canceled", Duration::from_secs(30)).await;
    }
    srv.stop().await;
}

/// Big renders hold both general CPU workers: a small bake still runs at once, on the worker
/// that takes only bakes (it used to wait for a render to end).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bake_runs_while_big_renders_hold_every_other_worker() {
    let srv = Server::start("fair-bake", |j, _| j.cpu_workers = 2).await;
    let mut big = Vec::new();
    for seed in 0..2 {
        let r = srv
            .post_json(
                "/v1/renders",
                &serde_json::json!({"scene": scene_sized(64, 64), "method": "reference",
                    "photons": 100_000_000u64, "seed": seed, "wait": false}),
            )
            .await;
        assert_eq!(r.status(), 202);
        big.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    for loc in &big {
        state_is(&srv, loc, "running", Duration::from_secs(60)).await;
    }
    let id = srv
        .submit_bake(
            &serde_json::json!({"scene": scene_sized(8, 8), "object": "glass",
            "method": "reference",
            "params": {"photons": 1000, "spp": 1, "width": 8, "height": 8, "seed": 5}}),
        )
        .await;
    srv.bake_succeeded(&id, Duration::from_secs(60)).await;
    for loc in &big {
        let (_, v) = srv.get_json(loc).await;
        assert_eq!(v["state"], "running", "the big renders still run: {v}");
        delete(&srv, loc).await;
        state_is(&srv, loc, "canceled", Duration::from_secs(30)).await;
    }
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flood_of_bakes_leaves_renders_room() {
    let srv = Server::start("fair-flood", |j, _| {
        j.cpu_workers = 1;
        j.max_queued_bakes = 3;
        // As small as the bakes' room: a shared count would refuse the renders.
        j.max_queued = 3;
    })
    .await;
    let mut accepted = Vec::new();
    let mut refused = 0;
    for seed in 0..8 {
        let r = srv.post_json("/v1/bakes", &long_bake(seed)).await;
        match r.status().as_u16() {
            202 => accepted.push(r.headers()["location"].to_str().unwrap().to_string()),
            429 => {
                let p = problem(r, 429).await;
                assert!(p["detail"].as_str().unwrap().contains("bake queue"), "{p}");
                refused += 1;
            }
            s => panic!("bake {seed}: {s}"),
        }
    }
    assert!(refused >= 4, "{refused} refused");
    // The bake queue is full and its worker busy: renders still get in and through.
    let mut times: Vec<Duration> = Vec::new();
    for seed in 0..10 {
        times.push(small_render(&srv, seed).await);
    }
    times.sort();
    eprintln!(
        "10 small renders under a bake flood: median {:?}, worst {:?}",
        times[5], times[9]
    );
    for loc in &accepted {
        delete(&srv, loc).await;
    }
    for loc in &accepted {
        state_is(&srv, loc, "canceled", Duration::from_secs(30)).await;
    }
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_cannot_ask_past_the_servers_caps() {
    let srv = Server::start("fair-caps", |j, _| j.caps.max_photons = 1_000_000).await;
    for (field, v, want) in [
        (
            "photons",
            2_000_000u64,
            "at most 1000000 on this server (CAUSTICA_MAX_PHOTONS)",
        ),
        ("spp", 512, "at most 256 on this server (CAUSTICA_MAX_SPP)"),
    ] {
        let mut body = serde_json::json!({"scene": scene_sized(8, 8), "method": "reference"});
        body[field] = v.into();
        let p = problem(srv.post_json("/v1/renders", &body).await, 422).await;
        assert_eq!(p["field"], field, "{p}");
        assert!(p["detail"].as_str().unwrap().contains(want), "{p}");
    }
    srv.stop().await;
}

/// A progressive render that asks for more than the server's time (400 M photons with ten
/// minutes of frames; 30 M reference photons, ~40 s on two cores) stops tracing at half the
/// render timeout and returns its frame, instead of failing at the timeout.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_progressive_render_returns_its_frame_within_the_servers_time() {
    let srv = Server::start("fair-budget", |j, _| {
        j.caps.max_photons = 1_000_000_000;
        j.render_timeout = Duration::from_secs(20);
    })
    .await;
    for body in [
        serde_json::json!({"scene": scene_sized(32, 32), "method": "photons",
            "photons": 400_000_000u64, "wait": false,
            "progressive": {"photons_per_frame": 100_000, "time_budget_ms": 600_000}}),
        serde_json::json!({"scene": scene_sized(32, 32), "method": "reference",
            "photons": 30_000_000u64, "spp": 1, "wait": false}),
    ] {
        let r = srv.post_json("/v1/renders", &body).await;
        assert_eq!(r.status(), 202, "{}", r.text().await.unwrap());
        let loc = r.headers()["location"].to_str().unwrap().to_string();
        let v = poll("the render to end", Duration::from_secs(120), || async {
            let (_, v) = srv.get_json(&loc).await;
            (v["state"] != "queued" && v["state"] != "running").then_some(v)
        })
        .await;
        assert_eq!(v["state"], "succeeded", "{v}");
        assert_eq!(v["info"]["statistics"]["stopped_by"], "time budget", "{v}");
        let art = srv
            .client
            .get(srv.url(v["artifact"].as_str().unwrap()))
            .send()
            .await
            .unwrap();
        assert_eq!(art.status(), 200);
        image::load_from_memory(&art.bytes().await.unwrap()).unwrap();
    }
    srv.stop().await;
}

/// Queued and running jobs hold their memory estimates against the job memory budget: a job
/// that alone needs more is 422, one that does not fit beside the others 503 until they end.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jobs_past_the_memory_budget_are_refused() {
    let srv = Server::start("fair-memory", |j, h| {
        j.job_memory = 150 << 20;
        j.cpu_workers = 1;
        h.render_wait = Duration::ZERO;
    })
    .await;
    // 10⁸ photons through the glass: ~4 GiB of stored photons, refused whatever the size.
    let r = serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                               "photons": 100_000_000u64, "spp": 1});
    let p = problem(srv.post_json("/v1/renders", &r).await, 422).await;
    let need: u64 = p["detail"].as_str().unwrap()["this job needs about ".len()..]
        .split(' ')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{p}"));
    assert!((3815..4200).contains(&need), "{p}");
    // Few photons and many camera samples: the estimate is the pixels', the run long.
    let render = |side: u32| {
        serde_json::json!({"scene": scene_sized(side, side), "method": "reference",
                           "photons": 10_000, "spp": 64})
    };
    // 2048² at ~256 bytes a pixel: ~1 GiB, more than the whole budget.
    let p = problem(srv.post_json("/v1/renders", &render(2048)).await, 422).await;
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("more than the 150 MiB"),
        "{p}"
    );
    // 640² (~132 MiB with the sphere and the fixed part) fits once, not twice.
    let r = srv.post_json("/v1/renders", &render(640)).await;
    assert_eq!(r.status(), 202);
    let first = r.headers()["location"].to_str().unwrap().to_string();
    let r = srv.post_json("/v1/renders", &render(640)).await;
    assert_eq!(r.headers()["retry-after"], "5");
    let p = problem(r, 503).await;
    assert!(p["detail"].as_str().unwrap().contains("job memory"), "{p}");
    // Once the first has ended, the second fits.
    srv.client.delete(srv.url(&first)).send().await.unwrap();
    let second = poll("room for the second", Duration::from_secs(30), || async {
        let r = srv.post_json("/v1/renders", &render(640)).await;
        (r.status() == 202).then(|| r.headers()["location"].to_str().unwrap().to_string())
    })
    .await;
    srv.client.delete(srv.url(&second)).send().await.unwrap();
    srv.stop().await;
}
