//! Light transport tables (Iwasaki et al. 2005, §4 and §6): for every vertex of a
//! refractive object and every sampling direction over the hemisphere above it, where light
//! arriving at the vertex from that direction finally leaves the object, in which direction and
//! with how much of its energy.
//!
//! 1. Each vertex Pᵢ gets the tangent frame (nᵢ, tᵢ, bᵢ) of its (outward) vertex normal.
//! 2. The sampling directions are Eq. 3, ω = −cos φ·n − sin φ cos θ·t − sin φ sin θ·b, on a
//!    regular (φ, θ) grid: the pole φ = 0 and `rings` rings φ = k·90°/rings, k = 1..=rings,
//!    of `azimuths` directions θ = m·360°/azimuths each (8 × 16 + 1 = 129 by default, the
//!    paper's count). A regular grid is what the render's "four nearest sampling directions"
//!    and bilinear interpolation need.
//! 3. Each sampling ray is refracted into the object at Pᵢ (Fresnel transmittance 1 − F), then
//!    traced: total internal reflection reflects it; otherwise it refracts out with the
//!    transmittance 1 − F (the reflected part is left out: the paper takes "only the refraction"
//!    into account); a ray that leaves and meets the object again enters it again (concave
//!    objects), so the stored exit is where the light *finally* leaves. Absorption follows
//!    Beer-Lambert over the path inside (stored as the path length, see [`table`]).
//! 4. Self-occlusion (§4): a ray from Pᵢ towards the light (−ω) that meets the object marks the
//!    sample occluded.
//! 5. A ray that never leaves (TIR beyond `max_depth` interactions, or absorbed by a
//!    non-refractive part) keeps its last hit point and direction and is flagged: the render
//!    does not use it for caustics, only to refract viewing rays (§4, last paragraph).
//!
//! The bake works in the object's rigid frame (scale applied, rotation and translation not),
//! so the table serves the object wherever it is moved or turned and wherever the light is.
//! Quantised storage (§6) and the artifact format are in [`table`].

pub mod table;
pub mod verify;

use super::{BakeError, Fnv64, Progress};
use crate::scene::{Material, Object, World};
use crate::trace::optics::{fresnel_dielectric, reflect, refract};
use crate::trace::{Accel, Hit};
use glam::{Mat4, Vec3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

pub use table::{Fit, TableError, TransportTable};

/// Revision of the bake algorithm, part of every table's content hash (see the CSL bake's).
/// 2: every sample records its path's signature ([`Sample::path`]).
pub const ALGORITHM: u32 = 2;

/// Parameters of a transport-table bake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransportParams {
    /// Rings of sampling directions between the pole and the horizon. 1..=64.
    pub rings: u32,
    /// Sampling directions per ring. 4..=256.
    pub azimuths: u32,
    /// Most interactions (refractions and internal reflections) of a ray inside. 1..=64.
    pub max_depth: u32,
}

impl TransportParams {
    /// The paper's 129 sampling directions (8 rings of 16 and the pole).
    pub const fn paper() -> Self {
        TransportParams {
            rings: 8,
            azimuths: 16,
            max_depth: 16,
        }
    }

    /// The method's default: 289 sampling directions (12 rings of 24 and the pole). On the
    /// canonical glass sphere it reaches 0.099 / 0.109 / 0.105 relative L1 under the
    /// directional, spot and point lights (flux 0.986–0.992), where the paper's 129 give
    /// 0.138 / 0.171 / 0.182; a table twice the paper's size, baked in about twice its time.
    pub const fn standard() -> Self {
        TransportParams {
            rings: 12,
            azimuths: 24,
            ..Self::paper()
        }
    }

    /// Sampling directions per vertex: the pole and the rings.
    pub fn directions(&self) -> usize {
        1 + (self.rings * self.azimuths) as usize
    }

    pub fn validate(&self) -> Result<(), BakeError> {
        let bad = |what: &str| Err(BakeError::InvalidParams(what.to_string()));
        if !(1..=64).contains(&self.rings) {
            return bad("rings must be in 1..=64");
        }
        if !(4..=256).contains(&self.azimuths) {
            return bad("azimuths must be in 4..=256");
        }
        if !(1..=64).contains(&self.max_depth) {
            return bad("max_depth must be in 1..=64");
        }
        Ok(())
    }

    /// Stable hash of the parameters.
    pub fn hash(&self) -> u64 {
        let mut h = Fnv64::new();
        for v in [self.rings, self.azimuths, self.max_depth] {
            h.write_u32(v);
        }
        h.finish()
    }

    /// Polar angle φ (from −n) of ring `k` (0 = the pole).
    pub fn phi(&self, k: u32) -> f32 {
        k as f32 * std::f32::consts::FRAC_PI_2 / self.rings as f32
    }

    /// Azimuth θ (from t towards b) of direction `m` of a ring.
    pub fn theta(&self, m: u32) -> f32 {
        m as f32 * std::f32::consts::TAU / self.azimuths as f32
    }

    /// Index of the sampling direction (ring k ≥ 1, azimuth m) within a vertex's table; 0 is
    /// the pole.
    pub fn index(&self, k: u32, m: u32) -> usize {
        if k == 0 {
            0
        } else {
            1 + ((k - 1) * self.azimuths + m % self.azimuths) as usize
        }
    }

    /// The sampling direction `j` of a vertex as (φ, θ).
    pub fn angles(&self, j: usize) -> (f32, f32) {
        if j == 0 {
            return (0.0, 0.0);
        }
        let j = (j - 1) as u32;
        (
            self.phi(1 + j / self.azimuths),
            self.theta(j % self.azimuths),
        )
    }
}

impl Default for TransportParams {
    fn default() -> Self {
        Self::paper()
    }
}

/// The tangent frame of a vertex (§4): normal, tangent, binormal. Deterministic in the normal.
pub fn tangent_frame(n: Vec3) -> (Vec3, Vec3, Vec3) {
    let n = n.normalize();
    let t = n.any_orthonormal_vector();
    (n, t, n.cross(t))
}

/// Eq. 3: the travel direction of sampling ray (φ, θ) in the frame (n, t, b).
pub fn sampling_direction((n, t, b): (Vec3, Vec3, Vec3), phi: f32, theta: f32) -> Vec3 {
    (-phi.cos() * n - phi.sin() * theta.cos() * t - phi.sin() * theta.sin() * b).normalize()
}

/// (φ, θ) of travel direction `w` in the frame (n, t, b): the inverse of [`sampling_direction`].
/// φ > 90° means light from below the tangent plane.
pub fn local_angles((n, t, b): (Vec3, Vec3, Vec3), w: Vec3) -> (f32, f32) {
    let w = w.normalize();
    let phi = (-w.dot(n)).clamp(-1.0, 1.0).acos();
    let theta = (-w.dot(b))
        .atan2(-w.dot(t))
        .rem_euclid(std::f32::consts::TAU);
    (phi, theta)
}

/// One table entry before quantisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Where the light finally leaves the object (object frame); for a trapped ray its last hit.
    pub position: Vec3,
    /// Unit direction it leaves in (for a trapped ray: its last direction).
    pub direction: Vec3,
    /// Product of the Fresnel transmittances (and mirror reflectances) along the path.
    pub transmittance: f32,
    /// Length of the path inside dielectric parts (for Beer-Lambert at render time).
    pub path_length: f32,
    /// The object itself is between the vertex and the light (§4).
    pub occluded: bool,
    /// The ray never leaves the object (only for refracting viewing rays).
    pub trapped: bool,
    /// The path's signature: a 16-bit hash of the sequence of its interactions inside, each
    /// as (smooth patch of the surface hit, refraction or reflection) ([`PathHash`]). Two
    /// samples with the same signature crossed the same patches in the same way, so their
    /// exits vary continuously between them; samples with different ones left on different
    /// paths, and the render never interpolates across them.
    pub path: u16,
}

/// The signature of a path inside an object ([`Sample::path`]): FNV-1a over its interactions.
#[derive(Clone, Copy, Debug)]
pub struct PathHash(Fnv64);

impl PathHash {
    pub fn new() -> Self {
        PathHash(Fnv64::new())
    }

    /// One interaction: the smooth patch hit, and whether the light refracted through it (or
    /// reflected off it).
    pub fn push(&mut self, patch: u32, refracted: bool) {
        self.0.write_u32(patch << 1 | refracted as u32);
    }

    /// The 16-bit signature.
    pub fn finish(self) -> u16 {
        let h = self.0.finish();
        (h ^ h >> 16 ^ h >> 32 ^ h >> 48) as u16
    }
}

impl Default for PathHash {
    fn default() -> Self {
        Self::new()
    }
}

/// The smooth patch of every triangle of `object` (its parts' triangles in order, as the
/// world's triangle numbering has them): triangles that share a vertex belong to the same
/// patch, vertices being the same when their positions and normals agree (so a seam of the
/// texture coordinates, which splits vertices but not the surface, does not split a patch,
/// and a hard edge, where the normals differ, does). A path's signature names the patches it
/// crosses.
pub fn smooth_patches(object: &Object) -> Vec<u32> {
    use std::collections::HashMap;
    let mut parent: Vec<u32> = Vec::new();
    fn find(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            let p = parent[parent[i as usize] as usize];
            parent[i as usize] = p;
            i = p;
        }
        i
    }
    let mut tri_vertex: Vec<u32> = Vec::new();
    for part in &object.parts {
        let m = &part.mesh;
        let scale = m
            .positions
            .iter()
            .fold(0.0f32, |a, p| a.max(p.abs().max_element()))
            .max(1e-6);
        let mut weld: HashMap<[i32; 6], u32> = HashMap::new();
        let ids: Vec<u32> = m
            .positions
            .iter()
            .zip(&m.normals)
            .map(|(p, n)| {
                let q = (*p / scale * 1e5).round();
                let nq = (n.normalize_or_zero() * 1e3).round();
                let key = [q.x, q.y, q.z, nq.x, nq.y, nq.z].map(|v| v as i32);
                *weld.entry(key).or_insert_with(|| {
                    parent.push(parent.len() as u32);
                    parent.len() as u32 - 1
                })
            })
            .collect();
        for t in &m.indices {
            let [a, b, c] = t.map(|i| ids[i as usize]);
            for (x, y) in [(a, b), (b, c)] {
                let (rx, ry) = (find(&mut parent, x), find(&mut parent, y));
                if rx != ry {
                    parent[rx.max(ry) as usize] = rx.min(ry);
                }
            }
            tri_vertex.push(a);
        }
    }
    tri_vertex
        .into_iter()
        .map(|v| find(&mut parent, v))
        .collect()
}

/// Bake statistics. The sample counts follow from the records (a loaded table has them too);
/// rays and times only from a bake.
#[derive(Clone, Debug, Default)]
pub struct TransportStats {
    pub vertices: u64,
    pub samples: u64,
    pub occluded: u64,
    pub trapped: u64,
    /// Ray casts, including the occlusion rays.
    pub rays: u64,
    pub time_trace: Duration,
    pub time_quantise: Duration,
    /// Checking the table against photons ([`verify`]).
    pub time_verify: Duration,
    pub time_total: Duration,
}

/// Trace one sampling ray entering at vertex `p` (outward normal `n`, index of refraction
/// `ior`) along `w`, counting ray casts in `rays`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn trace_sample(
    accel: &Accel,
    patches: &[u32],
    p: Vec3,
    n: Vec3,
    w: Vec3,
    ior: f32,
    max_depth: u32,
    rays: &mut u64,
) -> Sample {
    let scale = 1.0 + p.abs().max_element();
    let eps = 1e-4 * scale;
    // Self-occlusion: towards the light from just outside the surface.
    *rays += 1;
    let occluded = accel.occluded(p + n * eps, -w, f32::INFINITY);
    let cos_i = (-w.dot(n)).clamp(0.0, 1.0);
    let eta = 1.0 / ior;
    let mut transmittance = 1.0 - fresnel_dielectric(cos_i, eta);
    let Some(mut d) = refract(w, n, eta) else {
        // Cannot happen from outside (eta < 1), but a degenerate normal must not panic.
        return Sample {
            position: p,
            direction: w,
            transmittance: 0.0,
            path_length: 0.0,
            occluded,
            trapped: true,
            path: 0,
        };
    };
    let mut sig = PathHash::new();
    let mut o = p - n * eps;
    let mut last = p;
    let mut path_length = 0.0f32;
    let mut inside = true;
    // Up to max_depth interactions after entering; one more cast finds whether the ray has
    // left (nothing in its way) or is still inside (trapped).
    for depth in 0..=max_depth {
        *rays += 1;
        let mut found = accel.intersect(o, d, f32::INFINITY);
        if found.is_none() && inside {
            // From inside a closed surface a ray must meet it again; one that passes exactly
            // through a vertex or along an edge (on a UV sphere every normal-incidence ray
            // meets the opposite vertex, some along a meridian's edges) can slip between the
            // triangles there. Retry from points nudged sideways, in directions no mesh is
            // aligned with.
            for g in [
                Vec3::new(0.267, 0.535, 0.802),
                Vec3::new(0.816, -0.408, 0.408),
            ] {
                *rays += 1;
                let side = d.cross(g).normalize_or(Vec3::X) * (1e-5 * scale);
                found = accel.intersect(o + side, d, f32::INFINITY);
                if found.is_some() {
                    break;
                }
            }
        }
        let Some(hit) = found else {
            // Nothing more in the way: the light has left (an open surface leaves at once).
            return Sample {
                position: last,
                direction: d,
                transmittance,
                path_length,
                occluded,
                trapped: false,
                path: sig.finish(),
            };
        };
        if inside {
            path_length += hit.t;
        }
        if depth == max_depth {
            break;
        }
        last = hit.point;
        let patch = patches
            .get(hit.triangle as usize)
            .copied()
            .unwrap_or(u32::MAX >> 1);
        match *accel.material(&hit) {
            Material::Dielectric { ior, .. } => {
                let eta = if hit.front_face { 1.0 / ior } else { ior };
                let cos = (-d.dot(hit.normal)).clamp(0.0, 1.0);
                match refract(d, hit.normal, eta) {
                    Some(t) => {
                        transmittance *= 1.0 - fresnel_dielectric(cos, eta);
                        d = t;
                        inside = hit.front_face;
                        sig.push(patch, true);
                    }
                    None => {
                        d = reflect(d, hit.normal);
                        sig.push(patch, false);
                    }
                }
            }
            Material::Mirror { reflectance } => {
                transmittance *= reflectance.element_sum() / 3.0;
                d = reflect(d, hit.normal);
                sig.push(patch, false);
            }
            _ => {
                return trapped(hit, d, path_length, occluded);
            }
        }
        o = hit.spawn(d);
    }
    Sample {
        position: last,
        direction: d,
        transmittance,
        path_length,
        occluded,
        trapped: true,
        path: sig.finish(),
    }
}

/// A ray absorbed by a non-refractive part: trapped at that hit.
fn trapped(hit: Hit, d: Vec3, path_length: f32, occluded: bool) -> Sample {
    Sample {
        position: hit.point,
        direction: d,
        transmittance: 0.0,
        path_length,
        occluded,
        trapped: true,
        path: 0,
    }
}

/// A refractive vertex of the object: position and outward unit normal in the object's rigid
/// frame, and the index of refraction of its part.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub position: Vec3,
    pub normal: Vec3,
    pub ior: f32,
    /// Beer-Lambert coefficient of its part (per metre).
    pub absorption: Vec3,
}

/// The vertices the table is made for: those of the object's dielectric parts, in part order,
/// in the rigid frame (scale applied).
pub fn table_vertices(world: &World, object: &Object) -> Vec<Vertex> {
    let (scale, _, _) = object.transform.to_scale_rotation_translation();
    let m = Mat4::from_scale(scale);
    let mut out = Vec::new();
    for p in &object.parts {
        let Material::Dielectric { ior, absorption } = world.materials[p.material as usize] else {
            continue;
        };
        let mesh = p.mesh.transformed(m);
        for (pos, n) in mesh.positions.iter().zip(&mesh.normals) {
            out.push(Vertex {
                position: *pos,
                normal: n.normalize_or(Vec3::Y),
                ior,
                absorption,
            });
        }
    }
    out
}

/// Bake the light transport table of object `object_name`. `progress` may return false to
/// cancel ([`BakeError::Canceled`]).
pub fn bake_transport(
    world: &World,
    object_name: &str,
    params: &TransportParams,
    progress: &(dyn Fn(Progress) -> bool + Sync),
) -> Result<TransportTable, BakeError> {
    let t_start = Instant::now();
    params.validate()?;
    let object = world
        .object(object_name)
        .ok_or_else(|| BakeError::UnknownObject(object_name.to_string()))?;
    if object.triangle_count() == 0 {
        return Err(BakeError::EmptyObject(object_name.to_string()));
    }
    let vertices = table_vertices(world, object);
    if vertices.is_empty() {
        return Err(BakeError::NotRefractive(object_name.to_string()));
    }
    check_table_size(vertices.len(), params)?;
    let local = super::csl::rigid_frame_world(world, object);
    // The BVH build cannot be interrupted: asked right before and after it.
    let start = || {
        progress(Progress {
            stage: "trace",
            fraction: 0.0,
        })
    };
    if !start() {
        return Err(BakeError::Canceled);
    }
    let accel = Accel::build_with(&local, |_| true, obvhs::BvhBuildParams::fast_build());
    let patches = smooth_patches(&local.objects[0]);
    let (lo, hi) = local.bounds();
    let dirs = params.directions();
    if !start() {
        return Err(BakeError::Canceled);
    }

    // Trace: vertices in fixed chunks, in parallel, concatenated in order (deterministic).
    let t0 = Instant::now();
    const CHUNK: usize = 64;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let chunks: Vec<(Vec<Sample>, u64)> = vertices
        .par_chunks(CHUNK)
        .map(|vs| {
            let mut out = Vec::with_capacity(vs.len() * dirs);
            let mut rays = 0u64;
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return (out, rays);
            }
            for v in vs {
                let frame = tangent_frame(v.normal);
                for j in 0..dirs {
                    let (phi, theta) = params.angles(j);
                    let w = sampling_direction(frame, phi, theta);
                    out.push(trace_sample(
                        &accel,
                        &patches,
                        v.position,
                        frame.0,
                        w,
                        v.ior,
                        params.max_depth,
                        &mut rays,
                    ));
                }
            }
            let d = done.fetch_add(vs.len(), std::sync::atomic::Ordering::Relaxed) + vs.len();
            if !progress(Progress {
                stage: "trace",
                fraction: 0.9 * d as f32 / vertices.len() as f32,
            }) {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            (out, rays)
        })
        .collect();
    if cancel.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(BakeError::Canceled);
    }
    let mut samples = Vec::with_capacity(vertices.len() * dirs);
    let mut rays = 0;
    for (s, r) in chunks {
        samples.extend(s);
        rays += r;
    }
    let time_trace = t0.elapsed();

    let t0 = Instant::now();
    let absorbing = vertices.iter().any(|v| v.absorption != Vec3::ZERO);
    let mut table = TransportTable::quantise_with(
        source_hash(world, object, params),
        *params,
        (lo, hi),
        vertices.len() as u32,
        absorbing,
        &samples,
        &|| {
            progress(Progress {
                stage: "quantise",
                fraction: 0.95,
            })
        },
    )?;
    table.stats.rays = rays;
    table.stats.time_trace = time_trace;
    table.stats.time_quantise = t0.elapsed();
    let t0 = Instant::now();
    table.fit = verify::verify_with(world, object_name, &table, &|| {
        progress(Progress {
            stage: "verify",
            fraction: 0.97,
        })
    })?;
    table.stats.time_verify = t0.elapsed();
    table.stats.time_total = t_start.elapsed();
    progress(Progress {
        stage: "done",
        fraction: 1.0,
    });
    Ok(table)
}

/// Most samples (vertices × directions) one table may hold: 12–14 bytes each stored, about 90
/// while baking (traced samples, their copy and the records), so about 3 GB at the limit.
pub const MAX_TABLE_SAMPLES: u64 = 32 << 20;

/// Refuses a table of more than [`MAX_TABLE_SAMPLES`] samples, naming the sizes.
pub fn check_table_size(vertices: usize, params: &TransportParams) -> Result<(), BakeError> {
    let samples = vertices as u64 * params.directions() as u64;
    if samples > MAX_TABLE_SAMPLES {
        return Err(BakeError::InvalidParams(format!(
            "{vertices} vertices × {} sampling directions is {samples} table samples, more than \
             {MAX_TABLE_SAMPLES}; use fewer rings or azimuths, or a coarser mesh",
            params.directions()
        )));
    }
    Ok(())
}

/// Indices into `World::objects` of the objects with a dielectric part (those a table can be
/// baked for), in scene order.
pub fn refractive_objects(world: &World) -> Vec<usize> {
    world.objects_with(|m| matches!(m, Material::Dielectric { .. }))
}

/// Hash of everything the bake reads: the object's meshes, materials and scale, and the
/// parameters (no light: one table serves every light).
pub fn source_hash(world: &World, object: &Object, params: &TransportParams) -> u64 {
    let mut h = Fnv64::new();
    h.write(b"transport");
    h.write_u32(ALGORITHM);
    h.write(&super::csl::object_hash(world, object).to_le_bytes());
    h.write(&params.hash().to_le_bytes());
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::cancel::{Canceled, CountDown, assert_cancels};

    fn glass_ball() -> World {
        crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 2, 2], "target": [0, 0, 0]},
                "materials": {"g": {"type": "dielectric", "ior": 1.5}},
                "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5,
                             "segments": 16}, "material": "g"}]}"#,
        )
        .unwrap()
    }

    /// The fit check asks to go on around its BVH build, per direction, within the volumes'
    /// construction, per chunk of volumes and per row of photons, and ends canceled whenever
    /// told to stop; a bake told to stop there ends canceled too.
    #[test]
    fn the_fit_check_stops_inside_its_loops_when_asked() {
        let world = glass_ball();
        let params = TransportParams {
            rings: 4,
            azimuths: 8,
            max_depth: 8,
        };
        let table = bake_transport(&world, "ball", &params, &|_| true).unwrap();
        let fit = verify::verify(&world, "ball", &table);
        assert!(fit.is_some());
        let asked = assert_cancels(
            3 * verify::GRID,
            |k| {
                let f = verify::verify_with(&world, "ball", &table, k)?;
                assert_eq!(f, fit);
                Ok::<_, BakeError>(f)
            },
            |e| matches!(e, BakeError::Canceled),
        );
        eprintln!("verify: asked {asked} times");
        // The bake, told to stop while it checks its fit.
        let c = CountDown::new(usize::MAX);
        let stage = std::sync::Mutex::new(String::new());
        let verifying = std::sync::atomic::AtomicUsize::new(0);
        let r = bake_transport(&world, "ball", &params, &|p| {
            if p.stage == "verify" {
                *stage.lock().unwrap() = p.stage.into();
                return verifying.fetch_add(1, std::sync::atomic::Ordering::Relaxed) < 100;
            }
            c.ask()
        });
        assert!(matches!(r, Err(BakeError::Canceled)), "{:?}", r.map(|_| ()));
        assert!(verifying.into_inner() > 100);
    }

    /// Quantisation asks to go on every [`table::QUANTISE_CHUNK`] samples of each pass.
    #[test]
    fn quantisation_stops_when_asked() {
        let n = 3 * table::QUANTISE_CHUNK + 5;
        let samples: Vec<Sample> = (0..n)
            .map(|k| {
                let f = k as f32 / n as f32;
                Sample {
                    position: Vec3::new(f, 1.0 - f, 0.5),
                    direction: Vec3::new(f, 1.0, -f).normalize(),
                    transmittance: f,
                    path_length: 2.0 * f,
                    occluded: k % 7 == 0,
                    trapped: k % 11 == 0,
                    path: (k % 5) as u16,
                }
            })
            .collect();
        let q = |k: crate::cancel::KeepGoing| {
            TransportTable::quantise_with(
                1,
                TransportParams::paper(),
                (Vec3::ZERO, Vec3::ONE),
                (n / 129) as u32,
                true,
                &samples,
                k,
            )
        };
        let whole = TransportTable::quantise(
            1,
            TransportParams::paper(),
            (Vec3::ZERO, Vec3::ONE),
            (n / 129) as u32,
            true,
            &samples,
        )
        .to_bytes();
        let asked = assert_cancels(
            9,
            |k| {
                let t = q(k)?;
                assert_eq!(t.to_bytes(), whole);
                Ok::<_, Canceled>(t)
            },
            |_| true,
        );
        eprintln!("quantise: asked {asked} times");
    }

    #[test]
    fn smooth_patches_split_at_hard_edges_not_at_seams() {
        let world = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 2, 2], "target": [0, 0, 0]},
                "materials": {"g": {"type": "dielectric", "ior": 1.5}},
                "objects": [
                  {"name": "ball", "shape": {"type": "sphere", "radius": 0.5, "segments": 16}, "material": "g"},
                  {"name": "can", "shape": {"type": "cylinder", "radius": 0.3, "height": 0.8, "segments": 16}, "material": "g"}]}"#,
        )
        .unwrap();
        let count = |name: &str| {
            let p = smooth_patches(world.object(name).unwrap());
            assert_eq!(p.len(), world.object(name).unwrap().triangle_count());
            p.into_iter()
                .collect::<std::collections::HashSet<_>>()
                .len()
        };
        // A UV sphere is one smooth surface (its seam shares positions and normals); a
        // cylinder is three: the side and the two caps, meeting at hard edges.
        assert_eq!(count("ball"), 1);
        assert_eq!(count("can"), 3);
    }

    #[test]
    fn sampling_directions_follow_eq_3_and_invert() {
        let p = TransportParams::paper();
        assert_eq!(p.directions(), 129);
        let frame = tangent_frame(Vec3::new(0.3, 0.9, -0.2));
        let (n, t, b) = frame;
        assert!(n.dot(t).abs() < 1e-6 && n.dot(b).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
        // The pole is straight down the normal; every direction comes from the hemisphere
        // above the tangent plane; angles invert.
        assert!((sampling_direction(frame, 0.0, 0.0) + n).length() < 1e-6);
        for j in 0..p.directions() {
            let (phi, theta) = p.angles(j);
            let w = sampling_direction(frame, phi, theta);
            assert!(w.dot(n) <= 1e-6, "direction {j} from below");
            let (phi2, theta2) = local_angles(frame, w);
            assert!((phi - phi2).abs() < 1e-4, "{j}: {phi} {phi2}");
            if j > 0 {
                let dt = (theta - theta2).abs();
                assert!(
                    dt < 1e-4 || (dt - std::f32::consts::TAU).abs() < 1e-4,
                    "{j}"
                );
            }
            let (k, m) = if j == 0 {
                (0, 0)
            } else {
                (1 + (j as u32 - 1) / p.azimuths, (j as u32 - 1) % p.azimuths)
            };
            assert_eq!(p.index(k, m), j);
        }
        // The last ring lies on the horizon, azimuth 0 points against t.
        let w = sampling_direction(frame, p.phi(p.rings), 0.0);
        assert!((w + t).length() < 1e-6);
    }
}
