//! How close `csl` (a static bake for exactly each light direction, and optionally a dynamic
//! bake interpolated there) and `photons` come to the reference over the whole sphere of light
//! directions that light the floor: the canonical glass sphere (`scenes/glass-sphere-directional.json`)
//! under directional lights drawn at random (fixed seed) over the upper hemisphere, down to 20°
//! above the horizon. For each direction the camera looks down on the sphere's shadow from the
//! side away from the light; the reference's caustics (`caustics_only`, this many photons) are
//! the truth; each method is compared with it in the sphere's shadow (relative L1 after a 3×3
//! blur, flux ratio: `compare::shadow_mask`). From the repository root:
//!
//!     cargo run --release --example glass_sweep -- [--directions N] [--seed S] [--size PX] \
//!         [--grid G] [--photons REFERENCE_PHOTONS] [--dynamic BAKE.csld] [--gpu-photons N] \
//!         [--only I]
//!
//! `--references DIR` writes each reference's caustics as
//! `DIR/glass-sphere-sweep-II.caustics.NM.exr` (the sweep test's stored images: `--directions 20
//! --size 128 --photons 8000000 --no-csl`); `--truth DIR` reads each from there where a
//! previous run wrote it (the same size and scene) instead of rendering it again. `--write
//! DIR`: every image as PNG and EXR, and the shadow mask. `--verbose`: each static CSL's
//! figures. `--fit-samples`, `--fit-threshold`, `--splat-scale`: the bake's parameters of
//! those names.
//!
//! `--around I [--spread DEG]`: instead of the sweep, N directions within DEG degrees
//! (elevation and azimuth, default 2) of the sweep's direction I, the first exactly it: how much
//! bakes scatter between neighbouring directions (references rendered, never read).
//!
//! `--corners SUB`: also the static sets baked at the three directions of the dynamic bake's
//! icosphere (SUB subdivisions, the paper's 2) around each light, each turned onto the light
//! alone: what the dynamic bake interpolates from, without the interpolation.
//!
//! `--scene FILE --object NAME`: another glass object on a floor at y = 0 (the scene's first
//! light directional). `--no-csl` skips the static bakes.
//!
//! Prints one line per direction and, at the end, the worst of each column.

use caustica::bake::csl::dynamic::DynamicSet;
use caustica::bake::csl::{CslParams, CslSet, bake_csl};
use caustica::reference::sweep::{self, SweepCase};
use caustica::reference::{self, ReferenceParams, compare};
use caustica::render::csl::eval;
use caustica::trace::Accel;

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
}

/// `DIR/II-NAME.png` (clamped) and `.exr` (linear).
fn write_frame(
    dir: &str,
    i: usize,
    name: &str,
    f: &caustica::frame::Frame,
) -> Result<(), Box<dyn std::error::Error>> {
    let png = caustica::encode::encode_png(f, Default::default())?;
    std::fs::write(format!("{dir}/{i:02}-{name}.png"), png)?;
    std::fs::write(
        format!("{dir}/{i:02}-{name}.exr"),
        caustica::encode::encode_exr(f)?,
    )?;
    Ok(())
}

/// How much bakes scatter between neighbouring directions: `n` directions within `spread`
/// degrees (elevation and azimuth) of the sweep's direction `centre`, the first exactly it.
fn around(n: usize, seed: u64, centre: usize, spread: f32) -> Vec<SweepCase> {
    let c = sweep::directions(centre + 1, seed)[centre];
    let mut rng = caustica::sampling::Pcg::new(seed, 57);
    (0..n)
        .map(|k| {
            let mut jitter = || spread * (2.0 * rng.f32() - 1.0);
            let (de, da) = if k == 0 {
                (0.0, 0.0)
            } else {
                (jitter(), jitter())
            };
            let (e, a) = (
                (c.elevation_deg + de).to_radians(),
                (c.azimuth_deg + da).to_radians(),
            );
            SweepCase {
                direction: glam::Vec3::new(-e.cos() * a.cos(), -e.sin(), -e.cos() * a.sin()),
                elevation_deg: e.to_degrees(),
                azimuth_deg: a.to_degrees(),
            }
        })
        .collect()
}

/// Each CSL of `set`, baked for the light `local`: `--verbose`.
fn print_csls(set: &CslSet, local: glam::Vec3) {
    for (k, c) in set.csls.iter().enumerate() {
        let off = (set.centre - c.origin).cross(c.axis).length();
        println!(
            "  csl {k}: flux {:.4} axis {:.3}° from the light, line {:.2e} m from the \
             centre, focus at r=0 {:.4} m, kappa {:.4} gamma {:.4}, half extent {:.4}, {}²",
            c.flux,
            c.axis.angle_between(local).to_degrees(),
            off,
            1.0 / c.kappa,
            c.kappa,
            c.gamma,
            c.half_extent,
            c.size
        );
    }
}

/// The reference's caustics of `world`: `photons`, `seed`.
fn render_truth(
    world: &caustica::scene::World,
    accel: &Accel,
    photons: u64,
    seed: u64,
) -> Result<caustica::frame::Frame, Box<dyn std::error::Error>> {
    let params = ReferenceParams {
        photons,
        seed,
        caustics_only: true,
        ..Default::default()
    };
    Ok(reference::render(world, accel, &params, &|_| true)?
        .0
        .caustics)
}

/// A corner's index, its weight at the light, its angle to the light (degrees) and its set
/// turned onto the light.
type Corner = (u32, f32, f32, CslSet);

/// The corner sets of the dynamic bake's icosphere face (`sub` subdivisions) around the light
/// `local` (the object's rigid frame), each baked for its corner's direction and turned onto the
/// light alone: what interpolation starts from. Each with its corner's index, its weight there
/// and its angle to the light (degrees).
fn corner_sets(
    world: &caustica::scene::World,
    object: &str,
    local: glam::Vec3,
    params: &CslParams,
    sub: u32,
) -> Result<Vec<Corner>, Box<dyn std::error::Error>> {
    let ico = caustica::bake::csl::dynamic::Icosphere::new(sub);
    let (f, w) = ico.locate(local);
    let mut sets = Vec::new();
    for (k, &v) in ico.faces[f].iter().enumerate() {
        let corner = ico.vertices[v as usize];
        let set = bake_csl(world, object, corner, params, &|_| true)?;
        let q = glam::Mat3::from_quat(glam::Quat::from_rotation_arc(corner, local));
        let angle = corner.angle_between(local).to_degrees();
        let turned = CslSet {
            csls: set
                .csls
                .iter()
                .map(|c| c.clone().turned(set.centre, q))
                .collect(),
            light_dir: local,
            ..set
        };
        sets.push((v, w[k], angle, turned));
    }
    Ok(sets)
}

// One loop over the directions whose body adds the table's columns in turn, each a few lines
// over the helpers above: longer than 150 lines because the options are many, not the work.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = arg(&args, "--directions").unwrap_or(50);
    let seed: u64 = arg(&args, "--seed").unwrap_or(56);
    let size: u32 = arg(&args, "--size").unwrap_or(256);
    let grid: u32 = arg(&args, "--grid").unwrap_or(CslParams::paper().grid);
    let photons: u64 = arg(&args, "--photons").unwrap_or(16_000_000);
    let gpu_photons: Option<u32> = arg(&args, "--gpu-photons");
    let only: Option<usize> = arg(&args, "--only");
    let dynamic = match arg::<String>(&args, "--dynamic") {
        Some(p) => Some(DynamicSet::from_bytes(&std::fs::read(p)?)?),
        None => None,
    };
    let scene: String =
        arg(&args, "--scene").unwrap_or("scenes/glass-sphere-directional.json".into());
    let object: String = arg(&args, "--object").unwrap_or("glass".into());
    let base = caustica::scene::load_scene_file(scene.as_ref(), &Default::default())?;
    let references: Option<String> = arg(&args, "--references");
    let truth_dir: Option<String> = arg(&args, "--truth");
    let verbose = args.iter().any(|a| a == "--verbose");
    let no_csl = args.iter().any(|a| a == "--no-csl");
    let write: Option<String> = arg(&args, "--write");
    let scene_camera = args.iter().any(|a| a == "--scene-camera");
    let gpu = args.iter().any(|a| a == "--gpu");
    let corners: Option<u32> = arg(&args, "--corners");
    let mut renderer = match gpu || gpu_photons.is_some() {
        true => Some(caustica::render::Renderer::new(std::sync::Arc::new(
            caustica::gpu::GpuContext::new(&Default::default())?,
        ))?),
        false => None,
    };
    let paper = CslParams::paper();
    let params = CslParams {
        grid,
        fit_samples: arg(&args, "--fit-samples").unwrap_or(paper.fit_samples),
        fit_threshold_deg: arg(&args, "--fit-threshold").unwrap_or(paper.fit_threshold_deg),
        splat_scale: arg(&args, "--splat-scale").unwrap_or(paper.splat_scale),
        ..paper
    };
    let mut worst: Vec<(f32, f32, usize)> = Vec::new();
    let mut cases = sweep::directions(n, seed);
    if let Some(centre) = arg::<usize>(&args, "--around") {
        cases = around(n, seed, centre, arg(&args, "--spread").unwrap_or(2.0));
    }
    if args.iter().any(|a| a == "--scene-light") {
        let (d, _) = caustica::bake::csl::scene_directional_light(&base).expect("directional");
        let d = d.normalize();
        cases = vec![SweepCase {
            direction: d,
            elevation_deg: (-d.y).asin().to_degrees(),
            azimuth_deg: (-d.z).atan2(-d.x).to_degrees(),
        }];
    }
    for (i, case) in cases.into_iter().enumerate() {
        if only.is_some_and(|o| o != i) {
            continue;
        }
        let SweepCase {
            direction,
            elevation_deg,
            azimuth_deg,
        } = case;
        let mut world = sweep::lit_from(&base, &object, direction, size);
        if scene_camera {
            world.camera = caustica::scene::Camera {
                width: size,
                height: size,
                ..base.camera.clone()
            };
        }
        let accel = Accel::build(&world);
        let oi = world.object_index(&object).expect("the glass object");
        let blockers = Accel::build_with(&world, |k| k != oi, obvhs::BvhBuildParams::fast_build());
        let mask = compare::shadow_mask(&world, &accel, "floor", &object, direction);
        let t = std::time::Instant::now();
        let file = format!(
            "glass-sphere-sweep-{i:02}.caustics.{}M.exr",
            photons / 1_000_000
        );
        let stored = truth_dir
            .as_ref()
            .filter(|_| !args.iter().any(|a| a == "--around"))
            .map(|d| format!("{d}/{file}"));
        let truth = match stored.as_ref().map(std::fs::read) {
            Some(Ok(bytes)) => caustica::encode::decode_frame(&bytes)?,
            _ => render_truth(&world, &accel, photons, 1000 + i as u64)?,
        };
        let t_ref = t.elapsed();
        if let Some(dir) = &references {
            // The stored references of the sweep test (tests/data/reference/README.md).
            std::fs::write(
                format!("{dir}/{file}"),
                caustica::encode::encode_exr(&truth)?,
            )?;
        }
        if let Some(dir) = &write {
            write_frame(dir, i, "reference", &truth)?;
            let m: Vec<u8> = mask.iter().map(|&b| b as u8 * 255).collect();
            std::fs::write(format!("{dir}/{i:02}-mask.raw"), m)?;
        }
        let irradiance = caustica::bake::csl::scene_directional_light(&world)
            .map(|(_, e)| e)
            .expect("a directional light");
        let local = world.objects[oi].to_rigid_frame(direction);
        let draw = |set: &CslSet| {
            let csls = set.to_world(world.objects[oi].rigid_transform());
            eval::render_caustics(&world, &accel, &blockers, &csls, irradiance, 3)
        };
        let mut line = format!(
            "{i:2} elevation {elevation_deg:5.1}° azimuth {azimuth_deg:6.1}° ({} px, reference {t_ref:.1?})",
            mask.iter().filter(|&&m| m).count()
        );
        let mut cols = Vec::new();
        if !no_csl {
            let set = bake_csl(&world, &object, local, &params, &|_| true)?;
            let drawn = draw(&set);
            if verbose {
                print_csls(&set, local);
            }
            if let Some(dir) = &write {
                write_frame(dir, i, "static", &drawn)?;
            }
            let s = compare::compare(&drawn, &truth, &mask);
            line += &format!(
                " | static {:.3} / {:.3} ({} CSLs)",
                s.rel_l1,
                s.flux_ratio,
                set.csls.len()
            );
            cols.push((s.rel_l1, s.flux_ratio));
            if let Some(r) = renderer.as_mut().filter(|_| gpu) {
                // The frame a user gets: the same set drawn by the GPU passes.
                let layer = caustica::render::CslLayer::new(&world, &[(oi, &set)], irradiance);
                let out = r.render_csl(&world, &Default::default(), Some(&layer))?;
                let img = out.caustics.expect("a caustics layer");
                let s = compare::compare(&img, &truth, &mask);
                line += &format!(" | static on the GPU {:.3} / {:.3}", s.rel_l1, s.flux_ratio);
                cols.push((s.rel_l1, s.flux_ratio));
            }
        }
        if let Some(sub) = corners {
            for (v, weight, angle, set) in corner_sets(&world, &object, local, &params, sub)? {
                let s = compare::compare(&draw(&set), &truth, &mask);
                line += &format!(
                    " | corner {v} ({weight:.2}, {angle:.1}°) {:.3} / {:.3}",
                    s.rel_l1, s.flux_ratio
                );
                cols.push((s.rel_l1, s.flux_ratio));
            }
        }
        if let Some(d) = &dynamic {
            let set = d.interpolate(local);
            let s = compare::compare(&draw(&set), &truth, &mask);
            line += &format!(" | dynamic {:.3} / {:.3}", s.rel_l1, s.flux_ratio);
            cols.push((s.rel_l1, s.flux_ratio));
        }
        if let (Some(r), Some(p)) = (renderer.as_mut(), gpu_photons) {
            let layer = caustica::render::photons::PhotonsLayer::build(
                &world,
                &caustica::render::photons::PhotonsParams {
                    photons: p,
                    frames: 4,
                    ..Default::default()
                },
            );
            let out = r.render_photons(&world, &Default::default(), &layer)?;
            let img = out.caustics.expect("a caustics layer");
            let s = compare::compare(&img, &truth, &mask);
            line += &format!(" | photons {:.3} / {:.3}", s.rel_l1, s.flux_ratio);
            cols.push((s.rel_l1, s.flux_ratio));
        }
        println!("{line}");
        if worst.is_empty() {
            worst = cols.iter().map(|_| (0.0, 1.0, 0)).collect();
        }
        for (w, c) in worst.iter_mut().zip(cols) {
            if c.0 > w.0 {
                w.0 = c.0;
                w.2 = i;
            }
            if (c.1 - 1.0).abs() > (w.1 - 1.0).abs() {
                w.1 = c.1;
            }
        }
    }
    println!("worst (relative L1 at direction, flux): {worst:?}");
    Ok(())
}
