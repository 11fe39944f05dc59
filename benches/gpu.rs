//! GPU frame time: the direct renderer (shadow maps + direct/specular layers + readback) at
//! 800×600 on the glass-sphere scene (the same frame again, whose shadow maps the renderer
//! keeps, and a frame whose light turned, which draws them), and the same frame with the CSL
//! caustics layer evaluated per pixel (method `csl`, a paper-settings bake of the sphere made
//! once before timing), and at 640×480 the transport-table caustics (method `transport`: per
//! frame the illumination volumes and view refraction on the CPU, then the volume passes over
//! the G-buffer; a paper-settings table baked once before timing), and at 512×512 the pinhole
//! caustics of the mirror ring under the sun-and-sky map (method `pinhole`, default strategy
//! and filtering: the points chosen on the CPU, then the pinhole pass over the G-buffer) with
//! 1 000 and 10 000 points, on whatever adapter `GpuContext` picks (`CAUSTICA_BACKEND` /
//! `CAUSTICA_ADAPTER` choose). The adapter name is printed: quote it with the median.

use caustica::gpu::{GpuConfig, GpuContext};
use caustica::render::{RenderOptions, Renderer};
use caustica::scene::{Camera, Light, Material, Object, Part, World, shapes};
use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Mat4, Vec3};
use std::sync::Arc;
use std::time::Duration;

fn glass_sphere_world() -> World {
    let part = |mesh, material| Part {
        mesh: Arc::new(mesh),
        material,
    };
    World {
        name: "glass sphere".into(),
        camera: Camera {
            eye: Vec3::new(0.0, 3.2, 3.2),
            target: Vec3::new(0.35, 0.0, 0.0),
            up: Vec3::Y,
            fov_y: 40.0,
            width: 800,
            height: 600,
        },
        lights: vec![Light::Directional {
            direction: Vec3::new(1.0, -1.2, 0.0).normalize(),
            irradiance: Vec3::splat(3.0),
            angular_radius: 0.0,
        }],
        materials: vec![
            Material::Diffuse {
                albedo: Vec3::splat(0.6),
            },
            Material::Dielectric {
                ior: 1.5,
                absorption: Vec3::ZERO,
            },
        ],
        objects: vec![
            Object {
                name: "floor".into(),
                parts: vec![part(shapes::plane(8.0, 8.0), 0)],
                transform: Mat4::IDENTITY,
            },
            Object {
                name: "sphere".into(),
                parts: vec![part(shapes::sphere(0.5, 128), 1)],
                transform: Mat4::from_translation(Vec3::new(0.0, 0.58, 0.0)),
            },
        ],
        warnings: vec![],
        water: vec![],
        media: vec![],
        has_ground: false,
    }
}

fn bench_direct(c: &mut Criterion) {
    let ctx = Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let world = glass_sphere_world();
    let opts = RenderOptions {
        width: Some(800),
        height: Some(600),
        ..Default::default()
    };
    let first = renderer.render(&world, &opts).expect("render");
    println!("one frame's stages: {:?}", first.timings);
    let mut g = c.benchmark_group("gpu");
    g.sample_size(20).measurement_time(Duration::from_secs(15));
    // The same frame again: the renderer keeps the shadow maps (scene and light unchanged).
    g.bench_function("direct_frame_800x600_glass_sphere", |b| {
        b.iter(|| renderer.render(&world, &opts).expect("render"))
    });
    // The same without culling the back faces of closed objects (the sphere's), to compare
    // side by side with the above.
    renderer.set_back_face_cull(false);
    g.bench_function("direct_frame_800x600_glass_sphere_back_faces_drawn", |b| {
        b.iter(|| renderer.render(&world, &opts).expect("render"))
    });
    renderer.set_back_face_cull(true);
    // The light turns a little every frame: the shadow maps are drawn every frame.
    let mut turning = world.clone();
    let mut k = 0u32;
    g.bench_function("direct_frame_800x600_glass_sphere_light_turning", |b| {
        b.iter(|| {
            k += 1;
            turning.lights[0] = Light::Directional {
                direction: Vec3::new(1.0, -1.2, 0.01 * (k % 2) as f32).normalize(),
                irradiance: Vec3::splat(3.0),
                angular_radius: 0.0,
            };
            renderer.render(&turning, &opts).expect("render")
        })
    });
    let (dir, irradiance) =
        caustica::bake::csl::scene_directional_light(&world).expect("a directional light");
    let sets = caustica::methods::csl::sets_for_render(
        &world,
        &Default::default(),
        dir,
        &caustica::methods::ArtifactStore::none(),
        &|_| true,
    )
    .expect("csl bake");
    let placed: Vec<_> = sets.iter().map(|s| (s.object, &*s.set)).collect();
    let layer = caustica::render::CslLayer::new(&world, &placed, irradiance);
    println!("CSLs in the frame: {}", layer.csls.len());
    let first = renderer
        .render_csl(&world, &opts, Some(&layer))
        .expect("render");
    println!("one csl frame's stages: {:?}", first.timings);
    g.bench_function("csl_frame_800x600_glass_sphere", |b| {
        b.iter(|| {
            renderer
                .render_csl(&world, &opts, Some(&layer))
                .expect("render")
        })
    });
    g.finish();
}

fn bench_transport(c: &mut Criterion) {
    use caustica::bake::transport::{TransportParams, bake_transport};
    use caustica::render::TransportLayer;
    use caustica::render::transport::volumes;
    let ctx = Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let mut world = glass_sphere_world();
    world.camera.width = 640;
    world.camera.height = 480;
    let opts = RenderOptions::default();
    let table =
        bake_transport(&world, "sphere", &TransportParams::paper(), &|_| true).expect("bake");
    let build = |w: &World| {
        TransportLayer::build(w, &[(1, &table)], volumes::DEFAULT_LINE_POINTS).expect("volumes")
    };
    let layer = build(&world);
    println!(
        "{} vertices, {} volumes",
        table.vertex_count,
        layer.volumes.len()
    );
    let first = renderer
        .render_transport(&world, &opts, &layer)
        .expect("render");
    println!("one transport frame's stages: {:?}", first.timings);
    let mut g = c.benchmark_group("gpu");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    g.bench_function("transport_volumes_glass_sphere_8k3", |b| {
        b.iter(|| build(&world))
    });
    g.bench_function("transport_frame_640x480_glass_sphere_8k3", |b| {
        b.iter(|| {
            let layer = build(&world);
            renderer
                .render_transport(&world, &opts, &layer)
                .expect("render")
        })
    });
    g.finish();
}

fn bench_pinhole(c: &mut Criterion) {
    use caustica::render::PinholeLayer;
    use caustica::render::pinhole::PinholeParams;
    let ctx = Arc::new(GpuContext::new(&GpuConfig::default()).expect("no GPU adapter"));
    println!("adapter: {}", ctx.adapter_info());
    // 10 000 points at 512² take minutes a frame on a CPU adapter: there only 1 000 are timed.
    let cpu = ctx.adapter_info().device_type == "Cpu";
    let mut renderer = Renderer::new(ctx).expect("renderer");
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/mirror-ring-env.json");
    let mut world =
        caustica::scene::load_scene_file(&path, &Default::default()).expect("mirror-ring-env");
    world.camera.width = 512;
    world.camera.height = 512;
    let opts = RenderOptions::default();
    let mut g = c.benchmark_group("gpu");
    g.sample_size(10).measurement_time(Duration::from_secs(60));
    for samples in [1_000, 10_000] {
        if cpu && samples > 1_000 {
            continue;
        }
        let p = PinholeParams {
            samples,
            ..Default::default()
        };
        let frame = |r: &mut Renderer| {
            let layer = PinholeLayer::build(&world, &p).expect("points");
            r.render_pinhole(&world, &opts, &layer).expect("render")
        };
        let first = frame(&mut renderer);
        println!(
            "one pinhole frame's stages ({samples} points): {:?}",
            first.timings
        );
        g.bench_function(
            format!("pinhole_frame_512x512_mirror_ring_env_{samples}"),
            |b| b.iter(|| frame(&mut renderer)),
        );
    }
    g.finish();
}

criterion_group!(benches, bench_direct, bench_transport, bench_pinhole);
criterion_main!(benches);
