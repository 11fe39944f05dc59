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
//! The pool of rays not yet in a CSL is kept as a compact index list, so later bundles do not
//! scan the rays earlier ones took. Within one extraction, assignment iterates over a candidate
//! list (the pool's rays within relaxed thresholds of the axis, refreshed when the axis has moved
//! far from where it was taken), and the final membership is taken by one pass over the whole
//! pool with the final axis. Convergence: the membership changed by at most 0.1 % (or the axis
//! stopped moving), within the paper's cap of 100 iterations; a bundle whose membership keeps
//! swinging ends after 12 iterations without a more energetic membership, on the axis of the
//! most energetic one.

use super::trace::CausticRay;
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

    /// Visit every cell the infinite line o + t·d passes through (Amanatides-Woo 3D DDA).
    ///
    /// The number of cells is known from the entry and exit cells, so the walk needs no exit
    /// test, and it steps a linear cell index by a precomputed stride: the axis to step is
    /// chosen without branches (this loop runs a few hundred million times in a bake). An axis
    /// that has made all its steps takes no more, so rounding can never lead outside the grid.
    #[inline]
    pub fn dda(&self, o: Vec3, d: Vec3, mut visit: impl FnMut(usize)) {
        let Some((t0, t1)) = Self::clip(o, d, self.lo, self.hi()) else {
            return;
        };
        let n = self.n as i64;
        let cell_of = |p: f32| ((p / self.cell).floor() as i64).clamp(0, n - 1);
        let start = o + d * t0 - self.lo;
        let end = o + d * t1 - self.lo;
        let stride = [1i64, n, n * n];
        let mut idx = 0i64;
        let mut count = 1i64;
        let mut left = [0i64; 3];
        let mut jump = [0i64; 3];
        let mut tmax = [f32::INFINITY; 3];
        let mut tdelta = [f32::INFINITY; 3];
        for k in 0..3 {
            let c = cell_of(start[k]);
            let e = cell_of(end[k]);
            idx += c * stride[k];
            let rel = start[k] / self.cell;
            if d[k] > 1e-12 && e > c {
                left[k] = e - c;
                jump[k] = stride[k];
                tdelta[k] = self.cell / d[k];
                tmax[k] = t0 + ((c + 1) as f32 - rel) * tdelta[k];
            } else if d[k] < -1e-12 && e < c {
                left[k] = c - e;
                jump[k] = -stride[k];
                tdelta[k] = -self.cell / d[k];
                tmax[k] = t0 + (rel - c as f32) * tdelta[k];
            }
            count += left[k];
        }
        // Scalars rather than arrays indexed by the axis, so that the loop state stays in
        // registers and every choice is a select, not a branch.
        let [mut tx, mut ty, mut tz] = tmax;
        let [dx, dy, dz] = tdelta;
        let [mut lx, mut ly, mut lz] = left;
        let [jx, jy, jz] = jump;
        visit(idx as usize);
        for _ in 1..count {
            let sx = tx <= ty && tx <= tz;
            let sy = !sx && ty <= tz;
            let sz = !sx && !sy;
            idx += if sx { jx } else { 0 } + if sy { jy } else { 0 } + if sz { jz } else { 0 };
            lx -= sx as i64;
            ly -= sy as i64;
            lz -= sz as i64;
            tx = if lx == 0 {
                f32::INFINITY
            } else if sx {
                tx + dx
            } else {
                tx
            };
            ty = if ly == 0 {
                f32::INFINITY
            } else if sy {
                ty + dy
            } else {
                ty
            };
            tz = if lz == 0 {
                f32::INFINITY
            } else if sz {
                tz + dz
            } else {
                tz
            };
            visit(idx as usize);
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
    /// Indices of the alive rays, ascending.
    pool: Vec<u32>,
    pub volume: Volume,
    grid: Vec<u64>,
    blocked: Vec<bool>,
    fixed: Vec<u64>,
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
    idx.par_chunks(chunk)
        .map(|part| {
            let mut g = vec![0u64; cells];
            for &i in part {
                let r = &rays[i as usize];
                let e = fixed[i as usize];
                volume.dda(r.origin, r.dir, |c| g[c] = g[c].wrapping_add(e));
            }
            g
        })
        .reduce_with(|mut a, b| {
            for (x, y) in a.iter_mut().zip(&b) {
                *x = x.wrapping_add(*y);
            }
            a
        })
        .unwrap_or_else(|| vec![0; cells])
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

/// The rays of `idx` within thresholds `distance`, `cos_angle` of the axis line (b, a), in order.
fn assign(rays: &[CausticRay], idx: &[u32], b: Vec3, a: Vec3, distance: f32, cos: f32) -> Vec<u32> {
    let d2 = distance * distance;
    idx.par_iter()
        .copied()
        .filter(|&i| {
            let r = &rays[i as usize];
            r.dir.dot(a) >= cos && line_distance_within(r.origin, r.dir, b, a, d2)
        })
        .collect()
}

/// [`line_distance`] ≤ √`d2`, without a square root or a division.
#[inline]
fn line_distance_within(q: Vec3, d: Vec3, b: Vec3, a: Vec3, d2: f32) -> bool {
    let n = d.cross(a);
    let l2 = n.length_squared();
    let qb = q - b;
    if l2 > 1e-12 {
        let x = qb.dot(n);
        x * x <= d2 * l2
    } else {
        qb.cross(a).length_squared() <= d2
    }
}

impl<'a> Extractor<'a> {
    /// Rasterise every ray (parallel; exact integer sums).
    pub fn new(rays: &'a [CausticRay], volume: Volume) -> Self {
        let cells = (volume.n as usize).pow(3);
        let fixed: Vec<u64> = rays
            .par_iter()
            .map(|r| (r.weight() as f64 * FIXED).round() as u64)
            .collect();
        let pool: Vec<u32> = (0..rays.len() as u32).collect();
        let grid = rasterise(rays, &fixed, &pool, volume);
        Extractor {
            rays,
            alive: vec![true; rays.len()],
            pool,
            volume,
            grid,
            blocked: vec![false; cells],
            fixed,
        }
    }

    /// Take rays out of the pool, subtracting their energy from the grid.
    pub fn remove(&mut self, members: &[u32]) {
        for &m in members {
            self.alive[m as usize] = false;
        }
        let alive = &self.alive;
        self.pool.retain(|&i| alive[i as usize]);
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

    /// Energy (RGB mean) of the rays still in the pool.
    pub fn remaining_energy(&self) -> f64 {
        self.pool
            .iter()
            .map(|&i| self.rays[i as usize].weight() as f64)
            .sum()
    }

    /// Grow a bundle from the rays through `cell`: seed axis from their energy-weighted means,
    /// then assignment and least-squares optimisation until the axis converges.
    pub fn extract(&self, cell: usize, th: &Thresholds, scale: f32) -> Option<Bundle> {
        let (lo, hi) = self.volume.cell_bounds(cell);
        let seed: Vec<u32> = self
            .pool
            .par_iter()
            .copied()
            .filter(|&i| {
                let r = &self.rays[i as usize];
                Volume::line_hits_box(r.origin, r.dir, lo, hi)
            })
            .collect();
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
        let take =
            |o: Vec3, a: Vec3| assign(self.rays, &self.pool, o, a, 2.0 * th.distance, relaxed_cos);
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
            let next = assign(self.rays, &cand, origin, axis, th.distance, th.cos_angle);
            if next.is_empty() {
                return None;
            }
            // Assignment and axis fit can keep trading a few boundary rays (a short cycle, or a
            // slow drift along a ridge of the ray density) long after the bundle has settled:
            // a membership that changed by at most 0.1 % counts as converged.
            let changed = symmetric_difference(&next, &members);
            let same = changed * 1000 <= next.len();
            members = next;
            let energy = det_sum(&members, 0.0, |&i| self.rays[i as usize].weight() as f64);
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
                let (o, a) = optimise_axis(self.rays, &members, origin);
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
        members = assign(
            self.rays,
            &self.pool,
            origin,
            axis,
            th.distance,
            th.cos_angle,
        );
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
    #[derive(Clone, Copy)]
    struct Acc {
        w: f64,
        d: DVec3,
        q: DVec3,
        m: DMat3,
        rhs: DVec3,
    }
    impl std::ops::Add for Acc {
        type Output = Acc;
        fn add(self, o: Acc) -> Acc {
            Acc {
                w: self.w + o.w,
                d: self.d + o.d,
                q: self.q + o.q,
                m: self.m + o.m,
                rhs: self.rhs + o.rhs,
            }
        }
    }
    let zero = Acc {
        w: 0.0,
        d: DVec3::ZERO,
        q: DVec3::ZERO,
        m: DMat3::ZERO,
        rhs: DVec3::ZERO,
    };
    let acc = det_sum(members, zero, |&i| {
        let r = &rays[i as usize];
        let w = r.weight() as f64;
        let d = r.dir.as_dvec3();
        let q = r.origin.as_dvec3();
        let p = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        Acc {
            w,
            d: d * w,
            q: q * w,
            m: p * w,
            rhs: (p * q) * w,
        }
    });
    let axis = acc.d.normalize();
    let lambda = 1e-4 * acc.w;
    let m = acc.m + DMat3::IDENTITY * lambda;
    let rhs = acc.rhs + prev.as_dvec3() * lambda;
    let mut o = if m.determinant().abs() > 1e-30 {
        m.inverse() * rhs
    } else {
        prev.as_dvec3()
    };
    let qbar = acc.q / acc.w;
    o += axis * (qbar - o).dot(axis);
    (o.as_vec3(), axis.as_vec3())
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
        let mut rng = crate::reference::sampling::Pcg::new(7, 1);
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
        let mut rng = crate::reference::sampling::Pcg::new(5, 3);
        let unit = |rng: &mut crate::reference::sampling::Pcg| {
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
                    assert_eq!(
                        line_distance_within(q, d, b, a, t * t),
                        dist <= t,
                        "{dist} {t}"
                    );
                }
            }
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
