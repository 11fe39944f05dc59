//! API keys (issue: hardening): every `/v1` route needs a key once keys are configured; scenes,
//! jobs and idempotency keys belong to their keys; a bake two clients asked for is shared, and
//! one client's `DELETE` drops only its own hold; an admin key sees and cancels everything;
//! `serve` refuses a public address without keys.

use crate::support::scenes::{long_bake, scene_sized};
use crate::support::server::*;
use crate::support::{Cleanup, caustica, caustica_command, temp_dir};
use caustica::http::auth::{Keys, hash_key};
use std::process::Stdio;
use std::time::Duration;

const ALICE: &str = "ck_alice-test-key";
const BOB: &str = "ck_bob-test-key";
const ROOT: &str = "ck_root-test-key";

fn keys() -> Keys {
    let mut k = Keys::default();
    let lines = format!(
        "alice user {}\nbob user {}\nroot admin {}",
        hash_key(ALICE),
        hash_key(BOB),
        hash_key(ROOT)
    );
    k.parse(&lines, "test").unwrap();
    k
}

struct As<'a>(&'a Server, &'a str);

impl As<'_> {
    async fn post(&self, path: &str, body: &serde_json::Value) -> reqwest::Response {
        self.0
            .client
            .post(self.0.url(path))
            .bearer_auth(self.1)
            .json(body)
            .send()
            .await
            .unwrap()
    }
    async fn get(&self, path: &str) -> reqwest::Response {
        let c = &self.0.client;
        c.get(self.0.url(path))
            .bearer_auth(self.1)
            .send()
            .await
            .unwrap()
    }
    async fn delete(&self, path: &str) -> serde_json::Value {
        let c = &self.0.client;
        let r = c
            .delete(self.0.url(path))
            .bearer_auth(self.1)
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
        r.json().await.unwrap()
    }
    async fn state(&self, path: &str) -> String {
        let v: serde_json::Value = self.get(path).await.json().await.unwrap();
        v["state"].as_str().unwrap_or("?").to_string()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_key_sees_its_own_and_shares_what_both_asked_for() {
    let srv = Server::start("keys", |j, h| {
        h.keys = keys();
        j.cpu_workers = 1;
    })
    .await;
    let (alice, bob, root) = (As(&srv, ALICE), As(&srv, BOB), As(&srv, ROOT));

    // No key, an unknown key: 401 with a challenge; the probes and the spec stay open.
    let r = srv.post_json("/v1/renders", &serde_json::json!({})).await;
    assert_eq!(r.headers()["www-authenticate"], "Bearer realm=\"caustica\"");
    problem(r, 401).await;
    problem(As(&srv, "ck_nobody").get("/v1/renders/x").await, 401).await;
    for open in ["/healthz", "/openapi.json"] {
        assert_eq!(srv.get_json(open).await.0, 200, "{open}");
    }
    problem(alice.get("/metrics").await, 403).await;
    assert_eq!(root.get("/metrics").await.status(), 200);

    // Scenes: another user's id is unknown to bob until he uploads the same scene.
    let r = alice.post("/v1/scenes", &scene_sized(8, 8)).await;
    assert_eq!(r.status(), 201);
    let scene: serde_json::Value = r.json().await.unwrap();
    let scene = scene["id"].as_str().unwrap().to_string();
    let at = format!("/v1/scenes/{scene}");
    problem(bob.get(&at).await, 404).await;
    let body =
        serde_json::json!({"scene": scene, "method": "reference", "photons": 2000, "spp": 1});
    let p = problem(bob.post("/v1/renders", &body).await, 422).await;
    assert!(
        p["detail"].as_str().unwrap().contains("no stored scene"),
        "{p}"
    );
    assert_eq!(
        bob.post("/v1/scenes", &scene_sized(8, 8)).await.status(),
        201
    );
    assert_eq!(bob.get(&at).await.status(), 200);

    // Renders: alice's is hers (and the admin's).
    let r = alice.post("/v1/renders", &body).await;
    assert_eq!(r.status(), 200);
    let render = r.headers()["location"].to_str().unwrap().to_string();
    problem(bob.get(&render).await, 404).await;
    problem(bob.get(&format!("{render}/image")).await, 404).await;
    assert_eq!(root.get(&format!("{render}/image")).await.status(), 200);
    // Lists show a key what it holds (the admin: everything).
    let listed = |v: serde_json::Value| -> Vec<String> {
        v["items"]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| format!("/v1/renders/{}", i["id"].as_str().unwrap()))
            .collect()
    };
    let list = |who: &'static str| {
        let srv = &srv;
        async move {
            let r = As(srv, who).get("/v1/renders").await;
            assert_eq!(r.status(), 200);
            listed(r.json().await.unwrap())
        }
    };
    assert_eq!(list(ALICE).await, vec![render.clone()]);
    assert!(list(BOB).await.is_empty());
    assert_eq!(list(ROOT).await, vec![render.clone()]);
    let scenes: serde_json::Value = bob.get("/v1/scenes").await.json().await.unwrap();
    assert_eq!(scenes["items"][0]["id"], scene.as_str(), "{scenes}");
    problem(As(&srv, "ck_nobody").get("/v1/scenes").await, 401).await;

    // A bake both asked for is one job; bob's DELETE drops his hold only.
    let r = alice.post("/v1/bakes", &long_bake(1)).await;
    assert_eq!(r.status(), 202);
    let bake = r.headers()["location"].to_str().unwrap().to_string();
    let r = bob.post("/v1/bakes", &long_bake(1)).await;
    assert_eq!(r.headers()["location"].to_str().unwrap(), bake);
    poll("the bake to run", Duration::from_secs(60), || async {
        (alice.state(&bake).await == "running").then_some(())
    })
    .await;
    let v = bob.delete(&bake).await;
    assert_eq!(v["state"], "running", "{v}");
    problem(bob.get(&bake).await, 404).await;
    assert_eq!(alice.state(&bake).await, "running");
    // Idempotency keys are per client: bob's "k" is not alice's.
    let with_key = |who: &'static str, seed: u64| {
        let c = srv.client.clone();
        let url = srv.url("/v1/bakes");
        async move {
            c.post(url)
                .bearer_auth(who)
                .header("idempotency-key", "k")
                .json(&long_bake(seed))
                .send()
                .await
                .unwrap()
        }
    };
    let a = with_key(ALICE, 2).await;
    assert_eq!(a.status(), 202);
    let b = with_key(BOB, 3).await;
    assert_eq!(b.status(), 202, "bob's key k is his own");
    let b = b.headers()["location"].to_str().unwrap().to_string();
    problem(with_key(ALICE, 4).await, 422).await;
    // Once the last holder lets go (or an admin says so), the job is canceled.
    assert_eq!(bob.delete(&b).await["state"], "canceled");
    let a = a.headers()["location"].to_str().unwrap().to_string();
    assert_eq!(root.delete(&a).await["state"], "canceled");
    let v = alice.delete(&bake).await;
    assert_eq!(v["state"], "canceled", "{v}");
    srv.stop().await;
}

#[test]
fn serve_refuses_a_public_address_without_keys() {
    let dir = temp_dir("keys-public");
    let _cleanup = Cleanup(dir.clone());
    let out = caustica_command()
        .args(["serve", "--addr", "0.0.0.0:0", "--data-dir"])
        .arg(&dir)
        .env_remove("CAUSTICA_API_KEYS")
        .env_remove("CAUSTICA_API_KEYS_FILE")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not a loopback address") && err.contains("--api-keys"),
        "{err}"
    );

    // `caustica key new` makes a key and its line; with the line, the same address serves.
    let out = caustica(&["key", "new", "ci", "--admin"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let line = text.lines().find_map(|l| l.strip_prefix("line: ")).unwrap();
    let key = text.lines().find_map(|l| l.strip_prefix("key:  ")).unwrap();
    assert_eq!(line, format!("ci admin {}", hash_key(key)));
    let keyfile = dir.join("keys.txt");
    std::fs::write(&keyfile, format!("# test\n{line}\n")).unwrap();
    let mut child = caustica_command()
        .args(["serve", "--addr", "0.0.0.0:0", "--api-keys"])
        .arg(&keyfile)
        .arg("--data-dir")
        .arg(&dir)
        .env("CAUSTICA_LOG", "warn")
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let url = listening_on(&mut child);
    assert!(url.starts_with("http://0.0.0.0:"), "{url}");
    sigterm(&child);
    assert!(child.wait().unwrap().success());
}

/// One user key cannot hold more than its quota of queued or running jobs; an admin can.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_key_past_its_quota_gets_429() {
    let srv = Server::start("keys-quota", |j, h| {
        h.keys = keys();
        h.max_jobs_per_key = 2;
        j.cpu_workers = 1;
    })
    .await;
    let (alice, bob, root) = (As(&srv, ALICE), As(&srv, BOB), As(&srv, ROOT));
    let mut mine = Vec::new();
    for seed in 10..12 {
        let r = alice.post("/v1/bakes", &long_bake(seed)).await;
        assert_eq!(r.status(), 202);
        mine.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    let r = alice.post("/v1/bakes", &long_bake(12)).await;
    assert_eq!(r.headers()["retry-after"], "5");
    let p = problem(r, 429).await;
    assert!(
        p["detail"].as_str().unwrap().contains("key 'alice' has 2"),
        "{p}"
    );
    // Asking again for a bake she holds is no new job; other keys have their own quota.
    assert_eq!(alice.post("/v1/bakes", &long_bake(10)).await.status(), 202);
    let r = bob.post("/v1/bakes", &long_bake(13)).await;
    assert_eq!(r.status(), 202);
    let theirs = r.headers()["location"].to_str().unwrap().to_string();
    let r = root.post("/v1/bakes", &long_bake(14)).await;
    assert_eq!(r.status(), 202);
    let admins = r.headers()["location"].to_str().unwrap().to_string();
    // A finished job frees its place.
    alice.delete(&mine[1]).await;
    assert_eq!(alice.post("/v1/bakes", &long_bake(12)).await.status(), 202);
    for (who, loc) in [(&alice, &mine[0]), (&bob, &theirs), (&root, &admins)] {
        who.delete(loc).await;
    }
    let r = alice.post("/v1/bakes", &long_bake(12)).await;
    root.delete(r.headers()["location"].to_str().unwrap()).await;
    srv.stop().await;
}

/// Keys take turns within a priority (fair queueing), instead of one key's backlog running
/// first: with one worker busy on alice's first bake and three more of hers queued, bob's
/// bake, queued after all of them, runs once her second has, not after her fourth.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn keys_take_turns_for_the_workers() {
    let srv = Server::start("keys-fair", |j, h| {
        h.keys = keys();
        j.cpu_workers = 1;
    })
    .await;
    let (alice, bob) = (As(&srv, ALICE), As(&srv, BOB));
    let state = |who: &'static str, loc: String| {
        let srv = &srv;
        async move {
            let key = if who == "alice" { ALICE } else { BOB };
            let v: serde_json::Value = As(srv, key).get(&loc).await.json().await.unwrap();
            v["state"].as_str().unwrap_or_default().to_string()
        }
    };
    let mut hers = Vec::new();
    for seed in 20..24 {
        let r = alice.post("/v1/bakes", &long_bake(seed)).await;
        assert_eq!(r.status(), 202);
        hers.push(r.headers()["location"].to_str().unwrap().to_string());
        if seed == 20 {
            // Her first holds the one worker before the rest are queued.
            poll(
                "alice's first bake to run",
                Duration::from_secs(60),
                || async { (state("alice", hers[0].clone()).await == "running").then_some(()) },
            )
            .await;
        }
    }
    let r = bob.post("/v1/bakes", &long_bake(30)).await;
    assert_eq!(r.status(), 202);
    let his = r.headers()["location"].to_str().unwrap().to_string();
    let runs = |who: &'static str, loc: String| {
        let state = &state;
        async move {
            poll(
                &format!("{loc} to run"),
                Duration::from_secs(60),
                || async { (state(who, loc.clone()).await == "running").then_some(()) },
            )
            .await
        }
    };
    // FIFO would run hers[1], hers[2], hers[3], then his.
    alice.delete(&hers[0]).await;
    runs("alice", hers[1].clone()).await;
    alice.delete(&hers[1]).await;
    runs("bob", his.clone()).await;
    assert_eq!(state("alice", hers[2].clone()).await, "queued");
    bob.delete(&his).await;
    runs("alice", hers[2].clone()).await;
    for loc in &hers[2..] {
        alice.delete(loc).await;
    }
    srv.stop().await;
}
