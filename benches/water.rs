//! Method `water`: its caustics layer on the CPU (the direct frame under it is `gpu`'s
//! `direct_frame_*`), `sea-floor-low-sun` seen from above through the waves, at 800×600 and
//! 1920×1080, in the physical and the article's mode, per pixel (3 × 3 points a pixel, the
//! default, or one), in the light map and per vertex, the receivers' BVH built once as a
//! sequence keeps it; and on the GPU (variants `shader` and `shader_texture`, both modes),
//! whole frames. Quote the medians with the machine (cores) and the adapter.

use caustica::render::water::{Mode, Receivers, Variant, WaterParams, WaterStats, render_layer};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn bench_water(c: &mut Criterion) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sea-floor-low-sun.json");
    let base = caustica::scene::load_scene_file(&path, &Default::default()).expect("scene");
    println!("threads: {}", rayon::current_num_threads());
    let mut g = c.benchmark_group("water");
    g.sample_size(10).measurement_time(Duration::from_secs(5));
    // (size, mode, variant, points per pixel side): the default 3 × 3 for the physical mode
    // per pixel; one point a pixel (a shader's) for the rest.
    let cases = [
        ((800, 600), Mode::Physical, Variant::Pixel, 3),
        ((800, 600), Mode::Physical, Variant::Pixel, 1),
        ((800, 600), Mode::Physical, Variant::Texture, 1),
        ((800, 600), Mode::Article, Variant::Pixel, 1),
        ((800, 600), Mode::Article, Variant::Texture, 1),
        ((800, 600), Mode::Article, Variant::Vertex, 1),
        ((1920, 1080), Mode::Physical, Variant::Texture, 1),
        ((1920, 1080), Mode::Article, Variant::Pixel, 1),
        ((1920, 1080), Mode::Article, Variant::Texture, 1),
    ];
    let mut recv: Option<((u32, u32), Receivers)> = None;
    for ((w, h), mode, variant, k) in cases {
        let mut world = base.clone();
        world.camera.width = w;
        world.camera.height = h;
        if recv.as_ref().is_none_or(|(s, _)| *s != (w, h)) {
            recv = Some(((w, h), Receivers::build(&world)));
        }
        let r = &recv.as_ref().expect("built").1;
        let p = WaterParams {
            mode,
            variant,
            pixel_samples: k,
            ..Default::default()
        };
        let name = format!(
            "{}_{}_{k}x{k}_{w}x{h}_sea_floor_low_sun",
            mode.name(),
            variant.name()
        );
        let mut stats = WaterStats::default();
        render_layer(&world, r, &p, &mut stats);
        println!("{name}: stages {:?}", stats.stages);
        g.bench_function(name, |b| {
            b.iter(|| render_layer(&world, r, &p, &mut WaterStats::default()))
        });
    }
    g.finish();
}

/// The water on the GPU (variants `shader` and `shader_texture`, physical and article): the
/// whole frame (shadow maps, direct, G-buffer, the light map, the water pass, readback) at
/// 800×600 and 1920×1080, on whatever adapter `GpuContext` picks; the passes' own GPU times are
/// printed from the frame's timestamps (`gpu:water_map`, `gpu:water`).
fn bench_water_shader(c: &mut Criterion) {
    use caustica::gpu::{GpuConfig, GpuContext};
    use caustica::render::water::gpu::WaterGpuLayer;
    use caustica::render::{RenderOptions, Renderer};
    let ctx = std::sync::Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/sea-floor-low-sun.json");
    let base = caustica::scene::load_scene_file(&path, &Default::default()).expect("scene");
    let mut g = c.benchmark_group("water");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for (w, h) in [(800, 600), (1920, 1080)] {
        let mut world = base.clone();
        world.camera.width = w;
        world.camera.height = h;
        for (mode, variant) in [
            (Mode::Physical, Variant::Shader),
            (Mode::Physical, Variant::ShaderTexture),
            (Mode::Article, Variant::Shader),
            (Mode::Article, Variant::ShaderTexture),
        ] {
            let p = WaterParams {
                mode,
                variant,
                ..Default::default()
            };
            let layer = WaterGpuLayer::build(&world, &p).expect("layer");
            let opts = RenderOptions::default();
            let name = format!(
                "{}_{}_frame_{w}x{h}_sea_floor_low_sun",
                mode.name(),
                variant.name()
            );
            for _ in 0..2 {
                let out = renderer.render_water(&world, &opts, &layer).expect("frame");
                println!("{name}: {:?}", out.timings);
            }
            g.bench_function(name, |b| {
                b.iter(|| renderer.render_water(&world, &opts, &layer).expect("frame"))
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench_water, bench_water_shader);
criterion_main!(benches);
