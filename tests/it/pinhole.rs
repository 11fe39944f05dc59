//! Method `pinhole` (Wand and Straßer 2003): against the stored reference on the mirror ring
//! under the sun-and-sky map, under the sky alone, under a directional and a spot light, the
//! four sampling strategies with and without curvature filtering, a ring moved rigidly (the
//! same pattern, the caustic moved with it), the reflecting cup's caustics on itself, chrome
//! Suzanne (glTF) with and without shadows, light refracted by an open wavy glass sheet (one
//! interface, the paper's §5) against a reference rendered in the test, and bad parameters.
//!
//! Sized for CI: 96 × 96 frames on lavapipe; the stored references were rendered with
//! `--photons 8000000 --spp 8` at that size (tests/data/reference/README.md).

use crate::support::{caustica, gpu, images, scenes};
use caustica::frame::Frame;
use caustica::reference::compare;
use caustica::reference::{self, ReferenceParams};
use caustica::render::PinholeLayer;
use caustica::render::pinhole::{PinholeParams, Strategy};
use caustica::scene::{Camera, Light, Material, Mesh, Object, Part, World, shapes};
use caustica::trace::Accel;
use glam::{Mat4, Vec3};
use std::sync::Arc;

const SIZE: u32 = 96;

fn sized(name: &str) -> World {
    let mut w = scenes::load(name);
    w.camera.width = SIZE;
    w.camera.height = SIZE;
    w
}

fn caustics(world: &World, p: &PinholeParams) -> Frame {
    let layer = PinholeLayer::build(world, p).unwrap();
    let out = gpu::renderer()
        .render_pinhole(world, &Default::default(), &layer)
        .unwrap();
    out.caustics.expect("a caustics layer")
}

/// Relative L1 (3×3 blur) and flux ratio of `a` against `b` on the floor.
fn error(world: &World, a: &Frame, b: &Frame) -> (f32, f32) {
    let mask = compare::object_mask(world, &Accel::build(world), "floor");
    let e = compare::compare(a, b, &mask);
    (e.rel_l1, e.flux_ratio)
}

#[test]
fn both_ring_scenes_agree_with_the_reference_at_the_default_settings() {
    for (scene, stored, max_l1) in [
        ("mirror-ring-env", "mirror-ring-env.caustics.8M.exr", 0.15),
        ("mirror-ring-sky", "mirror-ring-sky.caustics.8M.exr", 0.15),
    ] {
        let w = sized(scene);
        let img = caustics(&w, &PinholeParams::default());
        let (l1, flux) = error(&w, &img, &images::stored_reference(stored));
        eprintln!("{scene}: rel L1 {l1:.4}, flux ratio {flux:.4}");
        assert!(l1 < max_l1, "{scene}: rel L1 {l1}");
        assert!((0.95..1.05).contains(&flux), "{scene}: flux ratio {flux}");
    }
}

#[test]
fn delta_lights_far_and_near_agree_with_the_reference() {
    // The directional light as a sun disc in the map; the spot light 1 m from the ring per
    // point (its own direction, distance and irradiance at each point).
    for (scene, stored) in [
        ("mirror-ring", "mirror-ring.caustics.8M.exr"),
        ("mirror-ring-spot", "mirror-ring-spot.caustics.8M.exr"),
    ] {
        let w = sized(scene);
        let img = caustics(&w, &PinholeParams::default());
        let (l1, flux) = error(&w, &img, &images::stored_reference(stored));
        eprintln!("{scene}: rel L1 {l1:.4}, flux ratio {flux:.4}");
        assert!(l1 < 0.25, "{scene}: rel L1 {l1}");
        assert!((0.85..1.05).contains(&flux), "{scene}: flux ratio {flux}");
    }
}

#[test]
fn shadows_take_the_light_the_ring_and_table_block_and_no_more() {
    // Shadowed, a receiver only sees points with nothing between them and the points only
    // reflect sky they see. On the ring that removes a few percent (light that would come from
    // below the table or through the ring); the pass is split into draws so that llvmpipe's
    // cap on loop iterations per invocation does not end the loop over points early (it used
    // to keep 29 %).
    let w = sized("mirror-ring-env");
    let p = |shadows| PinholeParams {
        samples: 500,
        shadows,
        ..Default::default()
    };
    let (open, shadowed) = (caustics(&w, &p(false)), caustics(&w, &p(true)));
    let (_, kept) = error(&w, &shadowed, &open);
    eprintln!("shadowed / unshadowed flux {kept:.4}");
    assert!((0.9..0.99).contains(&kept), "shadowing kept {kept}");
    let darker = shadowed
        .pixels
        .iter()
        .zip(&open.pixels)
        .all(|(s, o)| s.x <= o.x * 1.0001 + 1e-6);
    assert!(darker, "a shadowed pixel is brighter than unshadowed");
}

#[test]
fn a_pass_the_adapter_ends_early_is_drawn_again() {
    // Told that the adapter has no cap on loop iterations, the renderer draws all 1000 shadowed
    // points at once, which llvmpipe ends early (40 % of the light lost at 48²); the alpha
    // the pass reports that in makes the renderer draw the frame again in smaller draws.
    let mut w = sized("mirror-ring-env");
    w.camera.width = 48;
    w.camera.height = 48;
    let p = PinholeParams {
        samples: 1000,
        shadows: true,
        // Unclustered: every pixel takes every point.
        cluster: 1,
        ..Default::default()
    };
    let layer = PinholeLayer::build(&w, &p).unwrap();
    let ctx = gpu::context();
    assert!(
        ctx.loop_budget() < u32::MAX,
        "this test needs llvmpipe (lavapipe), as CI has"
    );
    let mut r = caustica::render::Renderer::new(ctx).unwrap();
    let opts = Default::default();
    let normal = r
        .render_pinhole(&w, &opts, &layer)
        .unwrap()
        .caustics
        .unwrap();
    r.set_loop_budget(Some(u32::MAX));
    let redrawn = r
        .render_pinhole(&w, &opts, &layer)
        .unwrap()
        .caustics
        .unwrap();
    let (l1, flux) = error(&w, &redrawn, &normal);
    assert!(
        l1 < 1e-3 && (flux - 1.0).abs() < 1e-3,
        "redrawn: {l1} {flux}"
    );
}

#[test]
fn every_strategy_renders_and_filtering_removes_the_aliasing() {
    // The sun covers 1/8000 of the map: without filtering 300 points give a scatter of spots,
    // with it a caustic much closer to the reference.
    let w = sized("mirror-ring-env");
    let reference = images::stored_reference("mirror-ring-env.caustics.8M.exr");
    for s in Strategy::ALL {
        let p = |filter| PinholeParams {
            samples: 300,
            strategy: s,
            filter,
            ..Default::default()
        };
        let (filtered, _) = error(&w, &caustics(&w, &p(true)), &reference);
        let (aliased, _) = error(&w, &caustics(&w, &p(false)), &reference);
        eprintln!("{s:?}: rel L1 filtered {filtered:.3}, not filtered {aliased:.3}");
        assert!(
            filtered < 0.6 && aliased > 1.5 * filtered,
            "{s:?}: {filtered} vs {aliased}"
        );
    }
}

#[test]
fn a_gltf_chrome_object_needs_its_shadows() {
    // Suzanne (glTF) as a mirror on the table: much of her underside reflects the table's
    // direction, and without shadows those points light the floor with sky they cannot see.
    let w = sized("chrome-suzanne");
    let reference = images::stored_reference("chrome-suzanne.caustics.8M.exr");
    let mask = compare::object_mask(&w, &Accel::build(&w), "table");
    let p = |shadows| PinholeParams {
        shadows,
        ..Default::default()
    };
    let open = compare::compare(&caustics(&w, &p(false)), &reference, &mask);
    let shadowed = compare::compare(&caustics(&w, &p(true)), &reference, &mask);
    eprintln!(
        "chrome-suzanne: unshadowed rel L1 {:.4} flux {:.4}; shadowed {:.4} {:.4}",
        open.rel_l1, open.flux_ratio, shadowed.rel_l1, shadowed.flux_ratio
    );
    assert!(open.flux_ratio > 1.2, "unshadowed {open:?}");
    assert!(
        shadowed.rel_l1 < 0.22 && (0.88..1.05).contains(&shadowed.flux_ratio),
        "shadowed {shadowed:?}"
    );
}

/// A floor under a wavy glass sheet 0.6 m above it (open: one interface, ior 1.33, as a water
/// surface), a sun 20° off the vertical, the camera under the sheet looking at the floor.
fn wave_sheet_world() -> World {
    let (n, size, height) = (96u32, 2.4f32, 0.6f32);
    // Height a·sin(2πx/λx)·cos(2πz/λz) + a/2·sin(2π(x + z)/λd) and its gradient.
    let (a, lx, lz, ld) = (0.012f32, 0.45f32, 0.6f32, 0.33f32);
    let tau = std::f32::consts::TAU;
    let h = |x: f32, z: f32| {
        a * (tau * x / lx).sin() * (tau * z / lz).cos() + 0.5 * a * (tau * (x + z) / ld).sin()
    };
    let grad = |x: f32, z: f32| {
        let d = 0.5 * a * tau / ld * (tau * (x + z) / ld).cos();
        (
            a * tau / lx * (tau * x / lx).cos() * (tau * z / lz).cos() + d,
            -a * tau / lz * (tau * x / lx).sin() * (tau * z / lz).sin() + d,
        )
    };
    let mut sheet = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let x = size * (i as f32 / n as f32 - 0.5);
            let z = size * (j as f32 / n as f32 - 0.5);
            let (gx, gz) = grad(x, z);
            sheet.positions.push(Vec3::new(x, height + h(x, z), z));
            sheet.normals.push(Vec3::new(-gx, 1.0, -gz).normalize());
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            // Counter-clockwise seen from above (+Y): the normals face up.
            sheet.indices.push([v, v + n + 1, v + 1]);
            sheet.indices.push([v + 1, v + n + 1, v + n + 2]);
        }
    }
    let part = |mesh, material| Part {
        mesh: Arc::new(mesh),
        material,
    };
    World {
        name: "wave sheet".into(),
        camera: Camera {
            eye: Vec3::new(0.0, 0.42, 1.0),
            target: Vec3::new(0.0, 0.0, -0.1),
            up: Vec3::Y,
            fov_y: 50.0,
            width: SIZE,
            height: SIZE,
        },
        lights: vec![Light::Directional {
            direction: Vec3::new(0.34, -1.0, 0.1).normalize(),
            irradiance: Vec3::splat(3.0),
            angular_radius: 0.0,
        }],
        materials: vec![
            Material::Diffuse {
                albedo: Vec3::splat(0.6),
            },
            Material::Dielectric {
                ior: 1.33,
                absorption: Vec3::ZERO,
            },
        ],
        objects: vec![
            Object {
                name: "floor".into(),
                parts: vec![part(shapes::plane(8.0, 8.0), 0)],
                transform: Mat4::IDENTITY,
            },
            Object {
                name: "sheet".into(),
                parts: vec![part(sheet, 1)],
                transform: Mat4::IDENTITY,
            },
        ],
        warnings: vec![],
        water: vec![],
        media: vec![],
        has_ground: false,
    }
}

#[test]
fn an_open_glass_surface_refracts_its_caustic_onto_the_floor() {
    let w = wave_sheet_world();
    let accel = Accel::build(&w);
    let params = ReferenceParams {
        photons: 4_000_000,
        spp: 2,
        ..Default::default()
    };
    let (reference, _) = reference::render(&w, &accel, &params, &|_| true).unwrap();
    let p = PinholeParams {
        transmit: true,
        ..Default::default()
    };
    let layer = PinholeLayer::build(&w, &p).unwrap();
    assert_eq!(layer.stats.transmitting_parts, 1, "the sheet is open");
    let img = caustics(&w, &p);
    let (l1, flux) = error(&w, &img, &reference.caustics);
    eprintln!("wave sheet: rel L1 {l1:.4}, flux ratio {flux:.4}");
    assert!(
        l1 < 0.3 && (0.9..1.1).contains(&flux),
        "wave sheet: {l1} {flux}"
    );
    // The same sheet closed into a slab would have a second interface: only reflection then.
    let mut closed = w.clone();
    closed.objects[1].parts[0] = Part {
        mesh: Arc::new(shapes::cuboid(Vec3::new(2.4, 0.05, 2.4))),
        material: 1,
    };
    let slab = PinholeLayer::build(&closed, &p).unwrap();
    assert_eq!(slab.stats.transmitting_parts, 0);
    // Without `transmit` the open sheet only reflects: no light under it.
    let off = caustics(&w, &PinholeParams::default());
    let (_, kept) = error(&w, &off, &reference.caustics);
    assert!(kept < 0.1, "reflection alone: {kept}");
}

#[test]
fn a_moved_ring_carries_its_pattern_and_its_caustic() {
    // Ring and camera moved together over the uniform table: the ring's points are the same
    // points of its surface, and the frame is the same frame.
    let w = sized("mirror-ring-sky");
    let mut moved = w.clone();
    let shift = Vec3::new(0.3, 0.0, -0.2);
    let m = Mat4::from_translation(shift);
    let ring = scenes::object_index(&w, "ring");
    moved.objects[ring].transform = m * w.objects[ring].transform;
    moved.camera.eye += shift;
    moved.camera.target += shift;
    let p = PinholeParams::default();
    let a = PinholeLayer::build(&w, &p).unwrap();
    let b = PinholeLayer::build(&moved, &p).unwrap();
    assert_eq!(a.samples.len(), b.samples.len());
    for (x, y) in a.samples.iter().zip(&b.samples) {
        let (px, py) = (Vec3::from_slice(&x.position), Vec3::from_slice(&y.position));
        assert!((px + shift - py).length() < 1e-5, "{px} + {shift} vs {py}");
        assert_eq!(x.normal, y.normal);
    }
    // Turned as well, the ring keeps its clusters: the same points, the same representatives.
    let mut turned = moved.clone();
    turned.objects[ring].transform = Mat4::from_rotation_y(0.7) * moved.objects[ring].transform;
    let c = PinholeLayer::build(&turned, &p).unwrap();
    assert!(a.clusters.len() > 1);
    let ranges = |l: &PinholeLayer| l.clusters.iter().map(|c| c.range).collect::<Vec<_>>();
    assert_eq!(ranges(&a), ranges(&c));
    for (x, y) in a.samples.iter().zip(&c.samples) {
        assert_eq!(
            x.position[3], y.position[3],
            "the same point in the same place"
        );
    }
    let (fa, fb) = (caustics(&w, &p), caustics(&moved, &p));
    let (l1, flux) = error(&w, &fb, &fa);
    assert!(
        l1 < 0.02 && (flux - 1.0).abs() < 0.01,
        "moved frame: {l1} {flux}"
    );
}

#[test]
fn the_cup_focuses_light_into_itself_without_hot_spots() {
    let w = sized("reflecting-cup");
    let img = caustics(&w, &PinholeParams::default());
    let reference = images::stored_reference("reflecting-cup.caustics.8M.exr");
    let mask = compare::object_mask(&w, &Accel::build(&w), "cup");
    let lit: Vec<f32> = img
        .pixels
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| p.x)
        .collect();
    let peak = |f: &Frame| {
        f.pixels
            .iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .map(|(p, _)| p.x)
            .fold(0.0f32, f32::max)
    };
    let e = compare::compare(&img, &reference, &mask);
    eprintln!(
        "cup: rel L1 {:.3}, flux {:.3}, peak {} vs {}",
        e.rel_l1,
        e.flux_ratio,
        peak(&img),
        peak(&reference)
    );
    assert!(
        lit.iter().any(|v| *v > 0.0),
        "the cup's floor gets caustics"
    );
    // No hot spot: the brightest pixel is not far above the reference's (3×3 blurred there).
    assert!(
        peak(&img) < 2.0 * peak(&reference),
        "{} vs {}",
        peak(&img),
        peak(&reference)
    );
    assert!(
        (0.5..1.5).contains(&e.flux_ratio),
        "flux ratio {}",
        e.flux_ratio
    );
}

#[test]
fn bad_parameters_are_refused_with_the_field_named() {
    let scene = scenes::path("mirror-ring-sky").display().to_string();
    let out_path = crate::support::temp_dir("pinhole-bad")
        .join("x.exr")
        .display()
        .to_string();
    for (args, needle) in [
        (&["--samples", "0"][..], "pinhole.samples"),
        (&["--samples", "1000000000"][..], "pinhole.samples"),
        (&["--sampling", "hexagonal"][..], "hexagonal"),
        (&["--sun-radius", "90"][..], "pinhole.sun_radius"),
        (&["--cluster", "0"][..], "pinhole.cluster"),
    ] {
        let mut all = vec!["render", &scene, "--method", "pinhole", "--out", &out_path];
        all.extend_from_slice(args);
        let out = caustica(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}
