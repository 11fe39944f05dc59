//! Method `photons` (progressive GPU photon tracing with photon differentials): its caustics
//! against the stored reference on glass and mirror objects under every light type, its
//! progression (more frames come closer; the error target and the time budget stop it), a line
//! light against the reference rendered here, and its parameters through the CLI.
//!
//! Sized for CI: 262,144 photons a frame, one or two frames; the stored references are 8 M to
//! 64 M photons (tests/data/reference/README.md).

use crate::support::{caustica, gpu, images, scenes};
use caustica::frame::Frame;
use caustica::reference::{self, ReferenceParams, compare};
use caustica::render::RenderOptions;
use caustica::render::photons::gpu::PhotonsRun;
use caustica::render::photons::{PhotonsLayer, PhotonsParams};
use caustica::scene::World;
use caustica::trace::Accel;

fn params(photons: u32, frames: u32) -> PhotonsParams {
    PhotonsParams {
        photons,
        frames,
        ..Default::default()
    }
}

fn render(world: &World, p: &PhotonsParams) -> (Frame, PhotonsRun) {
    let layer = PhotonsLayer::build(world, p);
    let out = gpu::renderer()
        .render_photons(world, &RenderOptions::default(), &layer)
        .expect("renders");
    (
        out.caustics.expect("a caustics layer"),
        out.photons.expect("the progression's figures"),
    )
}

/// Relative L1 (3×3 blur) and flux ratio of `a` against `b` where the camera sees `object`.
fn error(world: &World, object: &str, a: &Frame, b: &Frame) -> (f32, f32) {
    let mask = compare::object_mask(world, &Accel::build(world), object);
    let e = compare::compare(a, b, &mask);
    (e.rel_l1, e.flux_ratio)
}

fn sized(name: &str, size: u32) -> World {
    let mut w = scenes::load(name);
    w.camera.width = size;
    w.camera.height = size;
    w
}

/// Target of the issue: 10 % relative L1 and flux within 3 % of the reference.
fn assert_close(what: &str, (l1, flux): (f32, f32)) {
    eprintln!("{what}: relative L1 {l1:.4}, flux {flux:.4}");
    assert!(l1 <= 0.10, "{what}: relative L1 {l1}");
    assert!((flux - 1.0).abs() <= 0.03, "{what}: flux {flux}");
}

#[test]
fn the_glass_sphere_matches_the_reference_under_each_delta_light() {
    for (light, photons) in [("directional", "64M"), ("spot", "32M"), ("point", "32M")] {
        let name = format!("glass-sphere-{light}");
        let world = scenes::load(&name);
        let (img, run) = render(&world, &params(1 << 18, 1));
        assert_eq!((run.frames, run.photons), (1, 1 << 18));
        let reference = images::stored_reference(&format!("{name}.caustics.{photons}.exr"));
        assert_close(&name, error(&world, "floor", &img, &reference));
    }
}

/// The mirror ring under a directional light, a spot light, the sun-and-sky map and a constant
/// sky (environment photons from importance-sampled directions of the map), and the chrome
/// Suzanne (a glTF mesh with smooth normals) under the map.
#[test]
fn mirrors_match_the_reference_under_far_near_and_environment_lights() {
    for (name, receiver) in [
        ("mirror-ring", "floor"),
        ("mirror-ring-spot", "floor"),
        ("mirror-ring-env", "floor"),
        ("mirror-ring-sky", "floor"),
        ("chrome-suzanne", "table"),
    ] {
        let world = sized(name, 96);
        let (img, _) = render(&world, &params(1 << 18, 2));
        let reference = images::stored_reference(&format!("{name}.caustics.8M.exr"));
        assert_close(name, error(&world, receiver, &img, &reference));
    }
}

/// Glass nobody tuned the method for: the glass teapot (a glTF mesh with a handle, a spout and
/// a hollow body) under a directional light, the glass vases under a spot light on the wooden
/// table, KHR's AttenuationTest (flat-sided blocks of absorbing glass, five thicknesses, whose
/// sharp-edged caustics take more photons) and a lumpy organic blob (concave folds, smooth
/// normals), at 128 × 128.
#[test]
fn glass_objects_nobody_tuned_for_match_the_reference() {
    for (name, receiver, photons) in [
        ("glass-teapot", "floor", 4u32),
        ("glass-vase", "table", 4),
        ("glass-attenuation", "board", 16),
        ("glass-blob", "floor", 1),
    ] {
        let world = sized(name, 128);
        let p = PhotonsParams {
            photons: 1 << 19,
            frames: photons,
            ..Default::default()
        };
        let (img, _) = render(&world, &p);
        let reference = images::stored_reference(&format!("{name}.caustics.32M.exr"));
        assert_close(name, error(&world, receiver, &img, &reference));
    }
}

/// A line light over the glass sphere, against the reference's caustics rendered here.
#[test]
fn a_line_light_matches_the_reference() {
    let mut v = scenes::scene_sized(64, 64);
    v["lights"] = serde_json::json!([
        {"type": "line", "start": [-2.0, 2.4, -0.5], "end": [-2.0, 2.4, 0.5], "intensity": 12.0}
    ]);
    let world = scenes::parse(&v.to_string());
    let accel = Accel::build(&world);
    let rp = ReferenceParams {
        photons: 6_000_000,
        spp: 1,
        seed: 3,
        ..Default::default()
    };
    let (c, _) = reference::render(&world, &accel, &rp, &|_| true).expect("renders");
    let (img, _) = render(&world, &params(1 << 18, 2));
    assert_close("line light", error(&world, "floor", &img, &c.caustics));
}

/// Frames add photons: eight frames come closer to the reference than one; an error target
/// stops the progression once the noise estimate reaches it, a time budget after the frame
/// that passes it, and the caller between frames.
#[test]
fn frames_converge_and_stop_at_the_error_target_or_the_time_budget() {
    let world = scenes::load("glass-sphere-directional");
    let reference = images::stored_reference("glass-sphere-directional.caustics.64M.exr");
    let (one, _) = render(&world, &params(1 << 16, 1));
    let (eight, run) = render(&world, &params(1 << 16, 8));
    assert_eq!((run.frames, run.stopped_by), (8, "frames"));
    let e1 = error(&world, "floor", &one, &reference);
    let e8 = error(&world, "floor", &eight, &reference);
    eprintln!("1 frame {e1:?}, 8 frames {e8:?}");
    assert!(e8.0 < 0.8 * e1.0, "one frame {e1:?}, eight {e8:?}");

    // Two frames of 65,536 photons estimate a noise of about 0.06 here: 0.03 takes more.
    let target = PhotonsParams {
        error_target: Some(0.03),
        ..params(1 << 16, 64)
    };
    let (_, run) = render(&world, &target);
    eprintln!("error target 0.03: {run:?}");
    assert_eq!(run.stopped_by, "error target");
    assert!(run.error_estimate.is_some_and(|e| e <= 0.03), "{run:?}");
    assert!(
        (4..64).contains(&run.frames) && run.frames % 2 == 0,
        "{run:?}"
    );

    let budget = PhotonsParams {
        time_budget: Some(std::time::Duration::from_millis(1)),
        ..params(1 << 16, 64)
    };
    let (img, run) = render(&world, &budget);
    assert_eq!((run.frames, run.stopped_by), (1, "time budget"));
    // A render the caller gives up on (a job canceled or past its time) stops between frames.
    let asked = std::sync::atomic::AtomicU32::new(0);
    let keep_going = || asked.fetch_add(1, std::sync::atomic::Ordering::SeqCst) < 2;
    let layer = PhotonsLayer::build(&world, &params(1 << 16, 64));
    let out = gpu::renderer()
        .render_photons_while(&world, &RenderOptions::default(), &layer, &keep_going)
        .expect("renders");
    let run = out.photons.expect("the progression's figures");
    assert_eq!((run.frames, run.stopped_by), (3, "canceled"));
    // One frame is a whole estimate: the flux is already right.
    let (_, flux) = error(&world, "floor", &img, &reference);
    assert!((flux - 1.0).abs() <= 0.03, "flux {flux}");
}

#[test]
fn the_cli_renders_photons_and_names_a_bad_parameter() {
    let dir = crate::support::temp_dir("photons-cli");
    let out = dir.join("p.exr");
    let scene = scenes::path("glass-sphere-point");
    let o = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--method",
        "photons",
        "--width",
        "64",
        "--height",
        "64",
        "--photons",
        "65536",
        "--photons-per-frame",
        "32768",
        "--component",
        "caustics",
        "--out",
        out.to_str().unwrap(),
    ]);
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{said}");
    assert!(
        said.contains("65536 photons in 2 frames of 32768"),
        "{said}"
    );
    let img = images::read_frame(&out);
    assert!(images::peak(&img) > 0.0, "a caustic");
    let o = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--method",
        "photons",
        "--footprint",
        "20",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("progressive.footprint"), "{stderr}");
}
