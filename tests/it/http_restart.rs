//! Restart: the `caustica serve` binary is killed (SIGKILL) in the middle of a bake, started
//! again on the same data directory, and the bake completes under the same id; a finished
//! render from before the kill is still served.

use crate::support::contract::AnswerLog;
use crate::support::scenes::scene_sized;
use crate::support::server::*;
use crate::support::{Cleanup, caustica_command, temp_dir};
use std::process::{Child, Stdio};
use std::time::Duration;

/// Starts `caustica serve` on an ephemeral port; returns the child and its base URL (read
/// from the line it prints on stdout).
fn spawn(dir: &std::path::Path, log: &AnswerLog) -> (Child, String) {
    let mut child = caustica_command()
        .args(["serve", "--addr", "127.0.0.1:0", "--data-dir"])
        .arg(dir)
        .env("CAUSTICA_LOG", "warn")
        .env("CAUSTICA_ANSWER_LOG", log.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("starts");
    let url = listening_on(&mut child);
    (child, url)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bake_interrupted_by_kill_9_completes_after_restart() {
    // Both processes' answers, checked against the spec once the test is done with them.
    let log = AnswerLog::new("restart-answers");
    let dir = temp_dir("restart");
    let _cleanup = Cleanup(dir.clone());
    let c = client();
    let (mut child, base) = spawn(&dir, &log);
    // A render that finishes before the kill.
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
    let render = r.headers()["location"].to_str().unwrap().to_string();
    let png = r.bytes().await.unwrap();
    // A bake that takes a few seconds.
    let r = c
        .post(format!("{base}/v1/bakes"))
        .json(&serde_json::json!({
            "scene": scene_sized(16, 16), "object": "glass", "method": "reference",
            "params": {"photons": 3_000_000, "spp": 1},
        }))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 202);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    poll("the bake to run", Duration::from_secs(60), || async {
        let (_, v) = get_json(&c, &format!("{base}{loc}")).await;
        (v["state"] == "running" && v["progress"].as_f64().unwrap() > 0.0).then_some(())
    })
    .await;
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();

    let (mut child, base) = spawn(&dir, &log);
    let (s, v) = get_json(&c, &format!("{base}{loc}")).await;
    assert_eq!(s, 200);
    assert!(
        ["queued", "running", "succeeded"].contains(&v["state"].as_str().unwrap()),
        "{v}"
    );
    let done = poll("the bake to complete", Duration::from_secs(300), || async {
        let (_, v) = get_json(&c, &format!("{base}{loc}")).await;
        assert_ne!(v["state"], "failed", "{v}");
        (v["state"] == "succeeded").then_some(v)
    })
    .await;
    assert_eq!(done["info"]["statistics"]["photons_traced"], 3_000_000);
    let r = c.get(format!("{base}{loc}/artifact")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    // The render from before the kill is still there.
    let r = c.get(format!("{base}{render}/image")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    assert_eq!(r.bytes().await.unwrap(), png);
    // SIGTERM: graceful exit.
    sigterm(&child);
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
}
