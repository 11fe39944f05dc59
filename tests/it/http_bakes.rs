//! Bake lifecycle on a real server: queued → running with rising progress → canceled by
//! DELETE (the worker really stops); idempotency by content and by `Idempotency-Key`; a small
//! bake succeeds and its artifact is a multi-layer EXR.

use crate::support::scenes::{self, long_bake, scene_sized};
use crate::support::server::*;
use std::time::Duration;

fn bake(scene: &serde_json::Value, photons: u64) -> serde_json::Value {
    serde_json::json!({
        "scene": scene, "object": "glass", "method": "reference",
        "params": {"photons": photons, "spp": 1, "width": 16, "height": 16},
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn progress_rises_and_delete_cancels_a_running_bake() {
    // One CPU worker: the render after the cancel can only run once the bake really stopped.
    let srv = Server::start("bake-cancel", |j, _| j.cpu_workers = 1).await;
    // Far more photons than the test will wait for (their estimate, ~3.8 GiB, within the
    // job memory of a machine with 8 GiB or more).
    let r = srv
        .post_json("/v1/bakes", &bake(&scene_sized(16, 16), 100_000_000))
        .await;
    assert_eq!(r.status(), 202);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let first = poll("progress > 0", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&loc).await;
        let p = v["progress"].as_f64().unwrap();
        (v["state"] == "running" && p > 0.0).then_some(p)
    })
    .await;
    poll("progress to rise", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&loc).await;
        assert_eq!(v["stage"], "photons", "{v}");
        (v["progress"].as_f64().unwrap() > first).then_some(())
    })
    .await;
    let r = srv.client.delete(srv.url(&loc)).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["state"], "canceled", "{v}");
    // The worker stopped: progress no longer moves, and a new job runs on the pool.
    let (_, a) = srv.get_json(&loc).await;
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                "photons": 2000, "spp": 1}),
        )
        .await;
    assert_eq!(r.status(), 200);
    let (_, b) = srv.get_json(&loc).await;
    assert_eq!(a["progress"], b["progress"]);
    assert_eq!(b["state"], "canceled");
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
        m.contains("caustica_jobs_total{kind=\"bake\",state=\"canceled\"} 1"),
        "{m}"
    );
    // The artifact of a canceled bake is a 409 problem.
    let r = srv
        .client
        .get(srv.url(&format!("{loc}/artifact")))
        .send()
        .await
        .unwrap();
    problem(r, 409).await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bakes_are_idempotent_and_their_artifact_is_a_layered_exr() {
    let srv = Server::start("bake-idem", |_, _| {}).await;
    let body = bake(&scene_sized(16, 16), 20_000);
    let r1 = srv.post_json("/v1/bakes", &body).await;
    assert_eq!(r1.status(), 202);
    let v1: serde_json::Value = r1.json().await.unwrap();
    // Same inputs, written differently (defaults spelled out): same job.
    let mut body2 = body.clone();
    body2["params"]["seed"] = 1.into();
    let v2: serde_json::Value = srv
        .post_json("/v1/bakes", &body2)
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(v1["id"], v2["id"]);
    // By scene id too.
    let mut body3 = body.clone();
    body3.as_object_mut().unwrap().remove("scene");
    body3["scene_id"] = v1["scene_id"].clone();
    let v3: serde_json::Value = srv
        .post_json("/v1/bakes", &body3)
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(v1["id"], v3["id"]);
    // Another seed: another job.
    let mut other = body.clone();
    other["params"]["seed"] = 2.into();
    let v4: serde_json::Value = srv
        .post_json("/v1/bakes", &other)
        .await
        .json()
        .await
        .unwrap();
    assert_ne!(v1["id"], v4["id"]);
    // Idempotency-Key: the first job it named, and a reuse for another request is refused.
    let send = |b: &serde_json::Value, key: &str| {
        srv.client
            .post(srv.url("/v1/bakes"))
            .header("idempotency-key", key)
            .json(b)
            .send()
    };
    let k1: serde_json::Value = send(&other, "key-1").await.unwrap().json().await.unwrap();
    assert_eq!(k1["id"], v4["id"]);
    let k2: serde_json::Value = send(&other, "key-1").await.unwrap().json().await.unwrap();
    assert_eq!(k2["id"], v4["id"]);
    let p = problem(send(&body, "key-1").await.unwrap(), 422).await;
    assert!(
        p["detail"].as_str().unwrap().contains("Idempotency-Key"),
        "{p}"
    );

    let id = v1["id"].as_str().unwrap();
    let done = srv.bake_succeeded(id, Duration::from_secs(120)).await;
    assert_eq!(done["progress"], 1.0);
    let stages: Vec<&str> = done["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["stage"].as_str().unwrap())
        .collect();
    assert_eq!(stages[0], "queue");
    assert!(
        stages.contains(&"photons") && stages.contains(&"encode"),
        "{stages:?}"
    );
    let r = srv.bake_artifact(id).await;
    assert_eq!(r.headers()["content-type"], "image/x-exr");
    let bytes = r.bytes().await.unwrap();
    use exr::prelude::{ReadChannels, ReadLayers};
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes.to_vec()))
        .unwrap();
    let names: Vec<String> = img
        .layer_data
        .iter()
        .map(|l| l.attributes.layer_name.as_ref().unwrap().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "total",
            "direct",
            "caustics",
            "specular",
            "indirect",
            "volume",
            "volume_caustics"
        ]
    );
    // Asking again after success: still the same job, no new work.
    let again: serde_json::Value = srv
        .post_json("/v1/bakes", &body)
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(again["state"], "succeeded");
    // A bad object and a bad param name the field.
    let mut bad = body.clone();
    bad["object"] = "nope".into();
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert_eq!(p["field"], "object", "{p}");
    let mut bad = body.clone();
    bad["params"]["photonz"] = 3.into();
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("photonz"), "{p}");
    assert_eq!(p["field"], "params.photonz", "{p}");
    // A method without a bake, and no method at all, are refused naming the field.
    for method in ["direct", "magic"] {
        let mut bad = body.clone();
        bad["method"] = method.into();
        let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
        assert_eq!(p["field"], "method", "{p}");
        let detail = p["detail"].as_str().unwrap();
        assert!(detail.contains("reference, csl, transport"), "{detail}");
    }
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_run_before_queued_bakes_and_a_canceled_bake_can_run_again() {
    let srv = Server::start("bake-priority", |j, _| j.cpu_workers = 1).await;
    let a = srv.post_json("/v1/bakes", &long_bake(1)).await;
    let a = a.headers()["location"].to_str().unwrap().to_string();
    poll("bake A to run", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&a).await;
        (v["state"] == "running").then_some(())
    })
    .await;
    // B (a bake) is queued before R (a render); R must still run first.
    let b = srv
        .post_json("/v1/bakes", &bake(&scene_sized(8, 8), 20_000))
        .await;
    let b = b.headers()["location"].to_str().unwrap().to_string();
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                "photons": 2000, "spp": 1, "wait": false}),
        )
        .await;
    assert_eq!(r.status(), 202);
    let r = r.headers()["location"].to_str().unwrap().to_string();
    let (_, v) = srv.get_json(&b).await;
    assert_eq!(v["state"], "queued");
    srv.client.delete(srv.url(&a)).send().await.unwrap();
    let rv = poll("the render", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&r).await;
        (v["state"] == "succeeded").then_some(v)
    })
    .await;
    let bv = poll("bake B", Duration::from_secs(120), || async {
        let (_, v) = srv.get_json(&b).await;
        (v["state"] == "succeeded").then_some(v)
    })
    .await;
    assert!(
        rv["started_at"].as_i64().unwrap() <= bv["started_at"].as_i64().unwrap(),
        "render {rv} / bake {bv}"
    );
    // Asking for the canceled bake again runs it again, under the same id.
    let again = srv.post_json("/v1/bakes", &long_bake(1)).await;
    assert_eq!(again.headers()["location"].to_str().unwrap(), a);
    let v: serde_json::Value = again.json().await.unwrap();
    assert!(
        ["queued", "running"].contains(&v["state"].as_str().unwrap()),
        "{v}"
    );
    assert_eq!(v["error"], serde_json::Value::Null);
    srv.client.delete(srv.url(&a)).send().await.unwrap();
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_puts_a_running_bake_back_in_the_queue_and_the_next_start_runs_it() {
    let srv = Server::start("bake-shutdown", |j, h| {
        j.cpu_workers = 1;
        h.shutdown_grace = Duration::ZERO;
    })
    .await;
    let dir = srv.dir.clone();
    let r = srv
        .post_json("/v1/bakes", &bake(&scene_sized(16, 16), 3_000_000))
        .await;
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    poll("the bake to run", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&loc).await;
        (v["state"] == "running").then_some(())
    })
    .await;
    // The data directory stays until the second server is done with it.
    let _cleanup = srv.stop().await;
    let srv = Server::start_in(dir, |_, _| {}).await;
    let (s, v) = srv.get_json(&loc).await;
    assert_eq!(s, 200);
    assert!(
        ["queued", "running"].contains(&v["state"].as_str().unwrap()),
        "{v}"
    );
    poll("the bake to complete", Duration::from_secs(300), || async {
        let (_, v) = srv.get_json(&loc).await;
        (v["state"] == "succeeded").then_some(())
    })
    .await;
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn long_bakes_do_not_block_renders() {
    let srv = Server::start("bake-busy", |j, _| j.cpu_workers = 2).await;
    let mut locs = Vec::new();
    for seed in [1, 2, 3] {
        let r = srv.post_json("/v1/bakes", &long_bake(seed)).await;
        locs.push(r.headers()["location"].to_str().unwrap().to_string());
    }
    // One on the worker that takes only bakes, one on the one that takes anything.
    for loc in &locs[..2] {
        poll("a bake to run", Duration::from_secs(60), || async {
            let (_, v) = srv.get_json(loc).await;
            (v["state"] == "running").then_some(())
        })
        .await;
    }
    // The third bake waits; the render does not.
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(8, 8), "method": "reference",
                                "photons": 2000, "spp": 1}),
        )
        .await;
    assert_eq!(r.status(), 200);
    let (_, v) = srv.get_json(&locs[2]).await;
    assert_eq!(v["state"], "queued");
    for l in &locs {
        srv.client.delete(srv.url(l)).send().await.unwrap();
    }
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn csl_bake_job_gives_the_library_bake_bytes() {
    use caustica::bake::csl::{CslParams, CslSet, bake_csl};
    let srv = Server::start("bake-csl", |_, _| {}).await;
    let scene = scene_sized(16, 16);
    let body = serde_json::json!({
        "scene": scene, "object": "glass", "method": "csl",
        "params": {"preset": "fast", "grid": 96},
    });
    let id = srv.submit_bake(&body).await;
    // Spelling out the default-filled parameters names the same job.
    let mut body2 = body.clone();
    body2["params"] = serde_json::json!({"grid": 96, "preset": "fast"});
    let v2: serde_json::Value = srv
        .post_json("/v1/bakes", &body2)
        .await
        .json()
        .await
        .unwrap();
    assert_eq!(v2["id"], id.as_str());
    let done = srv.bake_succeeded(&id, Duration::from_secs(120)).await;
    let stages: Vec<&str> = done["timings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["stage"].as_str().unwrap())
        .collect();
    assert!(
        stages.contains(&"bundles") && stages.contains(&"fit"),
        "{stages:?}"
    );
    let r = srv.bake_artifact(&id).await;
    let bytes = r.bytes().await.unwrap().to_vec();
    let set = CslSet::from_bytes(&bytes).expect("a valid CSL set");
    assert!(!set.csls.is_empty());
    // The same bake through the library: identical bytes (deterministic, same inputs).
    let world = scenes::parse(&scene.to_string());
    let light = world
        .object("glass")
        .unwrap()
        .to_rigid_frame(glam::Vec3::new(1.0, -1.2, 0.0).normalize());
    let params = CslParams {
        grid: 96,
        ..CslParams::fast()
    };
    let lib = tokio::task::spawn_blocking(move || {
        bake_csl(&world, "glass", light, &params, &|_| true)
            .unwrap()
            .to_bytes()
    })
    .await
    .unwrap();
    assert!(
        lib == bytes,
        "the service's artifact differs from the library bake"
    );

    // A scene without a directional light is refused with the field named.
    let mut point = scene.clone();
    point["lights"] = serde_json::json!([{"type": "point", "position": [0, 2, 0], "intensity": 5}]);
    let mut bad = body.clone();
    bad["scene"] = point;
    let r = srv.post_json("/v1/bakes", &bad).await;
    let p = problem(r, 422).await;
    assert!(
        p["detail"].as_str().unwrap().contains("directional light"),
        "{p}"
    );
}

/// A dynamic csl bake (`"dynamic": true`) is a job with progress per direction; its artifact
/// is the library's dynamic bake, and a `csl` render with the same parameters finds it (any
/// directional light: the set is interpolated). Dynamic-only fields without it are refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dynamic_csl_bake_job_serves_renders() {
    use caustica::bake::csl::CslParams;
    use caustica::bake::csl::dynamic::{DynamicParams, DynamicSet, bake_dynamic};
    let srv = Server::start("bake-csl-dynamic", |_, _| {}).await;
    let scene = scene_sized(16, 16);
    let csl = serde_json::json!({
        "preset": "fast", "grid": 48, "dynamic": true, "subdivisions": 0,
        "track_grid": 16, "steps": 2,
    });
    let body = serde_json::json!({
        "scene": scene, "object": "glass", "method": "csl", "params": csl,
    });
    let id = srv.submit_bake(&body).await;
    let done = srv.bake_succeeded(&id, Duration::from_secs(300)).await;
    let st = &done["info"]["statistics"];
    assert_eq!(st["directions"], 12, "{done}");
    assert_eq!(st["edges"], 30, "{done}");
    // Its fit: sets interpolated at face centres, checked against a short reference on the
    // scene's receivers.
    let fit = st["fit_error"].as_f64().expect("a fit");
    assert!(fit.is_finite() && fit >= 0.0, "{done}");
    assert_eq!(
        st["poor_fit"],
        fit > caustica::methods::csl::POOR_FIT,
        "{done}"
    );
    let r = srv.bake_artifact(&id).await;
    let bytes = r.bytes().await.unwrap().to_vec();
    let set = DynamicSet::from_bytes(&bytes).expect("a valid dynamic CSL set");
    assert_eq!(set.sets.len(), 12);
    let world = scenes::parse(&scene.to_string());
    let params = DynamicParams {
        subdivisions: 0,
        track_grid: 16,
        steps: 2,
        csl: CslParams {
            grid: 48,
            ..CslParams::fast()
        },
        ..DynamicParams::paper()
    };
    let lib = tokio::task::spawn_blocking(move || {
        bake_dynamic(&world, "glass", &params, &|_| true)
            .unwrap()
            .to_bytes()
    })
    .await
    .unwrap();
    assert!(
        lib == bytes,
        "the service's artifact differs from the library bake"
    );

    // A render with the same csl parameters finds the bake, whatever the light's direction.
    let mut turned = scene.clone();
    turned["lights"][0]["direction"] = serde_json::json!([0.3, -1.0, 0.4]);
    let req = serde_json::json!({
        "scene": turned, "method": "csl", "width": 16, "height": 16, "format": "exr",
        "component": "caustics", "csl": csl,
    });
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(
        rec["info"]["statistics"]["bakes"][0]["cached"], true,
        "{rec}"
    );

    // Dynamic-only fields without "dynamic" are refused, naming the field.
    let mut bad = body.clone();
    bad["params"] = serde_json::json!({"preset": "fast", "subdivisions": 1});
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("params.subdivisions"),
        "{p}"
    );
    let mut bad = body.clone();
    bad["params"]["subdivisions"] = serde_json::json!(7);
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert!(
        p["detail"]
            .as_str()
            .unwrap()
            .contains("params.subdivisions"),
        "{p}"
    );
    srv.stop().await;
}

/// A dynamic csl render served by sets interpolated from the dynamic bake queues the static
/// bake of its light direction (`info.refine` names it); once that bake is done, the next
/// render at that direction is served by it (`set: exact`), its frame byte for byte a static
/// csl render's at that light. `refine: false` queues nothing; `refine` on a render that is
/// not a dynamic csl one is refused, naming the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_dynamic_csl_render_queues_the_exact_bake_and_the_next_frame_uses_it() {
    let srv = Server::start("csl-refine", |_, _| {}).await;
    let mut scene = scene_sized(32, 32);
    scene["lights"][0]["direction"] = serde_json::json!([0.3, -1.0, 0.4]);
    let csl = serde_json::json!({
        "preset": "fast", "grid": 48, "dynamic": true, "subdivisions": 0,
        "track_grid": 16, "steps": 2,
    });
    let render = |extra: serde_json::Value| {
        let mut req = serde_json::json!({
            "scene": scene, "method": "csl", "width": 32, "height": 32, "csl": csl,
        });
        for (k, v) in extra.as_object().unwrap() {
            req[k] = v.clone();
        }
        let srv = &srv;
        async move {
            let r = srv.post_json("/v1/renders", &req).await;
            assert_eq!(r.status(), 200);
            let loc = r.headers()["location"].to_str().unwrap().to_string();
            let png = r.bytes().await.unwrap();
            let (_, rec) = srv.get_json(&loc).await;
            (rec, png)
        }
    };
    let set = |rec: &serde_json::Value| rec["info"]["statistics"]["bakes"][0]["set"].clone();

    // Told not to refine: interpolated, nothing queued.
    let (rec, _) = render(serde_json::json!({"refine": false})).await;
    assert_eq!(set(&rec), "interpolated", "{rec}");
    assert!(rec["info"].get("refine").is_none(), "{rec}");
    let (_, list) = srv.get_json("/v1/bakes").await;
    assert_eq!(list["items"], serde_json::json!([]), "{list}");

    // By default: interpolated, and the static bake of this direction queued.
    let (rec, _) = render(serde_json::json!({"format": "exr"})).await;
    assert_eq!(set(&rec), "interpolated", "{rec}");
    let bakes = rec["info"]["refine"]["bakes"]
        .as_array()
        .expect("bakes queued");
    assert_eq!(bakes.len(), 1, "{rec}");
    let bake = srv
        .bake_succeeded(bakes[0].as_str().unwrap(), Duration::from_secs(120))
        .await;
    assert_eq!(bake["method"], "csl", "{bake}");

    // The next frame at that direction is served by the static bake, and is a static csl
    // render's frame at that light.
    let (rec, exact) = render(serde_json::json!({})).await;
    assert_eq!(set(&rec), "exact", "{rec}");
    assert!(rec["info"].get("refine").is_none(), "{rec}");
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({
                "scene": scene, "method": "csl", "width": 32, "height": 32,
                "csl": {"preset": "fast", "grid": 48},
            }),
        )
        .await;
    assert_eq!(r.status(), 200);
    let fixed = r.bytes().await.unwrap();
    assert!(
        exact == fixed,
        "the refined frame is not the static render's"
    );

    // With the light given in the request, the bake's scene is the stored one with that
    // light, held by nobody (so swept once no job needs it), while the client's scene stays
    // held (the database read directly).
    let mut light = scene["lights"][0].clone();
    light["direction"] = serde_json::json!([-0.2, -1.0, 0.3]);
    let (rec, _) = render(serde_json::json!({ "lights": [light] })).await;
    assert_eq!(set(&rec), "interpolated", "{rec}");
    let id = rec["info"]["refine"]["bakes"][0]
        .as_str()
        .unwrap()
        .to_string();
    let bake = srv.bake_succeeded(&id, Duration::from_secs(120)).await;
    let db = rusqlite::Connection::open(srv.dir.join("caustica.sqlite3")).unwrap();
    let holds = |id: &serde_json::Value| -> i64 {
        db.query_row(
            "SELECT COUNT(*) FROM holds WHERE kind = 'scene' AND id = ?1",
            [id.as_str().unwrap()],
            |r| r.get(0),
        )
        .unwrap()
    };
    assert_ne!(bake["scene_id"], rec["scene_id"]);
    assert_eq!(holds(&bake["scene_id"]), 0, "{bake}");
    assert_eq!(holds(&rec["scene_id"]), 1, "{rec}");

    // `refine` only where it means something.
    let p = problem(
        srv.post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene, "method": "direct", "refine": true}),
        )
        .await,
        422,
    )
    .await;
    assert!(p["detail"].as_str().unwrap().contains("refine"), "{p}");
    srv.stop().await;
}

/// `method: transport` bakes the light transport table of a glass object: the artifact is the
/// library's bytes for the same parameters; an object without glass is refused naming it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn transport_bake_job_gives_the_library_bake_bytes() {
    use caustica::bake::transport::{TransportParams, TransportTable, bake_transport};
    let srv = Server::start("bake-transport", |_, _| {}).await;
    let mut scene = scene_sized(16, 16);
    scene["objects"][1]["shape"]["segments"] = 24.into();
    let body = serde_json::json!({
        "scene": scene, "object": "glass", "method": "transport",
        "params": {"rings": 4, "azimuths": 8},
    });
    let id = srv.submit_bake(&body).await;
    let done = srv.bake_succeeded(&id, Duration::from_secs(120)).await;
    assert_eq!(done["info"]["statistics"]["directions"], 33, "{done}");
    // The table's fit on the scene's receivers is in the record.
    let fit = done["info"]["statistics"]["fit_error"]
        .as_f64()
        .expect("a fit");
    assert!(fit.is_finite() && fit >= 0.0, "{done}");
    let r = srv.bake_artifact(&id).await;
    let bytes = r.bytes().await.unwrap().to_vec();
    TransportTable::from_bytes(&bytes).expect("a valid table");
    let world = scenes::parse(&scene.to_string());
    let lib = tokio::task::spawn_blocking(move || {
        let params = TransportParams {
            rings: 4,
            azimuths: 8,
            ..TransportParams::paper()
        };
        bake_transport(&world, "glass", &params, &|_| true)
            .unwrap()
            .to_bytes()
    })
    .await
    .unwrap();
    assert!(
        lib == bytes,
        "the service's artifact differs from the library bake"
    );

    // The floor has no glass; bad parameters name their field.
    let mut bad = body.clone();
    bad["object"] = "floor".into();
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("glass"), "{p}");
    let mut bad = body.clone();
    bad["params"] = serde_json::json!({"rings": 0});
    let p = problem(srv.post_json("/v1/bakes", &bad).await, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("rings"), "{p}");
    // A table that would not fit in memory is refused before any tracing, with its sizes.
    let mut big = body.clone();
    big["scene"]["objects"][1]["shape"]["segments"] = 96.into();
    big["params"] = serde_json::json!({"rings": 64, "azimuths": 256});
    let p = problem(srv.post_json("/v1/bakes", &big).await, 422).await;
    let detail = p["detail"].as_str().unwrap();
    assert!(
        detail.contains("16385 sampling directions") && detail.contains("table samples"),
        "{p}"
    );
    srv.stop().await;
}
