//! The reference renderer against Mitsuba 3 and against closed-form answers.

use crate::support::images::{self, mitsuba};
use crate::support::scenes::{self, parse};
use crate::support::{Cleanup, temp_dir};
use caustica::reference::{self, Components, ReferenceParams, compare};
use caustica::scene::{self, World};
use caustica::trace::Accel;
use glam::Vec3;
use std::f32::consts::PI;

fn render(world: &World, photons: u64, spp: u32, seed: u64) -> Components {
    let accel = Accel::build(world);
    let params = ReferenceParams {
        photons,
        spp,
        seed,
        ..Default::default()
    };
    reference::render(world, &accel, &params, &|_| true)
        .expect("renders")
        .0
}

/// Our total (direct + caustics + indirect) on the floor against Mitsuba's particle tracer, and
/// our direct component against Mitsuba's path tracer (no caustics from delta lights).
fn check_against_mitsuba(light: &str) {
    let world = scenes::load(&format!("glass-sphere-{light}"));
    let c = render(&world, 1_500_000, 4, 7);
    let accel = Accel::build(&world);
    let mask = compare::object_mask(&world, &accel, "floor");
    assert!(mask.iter().filter(|m| **m).count() > 40_000);
    let total = compare::compare(
        &c.total(),
        &mitsuba(&format!("sphere-{light}-ptracer-1024spp.exr")),
        &mask,
    );
    let direct = compare::compare(
        &c.direct,
        &mitsuba(&format!("sphere-{light}-path-256spp.exr")),
        &mask,
    );
    eprintln!("{light}: total vs ptracer {total:?}, direct vs path {direct:?}");
    assert!(total.rel_l1 <= 0.05, "{light}: total {total:?}");
    assert!(
        (total.flux_ratio - 1.0).abs() <= 0.02,
        "{light}: total {total:?}"
    );
    assert!(direct.rel_l1 <= 0.02, "{light}: direct {direct:?}");
    // The caustic is really there: a bright spot on the floor, above the direct lighting.
    let peak = images::peak(&c.caustics);
    let lit = images::peak(&c.direct);
    assert!(peak > lit, "{light}: caustic peak {peak} vs direct {lit}");
}

/// The mirror ring under the sun-and-sky environment map (`scenes/mirror-ring-env.json`, at
/// 128 × 128) against Mitsuba's particle tracer with its `envmap` reading the same HDR file:
/// the floor's direct sky light, the sun's shadow and the ring's caustic at once, so the map's
/// orientation, texel layout, bilinear lookup and importance sampling are all checked.
#[test]
fn mirror_ring_environment_matches_mitsuba() {
    let mut world = scenes::load("mirror-ring-env");
    world.camera.width = 128;
    world.camera.height = 128;
    let c = render(&world, 1_000_000, 8, 7);
    let accel = Accel::build(&world);
    let mask = compare::object_mask(&world, &accel, "floor");
    assert!(mask.iter().filter(|m| **m).count() > 10_000);
    let total = compare::compare(&c.total(), &mitsuba("ring-env-ptracer-32768spp.exr"), &mask);
    eprintln!("mirror ring, environment: total vs ptracer {total:?}");
    assert!(total.rel_l1 <= 0.05, "{total:?}");
    assert!((total.flux_ratio - 1.0).abs() <= 0.02, "{total:?}");
    // The sun's caustic is there: the caustic layer peaks above the floor's direct light.
    let peak = images::peak(&c.caustics);
    let lit = images::peak(&c.direct);
    assert!(peak > lit, "caustic peak {peak} vs direct {lit}");
}

#[test]
fn sphere_directional_matches_mitsuba() {
    check_against_mitsuba("directional");
}

#[test]
fn sphere_spot_matches_mitsuba() {
    check_against_mitsuba("spot");
}

#[test]
fn sphere_point_matches_mitsuba() {
    check_against_mitsuba("point");
}

#[test]
fn same_seed_same_image_other_seed_other_noise() {
    let mut world = scenes::load("glass-sphere-point");
    world.camera.width = 64;
    world.camera.height = 64;
    let a = render(&world, 100_000, 1, 3);
    let b = render(&world, 100_000, 1, 3);
    let c = render(&world, 100_000, 1, 4);
    assert_eq!(a.total().pixels, b.total().pixels);
    assert_ne!(a.caustics.pixels, c.caustics.pixels);
}

/// A diffuse floor under a light that reaches it only through a horizontal glass slab: the
/// floor under the slab receives E·T with the slab transmittance summed over internal
/// reflections, T = (1−R)² e^{−σd} / (1 − R² e^{−2σd}), R = ((n−1)/(n+1))² at normal incidence.
/// The camera sits below the slab and sees the floor under it (rows 21..32); the dark floor
/// (albedo 0.1) keeps floor–slab interreflection under 0.5%.
fn slab_scene(absorption: f32) -> World {
    parse(&format!(
        r#"{{
        "camera": {{"eye": [0, 0.3, 3], "target": [0, 0, 0], "fov_y": 15, "width": 48, "height": 48}},
        "lights": [{{"type": "directional", "direction": [0, -1, 0], "irradiance": 2.0}}],
        "materials": {{"floor": {{"type": "diffuse", "albedo": 0.1}},
                      "glass": {{"type": "dielectric", "ior": 1.5, "absorption": {absorption}}}}},
        "objects": [
            {{"name": "floor", "shape": {{"type": "plane", "size": [40, 40]}}, "material": "floor"}},
            {{"name": "slab", "shape": {{"type": "box", "size": [2, 0.1, 2]}}, "material": "glass",
             "transform": {{"translation": [0, 0.8, 0]}}}}
        ]}}"#
    ))
}

fn slab_transmittance(absorption: f32, thickness: f32) -> f32 {
    let r = ((1.5f32 - 1.0) / (1.5 + 1.0)).powi(2);
    let a = (-absorption * thickness).exp();
    (1.0 - r).powi(2) * a / (1.0 - r * r * a * a)
}

#[test]
fn caustic_through_a_slab_is_fresnel_and_beer_lambert_exact() {
    for sigma in [0.0f32, 3.0] {
        let world = slab_scene(sigma);
        let c = render(&world, 600_000, 1, 11);
        let expect = 0.1 / PI * 2.0 * slab_transmittance(sigma, 0.1);
        let mut sum = 0.0;
        let mut n = 0.0;
        for y in 21..32 {
            for x in 4..44 {
                sum += c.caustics.at(x, y).x;
                n += 1.0;
            }
        }
        let mean = sum / n;
        eprintln!("sigma {sigma}: mean caustic radiance {mean}, expected {expect}");
        assert!(
            (mean / expect - 1.0).abs() < 0.03,
            "sigma {sigma}: {mean} vs {expect}"
        );
        assert!(
            c.direct.at(24, 26).x == 0.0,
            "the slab shadows the direct light"
        );
        assert!(
            c.direct.at(24, 40).x > 0.0,
            "the floor beyond the slab is lit"
        );
    }
}

#[test]
fn glass_is_visible_and_refracts_the_lit_floor() {
    // Camera looks down through the slab; the light comes in under the slab from the side at
    // grazing-free 60°, so the floor seen through the slab is lit directly.
    let world = parse(
        r#"{
        "camera": {"eye": [0, 3, 0.01], "target": [0, 0, 0], "fov_y": 10, "width": 16, "height": 16},
        "lights": [{"type": "directional", "direction": [0.866, -0.5, 0], "irradiance": 1.0}],
        "materials": {"floor": {"type": "diffuse", "albedo": 0.8},
                      "glass": {"type": "dielectric", "ior": 1.5}},
        "objects": [
            {"name": "floor", "shape": {"type": "plane", "size": [40, 40]}, "material": "floor"},
            {"name": "slab", "shape": {"type": "box", "size": [1, 0.05, 1]}, "material": "glass",
             "transform": {"translation": [0, 2, 0]}}
        ]}"#,
    );
    let c = render(&world, 10_000, 256, 5);
    let floor = 0.8 / PI * 0.5;
    let expect = floor * slab_transmittance(0.0, 0.05);
    let s = c.specular.at(8, 8).x;
    assert!((s / expect - 1.0).abs() < 0.02, "{s} vs {expect}");
    assert_eq!(
        c.direct.at(8, 8),
        Vec3::ZERO,
        "the glass pixel has no direct term"
    );
}

#[test]
fn lambertian_floor_direct_is_exact_for_each_delta_light() {
    let lights = [
        (
            r#"{"type": "directional", "direction": [1, -2, 0], "irradiance": 1.5}"#,
            1.5 * 2.0 / 5f32.sqrt(),
        ),
        (
            r#"{"type": "point", "position": [0, 2, 0], "intensity": 4.0}"#,
            4.0 / 4.0,
        ),
        (
            r#"{"type": "spot", "position": [0, 2, 0], "target": [0, 0, 0], "intensity": 4.0, "cutoff_angle": 30, "beam_width": 20}"#,
            4.0 / 4.0,
        ),
    ];
    for (light, e) in lights {
        let world = parse(&format!(
            r#"{{
            "camera": {{"eye": [0, 1, 0.001], "target": [0, 0, 0], "fov_y": 2, "width": 4, "height": 4}},
            "lights": [{light}],
            "materials": {{"floor": {{"type": "diffuse", "albedo": 0.7}}}},
            "objects": [{{"name": "floor", "shape": {{"type": "plane", "size": [10, 10]}}, "material": "floor"}}]
            }}"#
        ));
        let c = render(&world, 1000, 4, 1);
        let v = c.direct.at(2, 2).x;
        let expect = 0.7 / PI * e;
        assert!((v / expect - 1.0).abs() < 0.005, "{light}: {v} vs {expect}");
    }
}

#[test]
fn constant_environment_lights_a_floor_with_pi_times_radiance() {
    // Unoccluded floor under a constant sky of radiance L: E = πL, so radiance = ρ·L.
    let world = parse(
        r#"{
        "camera": {"eye": [0, 1, 0.001], "target": [0, 0, 0], "fov_y": 2, "width": 4, "height": 4},
        "lights": [{"type": "environment", "radiance": [0.5, 1.0, 2.0], "scale": 2.0}],
        "materials": {"floor": {"type": "diffuse", "albedo": 0.7}},
        "objects": [{"name": "floor", "shape": {"type": "plane", "size": [100, 100]}, "material": "floor"}]
        }"#,
    );
    let c = render(&world, 1000, 64, 1);
    let v = c.direct.at(1, 2);
    let expect = Vec3::new(0.5, 1.0, 2.0) * 2.0 * 0.7;
    assert!(
        ((v / expect) - Vec3::ONE).abs().max_element() < 0.01,
        "{v} vs {expect}"
    );
}

#[test]
fn line_light_matches_numerical_integration() {
    // Segment from (-1, 1, 0) to (1, 1, 0), total intensity 3 W/sr; floor point at the origin:
    // E = ∫ (I/L)·cosθ/d² dx = (I/L)·∫ 1/(1+x²)^{3/2} dx over [-1, 1] = (I/L)·√2.
    let world = parse(
        r#"{
        "camera": {"eye": [0, 0.5, 0.0001], "target": [0, 0, 0], "fov_y": 1, "width": 2, "height": 2},
        "lights": [{"type": "line", "start": [-1, 1, 0], "end": [1, 1, 0], "intensity": 3.0}],
        "materials": {"floor": {"type": "diffuse", "albedo": 0.5}},
        "objects": [{"name": "floor", "shape": {"type": "plane", "size": [10, 10]}, "material": "floor"}]
        }"#,
    );
    let c = render(&world, 1000, 256, 1);
    let expect = 0.5 / PI * 1.5 * 2f32.sqrt();
    let v = c.direct.at(1, 1).x;
    assert!((v / expect - 1.0).abs() < 0.01, "{v} vs {expect}");
}

#[test]
fn environment_map_file_is_loaded_scaled_and_oriented() {
    // An equirectangular HDR: the upper half (v < 0.5, +Y) has radiance 2, the lower half 0.
    let dir = temp_dir("env");
    let _cleanup = Cleanup(dir.clone());
    let (w, h) = (16u32, 8u32);
    let img = image::Rgb32FImage::from_fn(w, h, |_, y| {
        image::Rgb(if y < h / 2 { [2.0; 3] } else { [0.0; 3] })
    });
    img.save_with_format(dir.join("sky.hdr"), image::ImageFormat::Hdr)
        .unwrap();
    std::fs::write(
        dir.join("scene.json"),
        r#"{
        "camera": {"eye": [0, 1, 0.001], "target": [0, 0, 0], "fov_y": 2, "width": 4, "height": 4},
        "lights": [{"type": "environment", "path": "sky.hdr", "scale": 1.5}],
        "materials": {"floor": {"type": "diffuse", "albedo": 0.5}},
        "objects": [{"name": "floor", "shape": {"type": "plane", "size": [100, 100]}, "material": "floor"}]
        }"#,
    )
    .unwrap();
    let world = scene::load_scene_file(&dir.join("scene.json"), &Default::default()).unwrap();
    let c = render(&world, 1000, 64, 1);
    // The floor sees only the bright upper hemisphere: radiance ρ·L = 0.5·2·1.5.
    let v = c.direct.at(1, 1).x;
    assert!((v / 1.5 - 1.0).abs() < 0.01, "{v}");
    // Looking down past the floor's edge would see 0; looking up sees 3.
    let mut up = world.clone();
    up.camera.eye = glam::Vec3::new(0.0, 1.0, 0.0);
    up.camera.target = glam::Vec3::new(0.0, 2.0, 0.0);
    up.camera.up = glam::Vec3::Z;
    let c = render(&up, 1000, 4, 1);
    assert!(
        (c.direct.at(2, 2).x - 3.0).abs() < 1e-4,
        "{}",
        c.direct.at(2, 2)
    );
}

/// The fog slab of `scenes::fog_slab` against the closed form of its single scattering.
#[test]
fn single_scattering_in_a_fog_slab_is_the_closed_form() {
    let (world, closed_form) = scenes::fog_slab();
    let accel = Accel::build(&world);
    let params = ReferenceParams {
        photons: 3_000_000,
        spp: 1,
        seed: 5,
        volume_bounces: 1,
        ..Default::default()
    };
    let (c, _) = reference::render(&world, &accel, &params, &|_| true).expect("renders");
    let cam = &world.camera;
    let rays = cam.rays();
    let (mut got, mut want) = (0.0f64, 0.0f64);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let e = closed_form(rays.dir(x as f32 + 0.5, y as f32 + 0.5));
            let i = (y * cam.width + x) as usize;
            got += f64::from(c.volume.pixels[i].element_sum());
            want += f64::from(e.element_sum());
            // Nothing else: no surface, no light through glass.
            assert_eq!(c.volume_caustics.pixels[i], Vec3::ZERO);
            assert_eq!(c.direct.pixels[i], Vec3::ZERO);
        }
    }
    let ratio = got / want;
    eprintln!("single scattering in the slab: reference / closed form {ratio:.4}");
    assert!((ratio - 1.0).abs() < 0.02, "{ratio}");
    // Multiple scattering adds light.
    let (m, _) = reference::render(
        &world,
        &accel,
        &ReferenceParams {
            volume_bounces: u32::MAX,
            ..params
        },
        &|_| true,
    )
    .expect("renders");
    let ms: f64 = m
        .volume
        .pixels
        .iter()
        .map(|p| f64::from(p.element_sum()))
        .sum();
    eprintln!("multiple / single scattering {:.4}", ms / got);
    assert!(ms > got * 1.05, "{ms} {got}");
}

#[test]
fn bad_media_are_refused_with_their_field() {
    let scene = |medium: &str| {
        format!(
            r#"{{"camera": {{"eye": [0, 3, 1], "target": [0, 0, 0]}},
            "lights": [{{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}}],
            "media": [{medium}]}}"#
        )
    };
    for (medium, field) in [
        (r#"{"sigma_s": -0.1}"#, "media[0].sigma_s"),
        (
            r#"{"sigma_s": 0.1, "sigma_a": [0, -1, 0]}"#,
            "media[0].sigma_a",
        ),
        (r#"{"sigma_s": 0.1, "g": 1.0}"#, "media[0].g"),
        (r#"{"sigma_s": 0.1, "g": -1.5}"#, "media[0].g"),
        (
            r#"{"sigma_s": 0.1, "bounds": {"type": "box", "size": [1, 0, 1]}}"#,
            "media[0].bounds.size",
        ),
        (r#"{"sigma_s": 0.1}, {"sigma_s": 0.2}"#, "media"),
        (
            r#"{"sigma_s": 0.1, "bounds": {"type": "mesh", "shape": {"type": "plane", "size": [1, 1]}}}"#,
            "media[0].bounds.shape.type",
        ),
        (
            r#"{"sigma_s": 0.1, "bounds": {"type": "mesh", "shape": {"type": "sphere", "radius": -1}}}"#,
            "media[0].bounds.shape.radius",
        ),
    ] {
        let e = scene::load_scene_json(scene(medium).as_bytes()).unwrap_err();
        assert_eq!(e.field(), field, "{medium}: {e}");
    }
    // A good one loads, with a warning that only the reference renders it.
    let w = parse(&scene(r#"{"sigma_s": [0.1, 0.2, 0.3], "g": 0.7}"#));
    assert_eq!(w.media.len(), 1);
    assert!(w.warnings.iter().any(|m| m.contains("medium")));
    // A whole-scene medium spans the camera.
    assert!(w.media[0].contains(w.camera.eye));
    // Fog inside a sphere around the origin: the camera is outside it, the origin inside.
    let w = parse(&scene(
        r#"{"sigma_s": 0.1, "bounds": {"type": "mesh", "shape": {"type": "sphere", "radius": 0.5},
            "transform": {"translation": [0, 0.2, 0]}}}"#,
    ));
    assert!(w.media[0].contains(Vec3::ZERO) && !w.media[0].contains(w.camera.eye));
}

/// Flux bookkeeping: a point light in a box of coloured fog over a grey floor, multiple
/// scattering. The light paths' estimate of what the fog absorbs (σa·T/pdf at each sampled
/// interaction), what the floor absorbs (1 − albedo) and what leaves the box adds up to what the
/// light emits (4π·I), within 1 % per channel; and each term is a real share of it.
#[test]
fn the_light_traced_in_fog_is_absorbed_or_escapes() {
    // A box of fog, and a torus of denser fog around the light (rays cross it up to four times).
    for bounds in [
        r#"{"type": "box", "size": [4, 3, 4], "transform": {"translation": [0, 1.5, 0]}}"#,
        r#"{"type": "mesh", "shape": {"type": "torus", "major_radius": 1, "minor_radius": 0.6},
            "transform": {"translation": [0, 1.2, 0], "rotation_deg": [30, 0, 0]}}"#,
    ] {
        balance_in_fog(bounds);
    }
}

fn balance_in_fog(bounds: &str) {
    let world = parse(&format!(
        r#"{{"camera": {{"eye": [0, 1.5, 5], "target": [0, 1, 0], "width": 32, "height": 24}},
            "lights": [{{"type": "point", "position": [0, 1.2, 0], "intensity": [1, 2, 3]}}],
            "materials": {{"floor": {{"type": "diffuse", "albedo": 0.5}}}},
            "objects": [{{"name": "floor", "shape": {{"type": "plane", "size": [4, 4]}},
                         "material": "floor"}}],
            "media": [{{"sigma_s": [0.4, 0.3, 0.2], "sigma_a": [0.1, 0.2, 0.05], "g": 0.5,
                       "bounds": {bounds}}}]}}"#
    ));
    let accel = Accel::build(&world);
    let params = ReferenceParams {
        photons: 400_000,
        spp: 1,
        seed: 4,
        ..Default::default()
    };
    let (_, stats) = reference::render(&world, &accel, &params, &|_| true).expect("renders");
    let b = stats
        .flux
        .expect("no targeted photons: the balance is tallied");
    eprintln!("flux balance in {bounds}: {b:?}");
    let emitted = Vec3::new(1.0, 2.0, 3.0) * 4.0 * PI;
    for c in 0..3 {
        assert!((b.emitted[c] / emitted[c] - 1.0).abs() < 1e-3, "{b:?}");
        let gap = (b.accounted()[c] - b.emitted[c]).abs() / b.emitted[c];
        assert!(
            gap < 0.01,
            "channel {c}: {gap} of the light unaccounted: {b:?}"
        );
        assert!(b.cut[c] < 0.01 * b.emitted[c], "{b:?}");
        for share in [b.absorbed_medium[c], b.absorbed_surfaces[c], b.escaped[c]] {
            assert!(share > 0.02 * b.emitted[c], "{b:?}");
        }
    }
    // More absorbing channels absorb more in the fog (σa/σt 0.2, 0.4, 0.2 of each event).
    let frac = b.absorbed_medium / b.emitted;
    assert!(frac.y > frac.x && frac.y > frac.z, "{frac}");
}

/// A spot light in a box of fog over a diffuse floor, against Mitsuba 3's `volpath`
/// (tests/data/mitsuba/README.md): every pixel sees the fog, most of them the floor behind it.
#[test]
fn fog_with_a_spot_light_matches_mitsubas_volpath() {
    let world = scenes::parse(
        &std::fs::read_to_string(crate::support::repo_path(
            "tests/data/mitsuba/fog-spot.json",
        ))
        .unwrap(),
    );
    let c = render(&world, 8_000_000, 16, 3);
    let ours = c.total();
    let theirs = mitsuba("fog-spot-volpath-131072spp.exr");
    let all = vec![true; ours.pixels.len()];
    let e = compare::compare(&ours, &theirs, &all);
    eprintln!("fog and spot light against volpath: {e:?}");
    assert!(e.rel_l1 <= 0.05, "{e:?}");
    assert!((e.flux_ratio - 1.0).abs() <= 0.03, "{e:?}");
    // The fog's own light is a good part of it.
    let volume: f32 = c.volume.pixels.iter().map(|p| p.element_sum()).sum();
    let total: f32 = ours.pixels.iter().map(|p| p.element_sum()).sum();
    assert!(volume > 0.2 * total, "{volume} of {total}");
}

/// The caustic under the glass slab of `slab_scene` with an absorbing fog above the slab, from
/// its top (0.85 m) to 6 m, higher than where the slab's photons start: the caustic is the
/// slab's times e^{−σa·5.15} (the photons are attenuated from where the light enters the fog,
/// not from where they start).
#[test]
fn a_caustic_under_absorbing_fog_is_attenuated_over_the_whole_fog() {
    let sigma_a = 0.1f32;
    let mut desc: serde_json::Value = serde_json::from_str(&format!(
        r#"{{
        "camera": {{"eye": [0, 0.3, 3], "target": [0, 0, 0], "fov_y": 15, "width": 48, "height": 48}},
        "lights": [{{"type": "directional", "direction": [0, -1, 0], "irradiance": 2.0}}],
        "materials": {{"floor": {{"type": "diffuse", "albedo": 0.1}},
                      "glass": {{"type": "dielectric", "ior": 1.5}}}},
        "objects": [
            {{"name": "floor", "shape": {{"type": "plane", "size": [40, 40]}}, "material": "floor"}},
            {{"name": "slab", "shape": {{"type": "box", "size": [2, 0.1, 2]}}, "material": "glass",
             "transform": {{"translation": [0, 0.8, 0]}}}}
        ],
        "media": [{{"sigma_s": 0, "sigma_a": {sigma_a},
                    "bounds": {{"type": "box", "size": [3, 5.15, 3],
                                "transform": {{"translation": [0, 3.425, 0]}}}}}}]
        }}"#
    ))
    .unwrap();
    let world = parse(&desc.to_string());
    let c = render(&world, 600_000, 1, 11);
    let expect = 0.1 / PI * 2.0 * slab_transmittance(0.0, 0.1) * (-sigma_a * 5.15).exp();
    let mean = |c: &Components| {
        let mut sum = 0.0;
        for y in 21..32 {
            for x in 4..44 {
                sum += c.caustics.at(x, y).x;
            }
        }
        sum / (11.0 * 40.0)
    };
    let m = mean(&c);
    eprintln!("caustic under fog {m}, expected {expect}");
    assert!((m / expect - 1.0).abs() < 0.03, "{m} vs {expect}");
    // Without the fog, the slab's own.
    desc["media"] = serde_json::json!([]);
    let clear = mean(&render(&parse(&desc.to_string()), 600_000, 1, 11));
    assert!(
        (clear / m - (sigma_a * 5.15).exp()).abs() < 0.05,
        "{clear} {m}"
    );
}

/// A low-poly glass ball (a UV sphere of 10 segments, 80 triangles) with smooth shading normals
/// over the floor, against Mitsuba's particle tracer on the same triangles and normals
/// (`tests/data/mitsuba/lowpoly-glass.json`). Light paths through such a mesh need the adjoint
/// BSDF's shading-normal correction and the rule that drops light leaks; without them ours put
/// 8 % too much light in the ball's shadow (relative L1 0.092 there).
#[test]
fn a_low_poly_glass_ball_with_smooth_normals_matches_mitsuba() {
    let path = crate::support::repo_path("tests/data/mitsuba/lowpoly-glass.json");
    let world = parse(&std::fs::read_to_string(path).unwrap());
    let c = render(&world, 8_000_000, 1, 7);
    let accel = Accel::build(&world);
    let floor = compare::object_mask(&world, &accel, "floor");
    // The shadow: floor pixels that the light reaches only through the glass.
    let shadow: Vec<bool> = floor
        .iter()
        .zip(&c.direct.pixels)
        .map(|(f, d)| *f && *d == Vec3::ZERO)
        .collect();
    assert!(shadow.iter().filter(|s| **s).count() > 300);
    let reference = mitsuba("lowpoly-glass-ptracer-262144spp.exr");
    let total = c.total();
    let all = compare::compare(&total, &reference, &floor);
    let dark = compare::compare(&total, &reference, &shadow);
    eprintln!("low-poly glass ball: floor {all:?}, shadow {dark:?}");
    assert!((dark.flux_ratio - 1.0).abs() <= 0.02, "shadow {dark:?}");
    assert!(dark.rel_l1 <= 0.03, "shadow {dark:?}");
    assert!((all.flux_ratio - 1.0).abs() <= 0.01, "floor {all:?}");
    assert!(all.rel_l1 <= 0.03, "floor {all:?}");
}

/// A bright focus keeps its flux as the photon count grows: the sphere's caustic at 16 × 16
/// pixels, where its brightest pixel takes about a fifth of the caustic photons, at 2 M and at
/// 16 M photons. Summed in f32, the 16 M image was 2.3 % off the 2 M one there (each splat is
/// rounded against a sum millions of times larger); the reference sums in f64.
#[test]
fn a_focus_keeps_its_flux_as_photons_grow() {
    let mut world = scenes::load("glass-sphere-directional");
    world.camera.width = 16;
    world.camera.height = 16;
    let few = render(&world, 2_000_000, 1, 3).caustics;
    let many = render(&world, 16_000_000, 1, 4).caustics;
    let lum = |v: &Vec3| v.element_sum();
    let focus = (0..few.pixels.len())
        .max_by(|&a, &b| lum(&few.pixels[a]).total_cmp(&lum(&few.pixels[b])))
        .unwrap();
    let total = |f: &caustica::frame::Frame| f.pixels.iter().map(lum).sum::<f32>();
    assert!(lum(&few.pixels[focus]) > 0.15 * total(&few), "a focus");
    let ratio = lum(&many.pixels[focus]) / lum(&few.pixels[focus]);
    let whole = total(&many) / total(&few);
    eprintln!("focus 16M / 2M: {ratio}, whole caustic {whole}");
    assert!((ratio - 1.0).abs() <= 0.01, "focus {ratio}");
    assert!((whole - 1.0).abs() <= 0.005, "whole caustic {whole}");
}
