//! Method `photons`: the populations and BVH built on the CPU (glass sphere, 65 k triangles;
//! glass teapot), and frames of one photon pass (262,144 photons: trace, splat, readback, with
//! the shadow maps, direct pass and G-buffer) of `scenes/glass-sphere-directional.json` at
//! 256 × 256 and 800 × 600, on whatever adapter `GpuContext` picks; the passes' own GPU times
//! are printed from the first frame's timestamps (lavapipe's compute timestamps are not
//! meaningful). Quote the medians with the machine (cores) and the adapter.

use caustica::gpu::{GpuConfig, GpuContext};
use caustica::render::photons::{PhotonsLayer, PhotonsParams};
use caustica::render::{RenderOptions, Renderer};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn scene(name: &str) -> caustica::scene::World {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.json"));
    caustica::scene::load_scene_file(&path, &Default::default()).expect("scene")
}

fn params(photons: u32) -> PhotonsParams {
    PhotonsParams {
        photons,
        frames: 1,
        ..Default::default()
    }
}

fn bench_build(c: &mut Criterion) {
    println!("threads: {}", rayon::current_num_threads());
    let mut g = c.benchmark_group("photons");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for name in ["glass-sphere-directional", "glass-teapot"] {
        let world = scene(name);
        let p = params(1 << 18);
        g.bench_function(format!("build_{name}"), |b| {
            b.iter(|| PhotonsLayer::build(&world, &p))
        });
    }
    g.finish();
}

fn bench_frame(c: &mut Criterion) {
    let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let mut g = c.benchmark_group("photons");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (w, h) in [(256, 256), (800, 600)] {
        let mut world = scene("glass-sphere-directional");
        world.camera.width = w;
        world.camera.height = h;
        let layer = PhotonsLayer::build(&world, &params(1 << 18));
        let name = format!("frame_262144_{w}x{h}_glass_sphere");
        if let Ok(out) = renderer.render_photons(&world, &RenderOptions::default(), &layer) {
            println!("{name}: stages {:?}", out.timings);
        }
        g.bench_function(name, |b| {
            b.iter(|| {
                renderer
                    .render_photons(&world, &RenderOptions::default(), &layer)
                    .expect("frame")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_build, bench_frame);
criterion_main!(benches);
