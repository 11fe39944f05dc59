//! CSL caustics against the reference on the canonical glass sphere (caustics component, floor
//! pixels seen directly, 3×3 blur). The reference image is stored
//! (`tests/data/reference/glass-sphere-directional.caustics.64M.exr`, made by our `reference`
//! method with 64 M photons; see the README beside it): a 4 M-photon render made inside the
//! test differs from it by 10 % relative L1 by photon noise alone, which would drown the
//! figure being measured (a 16 M-photon render with another seed differs from it by 7.5 %).
//!
//! Both evaluations average each pixel over a disc of its area (`Csl::arrivals_filtered`):
//! a point sample at the pixel centre misses most of a focus smaller than the pixel (before
//! that filter the GPU pass gave flux 0.851 and 2×2 samples happened to land on the focus and
//! gave 0.975; 3×3 0.900, 4×4 0.879: not converged).
//!
//! Measured (grid 512, `CslParams::fast()` otherwise; llvmpipe for the GPU):
//! - CPU, 6×6 samples per pixel: relative L1 0.175, flux 0.907;
//! - the GPU pass, one sample per pixel: relative L1 0.189, flux 0.901.
//!
//! The targets (L1 ≤ 15 %, flux within 5 %) are NOT met. Where the light is missing
//! (radial profile around the focus): within 32 px of it the CSLs hold the reference's light
//! to a few percent, beyond it they have half of it. That far light is the sphere's reflection
//! off its lower-left side and light leaving after internal reflections, spread thinly over
//! the floor; the bake finds bundles for part of it (diverging CSLs, κ < 0), and raising the
//! coverage to 99 % does not bring it back (flux 0.893 at 0.992 coverage before the filter).

use caustica::bake::csl::{CslParams, CslSet, bake_csl, cache, eval};
use caustica::encode::decode_frame;
use caustica::reference::compare;
use caustica::render::{CslLayer, RenderOptions, Renderer};
use caustica::scene::{self, Light, World};
use caustica::trace::Accel;
use std::path::Path;

fn load(path: &str) -> World {
    scene::load_scene_file(Path::new(path), &Default::default()).expect("scene loads")
}

#[test]
fn glass_sphere_caustics_match_the_reference() {
    let world = load("scenes/glass-sphere-directional.json");
    let Light::Directional {
        direction,
        irradiance,
    } = world.lights[0].clone()
    else {
        panic!("directional light expected")
    };
    let reference = decode_frame(
        &std::fs::read("tests/data/reference/glass-sphere-directional.caustics.64M.exr").unwrap(),
    )
    .unwrap();
    assert_eq!(
        (reference.width, reference.height),
        (world.camera.width, world.camera.height)
    );
    let obj = world.object("glass").unwrap();
    let oi = world
        .objects
        .iter()
        .position(|o| o.name == "glass")
        .unwrap();
    let light = CslSet::light_in_object_frame(obj, direction);
    let params = CslParams {
        grid: 512,
        ..CslParams::fast()
    };
    let set = bake_csl(&world, "glass", light, &params, &|_| true).unwrap();
    eprintln!("{:#?}", set.stats);
    let csls = set.to_world(CslSet::rigid_transform(obj));
    let accel = Accel::build(&world);
    let blockers = Accel::build_with(&world, |i| i != oi, obvhs::BvhBuildParams::fast_build());
    // The CSL model over the whole pixel (6×6 stratified samples: converged to 1 % in flux),
    // and the product path, the GPU pass at one sample per pixel.
    let cpu = eval::render_caustics(&world, &accel, &blockers, &csls, irradiance, 6);
    let ctx = caustica::gpu::GpuContext::new(&Default::default()).expect("a GPU adapter");
    let mut renderer = Renderer::new(std::sync::Arc::new(ctx)).unwrap();
    let sets = cache::RenderSets {
        sets: vec![cache::ObjectSet {
            object: oi,
            set,
            cached: false,
        }],
        light: (direction, irradiance),
    };
    let layer = CslLayer::from_sets(&world, &sets);
    let gpu = renderer
        .render_csl(&world, &RenderOptions::default(), Some(&layer))
        .unwrap()
        .caustics
        .unwrap();
    let mask = compare::object_mask(&world, &accel, "floor");
    let c_cpu = compare::compare(&cpu, &reference, &mask);
    let c_gpu = compare::compare(&gpu, &reference, &mask);
    eprintln!("CPU (6×6 spp): {c_cpu:?}\nGPU (1 spp): {c_gpu:?}");
    if let Ok(dir) = std::env::var("CSL_QUALITY_OUT") {
        let _ = std::fs::create_dir_all(&dir);
        for (name, f) in [
            ("csl-cpu", &cpu),
            ("csl-gpu", &gpu),
            ("reference", &reference),
        ] {
            let bytes = caustica::encode::encode_exr(f).unwrap();
            std::fs::write(format!("{dir}/{name}.exr"), bytes).unwrap();
            let png = caustica::encode::encode_png(
                &compare::blur3(f),
                caustica::encode::PngSettings {
                    exposure: -2.0,
                    tone_map: caustica::encode::ToneMap::Reinhard,
                },
            )
            .unwrap();
            std::fs::write(format!("{dir}/{name}.png"), png).unwrap();
        }
    }
    // Targets (issue 3): relative L1 ≤ 0.15 and flux within 5 %. NOT met; these bounds guard
    // the measured state against regressions (see the module notes).
    assert!(c_cpu.rel_l1 <= 0.20, "{c_cpu:?}");
    assert!((0.87..=1.05).contains(&c_cpu.flux_ratio), "{c_cpu:?}");
    assert!(c_gpu.rel_l1 <= 0.21, "{c_gpu:?}");
    assert!((0.87..=1.05).contains(&c_gpu.flux_ratio), "{c_gpu:?}");
}
