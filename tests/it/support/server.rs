//! Shared by the HTTP tests: a real server on an ephemeral port (in this process, or the
//! `caustica` binary as a child), a real HTTP client and bounded polling helpers.

use super::contract::Contract;
use super::{Cleanup, temp_dir};
use caustica::http::{AppState, HttpConfig};
use caustica::jobs::JobConfig;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub struct Server {
    pub base: String,
    pub client: reqwest::Client,
    pub dir: PathBuf,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<std::io::Result<()>>>,
    /// The data directory the server made for itself ([`Server::start`]), removed with it.
    cleanup: Option<Cleanup>,
    /// Every answer checked against the OpenAPI document; a disagreement fails the test when
    /// the server stops or is dropped.
    pub contract: Arc<Contract>,
}

impl Drop for Server {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            self.contract.assert_clean();
        }
    }
}

impl Server {
    /// Starts a server in this process on 127.0.0.1:0 with its own data directory.
    pub async fn start(name: &str, tune: impl FnOnce(&mut JobConfig, &mut HttpConfig)) -> Server {
        let dir = temp_dir(name);
        let mut server = Server::start_in(dir.clone(), tune).await;
        server.cleanup = Some(Cleanup(dir));
        server
    }

    /// Starts a server on an existing data directory (a restart).
    pub async fn start_in(
        dir: PathBuf,
        tune: impl FnOnce(&mut JobConfig, &mut HttpConfig),
    ) -> Server {
        // Its GPU worker makes a context of its own.
        super::gpu::ensure_runtime_dir();
        let mut jc = JobConfig::new(&dir);
        let mut hc = HttpConfig::default();
        let contract = Arc::new(Contract::default());
        hc.observe = Some(contract.observer());
        tune(&mut jc, &mut hc);
        let state = tokio::task::spawn_blocking(move || AppState::start(jc, hc).unwrap())
            .await
            .unwrap();
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(caustica::http::serve(listener, state, async {
            let _ = rx.await;
        }));
        Server {
            base: format!("http://{addr}"),
            client: client(),
            dir,
            stop: Some(tx),
            task: Some(task),
            cleanup: None,
            contract,
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    /// Graceful shutdown; waits for it. The data directory stays (a restart may reuse it)
    /// until the returned guard is dropped.
    pub async fn stop(mut self) -> Option<Cleanup> {
        if let Some(tx) = self.stop.take() {
            let _ = tx.send(());
        }
        if let Some(t) = self.task.take() {
            t.await.unwrap().unwrap();
        }
        self.contract.assert_clean();
        self.cleanup.take()
    }

    pub async fn get_json(&self, path: &str) -> (u16, serde_json::Value) {
        get_json(&self.client, &self.url(path)).await
    }

    pub async fn post_json(&self, path: &str, body: &serde_json::Value) -> reqwest::Response {
        self.client
            .post(self.url(path))
            .json(body)
            .send()
            .await
            .unwrap()
    }

    /// Submits a bake (asserting 202) and returns its id.
    pub async fn submit_bake(&self, body: &serde_json::Value) -> String {
        let r = self.post_json("/v1/bakes", body).await;
        assert_eq!(r.status(), 202);
        let v: serde_json::Value = r.json().await.unwrap();
        v["id"].as_str().unwrap().to_string()
    }

    /// The record of bake `id` once it has succeeded (panics if it fails or takes past `limit`).
    pub async fn bake_succeeded(&self, id: &str, limit: Duration) -> serde_json::Value {
        poll(&format!("bake {id} to succeed"), limit, || async {
            let (_, v) = self.get_json(&format!("/v1/bakes/{id}")).await;
            assert_ne!(v["state"], "failed", "{v}");
            (v["state"] == "succeeded").then_some(v)
        })
        .await
    }

    /// The artifact of a succeeded bake (asserting 200).
    pub async fn bake_artifact(&self, id: &str) -> reqwest::Response {
        let r = self
            .client
            .get(self.url(&format!("/v1/bakes/{id}/artifact")))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
        r
    }
}

pub fn client() -> reqwest::Client {
    reqwest::Client::builder()
        .timeout(Duration::from_secs(300))
        .build()
        .unwrap()
}

pub async fn get_json(c: &reqwest::Client, url: &str) -> (u16, serde_json::Value) {
    let r = c.get(url).send().await.unwrap();
    let s = r.status().as_u16();
    let b = r.bytes().await.unwrap();
    (
        s,
        serde_json::from_slice(&b).unwrap_or(serde_json::Value::Null),
    )
}

/// Polls `f` until it returns Some, at most `limit`; panics with `what` past it.
pub async fn poll<T, F, Fut>(what: &str, limit: Duration, mut f: F) -> T
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Option<T>>,
{
    let t = Instant::now();
    loop {
        if let Some(v) = f().await {
            return v;
        }
        assert!(
            t.elapsed() < limit,
            "timed out after {limit:?} waiting for {what}"
        );
        // Yield between polls (a short pause, not synchronisation: the state decides).
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
}

/// Asserts a problem+json answer and returns its body.
pub async fn problem(r: reqwest::Response, status: u16) -> serde_json::Value {
    let s = r.status().as_u16();
    let ct = r
        .headers()
        .get("content-type")
        .map(|v| v.to_str().unwrap().to_string())
        .unwrap_or_default();
    let body = r.text().await.unwrap();
    assert_eq!(s, status, "{body}");
    assert_eq!(ct, "application/problem+json", "{body}");
    let v: serde_json::Value = serde_json::from_str(&body).unwrap();
    for k in ["type", "title", "status", "detail"] {
        assert!(v.get(k).is_some(), "problem without {k}: {body}");
    }
    assert_eq!(v["status"], status);
    v
}

/// The base URL of a `caustica serve` child started with its stdout piped, from the first line
/// it prints ("caustica listening on URL"); its stdout is closed afterwards.
pub fn listening_on(child: &mut Child) -> String {
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("stdout piped"))
        .read_line(&mut line)
        .unwrap();
    line.trim()
        .strip_prefix("caustica listening on ")
        .unwrap_or_else(|| panic!("unexpected first line {line:?}"))
        .to_string()
}

/// Sends SIGTERM to a child (a graceful shutdown of `caustica serve`).
pub fn sigterm(child: &Child) {
    Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
}

/// A child process killed (and reaped) when dropped, whether the test passed or not; then its
/// answer log, if any, is checked against the spec.
pub struct ChildGuard(pub Child, pub Option<super::contract::AnswerLog>);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
        // Checked (its own drop) now that nothing writes to it.
        drop(self.1.take());
    }
}

/// `caustica serve` on 127.0.0.1:0 over `dir`, started as `sh -c "LIMITS && exec caustica
/// serve ..."` so that `limits` (e.g. `ulimit -v 3145728`) bound it; and its base URL.
pub fn serve_under(limits: &str, dir: &std::path::Path) -> (ChildGuard, String) {
    let exe = super::caustica_command().get_program().to_owned();
    let log = super::contract::AnswerLog::new("answers-serve-under");
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(r#"{limits} && exec "$0" "$@""#))
        .arg(exe)
        .args(["serve", "--addr", "127.0.0.1:0", "--data-dir"])
        .arg(dir)
        .env("CAUSTICA_LOG", "warn")
        // glibc reserves 64 MiB of address space per malloc arena, up to 8 a core: without
        // this, an address-space limit would mean something else on a machine of many cores.
        .env("MALLOC_ARENA_MAX", "2")
        .env("CAUSTICA_ANSWER_LOG", log.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::inherit())
        .spawn()
        .expect("starts");
    let base = listening_on(&mut child);
    (ChildGuard(child, Some(log)), base)
}
