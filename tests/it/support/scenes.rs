//! The repository's scenes (`scenes/NAME.json`, found from `CARGO_MANIFEST_DIR` whatever the
//! current directory), and the scene-building helpers several modules share.

use caustica::scene::{self, Light, World};
use caustica::trace::Accel;
use glam::Vec3;
use std::path::PathBuf;

/// The canonical scene, the glass sphere under a directional light, as text.
pub const SCENE: &str = include_str!("../../../scenes/glass-sphere-directional.json");

/// The file of scene `name` (`scenes/{name}.json`).
pub fn path(name: &str) -> PathBuf {
    super::repo_path("scenes").join(format!("{name}.json"))
}

/// The text of scene `name`.
pub fn text(name: &str) -> String {
    let p = path(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Scene `name` resolved, its assets read beside it, default limits.
pub fn load(name: &str) -> World {
    scene::load_scene_file(&path(name), &Default::default()).expect("scene loads")
}

/// A scene given as JSON resolved, without assets, default limits.
pub fn parse(json: &str) -> World {
    scene::load_scene_json(json.as_bytes()).expect("scene resolves")
}

/// The canonical scene with another image size.
pub fn scene_sized(w: u32, h: u32) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_str(SCENE).unwrap();
    v["camera"]["width"] = w.into();
    v["camera"]["height"] = h.into();
    v
}

/// The index of the object called `name`.
pub fn object_index(world: &World, name: &str) -> usize {
    world.objects.iter().position(|o| o.name == name).unwrap()
}

/// Direction and irradiance of the scene's first light, which must be directional.
pub fn directional_light(world: &World) -> (Vec3, Vec3) {
    let Light::Directional {
        direction,
        irradiance,
        ..
    } = world.lights[0].clone()
    else {
        panic!("directional light expected")
    };
    (direction, irradiance)
}

/// Everything in `world` but object `except`: what stops the light that leaves it.
pub fn blockers(world: &World, except: usize) -> Accel {
    Accel::build_with(world, |i| i != except, obvhs::BvhBuildParams::fast_build())
}

/// A slab of fog 1 m thick (a 4 m × 1 m × 4 m box of coloured fog, g 0.4) under a slanted sun
/// of irradiance 2, seen from above with nothing else in the scene (40 × 30), and the closed
/// form of its single-scattered radiance along a view ray v (μv = |v·y|) from the sun along l
/// (μl = |l·y|): L = E σs p(l, −v) (1 − e^{−σt H k}) / (σt μv k), k = 1/μv + 1/μl — the
/// in-scattering ∫ σs p E e^{−σt z/μl} e^{−σt s} ds over the ray's path s in the slab, at depth
/// z = s μv.
pub fn fog_slab() -> (World, impl Fn(Vec3) -> Vec3) {
    let (sigma_s, sigma_a, g) = (Vec3::new(0.3, 0.5, 0.8), Vec3::new(0.1, 0.05, 0.2), 0.4f32);
    let world = parse(&format!(
        r#"{{
        "camera": {{"eye": [0, 3, 1.2], "target": [0, 0.5, 0], "fov_y": 20, "width": 40, "height": 30}},
        "lights": [{{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 2.0}}],
        "media": [{{"sigma_s": [{}, {}, {}], "sigma_a": [{}, {}, {}], "g": {g},
                    "bounds": {{"type": "box", "size": [4, 1, 4],
                                "transform": {{"translation": [0, 0.5, 0]}}}}}}]
        }}"#,
        sigma_s.x, sigma_s.y, sigma_s.z, sigma_a.x, sigma_a.y, sigma_a.z
    ));
    let l = Vec3::new(0.3, -1.0, 0.2).normalize();
    let closed_form = move |v: Vec3| {
        let (mu_l, mu_v) = (-l.y, -v.y);
        let st = sigma_s + sigma_a;
        let k = 1.0 / mu_v + 1.0 / mu_l;
        let p = caustica::scene::medium::hg(g, l, -v);
        2.0 * sigma_s * p * (Vec3::ONE - (-st * k).exp()) / (st * mu_v * k)
    };
    (world, closed_form)
}

/// A reference bake of `scene_sized(8, 8)`'s glass that runs for minutes (10⁹ camera samples
/// over a 1024² image) and holds little memory (its estimate ~0.27 GiB: few photons), for
/// tests that need a bake to hold a worker until they cancel it.
pub fn long_bake(seed: u64) -> serde_json::Value {
    serde_json::json!({"scene": scene_sized(8, 8), "object": "glass", "method": "reference",
                       "params": {"photons": 1000, "spp": 1024, "width": 1024, "height": 1024,
                                  "seed": seed}})
}
