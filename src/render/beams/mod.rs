//! Volumetric caustics with projected light beams (Liktor and Dachsbacher 2010, method
//! `beams`), built on the interpolated warped volumes of Ernst et al. 2005.
//!
//! Per frame, on the CPU ([`BeamsLayer::build`]), for each directional, spot or point light:
//!
//! 1. **The light-space geometry buffer** (§3.1, Fig. 1-I): a regular grid of (N+1)² rays from
//!    the light, framed tightly around the specular objects (the generators): orthographic for
//!    a directional light, perspective for a spot or point light. Each texel keeps the first
//!    surface the light sees (position, shading normal, material, object): a generator, or
//!    nothing when it misses them or something else is in front (which shadows it).
//! 2. **The projected grid** (§3.1, Fig. 1-II): per vertex, the light's direction ω_l and
//!    irradiance, and per effect the photon direction — reflective (mirrors, and glass by its
//!    Fresnel reflectance) and refractive. Beyond the paper, a refracted vertex is traced
//!    through its glass object to where it leaves it (**two-sided refraction**), carrying both
//!    Fresnel transmittances and the glass's absorption; a beam then starts on the exit
//!    triangle. The medium's transmittance from the light to the surface is included.
//! 3. **False triangles** (§3.1, Fig. 4) are removed: a grid triangle is kept only when its
//!    three vertices are valid, took the same path (object, effect, internal bounces), their
//!    normals agree within 30°, the triangle is not almost parallel to the light (|n_Δ·ω_l| ≥ 0.2,
//!    which drops any triangle across a depth step of more than about five grid cells), and
//!    every photon direction leaves the beam's base on the same side.
//! 4. **Beam space** (§3.1, Fig. 3): origin v0, x along v0→v1, y the base's normal towards the
//!    beam, z = x × y; the photon directions scaled to unit height, d_i'. The area of the slice
//!    at height y is the quadratic A(y) = ay² + by + c (the paper's a has a typo: it is
//!    l1z·l2x − l1x·l2z).
//! 5. **Shadows** (beyond the paper, its future work): each vertex's photon is traced to the
//!    first surface it meets; its height there bounds the beam (interpolated across it), so an
//!    occluder cuts its shaft and the beam ends on the receivers, where the same beams give the
//!    **surface caustics** (Ernst et al. 2005's area ratio at the receiver).
//!
//! On the GPU (`shaders/beams.wgsl`, [`gpu`]): one instance per beam covers the screen outline
//! of its bounding volume (the convex hull of its corners, or the paper's touching-plane
//! prism), and each pixel intersects its view ray with the beam (the planar triangle of the
//! paper's Fig. 5), evaluates the single-scattering integral with one sample (or more) and
//! blends additively: radiance σ_s · p_HG · E⊥ · e^{−σt (s1 + s2)} · Δx, E⊥ the flux density
//! from the area ratio. Optionally at half or quarter resolution, upsampled with depth-aware
//! weights (the paper's §6 suggestion). With a medium, `shaders/fog.wgsl` ray-marches the fog
//! the lights light directly, and the direct light is dimmed by the fog both ways.

pub mod gpu;

use crate::scene::{Light, Material, World};
use crate::trace::optics::{segment_transmittance, specular_branches};
use crate::trace::{Accel, Hit};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// The grid sizes the method takes (cells a side; the paper's 32² … 256²).
pub const GRIDS: [u32; 4] = [32, 64, 128, 256];
pub const DEFAULT_GRID: u32 = 128;
/// Sub-cells a side of a refined cell, by default, and at most.
pub const DEFAULT_REFINE: u32 = 4;
pub const MAX_REFINE: u32 = 8;
/// Samples along a pixel's ray per beam at most.
pub const MAX_SAMPLES: u32 = 16;
/// A triangle almost parallel to the light is a false one (§3.1): |n_Δ·ω_l| below this.
pub const FALSE_TRIANGLE_COS: f32 = 0.1;
/// Vertex normals of one triangle agree within 30°.
pub const NORMAL_AGREEMENT_COS: f32 = 0.866;
/// Internal reflections followed inside a glass object (each exit makes its own beams).
pub const MAX_INTERNAL_BOUNCES: usize = 2;
/// The photon sets of a grid vertex: the reflection, then the light leaving a glass object after
/// 0..=MAX_INTERNAL_BOUNCES internal reflections.
const EFFECTS: usize = 2 + MAX_INTERNAL_BOUNCES;
/// Where a beam passes a focus its slice's area goes to 0: the area ratio is clamped here.
pub const MAX_AREA_RATIO: f32 = 2000.0;

/// What a beams frame is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamsParams {
    /// Grid cells a side (one of [`GRIDS`]).
    pub grid: u32,
    /// Samples along the view ray per beam, 1..=16 (the paper: one).
    pub samples: u32,
    /// Beams end at the first surface their photons meet (else they run through everything,
    /// as in the paper).
    pub shadows: bool,
    /// Refracted photons are traced through their glass object (else the beam leaves the entry
    /// surface along the refracted direction, as in the paper).
    pub two_sided: bool,
    /// The beams also light the receivers they end on (surface caustics).
    pub surface: bool,
    /// The volume is evaluated at 1/downsample of the resolution (1, 2 or 4) and upsampled.
    pub downsample: u32,
    /// Cells across a silhouette or a change of path are split refine × refine (1: not).
    pub refine: u32,
    /// The bounding volume each beam is drawn with.
    pub bounds: Bounds,
}

/// The bounding volume of a beam (§3.1, Fig. 2), drawn as the screen outline of its six
/// corners.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Bounds {
    /// The convex hull of the beam's corners (base, and cap on the photon rays): the tightest
    /// convex volume that holds it.
    #[default]
    Hull,
    /// The paper's prism: per base edge the plane through it that touches the bilinear side
    /// patch (Ernst et al. 2005), capped at the beam's height; the hull where the planes fail
    /// (a beam through a focus, or strongly twisted).
    TouchingPlanes,
}

impl Default for BeamsParams {
    fn default() -> Self {
        BeamsParams {
            grid: DEFAULT_GRID,
            samples: 1,
            shadows: true,
            two_sided: true,
            surface: true,
            downsample: 1,
            refine: DEFAULT_REFINE,
            bounds: Bounds::Hull,
        }
    }
}

/// `Beam` of beams.wgsl (layout checked against naga's in `render::shaders`): one caustic beam
/// in its beam space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuBeam {
    /// xyz: v0, the origin of beam space (world); w: Y, the height of the hull's cap.
    pub origin: [f32; 4],
    /// xyz: the beam-space x axis (world); w: the doubled area the flux is counted over (the
    /// entry triangle's).
    pub ax: [f32; 4],
    /// xyz: y, the base's normal towards the beam; w: 0.
    pub ay: [f32; 4],
    /// xyz: z = x × y; w: 0.
    pub az: [f32; 4],
    /// v1'x, v1'z, v2'x, v2'z (v0' = 0; every base y is 0).
    pub k: [f32; 4],
    /// d0'x, d0'z, d1'x, d1'z (every d_i'y is 1).
    pub d01: [f32; 4],
    /// d2'x, d2'z, 0, 0.
    pub d2: [f32; 4],
    /// The area function's a, b, c (doubled signed slice area); w: 0.
    pub abc: [f32; 4],
    /// Per vertex: rgb the flux per unit of the counted area (W/m²); w: the height where the
    /// vertex's photon ends.
    pub rho: [[f32; 4]; 3],
    /// The cap's corners (world, at height Y) of the bounding volume drawn: on the photon rays
    /// (the convex hull of the beam's corners) or on the touching planes' extrusion rays.
    pub cap: [[f32; 4]; 3],
}

/// Figures of a build.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BeamsStats {
    pub grid: u32,
    /// Lights with a grid.
    pub lights: u32,
    /// Grid vertices that see a generator.
    pub vertices_on_generators: u32,
    /// Grid triangles looked at (two a cell, per light and effect).
    pub triangles: u32,
    pub beams: u32,
    pub reflective_beams: u32,
    pub refractive_beams: u32,
    /// Triangles dropped: a vertex off the generators or shadowed, or without this effect.
    pub dropped_invalid: u32,
    /// Dropped: vertices on different paths (objects, internal bounces).
    pub dropped_paths: u32,
    /// Dropped as false triangles: almost parallel to the light, or normals disagreeing.
    pub dropped_false: u32,
    /// Dropped: photon directions on both sides of the base, or a degenerate base.
    pub dropped_twisted: u32,
    /// Cells split for a silhouette or a change of path.
    pub refined_cells: u32,
    /// Light kinds skipped (environment, line).
    pub skipped_lights: Vec<&'static str>,
    pub time_build: Duration,
}

/// The scene's medium as the frame's `Globals` carry it for the beams and fog passes
/// (`render::plan`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuMedium {
    /// World → the box's frame (column-major).
    pub to_local: [f32; 16],
    /// xyz: the box's half extents (0: no medium).
    pub half: [f32; 4],
    /// rgb σs (1/m); w: g.
    pub sigma_s: [f32; 4],
    /// rgb σt (1/m).
    pub sigma_t: [f32; 4],
}

/// Everything the GPU pass needs of a frame's beams.
#[derive(Clone, Debug)]
pub struct BeamsLayer {
    pub beams: Vec<GpuBeam>,
    pub medium: GpuMedium,
    pub params: BeamsParams,
    pub stats: BeamsStats,
    /// Where each beam's photons entered the generator (the entry triangle), for tests.
    pub entries: Vec<[Vec3; 3]>,
    /// The objects with a glass or mirror part (the generators).
    pub generators: Vec<usize>,
}

/// One light's view of the generators: the rays of the grid.
#[derive(Clone, Copy, Debug)]
enum LightView {
    /// Parallel rays along `dir` from the plane through `origin` spanned by `u`, `v`.
    Ortho {
        dir: Vec3,
        origin: Vec3,
        u: Vec3,
        v: Vec3,
        irradiance: Vec3,
    },
    /// Rays from `pos` through the plane `w + a·u + b·v`, (a, b) over the box.
    Persp {
        pos: Vec3,
        w: Vec3,
        u: Vec3,
        v: Vec3,
        lo: Vec2,
        hi: Vec2,
        intensity: Vec3,
        /// (cutoff, beam width) of a spot light.
        spot: Option<(f32, f32)>,
    },
}

impl LightView {
    /// The ray of grid point `g` ∈ [0,1]²: origin, unit direction, and the irradiance facing
    /// the light at distance t (as a function of t).
    fn ray(&self, g: Vec2) -> (Vec3, Vec3, Vec3, bool) {
        match *self {
            LightView::Ortho {
                dir,
                origin,
                u,
                v,
                irradiance,
            } => (origin + u * g.x + v * g.y, dir, irradiance, true),
            LightView::Persp {
                pos,
                w,
                u,
                v,
                lo,
                hi,
                intensity,
                spot,
            } => {
                let ab = lo + (hi - lo) * g;
                let d = (w + u * ab.x + v * ab.y).normalize();
                let f = spot.map_or(1.0, |(cutoff, width)| {
                    Light::spot_falloff(d.dot(w), cutoff, width)
                });
                (pos, d, intensity * f, false)
            }
        }
    }
}

/// The light's view framed around `points` (the generators' vertices); None for a light the
/// method does not take, or when the generators surround a point light.
fn light_view(light: &Light, points: &[Vec3], span: f32) -> Option<LightView> {
    match *light {
        Light::Directional {
            direction,
            irradiance,
            ..
        } => {
            let (u, v) = crate::sampling::frame(direction);
            let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
            let mut back = f32::MAX;
            for p in points {
                let q = Vec2::new(p.dot(u), p.dot(v));
                lo = lo.min(q);
                hi = hi.max(q);
                back = back.min(p.dot(direction));
            }
            let pad = (hi - lo).max_element() * 0.01 + 1e-4;
            let (lo, hi) = (lo - pad, hi + pad);
            let origin = u * lo.x + v * lo.y + direction * (back - span);
            Some(LightView::Ortho {
                dir: direction,
                origin,
                u: u * (hi.x - lo.x),
                v: v * (hi.y - lo.y),
                irradiance,
            })
        }
        Light::Point {
            position,
            intensity,
        } => persp(position, None, intensity, None, points),
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff,
            beam_width,
        } => persp(
            position,
            Some(direction),
            intensity,
            Some((cutoff, beam_width)),
            points,
        ),
        Light::Line { .. } | Light::Environment { .. } => None,
    }
}

fn persp(
    pos: Vec3,
    axis: Option<Vec3>,
    intensity: Vec3,
    spot: Option<(f32, f32)>,
    points: &[Vec3],
) -> Option<LightView> {
    let mean = points
        .iter()
        .fold(Vec3::ZERO, |s, p| s + (*p - pos).normalize_or_zero());
    let w = axis.unwrap_or(mean).normalize_or_zero();
    if w == Vec3::ZERO {
        return None;
    }
    let (u, v) = crate::sampling::frame(w);
    let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    for p in points {
        let d = *p - pos;
        let z = d.dot(w);
        if z <= 1e-3 * d.length() {
            // Behind the light's image plane: frame the whole cone of a spot, or give up.
            match spot {
                Some(_) => {
                    lo = Vec2::splat(-1e9);
                    hi = Vec2::splat(1e9);
                    continue;
                }
                None => return None,
            }
        }
        let q = Vec2::new(d.dot(u), d.dot(v)) / z;
        lo = lo.min(q);
        hi = hi.max(q);
    }
    if let Some((cutoff, _)) = spot {
        let t = cutoff.min(1.5).tan();
        lo = lo.max(Vec2::splat(-t));
        hi = hi.min(Vec2::splat(t));
        if lo.x >= hi.x || lo.y >= hi.y {
            return None;
        }
    }
    let pad = (hi - lo).max_element() * 0.01 + 1e-5;
    Some(LightView::Persp {
        pos,
        w,
        u,
        v,
        lo: lo - pad,
        hi: hi + pad,
        intensity,
        spot,
    })
}

/// A grid vertex's photon for one effect.
#[derive(Clone, Copy, Debug, Default)]
struct Photon {
    valid: bool,
    /// Where the light met the generator, its shading normal there, the light's direction.
    entry: Vec3,
    entry_normal: Vec3,
    wl: Vec3,
    /// Where the beam starts (the entry, or the exit of a glass object) and its normal there.
    base: Vec3,
    base_normal: Vec3,
    /// Unit photon direction.
    dir: Vec3,
    /// Irradiance facing the light × Fresnel or reflectance × transmittances (W/m²).
    weight: Vec3,
    /// Length along `dir` to where the photon ends.
    end: f32,
    /// The path taken: object, internal bounces.
    key: (u32, u32),
}

/// The first surface a ray meets, nudged along.
fn first_hit(accel: &Accel, o: Vec3, d: Vec3) -> Option<Hit> {
    accel.intersect(o, d, f32::INFINITY)
}

/// Length along o + t·d to where it leaves the box lo..hi (0 when outside).
fn exit_length(lo: Vec3, hi: Vec3, o: Vec3, d: Vec3) -> f32 {
    let inv = d.recip();
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let t1 = a.max(b).min_element();
    if t1.is_finite() { t1.max(0.0) } else { 0.0 }
}

struct Ctx<'a> {
    world: &'a World,
    accel: &'a Accel,
    params: BeamsParams,
    lo: Vec3,
    hi: Vec3,
}

impl Ctx<'_> {
    fn material(&self, h: &Hit) -> Material {
        self.world.materials[h.material as usize]
    }

    /// Where a photon leaving `o` along `d` ends: the first surface it meets (shadows on), or
    /// where it leaves the medium when it meets none (nothing lies beyond to light or to
    /// scatter); without shadows, where it leaves the scene (the paper's constant length).
    fn end(&self, o: Vec3, d: Vec3) -> f32 {
        if !self.params.shadows {
            return exit_length(self.lo, self.hi, o, d);
        }
        first_hit(self.accel, o, d).map_or_else(
            || {
                self.world
                    .media
                    .iter()
                    .filter_map(|m| m.interval(o, d, f32::INFINITY))
                    .map(|(_, t1)| t1)
                    .fold(0.0, f32::max)
            },
            |h| h.t,
        )
    }

    /// The photons of one grid vertex: reflective and refractive.
    fn photons(&self, view: &LightView, g: Vec2) -> (Option<Hit>, [Photon; EFFECTS]) {
        let (o, d, e, ortho) = view.ray(g);
        let mut out = [Photon::default(); EFFECTS];
        let Some(h) = first_hit(self.accel, o, d) else {
            return (None, out);
        };
        let mat = self.material(&h);
        if !mat.is_specular() || e == Vec3::ZERO {
            return (Some(h), out);
        }
        // Irradiance facing the light at the surface, dimmed by the medium on the way.
        let (e, t0) = if ortho {
            (
                e,
                self.world
                    .media_transmittance_ray(h.point, -d, f32::INFINITY),
            )
        } else {
            (e / (h.t * h.t), self.world.medium_transmittance(o, h.point))
        };
        let e = e * t0;
        let base = Photon {
            valid: true,
            entry: h.point,
            entry_normal: h.normal,
            wl: d,
            base: h.point,
            base_normal: h.normal,
            key: (h.object, 0),
            ..Default::default()
        };
        let [r, t] = specular_branches(&h, d, &mat);
        if let Some(r) = r {
            let start = h.spawn(r.dir);
            out[0] = Photon {
                dir: r.dir,
                weight: e * r.weight,
                end: self.end(start, r.dir),
                ..base
            };
        }
        if let Some(t) = t {
            self.refracted(&h, t.dir, e * t.weight, base, &mut out[1..]);
        }
        (Some(h), out)
    }

    /// The refracted photons from entry hit `h` along `dir`, into `out[j]` for the light that
    /// leaves the glass object after j internal reflections (two-sided), or into `out[0]` the
    /// photon leaving the entry surface (the paper's one-sided refraction, and open surfaces).
    fn refracted(&self, h: &Hit, dir: Vec3, weight: Vec3, base: Photon, out: &mut [Photon]) {
        let one_sided = |end| Photon {
            dir,
            weight,
            end,
            ..base
        };
        let start = h.spawn(dir);
        if !self.params.two_sided {
            out[0] = one_sided(self.end(start, dir));
            return;
        }
        let (mut o, mut d, mut w) = (start, dir, weight);
        for (j, slot) in out.iter_mut().enumerate() {
            let Some(x) = first_hit(self.accel, o, d) else {
                if j == 0 {
                    *slot = one_sided(self.end(start, dir));
                }
                return;
            };
            if x.object != h.object || x.front_face {
                // An open surface or something inside: one interface.
                if j == 0 {
                    *slot = one_sided(x.t);
                }
                return;
            }
            let mat = self.material(&x);
            w *= segment_transmittance(&x, &mat);
            let [r, t] = specular_branches(&x, d, &mat);
            if let Some(t) = t {
                let leave = x.spawn(t.dir);
                *slot = Photon {
                    base: x.point,
                    base_normal: x.normal,
                    dir: t.dir,
                    weight: w * t.weight,
                    end: self.end(leave, t.dir),
                    key: (h.object, 1 + j as u32),
                    ..base
                };
            }
            let Some(r) = r else {
                return;
            };
            w *= r.weight;
            o = x.spawn(r.dir);
            d = r.dir;
        }
    }
}

/// What a grid triangle made. (Most are beams: boxing them would allocate for each.)
#[allow(clippy::large_enum_variant)]
enum Made {
    /// A beam of effect k and its entry triangle.
    Beam(usize, GpuBeam, [Vec3; 3]),
    Dropped(Drop),
    /// A cell was refined (counted once).
    Refined,
}

/// Whether a cell's corners differ in validity or path for some effect (a silhouette, a change
/// of path): refining it recovers the light its whole triangles lose.
fn mixed(c: &[&[Photon; EFFECTS]; 4]) -> bool {
    (0..EFFECTS).any(|k| {
        let first = (c[0][k].valid, c[0][k].key);
        c[1..].iter().any(|p| (p[k].valid, p[k].key) != first)
    })
}

/// The beams of a grid cell (corners counter-clockwise), two triangles per effect.
fn cell(c: [&[Photon; EFFECTS]; 4], bounds: Bounds) -> Vec<Made> {
    let mut out = Vec::new();
    for k in 0..EFFECTS {
        let [a, b, cc, d] = c.map(|p| &p[k]);
        if [a, b, cc, d].iter().all(|p| !p.valid) {
            continue;
        }
        for tri in [[a, b, cc], [a, cc, d]] {
            out.push(match beam(tri, bounds) {
                Ok((bm, e)) => Made::Beam(k, bm, e),
                Err(d) => Made::Dropped(d),
            });
        }
    }
    out
}

/// Why a grid triangle makes no beam (None: it makes one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Drop {
    Invalid,
    Paths,
    False,
    Twisted,
}

/// The extrusion rays of the touching-plane prism over base `b` (world) with photon
/// directions `d`, base normal `y` (towards the photons) and height `cap`, or None where the
/// planes fail. Per base edge (i, j): the plane through it that holds d_i or d_j and has the
/// other photon direction, and so the whole side patch, on its inner side; at each vertex the
/// line where its two edges' planes meet. They fail where a beam crosses a focus, or twists so
/// that its third ray leaves a side plane below the cap.
pub fn touching_plane_rays(b: [Vec3; 3], d: [Vec3; 3], y: Vec3, cap: f32) -> Option<[Vec3; 3]> {
    let top = |i: usize| b[i] + d[i] * (cap / d[i].dot(y));
    let mut m = [Vec3::ZERO; 3]; // m[i]: outward normal of the plane over edge (i, i+1)
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        let e = b[j] - b[i];
        let mut found = None;
        for dd in [d[i], d[j]] {
            let mut n = e.cross(dd).normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            if n.dot(b[k] - b[i]) > 0.0 {
                n = -n;
            }
            let tol = 1e-5;
            if n.dot(d[i]) <= tol && n.dot(d[j]) <= tol && n.dot(top(k) - b[i]) <= tol {
                found = Some(n);
                break;
            }
        }
        m[i] = found?;
    }
    let mut out = [Vec3::ZERO; 3];
    for i in 0..3 {
        // Vertex i lies on edges (i−1, i) and (i, i+1).
        let mut r = m[(i + 2) % 3].cross(m[i]).normalize_or_zero();
        if r.dot(y) < 0.0 {
            r = -r;
        }
        if r.dot(y) < 1e-3 {
            return None;
        }
        out[i] = r;
    }
    Some(out)
}

/// The beam of grid triangle `p` (§3.1): the false-triangle tests, beam space, the area
/// function, its bounding volume.
fn beam(p: [&Photon; 3], bounds: Bounds) -> Result<(GpuBeam, [Vec3; 3]), Drop> {
    if p.iter().any(|v| !v.valid) {
        return Err(Drop::Invalid);
    }
    if p.iter().any(|v| v.key != p[0].key) {
        return Err(Drop::Paths);
    }
    // The entry triangle: not almost parallel to the light, normals agreeing (Fig. 4).
    let e = [p[0].entry, p[1].entry, p[2].entry];
    let ce = (e[1] - e[0]).cross(e[2] - e[0]);
    let area0 = ce.length();
    if area0 <= 1e-14 {
        return Err(Drop::Twisted);
    }
    let ne = ce / area0;
    let wl = (p[0].wl + p[1].wl + p[2].wl).normalize();
    let agree = |n: [Vec3; 3]| (0..3).all(|i| n[i].dot(n[(i + 1) % 3]) >= NORMAL_AGREEMENT_COS);
    if ne.dot(wl).abs() < FALSE_TRIANGLE_COS
        || !agree([p[0].entry_normal, p[1].entry_normal, p[2].entry_normal])
        || !agree([p[0].base_normal, p[1].base_normal, p[2].base_normal])
    {
        return Err(Drop::False);
    }
    // Beam space (Fig. 3).
    let b = [p[0].base, p[1].base, p[2].base];
    let cb = (b[1] - b[0]).cross(b[2] - b[0]);
    if cb.length() <= 1e-14 || (b[1] - b[0]).length() <= 1e-9 {
        return Err(Drop::Twisted);
    }
    let mut y = cb.normalize();
    if p.iter().map(|v| v.dir.dot(y)).sum::<f32>() < 0.0 {
        y = -y;
    }
    if p.iter().any(|v| v.dir.dot(y) < 0.02) {
        return Err(Drop::Twisted);
    }
    let x = (b[1] - b[0]).normalize();
    let z = x.cross(y);
    let to = |q: Vec3| Vec2::new(x.dot(q), z.dot(q));
    let k1 = to(b[1] - b[0]);
    let k2 = to(b[2] - b[0]);
    let d: [Vec2; 3] = std::array::from_fn(|i| to(p[i].dir) / p[i].dir.dot(y));
    let (l1, l2) = (d[1] - d[0], d[2] - d[0]);
    // A(y) = cross2(k1 + y l1, k2 + y l2), cross2(u, w) = u_z w_x − u_x w_z.
    let cross2 = |u: Vec2, w: Vec2| u.y * w.x - u.x * w.y;
    let a = cross2(l1, l2);
    let bq = cross2(k1, l2) + cross2(l1, k2);
    let c = cross2(k1, k2);
    // Flux per unit entry area: irradiance facing the light × the cosine to the entry triangle.
    let ends: [f32; 3] = std::array::from_fn(|i| p[i].end * p[i].dir.dot(y));
    let cap = ends.iter().copied().fold(0.0f32, f32::max);
    let rho: [[f32; 4]; 3] = std::array::from_fn(|i| {
        let w = p[i].weight * ne.dot(p[i].wl).abs();
        [w.x, w.y, w.z, ends[i]]
    });
    // The cap's corners at height `cap`.
    let dirs = [p[0].dir, p[1].dir, p[2].dir];
    let rays = match bounds {
        Bounds::Hull => None,
        Bounds::TouchingPlanes => touching_plane_rays(b, dirs, y, cap),
    }
    .unwrap_or(dirs);
    let top: [[f32; 4]; 3] = std::array::from_fn(|i| {
        let c = b[i] + rays[i] * (cap / rays[i].dot(y));
        [c.x, c.y, c.z, 0.0]
    });
    Ok((
        GpuBeam {
            origin: [b[0].x, b[0].y, b[0].z, cap],
            ax: [x.x, x.y, x.z, area0],
            ay: [y.x, y.y, y.z, 0.0],
            az: [z.x, z.y, z.z, 0.0],
            k: [k1.x, k1.y, k2.x, k2.y],
            d01: [d[0].x, d[0].y, d[1].x, d[1].y],
            d2: [d[2].x, d[2].y, 0.0, 0.0],
            abc: [a, bq, c, 0.0],
            rho,
            cap: top,
        },
        e,
    ))
}

impl BeamsLayer {
    /// The beams of `world` (see the module documentation).
    pub fn build(world: &World, params: &BeamsParams) -> BeamsLayer {
        Self::build_with(world, params, &|| true).expect("never asked to stop")
    }

    /// [`Self::build`] that asks `keep_going` before each light, right before and after the
    /// BVH build, and per row of each light's grid as its photons are traced and its cells'
    /// beams made; None once it says stop.
    pub fn build_with(
        world: &World,
        params: &BeamsParams,
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Option<BeamsLayer> {
        let stop = crate::cancel::Stop::new(keep_going);
        let t = Instant::now();
        let generators = crate::methods::caustic_objects(world);
        let mut points = Vec::new();
        for &oi in &generators {
            let o = &world.objects[oi];
            for part in &o.parts {
                if world.materials[part.material as usize].is_specular() {
                    points.extend(
                        part.mesh
                            .positions
                            .iter()
                            .map(|p| o.transform.transform_point3(*p)),
                    );
                }
            }
        }
        if !stop.go() {
            return None;
        }
        let accel = Accel::shared_fast(world, |_| true);
        let (lo, hi) = world.bounds_with_media();
        let (lo, hi) = (lo - 1e-3, hi + 1e-3);
        let span = (hi - lo).length() + 1.0;
        let ctx = Ctx {
            world,
            accel: &accel,
            params: *params,
            lo,
            hi,
        };
        let n = params.grid as usize;
        let mut stats = BeamsStats {
            grid: params.grid,
            ..Default::default()
        };
        let mut beams = Vec::new();
        let mut entries = Vec::new();
        for light in &world.lights {
            if !stop.go() {
                return None;
            }
            let view = if points.is_empty() {
                None
            } else {
                light_view(light, &points, span)
            };
            let Some(view) = view else {
                if !points.is_empty() {
                    stats.skipped_lights.push(light.kind());
                }
                continue;
            };
            stats.lights += 1;
            // The G-buffer and the projected grid, (n+1)² vertices.
            let grid: Vec<(Option<Hit>, [Photon; EFFECTS])> = (0..(n + 1) * (n + 1))
                .into_par_iter()
                .map(|i| {
                    if !stop.go_at(i, n + 1) {
                        return (None, [Photon::default(); EFFECTS]);
                    }
                    let g = Vec2::new((i % (n + 1)) as f32, (i / (n + 1)) as f32) / n as f32;
                    ctx.photons(&view, g)
                })
                .collect();
            if stop.stopped() {
                return None;
            }
            stats.vertices_on_generators += grid
                .iter()
                .filter(|(h, _)| {
                    h.is_some_and(|h| world.materials[h.material as usize].is_specular())
                })
                .count() as u32;
            let at = |i: usize, j: usize| &grid[j * (n + 1) + i].1;
            let m = params.refine.max(1) as usize;
            // Per cell: its beams, or those of its sub-cells where the cell is mixed.
            let cells: Vec<Vec<Made>> = (0..n * n)
                .into_par_iter()
                .map(|c| {
                    if !stop.go_at(c, n) {
                        return Vec::new();
                    }
                    let (i, j) = (c % n, c / n);
                    let corners = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                    if m == 1 || !mixed(&corners) {
                        return cell(corners, params.bounds);
                    }
                    // Adaptive refinement (beyond the paper, its §6 future work): a cell
                    // across a silhouette or a change of path is split m × m.
                    let sub: Vec<[Photon; EFFECTS]> = (0..(m + 1) * (m + 1))
                        .map(|k| {
                            let g = Vec2::new(
                                i as f32 + (k % (m + 1)) as f32 / m as f32,
                                j as f32 + (k / (m + 1)) as f32 / m as f32,
                            ) / n as f32;
                            ctx.photons(&view, g).1
                        })
                        .collect();
                    let s = |a: usize, b: usize| &sub[b * (m + 1) + a];
                    let mut out = Vec::new();
                    for b in 0..m {
                        for a in 0..m {
                            out.extend(cell(
                                [s(a, b), s(a + 1, b), s(a + 1, b + 1), s(a, b + 1)],
                                params.bounds,
                            ));
                        }
                    }
                    out.push(Made::Refined);
                    out
                })
                .collect();
            if stop.stopped() {
                return None;
            }
            for made in cells.into_iter().flatten() {
                match made {
                    Made::Beam(k, bm, e) => {
                        beams.push(bm);
                        entries.push(e);
                        if k == 0 {
                            stats.reflective_beams += 1;
                        } else {
                            stats.refractive_beams += 1;
                        }
                        stats.triangles += 1;
                    }
                    Made::Dropped(d) => {
                        stats.triangles += 1;
                        match d {
                            Drop::Invalid => stats.dropped_invalid += 1,
                            Drop::Paths => stats.dropped_paths += 1,
                            Drop::False => stats.dropped_false += 1,
                            Drop::Twisted => stats.dropped_twisted += 1,
                        }
                    }
                    Made::Refined => stats.refined_cells += 1,
                }
            }
        }
        stats.beams = beams.len() as u32;
        stats.time_build = t.elapsed();
        Some(BeamsLayer {
            beams,
            medium: gpu_medium(world),
            params: *params,
            stats,
            entries,
            generators,
        })
    }
}

/// The scene's medium for the pass (none: half extents 0).
fn gpu_medium(world: &World) -> GpuMedium {
    match world.media.first() {
        Some(m) => {
            let s = m.sigma_s;
            let t = m.sigma_t();
            GpuMedium {
                to_local: m.to_local().to_cols_array(),
                half: m.half().extend(0.0).to_array(),
                sigma_s: [s.x, s.y, s.z, m.g],
                sigma_t: [t.x, t.y, t.z, 0.0],
            }
        }
        None => GpuMedium {
            to_local: glam::Mat4::IDENTITY.to_cols_array(),
            half: [0.0; 4],
            sigma_s: [0.0; 4],
            sigma_t: [0.0; 4],
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The layer asks to go on per row of each light's grid (photons, then cells) and ends
    /// with None whenever told to stop.
    #[test]
    fn the_layer_stops_inside_its_grids_when_asked() {
        let world = crate::scene::load_scene_json(include_bytes!(
            "../../../scenes/fog-glass-sphere-spot.json"
        ))
        .expect("scene resolves");
        let params = BeamsParams {
            grid: 32,
            ..BeamsParams::default()
        };
        let whole = BeamsLayer::build(&world, &params).beams.len();
        let asked = crate::cancel::assert_cancels(
            2 * 32,
            |k| {
                let l = BeamsLayer::build_with(&world, &params, k).ok_or("canceled")?;
                assert_eq!(l.beams.len(), whole);
                Ok(l)
            },
            |e: &&str| *e == "canceled",
        );
        eprintln!("asked {asked} times");
    }

    #[test]
    fn the_area_function_is_the_slice_area() {
        // Three photons from a triangle, converging: A(y) against the cross product.
        let mk = |base: Vec3, dir: Vec3| Photon {
            valid: true,
            entry: base,
            entry_normal: Vec3::Y,
            wl: -Vec3::Y,
            base,
            base_normal: Vec3::Y,
            dir: dir.normalize(),
            weight: Vec3::ONE,
            end: 10.0,
            key: (0, 0),
        };
        let p = [
            mk(Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.3, 1.0, 0.1)),
            mk(Vec3::new(1.0, 0.0, 0.2), Vec3::new(-0.4, 1.0, 0.0)),
            mk(Vec3::new(0.2, 0.0, 1.0), Vec3::new(0.0, 1.0, -0.5)),
        ];
        let (bm, _) = beam([&p[0], &p[1], &p[2]], Bounds::Hull).unwrap();
        let [a, b, c, _] = bm.abc;
        for yy in [0.0f32, 0.3, 0.9, 1.7] {
            let pt = |i: usize| p[i].base + p[i].dir / p[i].dir.y * yy;
            let area = (pt(1) - pt(0)).cross(pt(2) - pt(0)).length();
            let f = (a * yy * yy + b * yy + c).abs();
            assert!(
                (f - area).abs() < 1e-4 * (1.0 + area),
                "y {yy}: {f} vs {area}"
            );
        }
        assert!((bm.ax[3] - c.abs()).abs() < 1e-5, "A(Δ) is c");
    }

    /// The touching-plane prism holds the beam: every point of its three side patches lies on
    /// the inner side of the three planes, and the extrusion rays leave the base upwards.
    #[test]
    fn the_touching_planes_hold_the_side_patches() {
        let b = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.2),
            Vec3::new(0.2, 0.0, 1.0),
        ];
        // Diverging, unevenly (the side patches are not planar).
        let d = [
            Vec3::new(-0.2, 1.0, -0.3).normalize(),
            Vec3::new(0.4, 1.0, 0.05).normalize(),
            Vec3::new(0.1, 1.0, 0.35).normalize(),
        ];
        let r = touching_plane_rays(b, d, Vec3::Y, 3.0).expect("planes");
        for i in 0..3 {
            assert!(r[i].y > 0.0);
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            // The plane over edge (i, j) holds r[i] and r[j]; its outward normal:
            let mut n = (b[j] - b[i]).cross(r[i]).normalize();
            if n.dot(b[k] - b[i]) > 0.0 {
                n = -n;
            }
            assert!(n.dot(r[j]).abs() < 1e-4, "the edge's plane holds both rays");
            for s in 0..=10 {
                for u in 0..=10 {
                    let (h, u) = (s as f32 / 10.0 * 3.0, u as f32 / 10.0);
                    for (a, c) in [(i, j), (j, k), (k, i)] {
                        let at = |v: usize| b[v] + d[v] * (h / d[v].y);
                        let q = at(a) * (1.0 - u) + at(c) * u;
                        assert!(n.dot(q - b[i]) <= 1e-4, "patch point outside the plane");
                    }
                }
            }
        }
        // A beam through a focus (directions crossing below the cap) has no such planes.
        let crossing = [
            Vec3::new(0.3, 1.0, 0.1).normalize(),
            Vec3::new(-0.4, 1.0, 0.0).normalize(),
            Vec3::new(0.1, 1.0, -0.5).normalize(),
        ];
        assert!(touching_plane_rays(b, crossing, Vec3::Y, 3.0).is_none());
    }

    /// A grid triangle with two vertices on a mirror and one on the same mirror's part 0.5 m
    /// lower (a depth edge in the light's view, Fig. 4): false, whatever the normals; the same
    /// triangle without the step makes a beam.
    #[test]
    fn a_triangle_across_a_depth_step_is_false() {
        let h = 1.0 / 128.0;
        let mk = |x: f32, z: f32, y: f32| {
            let n = Vec3::Y;
            let wl = Vec3::new(0.2, -1.0, 0.1).normalize();
            // The light's grid cell projected along wl onto the plane at height y.
            let entry = Vec3::new(x, 0.0, z) + wl * (y / wl.y);
            Photon {
                valid: true,
                entry,
                entry_normal: n,
                wl,
                base: entry,
                base_normal: n,
                dir: crate::trace::optics::reflect(wl, n),
                weight: Vec3::ONE,
                end: 5.0,
                key: (0, 0),
            }
        };
        let (a, b) = (mk(0.0, 0.0, 0.0), mk(h, 0.0, 0.0));
        assert!(beam([&a, &b, &mk(h, h, 0.0)], Bounds::Hull).is_ok());
        assert!(matches!(
            beam([&a, &b, &mk(h, h, 0.5)], Bounds::Hull),
            Err(Drop::False)
        ));
        assert!(matches!(
            beam([&a, &b, &mk(h, h, -0.5)], Bounds::Hull),
            Err(Drop::False)
        ));
    }
}
