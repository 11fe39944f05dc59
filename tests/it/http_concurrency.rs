//! 32 clients × 3 small renders at once (GPU direct and CPU reference mixed): every request
//! answers an image (or a job that then succeeds), no error, no job lost.

use crate::support::scenes::scene_sized;
use crate::support::server::*;
use std::collections::HashSet;
use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn thirty_two_clients_three_renders_each() {
    let srv = Server::start("concurrency", |_, _| {}).await;
    // Store the scene once; clients render it by id.
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .header("content-type", "application/json")
        .body(serde_json::to_vec(&scene_sized(8, 8)).unwrap())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let id = r.json::<serde_json::Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let mut tasks = Vec::new();
    for client in 0..32u32 {
        let (base, id) = (srv.base.clone(), id.clone());
        tasks.push(tokio::spawn(async move {
            let c = crate::support::server::client();
            let mut ids = Vec::new();
            for k in 0..3u32 {
                let method = if (client + k) % 2 == 0 {
                    "direct"
                } else {
                    "reference"
                };
                let r = c
                    .post(format!("{base}/v1/renders"))
                    .json(&serde_json::json!({"scene": id, "method": method,
                        "width": 8 + client % 4, "height": 8, "photons": 2000, "spp": 1}))
                    .send()
                    .await
                    .unwrap();
                let status = r.status().as_u16();
                let loc = r.headers()["location"].to_str().unwrap().to_string();
                match status {
                    200 => {
                        let img = image::load_from_memory(&r.bytes().await.unwrap()).unwrap();
                        assert_eq!(img.width(), 8 + client % 4);
                    }
                    202 => {}
                    s => panic!(
                        "client {client} render {k}: {s} {}",
                        r.text().await.unwrap()
                    ),
                }
                ids.push(loc);
            }
            ids
        }));
    }
    let mut all = Vec::new();
    for t in tasks {
        all.extend(t.await.unwrap());
    }
    assert_eq!(all.len(), 96);
    assert_eq!(
        all.iter().collect::<HashSet<_>>().len(),
        96,
        "ids are unique"
    );
    for loc in &all {
        poll(
            "every render to succeed",
            Duration::from_secs(120),
            || async {
                let (_, v) = srv.get_json(loc).await;
                assert_ne!(v["state"], "failed", "{v}");
                (v["state"] == "succeeded").then_some(())
            },
        )
        .await;
    }
    let m = srv
        .client
        .get(srv.url("/metrics"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    assert!(
        m.contains("caustica_jobs_total{kind=\"render\",state=\"succeeded\"} 96"),
        "{m}"
    );
    srv.stop().await;
}
