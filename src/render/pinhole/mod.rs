//! The pinhole pass (Wand and Straßer 2003, method `pinhole`): the specular surfaces are
//! discretised into sample points ([`sampling`]), each a reflecting pinhole camera that
//! projects the incoming light onto the receivers. Per frame, on the CPU: the points of every
//! reflector part (mirrors, and glass by its Fresnel reflection), their normals, area and
//! principal curvatures ([`crate::scene::curvature`]: Kalaiah and Varshney's 2001
//! differential point samples), and for the delta lights the light each point receives
//! (shadowed). On the GPU (`shaders/pinhole.wgsl`), per receiver pixel of the G-buffer and
//! per point: the vector to the point reflected at its normal looks the light up (the
//! environment map, prefiltered over the footprint its curvature spreads the reflected
//! directions over; the delta lights as discs of `sun_radius` seen from the point), weighted
//! by ⟨n_s,−d⟩⟨n_d,d⟩/(⟨d,d⟩+ε) · area/N, the reflector's reflectance and the receiver's BRDF.
//!
//! Beyond the paper: receiver-to-point segments and the points' view of the environment are
//! tested against every object of the scene (`shadows`); point and spot lights are handled per
//! point (each point has its own direction to them, the paper's "several environment maps");
//! the reflectors receive too (self-caustics, the ε term keeping them free of hot spots); with
//! `transmit`, an open glass surface (one interface, the paper's §5) also sends the light it
//! refracts to receivers behind it.

pub mod sampling;

use super::direct::{HDR_FORMAT, Targets};
use super::gbuffer::GBuffer;
use super::scene::{BlockerBuffers, SceneBuffers};
use super::shaders;
use super::timestamps::Timestamps;
use crate::cancel::Canceled;
use crate::render::transport::volumes::{Source, sources};
use crate::scene::curvature::{principal, vertex_shape_operators};
use crate::scene::{EnvMap, Light, Material, World};
use bytemuck::{Pod, Zeroable};
use glam::{Mat3, Mat4, Vec3};
pub use sampling::Strategy;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// What a pinhole frame is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeParams {
    /// Sample points over all reflectors together (split by area).
    pub samples: u32,
    pub strategy: Strategy,
    /// Curvature-based anti-aliasing (§3.3); off shows the paper's aliasing.
    pub filter: bool,
    /// Occlusion, on the GPU, of receiver-to-point segments and of the environment reaching
    /// the points (the delta lights reaching the points are always shadowed, on the CPU).
    pub shadows: bool,
    /// Open glass surfaces also transmit (one refracting interface, §5).
    pub transmit: bool,
    /// Angular radius (radians) of the disc a delta light (directional, point, spot, line)
    /// appears as from a point.
    pub sun_radius: f32,
    pub seed: u64,
    /// Point lights a line light is split into.
    pub line_points: u32,
    /// Points per cluster (1: none; none either without filtering). A receiver farther than 6
    /// radii from a cluster takes it as one pinhole (beyond the paper: a two-level hierarchy of
    /// the points).
    pub cluster: u32,
}

pub const DEFAULT_SAMPLES: u32 = 2000;
pub const DEFAULT_CLUSTER: u32 = 16;
pub const MAX_CLUSTER: u32 = 64;
pub const MAX_SAMPLES: u32 = 100_000;
/// The sun's angular radius (0.27°).
pub const DEFAULT_SUN_RADIUS_DEG: f32 = 0.27;
/// Delta light sources per point at most (a line light counts its points).
pub const MAX_DELTA_SOURCES: usize = 64;

impl Default for PinholeParams {
    fn default() -> Self {
        PinholeParams {
            samples: DEFAULT_SAMPLES,
            strategy: Strategy::default(),
            filter: true,
            shadows: false,
            transmit: false,
            cluster: DEFAULT_CLUSTER,
            sun_radius: DEFAULT_SUN_RADIUS_DEG.to_radians(),
            seed: 1,
            line_points: 16,
        }
    }
}

/// `Sample` of pinhole.wgsl (layout checked against naga's in `render::shaders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuSample {
    /// xyz: position; w: area the point stands for (m²).
    pub position: [f32; 4],
    /// xyz: unit normal; w: ε, the squared radius of a disc of that area.
    pub normal: [f32; 4],
    /// xyz: first principal direction; w: its curvature k1 (1/m).
    pub dir1: [f32; 4],
    /// xyz: second principal direction; w: k2.
    pub dir2: [f32; 4],
    /// Mirror: rgb its reflectance, w 0. Glass: w its index of refraction (the reflectance is
    /// then Fresnel's), x 1 when the part is an open surface (a single interface: it also
    /// transmits, paper §5), else 0.
    pub reflectance: [f32; 4],
}

/// `SampleLight` of pinhole.wgsl: a delta light as one point receives it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuSampleLight {
    /// xyz: unit direction towards the light; w: its angular radius (radians).
    pub dir: [f32; 4],
    /// rgb: irradiance facing the light at the point (W/m², 0 when shadowed); w: 1/distance to
    /// the light (0 for a directional light).
    pub irradiance: [f32; 4],
}

/// `Cluster` of pinhole.wgsl: a run of points close together.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuCluster {
    /// xyz: the representative point's position; w: the radius around it holding every point.
    pub centre: [f32; 4],
    /// x: the representative point, y: the first point, z: the points, w: 0.
    pub range: [u32; 4],
    /// x: the points' summed area (m²), y: ε of that area, zw: 0.
    pub area: [f32; 4],
}

/// `Pinhole` of pinhole.wgsl: the pass's uniform.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuPinhole {
    /// x: points, y: delta lights per point, z: clusters, w: mip levels of the environment map.
    pub counts: [u32; 4],
    /// rgb: constant environment radiance; w: 1 when a map is bound.
    pub env: [f32; 4],
    /// rgb: multiplier of the (normalised) map's texels.
    pub env_scale: [f32; 4],
    /// xy: map size in texels.
    pub env_size: [f32; 4],
    /// x: clusters per draw (the pass is split into draws of that many clusters each).
    pub draw: [u32; 4],
}

/// What a frame's pinhole pass uses, as the override constants its pipeline is specialised on
/// (pinhole.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub filter: bool,
    pub shadows: bool,
    /// Delta lights per point are bound.
    pub delta: bool,
    /// An environment (map or constant) is bound.
    pub env: bool,
    /// Some points lie on an open glass surface and transmit.
    pub transmit: bool,
}

/// Whether a mesh has a boundary: an edge that only one triangle uses, between positions
/// welded within 10⁻⁵ of the mesh's size (vertices split for normals, seams and poles count as
/// one). Glass with a boundary is a single interface (a water surface, a sheet), whose
/// transmitted light the pinhole points carry; a closed glass solid has a second interface
/// they cannot, and only reflects.
pub fn is_open(positions: &[Vec3], indices: &[[u32; 3]]) -> bool {
    let (lo, hi) = positions
        .iter()
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let tol = (hi - lo).length().max(f32::MIN_POSITIVE) * 1e-5;
    let weld = crate::scene::world::weld(positions, tol);
    let mut uses: HashMap<(u32, u32), i32> = HashMap::with_capacity(indices.len() * 2);
    for t in indices {
        let w = t.map(|i| weld.get(i as usize).copied().unwrap_or(i));
        for (a, b) in [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])] {
            if a != b {
                *uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
    }
    uses.values().any(|&n| n == 1)
}

/// Figures of a frame's sampling.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PinholeStats {
    pub samples: usize,
    /// Total reflector area (m²).
    pub area: f32,
    /// Parts sampled.
    pub parts: usize,
    /// Of them, open glass surfaces that also transmit.
    pub transmitting_parts: usize,
    /// Delta light sources each point sees (line lights split).
    pub delta_sources: usize,
    /// Points with a delta light shadowed.
    pub shadowed: usize,
    pub time_sampling: Duration,
    pub time_lights: Duration,
}

/// The caustics of a frame by pinhole projection.
#[derive(Clone, Debug, Default)]
pub struct PinholeLayer {
    /// Ordered cluster by cluster.
    pub samples: Vec<GpuSample>,
    pub clusters: Vec<GpuCluster>,
    /// The most points in a cluster.
    pub cluster_size: u32,
    /// `samples.len() × delta_count`, point-major.
    pub lights: Vec<GpuSampleLight>,
    pub delta_count: u32,
    /// The sum of the constant environments.
    pub env_constant: Vec3,
    /// The first environment map and its multiplier (others are not reflected).
    pub env_map: Option<(Arc<EnvMap>, Vec3)>,
    pub filter: bool,
    pub shadows: bool,
    pub stats: PinholeStats,
}

/// The reflectance (rgb, ior; ior 0 for a mirror) of a material that reflects, None otherwise.
fn reflector(m: &Material) -> Option<[f32; 4]> {
    match *m {
        Material::Mirror { reflectance } => Some(reflectance.extend(0.0).to_array()),
        Material::Dielectric { ior, .. } => Some([0.0, 0.0, 0.0, ior]),
        _ => None,
    }
}

/// Indices into `World::objects` of the objects with a reflecting part.
pub fn reflecting_objects(world: &World) -> Vec<usize> {
    world.objects_with(|m| reflector(m).is_some())
}

/// Orders the points of each part (`ranges` of `samples`, each with the inverse of its
/// object's rigid motion) along a Morton curve in the part's own frame, so that a moving
/// object keeps its clusters, and cuts them into runs of `size`: the clusters. A cluster's
/// representative is its point nearest the area-weighted centroid, its radius the farthest of
/// its points from it, its area theirs summed (ε from it as for a point).
fn cluster_points(
    samples: &mut [GpuSample],
    ranges: &[(std::ops::Range<usize>, Mat4)],
    size: usize,
) -> Vec<GpuCluster> {
    let pos = |s: &GpuSample| Vec3::from_slice(&s.position);
    let mut clusters = Vec::new();
    for (r, to_part) in ranges {
        let local = |s: &GpuSample| to_part.transform_point3(pos(s));
        let part = &mut samples[r.clone()];
        let (lo, hi) = part.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), s| {
            (lo.min(local(s)), hi.max(local(s)))
        });
        let scale = (hi - lo).max_element().max(f32::MIN_POSITIVE);
        let morton = |s: &GpuSample| {
            let q = ((local(s) - lo) / scale * 1023.0).clamp(Vec3::ZERO, Vec3::splat(1023.0));
            // 10 bits to every third of 30 (the usual bit interleave).
            let spread = |v: f32| {
                let mut x = (v as u32 & 0x3ff) as u64;
                x = (x | (x << 16)) & 0x0300_00ff;
                x = (x | (x << 8)) & 0x0300_f00f;
                x = (x | (x << 4)) & 0x030c_30c3;
                x = (x | (x << 2)) & 0x0924_9249;
                x
            };
            spread(q.x) | (spread(q.y) << 1) | (spread(q.z) << 2)
        };
        part.sort_by_key(|s| morton(s));
        for (k, chunk) in part.chunks(size).enumerate() {
            let first = r.start + k * size;
            let area: f32 = chunk.iter().map(|s| s.position[3]).sum();
            let centroid = chunk.iter().map(|s| pos(s) * s.position[3]).sum::<Vec3>()
                / area.max(f32::MIN_POSITIVE);
            let (rep, _) = chunk
                .iter()
                .enumerate()
                .fold((0, f32::MAX), |best, (i, s)| {
                    let d = pos(s).distance_squared(centroid);
                    if d < best.1 { (i, d) } else { best }
                });
            let c = pos(&chunk[rep]);
            let radius = chunk.iter().map(|s| pos(s).distance(c)).fold(0.0, f32::max);
            clusters.push(GpuCluster {
                centre: c.extend(radius).to_array(),
                range: [(first + rep) as u32, first as u32, chunk.len() as u32, 0],
                area: [area, area / std::f32::consts::PI, 0.0, 0.0],
            });
        }
    }
    clusters
}

/// Sample points of [`PinholeLayer::build_with`]'s delta lights between two questions to its
/// `keep_going` (each traces a shadow ray per delta source).
pub const SAMPLES_PER_CHECK: usize = 256;

impl PinholeLayer {
    /// The points of every reflector of `world` and what each receives, under `p`.
    pub fn build(world: &World, p: &PinholeParams) -> Result<PinholeLayer, String> {
        Self::build_with(world, p, &|| true).expect("never asked to stop")
    }

    /// [`Self::build`] that asks `keep_going` as it goes: before each reflector part (as its
    /// mesh is welded and measured, and as its pattern is made and evaluated), within the
    /// making of a pattern, right before and after the BVH build, and every
    /// [`SAMPLES_PER_CHECK`] points as their delta lights are shadowed. Err(Canceled) once it
    /// says stop; Ok(Err(why)) where the scene's lights do not suit the method.
    pub fn build_with(
        world: &World,
        p: &PinholeParams,
        keep_going: &dyn Fn() -> bool,
    ) -> Result<Result<PinholeLayer, String>, Canceled> {
        let check = || if keep_going() { Ok(()) } else { Err(Canceled) };
        let t0 = Instant::now();
        let mut stats = PinholeStats::default();
        // Parts and their areas first: the points are split by area.
        struct PartRef {
            object: usize,
            part: usize,
            refl: [f32; 4],
            /// The mesh's vertices in the object's shape frame (its transform without the
            /// rotation and translation), where its pattern is made.
            q: Vec<Vec3>,
            area: f32,
        }
        let mut parts = Vec::new();
        for (oi, o) in world.objects.iter().enumerate() {
            let shape = o.rigid_transform().inverse() * o.transform;
            for (pi, part) in o.parts.iter().enumerate() {
                let Some(mut refl) = reflector(&world.materials[part.material as usize]) else {
                    continue;
                };
                check()?;
                let m = &part.mesh;
                if p.transmit && refl[3] > 0.0 && is_open(&m.positions, &m.indices) {
                    refl[0] = 1.0;
                    stats.transmitting_parts += 1;
                }
                let q: Vec<Vec3> = m
                    .positions
                    .iter()
                    .map(|v| shape.transform_point3(*v))
                    .collect();
                let area: f32 = m
                    .indices
                    .iter()
                    .map(|t| {
                        let [a, b, c] = t.map(|i| q[i as usize]);
                        0.5 * (b - a).cross(c - a).length()
                    })
                    .sum();
                if area > 0.0 {
                    parts.push(PartRef {
                        object: oi,
                        part: pi,
                        refl,
                        q,
                        area,
                    });
                }
            }
        }
        let total: f32 = parts.iter().map(|r| r.area).sum();
        stats.area = total;
        stats.parts = parts.len();
        let mut samples = Vec::new();
        let mut part_ranges = Vec::new();
        for r in &parts {
            check()?;
            let first = samples.len();
            let o = &world.objects[r.object];
            let mesh = &o.parts[r.part].mesh;
            let rigid = o.rigid_transform();
            let n = ((p.samples as f64 * f64::from(r.area / total)).round() as usize).max(1);
            let pattern =
                sampling::pattern_with(&r.q, &mesh.indices, n, p.strategy, p.seed, keep_going)
                    .ok_or(Canceled)?;
            if pattern.points.is_empty() {
                continue;
            }
            // The mesh in world space (original winding: the barycentrics refer to it).
            let m = o.transform;
            let nm = Mat3::from_mat4(m).inverse().transpose();
            let pw: Vec<Vec3> = mesh
                .positions
                .iter()
                .map(|v| m.transform_point3(*v))
                .collect();
            let nw: Vec<Vec3> = mesh
                .normals
                .iter()
                .map(|v| (nm * *v).normalize_or_zero())
                .collect();
            check()?;
            let shape_ops = vertex_shape_operators(&pw, &nw, &mesh.indices);
            check()?;
            let area = pattern.area / pattern.points.len() as f32;
            // ε = r² of the disc of the point's area: a disc of radius r facing a receiver at distance
            // h on its axis subtends exactly the form factor r²/(h² + r²), so the point's
            // A/(d² + ε) is exact there and finite as d → 0.
            let eps = area / std::f32::consts::PI;
            for sp in &pattern.points {
                let t = mesh.indices[sp.triangle as usize].map(|i| i as usize);
                let w = [1.0 - sp.bary.x - sp.bary.y, sp.bary.x, sp.bary.y];
                let pos = match sp.snapped {
                    Some(c) => rigid.transform_point3(c),
                    None => pw[t[0]] * w[0] + pw[t[1]] * w[1] + pw[t[2]] * w[2],
                };
                let nrm = (nw[t[0]] * w[0] + nw[t[1]] * w[1] + nw[t[2]] * w[2]).normalize_or_zero();
                if nrm == Vec3::ZERO {
                    continue;
                }
                let s = shape_ops[t[0]] * w[0] + shape_ops[t[1]] * w[1] + shape_ops[t[2]] * w[2];
                let k = principal(s, nrm);
                samples.push(GpuSample {
                    position: pos.extend(area).to_array(),
                    normal: nrm.extend(eps).to_array(),
                    dir1: k.d1.extend(k.k1).to_array(),
                    dir2: k.d2.extend(k.k2).to_array(),
                    reflectance: r.refl,
                });
            }
            part_ranges.push((first..samples.len(), rigid.inverse()));
        }
        // Unfiltered, a representative would alias for 16 points: no clusters then.
        let cluster_size = if p.filter { p.cluster.max(1) } else { 1 };
        let clusters = cluster_points(&mut samples, &part_ranges, cluster_size as usize);
        stats.samples = samples.len();
        stats.time_sampling = t0.elapsed();

        // Delta lights, per point, shadowed by everything (the reflector included).
        let t1 = Instant::now();
        let srcs: Vec<Source> = sources(&world.lights, p.line_points);
        if srcs.len() > MAX_DELTA_SOURCES {
            return Ok(Err(format!(
                "{} delta light sources (line lights count their points) over the pinhole \
                 method's {MAX_DELTA_SOURCES}",
                srcs.len()
            )));
        }
        stats.delta_sources = srcs.len();
        let mut lights = Vec::with_capacity(samples.len() * srcs.len());
        if !srcs.is_empty() {
            // The BVH build cannot be interrupted: asked right before and after it.
            check()?;
            let accel = crate::trace::Accel::shared_fast(world, |_| true);
            for (k, s) in samples.iter().enumerate() {
                if k.is_multiple_of(SAMPLES_PER_CHECK) {
                    check()?;
                }
                let pos = Vec3::from_slice(&s.position);
                let n = Vec3::from_slice(&s.normal);
                let lift = 1e-3 * s.normal[3].sqrt();
                let mut any_shadow = false;
                for src in &srcs {
                    let (travel, e) = src.at(pos).unwrap_or((Vec3::Y, Vec3::ZERO));
                    let to_light = -travel;
                    let dist = match *src {
                        Source::Directional { .. } => f32::INFINITY,
                        Source::Point { position, .. } => position.distance(pos),
                    };
                    let mut e = e;
                    if to_light.dot(n) <= 0.0 {
                        e = Vec3::ZERO;
                    } else if e.max_element() > 0.0
                        && accel.occluded(pos + n * lift, to_light, dist - 2.0 * lift)
                    {
                        e = Vec3::ZERO;
                        any_shadow = true;
                    }
                    lights.push(GpuSampleLight {
                        dir: to_light.extend(p.sun_radius).to_array(),
                        irradiance: e
                            .extend(if dist.is_finite() { 1.0 / dist } else { 0.0 })
                            .to_array(),
                    });
                }
                stats.shadowed += usize::from(any_shadow);
            }
        }
        check()?;
        stats.time_lights = t1.elapsed();

        let mut env_constant = Vec3::ZERO;
        let mut env_map = None;
        for l in &world.lights {
            if let Light::Environment { map, radiance } = l {
                match map {
                    Some(m) if env_map.is_none() => env_map = Some((m.clone(), *radiance)),
                    Some(_) => {}
                    None => env_constant += *radiance,
                }
            }
        }
        Ok(Ok(PinholeLayer {
            samples,
            clusters,
            cluster_size,
            lights,
            delta_count: srcs.len() as u32,
            env_constant,
            env_map,
            filter: p.filter,
            shadows: p.shadows,
            stats,
        }))
    }

    /// The pipeline variant this layer needs.
    pub fn variant(&self) -> Variant {
        Variant {
            filter: self.filter,
            shadows: self.shadows,
            delta: self.delta_count > 0,
            env: self.env_map.is_some() || self.env_constant.max_element() > 0.0,
            transmit: self.stats.transmitting_parts > 0,
        }
    }

    /// The pass's uniform.
    pub fn uniform(&self, env_levels: u32, env_norm: f32, per_draw: u32) -> GpuPinhole {
        let (has, scale, size) = match &self.env_map {
            Some((m, s)) => (1.0, *s * env_norm, [m.width as f32, m.height as f32]),
            None => (0.0, Vec3::ZERO, [1.0, 1.0]),
        };
        GpuPinhole {
            counts: [
                self.samples.len() as u32,
                self.delta_count,
                self.clusters.len() as u32,
                env_levels,
            ],
            env: self.env_constant.extend(has).to_array(),
            env_scale: scale.extend(0.0).to_array(),
            env_size: [size[0], size[1], 0.0, 0.0],
            draw: [per_draw, 0, 0, 0],
        }
    }

    /// Clusters per draw where a shader invocation may iterate its loops `budget` times in all.
    /// llvmpipe (lavapipe) ends every loop of an invocation once their iterations together
    /// reach 65535 (Mesa's `LP_MAX_TGSI_LOOP_ITERATIONS`, shared by all loops of a shader), which
    /// would silently drop the remaining points. A cluster costs 2 + its points (at most
    /// `cluster_size`) times a point's cost: 2 + its delta lights + at most 8 footprint taps
    /// (counted as 16), and with shadows two traversals of the occluder hierarchy, counted as
    /// 1024 iterations each (nodes and triangles visited). Where the estimate falls short the
    /// pass says so and the renderer draws again with fewer ([`super::Renderer::render_with`]).
    pub fn clusters_per_draw(&self, budget: u32) -> u32 {
        let per_point =
            (2 + 16 + if self.shadows { 2 * 1024 } else { 0u32 }).saturating_add(self.delta_count);
        let per_cluster = per_point
            .saturating_mul(self.cluster_size.max(1))
            .saturating_add(2);
        (budget / per_cluster).max(1)
    }

    /// Bytes of the storage buffers (checked against the adapter's binding limit).
    pub fn storage_bytes(&self) -> u64 {
        (self.samples.len() * std::mem::size_of::<GpuSample>())
            .max(self.lights.len() * std::mem::size_of::<GpuSampleLight>())
            .max(self.clusters.len() * std::mem::size_of::<GpuCluster>()) as u64
    }
}

/// The environment map as a mip pyramid (box filter, `Rgba16Float` so that every adapter
/// filters it), texels divided by their largest component so that bright suns fit in half
/// floats; the multiplier `norm` restores them.
pub struct EnvPyramid {
    /// Identity of the `EnvMap` (Arc pointer), or 0 for the placeholder.
    pub key: usize,
    pub texture: wgpu::Texture,
    pub levels: u32,
    pub norm: f32,
}

/// The mip levels of `map` (level 0 first), each a box-filtered halving of the one before.
pub fn mip_chain(map: &EnvMap) -> Vec<(u32, u32, Vec<Vec3>)> {
    let mut levels = vec![(map.width, map.height, map.texels.clone())];
    loop {
        let (w, h, t) = levels.last().expect("level 0");
        if *w == 1 && *h == 1 {
            break;
        }
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut out = Vec::with_capacity((nw * nh) as usize);
        for y in 0..nh {
            for x in 0..nw {
                let mut s = Vec3::ZERO;
                let mut c = 0.0;
                for dy in 0..2 {
                    for dx in 0..2 {
                        let (sx, sy) = ((2 * x + dx).min(w - 1), (2 * y + dy).min(h - 1));
                        s += t[(sy * w + sx) as usize];
                        c += 1.0;
                    }
                }
                out.push(s / c);
            }
        }
        levels.push((nw, nh, out));
    }
    levels
}

impl EnvPyramid {
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        map: Option<&EnvMap>,
        key: usize,
    ) -> EnvPyramid {
        let chain = match map {
            Some(m) => mip_chain(m),
            None => vec![(1, 1, vec![Vec3::ZERO])],
        };
        let max = chain[0]
            .2
            .iter()
            .map(|t| t.max_element())
            .fold(0f32, f32::max)
            .max(1e-30);
        let (w, h) = (chain[0].0, chain[0].1);
        let levels = chain.len() as u32;
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("pinhole environment"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba16Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (level, (lw, lh, texels)) in chain.iter().enumerate() {
            let data: Vec<u16> = texels
                .iter()
                .flat_map(|t| {
                    let v = *t / max;
                    [v.x, v.y, v.z, 1.0].map(|c| half::f16::from_f32(c).to_bits())
                })
                .collect();
            queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(&data),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(lw * 8),
                    rows_per_image: Some(*lh),
                },
                wgpu::Extent3d {
                    width: *lw,
                    height: *lh,
                    depth_or_array_layers: 1,
                },
            );
        }
        EnvPyramid {
            key,
            texture,
            levels,
            norm: max,
        }
    }
}

/// The pinhole pipelines (one per [`Variant`] used, made on first use) and their sampler,
/// created once per device; the environment pyramid kept per map.
pub struct PinholePipeline {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    variants: HashMap<Variant, wgpu::RenderPipeline>,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    pub env: Option<EnvPyramid>,
}

impl PinholePipeline {
    pub fn new(device: &wgpu::Device) -> PinholePipeline {
        let entry = |binding, ty| super::layout_entry(binding, wgpu::ShaderStages::FRAGMENT, ty);
        let (uniform, storage, texture) = (
            super::UNIFORM_BINDING,
            super::STORAGE_BINDING,
            super::texture_binding,
        );
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pinhole"),
            entries: &[
                entry(0, uniform),
                entry(2, storage),
                entry(8, storage),
                entry(9, storage),
                entry(10, texture(false)),
                entry(11, texture(false)),
                entry(12, storage),
                entry(13, storage),
                entry(14, uniform),
                entry(15, texture(true)),
                entry(
                    16,
                    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                ),
                entry(17, storage),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("pinhole.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("pinhole.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        // Equirectangular: u wraps, v stops at the poles.
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("pinhole environment"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        PinholePipeline {
            module,
            pipeline_layout,
            variants: HashMap::new(),
            layout,
            sampler,
            env: None,
        }
    }

    fn make_variant(&self, device: &wgpu::Device, v: Variant) -> wgpu::RenderPipeline {
        let flag = |b: bool| if b { 1.0 } else { 0.0 };
        let constants = [
            ("FILTER", flag(v.filter)),
            ("SHADOWS", flag(v.shadows)),
            ("DELTA", flag(v.delta)),
            ("ENV", flag(v.env)),
            ("TRANSMIT", flag(v.transmit)),
        ];
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("pinhole"),
            layout: Some(&self.pipeline_layout),
            vertex: wgpu::VertexState {
                module: &self.module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &self.module,
                entry_point: Some("fs_main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    // The draws add up (the direct pass cleared the layer's colour and left alpha
                    // 1), and so do their alphas: 1 where a draw's loop over points was ended
                    // early (Renderer::render_with draws such a frame again).
                    blend: Some(wgpu::BlendState {
                        color: wgpu::BlendComponent {
                            src_factor: wgpu::BlendFactor::One,
                            dst_factor: wgpu::BlendFactor::One,
                            operation: wgpu::BlendOperation::Add,
                        },
                        alpha: wgpu::BlendComponent {
                            src_factor: wgpu::BlendFactor::One,
                            dst_factor: wgpu::BlendFactor::One,
                            operation: wgpu::BlendOperation::Add,
                        },
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        })
    }

    /// Makes the pipeline variant `layer` needs unless made, and uploads the environment
    /// pyramid of its map unless it is the one kept.
    pub fn fit(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, layer: &PinholeLayer) {
        let v = layer.variant();
        if !self.variants.contains_key(&v) {
            let pipeline = self.make_variant(device, v);
            self.variants.insert(v, pipeline);
        }
        let key = layer
            .env_map
            .as_ref()
            .map_or(0, |(m, _)| Arc::as_ptr(m) as usize);
        if self.env.as_ref().is_none_or(|e| e.key != key) {
            let map = layer.env_map.as_ref().map(|(m, _)| m.as_ref());
            self.env = Some(EnvPyramid::new(device, queue, map, key));
        }
    }
}

/// The buffers of one pinhole frame (never empty: a zero point that lights nothing keeps the
/// bindings valid).
pub struct PinholeBuffers {
    samples: wgpu::Buffer,
    lights: wgpu::Buffer,
    clusters: wgpu::Buffer,
    uniform: wgpu::Buffer,
    clusters_count: u32,
    /// Clusters a draw.
    pub per_draw: u32,
    variant: Variant,
}

impl PinholeBuffers {
    /// `loop_budget`: the loop iterations a shader invocation may make on this adapter (see
    /// [`PinholeLayer::clusters_per_draw`]; `u32::MAX` where there is no such limit); at most
    /// `cap` clusters a draw.
    pub fn upload(
        device: &wgpu::Device,
        layer: &PinholeLayer,
        env: &EnvPyramid,
        loop_budget: u32,
        cap: u32,
    ) -> PinholeBuffers {
        let buf = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let zero_s = [GpuSample::zeroed()];
        let zero_l = [GpuSampleLight::zeroed()];
        let zero_c = [GpuCluster::zeroed()];
        let c: &[GpuCluster] = if layer.clusters.is_empty() {
            &zero_c
        } else {
            &layer.clusters
        };
        let s: &[GpuSample] = if layer.samples.is_empty() {
            &zero_s
        } else {
            &layer.samples
        };
        let l: &[GpuSampleLight] = if layer.lights.is_empty() {
            &zero_l
        } else {
            &layer.lights
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let per_draw = layer.clusters_per_draw(loop_budget).min(cap).max(1);
        let uniform = layer.uniform(env.levels, env.norm, per_draw);
        PinholeBuffers {
            samples: buf("pinhole samples", bytemuck::cast_slice(s), storage),
            lights: buf("pinhole sample lights", bytemuck::cast_slice(l), storage),
            clusters: buf("pinhole clusters", bytemuck::cast_slice(c), storage),
            uniform: buf(
                "pinhole",
                bytemuck::bytes_of(&uniform),
                wgpu::BufferUsages::UNIFORM,
            ),
            clusters_count: layer.clusters.len() as u32,
            per_draw,
            variant: layer.variant(),
        }
    }
}

/// Encodes the pinhole pass over the G-buffer `gbuf` (drawn before it, after the direct pass):
/// it writes the caustics layer.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &PinholePipeline,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    blockers: &BlockerBuffers,
    buffers: &PinholeBuffers,
    targets: &Targets,
    timestamps: Option<&mut Timestamps>,
) {
    let env = p.env.as_ref().expect("fit before encode");
    let pipeline = &p.variants[&buffers.variant];
    let (clusters, per_draw) = (buffers.clusters_count, buffers.per_draw);
    let env_view = env.texture.create_view(&Default::default());
    let (pos_view, nrm_view) = gbuf.views();
    let res = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pinhole"),
        layout: &p.layout,
        entries: &[
            res(0, globals.as_entire_binding()),
            res(2, scene.materials.as_entire_binding()),
            res(8, blockers.nodes.as_entire_binding()),
            res(9, blockers.triangles.as_entire_binding()),
            res(10, wgpu::BindingResource::TextureView(&pos_view)),
            res(11, wgpu::BindingResource::TextureView(&nrm_view)),
            res(12, buffers.samples.as_entire_binding()),
            res(13, buffers.lights.as_entire_binding()),
            res(14, buffers.uniform.as_entire_binding()),
            res(15, wgpu::BindingResource::TextureView(&env_view)),
            res(16, wgpu::BindingResource::Sampler(&p.sampler)),
            res(17, buffers.clusters.as_entire_binding()),
        ],
    });
    let cv = targets.caustics.create_view(&Default::default());
    let mut pass = super::caustics_pass(enc, &cv, "pinhole", timestamps);
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, &bg, &[]);
    // One draw per `per_draw` clusters (instance index: the draw's first cluster); they add up.
    for first in (0..clusters.max(1)).step_by(per_draw.max(1) as usize) {
        pass.draw(0..3, first..first + 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CPU layer asks to go on per part, within a pattern's making, around the BVH build
    /// and every [`SAMPLES_PER_CHECK`] points as their lights are shadowed, and ends canceled
    /// whenever told to stop.
    #[test]
    fn the_cpu_layer_stops_inside_its_loops_when_asked() {
        let world = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 2, 3], "target": [0, 0, 0]},
                 "lights": [{"type": "directional", "direction": [0.3, -1, 0.2],
                             "irradiance": 3.0},
                            {"type": "point", "position": [0, 2, 0], "intensity": 10}],
                 "materials": {"m": {"type": "mirror", "reflectance": 0.9},
                               "d": {"type": "diffuse", "albedo": 0.5}},
                 "objects": [
                   {"name": "floor", "shape": {"type": "plane", "size": [4, 4]}, "material": "d"},
                   {"name": "ring", "shape": {"type": "sphere", "radius": 0.4, "segments": 24},
                    "material": "m", "transform": {"translation": [0, 0.5, 0]}}]}"#,
        )
        .expect("scene resolves");
        for strategy in [Strategy::Random, Strategy::Neighbourhood] {
            let p = PinholeParams {
                samples: 4000,
                strategy,
                // Not the cache's pattern: each run makes its own.
                seed: 77,
                ..PinholeParams::default()
            };
            let whole = PinholeLayer::build(&world, &p).unwrap();
            let asked = crate::cancel::assert_cancels(
                (4000 / SAMPLES_PER_CHECK) + 4,
                |k| {
                    let l = PinholeLayer::build_with(&world, &p, k)?.unwrap();
                    assert_eq!(
                        bytemuck::cast_slice::<_, u8>(&l.lights),
                        bytemuck::cast_slice::<_, u8>(&whole.lights)
                    );
                    Ok::<_, Canceled>(l)
                },
                |_| true,
            );
            eprintln!("{strategy:?}: asked {asked} times");
        }
        // Within the making of a pattern: before each thinning of its candidates.
        let m = crate::scene::shapes::sphere(0.5, 24);
        let c = crate::cancel::CountDown::new(3);
        assert!(
            sampling::make_pattern_with(
                &m.positions,
                &m.indices,
                500,
                Strategy::Neighbourhood,
                5,
                &|| c.ask()
            )
            .is_none()
        );
        assert_eq!(c.calls(), 4);
    }

    #[test]
    fn open_surfaces_are_told_from_closed_solids() {
        use crate::scene::shapes;
        let m = shapes::plane(1.0, 1.0);
        assert!(is_open(&m.positions, &m.indices), "a plane has a rim");
        for (name, m) in [
            ("sphere", shapes::sphere(0.5, 32)),
            ("torus", shapes::torus(0.6, 0.1, 48)),
            ("box", shapes::cuboid(Vec3::ONE)),
            ("cylinder", shapes::cylinder(0.3, 1.0, 24)),
        ] {
            // Seams, poles and flat-shaded faces repeat positions: edges are between positions.
            assert!(!is_open(&m.positions, &m.indices), "{name} is closed");
            let mut cut = m.clone();
            cut.indices.pop();
            assert!(
                is_open(&cut.positions, &cut.indices),
                "{name} less a triangle"
            );
        }
    }

    #[test]
    fn draws_stay_under_the_loop_budget() {
        let mut layer = PinholeLayer {
            samples: vec![GpuSample::zeroed(); 10_000],
            delta_count: 3,
            ..Default::default()
        };
        for (shadows, size) in [(false, 1), (true, 1), (false, 16), (true, 16)] {
            layer.shadows = shadows;
            layer.cluster_size = size;
            let n = layer.clusters_per_draw(crate::gpu::LLVMPIPE_LOOP_ITERATIONS);
            let per_cluster = (2 + 3 + 16 + if shadows { 2048 } else { 0 }) * size + 2;
            let fits = n * per_cluster <= 65535 && (n + 1) * per_cluster > 65535;
            assert!(fits || n == 1, "{shadows} {size}: {n}");
            assert_eq!(layer.clusters_per_draw(u32::MAX), u32::MAX / per_cluster);
        }
        layer.delta_count = u32::MAX / 2;
        assert_eq!(layer.clusters_per_draw(100), 1);
    }

    #[test]
    fn clusters_cover_each_part_once_and_hold_their_points() {
        let mk = |x: f32, refl: f32| GpuSample {
            position: [x, (x * 7.0).sin(), 0.0, 0.5],
            reflectance: [refl, 0.0, 0.0, 0.0],
            ..GpuSample::zeroed()
        };
        // Two parts of 37 and 20 points.
        let mut samples: Vec<GpuSample> = (0..37)
            .map(|i| mk(i as f32 * 0.1, 1.0))
            .chain((0..20).map(|i| mk(10.0 + i as f32 * 0.1, 2.0)))
            .collect();
        let id = Mat4::IDENTITY;
        let clusters = cluster_points(&mut samples, &[(0..37, id), (37..57, id)], 16);
        assert_eq!(clusters.len(), 3 + 2);
        let mut covered = vec![0; samples.len()];
        for c in &clusters {
            let [rep, first, count, _] = c.range;
            let run = first as usize..(first + count) as usize;
            assert!(run.contains(&(rep as usize)));
            // One part per cluster, its area summed, every point within the radius.
            let part = samples[first as usize].reflectance[0];
            assert!(
                samples[run.clone()]
                    .iter()
                    .all(|s| s.reflectance[0] == part)
            );
            assert_eq!(c.area[0], 0.5 * count as f32);
            let centre = Vec3::from_slice(&c.centre);
            for s in &samples[run.clone()] {
                assert!(Vec3::from_slice(&s.position).distance(centre) <= c.centre[3] + 1e-6);
            }
            for i in run {
                covered[i] += 1;
            }
        }
        assert!(covered.iter().all(|&n| n == 1));
    }

    #[test]
    fn mip_chain_halves_down_to_one_texel_and_keeps_the_mean() {
        let map = EnvMap {
            width: 8,
            height: 4,
            texels: (0..32).map(|i| Vec3::splat(i as f32)).collect(),
        };
        let chain = mip_chain(&map);
        let sizes: Vec<(u32, u32)> = chain.iter().map(|l| (l.0, l.1)).collect();
        assert_eq!(sizes, [(8, 4), (4, 2), (2, 1), (1, 1)]);
        assert_eq!(chain[3].2[0], Vec3::splat(15.5));
    }
}
