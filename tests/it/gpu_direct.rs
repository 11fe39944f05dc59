//! The direct renderer on a real adapter (lavapipe in CI): readback, and radiance compared
//! number for number with analytic CPU evaluations of the same scenes. No adapter = failure.

use crate::support::gpu;
use caustica::frame::Frame;
use caustica::render::{Components, RenderOptions, Renderer};
use caustica::scene::shapes;
use caustica::scene::{Camera, Light, Material, Object, Part, World};
use glam::{Mat4, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

const W: u32 = 120;
const H: u32 = 90;

fn camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 4.5, 3.5),
        target: Vec3::new(0.0, 0.0, 0.2),
        up: Vec3::Y,
        fov_y: 40.0,
        width: W,
        height: H,
    }
}

fn object(name: &str, mesh: caustica::scene::Mesh, material: u32, transform: Mat4) -> Object {
    Object {
        name: name.into(),
        parts: vec![Part {
            mesh: Arc::new(mesh),
            material,
        }],
        transform,
    }
}

const PLANE_HALF: f32 = 2.0;

/// A 4×4 plane (material 0) plus spheres (material 1), analytic copies of the spheres for the
/// CPU side.
fn world(receiver: Material, spheres: &[(Vec3, f32)], lights: Vec<Light>) -> World {
    let mut objects = vec![object(
        "floor",
        shapes::plane(2.0 * PLANE_HALF, 2.0 * PLANE_HALF),
        0,
        Mat4::IDENTITY,
    )];
    for (i, (c, r)) in spheres.iter().enumerate() {
        objects.push(object(
            &format!("sphere{i}"),
            shapes::sphere(*r, 128),
            1,
            Mat4::from_translation(*c),
        ));
    }
    World {
        name: "test".into(),
        camera: camera(),
        lights,
        materials: vec![
            receiver,
            Material::Diffuse {
                albedo: Vec3::splat(0.5),
            },
        ],
        objects,
        warnings: vec![],
        water: vec![],
        media: vec![],
        has_ground: false,
    }
}

fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let oc = o - c;
    let b = oc.dot(d);
    let disc = b * b - (oc.length_squared() - r * r);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    [-b - s, -b + s].into_iter().find(|t| *t > 1e-4)
}

/// Plane pixels: (x, y, world point) for pixel centres whose camera ray hits the plane first,
/// at least `margin` inside its edges.
fn plane_pixels(cam: &Camera, spheres: &[(Vec3, f32)], margin: f32) -> Vec<(u32, u32, Vec3)> {
    let mut out = Vec::new();
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            if d.y >= 0.0 {
                continue;
            }
            let t = -cam.eye.y / d.y;
            let p = cam.eye + d * t;
            if p.x.abs() > PLANE_HALF - margin || p.z.abs() > PLANE_HALF - margin {
                continue;
            }
            if spheres
                .iter()
                .any(|(c, r)| ray_sphere(cam.eye, d, *c, *r + 0.02).is_some_and(|ts| ts < t))
            {
                continue;
            }
            out.push((x, y, p));
        }
    }
    out
}

fn occluded(p: Vec3, to_light: Vec3, max_t: f32, spheres: &[(Vec3, f32)]) -> bool {
    spheres
        .iter()
        .any(|(c, r)| ray_sphere(p, to_light, *c, *r).is_some_and(|t| t < max_t))
}

/// Renders with a fresh context and renderer.
fn render(w: &World) -> caustica::render::RenderOutput {
    render_with(w, &RenderOptions::default())
}

fn render_with(w: &World, opts: &RenderOptions) -> caustica::render::RenderOutput {
    let mut r = gpu::renderer();
    let out = r.render(w, opts).expect("render");
    eprintln!("timings: {:?}", out.timings);
    out
}

#[test]
fn readback_handles_any_width() {
    let ctx = gpu::context();
    let h = ctx.handle();
    for &(w, ht) in &[(1u32, 3u32), (7, 5), (257, 4), (800, 3)] {
        let tex = h.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size: wgpu::Extent3d {
                width: w,
                height: ht,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let data: Vec<[f32; 4]> = (0..w * ht)
            .map(|i| [(i % w) as f32, (i / w) as f32, i as f32 * 0.5, -1.0])
            .collect();
        h.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &tex,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&data),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 16),
                rows_per_image: Some(ht),
            },
            tex.size(),
        );
        let back = ctx.readback_rgba32f(&tex).expect("readback");
        assert_eq!(back, data, "width {w}");
    }
}

#[test]
fn directional_light_on_diffuse_plane_is_exact() {
    let e = 2.0;
    let theta = 60f32.to_radians();
    let dir = Vec3::new(theta.sin(), -theta.cos(), 0.0);
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &[],
        vec![Light::Directional {
            direction: dir,
            irradiance: Vec3::splat(e),
            angular_radius: 0.0,
        }],
    );
    let out = render(&w);
    let expected = 0.5 / PI * e * theta.cos();
    let px = plane_pixels(&w.camera, &[], 0.02);
    assert!(px.len() > 5000, "{} plane pixels", px.len());
    let mut worst = 0.0f32;
    for (x, y, _) in &px {
        let v = out.direct.at(*x, *y);
        for c in v.to_array() {
            worst = worst.max((c - expected).abs() / expected);
        }
    }
    eprintln!("expected {expected}, worst relative error {worst}");
    assert!(worst < 0.01, "worst relative error {worst}");
    // Specular layer: nothing specular, no environment.
    assert!(out.specular.pixels.iter().all(|p| *p == Vec3::ZERO));
}

/// Compares lit/unlit per plane pixel and the radiance of pixels lit on both sides.
fn check_against_cpu(
    w: &World,
    spheres: &[(Vec3, f32)],
    cpu: impl Fn(Vec3) -> (f32, bool), // (unshadowed radiance, shadowed?)
    label: &str,
) {
    let out = render(w);
    let px = plane_pixels(&w.camera, spheres, 0.02);
    let peak = px.iter().map(|(_, _, p)| cpu(*p).0).fold(0.0f32, f32::max);
    let (mut agree, mut total, mut rel_sum, mut rel_n, mut shadowed_n) =
        (0usize, 0usize, 0.0f64, 0usize, 0usize);
    for (x, y, p) in &px {
        let (l, shadowed) = cpu(*p);
        if l < 1e-3 * peak {
            continue; // outside the beam: no lit/unlit question
        }
        let g = out.direct.at(*x, *y).x;
        let gpu_lit = g > 0.5 * l;
        total += 1;
        shadowed_n += shadowed as usize;
        if gpu_lit != shadowed {
            agree += 1;
        }
        if gpu_lit && !shadowed {
            rel_sum += ((g - l).abs() / l) as f64;
            rel_n += 1;
        }
    }
    let agreement = agree as f64 / total as f64;
    let mean_rel = rel_sum / rel_n as f64;
    eprintln!(
        "{label}: {total} pixels, {shadowed_n} shadowed on the CPU, agreement {agreement:.4}, mean relative error {mean_rel:.5} over {rel_n} lit"
    );
    assert!(total > 3000, "{label}: only {total} pixels");
    assert!(
        shadowed_n > 50,
        "{label}: the test scene should have a shadow ({shadowed_n})"
    );
    assert!(
        agreement >= 0.97,
        "{label}: lit/unlit agreement {agreement}"
    );
    assert!(mean_rel < 0.02, "{label}: mean relative error {mean_rel}");
}

#[test]
fn sphere_shadow_under_directional_light_matches_cpu() {
    let theta = 60f32.to_radians();
    let dir = Vec3::new(theta.sin(), -theta.cos(), 0.0);
    let spheres = [(Vec3::new(-0.6, 0.8, 0.0), 0.5)];
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &spheres,
        vec![Light::Directional {
            direction: dir,
            irradiance: Vec3::splat(2.0),
            angular_radius: 0.0,
        }],
    );
    let l = 0.5 / PI * 2.0 * theta.cos();
    check_against_cpu(
        &w,
        &spheres,
        |p| (l, occluded(p, -dir, f32::INFINITY, &spheres)),
        "directional",
    );
}

#[test]
fn point_light_shadows_and_falloff_match_cpu() {
    let lp = Vec3::new(0.2, 1.2, -0.1);
    let i = 3.0;
    // One sphere below the light (-Y cube face), one to the side (+X face).
    let spheres = [
        (Vec3::new(-0.3, 0.5, 0.3), 0.25),
        (Vec3::new(1.0, 0.5, 0.3), 0.3),
    ];
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &spheres,
        vec![Light::Point {
            position: lp,
            intensity: Vec3::splat(i),
        }],
    );
    check_against_cpu(
        &w,
        &spheres,
        |p| {
            let d = lp - p;
            let dist = d.length();
            let wi = d / dist;
            (
                0.5 / PI * i * wi.y / (dist * dist),
                occluded(p, wi, dist, &spheres),
            )
        },
        "point",
    );
}

#[test]
fn spot_light_shadows_and_falloff_match_cpu() {
    let lp = Vec3::new(0.0, 2.5, 0.0);
    let axis = (Vec3::new(0.4, 0.0, 0.3) - lp).normalize();
    let (cutoff, beam) = (35f32.to_radians(), 20f32.to_radians());
    let i = 8.0;
    let spheres = [(Vec3::new(0.2, 1.0, 0.1), 0.25)];
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &spheres,
        vec![Light::Spot {
            position: lp,
            direction: axis,
            intensity: Vec3::splat(i),
            cutoff,
            beam_width: beam,
        }],
    );
    check_against_cpu(
        &w,
        &spheres,
        |p| {
            let d = lp - p;
            let dist = d.length();
            let wi = d / dist;
            let f = Light::spot_falloff((-wi).dot(axis), cutoff, beam);
            (
                0.5 / PI * i * f * wi.y / (dist * dist),
                occluded(p, wi, dist, &spheres),
            )
        },
        "spot",
    );
}

/// The Glossy BRDF of scene/types.rs, evaluated on the CPU.
fn glossy_brdf(n: Vec3, wi: Vec3, wo: Vec3, albedo: f32, f0: f32, roughness: f32) -> f32 {
    let (ci, co) = (n.dot(wi), n.dot(wo));
    if ci <= 0.0 || co <= 0.0 {
        return 0.0;
    }
    let a2 = (roughness * roughness).powi(2);
    let h = (wi + wo).normalize();
    let nh = n.dot(h);
    let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let lambda = |c: f32| 0.5 * (-1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt());
    let g2 = 1.0 / (1.0 + lambda(ci) + lambda(co));
    let f = f0 + (1.0 - f0) * (1.0 - wi.dot(h)).powi(5);
    albedo / PI + d * g2 * f / (4.0 * ci * co)
}

#[test]
fn glossy_plane_matches_cpu_brdf() {
    let lp = Vec3::new(0.0, 1.5, -1.0);
    let i = 4.0;
    let (albedo, f0, rough) = (0.3, 0.5, 0.4);
    let w = world(
        Material::Glossy {
            albedo: Vec3::splat(albedo),
            specular: Vec3::splat(f0),
            roughness: rough,
        },
        &[],
        vec![Light::Point {
            position: lp,
            intensity: Vec3::splat(i),
        }],
    );
    let out = render(&w);
    let cam = &w.camera;
    let px = plane_pixels(cam, &[], 0.02);
    let (mut rel_sum, mut worst, mut peak_ratio) = (0.0f64, 0.0f32, 0.0f32);
    for (x, y, p) in &px {
        let wi = (lp - *p).normalize();
        let dist2 = (lp - *p).length_squared();
        let wo = (cam.eye - *p).normalize();
        let f = glossy_brdf(Vec3::Y, wi, wo, albedo, f0, rough);
        let l = f * i * wi.y / dist2;
        let g = out.direct.at(*x, *y).x;
        let rel = (g - l).abs() / l;
        rel_sum += rel as f64;
        worst = worst.max(rel);
        peak_ratio = peak_ratio.max(f / (albedo / PI));
    }
    let mean = rel_sum / px.len() as f64;
    eprintln!(
        "glossy: mean relative error {mean:.5}, worst {worst:.4}, peak f / diffuse {peak_ratio:.1}"
    );
    assert!(peak_ratio > 3.0, "the view should include the highlight");
    assert!(mean < 0.01, "mean relative error {mean}");
    assert!(worst < 0.05, "worst relative error {worst}");
}

#[test]
fn renders_again_after_device_loss() {
    let ctx = gpu::context();
    let mut r = Renderer::new(ctx.clone()).expect("renderer");
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &[(Vec3::new(0.0, 0.8, 0.0), 0.5)],
        vec![Light::Directional {
            direction: Vec3::new(0.3, -1.0, 0.1).normalize(),
            irradiance: Vec3::splat(2.0),
            angular_radius: 0.0,
        }],
    );
    let opts = RenderOptions::default();
    let before = r.render(&w, &opts).expect("first render");
    assert!(
        before.direct.pixels.iter().any(|p| p.x > 0.1),
        "the frame has lit pixels"
    );
    let g0 = ctx.generation();
    ctx.device().destroy();
    let after = r.render(&w, &opts).expect("render after loss");
    assert!(ctx.generation() > g0, "device was recreated");
    assert_eq!(before.direct, after.direct);
    // And the renderer keeps working.
    r.render(&w, &opts).expect("third render");
}

#[test]
fn line_light_of_zero_length_is_a_point_light() {
    let p = Vec3::new(0.3, 1.0, 0.2);
    let spheres = [(Vec3::new(0.0, 0.4, 0.0), 0.2)];
    let mat = Material::Diffuse {
        albedo: Vec3::splat(0.5),
    };
    // The line light's 48 cube faces at 1024² fit the shadow budget, so both renders use the
    // same shadow resolution (at the default 2048 the line light's would be scaled down).
    let opts = RenderOptions {
        shadow_resolution: 1024,
        ..Default::default()
    };
    let a = render_with(
        &world(
            mat,
            &spheres,
            vec![Light::Point {
                position: p,
                intensity: Vec3::splat(2.0),
            }],
        ),
        &opts,
    );
    let b = render_with(
        &world(
            mat,
            &spheres,
            vec![Light::Line {
                start: p,
                end: p,
                intensity: Vec3::splat(2.0),
            }],
        ),
        &opts,
    );
    let max_diff = a
        .direct
        .pixels
        .iter()
        .zip(&b.direct.pixels)
        .map(|(x, y)| (*x - *y).abs().max_element() / x.max_element().max(1e-3))
        .fold(0.0f32, f32::max);
    assert!(max_diff < 1e-3, "{max_diff}");
}

#[test]
fn constant_environment_and_mirror() {
    let l_env = 0.7;
    let mut w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &[(Vec3::new(0.0, 0.6, 0.0), 0.5)],
        vec![Light::Environment {
            map: None,
            radiance: Vec3::splat(l_env),
        }],
    );
    w.materials[1] = Material::Mirror {
        reflectance: Vec3::splat(0.8),
    };
    let mut r = gpu::renderer();
    let out = r.render(&w, &RenderOptions::default()).unwrap();
    // Diffuse plane under a constant sky, shadowed by the sphere: albedo × L × (1 − F), F the
    // sphere's form factor from the point (r²/d² cos θ for a sphere wholly above the plane).
    // The sky's shadow comes from 32 directions (about 16 above the plane), so a point sees
    // the sphere block whole directions: each point within 0.15 of the open value of it (a
    // direction near the zenith carries about 1/8 of the cosine-weighted sky), the mean over
    // the plane within 0.02, and the plane under the sphere darker than the open plane.
    let (centre, radius) = (Vec3::new(0.0, 0.6, 0.0), 0.5);
    let px = plane_pixels(&w.camera, &[(centre, radius)], 0.02);
    let open = 0.5 * l_env;
    let (mut under, mut n, mut off, mut m, mut worst) = (0.0, 0, 0.0, 0, 0.0f32);
    for (x, y, p) in px.iter().step_by(17) {
        let to = centre - *p;
        let f = radius * radius / to.length_squared() * to.normalize().y;
        let v = out.direct.at(*x, *y).x;
        let want = open * (1.0 - f);
        assert!(
            (v - want).abs() < 0.15 * open,
            "{v} at {p} (form factor {f}, expected {want})"
        );
        off += (v - want) / open;
        worst = f32::max(worst, (v - want).abs() / open);
        m += 1;
        if f > 0.3 {
            under += v / open;
            n += 1;
        }
        assert_eq!(out.specular.at(*x, *y), Vec3::ZERO);
    }
    let mean_off = off / m as f32;
    println!(
        "plane under a constant sky: (v − expected)/open mean {mean_off:.4}, worst {worst:.4} over {m} points"
    );
    assert!(mean_off.abs() < 0.02, "{mean_off}");
    assert!(n > 0 && under / (n as f32) < 0.7, "{under} over {n}");
    // Mirror sphere in the centre of the image: 0 in direct, reflectance × L in specular.
    let (cx, cy, _) = w.camera.project(Vec3::new(0.0, 0.6, 0.0)).unwrap();
    let (cx, cy) = (cx as u32, cy as u32);
    assert_eq!(out.direct.at(cx, cy), Vec3::ZERO);
    assert!((out.specular.at(cx, cy).x - 0.8 * l_env).abs() < 1e-3);
    // Background shows the sky in the direct layer (emitted light seen directly, as in the
    // reference).
    assert!((out.direct.at(0, 0).x - l_env).abs() < 1e-4);
    assert_eq!(out.specular.at(0, 0), Vec3::ZERO);
    // Components: asking for direct only leaves specular black.
    let only = r
        .render(
            &w,
            &RenderOptions {
                components: Components {
                    direct: true,
                    specular: false,
                },
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(only.direct, out.direct);
    assert!(only.specular.pixels.iter().all(|p| *p == Vec3::ZERO));
}

/// Sum of the red channel over the left and the right half of a frame.
fn halves(f: &Frame) -> (f32, f32) {
    let (mut l, mut r) = (0.0, 0.0);
    for y in 0..f.height {
        for x in 0..f.width {
            let v = f.at(x, y).x;
            if x < f.width / 2 {
                l += v;
            } else {
                r += v;
            }
        }
    }
    (l, r)
}

#[test]
fn environment_map_orientation_follows_mitsuba() {
    // One bright texel of a 16 × 9 map at column 3 (u = 3.5/16 ≈ 0.22), row 4 (v = 1/2, the
    // horizon): under Mitsuba's `envmap` convention the direction towards it is
    // (sin 2πu, 0, −cos 2πu) ≈ (0.98, 0, −0.20): +X, the right of a camera at +Z looking at −Z.
    // A mirror sphere must show it on its right, a diffuse sphere must be lit on its right.
    let (mw, mh) = (16u32, 9u32);
    let mut texels = vec![Vec3::ZERO; (mw * mh) as usize];
    texels[(4 * mw + 3) as usize] = Vec3::splat(100.0);
    let map = Arc::new(caustica::scene::EnvMap {
        width: mw,
        height: mh,
        texels,
    });
    let mut r = gpu::renderer();
    for (label, material, layer) in [
        (
            "mirror",
            Material::Mirror {
                reflectance: Vec3::ONE,
            },
            0,
        ),
        ("diffuse", Material::Diffuse { albedo: Vec3::ONE }, 1),
    ] {
        let w = World {
            name: "env-orientation".into(),
            camera: Camera {
                eye: Vec3::new(0.0, 0.0, 3.0),
                target: Vec3::ZERO,
                up: Vec3::Y,
                fov_y: 30.0,
                width: 64,
                height: 64,
            },
            lights: vec![Light::Environment {
                map: Some(map.clone()),
                radiance: Vec3::ONE,
            }],
            materials: vec![material],
            objects: vec![object("ball", shapes::sphere(0.5, 64), 0, Mat4::IDENTITY)],
            warnings: vec![],
            water: vec![],
            media: vec![],
            has_ground: false,
        };
        let out = r.render(&w, &RenderOptions::default()).unwrap();
        let f = if layer == 0 {
            &out.specular
        } else {
            &out.direct
        };
        let (left, right) = halves(f);
        eprintln!("{label}: left half {left}, right half {right}");
        assert!(
            right > 0.0 && right > 5.0 * left,
            "{label}: {left} vs {right}"
        );
    }
}

#[test]
fn wide_spot_uses_cube_shadows_and_matches_cpu() {
    // A cutoff above 75° cannot use one perspective map: the renderer switches to six faces.
    let lp = Vec3::new(0.1, 0.9, 0.0);
    let axis = Vec3::new(0.2, -1.0, 0.1).normalize();
    let (cutoff, beam) = (85f32.to_radians(), 60f32.to_radians());
    let i = 2.0;
    let spheres = [
        (Vec3::new(0.9, 0.4, 0.2), 0.2),
        (Vec3::new(-0.2, 0.4, -0.1), 0.15),
    ];
    let w = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.5),
        },
        &spheres,
        vec![Light::Spot {
            position: lp,
            direction: axis,
            intensity: Vec3::splat(i),
            cutoff,
            beam_width: beam,
        }],
    );
    check_against_cpu(
        &w,
        &spheres,
        |p| {
            let d = lp - p;
            let dist = d.length();
            let wi = d / dist;
            let f = Light::spot_falloff((-wi).dot(axis), cutoff, beam);
            (
                0.5 / PI * i * f * wi.y / (dist * dist),
                occluded(p, wi, dist, &spheres),
            )
        },
        "wide spot",
    );
}

/// The renderer keeps the scene's buffers and occluders between frames of the same scene, and
/// the shadow maps between frames of the same scene and light views: a frame after other
/// scenes, after the same scene moved, lit from elsewhere or seen from elsewhere, and after a
/// transport frame (whose glass vertices carry the radiance seen through them) is the frame a
/// fresh renderer makes; a frame whose only change is the camera draws no shadow pass.
#[test]
fn frames_after_other_scenes_are_those_of_a_fresh_renderer() {
    use caustica::bake::transport::{TransportParams, bake_transport};
    use caustica::render::transport::volumes::DEFAULT_LINE_POINTS;
    use caustica::render::{Caustics, TransportLayer};
    let mut scene = crate::support::scenes::scene_sized(48, 36);
    scene["objects"][1]["shape"]["segments"] = 24.into();
    let a = crate::support::scenes::parse(&scene.to_string());
    let mut b = a.clone();
    b.objects[1].transform =
        Mat4::from_translation(Vec3::new(0.6, 0.0, -0.3)) * b.objects[1].transform;
    // The same scene lit from elsewhere, and seen from elsewhere.
    let mut lit = a.clone();
    let Light::Directional { direction, .. } = &mut lit.lights[0] else {
        panic!("the canonical scene has a directional light")
    };
    *direction = Vec3::new(-0.6, -1.0, 0.3).normalize();
    let mut seen = a.clone();
    seen.camera.eye += Vec3::new(0.5, 0.3, -0.2);
    let table = bake_transport(&a, "glass", &TransportParams::paper(), &|_| true).unwrap();
    let layer = TransportLayer::build(&a, &[(1, &table)], DEFAULT_LINE_POINTS).unwrap();
    let opts = RenderOptions::default();
    let fresh = |w: &World, c: Caustics| {
        let out = crate::support::gpu::renderer()
            .render_with(w, &opts, c)
            .unwrap();
        (out.total(), out.specular)
    };
    let (want_a, _) = fresh(&a, Caustics::None);
    let (want_b, _) = fresh(&b, Caustics::None);
    let (want_lit, _) = fresh(&lit, Caustics::None);
    let (want_seen, _) = fresh(&seen, Caustics::None);
    let (want_t, want_t_specular) = fresh(&a, Caustics::Transport(&layer));
    // Frames compared pixel for pixel; a failure names the largest difference.
    let same = |got: &Frame, want: &Frame, what: &str| {
        let d = got
            .pixels
            .iter()
            .zip(&want.pixels)
            .map(|(a, b)| (*a - *b).abs().max_element())
            .fold(0.0f32, f32::max);
        assert!(
            d == 0.0,
            "{what}: differs from a fresh renderer's by up to {d}"
        );
    };
    assert!(want_a != want_b, "the move shows");
    assert!(want_a != want_lit, "the light's turn shows");
    let mut r = crate::support::gpu::renderer();
    // The frame, its glass, and whether it drew the shadow pass where the adapter times passes.
    let mut frame = |w: &World, c: Caustics| {
        let out = r.render_with(w, &opts, c).unwrap();
        let timed = out.timings.iter().any(|(n, _)| n.starts_with("gpu:"));
        let drawn = timed.then(|| out.timings.iter().any(|(n, _)| n == "gpu:shadow_maps"));
        (out.total(), out.specular, drawn)
    };
    same(&frame(&a, Caustics::None).0, &want_a, "a");
    same(&frame(&b, Caustics::None).0, &want_b, "b after a");
    same(&frame(&a, Caustics::None).0, &want_a, "a after b");
    let (got, _, drawn) = frame(&lit, Caustics::None);
    same(&got, &want_lit, "a lit from elsewhere after a");
    assert_ne!(drawn, Some(false), "a turned light draws the shadow pass");
    same(
        &frame(&a, Caustics::None).0,
        &want_a,
        "a after a lit from elsewhere",
    );
    let (got, _, drawn) = frame(&seen, Caustics::None);
    same(&got, &want_seen, "a seen from elsewhere after a");
    assert_ne!(drawn, Some(true), "a moved camera keeps the shadow maps");
    let (t, t_specular, _) = frame(&a, Caustics::Transport(&layer));
    same(&t, &want_t, "a with transport");
    same(&t_specular, &want_t_specular, "a's glass with transport");
    let plain = frame(&a, Caustics::None);
    same(&plain.0, &want_a, "a after transport");
    assert!(t_specular != plain.1, "the view through the glass shows");
}

/// The direct pass culls the back faces of closed objects the camera sees from outside: no
/// pixel of any layer changes, whether the objects are glass, diffuse, mirrored by their
/// transform or open (the floor), and a camera inside a closed room (whose walls it sees from
/// their back) sees the same room as without the cull, not through its walls.
#[test]
fn culling_the_back_faces_of_closed_objects_changes_no_pixel() {
    let mut outside = world(
        Material::Diffuse {
            albedo: Vec3::splat(0.7),
        },
        &[(Vec3::new(0.6, 0.5, 0.0), 0.5)],
        vec![
            Light::Point {
                position: Vec3::new(-1.0, 3.0, 1.0),
                intensity: Vec3::splat(6.0),
            },
            // A sky: the background and the walls' insides differ.
            Light::Environment {
                map: None,
                radiance: Vec3::splat(0.3),
            },
        ],
    );
    outside.materials.push(Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    });
    // Glass, and a box mirrored by its transform (its winding turned over).
    outside.objects.push(object(
        "glass",
        shapes::sphere(0.4, 48),
        2,
        Mat4::from_translation(Vec3::new(-0.7, 0.4, 0.3)),
    ));
    outside.objects.push(object(
        "box",
        shapes::cuboid(Vec3::new(0.6, 0.8, 0.4)),
        1,
        Mat4::from_translation(Vec3::new(0.0, 0.4, -1.0))
            * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
    ));
    // A closed room around the camera, lit inside: seen from within, its walls are back faces
    // (black, one-sided) where a cull would show the sky through them.
    let mut inside = outside.clone();
    inside.objects.push(object(
        "room",
        shapes::cuboid(Vec3::new(12.0, 12.0, 12.0)),
        0,
        Mat4::IDENTITY,
    ));
    for (name, w) in [("outside", &outside), ("inside a room", &inside)] {
        let mut r = gpu::renderer();
        let mut frame = |cull: bool| {
            r.set_back_face_cull(cull);
            let out = r.render(w, &RenderOptions::default()).expect("render");
            (out.direct, out.specular)
        };
        let (culled, all) = (frame(true), frame(false));
        let lit = all
            .0
            .pixels
            .iter()
            .filter(|p| p.max_element() > 0.0)
            .count();
        assert!(
            lit > (W * H / 2) as usize,
            "{name}: the frame is lit ({lit} pixels)"
        );
        assert!(
            all.1.pixels.iter().any(|p| p.max_element() > 0.0),
            "{name}: the glass shows"
        );
        for (layer, a, b) in [
            ("direct", &culled.0, &all.0),
            ("specular", &culled.1, &all.1),
        ] {
            let differ = a
                .pixels
                .iter()
                .zip(&b.pixels)
                .filter(|(a, b)| a != b)
                .count();
            assert_eq!(differ, 0, "{name}: {layer} pixels changed by the cull");
        }
    }
}
