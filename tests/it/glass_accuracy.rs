//! Glass under any light, and glass no method was tuned on. The canonical glass sphere under 20
//! directional lights drawn at random (fixed seed) over the sky down to 20° above the horizon
//! (`reference::sweep`, the first 20 of `examples/glass_sweep.rs`'s 50), each seen from above
//! its shadow at 128², against stored references of its caustics (tests/data/reference/
//! README.md) in the sphere's shadow: a static `csl` bake for exactly each direction (CI size:
//! 640² rays) and, at every fourth direction, `photons`. A non-convex glass lump (nine spikes,
//! `scenes/glass-spiky.json`): `transport` within 0.20 in its shadow, `csl` (which scrambles
//! it) flagged by a self-check within 2× of its measured error. A dense smooth glass mesh
//! (81,920 triangles with a scanner's grain, `scenes/glass-dense.json`): `photons` within 0.10
//! and 3 % in its shadow.

use crate::support::{gpu, images, scenes};
use caustica::bake::csl::{CslParams, bake_csl};
use caustica::bake::transport::{TransportParams, bake_transport};
use caustica::frame::Frame;
use caustica::methods::check::{CheckParams, check_caustics};
use caustica::reference::compare::{self, Comparison};
use caustica::reference::sweep;
use caustica::render::Renderer;
use caustica::render::csl::eval;
use caustica::render::photons::{PhotonsLayer, PhotonsParams};
use caustica::render::transport::{TransportLayer, volumes};
use caustica::scene::World;
use caustica::trace::Accel;

const DIRECTIONS: usize = 20;
const SEED: u64 = 56;
const SIZE: u32 = 128;

/// Each direction's scene, its stored reference and the shadow mask.
fn cases() -> Vec<(sweep::SweepCase, World, Frame, Vec<bool>)> {
    let base = scenes::load("glass-sphere-directional");
    sweep::directions(DIRECTIONS, SEED)
        .into_iter()
        .enumerate()
        .map(|(i, case)| {
            let world = sweep::lit_from(&base, "glass", case.direction, SIZE);
            let accel = Accel::build(&world);
            let mask = compare::shadow_mask(&world, &accel, "floor", "glass", case.direction);
            let reference = images::stored_reference(&format!(
                "sweep/glass-sphere-sweep-{i:02}.caustics.8M.exr"
            ));
            (case, world, reference, mask)
        })
        .collect()
}

/// A static CSL bake of `object` for `world`'s directional light, and its caustics evaluated on
/// the CPU (3×3 samples a pixel) with the other objects' shadows: the frame and the CSL count.
fn static_csl(world: &World, object: &str, params: &CslParams) -> (Frame, usize) {
    let oi = scenes::object_index(world, object);
    let (dir, irradiance) = scenes::directional_light(world);
    let local = world.objects[oi].to_rigid_frame(dir);
    let set = bake_csl(world, object, local, params, &|_| true).expect("bakes");
    let csls = set.to_world(world.objects[oi].rigid_transform());
    let img = eval::render_caustics(
        world,
        &Accel::build(world),
        &scenes::blockers(world, oi),
        &csls,
        irradiance,
        3,
    );
    (img, set.csls.len())
}

/// `photons`' caustics of `world`: 2 frames of 262,144 photons.
fn photons(renderer: &mut Renderer, world: &World) -> Frame {
    let params = PhotonsParams {
        photons: 1 << 18,
        frames: 2,
        ..Default::default()
    };
    let layer = PhotonsLayer::build(world, &params);
    let out = renderer
        .render_photons(world, &Default::default(), &layer)
        .expect("renders");
    out.caustics.expect("caustics")
}

fn line(i: usize, case: &sweep::SweepCase, what: &str, c: &Comparison) -> String {
    format!(
        "{i:2} elevation {:5.1}° azimuth {:6.1}°: {what} {:.3} / {:.3} ({} px)",
        case.elevation_deg, case.azimuth_deg, c.rel_l1, c.flux_ratio, c.pixels
    )
}

/// A static bake for exactly each direction (CI size: 640² rays, 128², CPU evaluation): within
/// the 0.12 relative L1 and 4 % of the flux in the shadow at every direction, and 0.03
/// on average. Measured with rings and the fan of each bundle's axis: 0.011–0.071 (mean
/// 0.023), flux 0.989–1.009, the worst at 87°. With rings, before the fan: 0.014–0.066 below
/// 80° and 0.172 / 1.011 at 87° (mean 0.037); before the rings: 0.039–0.084 below 80°, 0.171 /
/// 1.072 at 87° (both fail).
#[test]
fn a_static_csl_bake_matches_the_reference_at_every_direction_of_the_sweep() {
    let params = CslParams {
        grid: 640,
        ..CslParams::paper()
    };
    let mut failures = Vec::new();
    let mut errors = Vec::new();
    for (i, (case, world, reference, mask)) in cases().into_iter().enumerate() {
        let (img, count) = static_csl(&world, "glass", &params);
        let c = compare::compare(&img, &reference, &mask);
        let l = line(i, &case, &format!("static csl ({count} CSLs)"), &c);
        eprintln!("{l}");
        errors.push(c.rel_l1);
        if c.rel_l1 > 0.12 || (c.flux_ratio - 1.0).abs() > 0.04 {
            failures.push(l);
        }
    }
    let mean = errors.iter().sum::<f32>() / errors.len() as f32;
    eprintln!("mean relative L1: {mean:.3}");
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(mean <= 0.03, "mean relative L1: {mean}");
}

/// `photons` (2 frames of 262,144 photons) at every fourth direction: within 0.10 relative L1
/// and 3 % of the flux in the shadow.
#[test]
fn photons_match_the_reference_at_every_fourth_direction_of_the_sweep() {
    let mut renderer = gpu::renderer();
    let mut failures = Vec::new();
    for (i, (case, world, reference, mask)) in cases().into_iter().enumerate().step_by(4) {
        let c = compare::compare(&photons(&mut renderer, &world), &reference, &mask);
        let l = line(i, &case, "photons", &c);
        eprintln!("{l}");
        if c.rel_l1 > 0.10 || (c.flux_ratio - 1.0).abs() > 0.03 {
            failures.push(l);
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// The spiky lump at 128² under its scene's sun, its stored reference and its shadow.
fn spiky() -> (World, Frame, Vec<bool>) {
    let mut world = scenes::load("glass-spiky");
    world.camera.width = SIZE;
    world.camera.height = SIZE;
    let (dir, _) = scenes::directional_light(&world);
    let mask = compare::shadow_mask(&world, &Accel::build(&world), "floor", "spiky", dir);
    let reference = images::stored_reference("glass-spiky.caustics.16M.exr");
    (world, reference, mask)
}

/// `transport` keeps a non-convex lump's caustic (its bake splits samples by path signature):
/// within 0.20 relative L1 and 6 % of the flux in its shadow (measured at 256² on the GPU:
/// 0.161 / 0.957).
#[test]
fn transport_renders_a_non_convex_glass_lump_within_a_fifth() {
    let (world, reference, mask) = spiky();
    let oi = scenes::object_index(&world, "spiky");
    let table = bake_transport(&world, "spiky", &TransportParams::paper(), &|_| true).unwrap();
    let layer = TransportLayer::build(&world, &[(oi, &table)], volumes::DEFAULT_LINE_POINTS)
        .expect("volumes");
    let accel = Accel::build(&world);
    let img = volumes::render_caustics(
        &world,
        &accel,
        Some(&scenes::blockers(&world, oi)),
        &layer.volumes,
    );
    let c = compare::compare(&img, &reference, &mask);
    eprintln!("spiky lump, transport: {c:?}");
    assert!(
        c.rel_l1 <= 0.20 && (c.flux_ratio - 1.0).abs() <= 0.06,
        "{c:?}"
    );
}

/// `csl` cannot model the lump (its bundles mix the light of several spikes), but says so: the
/// self-check of its frame reads the error measured against the reference in the lump's shadow
/// within 2×, over the 0.10 at which a render warns and names another method.
#[test]
fn csl_on_a_non_convex_glass_lump_is_flagged_by_its_self_check() {
    let (world, reference, mask) = spiky();
    let params = CslParams {
        grid: 512,
        ..CslParams::paper()
    };
    let (img, count) = static_csl(&world, "spiky", &params);
    let measured = compare::compare(&img, &reference, &mask);
    let check = check_caustics(&world, &img, None, &CheckParams::default(), &|| true)
        .expect("checks")
        .expect("caustic light on the receivers");
    eprintln!("spiky lump, csl ({count} CSLs): measured {measured:?}, self-check {check:?}");
    assert!(measured.rel_l1 > 0.2, "csl fits the lump now: {measured:?}");
    assert!(check.error > 0.10, "{check:?}");
    assert!(
        check.error <= 2.0 * measured.rel_l1 && measured.rel_l1 <= 2.0 * check.error,
        "measured {measured:?}, self-check {check:?}"
    );
}

/// `photons` on a dense smooth glass mesh (81,920 triangles whose smooth normals wobble by a
/// few degrees from vertex to vertex, as a scan's do): within 0.10 relative L1 and 3 % of the
/// flux in its shadow, 128², 2 frames of 262,144 photons (measured at 256²: 0.033–0.040 /
/// 0.998–1.001 at three random directions, `examples/glass_sweep.rs`).
#[test]
fn photons_render_a_dense_smooth_glass_mesh_within_a_tenth() {
    let mut world = scenes::load("glass-dense");
    world.camera.width = SIZE;
    world.camera.height = SIZE;
    let (dir, _) = scenes::directional_light(&world);
    let mask = compare::shadow_mask(&world, &Accel::build(&world), "floor", "dense", dir);
    let reference = images::stored_reference("glass-dense.caustics.16M.exr");
    let c = compare::compare(&photons(&mut gpu::renderer(), &world), &reference, &mask);
    eprintln!("dense mesh, photons: {c:?}");
    assert!(
        c.rel_l1 <= 0.10 && (c.flux_ratio - 1.0).abs() <= 0.03,
        "{c:?}"
    );
}
