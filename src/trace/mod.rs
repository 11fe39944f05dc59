//! CPU ray tracing: one BVH over every triangle of the world (built by obvhs as a CWBVH and
//! walked as an eight-wide tree of f32 boxes, module `wide`), closest-hit and occlusion queries
//! with smooth shading normals, and the specular optics (Snell, Fresnel, total internal
//! reflection, Beer-Lambert) that bakes and the reference share. No GPU.

pub mod optics;
pub(crate) mod simd;
mod wide;

use crate::scene::{Material, World};
use glam::{Mat4, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::{Ray, RayHit},
    rt_triangle::RtTriangle,
    triangle::Triangle,
};
use std::time::Duration;

/// Triangles the trees [`Accel::shared_fast`] keeps hold at most in all; a larger tree is kept
/// alone.
pub const SHARED_TRIANGLES: usize = 1 << 20;

/// Offset applied along the geometric normal when a ray leaves a surface, metres.
pub const RAY_EPSILON: f32 = 1e-4;

/// Per-triangle shading data, stored in BVH order next to the intersection data.
#[derive(Clone, Copy, Debug)]
struct TriData {
    normals: [Vec3A; 3],
    /// The unit geometric normal, `RtTriangle::compute_normal` worked out once.
    geo_normal: Vec3A,
    material: u32,
    object: u32,
    /// Index of the triangle in world order (objects, parts, triangles), stable across builds.
    source: u32,
}

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub point: Vec3,
    /// Unit geometric normal, on the side the ray came from.
    pub geo_normal: Vec3,
    /// Unit interpolated vertex normal, flipped to the same side as `geo_normal`.
    pub normal: Vec3,
    /// True when the ray hit the side the mesh's winding faces (entering a closed object).
    pub front_face: bool,
    pub material: u32,
    pub object: u32,
    /// Triangle index in world order.
    pub triangle: u32,
}

impl Hit {
    /// Origin for a ray leaving the surface towards `dir`, nudged off the surface.
    pub fn spawn(&self, dir: Vec3) -> Vec3 {
        let side = if dir.dot(self.geo_normal) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        self.point + self.geo_normal * (side * RAY_EPSILON * (1.0 + self.point.abs().max_element()))
    }
}

/// A BVH over a set of world-space triangles, with materials and objects per triangle.
pub struct Accel {
    bvh: CwBvh,
    /// The same tree with its boxes decoded, for a faster CPU traversal; None where it could not
    /// be made (an empty or very deep tree), and obvhs's traversal serves.
    wide: Option<wide::WideBvh>,
    /// Triangles reordered to `bvh.primitive_indices` so that a primitive id indexes them directly.
    tris: Vec<RtTriangle>,
    data: Vec<TriData>,
    pub materials: Vec<Material>,
    pub build_time: Duration,
    /// [`Self::convex_orientation`], worked out on first use.
    convex: std::sync::OnceLock<Option<f32>>,
}

impl Accel {
    /// Build over every object of the world.
    pub fn build(world: &World) -> Accel {
        Self::build_with(world, |_| true, BvhBuildParams::slow_build())
    }

    /// Build over the objects for which `keep(object index)` holds, with `params`.
    pub fn build_with(
        world: &World,
        keep: impl Fn(usize) -> bool,
        params: BvhBuildParams,
    ) -> Accel {
        let start = std::time::Instant::now();
        let mut tris = Vec::with_capacity(world.triangle_count());
        let mut data = Vec::with_capacity(world.triangle_count());
        let mut source = 0u32;
        for (oi, o) in world.objects.iter().enumerate() {
            let nm = o.transform.inverse().transpose();
            let flip = o.transform.determinant() < 0.0;
            for p in &o.parts {
                if !keep(oi) {
                    source += p.mesh.indices.len() as u32;
                    continue;
                }
                let pos: Vec<Vec3A> = p
                    .mesh
                    .positions
                    .iter()
                    .map(|v| o.transform.transform_point3(*v).into())
                    .collect();
                let nrm: Vec<Vec3A> = p
                    .mesh
                    .normals
                    .iter()
                    .map(|n| normal_xform(nm, *n))
                    .collect();
                for idx in &p.mesh.indices {
                    let [a, b, c] = if flip { [idx[0], idx[2], idx[1]] } else { *idx };
                    tris.push(Triangle {
                        v0: pos[a as usize],
                        v1: pos[b as usize],
                        v2: pos[c as usize],
                    });
                    data.push(TriData {
                        normals: [nrm[a as usize], nrm[b as usize], nrm[c as usize]],
                        geo_normal: Vec3A::ZERO,
                        material: p.material,
                        object: oi as u32,
                        source,
                    });
                    source += 1;
                }
            }
        }
        let bvh = if tris.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh_from_tris(&tris, params, &mut Duration::default())
        };
        let (tris, data) = if tris.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            bvh.primitive_indices
                .iter()
                .map(|&i| {
                    let tri = RtTriangle::from(&tris[i as usize]);
                    let geo_normal = tri.compute_normal();
                    (
                        tri,
                        TriData {
                            geo_normal,
                            ..data[i as usize]
                        },
                    )
                })
                .unzip()
        };
        Accel {
            wide: wide::WideBvh::from_cwbvh(&bvh, &tris),
            bvh,
            tris,
            data,
            materials: world.materials.clone(),
            build_time: start.elapsed(),
            convex: std::sync::OnceLock::new(),
        }
    }

    /// [`Self::build_with`] and [`BvhBuildParams::fast_build`], shared: the tree of the same
    /// objects of the same scene (the same meshes by identity, transforms, materials and
    /// `keep`) built for an earlier frame is served again while its meshes live, instead of
    /// being rebuilt every frame (method `transport` builds three a frame: 36–71 ms for the
    /// canonical 131k-triangle sphere's on 2 cores). A few trees are kept, up to
    /// [`SHARED_TRIANGLES`] triangles in all, the oldest forgotten first. Sound for the reason
    /// [`crate::bake::memo_by_meshes`] gives: a mesh with a `Weak` to it cannot change in place.
    pub fn shared_fast(world: &World, keep: impl Fn(usize) -> bool) -> std::sync::Arc<Accel> {
        use std::sync::{Arc, Mutex, Weak};
        struct Entry {
            meshes: Vec<Weak<crate::scene::Mesh>>,
            /// Per object: its transform and whether it is in the tree, and per part its
            /// material.
            objects: Vec<(Mat4, bool, Vec<u32>)>,
            materials: Vec<Material>,
            accel: Arc<Accel>,
        }
        const KEEP: usize = 6;
        static SHARED: Mutex<Vec<Entry>> = Mutex::new(Vec::new());
        let objects: Vec<(Mat4, bool, Vec<u32>)> = world
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| {
                let mats = o.parts.iter().map(|p| p.material).collect();
                (o.transform, keep(i), mats)
            })
            .collect();
        let meshes: Vec<&Arc<crate::scene::Mesh>> = world
            .objects
            .iter()
            .flat_map(|o| o.parts.iter().map(|p| &p.mesh))
            .collect();
        let alive = |e: &Entry| e.meshes.iter().all(|w| w.strong_count() > 0);
        let same = |e: &Entry| {
            e.objects == objects
                && e.materials == world.materials
                && e.meshes.len() == meshes.len()
                && e.meshes
                    .iter()
                    .zip(&meshes)
                    .all(|(w, m)| w.as_ptr() == Arc::as_ptr(m))
                && alive(e)
        };
        let lock = || SHARED.lock().unwrap_or_else(|e| e.into_inner());
        {
            let mut shared = lock();
            shared.retain(alive);
            if let Some(k) = shared.iter().position(same) {
                let e = shared.remove(k);
                let accel = e.accel.clone();
                shared.push(e);
                return accel;
            }
        }
        let accel = Arc::new(Self::build_with(world, keep, BvhBuildParams::fast_build()));
        let mut shared = lock();
        shared.retain(|e| alive(e) && !same(e));
        shared.push(Entry {
            meshes: meshes.iter().map(|m| Arc::downgrade(m)).collect(),
            objects,
            materials: world.materials.clone(),
            accel: accel.clone(),
        });
        let mut total: usize = shared.iter().map(|e| e.accel.triangle_count()).sum();
        while shared.len() > KEEP || (total > SHARED_TRIANGLES && shared.len() > 1) {
            total -= shared[0].accel.triangle_count();
            shared.remove(0);
        }
        accel
    }

    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Closest hit along `origin + t·dir`, t in (0, tmax). `dir` must be unit length.
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        self.intersect_prim(origin, dir, tmax).map(|(_, hit)| hit)
    }

    /// [`Self::intersect`], with the hit triangle's index in the order the BVH keeps them (for
    /// [`Self::triangle_hit`]).
    #[inline]
    pub fn intersect_prim(&self, origin: Vec3, dir: Vec3, tmax: f32) -> Option<(usize, Hit)> {
        if self.tris.is_empty() {
            return None;
        }
        let ray = make_ray(origin, dir, tmax);
        let (id, t) = match &self.wide {
            Some(w) => w.closest(&ray)?,
            None => {
                let mut hit = RayHit::none();
                if !self
                    .bvh
                    .ray_traverse(ray, &mut hit, |r, id| tri_t(&self.tris[id], r))
                {
                    return None;
                }
                (hit.primitive_id, hit.t)
            }
        };
        let id = id as usize;
        Some((id, self.hit_on(id, t, &ray, origin, dir)))
    }

    /// [`Self::intersect_prim`] for up to eight rays `(origin, dir)` at once (`out[r]` for
    /// `rays[r]`), with no range limit: the same hits, faster where the rays are coherent
    /// (neighbouring rays that took the same path), as the packet shares one tree walk.
    pub fn intersect_packet(&self, rays: &[(Vec3, Vec3)], out: &mut [Option<(usize, Hit)>]) {
        assert!(rays.len() <= 8 && out.len() == rays.len());
        let Some(wide) = self.wide.as_ref().filter(|_| !rays.is_empty()) else {
            for (o, &(origin, dir)) in out.iter_mut().zip(rays) {
                *o = self.intersect_prim(origin, dir, f32::INFINITY);
            }
            return;
        };
        let made: [Ray; 8] = std::array::from_fn(|r| {
            let (origin, dir) = rays[r.min(rays.len() - 1)];
            make_ray(origin, dir, f32::INFINITY)
        });
        let mut found = [None; 8];
        wide.closest_packet(&made[..rays.len()], &mut found[..rays.len()]);
        for (r, o) in out.iter_mut().enumerate() {
            *o = found[r].map(|(id, t)| {
                let (origin, dir) = rays[r];
                (
                    id as usize,
                    self.hit_on(id as usize, t, &made[r], origin, dir),
                )
            });
        }
    }

    /// The hit of `origin + t·dir`, t in (0, tmax), on triangle `prim` alone (an index of
    /// [`Self::triangle_vertices`]), the same as [`Self::intersect`] gives when that triangle is
    /// the closest; None when the ray misses it.
    #[inline]
    pub fn triangle_hit(&self, prim: usize, origin: Vec3, dir: Vec3, tmax: f32) -> Option<Hit> {
        let ray = make_ray(origin, dir, tmax);
        let t = tri_t(&self.tris[prim], &ray);
        t.is_finite()
            .then(|| self.hit_on(prim, t, &ray, origin, dir))
    }

    /// The vertices of triangle `prim`, in the order the BVH keeps the triangles (0 up to
    /// [`Self::triangle_count`]).
    pub fn triangle_vertices(&self, prim: usize) -> [Vec3; 3] {
        let t = &self.tris[prim];
        [t.v0, t.v0 - t.e1, t.v0 + t.e2].map(Vec3::from)
    }

    /// When the triangles bound one convex solid: the sign that turns their winding normals
    /// ((v1 − v0) × (v2 − v0)) outwards (+1, or −1 for a mesh wound inside out); otherwise None.
    /// A ray that leaves such a solid through a triangle (direction · outward normal > 0) can
    /// never meet it again: the solid lies behind the plane of every one of its faces.
    ///
    /// The test: the triangles, with vertices welded by position, form one connected closed
    /// surface in which every edge joins two triangles of opposite orientation, and at every
    /// edge the far vertex of each triangle lies behind the other's plane (within 10⁻⁶ of the
    /// solid's size): a connected closed surface that is convex at every edge bounds a convex
    /// solid. Degenerate triangles make it None.
    pub fn convex_orientation(&self) -> Option<f32> {
        *self
            .convex
            .get_or_init(|| convex_orientation(self, &|| true).expect("never asked to stop"))
    }

    /// [`Self::convex_orientation`] that asks `keep_going` every [`CONVEX_CHUNK`] triangles
    /// of each pass over them (there may be millions) while it is worked out; None once it
    /// says stop (and nothing is kept: a later call works it out again).
    pub fn convex_orientation_with(&self, keep_going: &dyn Fn() -> bool) -> Option<Option<f32>> {
        if let Some(c) = self.convex.get() {
            return Some(*c);
        }
        let c = convex_orientation(self, keep_going).ok()?;
        Some(*self.convex.get_or_init(|| c))
    }

    /// The hit at distance `t` on triangle `id`.
    #[inline(always)]
    fn hit_on(&self, id: usize, t: f32, ray: &Ray, origin: Vec3, dir: Vec3) -> Hit {
        let tri = &self.tris[id];
        let d = &self.data[id];
        let uv = tri.compute_barycentric(ray);
        let w = 1.0 - uv.x - uv.y;
        let ng: Vec3 = d.geo_normal.into();
        let front_face = ng.dot(dir) < 0.0;
        let geo_normal = if front_face { ng } else { -ng };
        let ns: Vec3 = (d.normals[0] * w + d.normals[1] * uv.x + d.normals[2] * uv.y).into();
        let mut normal = ns.normalize_or(ng);
        if !front_face {
            normal = -normal;
        }
        // A shading normal on the far side of the geometric one would let light leak.
        if normal.dot(geo_normal) <= 0.0 {
            normal = geo_normal;
        }
        Hit {
            t,
            point: origin + dir * t,
            geo_normal,
            normal,
            front_face,
            material: d.material,
            object: d.object,
            triangle: d.source,
        }
    }

    /// True when anything lies on the segment `origin + t·dir`, t in (0, tmax).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmax: f32) -> bool {
        if self.tris.is_empty() {
            return false;
        }
        let ray = make_ray(origin, dir, tmax);
        match &self.wide {
            Some(w) => w.any(&ray),
            None => !self
                .bvh
                .ray_traverse_miss(ray, |r, id| tri_t(&self.tris[id], r)),
        }
    }

    /// The material of a hit.
    pub fn material(&self, hit: &Hit) -> &Material {
        &self.materials[hit.material as usize]
    }
}

/// A multiply-rotate hasher for the integer keys of [`convex_orientation`] (the standard
/// hasher made that test take 80 ms on a 65k-triangle mesh).
#[derive(Default)]
struct FastHasher(u64);

impl std::hash::Hasher for FastHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..c.len()].copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(w));
        }
    }
    fn write_u64(&mut self, w: u64) {
        self.0 = (self.0.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_u32(&mut self, w: u32) {
        self.write_u64(w as u64);
    }
    fn write_i64(&mut self, w: i64) {
        self.write_u64(w as u64);
    }
    fn write_usize(&mut self, w: usize) {
        self.write_u64(w as u64);
    }
}

type HashMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<FastHasher>>;

/// Triangles [`Accel::convex_orientation_with`] handles between two questions to its
/// `keep_going` (a few milliseconds).
pub const CONVEX_CHUNK: usize = 1 << 15;

/// [`Accel::convex_orientation`], worked out; Err(Canceled) once `keep_going` (asked every
/// [`CONVEX_CHUNK`] triangles of each pass) says stop.
fn convex_orientation(
    accel: &Accel,
    keep_going: &dyn Fn() -> bool,
) -> Result<Option<f32>, crate::cancel::Canceled> {
    let check = |k: usize| {
        if k.is_multiple_of(CONVEX_CHUNK) && !keep_going() {
            Err(crate::cancel::Canceled)
        } else {
            Ok(())
        }
    };
    let count = accel.triangle_count();
    if count < 4 {
        return Ok(None);
    }
    check(0)?;
    let corners: Vec<[Vec3; 3]> = (0..count).map(|p| accel.triangle_vertices(p)).collect();
    let (lo, hi) = corners.iter().flatten().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &v| (lo.min(v), hi.max(v)),
    );
    let size = (hi - lo).length();
    if !(size > 0.0 && size.is_finite()) {
        return Ok(None);
    }
    // Weld vertices closer than 10⁻⁶ of the size (a generated sphere's seam and poles repeat
    // vertices up to rounding), in order, through a hash of cells of that size.
    let weld = 1e-6 * size;
    let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::default();
    cells.reserve(count);
    let mut points: Vec<Vec3> = Vec::with_capacity(count / 2 + 3);
    let mut id_of = |v: Vec3| -> u32 {
        let key = ((v - lo) / weld).floor().as_i64vec3().to_array();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let k = [key[0] + dx, key[1] + dy, key[2] + dz];
                    if let Some(list) = cells.get(&k) {
                        for &i in list {
                            if points[i as usize].distance(v) <= weld {
                                return i;
                            }
                        }
                    }
                }
            }
        }
        points.push(v);
        let i = points.len() as u32 - 1;
        cells.entry(key).or_default().push(i);
        i
    };
    // Triangles that welding folds to a line or a point are slivers on the surface: left out.
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(count);
    for (k, t) in corners.iter().enumerate() {
        check(k)?;
        let t = t.map(&mut id_of);
        if t[0] != t[1] && t[1] != t[2] && t[2] != t[0] {
            tris.push(t);
        }
    }
    if tris.len() < 4 {
        return Ok(None);
    }
    let tol = 1e-6 * size;
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| points[i as usize]);
        (b - a).cross(c - a)
    };
    // Directed edges; each must occur once, and its reverse once.
    let mut edges: HashMap<(u32, u32), u32> = HashMap::default();
    edges.reserve(3 * count);
    let mut volume = 0.0f64;
    for (k, t) in tris.iter().enumerate() {
        check(k)?;
        if normal(t).length_squared() <= 0.0 {
            return Ok(None);
        }
        let [a, b, c] = t.map(|i| points[i as usize].as_dvec3());
        volume += a.dot(b.cross(c));
        for e in 0..3 {
            if edges.insert((t[e], t[(e + 1) % 3]), k as u32).is_some() {
                return Ok(None);
            }
        }
    }
    if volume == 0.0 {
        return Ok(None);
    }
    let sign = if volume > 0.0 { 1.0f32 } else { -1.0 };
    let mut seen = vec![false; tris.len()];
    let mut todo = vec![0usize];
    seen[0] = true;
    let mut visited = 0usize;
    while let Some(k) = todo.pop() {
        visited += 1;
        check(visited)?;
        let t = &tris[k];
        let n = normal(t) * sign;
        let base = points[t[0] as usize];
        for e in 0..3 {
            let Some(&other) = edges.get(&(t[(e + 1) % 3], t[e])) else {
                return Ok(None);
            };
            let u = &tris[other as usize];
            // The vertex of the neighbour off the shared edge, behind this triangle's plane.
            let Some(far) = u.iter().find(|&&v| v != t[e] && v != t[(e + 1) % 3]) else {
                return Ok(None);
            };
            if (points[*far as usize] - base).dot(n) > tol * n.length() {
                return Ok(None);
            }
            if !seen[other as usize] {
                seen[other as usize] = true;
                todo.push(other as usize);
            }
        }
    }
    Ok(seen.iter().all(|&s| s).then_some(sign))
}

/// Ray-triangle distance (∞ on a miss): Möller-Trumbore in Embree's arrangement, which tests
/// the edges before dividing and divides only on a hit (about 20% more coherent rays/s here than
/// `RtTriangle::intersect`). obvhs's own `intersect_embree` returns t scaled by the determinant,
/// which breaks closest-hit ordering; this one returns the true distance.
#[inline(always)]
fn tri_t(tri: &RtTriangle, ray: &Ray) -> f32 {
    const SIGN: u32 = 0x8000_0000;
    let c = tri.v0 - ray.origin;
    let r = c.cross(ray.direction);
    let den = -tri.ng.dot(ray.direction);
    let abs_den = den.abs();
    let sgn = den.to_bits() & SIGN;
    let u = f32::from_bits(r.dot(tri.e2).to_bits() ^ sgn);
    let v = f32::from_bits(r.dot(tri.e1).to_bits() ^ sgn);
    let w = abs_den - u - v;
    // `< 0.0` rather than sign bits: a ray through a shared edge or vertex (u, v or w = -0.0)
    // must hit one of the triangles, or it would leak through the mesh.
    if den == 0.0 || u < 0.0 || v < 0.0 || w < 0.0 {
        return f32::INFINITY;
    }
    let t = f32::from_bits((-tri.ng).dot(c).to_bits() ^ sgn);
    if abs_den * ray.tmin < t && t <= abs_den * ray.tmax {
        t / abs_den
    } else {
        f32::INFINITY
    }
}

/// A ray for obvhs. Negative zero direction components are made positive: obvhs 0.4 picks the
/// traversal octant from the sign bit and misses everything for a -0.0 component.
fn make_ray(origin: Vec3, dir: Vec3, tmax: f32) -> Ray {
    Ray::new(origin.into(), Vec3A::from(dir) + Vec3A::ZERO, 0.0, tmax)
}

fn normal_xform(nm: Mat4, n: Vec3) -> Vec3A {
    nm.transform_vector3(n).normalize_or_zero().into()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The world of scene JSON `json` (no assets).
    fn world_of(json: &str) -> World {
        resolve(
            &parse_scene(json.as_bytes()).unwrap(),
            &MapSource::default(),
            &Default::default(),
        )
        .unwrap()
    }

    /// A shared tree serves the same scene again (the same `Arc`), and is built anew for
    /// another transform, another set of objects, or meshes of the same content in other
    /// allocations; it finds what a fresh build finds; a scene whose meshes are gone leaves
    /// nothing behind that a new scene could be served from.
    #[test]
    fn shared_trees_serve_only_the_same_scene() {
        use std::sync::Arc;
        let json = r#"{
            "camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
            "materials": {"d": {"type": "diffuse", "albedo": 0.5}},
            "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5,
                         "segments": 24}, "material": "d"},
                        {"name": "floor", "shape": {"type": "plane", "size": [4, 4]},
                         "material": "d"}]}"#;
        let load = || world_of(json);
        let world = load();
        let a = Accel::shared_fast(&world, |_| true);
        assert!(
            Arc::ptr_eq(&a, &Accel::shared_fast(&world, |_| true)),
            "served again"
        );
        let ball = Accel::shared_fast(&world, |i| i == 0);
        assert!(!Arc::ptr_eq(&a, &ball), "another set of objects");
        assert!(ball.triangle_count() < a.triangle_count());
        let mut moved = world.clone();
        moved.objects[0].transform = Mat4::from_translation(Vec3::Y) * moved.objects[0].transform;
        let m = Accel::shared_fast(&moved, |_| true);
        assert!(!Arc::ptr_eq(&a, &m), "another transform");
        let other = load();
        assert!(
            !Arc::ptr_eq(&a, &Accel::shared_fast(&other, |_| true)),
            "the same content in other meshes is another scene"
        );
        let fresh = Accel::build_with(&moved, |_| true, BvhBuildParams::fast_build());
        for k in 0..64 {
            let t = k as f32 / 64.0 * std::f32::consts::TAU;
            let o = Vec3::new(2.0 * t.cos(), 1.5, 2.0 * t.sin());
            let d = (Vec3::new(0.1 * t.sin(), 0.9, 0.0) - o).normalize();
            let (x, y) = (m.intersect(o, d, 100.0), fresh.intersect(o, d, 100.0));
            assert_eq!(
                x.map(|h| (h.triangle, h.point)),
                y.map(|h| (h.triangle, h.point))
            );
        }
        let weak = Arc::downgrade(&a);
        drop((a, ball, m, world, moved));
        let _ = Accel::shared_fast(&other, |_| true);
        assert!(
            weak.upgrade().is_none(),
            "the tree of a scene that is gone is dropped"
        );
    }

    /// The convexity test asks to go on every [`CONVEX_CHUNK`] triangles of each pass; told
    /// to stop it gives up and keeps nothing, so that a later call works it out.
    #[test]
    fn the_convexity_test_stops_when_asked_and_keeps_nothing() {
        let json = r#"{
            "camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
            "materials": {"d": {"type": "diffuse", "albedo": 0.5}},
            "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5,
                         "segments": 320}, "material": "d"}]}"#;
        let world = world_of(json);
        let accel = Accel::build_with(&world, |_| true, BvhBuildParams::fast_build());
        assert!(accel.triangle_count() > 2 * CONVEX_CHUNK);
        let asked = crate::cancel::assert_cancels(
            5,
            |k| {
                // Not kept once worked out: a fresh BVH each time would cost more.
                let c = convex_orientation(&accel, k)?;
                assert_eq!(c, Some(1.0));
                Ok::<_, crate::cancel::Canceled>(c)
            },
            |_| true,
        );
        eprintln!("asked {asked} times");
        let c = crate::cancel::CountDown::new(2);
        assert_eq!(accel.convex_orientation_with(&|| c.ask()), None);
        assert!(accel.convex.get().is_none(), "a stopped test is not kept");
        assert_eq!(accel.convex_orientation_with(&|| true), Some(Some(1.0)));
        assert_eq!(accel.convex_orientation(), Some(1.0));
        // Once known, it is not asked again.
        let c = crate::cancel::CountDown::new(0);
        assert_eq!(accel.convex_orientation_with(&|| c.ask()), Some(Some(1.0)));
    }
    use crate::scene::{MapSource, parse_scene, resolve};

    /// A random unit vector (a point of the unit ball's shell, normalised).
    fn random_unit(rng: &mut crate::sampling::Pcg) -> Vec3 {
        loop {
            let v = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }

    fn world() -> World {
        let json = r#"{
            "camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
            "materials": {"d": {"type": "diffuse", "albedo": 0.5}},
            "objects": [
                {"name": "floor", "shape": {"type": "plane", "size": [4, 4]}, "material": "d"},
                {"name": "ball", "shape": {"type": "sphere", "radius": 0.5, "segments": 64},
                 "material": "d", "transform": {"translation": [0, 1, 0]}}
            ]}"#;
        world_of(json)
    }

    #[test]
    fn hits_sphere_then_floor() {
        let a = Accel::build(&world());
        let h = a
            .intersect(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y, f32::INFINITY)
            .unwrap();
        assert!((h.t - 1.5).abs() < 1e-3, "{}", h.t);
        assert!(h.front_face && h.normal.y > 0.999 && h.object == 1);
        assert!((h.point.y - 1.5).abs() < 1e-3);
        // From inside the sphere: back face, normal flipped towards the ray.
        let h = a
            .intersect(Vec3::new(0.0, 1.0, 0.0), Vec3::NEG_Y, f32::INFINITY)
            .unwrap();
        assert!(!h.front_face && h.normal.y > 0.99 && (h.t - 0.5).abs() < 1e-3);
        // Beside the sphere straight onto the floor.
        let h = a
            .intersect(Vec3::new(1.5, 3.0, 0.2), Vec3::NEG_Y, f32::INFINITY)
            .unwrap();
        assert_eq!(h.object, 0);
        assert!((h.point - Vec3::new(1.5, 0.0, 0.2)).length() < 1e-4);
    }

    #[test]
    fn smooth_normals_match_the_sphere() {
        let a = Accel::build(&world());
        let o = Vec3::new(0.3, 3.0, 0.1);
        let h = a.intersect(o, Vec3::NEG_Y, f32::INFINITY).unwrap();
        let exact = (h.point - Vec3::Y).normalize();
        assert!(h.normal.dot(exact) > 0.9995, "{:?} vs {exact:?}", h.normal);
    }

    #[test]
    fn negative_zero_directions_hit() {
        let a = Accel::build(&world());
        let o = Vec3::new(2.0, 3.0, 0.0);
        let d = (Vec3::Y - o).normalize();
        let d = Vec3::new(d.x, d.y, -0.0);
        assert_eq!(a.intersect(o, d, f32::INFINITY).map(|h| h.object), Some(1));
        assert!(a.occluded(o, d, f32::INFINITY));
    }

    #[test]
    fn occlusion_respects_tmax() {
        let a = Accel::build(&world());
        let o = Vec3::new(0.0, 3.0, 0.0);
        assert!(a.occluded(o, Vec3::NEG_Y, 10.0));
        assert!(!a.occluded(o, Vec3::NEG_Y, 1.4));
        assert!(!a.occluded(o, Vec3::Y, 10.0));
    }

    #[test]
    fn convex_solids_are_told_from_the_rest() {
        let json = r#"{
            "camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
            "materials": {"d": {"type": "dielectric", "ior": 1.5}},
            "objects": [
                {"name": "ball", "shape": {"type": "sphere", "radius": 0.5, "segments": 96},
                 "material": "d"},
                {"name": "inside-out", "shape": {"type": "sphere", "radius": 0.5, "segments": 24},
                 "material": "d", "transform": {"scale": [1, -1, 1]}},
                {"name": "box", "shape": {"type": "box", "size": [0.4, 0.7, 0.3]}, "material": "d"},
                {"name": "can", "shape": {"type": "cylinder", "radius": 0.3, "height": 0.8,
                 "segments": 40}, "material": "d"},
                {"name": "ring", "shape": {"type": "torus", "major_radius": 0.5,
                 "minor_radius": 0.2, "segments": 48}, "material": "d"},
                {"name": "sheet", "shape": {"type": "plane", "size": [1, 1]}, "material": "d"},
                {"name": "pair", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "d"},
                {"name": "pair2", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]}, "material": "d",
                 "transform": {"translation": [1, 0, 0]}}
            ]}"#;
        let world = world_of(json);
        let only = |names: &[&str]| {
            Accel::build_with(
                &world,
                |i| names.contains(&world.objects[i].name.as_str()),
                BvhBuildParams::fast_build(),
            )
        };
        for name in ["ball", "inside-out", "box", "can"] {
            let accel = only(&[name]);
            let sign = accel.convex_orientation();
            assert!(sign.is_some(), "{name} is convex");
            // The property the CSL trace relies on: a ray leaving through a triangle (along
            // its outward normal's side) meets nothing more.
            let mut rng = crate::sampling::Pcg::new(21, 4);
            let (mut left, mut guessed) = (0, 0);
            for _ in 0..3000 {
                let mut unit = || {
                    (Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0).normalize_or(Vec3::Y)
                };
                let (from, towards) = (unit() * 3.0, unit() * 0.1);
                let Some(hit) = accel.intersect(from, (towards - from).normalize(), 10.0) else {
                    continue;
                };
                let winding = if hit.front_face {
                    hit.geo_normal
                } else {
                    -hit.geo_normal
                };
                let out = winding * sign.unwrap();
                let mut d = unit();
                if d.dot(out) <= 0.0 {
                    d = -d;
                }
                if d.dot(out) < 1e-3 {
                    continue;
                }
                assert!(
                    accel.intersect(hit.spawn(d), d, 10.0).is_none(),
                    "{name}: a ray leaving at {:?} along {d:?} hit again",
                    hit.point
                );
                left += 1;
                // And one going in meets exactly one triangle, where it leaves: the triangle
                // a neighbouring ray left through, where this one hits it at all, is where
                // the BVH finds this one's hit (the CSL trace's exit guesses).
                let din = -d;
                let o = hit.spawn(din);
                let (id, _) = accel.intersect_prim(o, din, 10.0).expect("it leaves");
                let d2 = (din + unit() * 0.05).normalize();
                if let Some(g) = accel.triangle_hit(id, o, d2, f32::INFINITY) {
                    let want = accel.intersect(o, d2, 10.0).expect("it leaves");
                    assert!(
                        (g.t - want.t).abs() <= 1e-5 * want.t
                            && g.point.distance(want.point) < 1e-5,
                        "{name}: {} vs {}",
                        g.t,
                        want.t
                    );
                    guessed += 1;
                }
            }
            assert!(left > 1000, "{name}: {left}");
            assert!(guessed > 100, "{name}: {guessed}");
        }
        // The mirrored sphere is wound the other way round.
        assert_eq!(
            only(&["ball"]).convex_orientation(),
            only(&["inside-out"]).convex_orientation()
        );
        for names in [
            &["ring"][..],
            &["sheet"],
            &["pair", "pair2"],
            &["ball", "box"],
        ] {
            assert_eq!(only(names).convex_orientation(), None, "{names:?}");
        }
    }

    /// The decoded eight-wide tree finds what obvhs's traversal of the CWBVH finds: the same
    /// closest distance, the same triangle (or another at exactly that distance), and the same
    /// occlusion, for rays from outside and from the surfaces (as a bake spawns them), in every
    /// octant, along axes and with signed zeros, and with finite ranges.
    #[test]
    fn the_wide_tree_agrees_with_obvhs() {
        use crate::sampling::Pcg;
        let teapot = crate::scene::load_scene_file(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-teapot.json"),
            &Default::default(),
        )
        .unwrap();
        for (name, world) in [("sphere and floor", world()), ("teapot scene", teapot)] {
            let a = Accel::build(&world);
            let wide = a.wide.as_ref().expect("a wide tree");
            let (lo, hi) = world.bounds();
            let mut rng = Pcg::new(11, 5);
            let (mut hits, mut ties, mut blocked) = (0, 0, 0);
            for k in 0..60_000 {
                let mut d = random_unit(&mut rng);
                let o = match k % 3 {
                    // From outside the bounds, towards a point inside them.
                    0 => {
                        let p = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                        p - d * (hi - lo).length()
                    }
                    // From a surface point, spawned as a bake does.
                    _ => {
                        let p = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                        match a.intersect(p - d * 10.0, d, f32::INFINITY) {
                            Some(h) => {
                                d = random_unit(&mut rng);
                                h.spawn(d)
                            }
                            None => p,
                        }
                    }
                };
                if k % 50 == 0 {
                    // Along an axis, with signed zeros.
                    let axis = (k / 50) % 3;
                    d = Vec3::ZERO;
                    d[axis] = if k % 100 == 0 { 1.0 } else { -1.0 };
                    d[(axis + 1) % 3] = -0.0;
                }
                let tmax = if k % 7 == 0 {
                    rng.f32() * (hi - lo).length()
                } else {
                    f32::INFINITY
                };
                let ray = make_ray(o, d, tmax);
                let mut hit = RayHit::none();
                let theirs = a
                    .bvh
                    .ray_traverse(ray, &mut hit, |r, id| tri_t(&a.tris[id], r))
                    .then_some((hit.primitive_id, hit.t));
                let ours = wide.closest(&ray);
                // The portable slab tests give the same as the AVX ones.
                let portable = wide.closest_in::<false>(&ray);
                assert_eq!(ours, portable, "{name}: ray {k}");
                match (ours, theirs) {
                    (Some((p, t)), Some((q, u))) => {
                        assert_eq!(t.to_bits(), u.to_bits(), "{name}: ray {k} distance");
                        if p != q {
                            assert_eq!(tri_t(&a.tris[p as usize], &ray), u, "{name}: ray {k}");
                            ties += 1;
                        }
                        hits += 1;
                    }
                    (None, None) => {}
                    _ => panic!("{name}: ray {k}: {ours:?} against obvhs's {theirs:?}"),
                }
                let occluded = wide.any(&ray);
                let miss = a.bvh.ray_traverse_miss(ray, |r, id| tri_t(&a.tris[id], r));
                assert_eq!(occluded, !miss, "{name}: ray {k} occlusion");
                let portable = wide.any_in::<false>(&ray);
                assert_eq!(occluded, portable, "{name}: ray {k} occlusion");
                blocked += occluded as u32;
            }
            // A ray with a NaN component (passes every slab test) ends, hitting nothing.
            for bad in [Vec3::new(f32::NAN, 0.0, 0.0), Vec3::NAN] {
                // Built by hand: `Ray::new` asserts a finite origin in debug builds.
                let ray = Ray {
                    origin: bad.into(),
                    ..make_ray(Vec3::ZERO, Vec3::Y, f32::INFINITY)
                };
                assert_eq!(wide.closest(&ray), None);
                assert_eq!(wide.closest_in::<false>(&ray), None);
                assert!(!wide.any(&ray) && !wide.any_in::<false>(&ray));
            }
            // Enough of each kind that the comparison means something.
            eprintln!("{name}: {hits} hits, {ties} ties, {blocked} blocked");
            assert!(hits > 10_000 && blocked > 10_000, "{name}: {hits} hits");
            assert!(ties < 60, "{name}: {ties} ties");
        }
    }

    /// Rays traced eight to a packet find what each finds alone: the same triangle (also
    /// where two lie at exactly one distance: thousands of rays down a cube's face diagonals
    /// and the seams between touching cubes, counted) and the same distance bit for bit, for
    /// coherent packets (neighbouring rays from a surface, as a bake's waves form them),
    /// incoherent ones and partial ones, with the AVX and the portable slab tests alike.
    #[test]
    fn packets_find_what_single_rays_find() {
        use crate::sampling::Pcg;
        let teapot = crate::scene::load_scene_file(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/glass-teapot.json"),
            &Default::default(),
        )
        .unwrap();
        let cube = resolve(
            &parse_scene(
                br#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
                     "materials": {"d": {"type": "diffuse", "albedo": 0.5}},
                     "objects": [{"name": "box", "shape": {"type": "box",
                                  "size": [0.4, 0.4, 0.4]}, "material": "d"}]}"#,
            )
            .unwrap(),
            &MapSource::default(),
            &Default::default(),
        )
        .unwrap();
        // Sixteen cubes side by side, touching (their corners exact in binary): a ray down
        // through a seam meets the tops of two at exactly one distance, in different leaves.
        let boxes: Vec<String> = (0..16)
            .map(|k| {
                format!(
                    r#"{{"name": "b{k}", "shape": {{"type": "box", "size": [0.5, 0.5, 0.5]}},
                        "material": "d", "transform": {{"translation": [{}, 0, 0]}}}}"#,
                    0.5 * k as f32
                )
            })
            .collect();
        let row = resolve(
            &parse_scene(
                format!(
                    r#"{{"camera": {{"eye": [0, 3, 3], "target": [0, 0, 0]}},
                         "materials": {{"d": {{"type": "diffuse", "albedo": 0.5}}}},
                         "objects": [{}]}}"#,
                    boxes.join(",")
                )
                .as_bytes(),
            )
            .unwrap(),
            &MapSource::default(),
            &Default::default(),
        )
        .unwrap();
        for (name, world) in [
            ("sphere and floor", world()),
            ("teapot scene", teapot),
            ("cube", cube),
            ("row of cubes", row),
        ] {
            let a = Accel::build(&world);
            let wide = a.wide.as_ref().expect("a wide tree");
            let (lo, hi) = world.bounds();
            let size = (hi - lo).length();
            let mut rng = Pcg::new(5, 9);
            let (mut hits, mut rays, mut ties) = (0, 0, 0);
            for k in 0..6000 {
                let n = if k % 5 == 0 { 1 + k % 8 } else { 8 };
                let mut packet = Vec::with_capacity(n);
                match k % 4 {
                    // Down through the seams between cubes, with rays along the row.
                    0 | 1 if name == "row of cubes" => {
                        for r in 0..n {
                            if r % 2 == 0 {
                                // A seam near the end the other rays come from.
                                let seam = (rng.f32() * 3.0).floor();
                                let seam = if k % 8 == 0 { seam } else { 14.0 - seam };
                                let x = 0.25 + 0.5 * seam;
                                let o = Vec3::new(x, 2.0, 0.4 * rng.f32() - 0.2);
                                packet.push((o, Vec3::NEG_Y));
                            } else {
                                // Along the row, from one end or the other: the packet then
                                // meets the cubes nearest that end first.
                                let z = 0.4 * rng.f32() - 0.2;
                                packet.push(if k % 8 == 0 {
                                    (Vec3::new(-0.3, 0.0, z), Vec3::X)
                                } else {
                                    (Vec3::new(7.8, 0.0, z), Vec3::NEG_X)
                                });
                            }
                        }
                    }
                    // Through the cube's face diagonals and edges, and the sphere's poles.
                    0 => {
                        let axis = k % 3;
                        let mut d = Vec3::ZERO;
                        d[axis] = if k % 8 < 4 { 1.0 } else { -1.0 };
                        for r in 0..n {
                            let mut o = 0.5 * (lo + hi) - d * size;
                            let s = (r as f32 - 4.0) * 0.02 * size;
                            o[(axis + 1) % 3] += s;
                            o[(axis + 2) % 3] += if k % 3 == 1 { 0.2 } else { s };
                            packet.push((o, d));
                        }
                    }
                    // Incoherent: anywhere, any way.
                    1 => {
                        for _ in 0..n {
                            let p = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                            let d = random_unit(&mut rng);
                            packet.push((p - d * size, d));
                        }
                    }
                    // Coherent: neighbours leaving a surface the same way, as a wave's.
                    _ => {
                        let p = lo + (hi - lo) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                        let d0 = random_unit(&mut rng);
                        let Some(h) = a.intersect(p - d0 * size, d0, f32::INFINITY) else {
                            continue;
                        };
                        let d1 = random_unit(&mut rng);
                        for r in 0..n {
                            let jitter = 1e-3 * r as f32;
                            let d = (d1 + jitter * random_unit(&mut rng)).normalize();
                            let o = h.point + (hi - lo) * jitter * random_unit(&mut rng);
                            let Some(h) = a.intersect(o - d0 * size, d0, f32::INFINITY) else {
                                continue;
                            };
                            packet.push((h.spawn(d), d));
                        }
                    }
                }
                if packet.is_empty() {
                    continue;
                }
                let mut got = vec![None; packet.len()];
                a.intersect_packet(&packet, &mut got);
                let made: Vec<Ray> = packet
                    .iter()
                    .map(|&(o, d)| make_ray(o, d, f32::INFINITY))
                    .collect();
                let mut portable = vec![None; packet.len()];
                wide.closest_packet_in::<false>(&made, &mut portable);
                for (r, &(o, d)) in packet.iter().enumerate() {
                    let want = a.intersect_prim(o, d, f32::INFINITY);
                    let key = |h: &Option<(usize, Hit)>| h.map(|(p, h)| (p, h.t.to_bits()));
                    assert_eq!(key(&got[r]), key(&want), "{name}: packet {k}, ray {r}");
                    assert_eq!(
                        portable[r],
                        want.map(|(p, h)| (p as u32, h.t)),
                        "{name}: packet {k}, ray {r} (portable)"
                    );
                    hits += want.is_some() as u32;
                    rays += 1;
                    // Ties: another triangle at exactly that distance (counted on the small
                    // meshes).
                    if let Some((_, h)) = want.filter(|_| a.tris.len() < 500) {
                        let ray = make_ray(o, d, f32::INFINITY);
                        ties +=
                            (a.tris.iter().filter(|t| tri_t(t, &ray) == h.t).count() > 1) as u32;
                    }
                }
            }
            eprintln!("{name}: {rays} rays, {hits} hits, {ties} ties");
            assert!(hits > 10_000, "{name}: {hits} hits");
            if name.contains("cube") {
                assert!(ties > 1000, "{name}: {ties} ties");
            }
        }
    }
}
