//! Property tests of bad input over HTTP (issue 27, extreme values): scenes generated with
//! extreme finite values (sizes from 0 to 10⁷ m, positions out to 10⁷ m, intensities to 10³⁰),
//! odd transforms (huge and tiny scales, any rotation) and degenerate shapes (zero radii, a
//! torus fatter than its ring, too few segments), sometimes with fog or a pool of water,
//! rendered by every method. Every answer must be an image (200) or a problem naming what is wrong (4xx),
//! never a 500: a panic or an internal error. The cases come from a fixed seed, so a failure
//! is the same on every run; it prints the scene and the method.

use crate::support::server::*;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use serde_json::{Value, json};

/// A length: mostly valid, from a micrometre to ten kilometres; now and then zero, negative
/// or past the world's extent.
fn size() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => 0.05..5.0f64,
        2 => 1e-6..1e-3f64,
        2 => 10.0..1e4f64,
        1 => prop_oneof![Just(0.0), -1.0..0.0f64, 1e6..1e7f64],
    ]
}

/// A coordinate: mostly near the origin, sometimes far, now and then past the world's extent.
fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![
        30 => -5.0..5.0f64,
        3 => Just(0.0),
        3 => -1e4..1e4f64,
        1 => -1e7..1e7f64,
    ]
}

/// A pool's size or depth: mostly a few metres, sometimes any [`size`].
fn pool_size() -> impl Strategy<Value = f64> {
    prop_oneof![3 => 0.5..5.0f64, 1 => size()]
}

fn point() -> impl Strategy<Value = [f64; 3]> {
    [coord(), coord(), coord()]
}

/// A light power: zero, everyday or enormous.
fn power() -> impl Strategy<Value = f64> {
    prop_oneof![1 => Just(0.0), 4 => 0.1..10.0f64, 2 => 1e10..1e30f64]
}

fn light() -> impl Strategy<Value = Value> {
    prop_oneof![
        3 => (point(), power())
            .prop_map(|(d, e)| json!({"type": "directional", "direction": d, "irradiance": e})),
        1 => (point(), power())
            .prop_map(|(p, i)| json!({"type": "point", "position": p, "intensity": i})),
        1 => (point(), point(), power(), 0.01..89.9f64, 0.0..1.0f64).prop_map(
            |(p, t, i, c, b)| json!({"type": "spot", "position": p, "target": t,
                "intensity": i, "cutoff_angle": c, "beam_width": (c * b).max(0.001)})
        ),
        1 => (point(), point(), power())
            .prop_map(|(s, e, i)| json!({"type": "line", "start": s, "end": e, "intensity": i})),
    ]
}

fn shape() -> impl Strategy<Value = Value> {
    prop_oneof![
        (size(), 0u32..40)
            .prop_map(|(r, s)| json!({"type": "sphere", "radius": r, "segments": s})),
        (size(), 0u32..40)
            .prop_map(|(r, s)| json!({"type": "sphere", "radius": r, "segments": s})),
        [size(), size(), size()].prop_map(|s| json!({"type": "box", "size": s})),
        (size(), size(), 0u32..40).prop_map(
            |(a, b, s)| json!({"type": "torus", "major_radius": a, "minor_radius": b, "segments": s})
        ),
        (size(), size(), 0u32..40).prop_map(
            |(r, h, s)| json!({"type": "cylinder", "radius": r, "height": h, "segments": s})
        ),
        (size(), size(), 0u32..40).prop_map(
            |(f, r, s)| json!({"type": "paraboloid", "focal_length": f, "radius": r, "segments": s})
        ),
    ]
}

fn material() -> impl Strategy<Value = Value> {
    prop_oneof![
        4 => (1.0..4.0f64).prop_map(|n| json!({"type": "dielectric", "ior": n})),
        3 => (0.0..1.0f64).prop_map(|r| json!({"type": "mirror", "reflectance": r})),
        1 => (0.0..1.0f64).prop_map(|a| json!({"type": "diffuse", "albedo": a})),
        1 => (0.5..5.0f64).prop_map(|n| json!({"type": "dielectric", "ior": n})),
    ]
}

fn transform() -> impl Strategy<Value = Value> {
    let scale = prop_oneof![4 => Just(1.0), 1 => size()];
    (
        point(),
        [-720.0..720.0f64, -720.0..720.0, -720.0..720.0],
        scale,
    )
        .prop_map(|(t, r, s)| json!({"translation": t, "rotation_deg": r, "scale": s}))
}

fn scene() -> impl Strategy<Value = Value> {
    let camera = (point(), point(), 1.0..170.0f64, 1u32..12, 1u32..12)
        .prop_map(|(eye, target, fov, w, h)| {
            json!({"eye": eye, "target": target, "fov_y": fov, "width": w, "height": h})
        });
    // Now and then fog (for beams) or a pool of water (for water) beside the object.
    let fog = prop_oneof![
        3 => Just(None),
        1 => (size(), 0.0..2.0f64, -0.99..0.99f64).prop_map(|(sigma, a, g)| Some(json!(
            [{"sigma_s": sigma, "sigma_a": a, "g": g, "bounds": {"type": "scene"}}]
        ))),
    ];
    let pool = prop_oneof![
        3 => Just(None),
        1 => ([pool_size(), pool_size()], pool_size(), 1u32..64).prop_map(|(s, d, r)| Some(json!(
            {"name": "pool", "shape": {"type": "water", "size": s, "depth": d,
             "floor": [0.5, 0.6, 0.7], "waves": {"preset": "article"}, "resolution": r}}
        ))),
    ];
    (
        camera,
        prop::collection::vec(light(), 1..3),
        [0.1..1e4f64, 0.1..1e4f64],
        (shape(), material(), transform()),
        fog,
        pool,
    )
        .prop_map(|(camera, lights, floor, (shape, mat, tr), fog, pool)| {
            let mut objects = vec![
                json!({"name": "floor", "shape": {"type": "plane", "size": floor}, "material": "floor"}),
                json!({"name": "thing", "shape": shape, "material": "thing", "transform": tr}),
            ];
            objects.extend(pool);
            let mut scene = json!({
                "camera": camera,
                "lights": lights,
                "materials": {"floor": {"type": "diffuse", "albedo": 0.5}, "thing": mat},
                "objects": objects,
            });
            if let Some(f) = fog {
                scene["media"] = f;
            }
            scene
        })
}

/// Every method, each with small settings (those that need water or fog answer 422 without).
fn requests(scene: &Value) -> Vec<Value> {
    let base = |method: &str| json!({"scene": scene, "method": method, "format": "exr"});
    let mut out = Vec::new();
    for m in ["direct", "pinhole", "transport", "auto", "water"] {
        out.push(base(m));
    }
    let mut r = base("reference");
    r["photons"] = 2000.into();
    r["spp"] = 1.into();
    out.push(r);
    let mut p = base("photons");
    p["photons"] = 4096.into();
    p["progressive"] = json!({"photons_per_frame": 4096});
    out.push(p);
    let mut b = base("beams");
    b["beams"] = json!({"grid": 32});
    out.push(b);
    let mut c = base("csl");
    c["csl"] = json!({"preset": "fast", "grid": 16});
    out.push(c);
    out
}

/// 64 generated scenes, each sent to nine methods: an image or a problem, never a 500.
#[test]
fn generated_scenes_get_an_image_or_a_problem_never_a_500() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let srv = rt.block_on(Server::start("props", |_, _| {}));
    let config = Config {
        cases: 64,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::deterministic_rng(RngAlgorithm::ChaCha);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let counts = std::sync::Mutex::new((0usize, 0usize));
    let rendered = std::sync::Mutex::new(std::collections::BTreeMap::<String, usize>::new());
    let result = runner.run(&scene(), |scene| {
        for body in requests(&scene) {
            let (status, text) = rt.block_on(async {
                let r = srv.post_json("/v1/renders", &body).await;
                let status = r.status().as_u16();
                (status, r.text().await.unwrap_or_default())
            });
            let method = body["method"].as_str().unwrap_or("?");
            prop_assert!(
                status == 200 || (400..500).contains(&status) || status == 503,
                "{method}: {status} {}\nscene: {scene}",
                text.chars().take(600).collect::<String>()
            );
            if (400..500).contains(&status) || status == 503 {
                // A problem names what is wrong.
                let p: Value = serde_json::from_str(&text).unwrap_or_default();
                prop_assert!(
                    p["detail"].as_str().is_some_and(|d| !d.is_empty()),
                    "{method}: {status} without a detail: {text}"
                );
            }
            let mut c = counts.lock().unwrap();
            if status == 200 {
                c.0 += 1;
                *rendered
                    .lock()
                    .unwrap()
                    .entry(method.to_string())
                    .or_insert(0) += 1;
            } else {
                c.1 += 1;
            }
        }
        Ok(())
    });
    let (images, problems) = *counts.lock().unwrap();
    let rendered = rendered.into_inner().unwrap();
    eprintln!("{images} images, {problems} problems; images by method: {rendered:?}");
    if let Err(e) = result {
        panic!("{e}");
    }
    // The cases reach both outcomes: some scenes render, some are refused.
    assert!(
        images > 0 && problems > 0,
        "{images} images, {problems} problems"
    );
    rt.block_on(async {
        let (s, v) = srv.get_json("/healthz").await;
        assert_eq!((s, v["status"].as_str()), (200, Some("ok")));
        srv.stop().await;
    });
}
