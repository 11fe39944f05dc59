//! CPU tracer throughput: BVH build, closest-hit rays/s (coherent camera grid and incoherent
//! random secondary rays) and reference photon paths/s, on the canonical glass-sphere scene
//! (65k triangles: a 256-segment sphere on a floor).

use caustica::reference::{self, ReferenceParams};
use caustica::sampling::{Pcg, uniform_sphere};
use caustica::scene;
use caustica::trace::Accel;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use std::hint::black_box;
use std::path::Path;

fn world() -> scene::World {
    scene::load_scene_file(
        Path::new("scenes/glass-sphere-directional.json"),
        &Default::default(),
    )
    .expect("scene")
}

fn bench(c: &mut Criterion) {
    let w = world();
    let accel = Accel::build(&w);
    eprintln!("triangles: {}", accel.triangle_count());
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.bench_function("build_65k_tris", |b| b.iter(|| black_box(Accel::build(&w))));
    g.finish();

    // Coherent: a 1024² camera grid aimed at the sphere, in parallel rows.
    let n = 1024u32;
    let mut cam = w.camera.clone();
    cam.width = n;
    cam.height = n;
    cam.target = Vec3::new(0.0, 0.58, 0.0);
    cam.fov_y = 25.0;
    let mut g = c.benchmark_group("rays");
    g.sample_size(10);
    g.throughput(Throughput::Elements(u64::from(n * n)));
    let rays = cam.rays();
    g.bench_function("closest_hit_coherent", |b| {
        b.iter(|| {
            (0..n).into_par_iter().for_each(|y| {
                for x in 0..n {
                    let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
                    black_box(accel.intersect(cam.eye, d, f32::INFINITY));
                }
            })
        })
    });
    // The same grid, eight neighbouring rays of a row to a packet (as the CSL bake traces
    // the paths of neighbouring grid rays that took the same branches).
    g.bench_function("closest_hit_coherent_packets", |b| {
        b.iter(|| {
            (0..n).into_par_iter().for_each(|y| {
                let mut hits = [None; 8];
                for x0 in (0..n).step_by(8) {
                    let packet: [(Vec3, Vec3); 8] = std::array::from_fn(|k| {
                        let x = (x0 + k as u32) as f32 + 0.5;
                        (cam.eye, rays.dir(x, y as f32 + 0.5))
                    });
                    accel.intersect_packet(&packet, &mut hits);
                    black_box(&hits);
                }
            })
        })
    });
    // Incoherent: random directions from random points inside the sphere's bounds, like
    // secondary rays after refraction and diffuse bounces.
    let m = 1 << 20;
    let rays: Vec<(Vec3, Vec3)> = {
        let mut r = Pcg::new(9, 9);
        (0..m)
            .map(|_| {
                let o = Vec3::new(0.0, 0.58, 0.0) + uniform_sphere(r.vec2()) * 0.45 * r.f32();
                (o, uniform_sphere(r.vec2()))
            })
            .collect()
    };
    g.throughput(Throughput::Elements(m as u64));
    g.bench_function("closest_hit_incoherent", |b| {
        b.iter(|| {
            rays.par_chunks(4096).for_each(|c| {
                for (o, d) in c {
                    black_box(accel.intersect(*o, *d, f32::INFINITY));
                }
            })
        })
    });
    g.finish();

    let mut g = c.benchmark_group("reference");
    g.sample_size(10);
    let photons = 400_000;
    g.throughput(Throughput::Elements(photons));
    let mut small = w.clone();
    small.camera.width = 64;
    small.camera.height = 64;
    let params = ReferenceParams {
        photons,
        spp: 1,
        ..Default::default()
    };
    g.bench_function("photon_paths", |b| {
        b.iter(|| black_box(reference::render(&small, &accel, &params, &|_| true).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
