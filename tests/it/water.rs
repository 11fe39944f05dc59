//! Method `water` (Sánchez-Crespo 2003) and the water in the reference: the physical mode
//! against the stored reference on both floor scenes at three times, flat water against the
//! closed form (the reference, under water and seen from above, and both modes), any sun
//! elevation, time continuity, the variants, the article's mode and its calibration, bad
//! parameters, and sequences as animated PNGs.
//!
//! Sized for CI: 96 × 72 frames; the stored references were rendered with
//! `--photons 32000000 --spp 1 --seed 11` and the cameras below (tests/data/reference/README.md).

use crate::support::{caustica, images, scenes, temp_dir};
use caustica::frame::Frame;
use caustica::jobs::render::apply_overrides;
use caustica::reference::{self, ReferenceParams, compare};
use caustica::render::water::{Mode, Receivers, Variant, WaterParams, WaterStats, render_layer};
use caustica::scene::types::CameraDesc;
use caustica::scene::{Limits, World};
use caustica::trace::Accel;
use caustica::trace::optics::{fresnel_dielectric, refract};
use glam::Vec3;

/// The test cameras: under the surface, looking down at the floor (the reference's caustics
/// component sees the floor directly from there).
const POOL_CAMERA: &str =
    r#"{"eye":[0.3,-0.25,0.6],"target":[0.2,-0.8,-0.1],"fov_y":60,"width":96,"height":72}"#;
const SEA_CAMERA: &str =
    r#"{"eye":[0.6,-0.3,0.8],"target":[-0.2,-1.5,-0.2],"fov_y":55,"width":96,"height":72}"#;

/// A scene of the repository with the camera `camera` (JSON) at time `t`.
fn at(scene: &str, camera: &str, t: f32) -> World {
    let mut w = scenes::load(scene);
    let cam: CameraDesc = serde_json::from_str(camera).unwrap();
    apply_overrides(
        &mut w,
        Some(&cam),
        (None, None),
        None,
        Some(t),
        false,
        &Limits::default(),
    )
    .unwrap();
    w
}

/// The water's light in `world`'s frame (seen directly and through the waves).
fn layer(world: &World, p: &WaterParams) -> (Frame, WaterStats) {
    let mut stats = WaterStats::default();
    let f = render_layer(world, &Receivers::build(world), p, &mut stats);
    (f.sum(), stats)
}

/// Relative L1 (3×3 blur) and flux ratio of `a` against `b` on `object`.
fn error(world: &World, a: &Frame, b: &Frame, object: &str) -> (f32, f32) {
    let mask = compare::object_mask(world, &Accel::build(world), object);
    let e = compare::compare(a, b, &mask);
    (e.rel_l1, e.flux_ratio)
}

#[test]
fn physical_mode_agrees_with_the_reference_on_both_floor_scenes_at_three_times() {
    for (scene, camera, floor) in [
        ("pool-noon", POOL_CAMERA, "pool-floor"),
        ("sea-floor-low-sun", SEA_CAMERA, "sea-floor"),
    ] {
        for t in ["0", "0.7", "1.9"] {
            let w = at(scene, camera, t.parse().unwrap());
            let (img, stats) = layer(&w, &WaterParams::default());
            let stored = images::stored_reference(&format!("{scene}.t{t}.caustics.32M.exr"));
            let (l1, flux) = error(&w, &img, &stored, floor);
            eprintln!(
                "{scene} t={t}: rel L1 {l1:.4}, flux ratio {flux:.4} ({} rays)",
                stats.rays
            );
            assert!(l1 <= 0.10, "{scene} t={t}: rel L1 {l1}");
            assert!(
                (flux - 1.0).abs() <= 0.03,
                "{scene} t={t}: flux ratio {flux}"
            );
        }
    }
}

/// Flat water 2 m × 2 m, `depth` deep, over a floor of albedo 0.5, under a sun `elevation`
/// degrees above the horizon; the camera under the surface looking down, or above it.
fn flat(elevation: f32, above: bool) -> (World, Vec3) {
    let e = elevation.to_radians();
    let dir = Vec3::new(e.cos(), -e.sin(), 0.0);
    let eye = if above {
        "[0.1, 0.8, 0.05]"
    } else {
        "[0.1, -0.05, 0.05]"
    };
    let json = format!(
        r#"{{
        "camera": {{"eye": {eye}, "target": [0.1, -0.6, 0], "up": [0, 0, -1], "fov_y": 50,
                    "width": 32, "height": 32}},
        "lights": [{{"type": "directional", "direction": [{}, {}, 0], "irradiance": 2.0}}],
        "objects": [{{"name": "w", "shape": {{"type": "water", "size": [2, 2], "depth": 0.6,
            "floor": 0.5, "absorption": [0.3, 0.2, 0.1], "resolution": 2,
            "waves": {{"preset": "physical",
                       "waves": [{{"wavelength": 1, "amplitude": 0}}]}}}}}}]
    }}"#,
        dir.x, dir.y
    );
    (scenes::parse(&json), dir)
}

/// The closed form under flat water: irradiance on the floor E·cosθᵢ·T·e^{−σd/cosθₜ}, and the
/// radiance it sends back along the camera ray through each pixel's centre.
fn closed_form(w: &World, sun: Vec3) -> Frame {
    let body = &w.water[0];
    let sigma = body.absorption;
    let eta = 1.0 / body.ior;
    let cos_i = -sun.y;
    let t = refract(sun, Vec3::Y, eta).unwrap();
    let cos_t = -t.y;
    let e_floor = 2.0 * cos_i * (1.0 - fresnel_dielectric(cos_i, eta));
    let e_floor = Vec3::splat(e_floor) * (-sigma * (body.depth / cos_t)).exp();
    let cam = &w.camera;
    let rays = cam.rays();
    let floor_y = -body.depth;
    let mut f = Frame::new(cam.width, cam.height);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
            let (start, dir, through) = if cam.eye.y > 0.0 {
                // Through the surface at y = 0.
                let s = cam.eye + d * (-cam.eye.y / d.y);
                let td = refract(d, Vec3::Y, eta).unwrap();
                let tr = (1.0 - fresnel_dielectric(-d.y, eta)) * eta * eta;
                (s, td, tr)
            } else {
                (cam.eye, d, 1.0)
            };
            let dist = (floor_y - start.y) / dir.y;
            f.pixels[(y * cam.width + x) as usize] =
                e_floor * (0.5 / std::f32::consts::PI) * through * (-sigma * dist).exp();
        }
    }
    f
}

/// The mean over the pixels of a/b, per channel summed.
fn mean_ratio(a: &Frame, b: &Frame) -> f32 {
    let (sa, sb) = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .fold((0.0f64, 0.0f64), |(x, y), (p, q)| {
            (x + p.element_sum() as f64, y + q.element_sum() as f64)
        });
    (sa / sb) as f32
}

/// The largest per-pixel relative difference.
fn worst(a: &Frame, b: &Frame) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| ((*p - *q).abs() / q.max(Vec3::splat(1e-9))).max_element())
        .fold(0.0, f32::max)
}

#[test]
fn flat_water_matches_the_closed_form_in_the_reference_and_both_modes() {
    // Under water: the reference's caustics (light tracing through the surface, Beer-Lambert
    // down to the floor and back up to the camera).
    let (w, sun) = flat(50.0, false);
    let want = closed_form(&w, sun);
    let params = ReferenceParams {
        photons: 2_000_000,
        spp: 1,
        ..Default::default()
    };
    let (c, _) = reference::render(&w, &Accel::build(&w), &params, &|_| true).unwrap();
    let r = mean_ratio(&c.caustics, &want);
    eprintln!("reference under water: mean ratio to the closed form {r:.4}");
    assert!((r - 1.0).abs() <= 0.01, "reference under water: {r}");
    for mode in [Mode::Physical, Mode::Article] {
        let p = WaterParams {
            mode,
            ..Default::default()
        };
        let (img, _) = layer(&w, &p);
        let (r, e) = (mean_ratio(&img, &want), worst(&img, &want));
        eprintln!("{mode:?} under water: mean ratio {r:.4}, worst pixel {e:.4}");
        assert!((r - 1.0).abs() <= 0.01 && e <= 0.02, "{mode:?}: {r}, {e}");
    }
    // From above: the reference's camera paths through the surface (radiance leaving the water
    // divided by n²) with the photon map's caustics; the method's layer.
    let (w, sun) = flat(50.0, true);
    let want = closed_form(&w, sun);
    let (c, _) = reference::render(&w, &Accel::build(&w), &params, &|_| true).unwrap();
    let r = mean_ratio(&c.specular, &want);
    eprintln!("reference from above: mean ratio to the closed form {r:.4}");
    assert!((r - 1.0).abs() <= 0.03, "reference from above: {r}");
    let (img, _) = layer(&w, &WaterParams::default());
    let (r, e) = (mean_ratio(&img, &want), worst(&img, &want));
    eprintln!("physical from above: mean ratio {r:.4}, worst pixel {e:.4}");
    assert!((r - 1.0).abs() <= 0.01 && e <= 0.02, "from above: {r}, {e}");
}

#[test]
fn any_sun_elevation_gives_the_closed_form_on_flat_water_and_keeps_the_flux_on_waves() {
    for elevation in [12.0, 35.0, 60.0, 90.0] {
        let (w, sun) = flat(elevation, false);
        let want = closed_form(&w, sun);
        let (img, _) = layer(&w, &WaterParams::default());
        let (r, e) = (mean_ratio(&img, &want), worst(&img, &want));
        eprintln!("flat, sun {elevation}°: mean ratio {r:.4}, worst pixel {e:.4}");
        assert!(
            (r - 1.0).abs() <= 0.01 && e <= 0.02,
            "{elevation}°: {r}, {e}"
        );
    }
    // Waves move the light around but keep it: over the sea's floor, the mean stays that of
    // the flat surface within the spread of Fresnel over the slopes.
    for elevation in [20.0f32, 35.0, 70.0] {
        let mut w = at("sea-floor-low-sun", SEA_CAMERA, 0.3);
        let e = elevation.to_radians();
        let dir = Vec3::new(e.cos() * 0.85, -e.sin(), e.cos() * 0.527).normalize();
        if let caustica::scene::Light::Directional { direction, .. } = &mut w.lights[0] {
            *direction = dir;
        }
        let (waves, _) = layer(&w, &WaterParams::default());
        let mut flat_w = w.clone();
        caustica::scene::water::set_time(&mut flat_w, 0.3);
        if let caustica::scene::Waves::Physical(ws) = &mut flat_w.water[0].surface.waves {
            ws.iter_mut().for_each(|x| x.amplitude = 0.0);
        }
        let (flat_img, _) = layer(&flat_w, &WaterParams::default());
        let (l1, flux) = error(&w, &waves, &flat_img, "sea-floor");
        eprintln!("waves, sun {elevation}°: flux against flat {flux:.4} (rel L1 {l1:.3})");
        assert!((flux - 1.0).abs() <= 0.05, "{elevation}°: {flux}");
        assert!(l1 > 0.1, "{elevation}°: the waves make a pattern ({l1})");
    }
}

#[test]
fn frames_close_in_time_differ_little_and_more_the_further_apart() {
    for (mode, scene, camera, floor) in [
        (Mode::Physical, "sea-floor-low-sun", SEA_CAMERA, "sea-floor"),
        (Mode::Article, "pool-noon", POOL_CAMERA, "pool-floor"),
    ] {
        let p = WaterParams {
            mode,
            grid: 384,
            ..Default::default()
        };
        let t0 = 0.5;
        let (base, _) = layer(&at(scene, camera, t0), &p);
        let w = at(scene, camera, t0);
        let mut last = 0.0;
        for dt in [1.0 / 240.0, 1.0 / 60.0, 1.0 / 15.0, 0.5] {
            let (img, _) = layer(&at(scene, camera, t0 + dt), &p);
            let (l1, _) = error(&w, &img, &base, floor);
            eprintln!("{mode:?}: {dt:.4} s apart, rel L1 {l1:.4}");
            assert!(l1 > last, "{mode:?}: {dt} s: {l1} after {last}");
            if dt < 0.01 {
                assert!(
                    l1 < 0.1,
                    "{mode:?}: consecutive frames at 240 fps differ by {l1}"
                );
            }
            last = l1;
        }
        assert!(last > 0.3, "{mode:?}: half a second apart, only {last}");
    }
}

#[test]
fn texture_and_vertex_variants_follow_the_per_pixel_one() {
    // The light map (1024² texels over 6 m) and the vertex grid (128 quads a side) against the
    // per-pixel image of the same mode; the physical mode's against the reference too.
    let w = at("sea-floor-low-sun", SEA_CAMERA, 0.7);
    let stored = images::stored_reference("sea-floor-low-sun.t0.7.caustics.32M.exr");
    // (largest rel L1, largest flux difference) against the per-pixel image: texture, vertex.
    let bounds = [(0.15, 0.03), (0.35, 0.05)];
    for mode in [Mode::Physical, Mode::Article] {
        let image = |variant| {
            let p = WaterParams {
                mode,
                variant,
                ..Default::default()
            };
            layer(&w, &p).0
        };
        let pixel = image(Variant::Pixel);
        let (l1, flux) = error(&w, &pixel, &stored, "sea-floor");
        eprintln!("{mode:?} Pixel against the reference: rel L1 {l1:.4}, flux ratio {flux:.4}");
        if mode == Mode::Physical {
            assert!(l1 <= 0.1 && (flux - 1.0).abs() <= 0.03, "{l1}, {flux}");
        }
        for (variant, (max, dflux)) in [Variant::Texture, Variant::Vertex].into_iter().zip(bounds) {
            let (l1, flux) = error(&w, &image(variant), &pixel, "sea-floor");
            eprintln!("{mode:?} {variant:?} against Pixel: rel L1 {l1:.4}, flux ratio {flux:.4}");
            assert!(l1 <= max, "{mode:?} {variant:?}: {l1} > {max}");
            assert!(
                (flux - 1.0).abs() <= dflux,
                "{mode:?} {variant:?}: flux {flux}"
            );
        }
    }
}

#[test]
fn the_article_mode_is_calibrated_to_the_mean_and_its_error_is_what_it_is() {
    // The article's brightness has no physical scale; calibrated, its mean irradiance is the
    // reference's, while the pattern is not (reported in docs/methods/water.md).
    for (scene, camera, floor, t) in [
        ("pool-noon", POOL_CAMERA, "pool-floor", "0.7"),
        ("sea-floor-low-sun", SEA_CAMERA, "sea-floor", "0.7"),
    ] {
        let w = at(scene, camera, t.parse().unwrap());
        let p = WaterParams {
            mode: Mode::Article,
            ..Default::default()
        };
        let (img, stats) = layer(&w, &p);
        let stored = images::stored_reference(&format!("{scene}.t{t}.caustics.32M.exr"));
        let (l1, flux) = error(&w, &img, &stored, floor);
        eprintln!(
            "article, {scene}: rel L1 {l1:.4}, flux ratio {flux:.4}, calibration {:?}",
            stats.calibration
        );
        assert!((flux - 1.0).abs() <= 0.1, "{scene}: flux ratio {flux}");
        assert!(stats.calibration.iter().all(|k| *k > 0.0));
    }
}

#[test]
fn bad_water_parameters_are_refused_with_their_field() {
    let scene = |shape: &str| {
        format!(
            r#"{{"camera": {{"eye": [0, 1, 2], "target": [0, 0, 0]}},
                "lights": [{{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}}],
                "objects": [{{"name": "w", "shape": {shape}}}]}}"#
        )
    };
    for (shape, field) in [
        (
            r#"{"type": "water", "size": [1, 1], "depth": -1}"#,
            "objects[0].shape.depth",
        ),
        (
            r#"{"type": "water", "size": [1, 0], "depth": 1}"#,
            "objects[0].shape.size[1]",
        ),
        (
            r#"{"type": "water", "size": [1, 1], "waves": {"preset": "physical",
                "waves": [{"wavelength": 0, "amplitude": 0.01}]}}"#,
            "objects[0].shape.waves.waves[0].wavelength",
        ),
        (
            r#"{"type": "water", "size": [1, 1], "ior": 0.9}"#,
            "objects[0].shape.ior",
        ),
        (
            r#"{"type": "water", "size": [1, 1], "depth": 0.01}"#,
            "objects[0].shape.depth",
        ),
    ] {
        let e = caustica::scene::load_scene_json(scene(shape).as_bytes()).unwrap_err();
        assert_eq!(e.field(), field, "{shape}: {e}");
    }
    // A NaN time, a sequence without water, frames out of range, water parameters for
    // another method: each a clear error naming its flag.
    let water = scenes::path("underwater-view").display().to_string();
    let sphere = scenes::path("glass-sphere-directional")
        .display()
        .to_string();
    let out = temp_dir("water-bad").join("x.png").display().to_string();
    for (args, says) in [
        (vec![&water[..], "--time", "NaN"], "--time"),
        (vec![&water[..], "--frames", "0"], "--frames"),
        (vec![&water[..], "--fps", "12"], "--fps"),
        (vec![&sphere[..], "--frames", "3"], "--frames"),
        (vec![&sphere[..], "--time", "1"], "--time"),
        (
            vec![&sphere[..], "--method", "csl", "--water-mode", "article"],
            "water",
        ),
        (
            vec![&water[..], "--method", "water", "--water-grid", "1"],
            "water.grid",
        ),
    ] {
        let mut a = vec!["render"];
        a.extend(args.iter().copied());
        a.extend(["--out", &out]);
        let o = caustica(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{a:?} succeeded");
        assert!(err.contains(says), "{a:?}: {err}");
    }
}

#[test]
fn a_sequence_is_an_animated_png_with_the_frames_asked_for() {
    let dir = temp_dir("water-apng");
    let scene = scenes::path("underwater-view").display().to_string();
    let apng = dir.join("waves.png");
    let o = caustica(&[
        "render",
        &scene,
        "--method",
        "water",
        "--width",
        "48",
        "--height",
        "36",
        "--water-grid",
        "256",
        "--frames",
        "3",
        "--fps",
        "12",
        "--out",
        apng.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&apng).unwrap()));
    let mut r = dec.read_info().unwrap();
    let ac = r.info().animation_control.expect("an animated PNG");
    assert_eq!(ac.num_frames, 3);
    let fc = r.info().frame_control.expect("frame control");
    assert_eq!((fc.delay_num, fc.delay_den), (1000, 12000));
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let mut frames = Vec::new();
    while let Ok(info) = r.next_frame(&mut buf) {
        assert_eq!((info.width, info.height), (48, 36));
        frames.push(buf[..info.buffer_size()].to_vec());
    }
    assert_eq!(frames.len(), 3);
    // The waves move: consecutive frames differ, and the floor is lit.
    assert_ne!(frames[0], frames[1]);
    assert!(frames[0].iter().map(|&b| b as u64).sum::<u64>() > 0);
}

#[test]
fn the_reference_agrees_with_mitsuba_on_a_wavy_frame() {
    // Mitsuba 3's particle tracer on our tessellation of one frame of waves (no absorption:
    // Mitsuba would need a medium), camera under the surface: every path, so our total.
    let path = crate::support::repo_path("tests/data/mitsuba/water-waves.json");
    let w = caustica::scene::load_scene_file(&path, &Default::default()).unwrap();
    let params = ReferenceParams {
        photons: 4_000_000,
        spp: 2,
        ..Default::default()
    };
    let accel = Accel::build(&w);
    let (c, _) = reference::render(&w, &accel, &params, &|_| true).unwrap();
    let mitsuba = images::mitsuba("water-waves-ptracer-65536spp.exr");
    let mask = compare::object_mask(&w, &accel, "sea-floor");
    let total = compare::compare(&c.total(), &mitsuba, &mask);
    let caustics = compare::compare(&c.caustics, &mitsuba, &mask);
    eprintln!("total {total:?}; caustics alone {caustics:?}");
    assert!(total.rel_l1 <= 0.05, "{total:?}");
    assert!((total.flux_ratio - 1.0).abs() <= 0.02, "{total:?}");
    // Light the floor sends up and the surface reflects back down (mostly total internal
    // reflection) is the rest: indirect, a few per cent.
    assert!(caustics.flux_ratio < total.flux_ratio, "{caustics:?}");
}

/// The article's GPU tests' frames, 96 × 72: the sea floor under its surface at t = 0.7, and
/// the pool from above; each with the object whose pixels are compared.
fn article_frames() -> [(&'static str, World, &'static str); 2] {
    let sized = |mut w: World| {
        w.camera.width = 96;
        w.camera.height = 72;
        w
    };
    [
        (
            "sea-floor-low-sun",
            sized(at("sea-floor-low-sun", SEA_CAMERA, 0.7)),
            "sea-floor",
        ),
        ("pool-noon", sized(scenes::load("pool-noon")), "pool"),
    ]
}

#[test]
fn the_articles_pixel_shader_on_the_gpu_gives_the_cpus_frame() {
    // Under the surface (receivers from the G-buffer, the rock's shadow from the blockers) and
    // from above (the first receiver through the waves), one point a pixel on both sides.
    for (scene, w, object) in article_frames() {
        let p = WaterParams {
            mode: Mode::Article,
            variant: Variant::Shader,
            pixel_samples: 1,
            ..Default::default()
        };
        let gpu = gpu_layer(&w, &p);
        let (cpu, _) = layer_of(&w, &p);
        let (l1, flux) = error(&w, &gpu, &cpu, object);
        eprintln!("{scene}: GPU against CPU rel L1 {l1:.4}, flux ratio {flux:.4}");
        assert!(l1 < 0.03, "{scene}: {l1}");
        assert!((flux - 1.0).abs() < 0.01, "{scene}: {flux}");
        assert!(gpu.pixels.iter().any(|p| p.x > 0.0), "{scene}: lit");
    }
}

/// The water's light the GPU's water passes render for `w` with `p`: the caustics layer and,
/// seen through the waves, the specular one (the direct pass adds nothing to it in these
/// scenes: no environment to reflect).
fn gpu_layer(w: &World, p: &WaterParams) -> Frame {
    use caustica::render::water::gpu::WaterGpuLayer;
    let layer = WaterGpuLayer::build(w, p).unwrap();
    let out = crate::support::gpu::renderer()
        .render_water(w, &Default::default(), &layer)
        .unwrap();
    out.caustics.expect("a caustics layer").add(&out.specular)
}

#[test]
fn the_physical_mode_on_the_gpu_agrees_with_the_reference_and_the_cpu() {
    // Under the surface against the stored references: the default variant (3 × 3 reads a
    // pixel) at the three times, the light map read once at the footprint at one.
    for (scene, camera, floor) in [
        ("pool-noon", POOL_CAMERA, "pool-floor"),
        ("sea-floor-low-sun", SEA_CAMERA, "sea-floor"),
    ] {
        for (t, variant) in [
            ("0", Variant::Shader),
            ("0.7", Variant::Shader),
            ("1.9", Variant::Shader),
            ("0.7", Variant::ShaderTexture),
        ] {
            let w = at(scene, camera, t.parse().unwrap());
            let stored = images::stored_reference(&format!("{scene}.t{t}.caustics.32M.exr"));
            let p = WaterParams {
                variant,
                ..Default::default()
            };
            let img = gpu_layer(&w, &p);
            let (l1, flux) = error(&w, &img, &stored, floor);
            eprintln!(
                "{scene} t={t} {}: against the reference rel L1 {l1:.4}, flux ratio {flux:.4}",
                variant.name()
            );
            assert!(l1 <= 0.10, "{scene} {}: rel L1 {l1}", variant.name());
            assert!((flux - 1.0).abs() <= 0.03, "{scene}: flux ratio {flux}");
        }
    }
    // From above, through the waves, onto the floor and the rock (the pixels that see the
    // water's surface): against the CPU's layer at 8 × 8 points a pixel (its area average).
    let mut w = scenes::load("sea-floor-low-sun");
    w.camera.width = 96;
    w.camera.height = 72;
    let p = WaterParams {
        variant: Variant::Shader,
        ..Default::default()
    };
    let gpu = gpu_layer(&w, &p);
    let (cpu, _) = layer_of(
        &w,
        &WaterParams {
            pixel_samples: 8,
            ..p.clone()
        },
    );
    let (l1, flux) = error(&w, &gpu, &cpu, "sea");
    eprintln!("from above: GPU against CPU rel L1 {l1:.4}, flux ratio {flux:.4}");
    assert!(l1 <= 0.10, "{l1}");
    assert!((flux - 1.0).abs() <= 0.03, "{flux}");
}

/// The sea floor's whole frame, 96 × 72, of the physical mode on the GPU (`shader`) and on the
/// CPU (`pixel`) against the reference's total, seen from above (the scene's own camera:
/// `sea-floor-low-sun.above.total.64M.exr`) and from under the surface towards the edge the
/// sun comes from (`SEA_CAMERA`: `sea-floor-low-sun.under.total.32M.exr`).
/// - From above, before the light the body's open sides let in was drawn, the GPU's frame was
///   0.48 from it with flux 0.61 (a black band on the side the sun comes from). The reference
///   sees the floor through the waves with a photon map gathered over a disc of a pixel's
///   footprint (about two pixels across): the CPU's frame, a box average over each pixel, is
///   sharper than that and than the GPU's light map, and further from it (0.093 against
///   0.059).
/// - From under the surface, before the direct pass knew the water's absorption, the band
///   that light makes was 3.3 times too bright (total 0.43 off, flux 1.36). The light the
///   floor sends up and the surface reflects back down (the reference's `indirect`, 2.3 % of
///   this frame) is not drawn: the flux is short by about that.
#[test]
fn the_sea_floors_whole_frame_matches_the_references_total_from_above_and_below() {
    use caustica::render::water::gpu::WaterGpuLayer;
    let mut r = crate::support::gpu::renderer();
    let above = {
        let mut w = scenes::load("sea-floor-low-sun");
        w.camera.width = 96;
        w.camera.height = 72;
        w
    };
    let under = at("sea-floor-low-sun", SEA_CAMERA, 0.0);
    for (view, w, stored, most, flux_range) in [
        (
            "from above",
            &above,
            "sea-floor-low-sun.above.total.64M.exr",
            [0.08, 0.11],
            0.97..1.03,
        ),
        (
            "under water",
            &under,
            "sea-floor-low-sun.under.total.32M.exr",
            [0.08, 0.08],
            0.955..1.01,
        ),
    ] {
        let want = images::stored_reference(stored);
        let p = WaterParams {
            variant: Variant::Shader,
            ..Default::default()
        };
        let layer = WaterGpuLayer::build(w, &p).unwrap();
        let gpu = r
            .render_water(w, &Default::default(), &layer)
            .unwrap()
            .total();
        let direct = r.render(w, &Default::default()).unwrap().total();
        let (cpu, _) = layer_of(w, &p);
        let cpu = direct.add(&cpu);
        let all = vec![true; want.pixels.len()];
        for (name, img, most) in [("GPU shader", &gpu, most[0]), ("CPU pixel", &cpu, most[1])] {
            let e = compare::compare(img, &want, &all);
            eprintln!(
                "{view}, {name}: rel L1 {:.4}, flux ratio {:.4} against the total",
                e.rel_l1, e.flux_ratio
            );
            assert!(e.rel_l1 <= most, "{view}, {name}: {e:?}");
            assert!(flux_range.contains(&e.flux_ratio), "{view}, {name}: {e:?}");
        }
    }
}

#[test]
fn the_articles_light_map_on_the_gpu_follows_the_pixels_area_average() {
    // The mipmapped map read at the pixel's footprint against the CPU's article mode at 3 × 3
    // points a pixel (the per-pixel shader takes one point, and aliases).
    for (scene, w, object) in article_frames() {
        let p = WaterParams {
            mode: Mode::Article,
            variant: Variant::ShaderTexture,
            ..Default::default()
        };
        let map = gpu_layer(&w, &p);
        let (cpu, _) = layer_of(&w, &p);
        let (l1, flux) = error(&w, &map, &cpu, object);
        eprintln!("{scene}: GPU light map against CPU 3 × 3 rel L1 {l1:.4}, flux ratio {flux:.4}");
        assert!(l1 < 0.08, "{scene}: {l1}");
        assert!((flux - 1.0).abs() < 0.03, "{scene}: {flux}");
    }
}

/// The CPU layer with `p`'s variant taken as per pixel.
fn layer_of(world: &World, p: &WaterParams) -> (Frame, WaterStats) {
    layer(
        world,
        &WaterParams {
            variant: Variant::Pixel,
            ..p.clone()
        },
    )
}
