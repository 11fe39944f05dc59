//! CSL caustics against the reference on the canonical glass sphere (caustics component, floor
//! pixels seen directly, 3×3 blur).
//!
//! Measured (grid 512, fast() otherwise, CPU evaluation, 2×2 samples per pixel): against this
//! 4M-photon reference relative L1 0.214, flux ratio 0.979; against a 16M-photon reference
//! (`caustica render --method reference --photons 16000000`) L1 0.204, flux 0.985, where the
//! 4M reference itself differs from the 16M one by L1 0.107 (photon noise). The target
//! (L1 ≤ 15%) is NOT met: the floor lies at the sphere's paraxial focus, and the two-parameter
//! focus law f(r) = α/(1+βr) puts too much of the light in the central spot and too little in
//! the spherical-aberration halo around it, with fold lines at the edges of the smaller CSLs.
//! The test guards what is met (flux within 5%) and the present L1 with little headroom.

use caustica::bake::csl::{CslParams, CslSet, bake_csl, eval};
use caustica::reference::{self, ReferenceParams, compare};
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
    let t = std::time::Instant::now();
    let ours = eval::render_caustics(&world, &accel, &blockers, &csls, irradiance, 2);
    eprintln!("csl render {:?}", t.elapsed());
    let t = std::time::Instant::now();
    let (refc, _) = reference::render(
        &world,
        &accel,
        &ReferenceParams {
            photons: 4_000_000,
            spp: 1,
            seed: 3,
            ..Default::default()
        },
        &|_| true,
    )
    .unwrap();
    eprintln!("reference {:?}", t.elapsed());
    let mask = compare::object_mask(&world, &accel, "floor");
    let c = compare::compare(&ours, &refc.caustics, &mask);
    eprintln!("{c:?}");
    if let Ok(dir) = std::env::var("CSL_QUALITY_OUT") {
        let _ = std::fs::create_dir_all(&dir);
        for (name, f) in [("csl", &ours), ("reference", &refc.caustics)] {
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
    // Target 0.15 (not met, see the module notes); this bound guards against regressions.
    assert!(c.rel_l1 <= 0.25, "{c:?}");
    assert!((c.flux_ratio - 1.0).abs() <= 0.05, "{c:?}");
}
