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
