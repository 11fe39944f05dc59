//! An eight-wide BVH with uncompressed f32 child boxes and triangles stored eight to a block,
//! for CPU traversal.
//!
//! obvhs's CWBVH is laid out for GPUs: its child boxes are quantised to bytes, and its
//! traversal decodes them one lane at a time and keeps a GPU-style node-group stack. This is the
//! same tree (the same nodes, children and leaves), with each child box decoded once at build
//! time to f32 and widened outwards by one unit in the last place, stored axis by axis so that
//! one node's eight slab tests are a handful of eight-lane instructions. The triangles of a
//! node's leaves (at most 24, numbered from the node's first primitive) are stored in blocks of
//! eight, component by component, and the triangles of the leaves a ray meets are tested a
//! block at a time. Traversal is front-to-back: the inner children a ray meets are visited
//! nearest first, and a child whose entry distance lies beyond the closest hit so far is
//! skipped.
//!
//! A triangle's distance is computed with the same operations, in the same order, as
//! [`super::tri_t`], so it is the same number bit for bit. The closest hit is then the same
//! triangle and distance as obvhs's traversal gives, except where two triangles lie at exactly
//! the same distance (a ray through a shared edge): the visiting order picks one of them.

use super::simd;
use obvhs::{cwbvh::CwBvh, ray::Ray, rt_triangle::RtTriangle};

/// Set in [`Node::child`] for a leaf: then bit k (k < 24) is set for each of its triangles,
/// the k-th from the node's first.
const LEAF: u32 = 0x8000_0000;

/// [`WideBvh::closest_packet`] traces a ray again alone where another triangle lies within
/// this fraction of its nearest's distance (plus [`NEAR_ABS`] of the tree's extent): far above
/// the rounding of the slab and triangle tests, and rare (a ray through a shared edge or
/// vertex, or surfaces that nearly touch).
const NEAR_REL: f32 = 1e-4;
const NEAR_ABS: f32 = 1e-5;

/// Entries the traversal stack holds; a tree whose depth could need more is left to obvhs.
const STACK: usize = 192;

/// One node: the boxes of its eight children, axis by axis (an empty slot has lo = +∞ and
/// hi = −∞, which no ray meets), what each child is, and where its leaves' triangles are.
#[repr(C, align(32))]
#[derive(Clone, Copy)]
struct Node {
    lo: [[f32; 8]; 3],
    hi: [[f32; 8]; 3],
    /// An inner child's node index, or [`LEAF`] with the leaf's triangles.
    child: [u32; 8],
    /// The primitive index (obvhs's `primitive_id`) of the node's first triangle.
    first_prim: u32,
    /// The block of [`WideBvh::tris`] holding the node's first eight triangles; the next ones
    /// follow.
    first_block: u32,
    /// A bit per slot that holds a child (a ray with a NaN component passes every slab test).
    used: u32,
    /// A bit per slot that holds a leaf.
    leaves: u32,
}

/// Eight triangles, component by component: v0, e1 = v0 − v1, e2 = v2 − v0 and
/// ng = e1 × e2 (obvhs's `RtTriangle`). An unused lane has ng = 0, which no ray hits.
#[repr(C, align(32))]
#[derive(Clone, Copy, Default)]
struct TriBlock {
    v0: [[f32; 8]; 3],
    e1: [[f32; 8]; 3],
    e2: [[f32; 8]; 3],
    ng: [[f32; 8]; 3],
}

/// The tree. Primitive indices are those of the CWBVH (`primitive_id`s, indexing its
/// `primitive_indices`).
pub(crate) struct WideBvh {
    nodes: Vec<Node>,
    tris: Vec<TriBlock>,
    /// The absolute part of [`WideBvh::closest_packet`]'s margin: [`NEAR_ABS`] of the largest
    /// coordinate magnitude of the tree's bounds.
    near_abs: f32,
}

impl WideBvh {
    /// The CWBVH's tree with its boxes decoded, over `tris` (in the CWBVH's primitive order),
    /// or None when the tree is empty or deep enough that the traversal stack could overflow.
    pub(crate) fn from_cwbvh(bvh: &CwBvh, tris: &[RtTriangle]) -> Option<WideBvh> {
        if bvh.nodes.is_empty() {
            return None;
        }
        let mut nodes = Vec::with_capacity(bvh.nodes.len());
        let mut blocks: Vec<TriBlock> = Vec::new();
        for n in &bvh.nodes {
            let ext = n.compute_extent();
            let mut node = Node {
                lo: [[f32::INFINITY; 8]; 3],
                hi: [[f32::NEG_INFINITY; 8]; 3],
                child: [0; 8],
                first_prim: n.primitive_base_idx,
                first_block: blocks.len() as u32,
                used: 0,
                leaves: 0,
            };
            let mut count = 0;
            for slot in 0..8 {
                if n.is_child_empty(slot) {
                    continue;
                }
                node.used |= 1 << slot;
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
                    node.leaves |= 1 << slot;
                    let (first, k) = n.child_primitives(slot);
                    let offset = first.checked_sub(n.primitive_base_idx)?;
                    if offset + k > 24 || !(1..=3).contains(&k) {
                        return None;
                    }
                    count = count.max(offset + k);
                    LEAF | ((1 << k) - 1) << offset
                } else {
                    let c = n.child_node_index(slot);
                    if c as usize >= bvh.nodes.len() {
                        return None;
                    }
                    c
                };
            }
            for b in 0..count.div_ceil(8) {
                let mut block = TriBlock::default();
                for lane in 0..8 {
                    let p = (n.primitive_base_idx + 8 * b + lane) as usize;
                    if 8 * b + lane >= count {
                        break;
                    }
                    let t = tris.get(p)?;
                    for a in 0..3 {
                        block.v0[a][lane as usize] = t.v0[a];
                        block.e1[a][lane as usize] = t.e1[a];
                        block.e2[a][lane as usize] = t.e2[a];
                        block.ng[a][lane as usize] = t.ng[a];
                    }
                }
                blocks.push(block);
            }
            nodes.push(node);
        }
        // The stack holds at most seven entries a level (a node pushes all but one of the
        // children it visits).
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
        let root = &nodes[0];
        let extent = (0..8)
            .filter(|s| root.used & (1 << s) != 0)
            .flat_map(|s| (0..3).flat_map(move |a| [root.lo[a][s], root.hi[a][s]]))
            .fold(0f32, |m, v| m.max(v.abs()));
        (7 * (deepest as usize) < STACK).then_some(WideBvh {
            near_abs: NEAR_ABS * extent,
            nodes,
            tris: blocks,
        })
    }

    /// The closest triangle along `ray` within (`ray.tmin`, `ray.tmax`]: its primitive index
    /// and distance.
    #[inline]
    pub(crate) fn closest(&self, ray: &Ray) -> Option<(u32, f32)> {
        simd::dispatch!(
            ["avx2"] as AVX,
            fn(tree: &WideBvh = self, ray: &Ray) -> Option<(u32, f32)> {
                tree.closest_in::<AVX>(ray)
            }
        )
    }

    #[inline(always)]
    pub(super) fn closest_in<const AVX: bool>(&self, ray: &Ray) -> Option<(u32, f32)> {
        let mut r = *ray;
        let mut best = None;
        self.walk::<true, AVX>(&mut r, |p, t, r| {
            r.tmax = t;
            best = Some((p, t));
            false
        });
        best
    }

    /// Whether any triangle lies along `ray` within (`ray.tmin`, `ray.tmax`].
    #[inline]
    pub(crate) fn any(&self, ray: &Ray) -> bool {
        simd::dispatch!(
            ["avx2"] as AVX,
            fn(tree: &WideBvh = self, ray: &Ray) -> bool { tree.any_in::<AVX>(ray) }
        )
    }

    #[inline(always)]
    pub(super) fn any_in<const AVX: bool>(&self, ray: &Ray) -> bool {
        let mut r = *ray;
        let mut found = false;
        self.walk::<false, AVX>(&mut r, |_, _, _| {
            found = true;
            true
        });
        found
    }

    /// The closest triangles along up to eight rays traced together (`out[r]` for `rays[r]`):
    /// what [`Self::closest`] gives each, at a fraction of the cost where the rays are
    /// coherent (neighbouring rays that took the same path), since the packet shares one
    /// walk's branches and stack and its rays' slab tests run side by side.
    ///
    /// The packet walk visits every node each ray meets within its range, in an order of its
    /// own; it finds each ray's nearest triangle and distance (the same arithmetic), but where
    /// two triangles lie at one distance, which one [`Self::closest`] takes depends on its
    /// visiting order. So a ray for which another triangle lies within [`NEAR_REL`] of its
    /// nearest (and [`Self::near_abs`]) is traced again alone: every answer is bit for bit
    /// the single walk's.
    #[inline]
    pub(crate) fn closest_packet(&self, rays: &[Ray], out: &mut [Option<(u32, f32)>]) {
        simd::dispatch!(
            ["avx2"] as AVX,
            fn(tree: &WideBvh = self, rays: &[Ray], out: &mut [Option<(u32, f32)>]) {
                tree.closest_packet_in::<AVX>(rays, out)
            }
        )
    }

    #[inline(always)]
    pub(super) fn closest_packet_in<const AVX: bool>(
        &self,
        rays: &[Ray],
        out: &mut [Option<(u32, f32)>],
    ) {
        let n = rays.len();
        assert!((1..=8).contains(&n) && out.len() == n);
        let tests: [SlabRay; 8] = std::array::from_fn(|r| SlabRay::new(&rays[r.min(n - 1)]));
        let margin = |d: f32| NEAR_REL * d + self.near_abs;
        // Per ray: the nearest triangle so far and the range searched (beyond the nearest by
        // twice the margin, so that any triangle within the margin of it is met).
        let mut best = [(u32::MAX, f32::INFINITY); 8];
        let mut bound: [f32; 8] = std::array::from_fn(|r| rays[r.min(n - 1)].tmax);
        // Rays with two triangles within the margin of each other, nearest first.
        let mut near = 0u32;
        let mut stack = [std::mem::MaybeUninit::<(u32, u32, f32)>::uninit(); STACK];
        let mut sp = 0usize;
        let (mut cur, mut live) = (0u32, (1u32 << n) - 1);
        loop {
            let node = &self.nodes[cur as usize];
            // Each live ray's slab tests: the triangles of the leaves it meets, and per inner
            // child the rays that meet it and the nearest entry.
            let mut prims = [0u32; 8];
            let mut slot_rays = [0u32; 8];
            let mut slot_near = [f32::INFINITY; 8];
            let scalar = |prims: &mut [u32; 8], rays: &mut [u32; 8], near: &mut [f32; 8]| {
                let mut m = live;
                while m != 0 {
                    let r = m.trailing_zeros() as usize;
                    m &= m - 1;
                    let (mask, tnear) = tests[r].node(node, bound[r]);
                    let mask = mask & node.used;
                    let mut leaves = mask & node.leaves;
                    while leaves != 0 {
                        let slot = leaves.trailing_zeros() as usize;
                        leaves &= leaves - 1;
                        prims[r] |= node.child[slot] & 0x00ff_ffff;
                    }
                    let mut inner = mask & !node.leaves;
                    while inner != 0 {
                        let slot = inner.trailing_zeros() as usize;
                        inner &= inner - 1;
                        rays[slot] |= 1 << r;
                        near[slot] = near[slot].min(tnear[slot]);
                    }
                }
            };
            #[cfg(target_arch = "x86_64")]
            if AVX {
                // SAFETY: AVX is only asked for from functions compiled with AVX2.
                unsafe {
                    node_rays_avx(
                        &tests,
                        node,
                        live,
                        &bound,
                        (&mut prims, &mut slot_rays, &mut slot_near),
                    )
                };
            } else {
                scalar(&mut prims, &mut slot_rays, &mut slot_near);
            }
            #[cfg(not(target_arch = "x86_64"))]
            scalar(&mut prims, &mut slot_rays, &mut slot_near);
            let mut m = live;
            while m != 0 {
                let r = m.trailing_zeros() as usize;
                m &= m - 1;
                let mut prims = prims[r];
                while prims != 0 {
                    let b = prims.trailing_zeros() / 8;
                    let mut lanes = (prims >> (8 * b)) & 0xff;
                    prims &= !(0xff << (8 * b));
                    let block = &self.tris[(node.first_block + b) as usize];
                    let (t, met) = tests[r].triangles::<AVX>(block, bound[r]);
                    lanes &= met;
                    while lanes != 0 {
                        let j = lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        let d = t[j];
                        if d == f32::INFINITY {
                            continue;
                        }
                        let (_, nearest) = best[r];
                        if d < nearest {
                            if nearest <= d + margin(d) {
                                near |= 1 << r;
                            }
                            best[r] = (node.first_prim + 8 * b + j as u32, d);
                            bound[r] = bound[r].min(d + 2.0 * margin(d));
                        } else if d <= nearest + margin(nearest) {
                            near |= 1 << r;
                        }
                    }
                }
            }
            // The inner children met, farthest first (by their nearest ray's entry).
            let mut inner = [(0f32, 0u32, 0u32); 8];
            let mut k = 0;
            for slot in 0..8 {
                if slot_rays[slot] != 0 {
                    let e = (slot_near[slot], node.child[slot], slot_rays[slot]);
                    let mut j = k;
                    while j > 0 && inner[j - 1].0 < e.0 {
                        inner[j] = inner[j - 1];
                        j -= 1;
                    }
                    inner[j] = e;
                    k += 1;
                }
            }
            if k > 0 {
                for &(t, c, rays) in &inner[..k - 1] {
                    stack[sp].write((c, rays, t));
                    sp += 1;
                }
                (_, cur, live) = inner[k - 1];
                continue;
            }
            loop {
                if sp == 0 {
                    for (r, o) in out.iter_mut().enumerate() {
                        *o = if near & (1 << r) != 0 {
                            self.closest_in::<AVX>(&rays[r])
                        } else {
                            (best[r].1 < f32::INFINITY).then_some(best[r])
                        };
                    }
                    return;
                }
                sp -= 1;
                // SAFETY: entries below `sp` were written.
                let (c, rays, t) = unsafe { stack[sp].assume_init() };
                // The rays whose range still reaches the child's nearest entry.
                let mut m = rays;
                let mut keep = 0;
                while m != 0 {
                    let r = m.trailing_zeros() as usize;
                    m &= m - 1;
                    keep |= u32::from(t <= bound[r]) << r;
                }
                if keep != 0 {
                    (cur, live) = (c, keep);
                    break;
                }
            }
        }
    }

    /// Visit the leaves `ray` meets, handing `hit(primitive, distance, ray)` the nearest
    /// triangle of each block of a node's triangles that the ray hits before `ray.tmax` (the
    /// lowest primitive index among equals); `hit` may shorten `ray.tmax` and returns true to
    /// stop. With `ORDERED` the inner children a node's ray meets are visited nearest first.
    #[inline(always)]
    fn walk<const ORDERED: bool, const AVX: bool>(
        &self,
        ray: &mut Ray,
        mut hit: impl FnMut(u32, f32, &mut Ray) -> bool,
    ) {
        let test = SlabRay::new(ray);
        let mut stack = [std::mem::MaybeUninit::<(u32, f32)>::uninit(); STACK];
        let mut sp = 0usize;
        let mut cur = 0u32;
        loop {
            let node = &self.nodes[cur as usize];
            // The node's triangles (bits by their place from its first) in the leaves met, and
            // the inner children met (entry distances and nodes), in slot order.
            #[cfg(target_arch = "x86_64")]
            let (mut prims, k, mut inner_t, mut inner_c) = if AVX {
                // SAFETY: AVX is only asked for from functions compiled with AVX2.
                unsafe { node_ray_avx(&test, node, ray.tmax) }
            } else {
                node_ray(&test, node, ray.tmax)
            };
            #[cfg(not(target_arch = "x86_64"))]
            let (mut prims, k, mut inner_t, mut inner_c) = node_ray(&test, node, ray.tmax);
            while prims != 0 {
                let b = prims.trailing_zeros() / 8;
                let lanes = (prims >> (8 * b)) & 0xff;
                prims &= !(0xff << (8 * b));
                let block = &self.tris[(node.first_block + b) as usize];
                let (t, met) = test.triangles::<AVX>(block, ray.tmax);
                let (mut lane, mut nearest) = (8, f32::INFINITY);
                let mut l = lanes & met;
                while l != 0 {
                    let j = l.trailing_zeros() as usize;
                    l &= l - 1;
                    if t[j] < nearest {
                        (lane, nearest) = (j, t[j]);
                    }
                }
                if lane < 8
                    && nearest < ray.tmax
                    && hit(node.first_prim + 8 * b + lane as u32, nearest, ray)
                {
                    return;
                }
            }
            if ORDERED && k > 1 {
                // Insertion sort, farthest first, so that the nearest is taken next and the
                // rest are pushed far to near.
                for i in 1..k {
                    let (et, ec) = (inner_t[i], inner_c[i]);
                    let mut j = i;
                    while j > 0 && inner_t[j - 1] < et {
                        inner_t[j] = inner_t[j - 1];
                        inner_c[j] = inner_c[j - 1];
                        j -= 1;
                    }
                    (inner_t[j], inner_c[j]) = (et, ec);
                }
            }
            if k > 0 {
                for (&t, &c) in inner_t[..k - 1].iter().zip(&inner_c[..k - 1]) {
                    stack[sp].write((c, t));
                    sp += 1;
                }
                let (t, c) = (inner_t[k - 1], inner_c[k - 1]);
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

/// A ray's slab tests at `node`: the triangles of the leaves it meets (bits as in
/// [`Node::child`]), and how many inner children it meets, their entry distances and their
/// nodes, in slot order.
#[inline(always)]
fn node_ray(test: &SlabRay, node: &Node, tmax: f32) -> (u32, usize, [f32; 8], [u32; 8]) {
    let (mask, tnear) = test.node(node, tmax);
    let mut mask = mask & node.used;
    let (mut inner_t, mut inner_c) = ([0f32; 8], [0u32; 8]);
    let mut k = 0;
    let mut prims = 0u32;
    while mask != 0 {
        let slot = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        let c = node.child[slot];
        // Without branches (whether a child is a leaf is hard to predict): a leaf's
        // triangles join `prims`, an inner child is written and counted.
        let leaf = c >> 31;
        prims |= c & leaf.wrapping_neg() & 0x00ff_ffff;
        (inner_t[k], inner_c[k]) = (tnear[slot], c);
        k += (1 - leaf) as usize;
    }
    (prims, k, inner_t, inner_c)
}

/// For each set of slots (a bit each), the slots in ascending order, then zeros: the lanes
/// that pack a vector's lanes of those slots to its front.
const PACK: [[u32; 8]; 256] = {
    let mut table = [[0u32; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let (mut slot, mut k) = (0, 0);
        while slot < 8 {
            if m & (1 << slot) != 0 {
                table[m][k] = slot as u32;
                k += 1;
            }
            slot += 1;
        }
        m += 1;
    }
    table
};

/// [`node_ray`] in vector registers: the leaves' triangles OR-ed across the lanes, and the
/// inner children met packed to the front ([`PACK`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn node_ray_avx(test: &SlabRay, node: &Node, tmax: f32) -> (u32, usize, [f32; 8], [u32; 8]) {
    use std::arch::x86_64::*;
    // SAFETY: the loads are of whole [f32; 8] and [u32; 8] rows, 32-byte aligned (`Node` is
    // `align(32)`, its rows at multiples of 32 bytes) or of a row of `PACK`; the stores
    // unaligned.
    unsafe {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let used = _mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(node.used as i32), bits),
            bits,
        );
        let child = _mm256_load_si256(node.child.as_ptr().cast());
        // A leaf's child word has its top bit set.
        let leaf = _mm256_srai_epi32::<31>(child);
        let (t0, hit) = test.slab_avx(node, tmax);
        let hit = _mm256_and_si256(hit, used);
        let p = _mm256_and_si256(
            _mm256_and_si256(hit, leaf),
            _mm256_and_si256(child, _mm256_set1_epi32(0x00ff_ffff)),
        );
        let p = _mm_or_si128(_mm256_castsi256_si128(p), _mm256_extracti128_si256::<1>(p));
        let p = _mm_or_si128(p, _mm_unpackhi_epi64(p, p));
        let p = _mm_or_si128(p, _mm_shuffle_epi32::<0b01>(p));
        let met = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_andnot_si256(leaf, hit))) as usize;
        let pack = _mm256_loadu_si256(PACK[met].as_ptr().cast());
        let (mut inner_t, mut inner_c) = ([0f32; 8], [0u32; 8]);
        _mm256_storeu_ps(inner_t.as_mut_ptr(), _mm256_permutevar8x32_ps(t0, pack));
        _mm256_storeu_si256(
            inner_c.as_mut_ptr().cast(),
            _mm256_permutevar8x32_epi32(child, pack),
        );
        (
            _mm_cvtsi128_si32(p) as u32,
            met.count_ones() as usize,
            inner_t,
            inner_c,
        )
    }
}

/// The slab tests of a packet's `live` rays at `node`, eight children a ray at a time: per
/// ray the triangles of the leaves it meets (bits as in [`Node::child`]), and per inner child
/// the rays that meet it (a bit each) and their nearest entry, gathered in vector registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn node_rays_avx(
    tests: &[SlabRay; 8],
    node: &Node,
    live: u32,
    bound: &[f32; 8],
    (prims, rays, near): (&mut [u32; 8], &mut [u32; 8], &mut [f32; 8]),
) {
    use std::arch::x86_64::*;
    // SAFETY: the loads are of whole [f32; 8] and [u32; 8] rows, 32-byte aligned (`Node` is
    // `align(32)`, its rows at multiples of 32 bytes); the stores unaligned.
    unsafe {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let set = |mask: u32| {
            _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(mask as i32), bits), bits)
        };
        let used = set(node.used);
        let leaf = _mm256_and_si256(set(node.leaves), used);
        let inner = _mm256_andnot_si256(leaf, used);
        let child = _mm256_load_si256(node.child.as_ptr().cast());
        let leaf_prims = _mm256_and_si256(
            _mm256_and_si256(child, _mm256_set1_epi32(0x00ff_ffff)),
            leaf,
        );
        let (mut slot_rays, mut slot_near) =
            (_mm256_setzero_si256(), _mm256_set1_ps(f32::INFINITY));
        let mut m = live;
        while m != 0 {
            let r = m.trailing_zeros() as usize;
            m &= m - 1;
            let (t0, hit) = tests[r].slab_avx(node, bound[r]);
            // The leaves' triangles, OR-ed across the lanes.
            let p = _mm256_and_si256(hit, leaf_prims);
            let p = _mm_or_si128(_mm256_castsi256_si128(p), _mm256_extracti128_si256::<1>(p));
            let p = _mm_or_si128(p, _mm_unpackhi_epi64(p, p));
            let p = _mm_or_si128(p, _mm_shuffle_epi32::<0b01>(p));
            prims[r] = _mm_cvtsi128_si32(p) as u32;
            let met = _mm256_and_si256(hit, inner);
            slot_rays =
                _mm256_or_si256(slot_rays, _mm256_and_si256(met, _mm256_set1_epi32(1 << r)));
            let entry =
                _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), t0, _mm256_castsi256_ps(met));
            slot_near = _mm256_min_ps(entry, slot_near);
        }
        _mm256_storeu_si256(rays.as_mut_ptr().cast(), slot_rays);
        _mm256_storeu_ps(near.as_mut_ptr(), slot_near);
    }
}

/// A ray prepared for slab and triangle tests: its origin and direction, the reciprocal of its
/// direction (obvhs's, with components near zero clamped), and for each axis whether it runs
/// towards −.
struct SlabRay {
    o: [f32; 3],
    d: [f32; 3],
    inv: [f32; 3],
    neg: [bool; 3],
    tmin: f32,
}

impl SlabRay {
    #[inline(always)]
    fn new(ray: &Ray) -> SlabRay {
        SlabRay {
            o: ray.origin.to_array(),
            d: ray.direction.to_array(),
            inv: ray.inv_direction.to_array(),
            neg: [0, 1, 2].map(|a| ray.inv_direction[a] < 0.0),
            tmin: ray.tmin,
        }
    }

    /// The children of `node` the ray meets within [tmin, tmax] (a bit per slot), and each
    /// slot's entry distance.
    #[inline(always)]
    fn node(&self, node: &Node, tmax: f32) -> (u32, [f32; 8]) {
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

    /// [`Self::node`] in vector registers: each slot's entry distance, and all ones in the
    /// slots the ray meets (not yet masked by the slots used).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn slab_avx(
        &self,
        node: &Node,
        tmax: f32,
    ) -> (std::arch::x86_64::__m256, std::arch::x86_64::__m256i) {
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
            (t0, _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)))
        }
    }

    /// The distance to each triangle of `block` within (tmin, tmax], ∞ where the ray misses
    /// it ([`super::tri_t`] lane by lane), and a bit for each lane that may be met (at least
    /// those with a finite distance), so that callers pass over the rest.
    #[inline(always)]
    fn triangles<const AVX: bool>(&self, block: &TriBlock, tmax: f32) -> ([f32; 8], u32) {
        #[cfg(target_arch = "x86_64")]
        if AVX {
            // SAFETY: AVX is only asked for from functions compiled with AVX2.
            return unsafe { self.triangles_avx(block, tmax) };
        }
        let t = self.triangles_scalar(block, tmax);
        let met = (0..8).fold(0, |m, l| m | u32::from(t[l] != f32::INFINITY) << l);
        (t, met)
    }

    /// The operations of [`super::tri_t`] (glam's Vec3A cross and dot products, without fused
    /// multiply-adds: a cross product's component is a·b − c·d, a dot product (x + y) + z).
    #[inline(always)]
    fn triangles_scalar(&self, block: &TriBlock, tmax: f32) -> [f32; 8] {
        let [ox, oy, oz] = self.o;
        let [dx, dy, dz] = self.d;
        let mut out = [f32::INFINITY; 8];
        for (l, out) in out.iter_mut().enumerate() {
            let (cx, cy, cz) = (
                block.v0[0][l] - ox,
                block.v0[1][l] - oy,
                block.v0[2][l] - oz,
            );
            let (rx, ry, rz) = (cy * dz - cz * dy, cz * dx - cx * dz, cx * dy - cy * dx);
            let [nx, ny, nz] = [block.ng[0][l], block.ng[1][l], block.ng[2][l]];
            let den = -((nx * dx + ny * dy) + nz * dz);
            let abs_den = den.abs();
            let sgn = den.to_bits() & 0x8000_0000;
            let u = (rx * block.e2[0][l] + ry * block.e2[1][l]) + rz * block.e2[2][l];
            let v = (rx * block.e1[0][l] + ry * block.e1[1][l]) + rz * block.e1[2][l];
            let u = f32::from_bits(u.to_bits() ^ sgn);
            let v = f32::from_bits(v.to_bits() ^ sgn);
            let w = abs_den - u - v;
            if den == 0.0 || u < 0.0 || v < 0.0 || w < 0.0 {
                continue;
            }
            let t = -((nx * cx + ny * cy) + nz * cz);
            let t = f32::from_bits(t.to_bits() ^ sgn);
            if abs_den * self.tmin < t && t <= abs_den * tmax {
                *out = t / abs_den;
            }
        }
        out
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    #[inline]
    fn triangles_avx(&self, block: &TriBlock, tmax: f32) -> ([f32; 8], u32) {
        use std::arch::x86_64::*;
        // SAFETY: the loads are of whole [f32; 8] rows, 32-byte aligned (`TriBlock` is
        // `align(32)`).
        unsafe {
            let ld = |row: &[f32; 8]| _mm256_load_ps(row.as_ptr());
            let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
            let [ox, oy, oz] = self.o.map(|v| _mm256_set1_ps(v));
            let [dx, dy, dz] = self.d.map(|v| _mm256_set1_ps(v));
            let sign = _mm256_set1_ps(-0.0);
            let zero = _mm256_setzero_ps();
            let cx = sub(ld(&block.v0[0]), ox);
            let cy = sub(ld(&block.v0[1]), oy);
            let cz = sub(ld(&block.v0[2]), oz);
            let rx = sub(mul(cy, dz), mul(cz, dy));
            let ry = sub(mul(cz, dx), mul(cx, dz));
            let rz = sub(mul(cx, dy), mul(cy, dx));
            let (nx, ny, nz) = (ld(&block.ng[0]), ld(&block.ng[1]), ld(&block.ng[2]));
            let den = _mm256_xor_ps(add(add(mul(nx, dx), mul(ny, dy)), mul(nz, dz)), sign);
            let abs_den = _mm256_andnot_ps(sign, den);
            let sgn = _mm256_and_ps(den, sign);
            let dot_r = |e: &[[f32; 8]; 3]| {
                add(
                    add(mul(rx, ld(&e[0])), mul(ry, ld(&e[1]))),
                    mul(rz, ld(&e[2])),
                )
            };
            let u = _mm256_xor_ps(dot_r(&block.e2), sgn);
            let v = _mm256_xor_ps(dot_r(&block.e1), sgn);
            let w = sub(sub(abs_den, u), v);
            let miss = _mm256_or_ps(
                _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_EQ_OQ>(den, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(u, zero),
                ),
                _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(v, zero),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(w, zero),
                ),
            );
            let t = _mm256_xor_ps(add(add(mul(nx, cx), mul(ny, cy)), mul(nz, cz)), sign);
            let t = _mm256_xor_ps(t, sgn);
            let within = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(mul(abs_den, _mm256_set1_ps(self.tmin)), t),
                _mm256_cmp_ps::<_CMP_LE_OQ>(t, mul(abs_den, _mm256_set1_ps(tmax))),
            );
            let ok = _mm256_andnot_ps(miss, within);
            let dist =
                _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), _mm256_div_ps(t, abs_den), ok);
            let mut out = [0f32; 8];
            _mm256_storeu_ps(out.as_mut_ptr(), dist);
            (out, _mm256_movemask_ps(ok) as u32)
        }
    }
}
