//! The render side of the light transport tables (Iwasaki et al. 2005 §5.1–5.2): lookup and interpolation
//! against the sphere in closed form, flux conservation of the illumination volumes, the GPU
//! pass against the CPU evaluation (diffuse and glossy receivers, an occluder), rigid motion
//! with no new bake, and the caustics against the reference for the directional, spot and
//! point lights.
//!
//! The sphere is the canonical one with 96 segments instead of 256 (4.8 k vertices instead of
//! 33 k: the same shape with smooth normals, and a bake a test can afford); the stored
//! references were rendered with 256.

use crate::support::{gpu, images, scenes};
use caustica::bake::transport::{TransportParams, TransportTable, bake_transport, table_vertices};
use caustica::frame::Frame;
use caustica::reference::compare;
use caustica::render::TransportLayer;
use caustica::render::transport::volumes;
use caustica::scene::World;
use caustica::trace::Accel;
use caustica::trace::optics::{fresnel_dielectric, refract};
use glam::Vec3;

/// Scene `name` with `segments` instead of 256 in its sphere, then edited by `edit`.
fn sphere_scene(name: &str, segments: u32, edit: impl Fn(String) -> String) -> World {
    let text = scenes::text(name);
    let text = text.replace("\"segments\": 256", &format!("\"segments\": {segments}"));
    scenes::parse(&edit(text))
}

fn bake(world: &World, rings: u32, azimuths: u32) -> TransportTable {
    let params = TransportParams {
        rings,
        azimuths,
        ..TransportParams::paper()
    };
    bake_transport(world, "glass", &params, &|_| true).unwrap()
}

/// The CPU caustics layer of `world` from `table`.
fn cpu_caustics(world: &World, table: &TransportTable) -> (Frame, TransportLayer) {
    let oi = scenes::object_index(world, "glass");
    let layer = TransportLayer::build(world, &[(oi, table)], volumes::DEFAULT_LINE_POINTS).unwrap();
    let accel = Accel::build(world);
    let blockers = scenes::blockers(world, oi);
    let img = volumes::render_caustics(world, &accel, Some(&blockers), &layer.volumes);
    (img, layer)
}

fn gpu_caustics(world: &World, layer: &TransportLayer) -> Frame {
    let mut r = gpu::renderer();
    let out = r
        .render_transport(world, &Default::default(), layer)
        .unwrap();
    out.caustics.expect("a caustics layer")
}

fn floor_mask(world: &World) -> Vec<bool> {
    compare::object_mask(world, &Accel::build(world), "floor")
}

/// Interpolated lookups (four nearest sampling directions, bilinear position and
/// transmittance, slerped direction) against Snell + Fresnel through a sphere in closed form,
/// at random incident directions: a lookup at a sampling direction returns its sample, the
/// errors are small at the paper's 129 directions and shrink with finer sampling.
#[test]
fn lookup_interpolates_the_sphere_in_closed_form() {
    let world = sphere_scene("glass-sphere-directional", 32, |s| s);
    let verts = table_vertices(&world, world.object("glass").unwrap());
    let mut means = Vec::new();
    for (rings, az) in [(8, 16), (16, 32)] {
        let table = bake(&world, rings, az);
        // At the sampling directions themselves: the stored samples.
        let p = table.params;
        for i in [0, verts.len() / 3, verts.len() - 1] {
            for j in [0, 5, p.directions() - p.azimuths as usize - 3] {
                let (phi, theta) = p.angles(j);
                let frame = caustica::bake::transport::tangent_frame(verts[i].normal);
                let w = caustica::bake::transport::sampling_direction(frame, phi, theta);
                let s = table.sample(i, j);
                let e = volumes::lookup(&table, i, &verts[i], w).unwrap();
                assert!((e.position - s.position).length() < 1e-4, "{i} {j}");
                assert!((e.direction - s.direction).length() < 1e-3, "{i} {j}");
                assert!(
                    (e.transmittance.x - s.transmittance).abs() < 1e-3,
                    "{i} {j}"
                );
            }
        }
        let mut rng = 0x2545_f491_u64;
        let mut rnd = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut ep, mut ed, mut et, mut n) = (0f32, 0f32, 0f32, 0);
        while n < 4000 {
            let i = (rnd() * verts.len() as f32) as usize % verts.len();
            let v = verts[i];
            let w = Vec3::new(rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0, rnd() * 2.0 - 1.0);
            let w = w.normalize_or(Vec3::Y);
            let nn = v.position.normalize();
            // Incidence up to 78° (the last ring is grazing, where nothing transmits).
            if w.dot(nn) > -0.2 {
                continue;
            }
            let Some(e) = volumes::lookup(&table, i, &v, w) else {
                panic!("vertex {i} normal {:?} w {w:?}: no exit", v.normal);
            };
            let d1 = refract(w, nn, 1.0 / 1.5).unwrap();
            let ct = -d1.dot(nn);
            let p2 = v.position + d1 * (2.0 * 0.5 * ct);
            let d2 = refract(d1, -p2.normalize(), 1.5).unwrap();
            let t = (1.0 - fresnel_dielectric(-w.dot(nn), 1.0 / 1.5))
                * (1.0 - fresnel_dielectric(ct, 1.5));
            ep += (e.position - p2).length();
            ed += (e.direction - d2).length();
            et += (e.transmittance.x - t).abs();
            n += 1;
        }
        let m = (ep / n as f32, ed / n as f32, et / n as f32);
        eprintln!(
            "{rings}×{az}: mean errors position {:.4} m, direction {:.4}, T {:.4}",
            m.0, m.1, m.2
        );
        means.push(m);
    }
    // 8 × 16 + 1: within 1 cm (a sphere of 0.5 m), 0.015 rad, 0.015.
    assert!(
        means[0].0 < 0.01 && means[0].1 < 0.015 && means[0].2 < 0.015,
        "{means:?}"
    );
    // Four times the directions: closer (measured: position 0.46×, direction 0.62×).
    assert!(
        means[1].0 < 0.6 * means[0].0 && means[1].1 < 0.75 * means[0].1,
        "{means:?}"
    );
    // From below the tangent plane: no light.
    let i = 0;
    assert!(volumes::lookup(&bake(&world, 8, 16), i, &verts[i], verts[i].normal).is_none());
}

/// Every volume's flux lands: integrating the footprint-averaged irradiance over cells that
/// tile the floor gives back S·mean(F) of every volume whose cross-section lies on it, to
/// rounding (the footprint evaluation integrates the piecewise linear field exactly).
#[test]
fn volumes_conserve_flux_on_a_plane() {
    let world = sphere_scene("glass-sphere-directional", 16, |s| s);
    let table = bake(&world, 8, 16);
    let sources = volumes::sources(&world.lights, 16);
    let (vols, stats) =
        volumes::build_volumes(&world, "glass", &table, &sources, None, &|| true).unwrap();
    assert!(stats.volumes > 50, "{stats:?}");
    let half = 4.0f32;
    let mut expect = 0.0f64;
    for v in &vols {
        if let Some(q) = v.cross_section(glam::DVec3::ZERO, glam::DVec3::Y)
            && q.iter()
                .all(|p| p.x.abs() < half as f64 && p.z.abs() < half as f64)
        {
            expect +=
                (v.flux_density.iter().map(|f| f.x).sum::<f32>() / 3.0 * v.source_area) as f64;
        }
    }
    assert!(
        expect > 0.5 * stats.flux.x as f64,
        "flux onto the floor {expect} of {stats:?}"
    );
    let cells = 64;
    let side = 2.0 * half / cells as f32;
    let mut got = 0.0f64;
    for cy in 0..cells {
        for cx in 0..cells {
            let (x0, z0) = (-half + cx as f32 * side, -half + cy as f32 * side);
            let fp = [
                Vec3::new(x0, 0.0, z0),
                Vec3::new(x0 + side, 0.0, z0),
                Vec3::new(x0 + side, 0.0, z0 + side),
                Vec3::new(x0, 0.0, z0 + side),
            ];
            let c = Vec3::new(x0 + 0.5 * side, 0.0, z0 + 0.5 * side);
            for v in &vols {
                if let Some(a) = v.arrival(c, Vec3::Y, Some(&fp)) {
                    got += (a.irradiance.x * side * side) as f64;
                }
            }
        }
    }
    eprintln!("flux on the floor: volumes {expect:.5} W, integrated {got:.5} W");
    assert!((got / expect - 1.0).abs() < 1e-3, "{got} vs {expect}");
}

/// The light the glass reflects (`build_reflection_volumes`, what the tables leave out): over
/// a sphere of radius r under a directional light of irradiance E it is E·πr²·2∫R(μ)μ dμ,
/// the Fresnel reflectance averaged over the lit disc (0.0918 for n = 1.5). The volumes'
/// corner fluxes must add up to it, to the mesh's approximation of the sphere.
#[test]
fn reflection_volumes_carry_the_fresnel_reflected_flux() {
    let world = sphere_scene("glass-sphere-directional", 96, |s| s);
    let sources = volumes::sources(&world.lights, 16);
    let (vols, stats) =
        volumes::build_reflection_volumes(&world, "glass", &sources, None, &|| true).unwrap();
    let n = 20_000;
    let mean_r: f64 = (0..n)
        .map(|k| {
            let mu = (k as f64 + 0.5) / n as f64;
            2.0 * mu * fresnel_dielectric(mu as f32, 1.0 / 1.5) as f64 / n as f64
        })
        .sum();
    let (r, e) = (0.5f64, 3.0f64);
    let expect = e * std::f64::consts::PI * r * r * mean_r;
    let got = stats.reflected_flux.x as f64;
    eprintln!("mean R {mean_r:.4}: reflected {got:.5} W, expected {expect:.5} W");
    assert!((0.09..0.094).contains(&mean_r), "{mean_r}");
    assert!((got / expect - 1.0).abs() < 0.01, "{got} vs {expect}");
    // Every mirror ray leaves from the glass, away from it.
    for v in &vols {
        for (e, d) in v.exits.iter().zip(&v.dirs) {
            let c = *e - Vec3::new(0.0, 0.58, 0.0);
            assert!(
                (c.length() - 0.5).abs() < 1e-3 && d.dot(c) >= -1e-4,
                "{v:?}"
            );
        }
    }
}

/// The GPU pass (transport.wgsl over the G-buffer) against the CPU evaluation of the same
/// volumes, on a diffuse floor, on a glossy floor, and with a box between the sphere and the
/// floor that must hide part of the caustic (and catch it on its top). Away from the focus the
/// two agree to a fraction of a percent; at the focus, which is narrower than a pixel, single
/// precision moves light between neighbouring pixels.
#[test]
fn gpu_pass_matches_the_cpu_evaluation() {
    let glossy = |s: String| {
        s.replace(
            r#""floor": {"type": "diffuse", "albedo": 0.6}"#,
            r#""floor": {"type": "glossy", "albedo": 0.4, "specular": 0.5, "roughness": 0.4}"#,
        )
    };
    let boxed = |s: String| {
        s.replace(
            r#"{"name": "floor","#,
            r#"{"name": "block", "shape": {"type": "box", "size": [0.3, 0.06, 0.3]}, "material": "floor",
              "transform": {"translation": [0.45, 0.03, 0.0]}},
             {"name": "floor","#,
        )
    };
    // A low camera among the beams: many volumes reach behind it and are cut at the plane
    // just in front of the eye.
    let inside = |s: String| {
        s.replace(
            r#""eye": [0, 3.2, 3.2], "target": [0.35, 0, 0]"#,
            r#""eye": [1.6, 0.35, 0.6], "target": [0.2, 0, 0]"#,
        )
    };
    let mut flux = Vec::new();
    for (name, edit) in [
        ("diffuse", &(|s| s) as &dyn Fn(String) -> String),
        ("glossy", &glossy),
        ("occluder", &boxed),
        ("camera among the beams", &inside),
    ] {
        let world = sphere_scene("glass-sphere-directional", 64, edit);
        let table = bake(&world, 8, 16);
        let (cpu, layer) = cpu_caustics(&world, &table);
        if name == "camera among the beams" {
            let cam = &world.camera;
            let (_, _, forward) = cam.basis();
            let behind = layer
                .volumes
                .iter()
                .filter(|v| {
                    (0..3)
                        .any(|i| (v.exits[i] + v.dirs[i] * v.length - cam.eye).dot(forward) <= 0.0)
                })
                .count();
            eprintln!(
                "{behind} of {} volumes reach behind the eye",
                layer.volumes.len()
            );
            assert!(behind > 100, "{behind}");
        }
        let gpu = gpu_caustics(&world, &layer);
        let mask = floor_mask(&world);
        let c = compare::compare(&gpu, &cpu, &mask);
        eprintln!("{name}: GPU vs CPU {c:?}");
        assert!(
            c.rel_l1 < 0.1 && (c.flux_ratio - 1.0).abs() < 0.01,
            "{name}: {c:?}"
        );
        let total: f32 = cpu
            .pixels
            .iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .map(|(p, _)| p.x)
            .sum();
        assert!(total > 0.0, "{name}: no caustic");
        flux.push(total);
    }
    // The block hides the focus from the floor.
    assert!(flux[2] < 0.7 * flux[0], "{flux:?}");
}

/// The table lives in the object's rigid frame: the same table serves the sphere moved and
/// turned (a sphere's caustic only moves with it), and a table for another mesh is refused.
#[test]
fn moving_and_turning_the_object_reuses_the_table() {
    let world = sphere_scene("glass-sphere-directional", 48, |s| s);
    let table = bake(&world, 8, 16);
    let place = |transform: &'static str| {
        sphere_scene("glass-sphere-directional", 48, move |s| {
            s.replace(r#""transform": {"translation": [0, 0.58, 0]}"#, transform)
        })
    };
    let moved = place(r#""transform": {"translation": [0.2, 0.58, -0.1]}"#);
    let turned =
        place(r#""transform": {"translation": [0.2, 0.58, -0.1], "rotation_deg": [20, 35, -10]}"#);
    let (a, _) = cpu_caustics(&world, &table);
    let (b, _) = cpu_caustics(&moved, &table);
    let (c, _) = cpu_caustics(&turned, &table);
    // Turned: the same caustic as moved only (a sphere), up to its tessellation, which now
    // meets the light elsewhere (measured L1 0.13, flux 1.008; a wrongly turned table puts
    // the light somewhere else entirely, L1 above 1).
    let mask = floor_mask(&moved);
    let cmp = compare::compare(&c, &b, &mask);
    eprintln!("turned vs moved: {cmp:?}");
    assert!(
        cmp.rel_l1 < 0.2 && (cmp.flux_ratio - 1.0).abs() < 0.02,
        "{cmp:?}"
    );
    // Moved: the focus moved with the sphere.
    let peak = |f: &Frame| {
        let k = (0..f.pixels.len())
            .max_by(|&i, &j| f.pixels[i].x.total_cmp(&f.pixels[j].x))
            .unwrap();
        (k as u32 % f.width, k as u32 / f.width)
    };
    let cam = &world.camera;
    let (pa, pb) = (peak(&a), peak(&b));
    let d = cam.rays().dir(pa.0 as f32 + 0.5, pa.1 as f32 + 0.5);
    let on_floor = cam.eye + d * (-cam.eye.y / d.y) + Vec3::new(0.2, 0.0, -0.1);
    let (ex, ey, _) = cam.project(on_floor).unwrap();
    assert!(
        (pb.0 as f32 + 0.5 - ex).abs() <= 1.5 && (pb.1 as f32 + 0.5 - ey).abs() <= 1.5,
        "{pa:?} {pb:?} ({ex}, {ey})"
    );
    // Another mesh: refused with a message.
    let other = sphere_scene("glass-sphere-directional", 40, |s| s);
    let err = volumes::build_volumes(&other, "glass", &table, &[], None, &|| true).unwrap_err();
    assert!(err.to_string().contains("does not fit object"), "{err}");
}

/// A mirroring scale (negative determinant) reverses the mesh's winding; the volumes take each
/// triangle's outward side from the table's normals (which the mirror turns correctly), so a
/// sphere mirrored across its own symmetry plane casts the same caustic, transmitted and
/// reflected light alike: the same flux (the volumes' sums agree to 10⁻⁶; a wrongly oriented
/// triangle carries none) and the same image up to interpolation (each vertex's tangent frame
/// comes from its normal, so the mirrored table samples other azimuths, as for a turned object:
/// measured L1 0.066 at 32 segments).
#[test]
fn a_mirrored_object_casts_the_same_caustic() {
    let file = "glass-sphere-directional";
    let world = sphere_scene(file, 32, |s| s);
    let mirrored = sphere_scene(file, 32, |s| {
        s.replace(
            r#""transform": {"translation": [0, 0.58, 0]}"#,
            r#""transform": {"translation": [0, 0.58, 0], "scale": [-1, 1, 1]}"#,
        )
    });
    let (a, la) = cpu_caustics(&world, &bake(&world, 8, 16));
    let (b, lb) = cpu_caustics(&mirrored, &bake(&mirrored, 8, 16));
    eprintln!("plain {:?}\nmirrored {:?}", la.stats, lb.stats);
    assert!(la.stats.flux.x > 0.5, "{:?}", la.stats);
    assert!((lb.stats.flux.x / la.stats.flux.x - 1.0).abs() < 0.01);
    assert!((lb.stats.reflected_flux.x / la.stats.reflected_flux.x - 1.0).abs() < 0.01);
    let c = compare::compare(&b, &a, &floor_mask(&world));
    eprintln!("mirrored vs plain: {c:?}");
    assert!(
        c.rel_l1 < 0.12 && (c.flux_ratio - 1.0).abs() < 0.01,
        "{c:?}"
    );
}

/// Building a frame's volumes stops when told to (a canceled or timed-out render job).
#[test]
fn building_the_volumes_can_be_canceled() {
    let world = sphere_scene("glass-sphere-directional", 16, |s| s);
    let table = bake(&world, 4, 8);
    let tables = [(scenes::object_index(&world, "glass"), &table)];
    let err = TransportLayer::build_with(&world, &tables, 16, &|| false).unwrap_err();
    assert!(matches!(err, volumes::EvalError::Canceled), "{err}");
    let layer = TransportLayer::build_with(&world, &tables, 16, &|| true).unwrap();
    assert!(layer.stats.volumes > 0);
}

/// Caustics against the stored references (caustics component, floor pixels, 3×3 blur), for
/// the three lights of the canonical sphere, at the paper's 129 directions and at 513. The
/// layer holds the tables' refracted light and the light the glass reflects (7 % of the
/// floor's caustic flux here: photons traced through the sphere put 0.937 of it on paths
/// that refract in and out, 0.071 on paths that start with a reflection off the glass).
///
/// Measured (this test, 96 segments, the CPU evaluation; the GPU pass agrees with it, see
/// above), relative L1 / flux ratio:
/// - 129 directions (the paper's): directional 0.119 / 0.974, spot 0.154 / 0.980,
///   point 0.181 / 0.983;
/// - 513 directions (16 rings of 32): directional 0.053 / 0.984, spot 0.064 / 0.986,
///   point 0.063 / 0.988: the issue's targets (L1 ≤ 0.15, flux within 5 %) are met, asserted
///   here.
///
/// At 129 directions the interpolation between samples 11° apart is what is left: exit
/// positions 9 mm and directions 0.011 rad off on average (the closed-form test above), which
/// blurs the focus; the flux is within 5 % there too.
#[test]
fn sphere_caustics_against_the_reference() {
    let mut report = Vec::new();
    for (light, reference) in [
        ("directional", "glass-sphere-directional.caustics.64M.exr"),
        ("spot", "glass-sphere-spot.caustics.32M.exr"),
        ("point", "glass-sphere-point.caustics.32M.exr"),
    ] {
        let world = sphere_scene(&format!("glass-sphere-{light}"), 96, |s| s);
        let reference = images::stored_reference(reference);
        let mask = floor_mask(&world);
        for (rings, az) in [(8, 16), (16, 32)] {
            let table = bake(&world, rings, az);
            let (cpu, layer) = cpu_caustics(&world, &table);
            let c = compare::compare(&cpu, &reference, &mask);
            let line = format!(
                "{light} {}×{}+1: {c:?} ({} volumes)",
                rings,
                az,
                layer.volumes.len()
            );
            eprintln!("{line}");
            report.push((light, rings, c));
        }
    }
    for (light, rings, c) in &report {
        let l1 = if *rings == 8 { 0.21 } else { 0.15 };
        assert!(
            c.rel_l1 <= l1 && (0.95..=1.05).contains(&c.flux_ratio),
            "{light} {rings}: {c:?}"
        );
    }
}

/// Streaks: a glass cylinder with flat caps (scenes/glass-cylinder.json, 128 × 128) under a
/// slanting sun. The side's triangles span the whole height, so the light entering their
/// corners leaves through different faces (the bottom cap, the far side); interpolating the
/// exits across those paths, as the paper does, drew long wedges of light on the floor
/// (relative L1 0.39, flux 0.71 against the reference before the fix). Each sample now keeps
/// its path's signature and a triangle whose corners disagree is split and traced
/// (`volumes::SPLIT_DEPTH` levels). Measured: 0.054 / 0.966 here (the CPU evaluation),
/// 0.040 / 0.992 from the CLI (the GPU pass, lavapipe).
#[test]
fn a_flat_capped_cylinder_casts_no_streaks() {
    let mut world = scenes::load("glass-cylinder");
    world.camera.width = 128;
    world.camera.height = 128;
    let table = bake_transport(&world, "glass", &TransportParams::paper(), &|_| true).unwrap();
    // Its samples leave on several paths (the caps and the side are separate smooth patches).
    let paths: std::collections::HashSet<u16> = (0..table.records.len())
        .map(|k| table.records[k].signature)
        .collect();
    assert!(paths.len() > 3, "{} path signatures", paths.len());
    let (cpu, layer) = cpu_caustics(&world, &table);
    let reference = images::stored_reference("glass-cylinder.caustics.32M.exr");
    let c = compare::compare(&cpu, &reference, &floor_mask(&world));
    let s = &layer.stats;
    eprintln!(
        "cylinder: {c:?}, {} volumes, split off {:?} of {:?}",
        s.volumes, s.split_flux, s.flux
    );
    assert!(
        c.rel_l1 <= 0.10 && (0.95..=1.05).contains(&c.flux_ratio),
        "{c:?}"
    );
    // What the split leaves out is small beside what leaves.
    assert!(s.split_flux.x <= 0.05 * s.flux.x, "{s:?}");
}

/// §5.3: the glass drawn by refracting the viewing rays through the tables. The `specular`
/// layer over the sphere's pixels against the reference's (what the camera sees in and through
/// the glass: the floor, its shadow and the caustic, refracted). Measured (96 segments,
/// llvmpipe): relative L1 0.053, flux 0.954; the `direct` method, which draws the glass from the
/// environment only (none here), is black there.
#[test]
fn glass_seen_through_the_tables_matches_the_reference() {
    let world = sphere_scene("glass-sphere-directional", 96, |s| s);
    let table = bake(&world, 8, 16);
    let layer = TransportLayer::build(
        &world,
        &[(scenes::object_index(&world, "glass"), &table)],
        16,
    )
    .unwrap();
    let mut r = gpu::renderer();
    let out = r
        .render_transport(&world, &Default::default(), &layer)
        .unwrap();
    let reference = images::stored_reference("glass-sphere-directional.specular.8M.exr");
    let mask = compare::object_mask(&world, &Accel::build(&world), "glass");
    let c = compare::compare(&out.specular, &reference, &mask);
    eprintln!("specular over the glass: {c:?}");
    assert!(
        c.rel_l1 < 0.12 && (0.9..=1.1).contains(&c.flux_ratio),
        "{c:?}"
    );
}

/// When the pass's list of (pixel, volume) pairs overflows (here: a list of one entry), the
/// frame is drawn again with every covered fragment evaluated and blended: the same caustics
/// as the list's, to rounding (the list sums in 64-bit fixed point, the blend in f32).
#[test]
fn an_overflowing_list_draws_the_frame_again_by_blending() {
    let world = sphere_scene("glass-sphere-directional", 24, |s| s);
    let table = bake(&world, 6, 12);
    let (_, layer) = cpu_caustics(&world, &table);
    let mut r = gpu::renderer();
    let listed = r
        .render_transport(&world, &Default::default(), &layer)
        .unwrap()
        .caustics
        .unwrap();
    r.set_transport_list(Some(0));
    let blended = r
        .render_transport(&world, &Default::default(), &layer)
        .unwrap()
        .caustics
        .unwrap();
    let c = compare::compare(&blended, &listed, &floor_mask(&world));
    eprintln!("blended vs listed: {c:?}");
    assert!(c.rel_l1 < 1e-4, "{c:?}");
    assert!((c.flux_ratio - 1.0).abs() < 1e-5, "{c:?}");
    let total: f64 = listed.pixels.iter().map(|p| p.x as f64).sum();
    assert!(total > 0.0, "the caustic is there");
}

/// The depth cull of the volumes' outlines drops only pixels that receive nothing from them:
/// the listed frame is the same bit for bit with and without it (its sums are exact), and so
/// is the blended one to rounding; under the canonical point light, whose volumes run long
/// and slanted from the glass to the floor, and from a camera low over the floor.
#[test]
fn the_depth_cull_of_the_volumes_drops_no_light() {
    for (name, edit) in [
        ("glass-sphere-point", None),
        (
            "glass-sphere-directional",
            Some(("\"eye\": [0, 3.2, 3.2]", "\"eye\": [2.4, 0.6, 2.2]")),
        ),
    ] {
        let world = sphere_scene(name, 24, |s| match edit {
            Some((a, b)) => {
                assert!(s.contains(a), "{name}: {a}");
                s.replace(a, b)
            }
            None => s,
        });
        let table = bake(&world, 6, 12);
        let (_, layer) = cpu_caustics(&world, &table);
        let mut r = gpu::renderer();
        let mut frame = |cull: bool, blended: bool| {
            r.set_transport_cull(cull);
            r.set_transport_list(blended.then_some(0));
            r.render_transport(&world, &Default::default(), &layer)
                .unwrap()
                .caustics
                .unwrap()
        };
        let (culled, all) = (frame(true, false), frame(false, false));
        let total: f64 = culled.pixels.iter().map(|p| p.x as f64).sum();
        assert!(total > 0.0, "{name}: the caustic is there");
        assert!(
            culled.pixels == all.pixels,
            "{name}: the listed frame changed with the cull: {:?}",
            compare::compare(&culled, &all, &floor_mask(&world))
        );
        let (culled, all) = (frame(true, true), frame(false, true));
        let c = compare::compare(&culled, &all, &floor_mask(&world));
        assert!(
            c.rel_l1 < 1e-6 && (c.flux_ratio - 1.0).abs() < 1e-6,
            "{name}: blended {c:?}"
        );
    }
}
