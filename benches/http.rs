//! HTTP request overhead, in process over loopback with a real client: the work around the
//! renderer (routing, body handling, JSON, hashing, validation, SQLite, queueing), not GPU
//! time. `POST /v1/scenes` of an already stored scene (parse, canonicalise, hash, resolve,
//! store), `GET /v1/scenes/{id}`, `GET /healthz`, and a 1×1 `direct` render (queue + GPU
//! worker hand-off + a 1-pixel frame + PNG encode; the `Server-Timing` of a run shows how
//! little of it is GPU).

use caustica::http::{AppState, HttpConfig};
use caustica::jobs::JobConfig;
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

const SCENE: &str = include_str!("../scenes/glass-sphere-directional.json");

fn bench(c: &mut Criterion) {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .unwrap();
    let dir = std::env::temp_dir().join(format!("caustica-bench-http-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (base, id) = rt.block_on(async {
        // Unpaced: the loop below is one client asking as fast as it can.
        let http = HttpConfig {
            requests_per_client: 0,
            ..HttpConfig::default()
        };
        let state = AppState::start(JobConfig::new(&dir), http).unwrap();
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let base = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(caustica::http::serve(
            listener,
            state,
            std::future::pending(),
        ));
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
        (base, v["id"].as_str().unwrap().to_string())
    });
    let client = reqwest::Client::new();
    let mut g = c.benchmark_group("http");
    g.measurement_time(Duration::from_secs(5));
    g.bench_function("GET /healthz", |b| {
        b.to_async(&rt).iter(|| async {
            let r = client.get(format!("{base}/healthz")).send().await.unwrap();
            assert_eq!(r.status(), 200);
            r.bytes().await.unwrap()
        })
    });
    g.bench_function("GET /v1/scenes/{id}", |b| {
        b.to_async(&rt).iter(|| async {
            let r = client
                .get(format!("{base}/v1/scenes/{id}"))
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 200);
            r.bytes().await.unwrap()
        })
    });
    g.bench_function("POST /v1/scenes (stored)", |b| {
        b.to_async(&rt).iter(|| async {
            let r = client
                .post(format!("{base}/v1/scenes"))
                .header("content-type", "application/json")
                .body(SCENE)
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 201);
            r.bytes().await.unwrap()
        })
    });
    let body = serde_json::json!({"scene": id, "method": "direct", "width": 1, "height": 1});
    g.bench_function("POST /v1/renders direct 1x1", |b| {
        b.to_async(&rt).iter(|| async {
            let r = client
                .post(format!("{base}/v1/renders"))
                .json(&body)
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 200);
            r.bytes().await.unwrap()
        })
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
