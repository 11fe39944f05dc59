//! An eight-wide BVH with uncompressed f32 child boxes, for CPU traversal.
//!
//! obvhs's CWBVH is laid out for GPUs: its child boxes are quantised to bytes, and its
//! traversal decodes them one lane at a time and keeps a GPU-style node-group stack. This is the
//! same tree (the same nodes, children and leaves), with each child box decoded once at build
//! time to f32 and widened outwards by one unit in the last place, stored axis by axis so that
//! one node's eight slab tests are a handful of eight-lane instructions. Traversal is
//! front-to-back: the children a ray meets are visited nearest first, and a child whose entry
//! distance lies beyond the closest hit so far is skipped.
//!
//! The closest hit is the same triangle and distance as obvhs's traversal gives, except where
//! two triangles lie at exactly the same distance (a ray through a shared edge), where the
//! visiting order picks one of them.

use obvhs::{cwbvh::CwBvh, ray::Ray};

/// Set in [`Node::child`] for a leaf: then bits 2.. are the first primitive and bits 0..2 the
/// count (1 to 3).
const LEAF: u32 = 0x8000_0000;

/// Entries the traversal stack holds; a tree whose depth could need more is left to obvhs.
const STACK: usize = 192;

/// One node: the boxes of its eight children, axis by axis (an empty slot has lo = +∞ and
/// hi = −∞, which no ray meets), and what each child is.
#[repr(C, align(32))]
#[derive(Clone, Copy)]
struct Node {
    lo: [[f32; 8]; 3],
    hi: [[f32; 8]; 3],
    /// An inner child's node index, or [`LEAF`] with a primitive range.
    child: [u32; 8],
}

/// The tree. Primitive indices are those of the CWBVH (`primitive_id`s, indexing its
/// `primitive_indices`).
pub(crate) struct WideBvh {
    nodes: Vec<Node>,
    /// Whether the processor has AVX2, for the eight-lane slab tests.
    avx2: bool,
}

impl WideBvh {
    /// The CWBVH's tree with its boxes decoded, or None when the tree is empty or deep enough
    /// that the traversal stack could overflow.
    pub(crate) fn from_cwbvh(bvh: &CwBvh) -> Option<WideBvh> {
        if bvh.nodes.is_empty() {
            return None;
        }
        let mut nodes = Vec::with_capacity(bvh.nodes.len());
        for n in &bvh.nodes {
            let ext = n.compute_extent();
            let mut node = Node {
                lo: [[f32::INFINITY; 8]; 3],
                hi: [[f32::NEG_INFINITY; 8]; 3],
                child: [0; 8],
            };
            for slot in 0..8 {
                if n.is_child_empty(slot) {
                    continue;
                }
                let q_lo = [
                    n.child_min_x[slot],
                    n.child_min_y[slot],
                    n.child_min_z[slot],
                ];
                let q_hi = [
                    n.child_max_x[slot],
                    n.child_max_y[slot],
                    n.child_max_z[slot],
                ];
                for a in 0..3 {
                    node.lo[a][slot] = (n.p[a] + q_lo[a] as f32 * ext[a]).next_down();
                    node.hi[a][slot] = (n.p[a] + q_hi[a] as f32 * ext[a]).next_up();
                }
                node.child[slot] = if n.is_leaf(slot) {
                    let (first, count) = n.child_primitives(slot);
                    if first >= 1 << 29 || !(1..=3).contains(&count) {
                        return None;
                    }
                    LEAF | first << 2 | count
                } else {
                    let c = n.child_node_index(slot);
                    if c as usize >= bvh.nodes.len() {
                        return None;
                    }
                    c
                };
            }
            nodes.push(node);
        }
        // The stack holds at most seven entries a level (a node pushes all but one of the
        // children it visits), plus one.
        let mut depth = vec![0u32; nodes.len()];
        let mut deepest = 1;
        let mut todo = vec![(0usize, 1u32)];
        while let Some((i, d)) = todo.pop() {
            if depth[i] != 0 {
                return None; // not a tree
            }
            depth[i] = d;
            deepest = deepest.max(d);
            for &c in &nodes[i].child {
                if c & LEAF == 0 && c != 0 {
                    todo.push((c as usize, d + 1));
                }
            }
        }
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        (7 * (deepest as usize) < STACK).then_some(WideBvh { nodes, avx2 })
    }

    /// The closest primitive along `ray` for which `tri(primitive, ray)` gives a distance below
    /// `ray.tmax`, with that distance.
    #[inline]
    pub(crate) fn closest(
        &self,
        ray: &Ray,
        tri: impl FnMut(usize, &Ray) -> f32,
    ) -> Option<(u32, f32)> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the processor has AVX2 (checked when the tree was built).
            return unsafe { self.closest_avx2(ray, tri) };
        }
        self.closest_in::<false>(ray, tri)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn closest_avx2(&self, ray: &Ray, tri: impl FnMut(usize, &Ray) -> f32) -> Option<(u32, f32)> {
        self.closest_in::<true>(ray, tri)
    }

    #[inline(always)]
    pub(super) fn closest_in<const AVX: bool>(
        &self,
        ray: &Ray,
        mut tri: impl FnMut(usize, &Ray) -> f32,
    ) -> Option<(u32, f32)> {
        let mut r = *ray;
        let mut best = None;
        self.walk::<true, AVX>(&mut r, |p, r| {
            let t = tri(p as usize, r);
            if t < r.tmax {
                r.tmax = t;
                best = Some((p, t));
            }
            false
        });
        best
    }

    /// Whether any primitive along `ray` gives `tri(primitive, ray) < ray.tmax`.
    #[inline]
    pub(crate) fn any(&self, ray: &Ray, tri: impl FnMut(usize, &Ray) -> f32) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the processor has AVX2 (checked when the tree was built).
            return unsafe { self.any_avx2(ray, tri) };
        }
        self.any_in::<false>(ray, tri)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn any_avx2(&self, ray: &Ray, tri: impl FnMut(usize, &Ray) -> f32) -> bool {
        self.any_in::<true>(ray, tri)
    }

    #[inline(always)]
    pub(super) fn any_in<const AVX: bool>(
        &self,
        ray: &Ray,
        mut tri: impl FnMut(usize, &Ray) -> f32,
    ) -> bool {
        let mut r = *ray;
        let mut found = false;
        self.walk::<false, AVX>(&mut r, |p, r| {
            found = tri(p as usize, r) < r.tmax;
            found
        });
        found
    }

    /// Visit the leaves `ray` meets, handing each primitive to `prim`, which may shorten
    /// `ray.tmax` and returns true to stop. With `ORDERED` the inner children a node's ray
    /// meets are visited nearest first.
    #[inline(always)]
    fn walk<const ORDERED: bool, const AVX: bool>(
        &self,
        ray: &mut Ray,
        mut prim: impl FnMut(u32, &mut Ray) -> bool,
    ) {
        let test = SlabRay::new(ray);
        let mut stack = [std::mem::MaybeUninit::<(u32, f32)>::uninit(); STACK];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            let node = &self.nodes[cur as usize];
            let (mut mask, tnear) = test.node::<AVX>(node, ray.tmax);
            let mut inner = [(0f32, 0u32); 8];
            let mut k = 0;
            while mask != 0 {
                let slot = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let c = node.child[slot];
                if c & LEAF != 0 {
                    let first = (c & !LEAF) >> 2;
                    for p in first..first + (c & 3) {
                        if prim(p, ray) {
                            return;
                        }
                    }
                } else {
                    inner[k] = (tnear[slot], c);
                    k += 1;
                }
            }
            if ORDERED && k > 1 {
                // Insertion sort, farthest first, so that the nearest is taken next and the
                // rest are pushed far to near.
                for i in 1..k {
                    let e = inner[i];
                    let mut j = i;
                    while j > 0 && inner[j - 1].0 < e.0 {
                        inner[j] = inner[j - 1];
                        j -= 1;
                    }
                    inner[j] = e;
                }
            }
            if k > 0 {
                for &(t, c) in &inner[..k - 1] {
                    stack[sp].write((c, t));
                    sp += 1;
                }
                let (t, c) = inner[k - 1];
                if t <= ray.tmax {
                    cur = c;
                    continue;
                }
            }
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written.
                let (c, t) = unsafe { stack[sp].assume_init() };
                if t <= ray.tmax {
                    cur = c;
                    break;
                }
            }
        }
    }
}

/// A ray prepared for slab tests: its origin, the reciprocal of its direction (obvhs's, with
/// components near zero clamped), and for each axis whether it runs towards −.
struct SlabRay {
    o: [f32; 3],
    inv: [f32; 3],
    neg: [bool; 3],
    tmin: f32,
}

impl SlabRay {
    #[inline(always)]
    fn new(ray: &Ray) -> SlabRay {
        SlabRay {
            o: ray.origin.to_array(),
            inv: ray.inv_direction.to_array(),
            neg: [0, 1, 2].map(|a| ray.inv_direction[a] < 0.0),
            tmin: ray.tmin,
        }
    }

    /// The children of `node` the ray meets within [tmin, tmax] (a bit per slot), and each
    /// slot's entry distance.
    #[inline(always)]
    fn node<const AVX: bool>(&self, node: &Node, tmax: f32) -> (u32, [f32; 8]) {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: AVX is only asked for from functions compiled with AVX2.
            return unsafe { self.node_avx(node, tmax) };
        }
        self.node_scalar(node, tmax)
    }

    #[inline(always)]
    fn node_scalar(&self, node: &Node, tmax: f32) -> (u32, [f32; 8]) {
        let mut tnear = [0f32; 8];
        let mut mask = 0;
        for (s, near) in tnear.iter_mut().enumerate() {
            let mut t0 = self.tmin;
            let mut t1 = tmax;
            for a in 0..3 {
                let (n, f) = if self.neg[a] {
                    (node.hi[a][s], node.lo[a][s])
                } else {
                    (node.lo[a][s], node.hi[a][s])
                };
                let tn = (n - self.o[a]) * self.inv[a];
                let tf = (f - self.o[a]) * self.inv[a];
                t0 = if tn > t0 { tn } else { t0 };
                t1 = if tf < t1 { tf } else { t1 };
            }
            *near = t0;
            mask |= ((t0 <= t1) as u32) << s;
        }
        (mask, tnear)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    fn node_avx(&self, node: &Node, tmax: f32) -> (u32, [f32; 8]) {
        use std::arch::x86_64::*;
        // SAFETY: the loads are of whole [f32; 8] rows, 32-byte aligned (`Node` is
        // `align(32)`).
        unsafe {
            let mut t0 = _mm256_set1_ps(self.tmin);
            let mut t1 = _mm256_set1_ps(tmax);
            for a in 0..3 {
                let (n, f) = if self.neg[a] {
                    (&node.hi[a], &node.lo[a])
                } else {
                    (&node.lo[a], &node.hi[a])
                };
                let o = _mm256_set1_ps(self.o[a]);
                let inv = _mm256_set1_ps(self.inv[a]);
                let tn = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.as_ptr()), o), inv);
                let tf = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(f.as_ptr()), o), inv);
                // max/min return the second operand when either is NaN; none arises here (the
                // reciprocals are finite and nonzero, the bounds finite or an empty slot's ±∞).
                t0 = _mm256_max_ps(tn, t0);
                t1 = _mm256_min_ps(tf, t1);
            }
            let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1);
            let mut tnear = [0f32; 8];
            _mm256_storeu_ps(tnear.as_mut_ptr(), t0);
            (_mm256_movemask_ps(hit) as u32, tnear)
        }
    }
}
