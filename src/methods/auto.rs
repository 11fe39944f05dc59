//! Method `auto`: one of the others, chosen from the scene by [`choose`]. The CLI's default.
//!
//! The rule, first match wins:
//! 0. a water shape and a directional light (the sun) → `water`;
//! 1. no object has a glass or mirror part → `direct` (nothing casts caustics);
//! 2. a participating medium in a box or the whole scene and a directional, spot or point
//!    light → `beams` (the volumetric caustics, and the surface caustics from the same beams);
//! 3. every caustic part is a mirror and an environment light lights the scene → `pinhole`
//!    (one reflection of the environment and of the other lights);
//! 4. otherwise → `photons`: progressive GPU photon tracing, which fits any glass or mirror
//!    object under every light type (within 10 % of the reference on every test scene, where
//!    the baked `csl` and `transport` are 27–81 % off on the glass teapot and vases, and their
//!    bakes' own fit checks flag them). The baked methods stay available by name; `auto` does
//!    not pick them even where a bake fits (the glass sphere), since `photons` is closer to the
//!    reference there too.

use super::{
    Env, Frames, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, caustic_objects,
};
use crate::scene::{Light, Material, World};

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Auto,
    name: "auto",
    // An auto render runs where the chosen method does.
    lane: Lane::Cpu,
    gpu: true,
    bake: false,
    // The chosen method checks the fields it takes.
    args: &[],
};

pub struct Auto;

/// The method `auto` renders `world` with, and why.
pub fn choose(world: &World) -> (Method, &'static str) {
    if super::water::check_scene(world).is_ok() {
        return (
            Method::Water,
            "a water surface under a directional light: underwater caustics",
        );
    }
    let caustic = caustic_objects(world);
    if caustic.is_empty() {
        return (
            Method::Direct,
            "no object has a glass or mirror part: nothing casts caustics",
        );
    }
    if !world.media.is_empty()
        && world.media.iter().all(|m| !m.has_boundary_mesh())
        && world.lights.iter().any(|l| {
            matches!(
                l,
                Light::Directional { .. } | Light::Spot { .. } | Light::Point { .. }
            )
        })
    {
        return (
            Method::Beams,
            "glass or mirrors in a participating medium under a directional, spot or point \
             light: volumetric caustics",
        );
    }
    let all_mirror = caustic.iter().all(|&i| {
        world.objects[i].parts.iter().all(|p| {
            let m = &world.materials[p.material as usize];
            !m.is_specular() || matches!(m, Material::Mirror { .. })
        })
    });
    let environment = world
        .lights
        .iter()
        .any(|l| matches!(l, Light::Environment { .. }));
    if all_mirror && environment {
        (
            Method::Pinhole,
            "every caustic object is a mirror, lit by an environment light",
        )
    } else {
        (
            Method::Photons,
            "glass or mirrors outside water and fog: progressive photon tracing, which fits \
             any shape and light",
        )
    }
}

impl MethodImpl for Auto {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        let (method, reason) = choose(world);
        Ok(Box::new(Chosen {
            plan: method.imp().plan(world, args)?,
            reason,
        }))
    }
}

/// The chosen method's plan, with the reason it was chosen.
struct Chosen {
    plan: Box<dyn RenderPlan>,
    reason: &'static str,
}

impl RenderPlan for Chosen {
    fn method(&self) -> Method {
        self.plan.method()
    }

    fn reason(&self) -> Option<&str> {
        Some(self.reason)
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        self.plan.frames(world, env)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(json: &str) -> World {
        crate::scene::load_scene_json(json.as_bytes()).unwrap()
    }

    fn with(material: &str, light: &str) -> World {
        scene(&format!(
            r#"{{"camera": {{"eye": [0, 2, 2], "target": [0, 0, 0]}},
                "lights": [{light}],
                "materials": {{"floor": {{"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
                               "m": {material}}},
                "objects": [
                  {{"name": "floor", "shape": {{"type": "plane", "size": [4, 4]}}, "material": "floor"}},
                  {{"name": "thing", "shape": {{"type": "sphere", "radius": 0.5}}, "material": "m"}}]}}"#
        ))
    }

    #[test]
    fn the_documented_rule() {
        let sun = r#"{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}"#;
        let bulb = r#"{"type": "point", "position": [0, 2, 0], "intensity": 1}"#;
        let sky = r#"{"type": "environment", "radiance": 1}"#;
        let glass = r#"{"type": "dielectric", "ior": 1.5}"#;
        let mirror = r#"{"type": "mirror", "reflectance": 0.9}"#;
        let paint = r#"{"type": "diffuse", "albedo": 0.5}"#;
        assert_eq!(choose(&with(paint, sun)).0, Method::Direct);
        assert_eq!(choose(&with(glass, sun)).0, Method::Photons);
        assert_eq!(choose(&with(glass, bulb)).0, Method::Photons);
        assert_eq!(choose(&with(mirror, sun)).0, Method::Photons);
        assert_eq!(choose(&with(mirror, bulb)).0, Method::Photons);
        assert_eq!(choose(&with(glass, sky)).0, Method::Photons);
        assert_eq!(choose(&with(mirror, sky)).0, Method::Pinhole);
        // In fog: the beams, for a delta light they take.
        let fog = |m: &str, l: &str| {
            let mut w = with(m, l);
            w.media.push(crate::scene::medium::Medium::new(
                glam::Vec3::splat(0.1),
                glam::Vec3::ZERO,
                0.0,
                glam::Mat4::IDENTITY,
                glam::Vec3::splat(3.0),
            ));
            w
        };
        assert_eq!(choose(&fog(glass, bulb)).0, Method::Beams);
        assert_eq!(choose(&fog(mirror, sun)).0, Method::Beams);
        assert_eq!(choose(&fog(paint, sun)).0, Method::Direct);
        assert_eq!(choose(&fog(mirror, sky)).0, Method::Pinhole);
        // The plan is the chosen method's, and says why.
        let plan = Auto
            .plan(&with(mirror, sun), &MethodArgs::default())
            .unwrap();
        assert_eq!(plan.method(), Method::Photons);
        assert!(plan.reason().unwrap().contains("photon tracing"));
    }
}
