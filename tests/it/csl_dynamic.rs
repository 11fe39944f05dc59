//! Dynamic CSL lighting (Liu et al. 2008 §4) on the canonical glass sphere: one dynamic bake (the
//! icosahedron subdivided once, 42 directions about 32° apart, twice the paper's spacing, with
//! 512² rays a direction as the static quality test has), then the caustics at light directions
//! that are no bake direction against Mitsuba 3 and the stored reference, exactness at a bake
//! direction, flux conservation of the interpolation, continuity across a face boundary,
//! determinism and the artifact.
//!
//! The light in the world stays the scene's; the *sphere* is turned so that the light in its
//! rigid frame is the direction under test. A sphere's caustic does not change when it turns
//! about its centre, so the stored ground truth of the scene holds for every direction, and any
//! change between frames is the interpolation's.

use crate::support::{gpu, images, scenes};
use caustica::bake::csl::dynamic::{DynamicParams, DynamicSet, Icosphere, bake_dynamic};
use caustica::bake::csl::{CslParams, CslSet};
use caustica::frame::Frame;
use caustica::reference::compare;
use caustica::render::csl::eval;
use caustica::render::{CslLayer, RenderOptions};
use caustica::scene::World;
use caustica::trace::Accel;
use glam::{Mat4, Quat, Vec3};
use std::sync::OnceLock;

fn params() -> DynamicParams {
    DynamicParams {
        subdivisions: 1,
        steps: 6,
        track_grid: 48,
        csl: CslParams {
            grid: 512,
            ..CslParams::fast()
        },
        ..DynamicParams::paper()
    }
}

fn world() -> World {
    scenes::load("glass-sphere-directional")
}

/// The bake every test shares (made once), as a render reads it from its artifact: the images
/// coded no finer than their noise needs.
fn baked() -> &'static (World, DynamicSet) {
    static BAKE: OnceLock<(World, DynamicSet)> = OnceLock::new();
    BAKE.get_or_init(|| {
        let w = world();
        let d = bake_dynamic(&w, "glass", &params(), &|_| true).expect("dynamic bake");
        eprintln!("{:#?}", d.stats);
        let d = DynamicSet::from_bytes(&d.to_bytes()).expect("the artifact reads back");
        (w, d)
    })
}

fn light(world: &World) -> (Vec3, Vec3) {
    let (direction, irradiance) = scenes::directional_light(world);
    (direction.normalize(), irradiance)
}

/// `world` with the sphere turned so that the light travels along `dir` in its rigid frame.
fn turned(world: &World, dir: Vec3) -> World {
    let mut w = world.clone();
    let (l, _) = light(world);
    let oi = scenes::object_index(&w, "glass");
    let (s, _, t) = w.objects[oi].transform.to_scale_rotation_translation();
    let rot = Quat::from_rotation_arc(dir.normalize(), l);
    w.objects[oi].transform = Mat4::from_scale_rotation_translation(s, rot, t);
    w
}

/// The caustics component of `set` (rigid frame of the sphere) in `world`, on the CPU.
fn caustics(world: &World, set: &CslSet, spp: u32) -> Frame {
    let oi = scenes::object_index(world, "glass");
    let obj = &world.objects[oi];
    let accel = Accel::build(world);
    let blockers = scenes::blockers(world, oi);
    let csls = set.to_world(obj.rigid_transform());
    eval::render_caustics(world, &accel, &blockers, &csls, light(world).1, spp)
}

fn reference() -> Frame {
    images::stored_reference("glass-sphere-directional.caustics.64M.exr")
}

/// At light directions that are no bake direction (near the centre of a face, near the middle
/// of an edge, near a bake direction), the interpolated set against Mitsuba 3's particle tracer
/// in the sphere's shadow, where the direct light is zero (issue 32's targets: relative L1
/// ≤ 0.12, flux within 4 %), and against the stored 64 M-photon reference on the whole floor
/// (issue 6's: ≤ 0.20, within 8 %); on the CPU (3×3 samples a pixel) and through the GPU pass.
#[test]
fn off_the_bake_directions_the_caustics_match_the_reference() {
    let (w0, d) = baked();
    let ico = Icosphere::new(1);
    let f = ico.faces[29];
    let v = |k: usize| ico.vertices[f[k] as usize];
    let reference = reference();
    let mitsuba = images::mitsuba("sphere-directional-ptracer-1024spp.exr");
    let cases = [
        ("near the face centre", (v(0) + v(1) + v(2)).normalize()),
        (
            "near an edge midpoint",
            (v(0) * 0.49 + v(1) * 0.49 + v(2) * 0.02).normalize(),
        ),
        (
            "near a bake direction",
            (v(0) * 0.9 + v(1) * 0.05 + v(2) * 0.05).normalize(),
        ),
    ];
    let mut renderer = gpu::renderer();
    for (name, dir) in cases {
        let world = turned(w0, dir);
        let oi = scenes::object_index(&world, "glass");
        let local = world.objects[oi].to_rigid_frame(light(&world).0);
        assert!(local.dot(dir) > 1.0 - 1e-5);
        assert!(ico.vertices.iter().all(|b| b.dot(local) < 1.0 - 1e-4));
        let set = d.interpolate(local);
        let accel = Accel::build(&world);
        let floor = compare::object_mask(&world, &accel, "floor");
        let shadow = compare::shadow_mask(&world, &accel, "floor", "glass", light(&world).0);
        assert!(shadow.iter().filter(|&&m| m).count() > 1000);
        let cpu = caustics(&world, &set, 3);
        let layer = CslLayer::new(&world, &[(oi, &set)], light(&world).1);
        let gpu = renderer
            .render_csl(&world, &RenderOptions::default(), Some(&layer))
            .unwrap()
            .caustics
            .unwrap();
        for (how, img) in [("CPU", &cpu), ("GPU", &gpu)] {
            let s = compare::compare(img, &mitsuba, &shadow);
            let a = compare::compare(img, &reference, &floor);
            eprintln!("{name}, {how}: shadow vs Mitsuba {s:?}; floor vs reference {a:?}");
            assert!(s.rel_l1 <= 0.12, "{name}, {how}: {s:?}");
            assert!(
                (0.96..=1.04).contains(&s.flux_ratio),
                "{name}, {how}: {s:?}"
            );
            assert!(a.rel_l1 <= 0.20, "{name}, {how}: {a:?}");
            assert!(
                (0.92..=1.08).contains(&a.flux_ratio),
                "{name}, {how}: {a:?}"
            );
        }
    }
}

/// At a bake direction the interpolated set renders as the baked one (rule 3 of §4.3; a CSL
/// whose matches close no cycle comes back as two halves with its own axis and image).
#[test]
fn at_a_bake_direction_the_interpolation_is_the_baked_set() {
    let (w0, d) = baked();
    let ico = Icosphere::new(1);
    for v in [0usize, 17, 40] {
        let mut world = turned(w0, ico.vertices[v]);
        world.camera.width = 96;
        world.camera.height = 96;
        let got = d.interpolate(ico.vertices[v]);
        for c in &got.csls {
            assert!(
                d.sets[v]
                    .csls
                    .iter()
                    .any(|s| (s.origin - c.origin).length() < 1e-5
                        && s.axis.dot(c.axis) > 1.0 - 1e-6
                        && s.kappa == c.kappa
                        && s.gamma == c.gamma),
                "direction {v}: an interpolated CSL that is none of the baked ones"
            );
        }
        let (a, b) = (caustics(&world, &got, 1), caustics(&world, &d.sets[v], 1));
        let diff: f32 = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, y)| (*x - *y).abs().element_sum())
            .sum();
        let total: f32 = b.pixels.iter().map(|p| p.element_sum()).sum();
        assert!(total > 0.0);
        assert!(diff <= 2e-3 * total, "direction {v}: {}", diff / total);
    }
}

/// The light crosses from one face into its neighbour in small steps: the caustic on the floor
/// changes smoothly, and no more at the boundary than elsewhere. Measured (this bake, frames
/// 0.50° apart, images coded as the artifact keeps them, each triple's members moved onto the
/// blended axis): relative L1 change 0.40–0.46 % per step, 0.42 % across the boundary; the flux
/// changes by at most 0.06 % between frames. (With the paper's blend of each triple into one
/// CSL, on the 128²-ray bake this test used before: 0.77–1.00 %, 0.85 % and 0.19 %. A first
/// version that built triples greedily, as the paper's propagation does, and left the unmatched
/// rest arbitrary jumped by 68 % across an edge of the bare icosahedron; the pair triples of
/// [`caustica::bake::csl::dynamic::Triple`] make the two faces of an edge agree exactly.)
#[test]
fn the_caustic_changes_smoothly_across_a_face_boundary() {
    let (w0, d) = baked();
    let ico = Icosphere::new(1);
    // Faces 7 and one of its neighbours across the edge (f[0], f[1]).
    let f = ico.faces[7];
    let (p, q) = (f[0], f[1]);
    let g = ico
        .faces
        .iter()
        .copied()
        .find(|g| g.contains(&p) && g.contains(&q) && *g != f)
        .unwrap();
    let centroid = |f: [u32; 3]| {
        f.iter()
            .map(|&v| ico.vertices[v as usize])
            .fold(Vec3::ZERO, |a, b| a + b)
            .normalize()
    };
    let mid = (ico.vertices[p as usize] + ico.vertices[q as usize]).normalize();
    // From a third of the way between face 7's centre and the edge, to as far on the other side.
    let (a, b) = (centroid(f).lerp(mid, 0.6), centroid(g).lerp(mid, 0.6));
    let steps = 16;
    let mut world = w0.clone();
    world.camera.width = 96;
    world.camera.height = 96;
    let frames: Vec<(f32, Frame)> = (0..=steps)
        .map(|i| {
            let t = i as f32 / steps as f32;
            let dir = a.lerp(b, t).normalize();
            let w = turned(&world, dir);
            let oi = scenes::object_index(&w, "glass");
            let local = w.objects[oi].to_rigid_frame(light(&w).0);
            // Which side of the edge: the sign along the great circle's normal.
            let side = local.dot(centroid(g) - centroid(f));
            (side, caustics(&w, &d.interpolate(local), 1))
        })
        .collect();
    let flux = |f: &Frame| f.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>();
    let change = |x: &Frame, y: &Frame| {
        let diff: f64 = x
            .pixels
            .iter()
            .zip(&y.pixels)
            .map(|(a, b)| (*a - *b).abs().element_sum() as f64)
            .sum();
        diff / flux(x).max(1e-12)
    };
    let changes: Vec<f64> = frames
        .windows(2)
        .map(|w| change(&w[0].1, &w[1].1))
        .collect();
    let cross = frames
        .windows(2)
        .position(|w| w[0].0 < 0.0 && w[1].0 >= 0.0)
        .expect("the sweep crosses the edge");
    eprintln!(
        "frame-to-frame relative change: {changes:.4?}, boundary between {cross} and {}",
        cross + 1
    );
    let others = changes
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != cross)
        .map(|(_, c)| *c)
        .fold(0.0f64, f64::max);
    eprintln!(
        "step {:.2}°",
        a.angle_between(b).to_degrees() / steps as f32
    );
    assert!(changes.iter().all(|&c| c <= 0.05), "{changes:?}");
    assert!(
        changes[cross] <= 1.5 * others + 0.005,
        "jump at the boundary: {changes:?}"
    );
    // The total flux does not jump either.
    let fluxes: Vec<f64> = frames.iter().map(|(_, f)| flux(f)).collect();
    eprintln!(
        "largest flux change between frames: {:.4}",
        fluxes
            .windows(2)
            .map(|w| (w[1] / w[0] - 1.0).abs())
            .fold(0.0f64, f64::max)
    );
    for w in fluxes.windows(2) {
        assert!((w[1] / w[0] - 1.0).abs() <= 0.01, "{fluxes:?}");
    }
}

/// Same inputs, same bytes, whatever the thread count; the artifact reads back to the same set.
#[test]
fn dynamic_bake_is_deterministic_and_round_trips() {
    let w = world();
    let small = DynamicParams {
        subdivisions: 0,
        steps: 4,
        track_grid: 32,
        csl: CslParams {
            grid: 64,
            ..CslParams::fast()
        },
        ..DynamicParams::paper()
    };
    let bake = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake_dynamic(&w, "glass", &small, &|_| true).unwrap())
            .to_bytes()
    };
    let one = bake(1);
    assert!(one == bake(3), "bytes differ between 1 and 3 threads");
    let back = DynamicSet::from_bytes(&one).unwrap();
    assert!(back.to_bytes() == one);
    assert_eq!(back.sets.len(), 12);
    assert_eq!(back.triples.len(), 20);
    assert!(back.is_for(&w, w.object("glass").unwrap()));
    // Another object (a different scale) is told apart.
    let mut other = w.clone();
    let oi = scenes::object_index(&other, "glass");
    other.objects[oi].transform = Mat4::from_scale(Vec3::splat(1.1)) * other.objects[oi].transform;
    assert!(!back.is_for(&other, other.object("glass").unwrap()));
    // A canceled bake stops with an error.
    let seen = std::sync::Mutex::new(Vec::new());
    let r = bake_dynamic(&w, "glass", &small, &|p| {
        seen.lock().unwrap().push(p);
        p.stage != "tracking"
    });
    assert!(matches!(r, Err(caustica::bake::BakeError::Canceled)));
    // Progress counted every direction, then the tracking began (where it was canceled).
    let seen = seen.into_inner().unwrap();
    let dirs: Vec<u32> = seen
        .iter()
        .filter(|p| p.stage == "directions")
        .map(|p| p.done)
        .collect();
    assert_eq!(dirs.iter().max(), Some(&12));
    assert_eq!(seen.last().map(|p| p.stage), Some("tracking"));
    assert!(
        seen.iter()
            .all(|p| p.stage != "directions" || p.total == 12)
    );
}

/// The interpolation conserves flux: at light directions inside faces (centres, near an edge,
/// off centre, near a corner) the interpolated set carries the barycentric blend of its three
/// corner sets' flux, both as the CSLs' `flux` and as their images' integral (what the
/// renderer draws), to 0.1 %. (Measured: within 3·10⁻⁸ at 12 directions in 3 faces: each
/// member's image is its corner's, weighted.)
#[test]
fn the_interpolation_conserves_flux() {
    let (_, d) = baked();
    let ico = Icosphere::new(1);
    // Per unit irradiance (m²): an image's integral over its light plane, and its `flux`.
    let image = |c: &caustica::bake::csl::Csl| -> f64 {
        let px = (2.0 * c.half_extent / c.size as f32) as f64;
        let sum: f64 = c
            .texels
            .iter()
            .map(|t| (t[0] as f64 + t[1] as f64 + t[2] as f64) / 3.0)
            .sum();
        sum * c.scale as f64 / 65535.0 * px * px
    };
    let totals = |s: &CslSet| -> [f64; 2] {
        [
            s.csls.iter().map(image).sum(),
            s.csls.iter().map(|c| c.flux as f64).sum(),
        ]
    };
    let mut worst = 0.0f64;
    for fi in [0usize, 7, 29] {
        let f = ico.faces[fi];
        for w in [
            [1.0 / 3.0; 3],
            [0.49, 0.49, 0.02],
            [0.6, 0.3, 0.1],
            [0.9, 0.05, 0.05],
        ] {
            let dir = (0..3)
                .map(|k| ico.vertices[f[k] as usize] * w[k])
                .fold(Vec3::ZERO, |a, b| a + b)
                .normalize();
            let got = totals(&d.interpolate(dir));
            let (face, weights) = ico.locate(dir);
            let want = ico.faces[face]
                .iter()
                .zip(weights)
                .map(|(&v, wk)| totals(&d.sets[v as usize]).map(|t| t * wk as f64))
                .fold([0.0; 2], |a, b| [a[0] + b[0], a[1] + b[1]]);
            for ((g, w2), what) in got.iter().zip(want).zip(["image integral", "flux"]) {
                let ratio = g / w2;
                worst = worst.max((ratio - 1.0).abs());
                assert!(
                    (ratio - 1.0).abs() <= 1e-3,
                    "face {fi} weights {w:?}: {what} {ratio} of the corners' blend"
                );
            }
        }
    }
    eprintln!("largest departure from the corners' blend: {worst:.2e}");
}
