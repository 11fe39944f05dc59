//! Method `beams` (Liktor and Dachsbacher 2010): the beams built on the CPU for grids 32² …
//! 256² on both fog scenes, and whole frames (the beams, shadow maps, direct, G-buffer, the
//! beams pass, readback) of `scenes/fog-paraboloid.json` at 900×600 — the paper's size — for
//! grids 32², 64² and 128², on whatever adapter `GpuContext` picks; the beams pass's own GPU
//! time is printed from the frame's timestamps (`gpu:beams`). Quote the medians with the
//! machine (cores) and the adapter. On lavapipe a 128² frame takes about a minute and a half:
//! filter the cases (`cargo bench --bench beams -- grid32`) when time is short.

use caustica::gpu::{GpuConfig, GpuContext};
use caustica::render::beams::{BeamsLayer, BeamsParams};
use caustica::render::{RenderOptions, Renderer};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn scene(name: &str) -> caustica::scene::World {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.json"));
    caustica::scene::load_scene_file(&path, &Default::default()).expect("scene")
}

fn bench_build(c: &mut Criterion) {
    println!("threads: {}", rayon::current_num_threads());
    let mut g = c.benchmark_group("beams");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    for name in ["fog-paraboloid", "fog-glass-sphere-spot"] {
        let world = scene(name);
        for grid in [32, 64, 128, 256] {
            let p = BeamsParams {
                grid,
                ..Default::default()
            };
            let layer = BeamsLayer::build(&world, &p);
            println!("{name} grid {grid}: {} beams", layer.beams.len());
            g.bench_function(format!("build_grid{grid}_{name}"), |b| {
                b.iter(|| BeamsLayer::build(&world, &p))
            });
        }
    }
    g.finish();
}

fn bench_frame(c: &mut Criterion) {
    let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let mut world = scene("fog-paraboloid");
    world.camera.width = 900;
    world.camera.height = 600;
    let mut g = c.benchmark_group("beams");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for grid in [32, 64, 128] {
        let p = BeamsParams {
            grid,
            ..Default::default()
        };
        let name = format!("frame_grid{grid}_900x600_fog_paraboloid");
        // One frame first: its stages, the GPU passes among them.
        let layer = BeamsLayer::build(&world, &p);
        if let Ok(out) = renderer.render_beams(&world, &RenderOptions::default(), &layer) {
            println!(
                "{name}: {} beams, stages {:?}",
                layer.beams.len(),
                out.timings
            );
        }
        g.bench_function(name, |b| {
            b.iter(|| {
                let layer = BeamsLayer::build(&world, &p);
                renderer
                    .render_beams(&world, &RenderOptions::default(), &layer)
                    .expect("renders")
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_build, bench_frame);
criterion_main!(benches);
