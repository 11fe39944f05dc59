//! Objects under a sun-and-sky map stand on their shadows: the map's sun and the rest of its
//! sky are occluded in `direct`'s light (and so in every GPU method's frame), and `auto`'s
//! whole frame matches the reference in and around the shadow and over the caustic. A mirror
//! (the ring) and a glass object (the canonical sphere) under `scenes/assets/sky-sun.hdr`,
//! against stored references (tests/data/reference/README.md), at 96².

use crate::support::{gpu, images, scenes, temp_dir};
use caustica::frame::{Component, Frame};
use caustica::methods::local::LocalGpu;
use caustica::methods::{ArtifactStore, Env, Frames, Method, MethodArgs};
use caustica::reference::compare;
use caustica::scene::World;
use caustica::trace::Accel;
use glam::Vec3;

const SIZE: u32 = 96;

fn sized(name: &str) -> World {
    let mut w = scenes::load(name);
    w.camera.width = SIZE;
    w.camera.height = SIZE;
    w
}

fn render(world: &World, method: Method) -> Frames {
    gpu::ensure_runtime_dir();
    let gpu = LocalGpu::default();
    let store = ArtifactStore::new(temp_dir("env-shadows"));
    let env = Env {
        progress: &|_, _| {},
        keep_going: &|| true,
        gpu: &gpu,
        store: &store,
    };
    let plan = method
        .imp()
        .plan(world, &MethodArgs::default())
        .expect("plans");
    caustica::methods::render(plan.as_ref(), world, &env, None).expect("renders")
}

/// Floor pixels in the sun's shadow of `occluder` and up to 4 pixels around it (the
/// penumbra and the lit floor at its edge).
fn in_and_around_the_shadow(world: &World, occluder: &str) -> Vec<bool> {
    let accel = Accel::build(world);
    let sun = Vec3::from_array(caustica::scene::random::repository_sun().map(|c| c as f32));
    let umbra = compare::shadow_mask(world, &accel, "floor", occluder, -sun);
    let floor = compare::object_mask(world, &accel, "floor");
    assert!(
        umbra.iter().filter(|m| **m).count() > 20,
        "the shadow is in view"
    );
    let (w, h) = (SIZE as i32, SIZE as i32);
    let near = |x: i32, y: i32| {
        (-4..=4).any(|dy| {
            (-4..=4).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                (0..w).contains(&u) && (0..h).contains(&v) && umbra[(v * w + u) as usize]
            })
        })
    };
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| floor[(y * w + x) as usize] && near(x, y))
        .collect()
}

/// Floor pixels where the reference's caustic is at least a tenth of its bright end (the
/// 99th percentile).
fn the_caustic(world: &World, caustics: &Frame) -> Vec<bool> {
    let floor = compare::object_mask(world, &Accel::build(world), "floor");
    let blurred = compare::blur3(caustics);
    let mut lum: Vec<f32> = blurred.pixels.iter().map(|p| p.element_sum()).collect();
    lum.sort_by(f32::total_cmp);
    let level = lum[lum.len() * 99 / 100] * 0.1;
    blurred
        .pixels
        .iter()
        .zip(&floor)
        .map(|(p, f)| *f && p.element_sum() >= level)
        .collect()
}

fn assert_within(what: &str, c: compare::Comparison, l1: f32, flux: f32) {
    eprintln!(
        "{what}: relative L1 {:.3}, flux {:.3} over {} pixels",
        c.rel_l1, c.flux_ratio, c.pixels
    );
    assert!(c.rel_l1 <= l1, "{what}: relative L1 {}", c.rel_l1);
    assert!(
        (c.flux_ratio - 1.0).abs() <= flux,
        "{what}: flux {}",
        c.flux_ratio
    );
}

/// `direct`'s direct light in and around the sun shadow of a mirror and of a glass object is
/// within 5 % relative L1 of the reference's (it was 0.255 with the sky unshadowed, 3.7× the
/// light in the umbra).
#[test]
fn direct_light_under_a_sky_map_casts_the_suns_shadow() {
    for (name, occluder) in [("mirror-ring-env", "ring"), ("glass-sphere-sky", "glass")] {
        let world = sized(name);
        let mask = in_and_around_the_shadow(&world, occluder);
        let frames = render(&world, Method::Direct);
        let truth = images::stored_reference(&format!("{name}.direct.16M.exr"));
        let c = compare::compare(frames.get(Component::Direct), &truth, &mask);
        assert_within(
            &format!("{name}: direct light by the shadow"),
            c,
            0.05,
            0.05,
        );
    }
}

/// `auto`'s whole frame of both objects under the map: within 15 % relative L1 and 10 % flux
/// of the reference's total in and around the shadow and over the caustic.
#[test]
fn autos_frame_under_a_sky_map_stands_on_its_shadow_and_caustic() {
    for (name, occluder) in [("mirror-ring-env", "ring"), ("glass-sphere-sky", "glass")] {
        let world = sized(name);
        let frames = render(&world, Method::Auto);
        let total = images::stored_reference(&format!("{name}.total.16M.exr"));
        let caustics = images::stored_reference(&format!("{name}.caustics.16M.exr"));
        let shadow = in_and_around_the_shadow(&world, occluder);
        let caustic = the_caustic(&world, &caustics);
        let made = frames.get(Component::Total);
        assert_within(
            &format!("{name}: auto's total by the shadow"),
            compare::compare(made, &total, &shadow),
            0.15,
            0.10,
        );
        assert_within(
            &format!("{name}: auto's total over the caustic"),
            compare::compare(made, &total, &caustic),
            0.15,
            0.10,
        );
    }
}
