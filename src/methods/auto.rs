//! Method `auto`: one of the others, chosen from the scene by [`choose`], the default of the
//! CLI and of the API. It picks the fastest method whose measured error on scenes of this
//! kind is within 0.10 relative L1 of the reference (the table in docs/accuracy.md, "How
//! `auto` picks"), and never one whose documented limits the scene hits:
//!
//! 0. a water shape and a directional light (the sun) → `water`, from under the surface
//!    (0.03–0.06 on the floor's caustics of the pool and the sea floor, 0.05–0.06 on the sea
//!    floor's whole frame) and from above (the whole frame 0.06–0.09 on both);
//! 1. a participating medium → `reference` (`beams` leaves out the fog lit by the surfaces,
//!    `direct` and `photons` have no fog);
//! 2. no object has a glass or mirror part → `direct` (nothing casts caustics; its direct
//!    light is within 1 % of the reference);
//! 3. otherwise → `photons`, progressive until its noise estimate is 0.10 (0.048–0.092 on
//!    every test scene, where `pinhole` is 0.07–0.42, `csl` 0.13–0.81, `transport` 0.04–0.52),
//!    then checked against a short reference on the receivers (`methods::check`): the rule is
//!    unsure for shapes and lights nobody measured (a dense glass mesh, an oblique light), so
//!    where the check finds the frame over 0.10 the frame is made by `reference` instead.

use super::{
    Env, Frames, Lane, Method, MethodArgs, MethodError, MethodImpl, MethodInfo, ParamError,
    RenderPlan, caustic_objects,
};
use crate::scene::{Light, World};

pub static INFO: MethodInfo = MethodInfo {
    method: Method::Auto,
    name: "auto",
    // An auto render runs where the chosen method does.
    lane: Lane::Cpu,
    gpu: true,
    bake: false,
    // The chosen method checks the fields it takes.
    args: &[],
    // Where its rule is unsure, the chosen plan checks itself (and falls back).
    check: false,
};

/// The largest self-check error `auto` accepts from `photons` before it renders with
/// `reference` instead.
pub const MAX_CHECK: f32 = 0.10;
/// The noise estimate `auto`'s `photons` frames progress to (per pixel, before the 3×3 blur of
/// the error measure: 0.094 there gave 0.066 on the glass sphere under the sky, bias
/// included), and the most photons they take.
const PHOTONS_ERROR_TARGET: f32 = 0.10;
const PHOTONS_MOST: u64 = 8 << 20;

pub struct Auto;

/// What `auto` picks for a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Choice {
    pub method: Method,
    /// Why, in words.
    pub reason: &'static str,
    /// The error to expect, as measured (docs/accuracy.md).
    pub expected: &'static str,
    /// Whether the frame is checked against a short reference (and made by `reference` where
    /// it is poor): the rule is unsure.
    pub check: bool,
}

/// The method `auto` renders `world` with, and why.
pub fn choose(world: &World) -> Choice {
    if super::water::check_scene(world).is_ok() {
        return Choice {
            method: Method::Water,
            reason: "a water surface under a directional light: underwater caustics, seen from \
                 under the surface or through the waves",
            expected: "0.03-0.09 relative L1 on the pool and the sea floor, from under the \
                 surface and from above",
            check: false,
        };
    }
    if !world.media.is_empty() {
        return Choice {
            method: Method::Reference,
            reason: "a participating medium (fog): method beams leaves out the fog lit by the \
                 surfaces, the reference has all of it",
            expected: "the reference's own noise",
            check: false,
        };
    }
    if caustic_objects(world).is_empty() {
        return Choice {
            method: Method::Direct,
            reason: "no object has a glass or mirror part: nothing casts caustics",
            expected: "direct light within 0.01 relative L1 of the reference",
            check: false,
        };
    }
    let environment = world
        .lights
        .iter()
        .any(|l| matches!(l, Light::Environment { .. }));
    Choice {
        method: Method::Photons,
        reason: if environment {
            "glass or mirrors under an environment light: progressive photon tracing (the sky's \
             sun traced as well), checked against a short reference"
        } else {
            "glass or mirrors outside water and fog: progressive photon tracing, which fits any \
             shape and light, checked against a short reference"
        },
        expected: "at most 0.10 relative L1 on the receivers (0.05-0.09 on the test scenes)",
        check: true,
    }
}

impl MethodImpl for Auto {
    fn info(&self) -> &'static MethodInfo {
        &INFO
    }

    fn plan(&self, world: &World, args: &MethodArgs) -> Result<Box<dyn RenderPlan>, ParamError> {
        let choice = choose(world);
        let mut args = args.clone();
        if choice.method == Method::Photons && args.photons.is_none() && args.progressive.is_none()
        {
            // Frames until the noise estimate is low enough for the expected error.
            args.photons = Some(PHOTONS_MOST);
            args.progressive = Some(serde_json::json!({ "error_target": PHOTONS_ERROR_TARGET }));
        }
        let fallback = choice
            .check
            .then(|| {
                Method::Reference
                    .imp()
                    .plan(world, &reference_args(world, &args))
            })
            .transpose()?;
        Ok(Box::new(Chosen {
            plan: choice.method.imp().plan(world, &args)?,
            choice,
            check: args.check != Some(false) && choice.check,
            fallback,
        }))
    }
}

/// Photons of the reference when `auto` falls back to it: 256 a pixel, 4–16 M. The frame
/// replaces one whose caustics were over 0.10 off, so its own noise should be under that: on
/// the glass teapot at 256² the default 4 M photons leave about 0.15, 16 M about 0.07.
pub fn fallback_photons(world: &World) -> u64 {
    let pixels = u64::from(world.camera.width) * u64::from(world.camera.height);
    (pixels * 256).clamp(4 << 20, 16 << 20)
}

/// The reference's parameters for a fallback: the request's seed, [`fallback_photons`].
fn reference_args(world: &World, args: &MethodArgs) -> MethodArgs {
    MethodArgs {
        seed: args.seed,
        photons: Some(fallback_photons(world)),
        ..Default::default()
    }
}

/// The chosen method's plan, with the reason it was chosen, and the reference's where the
/// choice is checked.
struct Chosen {
    plan: Box<dyn RenderPlan>,
    choice: Choice,
    check: bool,
    fallback: Option<Box<dyn RenderPlan>>,
}

impl RenderPlan for Chosen {
    fn method(&self) -> Method {
        self.plan.method()
    }

    fn reason(&self) -> Option<&str> {
        Some(self.choice.reason)
    }

    fn frames(&self, world: &World, env: &Env) -> Result<Frames, MethodError> {
        let mut frames = self.plan.frames(world, env)?;
        let mut auto = serde_json::json!({
            "picked": self.choice.method,
            "reason": self.choice.reason,
            "expected": self.choice.expected,
        });
        if self.check {
            let c = super::self_check(world, &mut frames, env)?;
            let poor = c.filter(|c| c.error > MAX_CHECK);
            if let (Some(c), Some(fallback)) = (poor, &self.fallback) {
                let why = format!(
                    "the frame of method {} was {:.2} relative L1 from a short reference on \
                     the receivers (more than {MAX_CHECK}): made by the reference instead",
                    self.choice.method, c.error
                );
                frames = fallback.frames(world, env)?;
                frames.made_by = Some(Method::Reference);
                // The check was of the frame put aside: recorded, but the frame given is the
                // reference's, so its only warning is the fallback.
                frames.record(
                    "check",
                    serde_json::to_value(c).expect("a check serialises"),
                );
                frames.warn(format!("auto: {why}"));
                auto["fell_back"] = serde_json::json!({ "to": Method::Reference, "why": why });
            } else {
                super::note_check(&mut frames, c.as_ref());
            }
        }
        frames.record("auto", auto);
        Ok(frames)
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
        assert_eq!(choose(&with(paint, sun)).method, Method::Direct);
        for (m, l) in [
            (glass, sun),
            (glass, bulb),
            (mirror, sun),
            (mirror, bulb),
            (glass, sky),
            (mirror, sky),
        ] {
            let c = choose(&with(m, l));
            assert_eq!((c.method, c.check), (Method::Photons, true), "{m} {l}");
        }
        // In fog: the reference, whatever lights it.
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
        for (m, l) in [(glass, bulb), (mirror, sun), (paint, sun), (mirror, sky)] {
            assert_eq!(choose(&fog(m, l)).method, Method::Reference, "{m} {l}");
        }
        // The plan is the chosen method's, and says why; photons progress to a noise target.
        let plan = Auto
            .plan(&with(mirror, sun), &MethodArgs::default())
            .unwrap();
        assert_eq!(plan.method(), Method::Photons);
        assert!(plan.reason().unwrap().contains("photon tracing"));
    }

    /// A frame of the chosen method that the check finds poor (here a black caustics layer
    /// under the glass sphere) is made again by the reference, and the answer says so.
    #[test]
    fn a_poor_frame_falls_back_to_the_reference() {
        use crate::frame::{Component, Frame};
        struct Black;
        impl RenderPlan for Black {
            fn method(&self) -> Method {
                Method::Photons
            }
            fn frames(&self, world: &World, _: &Env) -> Result<Frames, MethodError> {
                let (w, h) = (world.camera.width, world.camera.height);
                Ok(Frames {
                    layers: Component::ALL.map(|c| (c, Frame::new(w, h))).to_vec(),
                    timings: Vec::new(),
                    adapter: "none".into(),
                    statistics: None,
                    notes: Vec::new(),
                    warnings: Vec::new(),
                    made_by: None,
                })
            }
        }
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut world = crate::scene::load_scene_file(
            &dir.join("glass-sphere-directional.json"),
            &Default::default(),
        )
        .unwrap();
        (world.camera.width, world.camera.height) = (48, 36);
        let args = MethodArgs {
            photons: Some(1 << 18),
            ..Default::default()
        };
        let chosen = Chosen {
            plan: Box::new(Black),
            choice: choose(&world),
            check: true,
            fallback: Some(Method::Reference.imp().plan(&world, &args).unwrap()),
        };
        let store = crate::bake::store::ArtifactStore::new(std::env::temp_dir());
        let gpu = super::super::local::LocalGpu::default();
        let env = Env {
            progress: &|_, _| {},
            keep_going: &|| true,
            gpu: &gpu,
            store: &store,
        };
        let f = chosen.frames(&world, &env).unwrap();
        assert_eq!(f.made_by, Some(Method::Reference));
        let caustic: f32 = f.get(Component::Caustics).pixels.iter().map(|p| p.x).sum();
        assert!(caustic > 0.0, "the reference's caustic");
        let s = f.statistics.as_ref().unwrap();
        assert!(s["check"]["error"].as_f64().unwrap() > 0.5, "{s}");
        assert_eq!(s["auto"]["fell_back"]["to"], "reference", "{s}");
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        assert!(f.warnings[0].contains("made by the reference instead"));
    }

    /// Water: the water method, from under the surface and from above (the reference took the
    /// view from above until the water method drew the light the body's open sides let in).
    #[test]
    fn water_is_rendered_by_the_water_method_from_both_sides_of_the_surface() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let mut w = crate::scene::load_scene_file(&dir.join("pool-noon.json"), &Default::default())
            .unwrap();
        let from = |w: &mut World, eye: [f32; 3]| {
            w.camera.eye = glam::Vec3::from(eye);
            choose(w).method
        };
        assert_eq!(from(&mut w, [0.3, -0.25, 0.6]), Method::Water);
        assert_eq!(from(&mut w, [0.3, 1.5, 0.6]), Method::Water);
    }
}
