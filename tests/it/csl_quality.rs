//! CSL caustics against the reference on the canonical glass sphere (caustics component, floor
//! pixels seen directly, 3×3 blur), the quality targets: relative L1 ≤ 15 % and total
//! caustic flux within 5 %. The reference image is stored
//! (`tests/data/reference/glass-sphere-directional.caustics.64M.exr`, made by our `reference`
//! method with 64 M photons; see the README beside it; its own noise against a 16 M-photon
//! render is 1.2 % L1).
//!
//! The caustics component is L S+ D, light from the light through the glass onto the floor, the
//! light a CSL set stands for (Liu et al. 2008: "the light leaving a caustic object under the
//! illumination of a single directional light source"). The reference used to count light the
//! lit floor sends back through the sphere (L D S+ D) as caustics too: 6 % of the floor's
//! caustic flux, spread thinly far from the focus, which no CSL can carry; against that
//! component this test measured L1 0.19 and flux 0.90.
//!
//! Both evaluations average each pixel over its footprint (`Csl::arrivals_filtered`): a point
//! sample at the pixel centre misses most of a focus smaller than the pixel.
//!
//! Measured (grid 512, `CslParams::fast()` otherwise; llvmpipe for the GPU):
//! - CPU, 6×6 samples per pixel: relative L1 0.126, flux 0.975;
//! - the GPU pass, one sample per pixel: relative L1 0.129, flux 0.972.
//!
//! (0.131 / 0.971 and 0.146 / 0.965 when each pixel averaged over a disc of its area: discs do
//! not tile the image, and the sphere's focus, a spot far smaller than a pixel holding about
//! 12 % of the floor's caustic flux, fell into none, one or two of them depending on where the
//! pixel grid lay.)
//!
//! What is left is the 3–4 % of the leaving energy the set does not cover (the target is 95 %)
//! and the CSL model's fit of the far, thin light (1.6 m and more from the focus the set has
//! about half of the reference's light).

use crate::support::{gpu, images, scenes};
use caustica::bake::csl::{CslParams, bake_csl};
use caustica::reference::compare;
use caustica::render::csl::eval;
use caustica::render::{CslLayer, RenderOptions};
use caustica::trace::Accel;

#[test]
fn glass_sphere_caustics_match_the_reference() {
    let world = scenes::load("glass-sphere-directional");
    let (direction, irradiance) = scenes::directional_light(&world);
    let reference = images::stored_reference("glass-sphere-directional.caustics.64M.exr");
    assert_eq!(
        (reference.width, reference.height),
        (world.camera.width, world.camera.height)
    );
    let obj = world.object("glass").unwrap();
    let oi = scenes::object_index(&world, "glass");
    let light = obj.to_rigid_frame(direction);
    let params = CslParams {
        grid: 512,
        ..CslParams::fast()
    };
    let set = bake_csl(&world, "glass", light, &params, &|_| true).unwrap();
    eprintln!("{:#?}", set.stats);
    let csls = set.to_world(obj.rigid_transform());
    let accel = Accel::build(&world);
    let blockers = scenes::blockers(&world, oi);
    // The CSL model over the whole pixel (6×6 stratified samples: converged to 1 % in flux),
    // and the product path, the GPU pass at one sample per pixel.
    let cpu = eval::render_caustics(&world, &accel, &blockers, &csls, irradiance, 6);
    let mut renderer = gpu::renderer();
    let layer = CslLayer::new(&world, &[(oi, &set)], irradiance);
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
    // Targets (issue 3): relative L1 ≤ 0.15 and flux within 5 %.
    assert!(c_cpu.rel_l1 <= 0.15, "{c_cpu:?}");
    assert!((0.95..=1.05).contains(&c_cpu.flux_ratio), "{c_cpu:?}");
    assert!(c_gpu.rel_l1 <= 0.15, "{c_gpu:?}");
    assert!((0.95..=1.05).contains(&c_gpu.flux_ratio), "{c_gpu:?}");
}
