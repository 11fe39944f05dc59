//! Storage integrity (issue: hardening): an artifact that was truncated or replaced by a link
//! is not served and its job runs again; a failed artifact write fails the job and leaves no
//! temporary file; an unreadable job record is quarantined instead of stopping the server; an
//! empty database is reported by `/readyz`.

use crate::support::scenes::scene_sized;
use crate::support::server::*;
use crate::support::{Cleanup, temp_dir};
use std::path::Path;
use std::time::Duration;

fn small_render() -> serde_json::Value {
    serde_json::json!({"scene": scene_sized(8, 8), "method": "reference", "photons": 2000,
                       "spp": 1})
}

/// The stored artifact of job `loc` (`/v1/renders/ID`).
fn artifact_file(dir: &Path, loc: &str) -> std::path::PathBuf {
    let id = loc.rsplit('/').next().unwrap();
    dir.join("artifacts").join(format!("{id}.png"))
}

async fn get_image(srv: &Server, loc: &str) -> reqwest::Response {
    let url = srv.url(&format!("{loc}/image"));
    srv.client.get(url).send().await.unwrap()
}

async fn image_problem(srv: &Server, loc: &str, want: &str) {
    let r = get_image(srv, loc).await;
    assert_eq!(r.headers().get("retry-after").unwrap(), "5");
    let p = problem(r, 500).await;
    assert!(
        p["type"].as_str().unwrap().ends_with("/artifact-lost"),
        "{p}"
    );
    let d = p["detail"].as_str().unwrap();
    assert!(d.contains(want) && d.contains("queued again"), "{p}");
}

async fn image_served(srv: &Server, loc: &str) {
    poll(
        "the render to run again",
        Duration::from_secs(60),
        || async {
            let (_, v) = srv.get_json(loc).await;
            assert_ne!(v["state"], "failed", "{v}");
            (v["state"] == "succeeded").then_some(())
        },
    )
    .await;
    let r = get_image(srv, loc).await;
    assert_eq!(r.status(), 200);
    let img = image::load_from_memory(&r.bytes().await.unwrap()).unwrap();
    assert_eq!((img.width(), img.height()), (8, 8));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_damaged_artifact_is_not_served_and_its_job_runs_again() {
    let srv = Server::start("storage-damaged", |_, _| {}).await;
    let r = srv.post_json("/v1/renders", &small_render()).await;
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let file = artifact_file(&srv.dir, &loc);
    let good = std::fs::read(&file).unwrap();

    // Truncated to nothing (a 0-byte PNG was once served as 200, immutable).
    std::fs::write(&file, b"").unwrap();
    image_problem(&srv, &loc, "is 0 bytes").await;
    image_served(&srv, &loc).await;

    // Same length, other bytes.
    let mut bad = std::fs::read(&file).unwrap();
    let n = bad.len();
    bad[n / 2] ^= 0xff;
    std::fs::write(&file, &bad).unwrap();
    image_problem(&srv, &loc, "does not hash").await;
    image_served(&srv, &loc).await;

    // A symbolic link, even to the right bytes, is not followed.
    let elsewhere = srv.dir.join("elsewhere.png");
    std::fs::write(&elsewhere, &good).unwrap();
    std::fs::remove_file(&file).unwrap();
    std::os::unix::fs::symlink(&elsewhere, &file).unwrap();
    image_problem(&srv, &loc, "symbolic link").await;
    image_served(&srv, &loc).await;
    assert!(!std::fs::symlink_metadata(&file).unwrap().is_symlink());
    srv.stop().await;
}

/// `caustica serve` under a file-size limit (`ulimit -f`, SIGXFSZ ignored: writes past it fail
/// with EFBIG, as on a full disk): a render whose artifact does not fit fails with the reason,
/// no temporary file is left, and the server goes on answering.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_failed_artifact_write_fails_the_job_and_leaves_no_temp_file() {
    let dir = temp_dir("storage-full");
    let _cleanup = Cleanup(dir.clone());
    let (child, base) = serve_under(r#"ulimit -f 1024 && trap "" XFSZ"#, &dir);
    let c = client();
    // Fits: a small PNG.
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(&small_render())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    // Does not fit in 512 KiB: every layer of a noisy 1024² frame as float EXR (~1.1 MB).
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(
            &serde_json::json!({"scene": scene_sized(1024, 1024), "method": "reference",
            "photons": 200_000, "spp": 1, "format": "exr", "layers": true}),
        )
        .send()
        .await
        .unwrap();
    let p = problem(r, 500).await;
    let loc = p["instance"].as_str().unwrap().to_string();
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("storing the artifact failed"),
        "{p}"
    );
    let (_, v) = get_json(&c, &format!("{base}{loc}")).await;
    assert_eq!(v["state"], "failed", "{v}");
    let temps: Vec<_> = std::fs::read_dir(dir.join("artifacts"))
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect();
    assert!(temps.is_empty(), "{temps:?}");
    let (s, _) = get_json(&c, &format!("{base}/healthz")).await;
    assert_eq!(s, 200);
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(&small_render())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200, "the server still renders");
    sigterm(&child.0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unreadable_record_is_quarantined_and_temp_files_are_swept_at_start() {
    let srv = Server::start("storage-quarantine", |_, _| {}).await;
    let dir = srv.dir.clone();
    let cleanup = srv.stop().await;
    {
        let db = rusqlite::Connection::open(dir.join("caustica.sqlite3")).unwrap();
        db.execute(
            "INSERT INTO jobs (id, kind, method, scene_id, params, state, created_at)
             VALUES ('rn_00000000000000000000000000000bad', 'render', 'direct', 'x',
                     'not json', 'queued', 0)",
            [],
        )
        .unwrap();
    }
    std::fs::write(dir.join("artifacts").join(".rn_x.png.tmp"), b"partial").unwrap();
    let srv = Server::start_in(dir.clone(), |_, _| {}).await;
    let (s, _) = srv.get_json("/healthz").await;
    assert_eq!(s, 200);
    assert!(!dir.join("artifacts").join(".rn_x.png.tmp").exists());
    let (state, error): (String, String) = rusqlite::Connection::open(dir.join("caustica.sqlite3"))
        .unwrap()
        .query_row(
            "SELECT state, error FROM jobs WHERE id = 'rn_00000000000000000000000000000bad'",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )
        .unwrap();
    assert_eq!(state, "failed");
    assert!(error.contains("quarantined at start"), "{error}");
    // The server still takes work.
    let r = srv.post_json("/v1/renders", &small_render()).await;
    assert_eq!(r.status(), 200);
    srv.stop().await;
    drop(cleanup);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_emptied_database_is_reported_by_readyz() {
    let dir = temp_dir("storage-empty");
    let _cleanup = Cleanup(dir.clone());
    std::fs::create_dir_all(dir.join("artifacts")).unwrap();
    std::fs::write(dir.join("caustica.sqlite3"), b"").unwrap();
    std::fs::write(dir.join("artifacts").join("rn_old.png"), b"x").unwrap();
    std::fs::write(dir.join("caustica.sqlite3-wal"), vec![7u8; 4096]).unwrap();
    let srv = Server::start_in(dir.clone(), |_, _| {}).await;
    let text = poll("/readyz to settle", Duration::from_secs(60), || async {
        let r = srv.client.get(srv.url("/readyz")).send().await.ok()?;
        let t = r.text().await.ok()?;
        (!t.contains("still probing")).then_some(t)
    })
    .await;
    for want in [
        "is an empty file",
        "is not a SQLite WAL",
        "holds no jobs but",
    ] {
        assert!(text.contains(want), "{want}: {text}");
    }
    srv.stop().await;
}

/// Retention: renders past their time to live are deleted by the sweep.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_past_their_time_to_live_are_deleted() {
    let srv = Server::start("storage-ttl", |j, _| {
        j.retention.render_ttl = Some(Duration::from_secs(1));
        j.retention.sweep_every = Duration::from_millis(100);
    })
    .await;
    let r = srv.post_json("/v1/renders", &small_render()).await;
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let file = artifact_file(&srv.dir, &loc);
    assert!(file.exists());
    poll("the render to expire", Duration::from_secs(30), || async {
        (srv.get_json(&loc).await.0 == 404).then_some(())
    })
    .await;
    assert!(!file.exists());
    srv.stop().await;
}

/// Retention: past the size cap the least recently served renders go first.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn past_the_size_cap_the_least_recently_served_renders_go() {
    let srv = Server::start("storage-lru", |j, _| j.retention.max_render_bytes = None).await;
    let mut locs = Vec::new();
    let mut size = 0;
    for _ in 0..3 {
        // The same request three times: three renders of the same size.
        let r = srv.post_json("/v1/renders", &small_render()).await;
        assert_eq!(r.status(), 200);
        locs.push(r.headers()["location"].to_str().unwrap().to_string());
        size = r.bytes().await.unwrap().len() as u64;
    }
    // The first one served again: now the second is the least recently used.
    assert_eq!(get_image(&srv, &locs[0]).await.status(), 200);
    let dir = srv.dir.clone();
    let cleanup = srv.stop().await;
    let srv = Server::start_in(dir, |j, _| {
        j.retention.max_render_bytes = Some(2 * size + size / 2);
        j.retention.sweep_every = Duration::from_millis(100);
    })
    .await;
    poll(
        "the cap to be enforced",
        Duration::from_secs(30),
        || async { (srv.get_json(&locs[1]).await.0 == 404).then_some(()) },
    )
    .await;
    for kept in [&locs[0], &locs[2]] {
        let (s, v) = srv.get_json(kept).await;
        assert_eq!((s, &v["state"]), (200, &"succeeded".into()), "{kept}");
    }
    srv.stop().await;
    drop(cleanup);
}

/// `DELETE /v1/scenes/{id}`: refused while a job uses the scene, then the scene is gone.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_can_be_deleted_once_no_job_uses_it() {
    let srv = Server::start("storage-scene-delete", |_, h| {
        h.render_wait = Duration::ZERO;
    })
    .await;
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .json(&scene_sized(16, 16))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let v: serde_json::Value = r.json().await.unwrap();
    let id = v["id"].as_str().unwrap().to_string();
    let at = format!("/v1/scenes/{id}");
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": id, "method": "reference", "photons": 100_000_000u64}),
        )
        .await;
    assert_eq!(r.status(), 202);
    let render = r.headers()["location"].to_str().unwrap().to_string();
    let del = || async { srv.client.delete(srv.url(&at)).send().await.unwrap() };
    let p = problem(del().await, 409).await;
    assert!(
        p["detail"].as_str().unwrap().contains("cancel it first"),
        "{p}"
    );
    srv.client.delete(srv.url(&render)).send().await.unwrap();
    assert_eq!(del().await.status(), 204);
    assert_eq!(srv.get_json(&at).await.0, 404);
    let body = serde_json::json!({"scene": id, "method": "reference", "photons": 2000});
    let p = problem(srv.post_json("/v1/renders", &body).await, 422).await;
    assert!(
        p["detail"].as_str().unwrap().contains("no stored scene"),
        "{p}"
    );
    problem(del().await, 404).await;
    srv.stop().await;
}
