//! Stage 2 of the CSL bake, bundle extraction (§3.1.1): the lines of the caustic rays are
//! rasterised with a 3D DDA into the cells of an extended bounding volume (energy per cell);
//! a bundle axis starts from the rays through the cell of most energy and is refined by
//! alternating ray assignment (line distance and angle thresholds) and a least-squares axis fit.
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

/// Fractional bits of the fixed-point minor coordinates of a [`Walk`] (2^-15 of a cell).
const FRAC: u32 = 15;

/// Most cells per axis of a [`Volume`] (and so most slices of a walk).
pub const MAX_CELLS: usize = 256;

/// The cells of one line, slice by slice across its major axis. Every slice holds one to three
/// of them: where the line enters the slice, where it leaves, and between them the cell of
/// whichever minor axis it crosses first (the two minor axes cannot step more than once a
/// slice). The minor coordinates at slice `j`'s boundaries are `y[0] + j·y[1]` in fixed point,
/// held to the line's entry and exit values `y[2]..=y[3]`, so every slice is computed on its
/// own, without branches, eight at a time: a walk that picks the next axis from the last
/// crossing times waits on every comparison. The result is that of a 3D DDA (Amanatides-Woo)
/// up to the choice between two minor crossings less than 2^-15 of a cell apart.
struct Walk {
    slices: usize,
    /// Minor axis 1: coordinate at the first slice's start, step per slice, entry and exit.
    y: [i32; 4],
    /// Minor axis 2, the same.
    z: [i32; 4],
    /// Cell index at the first slice, minor coordinates 0.
    at: i32,
    /// Index strides of the major and the two minor axes (negative for mirrored axes).
    stride: [i32; 3],
}

impl Walk {
    /// Per slice j: `cells[0][j]` the cell the line enters, `cells[1][j]` the cell between,
    /// `cells[2][j]` the cell it leaves by; a slice without a cell between or with a single
    /// cell gets `skip + (j mod 8)` instead (eight distinct dummies, so that adding to them
    /// does not make one long chain of memory updates).
    #[inline(always)]
    fn cells(&self, skip: u32, cells: &mut [[u32; MAX_CELLS]; 3]) {
        let [y, dy, y0, y1] = self.y;
        let [z, dz, z0, z1] = self.z;
        let [jm, jy, jz] = self.stride;
        let [first, mid, last] = cells;
        let n = self.slices.min(MAX_CELLS);
        for j in 0..n {
            let ji = j as i32;
            let (ya, za) = (y + ji * dy, z + ji * dz);
            let (yb, zb) = (ya + dy, za + dz);
            let (yi, yo) = (ya.clamp(y0, y1), yb.clamp(y0, y1));
            let (zi, zo) = (za.clamp(z0, z1), zb.clamp(z0, z1));
            let (cyi, czi) = (yi >> FRAC, zi >> FRAC);
            let cyo = (yo >> FRAC).min(cyi + 1);
            let czo = (zo >> FRAC).min(czi + 1);
            let (ny, nz) = (cyo - cyi, czo - czi);
            // Minor axis 1 is crossed first when (its boundary − y)/dy ≤ (… z)/dz.
            let y_first = ((cyo << FRAC) - yi) * dz <= ((czo << FRAC) - zi) * dy;
            let f = self.at + ji * jm + cyi * jy + czi * jz;
            let m = if y_first { f + ny * jy } else { f + nz * jz };
            let l = f + ny * jy + nz * jz;
            let dummy = skip + (j as u32 & 7);
            first[j] = f as u32;
            mid[j] = if ny & nz != 0 { m as u32 } else { dummy };
            last[j] = if ny | nz != 0 { l as u32 } else { dummy };
        }
    }
}

/// Axis-aligned cube cut into n³ cells.
#[derive(Clone, Copy, Debug)]
pub struct Volume {
    pub lo: Vec3,
    pub cell: f32,
    pub n: u32,
}

impl Volume {
    /// The cube of half-size `half` around `centre`, `n` cells per axis.
    pub fn new(centre: Vec3, half: f32, n: u32) -> Volume {
        Volume {
            lo: centre - Vec3::splat(half),
            cell: 2.0 * half / n as f32,
            n,
        }
    }

    fn hi(&self) -> Vec3 {
        self.lo + Vec3::splat(self.cell * self.n as f32)
    }

    /// Parameter interval of the infinite line o + t·d inside the box [lo, hi].
    fn clip(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
        for k in 0..3 {
            if d[k].abs() < 1e-12 {
                if o[k] < lo[k] || o[k] > hi[k] {
                    return None;
                }
            } else {
                let a = (lo[k] - o[k]) / d[k];
                let b = (hi[k] - o[k]) / d[k];
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// The walk of the infinite line o + t·d through the volume, slice by slice across its
    /// major axis (see [`Walk`]); None when the line misses the volume.
    #[inline(always)]
    fn walk(&self, o: Vec3, d: Vec3) -> Option<Walk> {
        let (t0, t1) = Self::clip(o, d, self.lo, self.hi())?;
        let n = self.n as i64;
        let inv = 1.0 / self.cell as f64;
        let p0 = (o + d * t0 - self.lo).as_dvec3() * inv;
        let p1 = (o + d * t1 - self.lo).as_dvec3() * inv;
        let dd = d.as_dvec3();
        let ad = dd.abs();
        let m = if ad.x >= ad.y && ad.x >= ad.z {
            0
        } else if ad.y >= ad.z {
            1
        } else {
            2
        };
        let (k1, k2) = ((m + 1) % 3, (m + 2) % 3);
        let strides = [1i64, n, n * n];
        // Mirror backward axes (coordinate c → n − c, cell i → n − 1 − i), so that the walk
        // runs forwards along every axis.
        let mut at = 0i64;
        let mut stride = strides;
        let (mut q0, mut q1) = (p0.to_array(), p1.to_array());
        for k in 0..3 {
            if dd[k] < 0.0 {
                at += (n - 1) * strides[k];
                stride[k] = -strides[k];
                q0[k] = n as f64 - q0[k];
                q1[k] = n as f64 - q1[k];
            }
        }
        let cell_of = |x: f64| (x.max(0.0) as i64).min(n - 1);
        let (s0, s1) = (cell_of(q0[m]), cell_of(q1[m]));
        let top = (n << FRAC) - 1;
        // A minor coordinate at x = s0 (fixed point), its step per slice (at most one cell: the
        // minor axes are no steeper than the major one) and its values where the line enters
        // and leaves the volume. A function, not a closure, so that it is inlined into the
        // rasterisation's vector code (where rounding is an instruction, not a call).
        #[inline(always)]
        fn minor(
            k: usize,
            m: usize,
            ad: DVec3,
            [q0, q1]: [[f64; 3]; 2],
            s0: i64,
            top: i64,
        ) -> [i32; 4] {
            let one = (1i64 << FRAC) as f64;
            let fixed = |x: f64| ((x * one).round_ties_even() as i64).clamp(0, top);
            let slope = ad[k] / ad[m];
            let step = ((slope * one).round_ties_even() as i64).min(1 << FRAC);
            let at_s0 = ((q0[k] + slope * (s0 as f64 - q0[m])) * one).round_ties_even() as i64;
            let (lo, hi) = (fixed(q0[k]), fixed(q1[k].max(q0[k])));
            [at_s0, step, lo, hi].map(|v| v as i32)
        }
        Some(Walk {
            slices: (s1 - s0 + 1) as usize,
            y: minor(k1, m, ad, [q0, q1], s0, top),
            z: minor(k2, m, ad, [q0, q1], s0, top),
            at: (at + s0 * stride[m]) as i32,
            stride: [stride[m], stride[k1], stride[k2]].map(|v| v as i32),
        })
    }

    /// Visit every cell the infinite line o + t·d passes through, in order along the line
    /// (the cells `Walk::cells` lists).
    pub fn dda(&self, o: Vec3, d: Vec3, mut visit: impl FnMut(usize)) {
        let Some(w) = self.walk(o, d) else {
            return;
        };
        let skip = u32::MAX - 7;
        let mut cells = [[0u32; MAX_CELLS]; 3];
        w.cells(skip, &mut cells);
        for j in 0..w.slices {
            for list in &cells {
                if list[j] < skip {
                    visit(list[j] as usize);
                }
            }
        }
    }

    /// Bounds of cell `idx`.
    pub fn cell_bounds(&self, idx: usize) -> (Vec3, Vec3) {
        let n = self.n as usize;
        let (x, y, z) = (idx % n, (idx / n) % n, idx / (n * n));
        let lo = self.lo + Vec3::new(x as f32, y as f32, z as f32) * self.cell;
        (lo, lo + Vec3::splat(self.cell))
    }

    /// True when the line o + t·d meets the box.
    pub fn line_hits_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> bool {
        Self::clip(o, d, lo, hi).is_some()
    }
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
mod tests {
    use super::*;
    use glam::IVec3;

    #[test]
    fn dda_visits_the_cells_of_a_diagonal_and_an_axis_line() {
        let v = Volume::new(Vec3::ZERO, 1.0, 4);
        let mut cells = Vec::new();
        v.dda(Vec3::new(-0.9, -0.9, -0.9), Vec3::ONE.normalize(), |c| {
            cells.push(c)
        });
        // Through the main diagonal: (0,0,0), (1,1,1), (2,2,2), (3,3,3) and the cells where it
        // touches edges; all visited cells are distinct and include the four diagonal cells.
        for k in 0..4 {
            assert!(cells.contains(&(k * 16 + k * 4 + k)), "{cells:?}");
        }
        let mut sorted = cells.clone();
        sorted.dedup();
        assert_eq!(sorted.len(), cells.len());
        // A line along +x at y = z = 0.1 (cell 2 in y and z): 4 cells, in order.
        let mut cells = Vec::new();
        v.dda(Vec3::new(5.0, 0.1, 0.1), Vec3::NEG_X, |c| cells.push(c));
        assert_eq!(cells, vec![43, 42, 41, 40]);
        // A line missing the cube visits nothing.
        let mut n = 0;
        v.dda(Vec3::new(0.0, 2.0, 0.0), Vec3::X, |_| n += 1);
        assert_eq!(n, 0);
    }

    #[test]
    fn dda_visits_exactly_the_cells_a_line_passes_through() {
        // Random lines through and past a 16³ grid: the cells visited are distinct, each next
        // to the one before (sharing a face), each met by the line, and every cell that a dense
        // sampling of the line finds (away from cell boundaries) is among them.
        let v = Volume::new(Vec3::new(0.3, -0.2, 0.1), 2.0, 16);
        let mut rng = crate::sampling::Pcg::new(7, 1);
        let mut lines = 0;
        for _ in 0..2000 {
            let o = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 6.0 - 3.0;
            let d = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0).normalize();
            let mut cells = Vec::new();
            v.dda(o, d, |c| cells.push(c));
            let Some((t0, t1)) = Volume::clip(o, d, v.lo, v.hi()) else {
                assert!(cells.is_empty());
                continue;
            };
            lines += 1;
            let coords = |c: usize| [c % 16, (c / 16) % 16, c / 256].map(|x| x as i64);
            let mut sorted = cells.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), cells.len(), "a cell visited twice");
            for w in cells.windows(2) {
                let (a, b) = (coords(w[0]), coords(w[1]));
                let steps: i64 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
                assert_eq!(
                    steps, 1,
                    "cells {} and {} are not face neighbours",
                    w[0], w[1]
                );
            }
            for &c in &cells {
                let (lo, hi) = v.cell_bounds(c);
                let pad = Vec3::splat(1e-4);
                assert!(
                    Volume::line_hits_box(o, d, lo - pad, hi + pad),
                    "cell {c} off the line"
                );
            }
            for k in 0..=1000 {
                let p = o + d * (t0 + (t1 - t0) * k as f32 / 1000.0);
                let rel = (p - v.lo) / v.cell;
                let frac = rel - rel.floor();
                if frac.min_element() < 1e-3 || frac.max_element() > 1.0 - 1e-3 {
                    continue;
                }
                let c = rel.floor().as_ivec3().clamp(IVec3::ZERO, IVec3::splat(15));
                let idx = (c.z * 256 + c.y * 16 + c.x) as usize;
                assert!(cells.contains(&idx), "cell {idx} on the line not visited");
            }
        }
        assert!(lines > 500, "{lines}");
    }

    #[test]
    fn line_distance_test_agrees_with_the_distance() {
        let mut rng = crate::sampling::Pcg::new(5, 3);
        let unit = |rng: &mut crate::sampling::Pcg| {
            (Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0).normalize()
        };
        for k in 0..5000 {
            let q = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
            let b = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
            let a = unit(&mut rng);
            // Every tenth line is parallel to the axis.
            let d = if k % 10 == 0 { a } else { unit(&mut rng) };
            let dist = line_distance(q, d, b, a);
            for t in [0.2f32, 0.5, 1.0] {
                if (dist - t).abs() > 1e-4 {
                    assert_eq!(within(q, d, b, a, t * t, -2.0), dist <= t, "{dist} {t}");
                }
            }
        }
    }

    /// Random caustic rays around the origin, every tenth along a coordinate axis.
    fn random_rays(count: usize, seed: u64) -> Vec<CausticRay> {
        let mut rng = crate::sampling::Pcg::new(seed, 11);
        (0..count)
            .map(|k| {
                let mut v = || Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
                let origin = v() * 2.0;
                let dir = if k % 10 == 0 {
                    [Vec3::X, Vec3::NEG_Y, Vec3::Z][k / 10 % 3]
                } else {
                    v().normalize()
                };
                CausticRay {
                    origin,
                    dir,
                    energy: v().abs(),
                }
            })
            .collect()
    }

    #[test]
    fn column_scans_pass_the_rays_the_single_ray_tests_pass() {
        let rays = random_rays(20_000, 3);
        let idx: Vec<u32> = (0..rays.len() as u32).step_by(3).collect();
        let cols = Columns::of(&rays, &idx);
        let (b, a) = (
            Vec3::new(0.1, 0.2, -0.1),
            Vec3::new(0.3, 0.9, -0.2).normalize(),
        );
        for (dist, cos) in [(0.3f32, 0.5f32), (1.0, -1.0), (0.05, 0.9)] {
            let want: Vec<u32> = (0..idx.len() as u32)
                .filter(|&p| {
                    let r = &rays[idx[p as usize] as usize];
                    within(r.origin, r.dir, b, a, dist * dist, cos)
                })
                .collect();
            assert!(!want.is_empty());
            assert_eq!(cols.scan(b, a, dist, cos), want);
        }
        let (lo, hi) = (Vec3::new(-0.2, -0.1, 0.0), Vec3::new(0.1, 0.3, 0.25));
        let want: Vec<u32> = (0..idx.len() as u32)
            .filter(|&p| {
                let r = &rays[idx[p as usize] as usize];
                Volume::line_hits_box(r.origin, r.dir, lo, hi)
            })
            .collect();
        assert!(!want.is_empty());
        assert_eq!(cols.meeting_box(lo, hi), want);
        // Selecting and retaining keep indices and columns together.
        let mut sub = cols.select(&want);
        sub.retain(|i| i % 2 == 0);
        for (p, &i) in sub.idx.iter().enumerate() {
            assert_eq!(i % 2, 0);
            assert_eq!(sub.o[1][p], rays[i as usize].origin.y);
            assert_eq!(sub.d[2][p], rays[i as usize].dir.z);
        }
    }

    #[test]
    fn rasterised_grid_is_the_energy_of_the_cells_each_line_visits() {
        // The grid (parallel shares, vector walk, dummy cells) against the cells the plain
        // walk visits, added one line at a time; and removing rays subtracts them exactly.
        let rays = random_rays(3000, 4);
        let volume = Volume::new(Vec3::new(0.1, 0.0, -0.1), 1.5, 24);
        // With a search sample (stride 4) only its lines are in the grid.
        let mut ex = Extractor::new(&rays, volume, 4);
        let grid_of = |keep: &dyn Fn(u32) -> bool, ex: &Extractor| {
            let mut want = vec![0u64; 24 * 24 * 24];
            for (i, (r, &e)) in rays.iter().zip(&ex.fixed).enumerate() {
                if keep(i as u32) && in_search_sample(i as u32, 4) {
                    volume.dda(r.origin, r.dir, |c| want[c] += e);
                }
            }
            want
        };
        assert_eq!(ex.grid, grid_of(&|_| true, &ex));
        assert!(ex.grid.iter().any(|&e| e > 0));
        // Without one, every line.
        let every = Extractor::new(&rays, volume, 1);
        let mut want = vec![0u64; 24 * 24 * 24];
        for (r, &e) in rays.iter().zip(&every.fixed) {
            volume.dda(r.origin, r.dir, |c| want[c] += e);
        }
        assert_eq!(every.grid, want);
        let gone: Vec<u32> = (0..rays.len() as u32).filter(|i| i % 3 == 1).collect();
        ex.remove(&gone, false);
        assert_eq!(ex.grid, grid_of(&|i| i % 3 != 1, &ex));
        assert_eq!(ex.pool.len(), rays.len() - gone.len());
        // The search sample loses the same rays.
        let sample = ex.sample.as_ref().unwrap();
        assert!(
            sample
                .idx
                .iter()
                .all(|&i| i % 3 != 1 && in_search_sample(i, 4))
        );
        let want = (0..rays.len() as u32)
            .filter(|&i| i % 3 != 1 && in_search_sample(i, 4))
            .count();
        assert_eq!(sample.len(), want);
        // Removed in place, on this thread: the same exact sums.
        let gone: Vec<u32> = (0..rays.len() as u32).filter(|i| i % 3 == 2).collect();
        ex.remove(&gone, true);
        assert_eq!(ex.grid, grid_of(&|i| i % 3 == 0, &ex));
    }

    /// A bundle focused at (0, 0, -1) from a disc at z = 1 (drawn from `Pcg::new(seed, stream)`),
    /// among as many scattered rays ([`random_rays`] seeded `scatter`), with a volume and
    /// thresholds for it.
    fn focused_bundle(
        (seed, stream): (u64, u64),
        scatter: u64,
    ) -> (Vec<CausticRay>, Volume, Thresholds) {
        let mut rng = crate::sampling::Pcg::new(seed, stream);
        let mut rays = random_rays(20_000, scatter);
        for _ in 0..20_000 {
            let (r, phi) = (0.3 * rng.f32().sqrt(), std::f32::consts::TAU * rng.f32());
            let origin = Vec3::new(r * phi.cos(), r * phi.sin(), 1.0);
            let jitter = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 0.02 - 0.01;
            rays.push(CausticRay {
                origin,
                dir: (Vec3::new(0.0, 0.0, -1.0) + jitter - origin).normalize(),
                energy: Vec3::ONE,
            });
        }
        let volume = Volume::new(Vec3::ZERO, 3.0, 32);
        let th = Thresholds {
            distance: 0.1,
            cos_angle: 60f32.to_radians().cos(),
            max_iterations: 100,
        };
        (rays, volume, th)
    }

    #[test]
    fn the_search_sample_takes_every_branch_alike_and_finds_the_same_bundle() {
        let strides = [128, 512, 905, 906, 1280].map(search_stride);
        assert_eq!(strides, [1, 1, 1, 2, 4]);
        // A quarter of the indices of every residue: a grid ray's tree of paths leaves its rays
        // in a fixed order, and no branch may be left out of the search.
        for r in 0..4u32 {
            let n = (0..40_000u32)
                .filter(|&i| i % 4 == r && in_search_sample(i, 4))
                .count();
            assert!((2300..2700).contains(&n), "residue {r}: {n} of 10000");
        }
        let (rays, volume, th) = focused_bundle((7, 3), 9);
        let [all, sampled] = [1, 4].map(|stride| {
            let ex = Extractor::new(&rays, volume, stride);
            ex.extract(ex.max_cell().unwrap(), &th, 1.0).unwrap()
        });
        assert!(all.members.len() > 15_000, "{}", all.members.len());
        assert!(all.axis.dot(sampled.axis) > (0.5f32).to_radians().cos());
        assert!(line_distance(all.origin, all.axis, sampled.origin, sampled.axis) < 0.005);
        let changed = symmetric_difference(&all.members, &sampled.members);
        assert!(changed * 100 < all.members.len(), "{changed}");
    }

    #[test]
    fn removed_rays_left_in_the_columns_are_passed_over() {
        // A focused bundle among scattered rays; a few of its rays removed: extraction gives
        // the same bundle, bit for bit, whether the columns still hold them or not.
        let (rays, volume, th) = focused_bundle((5, 11), 3);
        for stride in [1, 4] {
            let mut lazy = Extractor::new(&rays, volume, stride);
            let first = lazy.extract(lazy.max_cell().unwrap(), &th, 1.0).unwrap();
            // One in 40 of the bundle's rays, and a few scattered ones.
            let gone: Vec<u32> = first
                .members
                .iter()
                .copied()
                .filter(|i| i % 40 == 7 || *i < 300)
                .collect();
            lazy.remove(&gone, false);
            assert!(lazy.dead > 0, "stride {stride}: the columns were compacted");
            let mut compacted = Extractor::new(&rays, volume, stride);
            compacted.remove(&gone, false);
            compacted.compact();
            assert_eq!(lazy.remaining_energy(), compacted.remaining_energy());
            let cell = lazy.max_cell().unwrap();
            assert_eq!(cell, compacted.max_cell().unwrap());
            let (a, b) = (
                lazy.extract(cell, &th, 1.0).unwrap(),
                compacted.extract(cell, &th, 1.0).unwrap(),
            );
            assert!(a.members.len() > 15_000, "{}", a.members.len());
            assert!(a.members.iter().all(|&i| lazy.alive[i as usize]));
            assert_eq!(a.members, b.members);
            assert_eq!((a.origin, a.axis), (b.origin, b.axis));
        }
    }

    #[test]
    fn walks_stay_in_the_largest_volume() {
        // 256 cells a side: fixed-point coordinates and indices stay in range (debug builds
        // check the arithmetic for overflow), and every line's cells are face neighbours.
        let v = Volume::new(Vec3::ZERO, 1.0, MAX_CELLS as u32);
        let n = MAX_CELLS;
        for r in random_rays(300, 5) {
            let mut cells = Vec::new();
            v.dda(r.origin, r.dir, |c| cells.push(c));
            for w in cells.windows(2) {
                let coords = |c: usize| [c % n, (c / n) % n, c / (n * n)].map(|x| x as i64);
                let (a, b) = (coords(w[0]), coords(w[1]));
                let steps: i64 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
                assert_eq!(steps, 1);
            }
            assert!(cells.iter().all(|&c| c < n * n * n));
        }
    }

    #[test]
    fn line_distance_of_skew_and_parallel_lines() {
        let d = line_distance(Vec3::new(0.0, 0.0, 1.0), Vec3::X, Vec3::ZERO, Vec3::Y);
        assert!((d - 1.0).abs() < 1e-6);
        let d = line_distance(Vec3::new(0.0, 0.0, 2.0), Vec3::Y, Vec3::ZERO, Vec3::Y);
        assert!((d - 2.0).abs() < 1e-6);
    }
}
