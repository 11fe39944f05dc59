//! Without a usable adapter the service still starts and serves CPU methods; `/readyz` says
//! why it is not ready and GPU renders are a 503 problem naming the cause.

use crate::support::contract::AnswerLog;
use crate::support::scenes::scene_sized;
use crate::support::server::*;
use crate::support::{Cleanup, caustica_command, temp_dir};
use std::process::Stdio;
use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn no_adapter_means_not_ready_and_503_for_gpu_renders() {
    let dir = temp_dir("no-gpu");
    let log = AnswerLog::new("no-gpu-answers");
    let _cleanup = Cleanup(dir.clone());
    let mut child = caustica_command()
        .args(["serve", "--addr", "127.0.0.1:0", "--log-json", "--data-dir"])
        .arg(&dir)
        .env("CAUSTICA_ADAPTER", "no-such-adapter")
        .env("CAUSTICA_ANSWER_LOG", log.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let base = listening_on(&mut child);
    let c = client();
    let p = poll("readyz to settle", Duration::from_secs(60), || async {
        let r = c.get(format!("{base}/readyz")).send().await.unwrap();
        let v: serde_json::Value = r.json().await.unwrap();
        (v["type"].as_str().unwrap_or("").ends_with("no-gpu")).then_some(v)
    })
    .await;
    assert_eq!(p["status"], 503);
    assert!(
        p["detail"].as_str().unwrap().contains("no-such-adapter"),
        "{p}"
    );
    let r = c
        .post(format!("{base}/v1/renders"))
        .json(&serde_json::json!({"scene": scene_sized(8, 8), "method": "direct"}))
        .send()
        .await
        .unwrap();
    let p = problem(r, 503).await;
    assert!(p["detail"].as_str().unwrap().contains("GPU"), "{p}");
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
    sigterm(&child);
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    // --log-json: every log line is a JSON object.
    let logs = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = logs.lines().filter(|l| l.starts_with('{')).collect();
    assert!(!lines.is_empty(), "{logs}");
    for l in lines {
        serde_json::from_str::<serde_json::Value>(l).unwrap();
    }
}
