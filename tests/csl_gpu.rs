//! The GPU CSL evaluation (shaders/csl.inc.wgsl) against the CPU one (bake::csl::eval) on a
//! baked glass sphere, point for point. Needs an adapter (lavapipe in CI).

use caustica::bake::csl::{CslParams, bake_csl};
use caustica::gpu::{GpuConfig, GpuContext};
use caustica::render::csl::CslEvaluator;
use caustica::scene;
use glam::Vec3;

fn context() -> GpuContext {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        let dir = std::env::temp_dir().join(format!("caustica-xdg-{}", std::process::id()));
        let _ = std::fs::create_dir_all(&dir);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700));
        }
        // SAFETY: set before any GPU thread of this test reads the environment.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
    let ctx = GpuContext::new(&GpuConfig::default())
        .expect("a GPU adapter is required (CI installs lavapipe: mesa-vulkan-drivers)");
    eprintln!("adapter: {}", ctx.adapter_info());
    ctx
}

#[test]
fn gpu_csl_evaluation_matches_the_cpu() {
    let world = scene::resolve(
        &scene::parse_scene(
            br#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
                "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
                "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5,
                             "segments": 128}, "material": "glass"}]}"#,
        )
        .unwrap(),
        &scene::MapSource::default(),
        &Default::default(),
    )
    .unwrap();
    let params = CslParams {
        grid: 128,
        ..CslParams::fast()
    };
    let set = bake_csl(&world, "ball", Vec3::new(0.2, -1.0, 0.1), &params, &|_| {
        true
    })
    .unwrap();
    // Receiver points on planes below and beside the sphere, including the axis region and the
    // focus, with flat and tilted normals.
    let mut pts = Vec::new();
    for (k, y) in [-0.6f32, -0.75, -1.0, -1.5, 0.2].into_iter().enumerate() {
        for j in 0..60 {
            for i in 0..60 {
                let x = -1.5 + 3.0 * (i as f32 + 0.5) / 60.0;
                let z = -1.5 + 3.0 * (j as f32 + 0.5) / 60.0;
                let n = if k % 2 == 0 {
                    Vec3::Y
                } else {
                    Vec3::new(0.3, 1.0, -0.2).normalize()
                };
                pts.push((Vec3::new(x, y, z), n));
            }
        }
    }
    let cpu: Vec<Vec3> = pts
        .iter()
        .map(|&(p, n)| set.csls.iter().map(|c| c.irradiance(p, n)).sum())
        .collect();
    let ctx = context();
    let eval = CslEvaluator::new(&ctx).unwrap();
    let gpu = eval.irradiance(&ctx, &set.csls, &pts).unwrap();
    let peak = cpu.iter().map(|v| v.max_element()).fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    let mut bad = 0;
    let mut worst = 0.0f32;
    for (c, g) in cpu.iter().zip(&gpu) {
        let err = (*c - *g).abs().max_element();
        let tol = 1e-3 * c.max_element().max(g.max_element()) + 1e-5 * peak;
        if err > tol {
            bad += 1;
        }
        worst = worst.max(err / peak);
    }
    let lit = cpu.iter().filter(|c| c.max_element() > 0.0).count();
    eprintln!(
        "{} points, {lit} lit, {bad} beyond tolerance, worst error {worst:e} of the peak",
        pts.len()
    );
    // A handful may differ where f32 rounding puts a root on the other side of an image edge
    // or a branch; anything systematic would show in many points.
    assert!(lit > 1000, "{lit}");
    // Measured on llvmpipe: 0 of 18000 beyond tolerance, worst error 3e-8 of the peak.
    assert!(
        bad * 1000 <= pts.len(),
        "{bad} of {} points differ",
        pts.len()
    );
    assert!(worst < 1e-3, "{worst}");
}
