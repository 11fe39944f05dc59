//! Stage 2 of the CSL bake, bundle extraction (§3.1.1): the lines of the caustic rays are
//! rasterised with a 3D DDA into the cells of an extended bounding volume ([`super::volume`];
//! energy per cell); a bundle axis starts from the rays through the cell of most energy and is
//! refined by alternating ray assignment (line distance and angle thresholds) and a
//! least-squares axis fit.
//!
//! Cell energies are fixed-point integers: each thread rasterises its share of the rays into a
//! grid of its own and the grids are added, and integer addition is associative, so the grid is
//! identical whatever the thread schedule, and removing a bundle's rays subtracts exactly what
//! they added.
//!
//! The pool of rays not yet in a CSL is kept compact, as columns of origins, directions and
//! weights, so later bundles do not scan the rays earlier ones took and a scan reads memory
//! front to back, eight rays at a time. Within one extraction, assignment iterates over a
//! candidate list (the pool's rays within relaxed thresholds of the axis, refreshed when the
//! axis has moved far from where it was taken), and the final membership is taken by one pass
//! over the whole pool with the final axis. Convergence: the membership changed by at most
//! 0.1 % (or the axis stopped moving), within the paper's cap of 100 iterations; a bundle whose
//! membership keeps swinging ends after 12 iterations without a more energetic membership, on
//! the axis of the most energetic one.

use super::trace::CausticRay;
pub use super::volume::{MAX_CELLS, Volume};
use crate::trace::simd;
use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;

/// Fixed-point scale of cell energies (a unit-energy ray adds 2^32).
const FIXED: f64 = 4_294_967_296.0;

/// Deterministic parallel sum: fixed chunks summed in parallel, partial sums added in order.
pub fn det_sum<T: Sync, R: Send + Sync + Copy + std::ops::Add<Output = R>>(
    items: &[T],
    zero: R,
    f: impl Fn(&T) -> R + Sync,
) -> R {
    det_fold(items, zero, f, |a, b| a + b)
}

/// [`det_sum`] with the addition `add`.
pub fn det_fold<T: Sync, R: Send + Sync + Copy>(
    items: &[T],
    zero: R,
    f: impl Fn(&T) -> R + Sync,
    add: impl Fn(R, R) -> R + Sync,
) -> R {
    let parts: Vec<R> = items
        .par_chunks(4096)
        .map(|c| c.iter().fold(zero, |acc, x| add(acc, f(x))))
        .collect();
    parts.into_iter().fold(zero, &add)
}

/// A bundle: the axis (origin, unit direction) and the indices of its rays.
#[derive(Clone, Debug)]
pub struct Bundle {
    pub origin: Vec3,
    pub axis: Vec3,
    pub members: Vec<u32>,
    pub iterations: u32,
}

/// Thresholds of ray assignment.
#[derive(Clone, Copy, Debug)]
pub struct Thresholds {
    /// Largest distance between a ray's line and the axis line, metres.
    pub distance: f32,
    /// Smallest cosine between a ray's direction and the axis.
    pub cos_angle: f32,
    pub max_iterations: u32,
}

/// Distance between the line (q, d) and the line (b, a), both directions unit.
pub fn line_distance(q: Vec3, d: Vec3, b: Vec3, a: Vec3) -> f32 {
    let n = d.cross(a);
    let l = n.length();
    if l > 1e-6 {
        ((q - b).dot(n) / l).abs()
    } else {
        (q - b).cross(a).length()
    }
}

/// The pool of rays not yet in a CSL and the energy grid of their lines.
pub struct Extractor<'a> {
    pub rays: &'a [CausticRay],
    pub alive: Vec<bool>,
    /// The alive rays, ascending.
    pool: Columns,
    /// The alive rays of the search sample ([`search_stride`]), ascending; None when every
    /// ray takes part.
    sample: Option<Columns>,
    pub volume: Volume,
    grid: Vec<u64>,
    blocked: Vec<bool>,
    fixed: Vec<u64>,
    /// Rays removed from the pool since its columns were last compacted: the scans pass them
    /// over until they are an eighth of the columns ([`Self::remove`]).
    dead: usize,
    /// [`search_stride`]: the energy grid holds the lines of the search sample only.
    stride: u32,
}

/// The fixed-point energy grid of the lines of `rays[idx]`: each thread rasterises a share into
/// a grid of its own, then the grids are summed (exactly: integers).
fn rasterise(rays: &[CausticRay], fixed: &[u64], idx: &[u32], volume: Volume) -> Vec<u64> {
    let cells = (volume.n as usize).pow(3);
    if idx.is_empty() {
        return vec![0; cells];
    }
    let shares = rayon::current_num_threads().max(1);
    let chunk = idx.len().div_ceil(shares).max(1024);
    let mut grid = idx
        .par_chunks(chunk)
        .map(|part| {
            simd::dispatch!(
                ["avx2"],
                fn(rays: &[CausticRay], fixed: &[u64], part: &[u32], volume: Volume) -> Vec<u64> {
                    rasterise_part(rays, fixed, part, volume)
                }
            )
        })
        .reduce_with(|mut a, b| {
            for (x, y) in a.iter_mut().zip(&b) {
                *x = x.wrapping_add(*y);
            }
            a
        })
        .unwrap_or_else(|| vec![0; cells]);
    grid.truncate(cells);
    grid
}

/// The grid of one share of the rays, with eight dummy cells after the last.
#[inline(always)]
fn rasterise_part(rays: &[CausticRay], fixed: &[u64], part: &[u32], volume: Volume) -> Vec<u64> {
    let cells = (volume.n as usize).pow(3);
    let mut g = vec![0u64; cells + 8];
    splat::<true>(rays, fixed, part, volume, &mut g);
    g
}

/// Add (`ADD`) or subtract the energy of the lines of `rays[part]` to or from the cells of
/// `grid` they visit; `grid` holds the volume's cells and eight dummy cells after them.
#[inline(always)]
fn splat<const ADD: bool>(
    rays: &[CausticRay],
    fixed: &[u64],
    part: &[u32],
    volume: Volume,
    grid: &mut [u64],
) {
    let cells = grid.len() - 8;
    let mut list = [[0u32; MAX_CELLS]; 3];
    for &i in part {
        let r = &rays[i as usize];
        let Some(w) = volume.walk(r.origin, r.dir) else {
            continue;
        };
        let e = fixed[i as usize];
        w.cells(cells as u32, &mut list);
        for j in 0..w.slices {
            for l in &list {
                let c = l[j] as usize;
                grid[c] = if ADD {
                    grid[c].wrapping_add(e)
                } else {
                    grid[c].wrapping_sub(e)
                };
            }
        }
    }
}

/// Number of elements in exactly one of two ascending lists.
fn symmetric_difference(a: &[u32], b: &[u32]) -> usize {
    let (mut i, mut j, mut n) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                n += 1;
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                n += 1;
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    n + (a.len() - i) + (b.len() - j)
}

/// Rays as columns (origin and direction components and weights, with their indices into the
/// caustic rays), in ascending index order: the pool and the candidates that assignment scans
/// millions of times per bake, read front to back and tested eight at a time.
#[derive(Clone, Debug, Default)]
pub(crate) struct Columns {
    idx: Vec<u32>,
    o: [Vec<f32>; 3],
    d: [Vec<f32>; 3],
    /// Weight (RGB mean energy).
    w: Vec<f32>,
}

/// Positions of one scan block (a block's passes are written branch-free into it).
const BLOCK: usize = 64;

/// Rays per share of a parallel scan.
const SCAN_SHARE: usize = 16 * 1024;

/// Candidate rays: the rays of a [`Columns`] that passed a scan, one set of columns per share
/// of it, in order (no copy into one list).
struct Shares(Vec<Columns>);

impl Shares {
    /// The rays within thresholds `distance`, `cos` of the axis line (b, a) ([`within`]):
    /// their indices (ascending) and their places (share, position).
    fn scan(&self, b: Vec3, a: Vec3, distance: f32, cos: f32) -> (Vec<u32>, Vec<(u32, u32)>) {
        let d2 = distance * distance;
        let found: Vec<Vec<u32>> = self
            .0
            .par_iter()
            .map(|c| c.filter_range_best(0..c.len(), move |q, d| within(q, d, b, a, d2, cos)))
            .collect();
        let total = found.iter().map(Vec::len).sum();
        let (mut members, mut places) = (Vec::with_capacity(total), Vec::with_capacity(total));
        for (s, (c, found)) in self.0.iter().zip(&found).enumerate() {
            members.extend(found.iter().map(|&p| c.idx[p as usize]));
            places.extend(found.iter().map(|&p| (s as u32, p)));
        }
        (members, places)
    }

    /// Weight, direction and origin of the ray at `place`.
    #[inline(always)]
    fn ray(&self, (share, p): (u32, u32)) -> (f32, Vec3, Vec3) {
        self.0[share as usize].ray(p)
    }
}

impl Columns {
    pub(crate) fn of(rays: &[CausticRay], idx: &[u32]) -> Columns {
        let n = idx.len();
        let mut c = Columns {
            idx: idx.to_vec(),
            o: std::array::from_fn(|_| vec![0.0; n]),
            d: std::array::from_fn(|_| vec![0.0; n]),
            w: vec![0.0; n],
        };
        // One pass over the rays, in shares, writing every column.
        const SHARE: usize = SCAN_SHARE;
        let [ox, oy, oz] = &mut c.o;
        let [dx, dy, dz] = &mut c.d;
        (
            idx.par_chunks(SHARE),
            ox.par_chunks_mut(SHARE),
            oy.par_chunks_mut(SHARE),
            oz.par_chunks_mut(SHARE),
            dx.par_chunks_mut(SHARE),
            dy.par_chunks_mut(SHARE),
            dz.par_chunks_mut(SHARE),
            c.w.par_chunks_mut(SHARE),
        )
            .into_par_iter()
            .for_each(|(ix, ox, oy, oz, dx, dy, dz, w)| {
                for (k, &i) in ix.iter().enumerate() {
                    let r = &rays[i as usize];
                    (ox[k], oy[k], oz[k]) = (r.origin.x, r.origin.y, r.origin.z);
                    (dx[k], dy[k], dz[k]) = (r.dir.x, r.dir.y, r.dir.z);
                    w[k] = r.weight();
                }
            });
        c
    }

    fn len(&self) -> usize {
        self.idx.len()
    }

    /// Weight, direction and origin of the ray at position `p`.
    #[inline(always)]
    fn ray(&self, p: u32) -> (f32, Vec3, Vec3) {
        let p = p as usize;
        let [ox, oy, oz] = &self.o;
        let [dx, dy, dz] = &self.d;
        (
            self.w[p],
            Vec3::new(dx[p], dy[p], dz[p]),
            Vec3::new(ox[p], oy[p], oz[p]),
        )
    }

    /// The columns at `positions` (ascending), on this thread.
    fn select(&self, positions: &[u32]) -> Columns {
        let pick = |c: &Vec<f32>| positions.iter().map(|&p| c[p as usize]).collect();
        Columns {
            idx: self.indices(positions),
            o: self.o.each_ref().map(pick),
            d: self.d.each_ref().map(pick),
            w: pick(&self.w),
        }
    }

    /// Keep the rays for which `keep(index)` holds: each column compacted in place (no new
    /// pages to fault in), the columns in parallel.
    fn retain(&mut self, keep: impl Fn(u32) -> bool + Sync) {
        let mask: Vec<bool> = self.idx.par_iter().map(|&i| keep(i)).collect();
        fn compact<T: Copy>(col: &mut Vec<T>, mask: &[bool]) {
            let mut w = 0;
            for r in 0..col.len() {
                col[w] = col[r];
                w += mask[r] as usize;
            }
            col.truncate(w);
        }
        let [o0, o1, o2] = &mut self.o;
        let [d0, d1, d2] = &mut self.d;
        let mut floats = [o0, o1, o2, d0, d1, d2, &mut self.w];
        rayon::join(
            || compact(&mut self.idx, &mask),
            || floats.par_iter_mut().for_each(|c| compact(c, &mask)),
        );
    }

    /// Positions (ascending) of the rays within thresholds `distance`, `cos` of the axis line
    /// (b, a) ([`within`]).
    fn scan(&self, b: Vec3, a: Vec3, distance: f32, cos: f32) -> Vec<u32> {
        let d2 = distance * distance;
        self.filter(move |q, d| within(q, d, b, a, d2, cos))
    }

    /// The ray indices at `positions`.
    fn indices(&self, positions: &[u32]) -> Vec<u32> {
        positions.iter().map(|&p| self.idx[p as usize]).collect()
    }

    /// Positions (ascending) of the rays whose lines meet the box [lo, hi]
    /// ([`Volume::line_hits_box`], in the same operations).
    fn meeting_box(&self, lo: Vec3, hi: Vec3) -> Vec<u32> {
        self.filter(move |q, d| meets_box(q, d, lo, hi))
    }

    /// The rays within thresholds `distance`, `cos` of the axis line (b, a) ([`within`]), as
    /// [`Shares`]: each share of the pool scanned and its passing rays copied while the share
    /// is still in the cache; only those `alive` (by ray index) where given.
    fn scan_shares(
        &self,
        b: Vec3,
        a: Vec3,
        distance: f32,
        cos: f32,
        alive: Option<&[bool]>,
    ) -> Shares {
        let d2 = distance * distance;
        let test = move |q, d| within(q, d, b, a, d2, cos);
        let n = self.len();
        Shares(
            (0..n.div_ceil(SCAN_SHARE))
                .into_par_iter()
                .map(|c| {
                    let range = c * SCAN_SHARE..((c + 1) * SCAN_SHARE).min(n);
                    let mut found = self.filter_range_best(range, test);
                    if let Some(alive) = alive {
                        found.retain(|&p| alive[self.idx[p as usize] as usize]);
                    }
                    self.select(&found)
                })
                .collect(),
        )
    }

    /// Positions (ascending) of the rays in `range` for which `test` holds, on this thread,
    /// eight rays at a time where the processor has AVX2.
    fn filter_range_best(
        &self,
        range: std::ops::Range<usize>,
        test: impl Fn(Vec3, Vec3) -> bool,
    ) -> Vec<u32> {
        simd::dispatch!(
            ["avx2"],
            fn(
                columns: &Columns = self,
                range: std::ops::Range<usize>,
                test: impl Fn(Vec3, Vec3) -> bool,
            ) -> Vec<u32> {
                columns.filter_range(range, test)
            }
        )
    }

    /// Ray indices of the rays at positions in `ranges` for which `test` holds, ascending, on
    /// this thread.
    pub(crate) fn filter_ranges(
        &self,
        ranges: impl Iterator<Item = std::ops::Range<usize>>,
        test: impl Fn(Vec3, Vec3) -> bool + Copy,
    ) -> Vec<u32> {
        let mut out: Vec<u32> = Vec::new();
        for range in ranges {
            out.extend(
                self.filter_range_best(range, test)
                    .into_iter()
                    .map(|p| self.idx[p as usize]),
            );
        }
        out.sort_unstable();
        out
    }

    /// Positions (ascending) of the rays (origin, direction) for which `test` holds; in
    /// parallel, eight rays at a time where the processor has AVX2.
    fn filter(&self, test: impl Fn(Vec3, Vec3) -> bool + Sync + Copy) -> Vec<u32> {
        let n = self.len();
        let parts: Vec<Vec<u32>> = (0..n.div_ceil(SCAN_SHARE))
            .into_par_iter()
            .map(|c| self.filter_range_best(c * SCAN_SHARE..((c + 1) * SCAN_SHARE).min(n), test))
            .collect();
        parts.concat()
    }

    #[inline(always)]
    fn filter_range(
        &self,
        range: std::ops::Range<usize>,
        test: impl Fn(Vec3, Vec3) -> bool,
    ) -> Vec<u32> {
        let mut out = Vec::new();
        let mut start = range.start;
        while start < range.end {
            let end = (start + BLOCK).min(range.end);
            let m = end - start;
            let [ox, oy, oz] = self.o.each_ref().map(|c| &c[start..end]);
            let [dx, dy, dz] = self.d.each_ref().map(|c| &c[start..end]);
            let mut pass = [false; BLOCK];
            for k in 0..m {
                pass[k] = test(
                    Vec3::new(ox[k], oy[k], oz[k]),
                    Vec3::new(dx[k], dy[k], dz[k]),
                );
            }
            let mut found = [0u32; BLOCK];
            let mut count = 0;
            for (k, &p) in pass[..m].iter().enumerate() {
                found[count] = (start + k) as u32;
                count += p as usize;
            }
            out.extend_from_slice(&found[..count]);
            start = end;
        }
        out
    }
}

/// The assignment test of one ray (q, d) against the axis line (b, a), without branches: the
/// angle between d and a at most acos(`cos`), and [`line_distance`] at most √`d2`, tested
/// without a square root or a division.
#[inline(always)]
fn within(q: Vec3, d: Vec3, b: Vec3, a: Vec3, d2: f32, cos: f32) -> bool {
    let n = d.cross(a);
    let l2 = n.length_squared();
    let qb = q - b;
    let x = qb.dot(n);
    let skew = x * x <= d2 * l2;
    let parallel = qb.cross(a).length_squared() <= d2;
    let near = if l2 > 1e-12 { skew } else { parallel };
    (d.dot(a) >= cos) & near
}

/// [`Volume::line_hits_box`] without branches.
#[inline(always)]
fn meets_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
    let mut outside = false;
    for k in 0..3 {
        let parallel = d[k].abs() < 1e-12;
        outside |= parallel & ((o[k] < lo[k]) | (o[k] > hi[k]));
        let a = (lo[k] - o[k]) / d[k];
        let b = (hi[k] - o[k]) / d[k];
        t0 = if parallel { t0 } else { t0.max(a.min(b)) };
        t1 = if parallel { t1 } else { t1.min(a.max(b)) };
    }
    !outside & (t0 < t1)
}

/// One ray in how many takes part in the search for a bundle's axis, for a bake of `grid`²
/// rays: as many as leaves a sample as dense as the rays of a 640² grid, ⌊(grid / 640)²⌋ (4 at
/// the paper's 1280², every ray up to 905²).
///
/// The axis of a bundle is the least-squares line of its members (§3.1.1 step 4); a sample of
/// them gives it as well when it is dense enough, at a fraction of the scans. The bundle itself
/// is then every ray of the pool within the thresholds of that axis (step 3), as before.
/// Measured (CSL caustics against the references, floor, L1 / flux): at 1280² a quarter gave
/// the glass sphere 0.139 / 0.962 (all rays 0.138 / 0.962) and the teapot 0.759 / 0.773
/// (0.776 / 0.762), and the search took 40–50 % of the time; at grid 512 a quarter (as dense as
/// 256²) made the sphere worse, 0.135 / 0.969 against 0.126 / 0.975 (CPU evaluation), and at
/// grid 128 (the dynamic CI test) 0.136–0.145 against 0.117.
pub fn search_stride(grid: u32) -> u32 {
    ((grid as f32 / 640.0).powi(2) as u32).clamp(1, 16)
}

/// Whether ray `i` is in the search sample of one ray in `stride`: a hash of its index (a
/// fixed pseudo-random sample, unrelated to the order in which a grid ray's tree of paths
/// leaves its rays; every fourth index would pick the same branch of trees that each leave
/// four rays).
fn in_search_sample(i: u32, stride: u32) -> bool {
    // The finaliser of MurmurHash3.
    let mut h = i;
    h ^= h >> 16;
    h = h.wrapping_mul(0x85eb_ca6b);
    h ^= h >> 13;
    h = h.wrapping_mul(0xc2b2_ae35);
    h ^= h >> 16;
    h.is_multiple_of(stride)
}

impl<'a> Extractor<'a> {
    /// Rasterise the rays (parallel; exact integer sums). One ray in `stride` takes part in
    /// the search for the bundles' axes ([`search_stride`]), and only those are rasterised:
    /// the grid does nothing but choose the cell a bundle's search starts from, and the sample
    /// (a fixed pseudo-random quarter of the rays: over a million of the sphere's 4.2 M at
    /// 1280²) measures the energy through a cell as well as all the rays. At 1280² the rasterisation and the removals
    /// took a quarter of a dynamic bake's time (perf, the glass sphere).
    pub fn new(rays: &'a [CausticRay], volume: Volume, stride: u32) -> Self {
        let cells = (volume.n as usize).pow(3);
        let fixed: Vec<u64> = rays
            .par_iter()
            .map(|r| (r.weight() as f64 * FIXED).round() as u64)
            .collect();
        let all: Vec<u32> = (0..rays.len() as u32).collect();
        let pool = Columns::of(rays, &all);
        let some: Option<Vec<u32>> = (stride > 1).then(|| {
            all.iter()
                .copied()
                .filter(|&i| in_search_sample(i, stride))
                .collect()
        });
        let grid = rasterise(rays, &fixed, some.as_deref().unwrap_or(&all), volume);
        let sample = some.map(|some| Columns::of(rays, &some));
        Extractor {
            rays,
            alive: vec![true; rays.len()],
            pool,
            sample,
            volume,
            grid,
            blocked: vec![false; cells],
            fixed,
            dead: 0,
            stride,
        }
    }

    /// Take rays (distinct, in the pool) out of the pool, subtracting their energy from the
    /// grid. The columns keep them until they are an eighth of all (compacting the columns of
    /// 1.7 M rays after each of 64 CSLs took 4 % of a dynamic bake); until then the scans leave
    /// them out of what they find (`live`), which gives the same rays in the same order.
    ///
    /// `in_place`: subtract their lines from the grid on this thread, for callers that keep
    /// every core busy; otherwise they are rasterised into a grid per thread, in parallel, and
    /// that is subtracted. The integer sums are the same either way. Measured on the teapot at
    /// 1280² (63 removals of 16 k rays on average): in place, a 42-direction dynamic bake's
    /// sets took 76.3 → 74.5 s (the grids per thread, 2 MB each at 64³ cells, are zeroed,
    /// summed and subtracted for every removal), while a static bake with a core to spare
    /// spent about 100 ms more on its bundles.
    pub fn remove(&mut self, members: &[u32], in_place: bool) {
        for &m in members {
            self.alive[m as usize] = false;
        }
        self.dead += members.len();
        if self.dead * 8 > self.pool.len() {
            self.compact();
        }
        // The grid holds the search sample's lines only.
        let sampled: Vec<u32>;
        let members = if self.stride > 1 {
            sampled = members
                .iter()
                .copied()
                .filter(|&i| in_search_sample(i, self.stride))
                .collect();
            &sampled[..]
        } else {
            members
        };
        if in_place {
            let cells = self.grid.len();
            self.grid.resize(cells + 8, 0);
            simd::dispatch!(
                ["avx2"],
                fn(
                    rays: &[CausticRay] = self.rays,
                    fixed: &[u64] = &self.fixed,
                    part: &[u32] = members,
                    volume: Volume = self.volume,
                    grid: &mut [u64] = &mut self.grid,
                ) {
                    splat::<false>(rays, fixed, part, volume, grid)
                }
            );
            self.grid.truncate(cells);
            return;
        }
        let delta = rasterise(self.rays, &self.fixed, members, self.volume);
        for (g, d) in self.grid.iter_mut().zip(&delta) {
            *g = g.wrapping_sub(*d);
        }
    }

    /// Never seed a bundle from this cell again.
    pub fn block(&mut self, cell: usize) {
        self.blocked[cell] = true;
    }

    /// The unblocked cell of most energy (lowest index on ties), if any has energy.
    pub fn max_cell(&self) -> Option<usize> {
        let mut best: Option<(u64, usize)> = None;
        for (i, &e) in self.grid.iter().enumerate() {
            if e > 0 && !self.blocked[i] && best.is_none_or(|(b, _)| e > b) {
                best = Some((e, i));
            }
        }
        best.map(|(_, i)| i)
    }

    /// Drop the removed rays from the columns.
    fn compact(&mut self) {
        let alive = &self.alive;
        self.pool.retain(|i| alive[i as usize]);
        if let Some(sample) = &mut self.sample {
            sample.retain(|i| alive[i as usize]);
        }
        self.dead = 0;
    }

    /// The rays of `idx` still in the pool, in order.
    fn live(&self, mut idx: Vec<u32>) -> Vec<u32> {
        if self.dead > 0 {
            idx.retain(|&i| self.alive[i as usize]);
        }
        idx
    }

    /// Energy (RGB mean) of the rays still in the pool.
    pub fn remaining_energy(&self) -> f64 {
        self.pool
            .idx
            .iter()
            .filter(|&&i| self.alive[i as usize])
            .map(|&i| self.rays[i as usize].weight() as f64)
            .sum()
    }

    /// The live rays of the whole pool within `distance` and `cos` of the axis line (b, a),
    /// ascending.
    pub fn around(&self, b: Vec3, a: Vec3, distance: f32, cos: f32) -> Vec<u32> {
        self.live(self.pool.indices(&self.pool.scan(b, a, distance, cos)))
    }

    /// Grow a bundle from the rays through `cell`: seed axis from their energy-weighted means,
    /// then assignment and least-squares optimisation until the axis converges, on the search
    /// sample ([`search_stride`]; the seed from all rays through the cell where the sample has
    /// none); the bundle is every ray of the pool within the thresholds of that axis.
    pub fn extract(&self, cell: usize, th: &Thresholds, scale: f32) -> Option<Bundle> {
        let (lo, hi) = self.volume.cell_bounds(cell);
        let through = |c: &Columns| self.live(c.indices(&c.meeting_box(lo, hi)));
        let search = self.sample.as_ref().unwrap_or(&self.pool);
        let mut seed = through(search);
        if seed.is_empty() {
            seed = through(&self.pool);
        }
        if seed.is_empty() {
            return None;
        }
        let (mut sw, mut so, mut sd) = (0.0f64, DVec3::ZERO, DVec3::ZERO);
        for &i in &seed {
            let r = &self.rays[i as usize];
            let w = r.weight() as f64;
            sw += w;
            so += r.origin.as_dvec3() * w;
            sd += r.dir.as_dvec3() * w;
        }
        if sw <= 0.0 || sd.length() < 1e-9 * sw {
            return None;
        }
        let mut origin = (so / sw).as_vec3();
        let mut axis = sd.normalize().as_vec3();
        // Candidates: twice the distance threshold and 10° more angle around the axis they were
        // taken at; refreshed when the axis has moved half a threshold or turned 5°.
        let angle = th.cos_angle.clamp(-1.0, 1.0).acos();
        let relaxed_cos = (angle + 10f32.to_radians()).min(std::f32::consts::PI).cos();
        let alive = (self.dead > 0).then_some(&self.alive[..]);
        let take =
            |o: Vec3, a: Vec3| search.scan_shares(o, a, 2.0 * th.distance, relaxed_cos, alive);
        let mut cand = take(origin, axis);
        let mut cand_at = (origin, axis);
        let mut members: Vec<u32> = Vec::new();
        let mut iterations = 0;
        // Some bundles never settle: on the remainder of an aberrated lens the membership
        // swings by tens of percent per iteration until the cap. The axis of the most energetic
        // membership seen is kept, and the iteration stops when PATIENCE iterations in a row
        // have not beaten it by 0.1 %.
        const PATIENCE: u32 = 12;
        let (mut best_energy, mut best_axis, mut stall) = (0.0f64, (origin, axis), 0u32);
        while iterations < th.max_iterations {
            iterations += 1;
            let (co, ca) = cand_at;
            if (origin - co).length() > 0.5 * th.distance || axis.dot(ca) < 5f32.to_radians().cos()
            {
                cand = take(origin, axis);
                cand_at = (origin, axis);
            }
            let (next, places) = cand.scan(origin, axis, th.distance, th.cos_angle);
            if next.is_empty() {
                return None;
            }
            // Assignment and axis fit can keep trading a few boundary rays (a short cycle, or a
            // slow drift along a ridge of the ray density) long after the bundle has settled:
            // a membership that changed by at most 0.1 % counts as converged.
            let changed = symmetric_difference(&next, &members);
            let same = changed * 1000 <= next.len();
            members = next;
            // One pass gives the membership's energy and the sums of its axis fit.
            let sums = AxisSums::of(&places, |&k| cand.ray(k));
            let energy = sums.energy();
            if energy > best_energy * 1.001 {
                (best_energy, best_axis, stall) = (energy, (origin, axis), 0);
            } else {
                stall += 1;
                if stall >= PATIENCE {
                    (origin, axis) = best_axis;
                    break;
                }
            }
            let mut converged = same;
            if !same {
                let (o, a) = sums.solve(origin);
                let moved = (o - origin).length() / scale;
                let turned = 1.0 - a.dot(axis);
                origin = o;
                axis = a;
                converged = converged || (moved < 1e-4 && turned < 1e-7);
            }
            if converged {
                break;
            }
        }
        // The members are those of the whole pool for the final axis.
        let pool = &self.pool;
        members = self.live(pool.indices(&pool.scan(origin, axis, th.distance, th.cos_angle)));
        if members.is_empty() {
            return None;
        }
        Some(Bundle {
            origin,
            axis,
            members,
            iterations,
        })
    }
}

/// Least-squares axis: direction the energy-weighted mean direction; origin the point of
/// least summed squared distance to the member lines (slightly regularised towards the old
/// origin, for bundles of nearly parallel rays), moved along the axis to the plane of the
/// mean ray origin.
pub fn optimise_axis(rays: &[CausticRay], members: &[u32], prev: Vec3) -> (Vec3, Vec3) {
    AxisSums::of(members, |&i| {
        let r = &rays[i as usize];
        (r.weight(), r.dir, r.origin)
    })
    .solve(prev)
}

/// The energy-weighted sums of [`optimise_axis`] over a membership (deterministic parallel
/// sums): Σw (the membership's energy), Σw·d, Σw·q, Σw·d dᵀ (six distinct entries) and
/// Σw·d (d·q), from which the normal equations Σw(I − d dᵀ)·o = Σw(I − d dᵀ)·q follow.
#[derive(Clone, Copy)]
struct AxisSums([f64; 16]);

impl AxisSums {
    /// The sums over the rays `ray(k)` (weight, direction, origin) of the `members`.
    fn of<T: Sync>(members: &[T], ray: impl Fn(&T) -> (f32, Vec3, Vec3) + Sync) -> AxisSums {
        let add = |x: [f64; 16], y: [f64; 16]| std::array::from_fn(|k| x[k] + y[k]);
        AxisSums(det_fold(
            members,
            [0.0; 16],
            |k| {
                let (w, d, q) = ray(k);
                let w = w as f64;
                let [dx, dy, dz] = d.as_dvec3().to_array();
                let q = q.as_dvec3();
                let (wx, wy, wz) = (w * dx, w * dy, w * dz);
                let dq = dx * q.x + dy * q.y + dz * q.z;
                [
                    w,
                    wx,
                    wy,
                    wz,
                    w * q.x,
                    w * q.y,
                    w * q.z,
                    wx * dx,
                    wx * dy,
                    wx * dz,
                    wy * dy,
                    wy * dz,
                    wz * dz,
                    wx * dq,
                    wy * dq,
                    wz * dq,
                ]
            },
            add,
        ))
    }

    /// Σw: the membership's energy.
    fn energy(&self) -> f64 {
        self.0[0]
    }

    /// The least-squares axis (origin, unit direction), regularised towards `prev`.
    fn solve(&self, prev: Vec3) -> (Vec3, Vec3) {
        let s = &self.0;
        let w = s[0];
        let axis = DVec3::new(s[1], s[2], s[3]).normalize();
        let wq = DVec3::new(s[4], s[5], s[6]);
        let dd =
            DMat3::from_cols_array(&[s[7], s[8], s[9], s[8], s[10], s[11], s[9], s[11], s[12]]);
        let lambda = 1e-4 * w;
        let m = DMat3::IDENTITY * (w + lambda) - dd;
        let rhs = wq - DVec3::new(s[13], s[14], s[15]) + prev.as_dvec3() * lambda;
        let mut o = if m.determinant().abs() > 1e-30 {
            m.inverse() * rhs
        } else {
            prev.as_dvec3()
        };
        let qbar = wq / w;
        o += axis * (qbar - o).dot(axis);
        (o.as_vec3(), axis.as_vec3())
    }
}

#[cfg(test)]
#[path = "bundle_tests.rs"]
mod tests;
