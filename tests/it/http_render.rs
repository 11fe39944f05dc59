//! `POST /v1/renders` end to end on a real server: the canonical scene rendered by the
//! reference at 64×64 gives the same image as the library call (so the caustic is where the
//! reference puts it), `direct` gives a PNG from the GPU worker, `pinhole` the library's
//! frame, and the record, image and `Server-Timing` say what happened.

use crate::support::scenes::{self, SCENE, scene_sized};
use crate::support::server::*;
use crate::support::{gpu, images};
use caustica::encode::{self, PngSettings};
use caustica::reference::{self, ReferenceParams};
use caustica::trace::Accel;
use std::time::Duration;

const PHOTONS: u64 = 50_000;

/// The same render through the library: components of the canonical scene at 64×64.
fn library_components() -> reference::Components {
    let mut w = scenes::parse(SCENE);
    w.camera.width = 64;
    w.camera.height = 64;
    let accel = Accel::build(&w);
    let p = ReferenceParams {
        photons: PHOTONS,
        spp: 1,
        seed: 7,
        ..Default::default()
    };
    reference::render(&w, &accel, &p, &|_| true).unwrap().0
}

fn brightest(img: &image::RgbImage) -> (u32, u32) {
    let mut best = (0, 0, 0u32);
    for (x, y, p) in img.enumerate_pixels() {
        let s = p.0.iter().map(|&c| u32::from(c)).sum::<u32>();
        if s > best.2 {
            best = (x, y, s);
        }
    }
    (best.0, best.1)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reference_render_matches_the_library_and_puts_the_caustic_there() {
    let srv = Server::start("render-ref", |_, _| {}).await;
    let scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    let req = |component: &str| {
        serde_json::json!({
            "scene": scene, "method": "reference", "width": 64, "height": 64,
            "format": "png", "photons": PHOTONS, "spp": 1, "seed": 7, "component": component,
        })
    };
    let r = srv.post_json("/v1/renders", &req("total")).await;
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/png");
    let timing = r.headers()["server-timing"].to_str().unwrap().to_string();
    for stage in [
        "accept", "queue", "bvh", "photons", "camera", "encode", "store", "respond", "request",
    ] {
        assert!(timing.contains(&format!("{stage};dur=")), "{timing}");
    }
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    assert!(loc.starts_with("/v1/renders/rn_"), "{loc}");
    let png = r.bytes().await.unwrap();
    let got = image::load_from_memory(&png).unwrap().to_rgb8();
    assert_eq!(got.dimensions(), (64, 64));

    // Same numbers as the library (the reference is deterministic for a seed).
    let c = tokio::task::spawn_blocking(library_components)
        .await
        .unwrap();
    let want = encode::encode_png(&c.total(), PngSettings::default()).unwrap();
    let want = image::load_from_memory(&want).unwrap().to_rgb8();
    let diff = got
        .pixels()
        .zip(want.pixels())
        .map(|(a, b)| {
            (0..3)
                .map(|k| a.0[k].abs_diff(b.0[k]) as u32)
                .max()
                .unwrap()
        })
        .max()
        .unwrap();
    assert!(diff <= 1, "PNG differs from the library render by {diff}");

    // The caustic: the brightest pixel of the caustics component, same place.
    let r = srv.post_json("/v1/renders", &req("caustics")).await;
    assert_eq!(r.status(), 200);
    let caustic = image::load_from_memory(&r.bytes().await.unwrap())
        .unwrap()
        .to_rgb8();
    let lib = encode::encode_png(&c.caustics, PngSettings::default()).unwrap();
    let lib = image::load_from_memory(&lib).unwrap().to_rgb8();
    let (x, y) = brightest(&lib);
    assert_eq!(brightest(&caustic), (x, y));
    // It is a caustic: brighter there than the lit floor around it in the total image.
    let floor = got.get_pixel(2, 60).0[0];
    assert!(
        got.get_pixel(x, y).0[0] > floor,
        "caustic at {x},{y} not above the floor"
    );

    // The record.
    let (s, rec) = srv.get_json(&loc).await;
    assert_eq!(s, 200);
    assert_eq!(rec["state"], "succeeded");
    assert_eq!(rec["method"], "reference");
    assert_eq!(rec["info"]["width"], 64);
    assert!(
        rec["info"]["statistics"]["photons_traced"]
            .as_u64()
            .unwrap()
            >= PHOTONS
    );
    assert!(rec["timings"].as_array().unwrap().len() >= 4, "{rec}");
    let img = srv
        .client
        .get(srv.url(&format!("{loc}/image")))
        .send()
        .await
        .unwrap();
    assert_eq!(img.status(), 200);
    assert_eq!(img.bytes().await.unwrap(), png);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn direct_render_gives_a_png_and_exr_from_the_gpu_worker() {
    let srv = Server::start("render-direct", |_, _| {}).await;
    // Stored scene, then rendered by id.
    let r = srv
        .client
        .post(srv.url("/v1/scenes"))
        .header("content-type", "application/json")
        .body(SCENE)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let info: serde_json::Value = r.json().await.unwrap();
    let id = info["id"].as_str().unwrap().to_string();
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": id, "method": "direct", "width": 33, "height": 17}),
        )
        .await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let timing = r.headers()["server-timing"].to_str().unwrap().to_string();
    for stage in ["queue", "prepare", "readback", "encode"] {
        assert!(timing.contains(&format!("{stage};dur=")), "{timing}");
    }
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let img = image::load_from_memory(&r.bytes().await.unwrap())
        .unwrap()
        .to_rgb8();
    assert_eq!(img.dimensions(), (33, 17));
    // Lit floor: sRGB of 0.44 (clamp) is 176, as the CLI test.
    let p = img.get_pixel(1, 15).0[0];
    assert!((174..=178).contains(&p), "{p}");
    let (_, rec) = srv.get_json(&loc).await;
    assert!(!rec["info"]["adapter"].as_str().unwrap().is_empty());

    // EXR with layers.
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": id, "method": "direct", "width": 16, "height": 8,
                                "format": "exr", "layers": true}),
        )
        .await;
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/x-exr");
    let f = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert_eq!((f.width, f.height), (16, 8));

    // readyz once the probe ran.
    let ready = poll("readyz", Duration::from_secs(60), || async {
        let (s, v) = srv.get_json("/readyz").await;
        (s == 200).then_some(v)
    })
    .await;
    assert_eq!(ready["status"], "ready");
    // Metrics show the renders (OpenMetrics text).
    let r = srv.client.get(srv.url("/metrics")).send().await.unwrap();
    assert!(
        r.headers()["content-type"]
            .to_str()
            .unwrap()
            .starts_with("application/openmetrics-text"),
        "{:?}",
        r.headers()
    );
    let m = r.text().await.unwrap();
    for line in [
        "caustica_http_requests_total{route=\"/v1/renders\",code=\"200\"} 2",
        "caustica_http_request_duration_seconds_count{route=\"/v1/renders\"} 2",
        // Job run times: buckets up to the job time limit (the bake timeout, 3600 s).
        "caustica_job_duration_seconds_bucket{le=\"3600.0\",kind=\"render\"} 2",
        "caustica_jobs_running{kind=\"render\"} 0",
        "caustica_build_info{version=\"",
        "process_resident_memory_bytes ",
        "# EOF",
    ] {
        assert!(m.contains(line), "no {line} in {m}");
    }
    assert!(
        m.contains("caustica_jobs_total{kind=\"render\",state=\"succeeded\"} 2"),
        "{m}"
    );
    assert!(
        m.contains("caustica_render_latency_seconds_count{method=\"direct\"} 2"),
        "{m}"
    );
    assert!(m.contains("caustica_queue_depth{lane=\"gpu\"}"), "{m}");
    srv.stop().await;
}

/// `method: auto` renders with the method the scene calls for and says which and why: the
/// canonical scene with its sphere painted diffuse has nothing that casts caustics, so `direct`
/// on the GPU worker, the same image as asking for `direct`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn auto_render_picks_the_method_and_says_why() {
    let srv = Server::start("render-auto", |_, _| {}).await;
    let mut scene = scene_sized(24, 16);
    scene["materials"]["glass"] = serde_json::json!({"type": "diffuse", "albedo": 0.5});
    let render = |method: &str| serde_json::json!({"scene": scene, "method": method, "format": "exr", "layers": true});
    let r = srv.post_json("/v1/renders", &render("auto")).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let auto = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["method"], "auto", "{rec}");
    assert_eq!(rec["info"]["method"], "direct", "{rec}");
    assert_eq!(rec["info"]["requested_method"], "auto", "{rec}");
    let why = rec["info"]["reason"].as_str().unwrap();
    assert!(why.contains("nothing casts caustics"), "{why}");
    let r = srv.post_json("/v1/renders", &render("direct")).await;
    assert_eq!(r.status(), 200);
    let direct = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert_eq!(auto, direct);
    // A field of a method the scene did not call for is refused, naming it.
    let mut req = render("auto");
    req["csl"] = serde_json::json!({"grid": 64});
    let p = problem(srv.post_json("/v1/renders", &req).await, 422).await;
    assert_eq!(p["field"], "csl", "{p}");
    assert!(p["detail"].as_str().unwrap().contains("not direct"), "{p}");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_past_the_wait_answers_202_and_completes() {
    let srv = Server::start("render-202", |_, h| h.render_wait = Duration::ZERO).await;
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": scene_sized(16, 16), "method": "reference",
                                "photons": 5000, "spp": 1}),
        )
        .await;
    assert_eq!(r.status(), 202);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let rec = poll("render to finish", Duration::from_secs(120), || async {
        let (_, v) = srv.get_json(&loc).await;
        (v["state"] == "succeeded").then_some(v)
    })
    .await;
    assert_eq!(rec["artifact"], format!("{loc}/image"));
    srv.stop().await;
}

/// `DELETE /v1/renders/{id}` cancels a render: a running one (a billion photons) stops at its
/// next progress check and its record says `canceled`; a render that succeeded answers 409, an
/// unknown one 404.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_can_be_canceled() {
    let srv = Server::start("render-cancel", |_, h| h.render_wait = Duration::ZERO).await;
    let submit = |photons: u64| {
        let body = serde_json::json!({"scene": scene_sized(16, 16), "method": "reference",
                                      "photons": photons, "spp": 1});
        let srv = &srv;
        async move {
            let r = srv.post_json("/v1/renders", &body).await;
            assert_eq!(r.status(), 202);
            r.headers()["location"].to_str().unwrap().to_string()
        }
    };
    let big = submit(100_000_000).await;
    let r = srv.client.delete(srv.url(&big)).send().await.unwrap();
    assert_eq!(r.status(), 200);
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["state"], "canceled", "{v}");
    let (_, v) = srv.get_json(&big).await;
    assert_eq!(v["state"], "canceled", "{v}");

    let small = submit(5000).await;
    poll("render to finish", Duration::from_secs(120), || async {
        let (_, v) = srv.get_json(&small).await;
        (v["state"] == "succeeded").then_some(())
    })
    .await;
    // A finished render is deleted, record and image.
    let r = srv.client.delete(srv.url(&small)).send().await.unwrap();
    assert_eq!(r.status(), 204);
    problem(srv.client.get(srv.url(&small)).send().await.unwrap(), 404).await;
    let image = srv.client.get(srv.url(&format!("{small}/image")));
    problem(image.send().await.unwrap(), 404).await;
    let r = srv
        .client
        .delete(srv.url("/v1/renders/rn_00000000000000000000000000000000"))
        .send()
        .await
        .unwrap();
    problem(r, 404).await;
    srv.stop().await;
}

/// A reference render canceled in its camera pass (a large frame, many samples a pixel) stops
/// soon after, not at the end of the pass.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reference_render_stops_in_its_camera_pass() {
    let srv = Server::start("render-cancel-camera", |_, h| {
        h.render_wait = Duration::ZERO
    })
    .await;
    let body = serde_json::json!({"scene": scene_sized(2048, 2048), "method": "reference",
                                  "photons": 2000, "spp": 64});
    let r = srv.post_json("/v1/renders", &body).await;
    assert_eq!(r.status(), 202);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    poll("the camera pass", Duration::from_secs(60), || async {
        let (_, v) = srv.get_json(&loc).await;
        (v["stage"] == "camera").then_some(())
    })
    .await;
    let t = std::time::Instant::now();
    let r = srv.client.delete(srv.url(&loc)).send().await.unwrap();
    let v: serde_json::Value = r.json().await.unwrap();
    assert_eq!(v["state"], "canceled", "{v}");
    eprintln!("camera pass stopped {:?} after the cancel", t.elapsed());
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_past_its_job_time_limit_is_a_504_problem() {
    let srv = Server::start("render-timeout", |j, _| {
        j.render_timeout = Duration::from_millis(300)
    })
    .await;
    let r = srv
        .post_json(
            "/v1/renders",
            // The camera pass (67 M samples): photons stop at half the timeout and return
            // their frame, the camera pass is not cut short.
            &serde_json::json!({"scene": scene_sized(512, 512), "method": "reference",
                                "photons": 1000, "spp": 256}),
        )
        .await;
    let p = problem(r, 504).await;
    assert!(p["detail"].as_str().unwrap().contains("time limit"), "{p}");
    assert!(
        p["instance"]
            .as_str()
            .unwrap()
            .starts_with("/v1/renders/rn_"),
        "{p}"
    );
    srv.stop().await;
}

/// `method: csl` bakes first (on the CPU pool, `bake` in `Server-Timing`), renders the
/// caustics layer on the GPU, and gives the same image as the library path (same bake, same
/// pass); a second render of the same object and light finds the bake by content hash.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn csl_render_bakes_first_then_reuses_the_bake() {
    use caustica::methods::{ArtifactStore, csl};
    use caustica::render::{CslLayer, RenderOptions};
    let srv = Server::start("render-csl", |_, _| {}).await;
    let scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    let req = serde_json::json!({
        "scene": scene, "method": "csl", "width": 64, "height": 64, "format": "exr",
        "component": "caustics", "csl": {"preset": "fast", "grid": 128},
    });
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200);
    assert_eq!(r.headers()["content-type"], "image/x-exr");
    let timing = r.headers()["server-timing"].to_str().unwrap().to_string();
    for stage in ["queue", "bake", "gpu_wait", "readback", "encode"] {
        assert!(timing.contains(&format!("{stage};dur=")), "{timing}");
    }
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let got = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert_eq!((got.width, got.height), (64, 64));
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["method"], "csl");
    assert_eq!(
        rec["info"]["statistics"]["bakes"][0]["cached"], false,
        "{rec}"
    );

    // The library path: same bake parameters, same renderer pass.
    let csl_params = req["csl"].clone();
    let want = tokio::task::spawn_blocking(move || {
        let mut w = scenes::parse(SCENE);
        w.camera.width = 64;
        w.camera.height = 64;
        let params = csl::BakeParams::parse(&csl_params, "csl").unwrap();
        let (dir, irradiance) = scenes::directional_light(&w);
        let sets =
            csl::sets_for_render(&w, &params, dir, &ArtifactStore::none(), &|_| true).unwrap();
        let mut r = gpu::renderer();
        let layer = CslLayer::new(&w, &[(sets[0].object, &*sets[0].set)], irradiance);
        r.render_csl(&w, &RenderOptions::default(), Some(&layer))
            .unwrap()
            .caustics
            .unwrap()
    })
    .await
    .unwrap();
    let peak = images::peak(&want);
    assert!(peak > 1.0, "a caustic: {peak}");
    let worst = got
        .pixels
        .iter()
        .zip(&want.pixels)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1e-3 * peak,
        "differs from the library by {worst} (peak {peak})"
    );

    // Again, with another camera: the bake is found, not redone.
    let mut req2 = req.clone();
    req2["camera"] = serde_json::json!({"eye": [0, 4, 2], "target": [0.3, 0, 0]});
    let r = srv.post_json("/v1/renders", &req2).await;
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(
        rec["info"]["statistics"]["bakes"][0]["cached"], true,
        "{rec}"
    );

    // A scene without a directional light is refused up front, naming the field.
    let mut no_light = scene.clone();
    no_light["lights"] =
        serde_json::json!([{"type": "point", "position": [0, 3, 0], "intensity": 5}]);
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": no_light, "method": "csl"}),
        )
        .await;
    let p = problem(r, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("directional"), "{p}");
    srv.stop().await;
}

/// `method: transport` bakes the glass object's table first (on the CPU pool), builds the
/// frame's illumination volumes, renders them on the GPU, and gives the library path's image;
/// a second render finds the table by content hash; a scene without glass is refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn transport_render_bakes_first_then_reuses_the_table() {
    use caustica::bake::transport::{TransportParams, bake_transport};
    use caustica::render::TransportLayer;
    use caustica::render::transport::volumes;
    let srv = Server::start("render-transport", |_, _| {}).await;
    let mut scene: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    scene["objects"][1]["shape"]["segments"] = 32.into();
    let req = serde_json::json!({
        "scene": scene, "method": "transport", "width": 64, "height": 64, "format": "exr",
        "component": "caustics",
    });
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200);
    let timing = r.headers()["server-timing"].to_str().unwrap().to_string();
    for stage in ["bake", "volumes", "gpu_wait", "encode"] {
        assert!(timing.contains(&format!("{stage};dur=")), "{timing}");
    }
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let got = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["method"], "transport");
    assert_eq!(
        rec["info"]["statistics"]["bakes"][0]["cached"], false,
        "{rec}"
    );

    let text = scene.to_string();
    let want = tokio::task::spawn_blocking(move || {
        let mut w = scenes::parse(&text);
        w.camera.width = 64;
        w.camera.height = 64;
        let table = bake_transport(&w, "glass", &TransportParams::standard(), &|_| true).unwrap();
        let layer =
            TransportLayer::build(&w, &[(1, &table)], volumes::DEFAULT_LINE_POINTS).unwrap();
        let mut r = gpu::renderer();
        r.render_transport(&w, &Default::default(), &layer)
            .unwrap()
            .caustics
            .unwrap()
    })
    .await
    .unwrap();
    let peak = images::peak(&want);
    assert!(peak > 1.0, "a caustic: {peak}");
    let worst = got
        .pixels
        .iter()
        .zip(&want.pixels)
        .map(|(a, b)| (*a - *b).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1e-3 * peak,
        "differs from the library by {worst} (peak {peak})"
    );

    // Again with a point light: the table serves every light, found by content hash.
    let mut req2 = req.clone();
    req2["lights"] =
        serde_json::json!([{"type": "point", "position": [-1.5, 2.5, 0], "intensity": 20}]);
    let r = srv.post_json("/v1/renders", &req2).await;
    assert_eq!(r.status(), 200);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let img = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert!(
        img.pixels.iter().any(|p| p.x > 0.1),
        "a caustic under the point light"
    );
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(
        rec["info"]["statistics"]["bakes"][0]["cached"], true,
        "{rec}"
    );

    // No glass in the scene: refused up front, naming the field.
    let mut no_glass = scene.clone();
    no_glass["objects"][1]["material"] = "floor".into();
    let r = srv
        .post_json(
            "/v1/renders",
            &serde_json::json!({"scene": no_glass, "method": "transport"}),
        )
        .await;
    let p = problem(r, 422).await;
    assert!(p["detail"].as_str().unwrap().contains("glass"), "{p}");
    srv.stop().await;
}

/// `method: pinhole` through the service: the canonical scene with its sphere made a mirror,
/// shadowed points, as an EXR: the same frame as the library call (with caustics in it), and
/// the record gives the points' figures.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pinhole_render_matches_the_library_and_reports_its_points() {
    use caustica::render::PinholeLayer;
    use caustica::render::pinhole::PinholeParams;
    let srv = Server::start("render-pinhole", |_, _| {}).await;
    let mut scene = scene_sized(32, 32);
    scene["materials"]["glass"] = serde_json::json!({"type": "mirror", "reflectance": 0.9});
    let req = serde_json::json!({"scene": scene, "method": "pinhole", "format": "exr",
        "pinhole": {"samples": 400, "shadows": true}});
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let served = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    let stats = &rec["info"]["statistics"];
    assert_eq!(stats["samples_asked"], 400, "{rec}");
    assert_eq!(stats["shadows"], true, "{rec}");
    assert_eq!(stats["reflector_parts"], 1, "{rec}");
    srv.stop().await;

    let world = caustica::scene::load_scene_json(scene.to_string().as_bytes()).unwrap();
    let p = PinholeParams {
        samples: 400,
        shadows: true,
        ..Default::default()
    };
    let layer = PinholeLayer::build(&world, &p).unwrap();
    let out = gpu::renderer()
        .render_pinhole(&world, &Default::default(), &layer)
        .unwrap();
    let caustics = out.caustics.as_ref().unwrap();
    assert!(
        caustics.pixels.iter().any(|p| p.x > 0.0),
        "the mirror casts light"
    );
    assert_eq!(served, out.total());
}

/// `method: photons` through the service: the library's frame for the same photons and seed,
/// the progression's figures in the record (a time budget stops it after one frame), and a bad
/// `progressive` field or a scene with fog refused with 422 naming the field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn photons_render_matches_the_library_and_reports_its_frames() {
    use caustica::render::photons::{PhotonsLayer, PhotonsParams};
    let srv = Server::start("render-photons", |_, _| {}).await;
    let scene = scene_sized(32, 32);
    let req = serde_json::json!({"scene": scene, "method": "photons", "format": "exr",
        "photons": 8192, "seed": 3, "progressive": {"photons_per_frame": 4096}});
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let served = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    let stats = &rec["info"]["statistics"];
    assert_eq!(stats["frames"], 2, "{rec}");
    assert_eq!(stats["photons"], 8192, "{rec}");
    assert_eq!(stats["stopped_by"], "frames", "{rec}");
    let mut budget = req.clone();
    budget["progressive"] = serde_json::json!({"photons_per_frame": 4096, "time_budget_ms": 1});
    let r = srv.post_json("/v1/renders", &budget).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["info"]["statistics"]["frames"], 1, "{rec}");
    assert_eq!(
        rec["info"]["statistics"]["stopped_by"], "time budget",
        "{rec}"
    );
    let mut bad = req.clone();
    bad["progressive"] = serde_json::json!({"error_target": 2});
    let p = problem(srv.post_json("/v1/renders", &bad).await, 422).await;
    assert_eq!(p["field"], "progressive.error_target", "{p}");
    let mut foggy = req.clone();
    foggy["scene"]["media"] = serde_json::json!([{"sigma_s": 0.1}]);
    let p = problem(srv.post_json("/v1/renders", &foggy).await, 422).await;
    assert_eq!(p["field"], "scene.media", "{p}");
    srv.stop().await;

    let world = caustica::scene::load_scene_json(scene.to_string().as_bytes()).unwrap();
    let p = PhotonsParams {
        photons: 4096,
        frames: 2,
        seed: 3,
        ..Default::default()
    };
    let layer = PhotonsLayer::build(&world, &p);
    let out = gpu::renderer()
        .render_photons(&world, &Default::default(), &layer)
        .unwrap();
    assert!(
        out.caustics
            .as_ref()
            .unwrap()
            .pixels
            .iter()
            .any(|p| p.x > 0.0),
        "the glass casts light"
    );
    // The same photons; the GPU's order of blending the splats varies from run to run.
    let all = vec![true; served.pixels.len()];
    let e = caustica::reference::compare::compare(&served, &out.total(), &all);
    assert!(e.rel_l1 < 1e-4, "{e:?}");
}

/// `method: water` through the service: the underwater view at a given `time` as an EXR (the
/// library's frame at that time, and the record's figures), a sequence as an animated PNG of
/// the frames asked for, and a time that is not finite or a sequence as EXR refused with 422.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn water_renders_frames_at_a_time_and_sequences_as_animated_png() {
    use caustica::render::water::{Receivers, WaterParams, WaterStats, render_layer};
    let srv = Server::start("render-water", |_, _| {}).await;
    let mut scene: serde_json::Value =
        serde_json::from_str(&scenes::text("underwater-view")).unwrap();
    scene["camera"]["width"] = 40.into();
    scene["camera"]["height"] = 30.into();
    let req = serde_json::json!({"scene": scene, "method": "water", "format": "exr",
        "component": "caustics", "time": 1.25, "water_mode": "physical",
        "water": {"grid": 128, "sun_samples": 2, "variant": "pixel"}});
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let served = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    let stats = &rec["info"]["statistics"];
    assert_eq!(stats["mode"], "physical", "{rec}");
    assert_eq!(stats["variant"], "pixel", "{rec}");
    assert_eq!(stats["grid"], 128, "{rec}");
    assert_eq!(stats["rays"], 2 * 129 * 129, "{rec}");
    // Without a variant, one water shape under one sun renders on the GPU.
    let mut req = req.clone();
    req["water"] = serde_json::json!({"grid": 128, "sun_samples": 2});
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let on_gpu = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    let stats = &rec["info"]["statistics"];
    assert_eq!(stats["variant"], "shader", "{rec}");
    assert_eq!(stats["rays"], 2 * 129 * 129, "{rec}");
    let sum = |f: &caustica::frame::Frame| f.pixels.iter().map(|p| p.x as f64).sum::<f64>();
    let ratio = sum(&on_gpu) / sum(&served);
    assert!((ratio - 1.0).abs() < 0.05, "GPU against CPU flux {ratio}");

    let seq = serde_json::json!({"scene": scene, "method": "water", "frames": 4, "fps": 30,
        "water": {"grid": 64}});
    let r = srv.post_json("/v1/renders", &seq).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    assert_eq!(r.headers()["content-type"], "image/apng");
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let bytes = r.bytes().await.unwrap();
    let dec = png::Decoder::new(std::io::Cursor::new(bytes.to_vec()));
    let reader = dec.read_info().unwrap();
    assert_eq!(reader.info().animation_control.unwrap().num_frames, 4);
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["info"]["frames"], 4, "{rec}");
    assert!(rec["info"]["ms_per_frame"].as_f64().unwrap() > 0.0, "{rec}");

    for (bad, field) in [
        (
            serde_json::json!({"scene": scene, "method": "water", "time": "soon"}),
            "time",
        ),
        // Beyond f32: infinite.
        (
            serde_json::json!({"scene": scene, "method": "water", "time": 1e39}),
            "time",
        ),
        (
            serde_json::json!({"scene": scene, "method": "water", "frames": 3, "format": "exr"}),
            "format",
        ),
        (
            serde_json::json!({"scene": scene, "method": "water", "frames": 0}),
            "frames",
        ),
        (
            serde_json::json!({"scene": serde_json::from_str::<serde_json::Value>(SCENE).unwrap(), "method": "direct", "time": 1.0}),
            "time",
        ),
    ] {
        let r = srv.post_json("/v1/renders", &bad).await;
        assert_eq!(r.status(), 422, "{bad}");
        let body: serde_json::Value = r.json().await.unwrap();
        assert_eq!(body["field"], field, "{body}");
    }
    srv.stop().await;

    let mut world = caustica::scene::load_scene_json(scene.to_string().as_bytes()).unwrap();
    caustica::scene::water::set_time(&mut world, 1.25);
    let p = WaterParams {
        grid: 128,
        sun_samples: 2,
        ..Default::default()
    };
    let layer = render_layer(
        &world,
        &Receivers::build(&world),
        &p,
        &mut WaterStats::default(),
    )
    .caustics;
    assert!(layer.pixels.iter().any(|p| p.x > 0.0), "the floor is lit");
    // The same frame, up to the order the threads summed in.
    assert_eq!((served.width, served.height), (layer.width, layer.height));
    for (a, b) in served.pixels.iter().zip(&layer.pixels) {
        assert!(
            (*a - *b).abs().max_element() <= 1e-4 * (1.0 + b.max_element()),
            "{a} {b}"
        );
    }
}

/// A render without `method` is `auto` (the README's curl line): the canonical glass sphere
/// comes back with its caustic, within 15 % relative L1 of the stored reference on the floor,
/// made by `photons` and checked against a short reference (the record says so).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_render_without_a_method_is_auto_and_shows_the_caustic() {
    let srv = Server::start("render-default-auto", |_, _| {}).await;
    let scene = scene_sized(256, 256);
    let req = serde_json::json!({"scene": scene, "format": "exr", "component": "caustics"});
    let r = srv.post_json("/v1/renders", &req).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let caustics = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(rec["method"], "auto", "{rec}");
    assert_eq!(rec["info"]["method"], "photons", "{rec}");
    let stats = &rec["info"]["statistics"];
    assert!(stats["auto"]["expected"].is_string(), "{rec}");
    let check = stats["check"]["error"].as_f64().expect("a self-check");
    srv.stop().await;
    let world = caustica::scene::load_scene_json(scene.to_string().as_bytes()).unwrap();
    let truth = images::stored_reference("glass-sphere-directional.caustics.64M.exr");
    let e = caustica::reference::compare::compare_on(world, "floor", &caustics, &truth);
    eprintln!("default auto: {e:?}, self-check {check:.3}");
    assert!(
        e.rel_l1 <= 0.15 && (e.flux_ratio - 1.0).abs() <= 0.05,
        "{e:?}"
    );
    // The self-check tells the truth within 2×.
    let measured = f64::from(e.rel_l1);
    assert!(
        check <= 2.0 * measured && measured <= 2.0 * check.max(0.02),
        "{check} {e:?}"
    );
}

/// A lone glass GLB (the teapot, as the Python client's example uploads it): its caustic
/// falls on nothing, and the answer says so and what to do; with `"ground": true` a floor
/// under it receives the caustic and the warning is gone.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lone_glb_warns_of_its_black_caustic_and_renders_it_on_a_ground() {
    let srv = Server::start("render-lone-glb", |_, _| {}).await;
    let glb = std::fs::read(crate::support::repo_path("scenes/assets/teapot-glass.glb")).unwrap();
    let r = reqwest::Client::new()
        .post(srv.url("/v1/scenes"))
        .header("content-type", "model/gltf-binary")
        .body(glb)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201, "{:?}", r.text().await);
    let id = r.json::<serde_json::Value>().await.unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    let render = |ground: bool| {
        serde_json::json!({"scene": id, "method": "photons", "photons": 262144, "width": 64,
            "height": 48, "format": "exr", "component": "caustics", "ground": ground})
    };
    let r = srv.post_json("/v1/renders", &render(false)).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    let warnings: Vec<String> = r
        .headers()
        .get_all("caustica-warning")
        .iter()
        .map(|v| v.to_str().unwrap().to_string())
        .collect();
    let loc = r.headers()["location"].to_str().unwrap().to_string();
    let black = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    assert!(black.pixels.iter().all(|p| p.element_sum() == 0.0));
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("no surface receives") && w.contains("\"ground\": true")),
        "{warnings:?}"
    );
    let (_, rec) = srv.get_json(&loc).await;
    assert_eq!(
        rec["info"]["warnings"].as_array().map(Vec::len),
        Some(warnings.len()),
        "{rec}"
    );
    let r = srv.post_json("/v1/renders", &render(true)).await;
    assert_eq!(r.status(), 200, "{:?}", r.text().await);
    assert!(
        r.headers().get("caustica-warning").is_none(),
        "{:?}",
        r.headers()
    );
    let lit = encode::decode_frame(&r.bytes().await.unwrap()).unwrap();
    let bright = lit.pixels.iter().filter(|p| p.element_sum() > 0.0).count();
    assert!(
        bright > lit.pixels.len() / 20,
        "{bright} pixels of caustic light"
    );
    srv.stop().await;
}
