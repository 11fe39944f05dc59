//! How close a dynamic CSL bake of the canonical glass sphere comes to the ground truth at light
//! directions that are no bake direction: the sphere is turned so that the scene's light
//! crosses icosahedron face `FACE` at its centre, near an edge midpoint and near a corner (a
//! sphere's caustic does not change when it turns about its centre, so one ground truth holds
//! for every direction). For each: the set interpolated from the bake, and optionally a static
//! bake made for exactly that direction, rendered on the CPU (caustics at 3×3 samples a pixel),
//! against Mitsuba 3's particle tracer in the sphere's shadow (where the direct light is zero)
//! and against our 64 M-photon reference on the whole floor (relative L1 after a 3×3 blur, flux
//! ratio). Prints one line per case. From the repository root:
//!
//!     cargo run --release --example csl_accuracy -- BAKE.csld [FACE] [--static GRID] [--sweep]
//!
//! `--sweep`: instead of the three directions, the light from corner 0 of the face towards its
//! centre and towards the midpoint of edge (0, 1), in eight steps each.

use caustica::bake::csl::dynamic::{DynamicSet, Icosphere};
use caustica::bake::csl::{CslParams, CslSet, bake_csl};
use caustica::encode::decode_frame;
use caustica::frame::Frame;
use caustica::reference::compare;
use caustica::render::csl::eval;
use caustica::scene::{Light, World};
use caustica::trace::Accel;
use glam::{Mat4, Quat, Vec3};

fn frame(path: &str) -> Result<Frame, Box<dyn std::error::Error>> {
    Ok(decode_frame(&std::fs::read(path)?)?)
}

fn light(world: &World) -> (Vec3, Vec3) {
    match &world.lights[0] {
        Light::Directional {
            direction,
            irradiance,
            ..
        } => (direction.normalize(), *irradiance),
        _ => panic!("the scene's first light is directional"),
    }
}

/// `world` with the glass turned so that the light travels along `dir` in its rigid frame.
fn turned(world: &World, dir: Vec3) -> World {
    let mut w = world.clone();
    let (l, _) = light(world);
    let oi = w.objects.iter().position(|o| o.name == "glass").unwrap();
    let (s, _, t) = w.objects[oi].transform.to_scale_rotation_translation();
    let rot = Quat::from_rotation_arc(dir.normalize(), l);
    w.objects[oi].transform = Mat4::from_scale_rotation_translation(s, rot, t);
    w
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let bake = args
        .first()
        .ok_or("usage: csl_accuracy BAKE.csld [FACE] [--static GRID] [--sweep]")?;
    let face: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(29);
    let static_grid: Option<u32> = args
        .iter()
        .position(|a| a == "--static")
        .and_then(|i| args.get(i + 1))
        .map(|g| g.parse())
        .transpose()?;
    let d = DynamicSet::from_bytes(&std::fs::read(bake)?)?;
    let w0 = caustica::scene::load_scene_file(
        "scenes/glass-sphere-directional.json".as_ref(),
        &Default::default(),
    )?;
    let mitsuba = frame("tests/data/mitsuba/sphere-directional-ptracer-1024spp.exr")?;
    let reference = frame("tests/data/reference/glass-sphere-directional.caustics.64M.exr")?;
    let ico = Icosphere::new(d.subdivisions);
    let f = ico.faces[face];
    let v = |k: usize| ico.vertices[f[k] as usize];
    let mut cases = vec![
        ("face centre".to_string(), (v(0) + v(1) + v(2)).normalize()),
        (
            "near an edge midpoint".to_string(),
            (v(0) * 0.49 + v(1) * 0.49 + v(2) * 0.02).normalize(),
        ),
        (
            "near a corner".to_string(),
            (v(0) * 0.9 + v(1) * 0.05 + v(2) * 0.05).normalize(),
        ),
    ];
    if args.iter().any(|a| a == "--sweep") {
        // From corner 0 towards the face centre and towards the midpoint of edge (0, 1).
        let (centre, mid) = ((v(0) + v(1) + v(2)).normalize(), (v(0) + v(1)).normalize());
        cases.clear();
        for (towards, end) in [("centre", centre), ("edge midpoint", mid)] {
            for t in [0.0f32, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0] {
                let dir = v(0).lerp(end, t).normalize();
                cases.push((format!("towards the {towards}, t = {t}"), dir));
            }
        }
    }
    for (name, dir) in cases {
        let world = turned(&w0, dir);
        let oi = world
            .objects
            .iter()
            .position(|o| o.name == "glass")
            .unwrap();
        let local = world.objects[oi].to_rigid_frame(light(&world).0);
        let nearest = ico
            .vertices
            .iter()
            .map(|b| b.angle_between(local).to_degrees())
            .fold(f32::INFINITY, f32::min);
        let accel = Accel::build(&world);
        let blockers = Accel::build_with(&world, |i| i != oi, obvhs::BvhBuildParams::fast_build());
        let shadow = compare::shadow_mask(&world, &accel, "floor", "glass", light(&world).0);
        let floor = compare::object_mask(&world, &accel, "floor");
        let render = |set: &CslSet| {
            let csls = set.to_world(world.objects[oi].rigid_transform());
            eval::render_caustics(&world, &accel, &blockers, &csls, light(&world).1, 3)
        };
        let report = |what: &str, set: &CslSet| {
            let img = render(set);
            let s = compare::compare(&img, &mitsuba, &shadow);
            let a = compare::compare(&img, &reference, &floor);
            println!(
                "{name} ({nearest:.1}° from the nearest bake direction), {what}: shadow vs Mitsuba \
                 rel. L1 {:.3} flux {:.3} ({} px); floor vs 64M reference rel. L1 {:.3} flux {:.3}",
                s.rel_l1, s.flux_ratio, s.pixels, a.rel_l1, a.flux_ratio
            );
        };
        let t = std::time::Instant::now();
        let set = d.interpolate(local);
        let took = t.elapsed();
        report(
            &format!("interpolated ({} CSLs, {took:.0?})", set.csls.len()),
            &set,
        );
        if let Some(grid) = static_grid {
            let params = CslParams {
                grid,
                ..CslParams::paper()
            };
            // The bake takes the light in the object's rigid frame, as a set keeps it.
            let s = bake_csl(&world, "glass", local, &params, &|_| true)?;
            report(&format!("static bake, grid {grid}"), &s);
        }
    }
    Ok(())
}
