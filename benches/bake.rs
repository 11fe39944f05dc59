//! Bake time: a static CSL bake (Liu et al. 2008 §3) of one light direction at the paper's settings
//! (1280² rays) on the canonical glass sphere (a 256-segment UV sphere, 65k triangles), all
//! cores. The stage times of one bake are printed before timing.

use caustica::bake::csl::dynamic::{DynamicParams, Icosphere, bake_dynamic};
use caustica::bake::csl::{CslParams, bake_csl};
use caustica::bake::transport::{TransportParams, bake_transport};
use caustica::scene;
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let w = scene::load_scene_file(
        Path::new("scenes/glass-sphere-directional.json"),
        &Default::default(),
    )
    .expect("scene");
    let obj = w.object("glass").expect("glass");
    let (dir, _) = caustica::bake::csl::scene_directional_light(&w).expect("light");
    let light = obj.to_rigid_frame(dir);
    let params = CslParams::paper();
    let once = bake_csl(&w, "glass", light, &params, &|_| true).expect("bake");
    println!(
        "triangles {}, {} CSLs, coverage {:.3}, stats {:?}",
        obj.triangle_count(),
        once.csls.len(),
        once.stats.coverage(),
        once.stats
    );
    let mut g = c.benchmark_group("bake");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    g.bench_function("csl_static_1280_glass_sphere_65k", |b| {
        b.iter(|| black_box(bake_csl(&w, "glass", light, &params, &|_| true).expect("bake")))
    });
    // Light transport table (Iwasaki et al. 2005 §4) of a 6.4k-vertex glass sphere (112 segments: 6441
    // vertices) at the paper's 129 directions.
    let json = r#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
            "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
            "objects": [{"name": "glass", "shape": {"type": "sphere", "radius": 0.5, "segments": 112},
                         "material": "glass"}]}"#;
    let w = scene::load_scene_json(json.as_bytes()).expect("scene resolves");
    let tp = TransportParams::paper();
    let once = bake_transport(&w, "glass", &tp, &|_| true).expect("bake");
    println!(
        "transport: {} vertices, {} samples, {} rays, {} bytes, errors {:?}, stats {:?}",
        once.vertex_count,
        once.stats.samples,
        once.stats.rays,
        once.to_bytes().len(),
        once.errors,
        once.stats
    );
    g.bench_function("transport_129_glass_sphere_6k4", |b| {
        b.iter(|| black_box(bake_transport(&w, "glass", &tp, &|_| true).expect("bake")))
    });
    g.finish();
}

/// Dynamic lighting (Liu et al. 2008 §4): the per-frame interpolation of a set for a light direction
/// inside an icosahedron face, from a dynamic bake of the glass sphere (once subdivided: 42
/// directions, 256² rays a direction, 64² a tracking step, 10 steps; its time is printed, not
/// sampled: it is minutes).
fn bench_dynamic(c: &mut Criterion) {
    let w = scene::load_scene_file(
        Path::new("scenes/glass-sphere-directional.json"),
        &Default::default(),
    )
    .expect("scene");
    let params = DynamicParams {
        subdivisions: 1,
        steps: 10,
        track_grid: 64,
        csl: CslParams {
            grid: 256,
            ..CslParams::fast()
        },
        ..DynamicParams::paper()
    };
    let d = bake_dynamic(&w, "glass", &params, &|_| true).expect("bake");
    println!("dynamic bake (42 directions): {:?}", d.stats);
    let ico = Icosphere::new(1);
    let f = ico.faces[29];
    let dir = (0..3)
        .map(|k| ico.vertices[f[k] as usize] * [0.5, 0.3, 0.2][k])
        .fold(glam::Vec3::ZERO, |a, b| a + b)
        .normalize();
    println!("interpolated: {} CSLs", d.interpolate(dir).csls.len());
    let mut g = c.benchmark_group("bake");
    g.bench_function("csl_dynamic_interpolate_glass_sphere", |b| {
        b.iter(|| black_box(d.interpolate(black_box(dir))))
    });
    g.finish();
}

criterion_group!(benches, bench, bench_dynamic);
criterion_main!(benches);
