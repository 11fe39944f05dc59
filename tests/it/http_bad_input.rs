//! Bad input over HTTP: every file of the malformed glTF corpus POSTed as a scene gets a 4xx
//! problem+json within seconds and the server keeps serving; an oversized body gets 413, a
//! bogus content type 415, a scene with a bad field 422 naming it; hostile uploads beyond
//! the corpus (external URIs, huge declared sizes, deep JSON, bad multipart) too.

use crate::support::scenes::{SCENE, long_bake, scene_sized};
use crate::support::server::*;
use crate::support::{files_under, repo_path};
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

async fn healthy(srv: &Server) {
    let (s, v) = srv.get_json("/healthz").await;
    assert_eq!((s, v["status"].as_str()), (200, Some("ok")));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_malformed_corpus_gets_problems_and_the_server_keeps_serving() {
    let srv = Server::start("corpus", |_, _| {}).await;
    let root = repo_path("tests/data/gltf-bad");
    let mut files = files_under(&root);
    files.sort();
    assert!(files.len() >= 50);
    let mut accepted = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&root).unwrap().display().to_string();
        let ct = if rel.ends_with(".glb") {
            "model/gltf-binary"
        } else {
            "model/gltf+json"
        };
        let t = Instant::now();
        let r = srv
            .client
            .post(srv.url("/v1/scenes"))
            .header("content-type", ct)
            .body(std::fs::read(f).unwrap())
            .send()
            .await
            .unwrap();
        let status = r.status().as_u16();
        let ctype = r.headers()["content-type"].to_str().unwrap().to_string();
        let body: serde_json::Value = r.json().await.unwrap();
        assert!(
            t.elapsed() < Duration::from_secs(5),
            "{rel}: {:?}",
            t.elapsed()
        );
        if status == 201 {
            // Accepted: the importer clamps out-of-range values and says so.
            assert!(
                !body["warnings"].as_array().unwrap().is_empty(),
                "{rel}: {body}"
            );
            accepted.push(rel);
        } else {
            assert!((400..500).contains(&status), "{rel}: {status} {body}");
            assert_eq!(ctype, "application/problem+json", "{rel}");
            let detail = body["detail"].as_str().unwrap();
            assert!(!detail.is_empty(), "{rel}");
        }
        healthy(&srv).await;
    }
    println!("accepted with warnings: {accepted:?}");
    // One file of the corpus is a usable triangle (only an accessor `max` of the wrong arity,
    // which the importer ignores): it is accepted with warnings about the added camera and light.
    assert_eq!(accepted, ["gltf-rs/minimal_accessor_invalid.gltf"]);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn limits_media_types_and_fields() {
    let srv = Server::start("bad-input", |_, h| h.max_body = 1 << 20).await;
    // Declared oversize body: refused before it is read.
    let addr = srv.base.strip_prefix("http://").unwrap().to_string();
    let mut s = tokio::net::TcpStream::connect(&addr).await.unwrap();
    s.write_all(
        b"POST /v1/scenes HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n\
          Content-Length: 1000000000\r\n\r\n{",
    )
    .await
    .unwrap();
    let mut buf = vec![0u8; 4096];
    let n = s.read(&mut buf).await.unwrap();
    let head = String::from_utf8_lossy(&buf[..n]).to_string();
    assert!(head.starts_with("HTTP/1.1 413"), "{head}");
    assert!(head.contains("application/problem+json"), "{head}");
    assert!(head.contains("1048576"), "the limit is named: {head}");
    assert!(
        head.to_ascii_lowercase().contains("connection: close"),
        "{head}"
    );
    // Streamed (chunked) oversize body.
    let big = vec![b' '; 2 << 20];
    let stream = futures_util::stream::iter(
        big.chunks(64 << 10)
            .map(|c| Ok::<_, std::io::Error>(c.to_vec()))
            .collect::<Vec<_>>(),
    );
    // A client of its own: the answer comes while the body is still being written, and that
    // connection must not be the one the next request of the shared pool picks up.
    let r = client()
        .post(srv.url("/v1/scenes"))
        .header("content-type", "application/json")
        .body(reqwest::Body::wrap_stream(stream))
        .send()
        .await;
    if let Ok(r) = r {
        let close = r
            .headers()
            .get("connection")
            .map(|v| v.to_str().unwrap().to_string());
        problem(r, 413).await;
        assert_eq!(
            close.as_deref(),
            Some("close"),
            "a 413 closes the connection"
        );
    }
    healthy(&srv).await;

    // Content types.
    for ct in ["text/plain", "image/png", ""] {
        let mut rb = srv.client.post(srv.url("/v1/scenes")).body(SCENE);
        if !ct.is_empty() {
            rb = rb.header("content-type", ct);
        }
        problem(rb.send().await.unwrap(), 415).await;
    }
    let r = srv
        .client
        .post(srv.url("/v1/renders"))
        .header("content-type", "text/plain")
        .body("{}")
        .send()
        .await
        .unwrap();
    problem(r, 415).await;

    // Bad fields are named.
    let post = |body: String| {
        srv.client
            .post(srv.url("/v1/scenes"))
            .header("content-type", "application/json")
            .body(body)
            .send()
    };
    let p = problem(
        post(SCENE.replace("\"radius\": 0.5", "\"radius\": -1"))
            .await
            .unwrap(),
        422,
    )
    .await;
    assert_eq!(p["field"], "objects[1].shape.radius", "{p}");
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("objects[1].shape.radius"),
        "{p}"
    );
    let p = problem(
        post(SCENE.replace("\"fov_y\": 40", "\"fov_y\": 40, \"zoom\": 2"))
            .await
            .unwrap(),
        422,
    )
    .await;
    assert!(p["detail"].as_str().unwrap().contains("zoom"), "{p}");
    let p = problem(
        post(SCENE.replace("\"width\": 256", "\"width\": 100000"))
            .await
            .unwrap(),
        422,
    )
    .await;
    assert_eq!(p["field"], "camera.width", "{p}");
    // Not JSON at all: 400, as on every other route (valid JSON of the wrong shape is 422).
    let p = problem(post("{\"camera\": ".into()).await.unwrap(), 400).await;
    assert!(
        p["detail"].as_str().unwrap().contains("not valid JSON"),
        "{p}"
    );
    // Deeply nested JSON: an error, not a stack overflow.
    problem(post("[".repeat(100_000)).await.unwrap(), 422).await;
    let r = srv
        .client
        .post(srv.url("/v1/renders"))
        .header("content-type", "application/json")
        .body("{\"scene\": ")
        .send()
        .await
        .unwrap();
    problem(r, 400).await;
    // Render fields.
    let p = problem(
        srv.post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "width": 0}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "width", "{p}");
    // Past the service's image cap (memory: a reference frame is ~100 bytes a pixel).
    let p = problem(
        srv.post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "width": 5000}),
        )
        .await,
        422,
    )
    .await;
    assert!(p["detail"].as_str().unwrap().contains("4096"), "{p}");
    let p = problem(
        srv.post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "magic"}),
        )
        .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "method", "{p}");
    // Method parameters: pinhole's point count, strategy and sun radius.
    for (pinhole, field, needle) in [
        (serde_json::json!({"samples": 0}), "pinhole.samples", "1"),
        (
            serde_json::json!({"samples": 1_000_000_000}),
            "pinhole.samples",
            "100000",
        ),
        (
            serde_json::json!({"sampling": "hexagonal"}),
            "pinhole",
            "hexagonal",
        ),
        (
            serde_json::json!({"sun_radius": 90}),
            "pinhole.sun_radius",
            "degrees",
        ),
    ] {
        let p = problem(
            srv.post_json(
                "/v1/renders",
                &serde_json::json!({"scene": scene_sized(8, 8), "method": "pinhole", "pinhole": pinhole}),
            )
            .await,
            422,
        )
        .await;
        assert!(
            p["field"].as_str().unwrap().starts_with(field)
                && p["detail"].as_str().unwrap().contains(needle),
            "{pinhole}: {p}"
        );
    }
    let mut bad = scene_sized(8, 8);
    bad["lights"][0]["irradiance"] = serde_json::json!([1, -2, 3]);
    let p = problem(
        srv.post_json("/v1/renders", &serde_json::json!({"scene": bad}))
            .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "scene.lights[0].irradiance", "{p}");
    let p = problem(
        srv.post_json("/v1/renders", &serde_json::json!({"scene": "0".repeat(64)}))
            .await,
        422,
    )
    .await;
    assert_eq!(p["field"], "scene", "{p}");
    // Unknown ids and routes.
    problem(
        srv.client
            .get(srv.url("/v1/scenes/nope"))
            .send()
            .await
            .unwrap(),
        404,
    )
    .await;
    problem(
        srv.client
            .get(srv.url("/v1/bakes/bk_0123"))
            .send()
            .await
            .unwrap(),
        404,
    )
    .await;
    problem(
        srv.client
            .get(srv.url("/v2/anything"))
            .send()
            .await
            .unwrap(),
        404,
    )
    .await;
    problem(
        srv.client.put(srv.url("/v1/scenes")).send().await.unwrap(),
        405,
    )
    .await;

    // glTF naming an external file or a file: URI: refused, nothing read from disk.
    let gltf = r#"{"asset": {"version": "2.0"}, "buffers": [{"uri": "file:///etc/passwd", "byteLength": 10}]}"#;
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .header("content-type", "model/gltf+json")
        .body(gltf)
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("refused"), "{p}");
    // Multipart: the scene names a file that was not uploaded; then one that was.
    let mut with_gltf: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    with_gltf["objects"][1]["shape"] = serde_json::json!({"type": "gltf", "path": "box.glb"});
    let form = reqwest::multipart::Form::new().text("scene", with_gltf.to_string());
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    let p = problem(r, 422).await;
    assert_eq!(p["field"], "objects[1].shape.path", "{p}");
    assert!(p["detail"].as_str().unwrap().contains("box.glb"), "{p}");
    let glb = std::fs::read(repo_path("scenes/assets/Box.glb")).unwrap();
    let form = reqwest::multipart::Form::new()
        .text("scene", with_gltf.to_string())
        .part(
            "box.glb",
            reqwest::multipart::Part::bytes(glb.clone()).file_name("whatever.glb"),
        );
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["files"], serde_json::json!(["box.glb"]));
    assert!(v["objects"][1]["triangles"].as_u64().unwrap() > 0);
    // Same bytes: same id.
    let form = reqwest::multipart::Form::new()
        .text("scene", with_gltf.to_string())
        .part("box.glb", reqwest::multipart::Part::bytes(glb.clone()));
    let v2: serde_json::Value = srv
        .client
        .post(srv.url("/v1/scenes"))
        .multipart(form)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(v["id"], v2["id"]);
    // A GLB as a whole scene: default camera and light, with warnings.
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .header("content-type", "model/gltf-binary")
        .body(glb)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["objects"][0]["name"], "model");
    assert_eq!(v["warnings"].as_array().unwrap().len(), 2, "{v}");
    let (s, got) = srv
        .get_json(&format!("/v1/scenes/{}", v["id"].as_str().unwrap()))
        .await;
    assert_eq!(s, 200);
    assert_eq!(got["id"], v["id"]);
    // Multipart without a scene part.
    let form = reqwest::multipart::Form::new().text("other", "x");
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .multipart(form)
        .send()
        .await
        .unwrap();
    assert_eq!(problem(r, 422).await["field"], "scene");
    healthy(&srv).await;
    srv.stop().await;
}

/// Extreme finite values: a glass sphere of radius 3·10³⁸ (a `reference` render of it made the
/// photon tracer run on for ever) and one scaled by 10³⁰ (a `csl` bake of it panicked, index
/// out of bounds) are refused with 422 naming the world's extent, before any job is queued;
/// a light or camera that far is refused too, and so is an object too small to trace.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_scene_beyond_the_worlds_extent_gets_422() {
    let srv = Server::start("bad-extent", |_, _| {}).await;
    let mut huge = scene_sized(16, 16);
    huge["objects"][1]["shape"]["radius"] = 3e38.into();
    let mut scaled = scene_sized(16, 16);
    scaled["objects"][1]["transform"] = serde_json::json!({"scale": 1e30});
    let mut far_light = scene_sized(16, 16);
    far_light["lights"] =
        serde_json::json!([{"type": "point", "position": [0, 1e6, 0], "intensity": 1}]);
    let mut far_eye = scene_sized(16, 16);
    far_eye["camera"]["eye"] = serde_json::json!([0, 0, 2e5]);
    // Found by the property test (`http_props`): a sphere of 10⁻¹² m, whose triangles
    // collapse onto one point, made the BVH builder panic.
    let mut tiny = scene_sized(16, 16);
    tiny["objects"][1]["shape"]["radius"] = 1e-6.into();
    tiny["objects"][1]["transform"] =
        serde_json::json!({"scale": 1e-6, "translation": [1.7, 0, 1.4]});
    for (scene, field, what) in [
        (
            &huge,
            "objects",
            "object 'glass' reaches beyond the world's extent",
        ),
        (
            &scaled,
            "objects",
            "object 'glass' reaches beyond the world's extent",
        ),
        (
            &far_light,
            "lights[0]",
            "the light reaches beyond the world's extent",
        ),
        (
            &far_eye,
            "camera.eye",
            "the camera reaches beyond the world's extent",
        ),
        (&tiny, "objects", "too small to trace"),
    ] {
        let body = serde_json::json!({"scene": scene, "method": "reference", "photons": 10000, "wait": false});
        let p = problem(srv.post_json("/v1/renders", &body).await, 422).await;
        assert_eq!(p["field"], format!("scene.{field}"), "{p}");
        let detail = p["detail"].as_str().unwrap();
        assert!(detail.contains(what), "{p}");
        let body = serde_json::json!({"scene": scene, "object": "glass", "method": "csl"});
        let p = problem(srv.post_json("/v1/bakes", &body).await, 422).await;
        assert_eq!(p["field"], format!("scene.{field}"), "{p}");
    }
    healthy(&srv).await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_full_queue_answers_429_with_retry_after() {
    let srv = Server::start("queue-full", |j, _| {
        j.max_queued_bakes = 1;
        j.cpu_workers = 1;
    })
    .await;
    // One running, one queued, the third refused.
    let a = srv.post_json("/v1/bakes", &long_bake(1)).await;
    assert_eq!(a.status(), 202);
    let a = a.headers()["location"].to_str().unwrap().to_string();
    poll("the first bake to run", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&a).await;
        (v["state"] == "running").then_some(())
    })
    .await;
    let b = srv.post_json("/v1/bakes", &long_bake(2)).await;
    assert_eq!(b.status(), 202);
    let b = b.headers()["location"].to_str().unwrap().to_string();
    let r = srv.post_json("/v1/bakes", &long_bake(3)).await;
    assert_eq!(r.headers()["retry-after"], "5");
    problem(r, 429).await;
    // Cancel a queued job: dropped at once.
    let v: serde_json::Value = srv
        .client
        .delete(srv.url(&b))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(v["state"], "canceled");
    let v: serde_json::Value = srv
        .client
        .delete(srv.url(&a))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(v["state"], "canceled");
    srv.stop().await;
}
