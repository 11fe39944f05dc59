//! Occluders of caustic light for the GPU: a small bounding volume hierarchy over every
//! triangle of the scene *except* the caustic objects (whose own surfaces are where the caustic
//! rays come from), flattened into two storage buffers that `shaders/occlusion.inc.wgsl`
//! traverses with one shadow ray per caustic arrival. It is the GPU twin of the CPU
//! evaluation's `blockers` acceleration structure (`render::csl::eval::render_caustics`), so both
//! answer the same question: is anything between the receiver and the light plane along the
//! arriving ray?
//!
//! The tree is built by median splits on the longest axis of the centroid bounds, at most
//! [`LEAF_SIZE`] triangles per leaf, children stored next to each other (right = left + 1).
//! Occluders are usually few (a floor, a table, a blocker box), so build quality matters less
//! than a build that is O(n log n), deterministic and needs no dependency.

use crate::scene::World;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Most triangles in a leaf.
pub const LEAF_SIZE: usize = 4;
/// Entries of the traversal stack in `shaders/occlusion.inc.wgsl` (`BVH_STACK`).
pub const STACK_DEPTH: usize = 48;

/// `BvhNode` of occlusion.inc.wgsl (layout checked in `render::shaders`). `count == 0`: inner node whose children are
/// `first` and `first + 1`; otherwise a leaf of `count` triangles from index `first`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuBvhNode {
    pub lo: [f32; 3],
    pub first: u32,
    pub hi: [f32; 3],
    pub count: u32,
}

/// `BlockerTri` of occlusion.inc.wgsl: v0 and the two edges (layout checked in
/// `render::shaders`); `v0[3]` is the triangle's material index as a float (exact below 2²⁴),
/// for passes that shade what a ray finds.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuTriangle {
    pub v0: [f32; 4],
    pub e1: [f32; 4],
    pub e2: [f32; 4],
}

/// The flattened hierarchy. Never empty: with no occluder it holds one leaf with a degenerate
/// triangle (zero edges, which no ray hits), so the bindings stay valid.
#[derive(Clone, Debug, Default)]
pub struct Blockers {
    pub nodes: Vec<GpuBvhNode>,
    pub triangles: Vec<GpuTriangle>,
    /// For each of `triangles`, its index in the list the tree was built from (empty for the
    /// placeholder).
    pub source: Vec<u32>,
}

impl Blockers {
    /// Every triangle of `world` whose object index `keep` accepts, in world space.
    pub fn build(world: &World, keep: impl Fn(usize) -> bool) -> Blockers {
        let mut tris = Vec::new();
        let mut materials = Vec::new();
        for (oi, o) in world.objects.iter().enumerate() {
            if !keep(oi) {
                continue;
            }
            for p in &o.parts {
                let pos: Vec<Vec3> = p
                    .mesh
                    .positions
                    .iter()
                    .map(|v| o.transform.transform_point3(*v))
                    .collect();
                for t in &p.mesh.indices {
                    tris.push([pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]]);
                    materials.push(p.material);
                }
            }
        }
        Self::from_tagged(&tris, &materials)
    }

    /// Untagged triangles (material 0).
    pub fn from_triangles(tris: &[[Vec3; 3]]) -> Blockers {
        Self::from_tagged(tris, &vec![0; tris.len()])
    }

    /// Triangles and their material indices.
    pub fn from_tagged(tris: &[[Vec3; 3]], materials: &[u32]) -> Blockers {
        assert_eq!(tris.len(), materials.len(), "one material a triangle");
        let empty = GpuBvhNode {
            lo: [1.0; 3],
            first: 0,
            hi: [-1.0; 3],
            count: 0,
        };
        if tris.is_empty() {
            return Blockers {
                nodes: vec![GpuBvhNode {
                    lo: [0.0; 3],
                    first: 0,
                    hi: [0.0; 3],
                    count: 1,
                }],
                triangles: vec![GpuTriangle::zeroed()],
                source: Vec::new(),
            };
        }
        let centroid = |t: &[Vec3; 3]| (t[0] + t[1] + t[2]) / 3.0;
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = vec![empty];
        // (node index, range start, range end)
        let mut stack = vec![(0usize, 0usize, tris.len())];
        while let Some((ni, s, e)) = stack.pop() {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            let (mut clo, mut chi) = (lo, hi);
            for &i in &order[s..e] {
                let t = &tris[i as usize];
                for v in t {
                    lo = lo.min(*v);
                    hi = hi.max(*v);
                }
                let c = centroid(t);
                clo = clo.min(c);
                chi = chi.max(c);
            }
            nodes[ni].lo = lo.to_array();
            nodes[ni].hi = hi.to_array();
            let ext = chi - clo;
            if e - s <= LEAF_SIZE || ext.max_element() <= 0.0 {
                nodes[ni].first = s as u32;
                nodes[ni].count = (e - s) as u32;
                continue;
            }
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = (s + e) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                let (ca, cb) = (
                    centroid(&tris[a as usize])[axis],
                    centroid(&tris[b as usize])[axis],
                );
                ca.total_cmp(&cb).then(a.cmp(&b))
            });
            let left = nodes.len();
            nodes.push(empty);
            nodes.push(empty);
            nodes[ni].first = left as u32;
            nodes[ni].count = 0;
            stack.push((left + 1, mid, e));
            stack.push((left, s, mid));
        }
        Blockers {
            nodes,
            triangles: packed(tris, materials, &order),
            source: order,
        }
    }

    /// The same layout from obvhs's binary tree (PLOC with SAH-driven collapsing, whose inner
    /// nodes keep their two children side by side as here; leaves of at most 4 triangles), for
    /// passes that follow many rays through large meshes (method photons). The median split
    /// stands in when the tree is deeper than the shaders' traversal stack.
    pub fn from_tagged_sah(tris: &[[Vec3; 3]], materials: &[u32]) -> Blockers {
        use obvhs::BvhBuildParams;
        use obvhs::bvh2::builder::build_bvh2_from_tris;
        use obvhs::triangle::Triangle;
        if tris.len() < 2 {
            return Self::from_tagged(tris, materials);
        }
        let input: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect();
        let params = BvhBuildParams {
            max_prims_per_leaf: 4,
            ..BvhBuildParams::medium_build()
        };
        let bvh = build_bvh2_from_tris(&input, params, &mut std::time::Duration::default());
        // Depth of the deepest leaf; the shader's stack holds about one node a level.
        let mut deepest = 0usize;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((ni, depth)) = stack.pop() {
            let n = &bvh.nodes[ni];
            deepest = deepest.max(depth);
            if n.prim_count == 0 {
                stack.push((n.first_index as usize, depth + 1));
                stack.push((n.first_index as usize + 1, depth + 1));
            }
        }
        if bvh.nodes.is_empty() || deepest + 2 > STACK_DEPTH {
            return Self::from_tagged(tris, materials);
        }
        let nodes = bvh
            .nodes
            .iter()
            .map(|n| GpuBvhNode {
                lo: Vec3::from(n.aabb.min).to_array(),
                first: n.first_index,
                hi: Vec3::from(n.aabb.max).to_array(),
                count: n.prim_count,
            })
            .collect();
        Blockers {
            nodes,
            triangles: packed(tris, materials, &bvh.primitive_indices),
            source: bvh.primitive_indices,
        }
    }

    /// CPU traversal of the flattened tree, exactly as the shader does it: whether a triangle
    /// lies on the segment `origin + t·dir`, `0 < t < t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let inv = dir.recip();
        let mut stack = vec![0u32];
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni as usize];
            if !slab(Vec3::from(n.lo), Vec3::from(n.hi), origin, inv, t_max) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
                continue;
            }
            for t in &self.triangles[n.first as usize..(n.first + n.count) as usize] {
                let v0 = Vec3::from_slice(&t.v0);
                let e1 = Vec3::from_slice(&t.e1);
                let e2 = Vec3::from_slice(&t.e2);
                if let Some(d) = moller_trumbore(origin, dir, v0, e1, e2)
                    && d > 0.0
                    && d < t_max
                {
                    return true;
                }
            }
        }
        false
    }
}

/// The triangles in the tree's `order`, as the shaders read them: v0 with the material index,
/// and the two edges.
fn packed(tris: &[[Vec3; 3]], materials: &[u32], order: &[u32]) -> Vec<GpuTriangle> {
    order
        .iter()
        .map(|&i| {
            let [a, b, c] = tris[i as usize];
            GpuTriangle {
                v0: a.extend(materials[i as usize] as f32).to_array(),
                e1: (b - a).extend(0.0).to_array(),
                e2: (c - a).extend(0.0).to_array(),
            }
        })
        .collect()
}

fn slab(lo: Vec3, hi: Vec3, o: Vec3, inv: Vec3, t_max: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let tn = t0.min(t1).max_element().max(0.0);
    let tf = t0.max(t1).min_element().min(t_max);
    tn <= tf
}

/// How far outside a triangle, in barycentric units, a hit still counts (the shader's too).
const EDGE_SLACK: f32 = 1e-5;

fn moller_trumbore(o: Vec3, d: Vec3, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<f32> {
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v0;
    // Edges are widened by EDGE_SLACK (in barycentric units) so that a ray through the
    // shared edge of two triangles meets at least one of them.
    let u = s.dot(p) * inv;
    if !(-EDGE_SLACK..=1.0 + EDGE_SLACK).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return None;
    }
    Some(e2.dot(q) * inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flattened tree answers like a brute-force test over all triangles.
    #[test]
    fn traversal_matches_brute_force() {
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut tris = Vec::new();
        for _ in 0..300 {
            let c = Vec3::new(next(), next(), next()) * 4.0 - 2.0;
            let a = c + Vec3::new(next(), next(), next()) * 0.3;
            let b = c + Vec3::new(next(), next(), next()) * 0.3;
            tris.push([c, a, b]);
        }
        let bvh = Blockers::from_triangles(&tris);
        assert!(bvh.nodes.len() > 100);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(next(), next(), next()) * 6.0 - 3.0;
            let d = (Vec3::new(next(), next(), next()) - 0.5).normalize();
            let t_max = next() * 6.0;
            let brute = tris.iter().any(|t| {
                moller_trumbore(o, d, t[0], t[1] - t[0], t[2] - t[0])
                    .is_some_and(|x| x > 0.0 && x < t_max)
            });
            hits += brute as u32;
            assert_eq!(bvh.occluded(o, d, t_max), brute, "ray {o} {d} {t_max}");
        }
        assert!(hits > 50, "the test should see hits ({hits})");
    }

    /// obvhs's tree, flattened the same way, answers like brute force too, on a sphere mesh
    /// (whose rays all come from outside it) and on random triangles.
    #[test]
    fn the_sah_tree_matches_brute_force() {
        let m = crate::scene::shapes::sphere(0.5, 64);
        let sphere: Vec<[Vec3; 3]> = m
            .indices
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect();
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let bvh = Blockers::from_tagged_sah(&sphere, &vec![0; sphere.len()]);
        assert!(bvh.nodes.len() > 100);
        let mut source = bvh.source.clone();
        source.sort_unstable();
        source.dedup();
        assert_eq!(source.len(), sphere.len(), "every triangle is in the tree");
        let mut hits = 0;
        for _ in 0..4000 {
            let o = Vec3::new(next(), next(), next()) * 3.0 - 1.5;
            let d = (Vec3::new(next(), next(), next()) - 0.5).normalize();
            let t_max = next() * 3.0;
            let brute = sphere.iter().any(|t| {
                moller_trumbore(o, d, t[0], t[1] - t[0], t[2] - t[0])
                    .is_some_and(|x| x > 0.0 && x < t_max)
            });
            hits += brute as u32;
            assert_eq!(bvh.occluded(o, d, t_max), brute, "ray {o} {d} {t_max}");
        }
        assert!(hits > 100, "the test should see hits ({hits})");
    }

    #[test]
    fn empty_scene_blocks_nothing() {
        let bvh = Blockers::from_triangles(&[]);
        assert!(!bvh.occluded(Vec3::ZERO, Vec3::Y, 10.0));
    }
}
