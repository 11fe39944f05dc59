//! The HTTP layer under hostile clients (issue: hardening): slow and silent connections are
//! closed, a body that never arrives gets a 408, the connection cap sheds load with 503 while
//! `/healthz` keeps answering, oversized heads and hostile JSON shapes get problem+json.

use crate::support::scenes::scene_sized;
use crate::support::server::*;
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

fn addr(srv: &Server) -> String {
    srv.base.trim_start_matches("http://").to_string()
}

/// Everything the server sends until it closes the connection, at most `limit` to wait.
async fn read_to_close(s: &mut TcpStream, limit: Duration) -> Vec<u8> {
    let mut out = Vec::new();
    tokio::time::timeout(limit, s.read_to_end(&mut out))
        .await
        .expect("the server closes the connection in time")
        .ok();
    out
}

/// One request on a fresh connection, answered in full (`connection: close`).
async fn raw(srv: &Server, request: &str) -> String {
    let mut s = TcpStream::connect(addr(srv)).await.unwrap();
    s.write_all(request.as_bytes()).await.unwrap();
    String::from_utf8_lossy(&read_to_close(&mut s, Duration::from_secs(30)).await).into_owned()
}

/// Slowloris: connections that drip a request head byte by byte are closed after the
/// header-read timeout, and `/healthz` answers all the while.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn slow_connections_are_closed_and_healthz_answers() {
    let srv = Server::start("limits-slow", |_, h| {
        h.header_timeout = Duration::from_secs(1);
    })
    .await;
    let mut slow = Vec::new();
    for _ in 0..50 {
        let mut s = TcpStream::connect(addr(&srv)).await.unwrap();
        s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            .await
            .unwrap();
        slow.push(s);
    }
    let t = Instant::now();
    let mut closed = vec![false; slow.len()];
    let mut worst = Duration::ZERO;
    while closed.iter().any(|c| !c) {
        assert!(
            t.elapsed() < Duration::from_secs(20),
            "slow connections still open after 20 s"
        );
        // Another byte of header from every slow client (the attack itself, not a wait).
        for (s, c) in slow.iter_mut().zip(closed.iter_mut()) {
            if !*c && s.write_all(b"X").await.is_err() {
                *c = true;
            }
            if !*c {
                let mut b = [0u8; 512];
                if let Ok(r) = tokio::time::timeout(Duration::from_millis(5), s.read(&mut b)).await
                {
                    // EOF or the server's answer to the timeout: either way it is ending.
                    if matches!(r, Ok(0) | Err(_)) {
                        *c = true;
                    }
                }
            }
        }
        let h = Instant::now();
        let (status, v) = srv.get_json("/healthz").await;
        worst = worst.max(h.elapsed());
        assert_eq!((status, &v["status"]), (200, &"ok".into()));
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    eprintln!(
        "50 slow connections closed after {:?}; worst /healthz {:?}",
        t.elapsed(),
        worst
    );
    assert!(
        t.elapsed() >= Duration::from_millis(900),
        "closed before the timeout"
    );
}

/// A body that promises more bytes than it sends gets a 408 problem once the body timeout
/// passes, and the connection is closed.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_body_that_never_arrives_gets_408() {
    let srv = Server::start("limits-body", |_, h| {
        h.body_timeout = Duration::from_secs(1);
    })
    .await;
    let mut s = TcpStream::connect(addr(&srv)).await.unwrap();
    s.write_all(
        b"POST /v1/renders HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
          Content-Length: 1000\r\n\r\n{\"scene\":",
    )
    .await
    .unwrap();
    let t = Instant::now();
    let out =
        String::from_utf8_lossy(&read_to_close(&mut s, Duration::from_secs(20)).await).into_owned();
    assert!(out.starts_with("HTTP/1.1 408"), "{out}");
    assert!(out.contains("application/problem+json"), "{out}");
    assert!(out.contains("did not arrive within 1 s"), "{out}");
    assert!(t.elapsed() >= Duration::from_millis(900));
}

/// Past the connection cap, new connections are shed: `/healthz` still answers, everything
/// else gets 503 problem+json with Retry-After; a freed slot serves again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn past_the_connection_cap_load_is_shed_but_healthz_answers() {
    let srv = Server::start("limits-cap", |_, h| {
        h.max_connections = 4;
        h.header_timeout = Duration::from_secs(60);
    })
    .await;
    // Four keep-alive connections, each known to be served (a shed one could answer only
    // /healthz, and would close).
    let mut held = Vec::new();
    for _ in 0..4 {
        let mut s = TcpStream::connect(addr(&srv)).await.unwrap();
        s.write_all(b"GET /openapi.json HTTP/1.1\r\nHost: x\r\n\r\n")
            .await
            .unwrap();
        let mut b = [0u8; 512];
        let n = s.read(&mut b).await.unwrap();
        assert!(b[..n].starts_with(b"HTTP/1.1 200"));
        held.push(s);
    }
    let health = raw(&srv, "GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n").await;
    assert!(health.starts_with("HTTP/1.1 200"), "{health}");
    assert!(health.contains("\"status\":\"ok\""), "{health}");
    let c = reqwest::Client::builder().build().unwrap();
    let r = c
        .post(srv.url("/v1/renders"))
        .json(&serde_json::json!({"scene": scene_sized(8, 8)}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.headers()["retry-after"], "1");
    let p = problem(r, 503).await;
    assert!(p["type"].as_str().unwrap().ends_with("/overloaded"), "{p}");
    drop(held.pop());
    poll("a slot to free", Duration::from_secs(10), || async {
        let r = c.get(srv.url("/openapi.json")).send().await.ok()?;
        (r.status() == 200).then_some(())
    })
    .await;
}

/// Past the cap and with every half-second shedding slot taken (a flood of silent sockets;
/// here none are configured), a probe that sends its request as it connects is still answered
/// within the quick slots' 50 ms.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_the_shedding_slots_taken_healthz_still_answers() {
    let srv = Server::start("limits-quick", |_, h| {
        h.max_connections = 1;
        h.shed_slots = 0;
        h.header_timeout = Duration::from_secs(60);
    })
    .await;
    let mut held = TcpStream::connect(addr(&srv)).await.unwrap();
    held.write_all(b"GET /openapi.json HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    let mut b = [0u8; 512];
    let n = held.read(&mut b).await.unwrap();
    assert!(b[..n].starts_with(b"HTTP/1.1 200"));
    // Retried: a loaded test machine may take longer than 50 ms to send a request; without
    // the quick slots no probe is ever answered.
    let health = poll("/healthz to answer", Duration::from_secs(20), || async {
        let mut s = TcpStream::connect(addr(&srv)).await.ok()?;
        s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
            .await
            .ok()?;
        let out = read_to_close(&mut s, Duration::from_secs(5)).await;
        let out = String::from_utf8_lossy(&out).into_owned();
        out.starts_with("HTTP/1.1 200").then_some(out)
    })
    .await;
    assert!(health.contains("\"status\":\"ok\""), "{health}");
    let out = raw(&srv, "GET /openapi.json HTTP/1.1\r\nHost: x\r\n\r\n").await;
    assert!(out.starts_with("HTTP/1.1 503"), "{out}");
    drop(held);
}

/// A body refused from its head alone (413) still reaches a client that sends its whole body
/// before reading the answer (as most clients do): the server's close lingers, reading and
/// dropping what comes, instead of resetting the connection with the client's bytes unread
/// (which made the client's write fail and lose the answer).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_body_refused_from_its_head_still_gets_its_answer() {
    let srv = Server::start("limits-linger", |_, _| {}).await;
    let body = vec![b' '; 9 << 20];
    for _ in 0..3 {
        let mut s = TcpStream::connect(addr(&srv)).await.unwrap();
        let head = format!(
            "POST /v1/renders HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
             Content-Length: {}\r\n\r\n",
            body.len()
        );
        s.write_all(head.as_bytes()).await.unwrap();
        let sent = s.write_all(&body).await;
        assert!(sent.is_ok(), "the server reset the connection: {sent:?}");
        let mut out = Vec::new();
        let r = tokio::time::timeout(Duration::from_secs(30), s.read_to_end(&mut out))
            .await
            .expect("the server closes in time");
        let out = String::from_utf8_lossy(&out).into_owned();
        assert!(r.is_ok(), "the connection was reset ({r:?}) after: {out}");
        assert!(out.starts_with("HTTP/1.1 413"), "{out}");
        assert!(out.contains("limit of 8388608 bytes"), "{out}");
    }
}

/// Request heads past the server's limits get problem+json, not hyper's empty answers.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_heads_get_problems() {
    let srv = Server::start("limits-head", |_, _| {}).await;
    let long = format!("/v1/scenes/{}", "a".repeat(9000));
    let r = srv.client.get(srv.url(&long)).send().await.unwrap();
    let p = problem(r, 414).await;
    assert!(
        p["detail"].as_str().unwrap().contains("limit is 8192"),
        "{p}"
    );
    let mut req = srv.client.get(srv.url("/healthz"));
    for i in 0..120 {
        req = req.header(format!("x-h{i}"), "v");
    }
    let p = problem(req.send().await.unwrap(), 431).await;
    assert!(p["detail"].as_str().unwrap().contains("100 fields"), "{p}");
}

/// What hyper refuses before any handler runs (a request line or header it cannot parse, more
/// header fields than it reads, a head larger than its buffer) is answered with hyper's status
/// and a problem+json body, and the server goes on serving.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn heads_hyper_cannot_parse_get_problems() {
    let srv = Server::start("limits-parse", |_, _| {}).await;
    let many: String = (0..300).map(|i| format!("x-h{i}: v\r\n")).collect();
    // Past hyper's ~400 KB buffer: answered while the rest still arrives (the close lingers).
    let huge = format!("x-big: {}\r\n", "a".repeat(600 << 10));
    for (request, status, kind) in [
        (
            "NOT HTTP AT ALL\r\n\r\n".to_string(),
            400,
            "malformed-request",
        ),
        (
            "GET /healthz HTTP/1.1\r\nHost: x\r\nbad header\r\n\r\n".into(),
            400,
            "malformed-request",
        ),
        (
            format!("GET /healthz HTTP/1.1\r\nHost: x\r\n{many}\r\n"),
            431,
            "headers-too-large",
        ),
        (
            format!("GET /healthz HTTP/1.1\r\nHost: x\r\n{huge}\r\n"),
            431,
            "headers-too-large",
        ),
    ] {
        let out = raw(&srv, &request).await;
        let what = &request[..request.len().min(40)];
        assert!(
            out.starts_with(&format!("HTTP/1.1 {status} ")),
            "{what:?}: {out}"
        );
        let (head, body) = out.split_once("\r\n\r\n").expect("a head and a body");
        assert!(
            head.contains("content-type: application/problem+json"),
            "{head}"
        );
        let p: serde_json::Value = serde_json::from_str(body).expect("a JSON problem");
        assert_eq!(p["status"], status, "{p}");
        assert!(p["type"].as_str().unwrap().ends_with(kind), "{p}");
        assert!(!p["detail"].as_str().unwrap().is_empty(), "{p}");
    }
    let (status, v) = srv.get_json("/healthz").await;
    assert_eq!((status, &v["status"]), (200, &"ok".into()));
}

/// A JSON body of a hostile shape (the million lights, scaled to fit the JSON body
/// limit) is refused at the first item past the limit, naming it; a body over the JSON limit
/// is refused unread.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_json_shapes_are_refused_before_they_are_built() {
    let srv = Server::start("limits-json", |_, _| {}).await;
    let light = serde_json::json!({"type": "point", "position": [0, 1, 0], "intensity": [1, 1, 1]});
    let body = serde_json::json!({
        "scene": scene_sized(8, 8),
        "lights": vec![light; 20_000],
    });
    let p = problem(srv.post_json("/v1/renders", &body).await, 422).await;
    assert_eq!(p["field"], "lights[10000]", "{p}");
    let mut scene = scene_sized(8, 8);
    scene["objects"] = serde_json::Value::Array(vec![scene["objects"][0].clone(); 10_001]);
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .header("content-type", "application/json")
        .body(serde_json::to_vec(&scene).unwrap())
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    assert_eq!(p["field"], "objects[10000]", "{p}");
    // 9 MiB of JSON announced: refused from the head alone, before a byte of it is read.
    let out = raw(
        &srv,
        "POST /v1/renders HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
         Content-Length: 9437184\r\n\r\n",
    )
    .await;
    assert!(out.starts_with("HTTP/1.1 413"), "{out}");
    assert!(out.contains("limit of 8388608 bytes"), "{out}");
}

/// Request bodies held at once are bounded by the bytes they sent: while one client's body
/// holds most of the budget (900 KiB sent of a declared MiB, then silence), an upload that
/// declares more than is left gets 503 busy with Retry-After at once; once the first is
/// answered (408), uploads go through again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn request_bodies_in_flight_are_bounded() {
    let srv = Server::start("limits-bodies", |_, h| {
        h.max_body_bytes_in_flight = 1 << 20;
        h.body_timeout = Duration::from_secs(5);
    })
    .await;
    let mut hog = TcpStream::connect(addr(&srv)).await.unwrap();
    hog.write_all(
        b"POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/gltf-binary\r\n\
          Content-Length: 1048576\r\n\r\nglTF",
    )
    .await
    .unwrap();
    hog.write_all(&vec![0u8; 900 << 10]).await.unwrap();
    // An upload declaring 200 KiB: refused at once while the hog's bytes hold the budget
    // (answered within a second), admitted otherwise (then dropped unanswered).
    let big = || async {
        let mut s = TcpStream::connect(addr(&srv)).await.unwrap();
        s.write_all(
            b"POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: model/gltf-binary\r\n\
              Content-Length: 204800\r\n\r\n",
        )
        .await
        .unwrap();
        let out = tokio::time::timeout(Duration::from_secs(1), async {
            let mut out = Vec::new();
            let _ = s.read_to_end(&mut out).await;
            out
        })
        .await
        .ok()?;
        Some(String::from_utf8_lossy(&out).into_owned())
    };
    let busy = poll(
        "the hog's bytes to hold the budget",
        Duration::from_secs(10),
        || async { big().await.filter(|out| out.starts_with("HTTP/1.1 503")) },
    )
    .await;
    assert!(
        busy.to_ascii_lowercase().contains("retry-after: 1"),
        "{busy}"
    );
    assert!(busy.contains("request bytes"), "{busy}");
    let out = String::from_utf8_lossy(&read_to_close(&mut hog, Duration::from_secs(20)).await)
        .into_owned();
    assert!(out.starts_with("HTTP/1.1 408"), "{out}");
    let upload = || async {
        srv.client
            .post(srv.url("/v1/scenes"))
            .header("content-type", "application/json")
            .body(serde_json::to_vec(&scene_sized(8, 8)).unwrap())
            .send()
            .await
            .unwrap()
    };
    poll(
        "uploads to go through again",
        Duration::from_secs(10),
        || async { (upload().await.status() == 201).then_some(()) },
    )
    .await;
}
