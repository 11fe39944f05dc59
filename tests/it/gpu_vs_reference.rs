//! The GPU `direct` method against the CPU reference's direct component and against Mitsuba's
//! path tracer (which has no caustics from delta lights), on the canonical scenes' floor pixels.

use crate::support::{gpu, images, scenes};
use caustica::reference::{self, ReferenceParams, compare};
use caustica::render::RenderOptions;
use caustica::trace::Accel;

#[test]
fn gpu_direct_agrees_with_reference_and_mitsuba_on_all_canonical_scenes() {
    let mut renderer = gpu::renderer();
    for light in ["directional", "spot", "point"] {
        let world = scenes::load(&format!("glass-sphere-{light}"));
        let gpu = renderer.render(&world, &RenderOptions::default()).unwrap();
        let accel = Accel::build(&world);
        let params = ReferenceParams {
            photons: 0,
            spp: 4,
            ..Default::default()
        };
        let (cpu, _) = reference::render(&world, &accel, &params, &|_| true).unwrap();
        let mask = compare::object_mask(&world, &accel, "floor");
        let vs_ref = compare::compare(&gpu.direct, &cpu.direct, &mask);
        let mitsuba = images::mitsuba(&format!("sphere-{light}-path-256spp.exr"));
        let vs_mitsuba = compare::compare(&gpu.direct, &mitsuba, &mask);
        eprintln!("{light}: vs reference {vs_ref:?}, vs mitsuba path {vs_mitsuba:?}");
        for c in [vs_ref, vs_mitsuba] {
            assert!(c.rel_l1 <= 0.05, "{light}: {c:?}");
            assert!((c.flux_ratio - 1.0).abs() <= 0.02, "{light}: {c:?}");
        }
        // The sphere shadows the floor: some floor pixels are dark in both.
        let dark = mask
            .iter()
            .zip(&gpu.direct.pixels)
            .filter(|(m, p)| **m && p.x < 1e-4)
            .count();
        assert!(dark > 200, "{light}: shadow has {dark} pixels");
    }
}
