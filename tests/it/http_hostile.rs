//! The service under hostile load (issue: hostile load): one client cannot shut out another.
//! Slow uploads hold only the bytes they sent and are capped per key; event streams are capped
//! per key and end after their lifetime with a `retry:`; submissions at once cannot pass a
//! key's job quota; a client's requests are paced; a key's scenes are capped by bytes; one
//! key's long GPU render leaves the other GPU workers to other keys; a database outage answers
//! fast 503s while `/healthz` answers and `/readyz` says not ready, and the service comes back
//! with the database.

use crate::support::pg::PgCluster;
use crate::support::scenes::{long_bake, scene_sized};
use crate::support::server::*;
use caustica::http::auth::{Keys, hash_key};
use std::time::Duration;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

const ALICE: &str = "ck_alice-hostile";
const BOB: &str = "ck_bob-hostile";

fn keys() -> Keys {
    let mut k = Keys::default();
    let lines = format!("alice user {}\nbob user {}", hash_key(ALICE), hash_key(BOB));
    k.parse(&lines, "test").unwrap();
    k
}

/// The status line and headers of the answer on `s` (read up to the blank line).
async fn answer_head(mut s: impl tokio::io::AsyncRead + Unpin) -> String {
    let mut buf = Vec::new();
    let mut b = [0u8; 1024];
    while !buf.windows(4).any(|w| w == b"\r\n\r\n") {
        match s.read(&mut b).await {
            Ok(0) | Err(_) => break,
            Ok(n) => buf.extend_from_slice(&b[..n]),
        }
    }
    String::from_utf8_lossy(&buf).into_owned()
}

async fn upload(srv: &Server, key: &str) -> reqwest::Response {
    srv.client
        .post(srv.url("/v1/scenes"))
        .bearer_auth(key)
        .header("content-type", "application/json")
        .body(serde_json::to_vec(&scene_sized(8, 8)).unwrap())
        .send()
        .await
        .unwrap()
}

/// Six of alice's sockets each declare the largest body (a quarter of the budget) and send
/// four bytes: three are refused at once (429, her cap of uploads), three are held — by the
/// bytes they sent, not the bytes they announced — and bob's uploads go through while they
/// hang, a largest one included; once they close, alice uploads again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_uploads_hold_what_they_sent_and_are_capped_per_key() {
    let srv = Server::start("hostile-uploads", |_, h| {
        h.keys = keys();
        h.max_body = 1 << 20;
        h.max_body_bytes_in_flight = 4 << 20;
        h.max_uploads_per_client = 3;
    })
    .await;
    let addr = srv.base.trim_start_matches("http://").to_string();
    let mut hogs = tokio::task::JoinSet::new();
    let mut held = Vec::new();
    for _ in 0..6 {
        let mut s = TcpStream::connect(&addr).await.unwrap();
        s.write_all(
            format!(
                "POST /v1/scenes HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {ALICE}\r\n\
                 Content-Type: model/gltf-binary\r\nContent-Length: 1048576\r\n\r\nglTF"
            )
            .as_bytes(),
        )
        .await
        .unwrap();
        let (r, w) = s.into_split();
        held.push(w);
        hogs.spawn(answer_head(r));
    }
    let mut refused = Vec::new();
    while refused.len() < 3 {
        let head = tokio::time::timeout(Duration::from_secs(20), hogs.join_next())
            .await
            .expect("three of six uploads are refused at once")
            .unwrap()
            .unwrap();
        refused.push(head);
    }
    for head in &refused {
        assert!(head.starts_with("HTTP/1.1 429"), "{head}");
        assert!(
            head.to_ascii_lowercase().contains("retry-after: 1"),
            "{head}"
        );
    }
    // Bob's uploads are admitted beside alice's three (which announced three quarters of the
    // budget), a largest one too.
    assert_eq!(upload(&srv, BOB).await.status(), 201);
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .bearer_auth(BOB)
        .header("content-type", "model/gltf-binary")
        .body(vec![0u8; 1 << 20])
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    assert_eq!(
        p["type"], "/problems/invalid-scene",
        "read whole, then refused: {p}"
    );
    let p = problem(upload(&srv, ALICE).await, 429).await;
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("CAUSTICA_MAX_UPLOADS_PER_CLIENT"),
        "{p}"
    );
    assert_eq!(hogs.len(), 3, "three uploads still hang, unanswered");
    drop(held);
    hogs.abort_all();
    poll(
        "alice's uploads to be admitted again",
        Duration::from_secs(20),
        || async { (upload(&srv, ALICE).await.status() == 201).then_some(()) },
    )
    .await;
    srv.stop().await;
}

/// Alice follows two event streams of a long bake (her cap); a third is refused with 429,
/// bob's own stream of the same bake is served; each stream ends after the lifetime without
/// `done`, its first event carrying `retry:`; then alice may follow it again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn event_streams_are_capped_per_key_and_end_with_retry() {
    let srv = Server::start("hostile-streams", |j, h| {
        j.cpu_workers = 1;
        h.keys = keys();
        h.max_streams_per_client = 2;
        h.stream_lifetime = Duration::from_secs(2);
    })
    .await;
    let post = |key: &'static str| {
        srv.client
            .post(srv.url("/v1/bakes"))
            .bearer_auth(key)
            .json(&long_bake(7))
            .send()
    };
    let r = post(ALICE).await.unwrap();
    assert_eq!(r.status(), 202);
    let id = r.json::<serde_json::Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(post(BOB).await.unwrap().status(), 202, "bob holds it too");
    let events = format!("/v1/bakes/{id}/events");
    let follow = |key: &'static str| srv.client.get(srv.url(&events)).bearer_auth(key).send();
    let a1 = follow(ALICE).await.unwrap();
    let a2 = follow(ALICE).await.unwrap();
    assert_eq!((a1.status().as_u16(), a2.status().as_u16()), (200, 200));
    let third = follow(ALICE).await.unwrap();
    assert_eq!(third.headers()["retry-after"], "1");
    let p = problem(third, 429).await;
    assert_eq!(p["type"], "/problems/too-many", "{p}");
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("CAUSTICA_MAX_STREAMS_PER_CLIENT"),
        "{p}"
    );
    let b1 = follow(BOB).await.unwrap();
    assert_eq!(b1.status(), 200, "another key's stream is served");
    for r in [a1, a2, b1] {
        let text = tokio::time::timeout(Duration::from_secs(30), r.text())
            .await
            .expect("the stream ends after its lifetime")
            .unwrap();
        assert!(text.contains("retry: 1000"), "{text}");
        assert!(text.contains("event: progress"), "{text}");
        assert!(
            !text.contains("event: done"),
            "the bake is still running: {text}"
        );
    }
    poll(
        "alice to follow the bake again",
        Duration::from_secs(20),
        || async {
            let r = follow(ALICE).await.unwrap();
            (r.status() == 200).then_some(())
        },
    )
    .await;
    for key in [ALICE, BOB] {
        let r = srv
            .client
            .delete(srv.url(&format!("/v1/bakes/{id}")))
            .bearer_auth(key)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
    }
    srv.stop().await;
}

/// Twenty-four renders of one key sent at once against a quota of three: exactly three are
/// accepted (the count and the hold are one step), the rest get 429.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_job_quota_holds_under_parallel_submissions() {
    let srv = Server::start("hostile-quota", |j, h| {
        j.cpu_workers = 1;
        h.keys = keys();
        h.max_jobs_per_key = 3;
    })
    .await;
    let mut tasks = tokio::task::JoinSet::new();
    for seed in 0..24u64 {
        let (c, url) = (client(), srv.url("/v1/renders"));
        tasks.spawn(async move {
            let r = c
                .post(url)
                .bearer_auth(ALICE)
                .json(
                    &serde_json::json!({"scene": scene_sized(64, 64), "method": "reference",
                    "photons": 100_000_000u64, "seed": seed, "wait": false}),
                )
                .send()
                .await
                .unwrap();
            let status = r.status().as_u16();
            let loc = r
                .headers()
                .get("location")
                .map(|l| l.to_str().unwrap().to_string());
            (status, loc)
        });
    }
    let mut accepted = vec![];
    while let Some(r) = tasks.join_next().await {
        match r.unwrap() {
            (202, Some(loc)) => accepted.push(loc),
            (429, _) => {}
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(accepted.len(), 3, "{accepted:?}");
    let r = srv
        .client
        .get(srv.url("/v1/renders?state=queued"))
        .bearer_auth(ALICE)
        .send()
        .await
        .unwrap();
    let v: serde_json::Value = r.json().await.unwrap();
    let running = srv
        .client
        .get(srv.url("/v1/renders?state=running"))
        .bearer_auth(ALICE)
        .send()
        .await
        .unwrap()
        .json::<serde_json::Value>()
        .await
        .unwrap();
    let active = v["items"].as_array().unwrap().len() + running["items"].as_array().unwrap().len();
    assert_eq!(active, 3, "{v} {running}");
    for loc in &accepted {
        let r = srv
            .client
            .delete(srv.url(loc))
            .bearer_auth(ALICE)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
    }
    srv.stop().await;
}

/// Alice sends 200 requests at once against a pace of 10 a second: the first wait their turn
/// (all answered), those whose turn is over a second away get 429 naming the setting; bob's
/// request is not paced behind hers, and `/healthz` is not paced at all.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn requests_are_paced_per_client() {
    let srv = Server::start("hostile-pace", |_, h| {
        h.keys = keys();
        h.requests_per_client = 10;
    })
    .await;
    let get = |key: &'static str| {
        srv.client
            .get(srv.url("/v1/renders"))
            .bearer_auth(key)
            .send()
    };
    let mut hers = tokio::task::JoinSet::new();
    for _ in 0..200 {
        let (c, url) = (client(), srv.url("/v1/renders"));
        hers.spawn(async move {
            let r = c.get(url).bearer_auth(ALICE).send().await.unwrap();
            let status = r.status().as_u16();
            (status, r.text().await.unwrap())
        });
    }
    assert_eq!(
        get(BOB).await.unwrap().status(),
        200,
        "bob has his own pace"
    );
    for _ in 0..30 {
        let r = srv.client.get(srv.url("/healthz")).send().await.unwrap();
        assert_eq!(r.status(), 200);
    }
    let (mut ok, mut paced) = (0, 0);
    while let Some(r) = hers.join_next().await {
        match r.unwrap() {
            (200, _) => ok += 1,
            (429, body) => {
                assert!(body.contains("CAUSTICA_REQUESTS_PER_CLIENT"), "{body}");
                assert!(body.contains("/problems/too-many"), "{body}");
                paced += 1;
            }
            other => panic!("{other:?}"),
        }
    }
    assert!(
        ok >= 10,
        "a second's worth at once, then the waiting ones: {ok}"
    );
    assert!(paced > 0, "past a second's wait: 429 ({ok} answered)");
    srv.stop().await;
}

/// Alice's scenes count against her storage quota: past it a new scene gets 429 quota naming
/// the setting, while bob's go through; deleting one of hers makes room again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_keys_storage_is_capped() {
    let body = |i: u32| serde_json::to_vec(&scene_sized(8, 8 + i)).unwrap();
    let len = body(0).len() as u64;
    let srv = Server::start("hostile-storage", |_, h| {
        h.keys = keys();
        h.max_bytes_per_key = 2 * len + len / 2;
    })
    .await;
    let post = |key: &'static str, i: u32| {
        srv.client
            .post(srv.url("/v1/scenes"))
            .bearer_auth(key)
            .header("content-type", "application/json")
            .body(body(i))
            .send()
    };
    let mut hers = vec![];
    for i in 0..2 {
        let r = post(ALICE, i).await.unwrap();
        assert_eq!(r.status(), 201);
        hers.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    let p = problem(post(ALICE, 2).await.unwrap(), 429).await;
    assert_eq!(p["type"], "/problems/quota", "{p}");
    let detail = p["detail"].as_str().unwrap();
    assert!(detail.contains("CAUSTICA_MAX_BYTES_PER_KEY"), "{p}");
    assert!(detail.contains("key 'alice'"), "{p}");
    assert_eq!(post(BOB, 2).await.unwrap().status(), 201, "bob has room");
    let r = srv
        .client
        .delete(srv.url(&hers[0]))
        .bearer_auth(ALICE)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    assert_eq!(post(ALICE, 2).await.unwrap().status(), 201, "room again");
    srv.stop().await;
}

/// The job at `loc`'s state, as `key` sees it.
async fn state(srv: &Server, key: &str, loc: &str) -> String {
    let r = srv
        .client
        .get(srv.url(loc))
        .bearer_auth(key)
        .send()
        .await
        .unwrap();
    let v: serde_json::Value = r.json().await.unwrap();
    v["state"].as_str().unwrap().to_string()
}

/// Alice queues two photon renders that would run for minutes: one runs on a GPU worker, her
/// second waits (one GPU job per key) though a worker is free, and bob's render — big enough
/// not to be a small one — runs on that worker and ends while hers runs.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_keys_long_gpu_render_leaves_the_other_gpu_workers_to_others() {
    let srv = Server::start("hostile-lanes", |j, h| {
        j.cpu_workers = 1;
        j.gpu_workers = 2;
        j.caps.max_photons = 1_000_000_000;
        h.keys = keys();
    })
    .await;
    let post = |key: &'static str, body: serde_json::Value| {
        srv.client
            .post(srv.url("/v1/renders"))
            .bearer_auth(key)
            .json(&body)
            .send()
    };
    let mut hers = vec![];
    for seed in 0..2u64 {
        let body = serde_json::json!({"scene": scene_sized(64, 64), "method": "photons",
            "photons": 1_000_000_000u64, "seed": seed, "wait": false,
            "progressive": {"photons_per_frame": 1_000_000, "time_budget_ms": 600_000}});
        let r = post(ALICE, body).await.unwrap();
        assert_eq!(r.status(), 202);
        hers.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    poll(
        "alice's first render to run",
        Duration::from_secs(60),
        || async { (state(&srv, ALICE, &hers[0]).await == "running").then_some(()) },
    )
    .await;
    // 1,025 × 1,024 pixels: past the small renders' 2^20, so not on the small worker.
    let r = post(
        BOB,
        serde_json::json!({"scene": scene_sized(1025, 1024), "method": "direct", "wait": false}),
    )
    .await
    .unwrap();
    assert_eq!(r.status(), 202);
    let his = r.headers()["location"].to_str().unwrap().to_string();
    poll("bob's render to end", Duration::from_secs(120), || async {
        let s = state(&srv, BOB, &his).await;
        (s != "queued" && s != "running").then_some(s)
    })
    .await;
    assert_eq!(state(&srv, BOB, &his).await, "succeeded");
    let first = srv
        .client
        .get(srv.url(&hers[0]))
        .bearer_auth(ALICE)
        .send()
        .await
        .unwrap();
    let first: serde_json::Value = first.json().await.unwrap();
    assert_eq!(first["state"], "running", "{first}");
    assert_eq!(
        state(&srv, ALICE, &hers[1]).await,
        "queued",
        "alice's second waits for her first"
    );
    for loc in &hers {
        let r = srv
            .client
            .delete(srv.url(loc))
            .bearer_auth(ALICE)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
    }
    srv.stop().await;
}

/// The database goes away: requests that need it get 503 `store-unavailable` with
/// Retry-After within the client's 15 s (not after the workers' minute of retries), `/healthz`
/// answers throughout, `/readyz` is not ready; with the database back, so is the service.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_store_outage_answers_fast_503s_and_healthz() {
    let pg = std::sync::Arc::new(
        tokio::task::spawn_blocking(|| PgCluster::start("hostile-outage"))
            .await
            .unwrap(),
    );
    let url = {
        let pg = pg.clone();
        tokio::task::spawn_blocking(move || pg.url("outage"))
            .await
            .unwrap()
    };
    let srv = Server::start("hostile-outage", |j, _| j.database = Some(url)).await;
    let quick = reqwest::Client::builder()
        .timeout(Duration::from_secs(15))
        .build()
        .unwrap();
    let get = |path: &str| quick.get(srv.url(path)).send();
    poll(
        "the server to be ready",
        Duration::from_secs(120),
        || async { (get("/readyz").await.unwrap().status() == 200).then_some(()) },
    )
    .await;
    assert_eq!(get("/v1/renders").await.unwrap().status(), 200);
    {
        let pg = pg.clone();
        tokio::task::spawn_blocking(move || pg.stop())
            .await
            .unwrap();
    }
    // Several requests at once, while /healthz is asked.
    let lists: Vec<_> = (0..6).map(|_| get("/v1/renders")).collect();
    let health = get("/healthz");
    let (lists, health) = tokio::join!(futures_util::future::join_all(lists), health);
    assert_eq!(health.unwrap().status(), 200);
    for r in lists {
        let r = r.expect("answered within the client's 15 s");
        assert_eq!(r.headers()["retry-after"], "5");
        let p = problem(r, 503).await;
        assert_eq!(p["type"], "/problems/store-unavailable", "{p}");
    }
    let p = problem(get("/readyz").await.unwrap(), 503).await;
    assert_eq!(p["type"], "/problems/store-unavailable", "{p}");
    assert_eq!(get("/healthz").await.unwrap().status(), 200);
    {
        let pg = pg.clone();
        tokio::task::spawn_blocking(move || pg.start_again())
            .await
            .unwrap();
    }
    poll(
        "the service to come back",
        Duration::from_secs(60),
        || async {
            let ok = get("/v1/renders").await.is_ok_and(|r| r.status() == 200)
                && get("/readyz").await.is_ok_and(|r| r.status() == 200);
            ok.then_some(())
        },
    )
    .await;
    srv.stop().await;
}
