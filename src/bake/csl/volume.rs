//! The extended bounding volume of the CSL bake's bundle extraction (Liu et al. 2008 §3.1.1
//! step 1): an axis-aligned cube of n³ cells, and the walk of a line through its cells (a 3D
//! DDA, Amanatides and Woo 1987) that the energy grid of [`super::bundle`] is rasterised with.

use glam::{DVec3, Vec3};

/// Fractional bits of the fixed-point minor coordinates of a [`Walk`] (2^-15 of a cell).
pub(super) const FRAC: u32 = 15;

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
pub(super) struct Walk {
    pub(super) slices: usize,
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
    pub(super) fn cells(&self, skip: u32, cells: &mut [[u32; MAX_CELLS]; 3]) {
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

    pub(super) fn hi(&self) -> Vec3 {
        self.lo + Vec3::splat(self.cell * self.n as f32)
    }

    /// Parameter interval of the infinite line o + t·d inside the box [lo, hi].
    pub(super) fn clip(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
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
    pub(super) fn walk(&self, o: Vec3, d: Vec3) -> Option<Walk> {
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
