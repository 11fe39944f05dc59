//! Method `beams` (Liktor and Dachsbacher 2010): the volumetric and surface caustics of both fog
//! scenes against the stored reference at grid 128, two-sided refraction against the paper's
//! one-sided beams, shadowed beams, the false-triangle removal across a depth edge, and the
//! method's parameters through the CLI.
//!
//! Sized for CI: 80 × 60 frames; the stored references (tests/data/reference/README.md) are
//! single-scattering renders of the reference with 200 M photons.

use crate::support::{caustica, gpu, images, scenes, temp_dir};
use caustica::frame::Frame;
use caustica::reference::compare;
use caustica::render::beams::{BeamsLayer, BeamsParams};
use caustica::render::{RenderOptions, RenderOutput};
use caustica::scene::World;
use glam::Vec3;

const W: u32 = 80;
const H: u32 = 60;

fn sized(mut world: World) -> World {
    world.camera.width = W;
    world.camera.height = H;
    world
}

fn render(world: &World, params: &BeamsParams) -> (RenderOutput, BeamsLayer) {
    let layer = BeamsLayer::build(world, params);
    let out = gpu::renderer()
        .render_beams(world, &RenderOptions::default(), &layer)
        .expect("renders");
    (out, layer)
}

/// Relative L1 (3×3 blur) and flux ratio of `a` against `b` over every pixel (each sees the
/// fog of these scenes).
fn error(a: &Frame, b: &Frame) -> (f32, f32) {
    let e = compare::compare(a, b, &vec![true; a.pixels.len()]);
    (e.rel_l1, e.flux_ratio)
}

fn stored(scene: &str, component: &str) -> Frame {
    images::stored_reference(&format!("{scene}.{component}.200M.exr"))
}

fn sum(f: &Frame, keep: impl Fn(u32, u32) -> bool) -> f32 {
    (0..f.height)
        .flat_map(|y| (0..f.width).map(move |x| (x, y)))
        .filter(|&(x, y)| keep(x, y))
        .map(|(x, y)| f.pixels[(y * f.width + x) as usize].x)
        .sum()
}

#[test]
fn the_paraboloid_in_fog_matches_the_reference() {
    let world = sized(scenes::load("fog-paraboloid"));
    let (out, layer) = render(&world, &BeamsParams::default());
    assert!(layer.stats.reflective_beams > 10_000, "{:?}", layer.stats);
    let volume = out.volume_caustics.as_ref().expect("a volume layer");
    let (l1, flux) = error(volume, &stored("fog-paraboloid", "volume_caustics"));
    eprintln!("paraboloid, grid 128: volume {l1:.4} relative L1, flux {flux:.4}");
    assert!(l1 <= 0.15 && (flux - 1.0).abs() <= 0.05, "{l1} {flux}");
    // The focus is the brightest place of the volume, and lies on the axis at the focal length
    // above the dish: the ray through its pixel passes within a few centimetres of (0, 0.65, 0).
    let (i, _) = volume
        .pixels
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.x.total_cmp(&b.1.x))
        .unwrap();
    let d = world
        .camera
        .ray_dir((i as u32 % W) as f32 + 0.5, (i as u32 / W) as f32 + 0.5);
    let focus = Vec3::new(0.0, 0.65, 0.0);
    let o = world.camera.eye;
    let miss = (focus - o).cross(d).length();
    assert!(
        miss < 0.05,
        "the brightest pixel's ray passes {miss} m from the focus"
    );
    // The volume at half resolution, upsampled edge-aware (§6), stays close.
    let (half, _) = render(
        &world,
        &BeamsParams {
            downsample: 2,
            ..Default::default()
        },
    );
    let (l1h, fluxh) = error(
        half.volume_caustics.as_ref().unwrap(),
        &stored("fog-paraboloid", "volume_caustics"),
    );
    eprintln!("paraboloid, grid 128, half resolution: {l1h:.4} relative L1, flux {fluxh:.4}");
    assert!(l1h <= 0.2 && (fluxh - 1.0).abs() <= 0.05, "{l1h} {fluxh}");
}

#[test]
fn the_glass_sphere_under_a_spot_in_fog_matches_the_reference_and_needs_two_sided_beams() {
    let world = sized(scenes::load("fog-glass-sphere-spot"));
    let (out, layer) = render(&world, &BeamsParams::default());
    let s = &layer.stats;
    assert!(
        s.reflective_beams > 10_000 && s.refractive_beams > 3 * s.reflective_beams / 2,
        "{s:?}"
    );
    let ref_volume = stored("fog-glass-sphere-spot", "volume_caustics");
    let ref_surface = stored("fog-glass-sphere-spot", "caustics");
    let (l1, flux) = error(out.volume_caustics.as_ref().unwrap(), &ref_volume);
    eprintln!("sphere, grid 128: volume {l1:.4} relative L1, flux {flux:.4}");
    assert!(l1 <= 0.15 && (flux - 1.0).abs() <= 0.05, "{l1} {flux}");
    // The surface caustics from the same beams.
    let (sl1, sflux) = error(out.caustics.as_ref().unwrap(), &ref_surface);
    eprintln!("sphere, grid 128: surface {sl1:.4} relative L1, flux {sflux:.4}");
    assert!(sl1 <= 0.15 && (sflux - 1.0).abs() <= 0.1, "{sl1} {sflux}");
    // The direct light crosses the fog both ways (the direct pass and the fog pass).
    let (dl1, dflux) = error(&out.direct, &stored("fog-glass-sphere-spot", "direct"));
    eprintln!("sphere: direct {dl1:.4} relative L1, flux {dflux:.4}");
    assert!(dl1 <= 0.05 && (dflux - 1.0).abs() <= 0.02, "{dl1} {dflux}");

    // The paper's one-sided refraction: beams leave the sphere's front along the refracted
    // directions, through the glass, and no light leaves its back where it should.
    let one = BeamsParams {
        two_sided: false,
        ..Default::default()
    };
    let (out1, _) = render(&world, &one);
    let (l1_one, _) = error(out1.volume_caustics.as_ref().unwrap(), &ref_volume);
    let (sl1_one, _) = error(out1.caustics.as_ref().unwrap(), &ref_surface);
    eprintln!("one-sided: volume {l1_one:.4}, surface {sl1_one:.4}");
    assert!(
        l1_one > 2.0 * l1 && sl1_one > 2.0 * sl1,
        "{l1_one} {sl1_one}"
    );
}

/// The paper's touching-plane prisms (the hull where their planes fail: every beam of a
/// focusing mirror crosses its focus) cover each pixel of a beam once, as the hull does: the
/// same image. A mirror ball in fog under the sun: its beams diverge, most get a prism.
#[test]
fn touching_plane_prisms_draw_what_the_hull_draws() {
    let world = scenes::parse(
        r#"{"camera": {"eye": [0, 1.2, 3.5], "target": [0, 0.8, 0], "width": 60, "height": 45},
            "lights": [{"type": "directional", "direction": [0.3, -1, 0.2], "irradiance": 2}],
            "materials": {"m": {"type": "mirror", "reflectance": 0.9},
                          "floor": {"type": "diffuse", "albedo": 0.5}},
            "objects": [
              {"name": "floor", "shape": {"type": "plane", "size": [6, 6]}, "material": "floor"},
              {"name": "ball", "shape": {"type": "sphere", "radius": 0.4, "segments": 64},
               "material": "m", "transform": {"translation": [0, 0.6, 0]}}],
            "media": [{"sigma_s": 0.3, "sigma_a": 0.02, "g": 0.3,
                       "bounds": {"type": "box", "size": [6, 3, 6],
                                  "transform": {"translation": [0, 1.5, 0]}}}]}"#,
    );
    let p = |bounds| BeamsParams {
        grid: 64,
        bounds,
        ..Default::default()
    };
    use caustica::render::beams::Bounds;
    let (hull, hull_layer) = render(&world, &p(Bounds::Hull));
    let (prism, prism_layer) = render(&world, &p(Bounds::TouchingPlanes));
    let prisms = prism_layer
        .beams
        .iter()
        .zip(&hull_layer.beams)
        .filter(|(a, b)| a.cap != b.cap)
        .count();
    eprintln!(
        "{prisms} of {} beams drawn as touching-plane prisms",
        hull_layer.beams.len()
    );
    assert!(prisms > hull_layer.beams.len() / 2, "{prisms}");
    let v = hull.volume_caustics.as_ref().unwrap();
    assert!(images::peak(v) > 0.0);
    let (same, _) = error(prism.volume_caustics.as_ref().unwrap(), v);
    let (surface, _) = error(
        prism.caustics.as_ref().unwrap(),
        hull.caustics.as_ref().unwrap(),
    );
    assert!(same < 1e-4 && surface < 1e-4, "{same} {surface}");
}

/// The fog lit directly (the in-scattering pass, the `volume` component) against the closed form
/// of single scattering in the slab of `scenes::fog_slab`, per pixel.
#[test]
fn the_fog_lit_directly_is_the_closed_form_in_a_slab() {
    let (world, closed_form) = scenes::fog_slab();
    let (out, layer) = render(&world, &BeamsParams::default());
    assert!(layer.beams.is_empty());
    let volume = out.volume.as_ref().expect("an in-scattering layer");
    let cam = &world.camera;
    let rays = cam.rays();
    let (mut diff, mut sum) = (0.0f64, 0.0f64);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let want = closed_form(rays.dir(x as f32 + 0.5, y as f32 + 0.5));
            let got = volume.pixels[(y * cam.width + x) as usize];
            diff += f64::from((got - want).abs().element_sum());
            sum += f64::from(want.element_sum());
        }
    }
    let rel = diff / sum;
    eprintln!("the fog lit directly against the closed form: {rel:.4} relative L1");
    assert!(rel < 0.02, "{rel}");
    // The total holds it.
    let total = out.total();
    assert_eq!(
        total.pixels[0],
        volume.pixels[0] + out.direct.pixels[0] + out.specular.pixels[0]
    );
}

/// A shelf over the right part of the paraboloid's cone: with shadows its beams end on it and
/// the fog above it stays as dark as in the reference; the paper's beams run on through it.
#[test]
fn an_occluder_cuts_the_beams() {
    let world = sized(scenes::parse(
        &std::fs::read_to_string(crate::support::repo_path(
            "tests/data/beams/fog-paraboloid-shelf.json",
        ))
        .unwrap(),
    ));
    let reference = stored("fog-paraboloid-shelf", "volume_caustics");
    // Above the shelf: the pixels whose rays pass over it.
    let cam = &world.camera;
    let above = |x: u32, y: u32| {
        let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
        // Where the ray crosses z = 0 (the shelf's middle), it is over the shelf.
        let t = -cam.eye.z / d.z;
        let p = cam.eye + d * t;
        p.x > 0.8 && p.x < 1.6 && p.y > 1.6
    };
    assert!(
        (0..H)
            .flat_map(|y| (0..W).map(move |x| (x, y)))
            .filter(|&(x, y)| above(x, y))
            .count()
            > 30
    );
    let (shadowed, _) = render(&world, &BeamsParams::default());
    let (through, _) = render(
        &world,
        &BeamsParams {
            shadows: false,
            ..Default::default()
        },
    );
    let r = sum(&reference, above);
    let s = sum(shadowed.volume_caustics.as_ref().unwrap(), above);
    let t = sum(through.volume_caustics.as_ref().unwrap(), above);
    eprintln!("over the shelf: reference {r}, shadowed beams {s}, unshadowed {t}");
    assert!((s - r).abs() <= 0.15 * r, "{s} against {r}");
    assert!(t > 1.5 * r, "{t} against {r}");
    // Elsewhere the shadows change nothing.
    let (l1, flux) = error(shadowed.volume_caustics.as_ref().unwrap(), &reference);
    assert!(l1 <= 0.15 && (flux - 1.0).abs() <= 0.05, "{l1} {flux}");
}

/// Two mirrors under the sun, one 0.5 m above the other and overlapping it by half: no grid
/// triangle across the step makes a beam (its vertices took different paths; within one object
/// the step makes it a false triangle, §3.1 Fig. 4: `render::beams` tests that), while each
/// mirror makes its own.
#[test]
fn no_beam_spans_a_depth_edge() {
    let world = scenes::parse(
        r#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0], "width": 32, "height": 24},
            "lights": [{"type": "directional", "direction": [0.2, -1, 0.1], "irradiance": 1}],
            "materials": {"m": {"type": "mirror", "reflectance": 0.9}},
            "objects": [
              {"name": "low", "shape": {"type": "plane", "size": [1, 1]}, "material": "m"},
              {"name": "high", "shape": {"type": "plane", "size": [1, 1]}, "material": "m",
               "transform": {"translation": [0.5, 0.5, 0]}}]}"#,
    );
    for grid in [32, 64] {
        let layer = BeamsLayer::build(
            &world,
            &BeamsParams {
                grid,
                ..Default::default()
            },
        );
        let s = &layer.stats;
        assert!(s.dropped_paths > 0, "{s:?}");
        let (mut low, mut high) = (0, 0);
        for e in &layer.entries {
            let ys = e.map(|p| p.y);
            let on_low = ys.iter().all(|y| y.abs() < 1e-3);
            let on_high = ys.iter().all(|y| (y - 0.5).abs() < 1e-3);
            assert!(on_low || on_high, "a beam across the step: {e:?}");
            low += usize::from(on_low);
            high += usize::from(on_high);
        }
        assert!(low > 100 && high > 100, "{low} {high}");
        // Beam space: every beam's photons leave its base on one side, and its area function
        // is the base's doubled area at height 0.
        for b in &layer.beams {
            let c = b.abc[2].abs();
            assert!((c - b.ax[3]).abs() <= 1e-3 * c, "{b:?}");
        }
    }
}

#[test]
fn the_cli_renders_beams_and_refuses_bad_parameters() {
    let dir = temp_dir("beams-cli");
    let out = dir.join("f.exr");
    let o = caustica(&[
        "render",
        scenes::path("fog-paraboloid").to_str().unwrap(),
        "--method",
        "beams",
        "--grid",
        "32",
        "--width",
        "40",
        "--height",
        "30",
        "--component",
        "volume_caustics",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let f = images::read_frame(&out);
    assert!(images::peak(&f) > 0.0);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("beams ("), "{err}");
    for (flag, value, field) in [
        ("--grid", "100", "beams.grid"),
        ("--beam-samples", "0", "beams.samples"),
        ("--downsample", "3", "beams.downsample"),
    ] {
        let o = caustica(&[
            "render",
            scenes::path("fog-paraboloid").to_str().unwrap(),
            "--method",
            "beams",
            flag,
            value,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(field), "{flag} {value}: {err}");
    }
    // Without a medium the beams give the surface caustics alone, and say so.
    let o = caustica(&[
        "render",
        scenes::path("glass-sphere-directional").to_str().unwrap(),
        "--method",
        "beams",
        "--grid",
        "32",
        "--width",
        "32",
        "--height",
        "32",
        "--component",
        "caustics",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no medium"));
    assert!(images::peak(&images::read_frame(&out)) > 0.0);
    // A scene without glass or mirrors has no beams to cast.
    let bare = dir.join("bare.json");
    std::fs::write(
        &bare,
        r#"{"camera": {"eye": [0, 2, 2], "target": [0, 0, 0], "width": 16, "height": 16},
            "lights": [{"type": "directional", "direction": [0, -1, 0], "irradiance": 1}],
            "materials": {"m": {"type": "diffuse", "albedo": 0.5}},
            "objects": [{"name": "floor", "shape": {"type": "plane", "size": [2, 2]}, "material": "m"}]}"#,
    )
    .unwrap();
    let o = caustica(&[
        "render",
        bare.to_str().unwrap(),
        "--method",
        "beams",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("scene.objects"));
    // Fog inside a mesh is the reference's alone.
    let meshed = dir.join("meshed.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scenes::path("fog-paraboloid")).unwrap())
            .unwrap();
    v["media"][0]["bounds"] = serde_json::json!(
        {"type": "mesh", "shape": {"type": "sphere", "radius": 1.5}}
    );
    std::fs::write(&meshed, v.to_string()).unwrap();
    let o = caustica(&[
        "render",
        meshed.to_str().unwrap(),
        "--method",
        "beams",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("scene.media") && err.contains("reference"),
        "{err}"
    );
}
