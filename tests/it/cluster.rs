//! Beyond one machine: `caustica serve --no-workers` and `caustica worker` processes sharing a
//! PostgreSQL job store (a throwaway cluster) and one data directory (the shared volume).
//! Real processes: jobs reach a terminal state exactly once in effect, a worker killed with
//! SIGKILL loses its lease and another finishes its job under the same id, the API can be
//! killed and replaced while workers go on, and a restart of PostgreSQL under load loses
//! nothing.

use crate::http_api::read_events;
use crate::support::contract::AnswerLog;
use crate::support::pg::PgCluster;
use crate::support::scenes::{long_bake, scene_sized};
use crate::support::server::*;
use crate::support::{Cleanup, caustica_command, temp_dir};
use object_store::ObjectStoreExt;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

/// Leases in these tests: short, so a dead worker's job is taken again within seconds.
const LEASE_S: &str = "1.5";

/// `caustica serve --no-workers` over `db` and `dir`, with `more` (arguments and environment);
/// its answers go to `log`.
fn api_with(dir: &Path, db: &str, log: &AnswerLog, more: &More) -> (ChildGuard, String) {
    let mut c = caustica_command();
    c.args(["serve", "--addr", "127.0.0.1:0", "--no-workers"])
        .env("CAUSTICA_ANSWER_LOG", log.path())
        // Jobs get 2 GiB: a job estimated above it is refused by the API, not by a worker.
        .env("CAUSTICA_JOB_MEMORY", (2u64 << 30).to_string());
    let mut child = common(&mut c, dir, db, more).spawn().expect("starts");
    let url = listening_on(&mut child);
    (ChildGuard(child, None), url)
}

fn api(dir: &Path, db: &str, log: &AnswerLog) -> (ChildGuard, String) {
    api_with(dir, db, log, &More::default())
}

/// Arguments and environment variables a test adds to a process.
#[derive(Default)]
struct More {
    args: Vec<String>,
    env: Vec<(&'static str, String)>,
}

/// What every process of these tests gets: the store, the data directory, short leases, quiet
/// logs, stdout piped (the first line says it is up).
fn common<'a>(c: &'a mut Command, dir: &Path, db: &str, more: &More) -> &'a mut Command {
    c.args(["--database", db, "--data-dir"])
        .arg(dir)
        .args(&more.args)
        .envs(more.env.iter().map(|(k, v)| (k, v)))
        .env("CAUSTICA_LOG", "warn")
        .env("CAUSTICA_LEASE_S", LEASE_S)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
}

/// A worker process; returns once it printed that it runs (its id names its process id).
fn worker_with(dir: &Path, db: &str, lanes: &str, more: &More) -> ChildGuard {
    let mut c = caustica_command();
    c.args(["worker", "--lanes", lanes])
        .env("CAUSTICA_CPU_WORKERS", "1");
    let mut child = common(&mut c, dir, db, more).spawn().expect("starts");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(
        line.starts_with("caustica worker ") && line.trim_end().ends_with(" running"),
        "{line:?}"
    );
    ChildGuard(child, None)
}

fn worker(dir: &Path, db: &str, lanes: &str) -> ChildGuard {
    worker_with(dir, db, lanes, &More::default())
}

fn render(seed: u64) -> serde_json::Value {
    serde_json::json!({"scene": scene_sized(8, 8), "method": "reference", "photons": 2000,
                       "spp": 1, "seed": seed, "wait": false})
}

fn bake(photons: u64) -> serde_json::Value {
    serde_json::json!({"scene": scene_sized(16, 16), "object": "glass", "method": "reference",
                       "params": {"photons": photons, "spp": 1, "width": 16, "height": 16}})
}

/// The record's state once terminal.
async fn terminal(c: &reqwest::Client, url: &str, limit: Duration) -> serde_json::Value {
    poll(&format!("{url} to end"), limit, || async {
        let (s, v) = get_json(c, url).await;
        assert_eq!(s, 200, "{v}");
        ["succeeded", "failed", "canceled"]
            .contains(&v["state"].as_str().unwrap_or(""))
            .then_some(v)
    })
    .await
}

/// Worker and attempts of job `id`, read from the store.
fn holder(db: &str, id: &str) -> (Option<String>, i32) {
    crate::support::pg::sync(|| {
        let mut c = postgres::Client::connect(db, postgres::NoTls).unwrap();
        let r = c
            .query_one("SELECT worker, attempts FROM jobs WHERE id = $1", &[&id])
            .unwrap();
        (r.get(0), r.get(1))
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_api_and_three_workers_run_mixed_jobs_through_a_postgres_restart() {
    let pg = PgCluster::start("cluster-mixed");
    let db = pg.url("caustica");
    let dir = temp_dir("cluster-mixed");
    let _cleanup = Cleanup(dir.clone());
    let log = AnswerLog::new("cluster-mixed-answers");
    let (_api, base) = api(&dir, &db, &log);
    let _w: Vec<_> = ["cpu,gpu", "cpu", "cpu"]
        .iter()
        .map(|l| worker(&dir, &db, l))
        .collect();
    let c = client();

    // 160 renders and 8 distinct bakes asked for 5 times each: 200 submissions. Half go in
    // before PostgreSQL restarts, half after.
    let mut renders = vec![];
    let mut bakes = vec![];
    for round in 0..2u64 {
        for i in 0..80u64 {
            let r = c
                .post(format!("{base}/v1/renders"))
                .json(&render(round * 1000 + i))
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 202, "{}", r.text().await.unwrap());
            renders.push(r.headers()["location"].to_str().unwrap().to_string());
        }
        for i in 0..20u64 {
            let photons = 20_000 + 1000 * (round * 4 + i % 4);
            let r = c
                .post(format!("{base}/v1/bakes"))
                .json(&bake(photons))
                .send()
                .await
                .unwrap();
            assert!(
                [200, 202].contains(&r.status().as_u16()),
                "{}",
                r.text().await.unwrap()
            );
            let v: serde_json::Value = r.json().await.unwrap();
            bakes.push(v["id"].as_str().unwrap().to_string());
        }
        if round == 0 {
            // Under load: jobs queued and running while the database goes away and comes back.
            pg.restart();
        }
    }
    let unique: std::collections::BTreeSet<_> = bakes.iter().cloned().collect();
    assert_eq!(unique.len(), 8, "one job per distinct bake");
    // A render waited for in the request: the API gets the frame from a worker's record.
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                  "photons": 2000, "spp": 1, "seed": 7}),
        )
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(&r.bytes().await.unwrap()[1..4], b"PNG");

    for loc in &renders {
        let v = terminal(&c, &format!("{base}{loc}"), Duration::from_secs(300)).await;
        assert_eq!(v["state"], "succeeded", "{v}");
    }
    for id in &unique {
        let v = terminal(
            &c,
            &format!("{base}/v1/bakes/{id}"),
            Duration::from_secs(300),
        )
        .await;
        assert_eq!(v["state"], "succeeded", "{v}");
        let (w, attempts) = holder(&db, id);
        assert_eq!((w, attempts), (None, 1), "{id} ran once");
    }
    // One artifact file per job: 8 bakes, 161 renders, no temporary file left.
    let files: Vec<_> = std::fs::read_dir(dir.join("artifacts"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(
        files.iter().filter(|f| f.starts_with("bk_")).count(),
        8,
        "{files:?}"
    );
    assert!(!files.iter().any(|f| f.ends_with(".tmp")), "{files:?}");

    // The bake's bytes are those of the same bake in one embedded server.
    let one = crate::support::server::Server::start("cluster-single", |_, _| {}).await;
    let id = one.submit_bake(&bake(20_000)).await;
    assert!(unique.contains(&id), "same spec, same id");
    one.bake_succeeded(&id, Duration::from_secs(120)).await;
    let single = one.bake_artifact(&id).await.bytes().await.unwrap();
    let r = c
        .get(format!("{base}/v1/bakes/{id}/artifact"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    assert!(
        r.bytes().await.unwrap() == single,
        "the cluster's bake differs from the single process's"
    );
    one.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_worker_loses_its_lease_and_a_new_api_serves_the_result() {
    let pg = PgCluster::start("cluster-kill");
    let db = pg.url("caustica");
    let dir = temp_dir("cluster-kill");
    let _cleanup = Cleanup(dir.clone());
    let log = AnswerLog::new("cluster-kill-answers");
    let (mut api1, base) = api(&dir, &db, &log);
    let mut workers = vec![worker(&dir, &db, "cpu"), worker(&dir, &db, "cpu")];
    let c = client();
    // A job bigger than a whole memory budget is refused at once (10⁸ photons through glass:
    // ~3.8 GiB).
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                  "photons": 100_000_000, "spp": 1, "wait": false}),
        )
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    assert!(p["type"].as_str().unwrap().ends_with("too-big"), "{p}");
    // A bake of a few seconds.
    let r = c
        .post(format!("{base}/v1/bakes"))
        .json(&bake(3_000_000))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 202);
    let v: serde_json::Value = r.json().await.unwrap();
    let id = v["id"].as_str().unwrap().to_string();
    // Live progress through the API, which runs no job: it follows the worker's record.
    let ev = c
        .get(format!("{base}/v1/bakes/{id}/events"))
        .send()
        .await
        .unwrap();
    assert_eq!(ev.status(), 200);
    let mut rises = 0;
    let mut last = -1.0;
    let (_, ended) = read_events(ev, Duration::from_secs(120), |name, v| {
        assert_eq!(name, "progress", "{v}");
        let p = v["progress"].as_f64().unwrap();
        if v["state"] == "running" {
            if p > last && last >= 0.0 {
                rises += 1;
            }
            last = p;
        }
        rises >= 2
    })
    .await;
    assert!(!ended, "the stream goes on while the bake runs");
    // SIGKILL the worker that holds it (its id names its process).
    let (first, attempts) = holder(&db, &id);
    let first = first.expect("held");
    assert_eq!(attempts, 1);
    let victim = workers
        .iter()
        .position(|w| first.contains(&format!("-{}-", w.0.id())))
        .expect("the holder is one of ours");
    let mut dead = workers.remove(victim);
    dead.0.kill().unwrap();
    dead.0.wait().unwrap();
    // And the API: the other worker goes on without it.
    api1.0.kill().unwrap();
    api1.0.wait().unwrap();
    // The lease runs out; the other worker takes the job again under the same id.
    let (api2, base2) = api(&dir, &db, &log);
    let url2 = format!("{base2}/v1/bakes/{id}");
    let done = terminal(&c, &url2, Duration::from_secs(300)).await;
    assert_eq!(done["state"], "succeeded", "{done}");
    assert_eq!(done["info"]["statistics"]["photons_traced"], 3_000_000);
    let (w, attempts) = holder(&db, &id);
    assert_eq!(
        (w, attempts),
        (None, 2),
        "taken twice: the second time by the survivor"
    );
    let r = c.get(format!("{url2}/artifact")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    // Cancelling a bake another process runs: the worker hears it and stops.
    let r = c
        .post(format!("{base2}/v1/bakes"))
        .json(&long_bake(31))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 202);
    let long = r.headers()["location"].to_str().unwrap().to_string();
    poll("the long bake to run", Duration::from_secs(60), || async {
        let (_, v) = get_json(&c, &format!("{base2}{long}")).await;
        (v["state"] == "running").then_some(())
    })
    .await;
    let r = c.delete(format!("{base2}{long}")).send().await.unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    let v = terminal(&c, &format!("{base2}{long}"), Duration::from_secs(30)).await;
    assert_eq!(v["state"], "canceled", "{v}");
    // The worker is free again: a render runs on it.
    let r = c
        .post(format!("{base2}/v1/renders"))
        .json(
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                  "photons": 2000, "spp": 1}),
        )
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    // SIGTERM: the survivor and the new API stop gracefully.
    sigterm(&workers[0].0);
    assert!(workers[0].0.wait().unwrap().success());
    sigterm(&api2.0);
    let mut api2 = api2;
    assert!(api2.0.wait().unwrap().success());
}

/// `moto_server` (moto's S3-compatible server, from PyPI) on a loopback port, killed when
/// dropped; its base URL.
fn moto() -> (ChildGuard, String) {
    let exe = crate::support::python_tool("MOTO_SERVER", "moto_server", "moto[server]==5.2.6");
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let child = std::process::Command::new(exe)
        .args(["-H", "127.0.0.1", "-p", &port.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("moto_server starts");
    (ChildGuard(child, None), format!("http://127.0.0.1:{port}"))
}

/// The settings object_store reads to reach `endpoint` (moto accepts any key).
fn s3_env(endpoint: &str) -> Vec<(&'static str, String)> {
    [
        ("AWS_ENDPOINT", endpoint),
        ("AWS_ALLOW_HTTP", "true"),
        ("AWS_ACCESS_KEY_ID", "test"),
        ("AWS_SECRET_ACCESS_KEY", "test"),
        ("AWS_DEFAULT_REGION", "us-east-1"),
    ]
    .into_iter()
    .map(|(k, v)| (k, v.to_string()))
    .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn artifacts_in_an_s3_bucket_need_no_shared_volume() {
    let (_s3, endpoint) = moto();
    let c = client();
    poll("moto_server to answer", Duration::from_secs(60), || async {
        c.get(&endpoint).send().await.ok().map(|_| ())
    })
    .await;
    let r = c.put(format!("{endpoint}/caustica")).send().await.unwrap();
    assert!(r.status().is_success(), "create the bucket: {}", r.status());
    let pg = PgCluster::start("cluster-s3");
    let db = pg.url("caustica");
    // The API and the worker each with a data directory of its own: only the bucket joins them.
    let (api_dir, worker_dir) = (temp_dir("cluster-s3-api"), temp_dir("cluster-s3-worker"));
    let _cleanup = (Cleanup(api_dir.clone()), Cleanup(worker_dir.clone()));
    let more = More {
        args: vec!["--artifacts".into(), "s3://caustica/run".into()],
        env: s3_env(&endpoint),
    };
    let log = AnswerLog::new("cluster-s3-answers");
    let (_api, base) = api_with(&api_dir, &db, &log, &more);
    let _worker = worker_with(&worker_dir, &db, "cpu", &more);

    // A render the worker makes and the API serves: through the bucket.
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                  "photons": 2000, "spp": 1}),
        )
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let png = r.bytes().await.unwrap();
    let id = loc.rsplit('/').next().unwrap();
    let name = format!("{id}.png");
    let bucket = object_store::aws::AmazonS3Builder::new()
        .with_endpoint(&endpoint)
        .with_allow_http(true)
        .with_bucket_name("caustica")
        .with_access_key_id("test")
        .with_secret_access_key("test")
        .with_region("us-east-1")
        .build()
        .unwrap();
    let object = object_store::path::Path::from(format!("run/artifacts/{name}"));
    let stored = bucket
        .get(&object)
        .await
        .expect("the object is in the bucket");
    assert_eq!(stored.bytes().await.unwrap(), png);
    assert!(worker_dir.join("artifacts").join(&name).exists());
    assert!(
        api_dir.join("artifacts").join(&name).exists(),
        "the API cached what it fetched"
    );
    // Served again after the API's cache lost it: fetched again, the same bytes.
    std::fs::remove_file(api_dir.join("artifacts").join(&name)).unwrap();
    let r = c.get(format!("{base}{loc}/image")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.bytes().await.unwrap(), png);
    // A bake's artifact likewise.
    let r = c
        .post(format!("{base}/v1/bakes"))
        .json(&bake(20_000))
        .send()
        .await
        .unwrap();
    let v: serde_json::Value = r.json().await.unwrap();
    let bake_id = v["id"].as_str().unwrap().to_string();
    let done = terminal(
        &c,
        &format!("{base}/v1/bakes/{bake_id}"),
        Duration::from_secs(120),
    )
    .await;
    assert_eq!(done["state"], "succeeded", "{done}");
    let r = c
        .get(format!("{base}/v1/bakes/{bake_id}/artifact"))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    // Deleting the render deletes its object.
    let r = c.delete(format!("{base}{loc}")).send().await.unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    assert!(
        matches!(
            bucket.get(&object).await,
            Err(object_store::Error::NotFound { .. })
        ),
        "the object is gone"
    );
}
