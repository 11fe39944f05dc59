//! Stage 1 of the CSL bake: a regular grid of parallel rays over the object's silhouette, traced
//! recursively through the object alone (both Fresnel branches, total internal reflection,
//! Beer-Lambert absorption) until they leave it for good.

use super::CslParams;
use crate::trace::{Accel, optics};
use glam::Vec3;
use rayon::prelude::*;

/// A ray leaving the caustic object: where it last left the surface, its direction, and the
/// energy it carries relative to one unit per grid ray (RGB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub energy: Vec3,
}

impl CausticRay {
    /// Scalar energy used for clustering and coverage: the RGB mean.
    pub fn weight(&self) -> f32 {
        self.energy.element_sum() / 3.0
    }
}

/// The ray grid: light direction and an orthonormal frame of the plane the rays start on.
#[derive(Clone, Copy, Debug)]
pub struct RayGrid {
    pub light: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub centre: Vec3,
    pub radius: f32,
    pub n: u32,
}

impl RayGrid {
    /// Distance between neighbouring rays, metres.
    pub fn spacing(&self) -> f32 {
        2.0 * self.radius / self.n as f32
    }

    /// Start of grid ray (i, j), cell centres, on a plane 2 radii before the bounding sphere
    /// centre; None outside the projected bounding sphere (such a ray cannot hit the object).
    pub fn origin(&self, i: u32, j: u32) -> Option<Vec3> {
        let s = self.spacing();
        let x = -self.radius + (i as f32 + 0.5) * s;
        let y = -self.radius + (j as f32 + 0.5) * s;
        if x * x + y * y > self.radius * self.radius {
            return None;
        }
        Some(self.centre - self.light * (2.0 * self.radius) + self.u * x + self.v * y)
    }
}

/// Totals of the trace stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceTotals {
    /// Grid rays that hit the object.
    pub hits: u64,
    /// Energy (RGB mean) that left the object in recorded rays.
    pub exiting: f64,
    /// Energy dropped below the threshold or by the depth limit.
    pub dropped: f64,
}

/// Trace every grid ray; rows run in parallel and are concatenated in order, so the result is
/// deterministic. `progress(rows_done)` may return false to stop (then None).
pub fn trace_grid(
    accel: &Accel,
    grid: &RayGrid,
    params: &CslParams,
    progress: &(dyn Fn(u32) -> bool + Sync),
) -> Option<(Vec<CausticRay>, TraceTotals)> {
    let done = std::sync::atomic::AtomicU32::new(0);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let rows: Vec<(Vec<CausticRay>, TraceTotals)> = (0..grid.n)
        .into_par_iter()
        .map(|j| {
            let mut out = Vec::new();
            let mut stack = Vec::new();
            let mut tot = TraceTotals::default();
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return (out, tot);
            }
            for i in 0..grid.n {
                if let Some(o) = grid.origin(i, j) {
                    trace_one(accel, o, grid.light, params, &mut stack, &mut out, &mut tot);
                }
            }
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if d.is_multiple_of(16) && !progress(d) {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            (out, tot)
        })
        .collect();
    if cancel.load(std::sync::atomic::Ordering::Relaxed) {
        return None;
    }
    let mut tot = TraceTotals::default();
    let mut rays = Vec::with_capacity(rows.iter().map(|r| r.0.len()).sum());
    for (r, t) in rows {
        rays.extend(r);
        tot.hits += t.hits;
        tot.exiting += t.exiting;
        tot.dropped += t.dropped;
    }
    Some((rays, tot))
}

/// Paths waiting to be traced: (origin, direction, energy, interactions so far).
type PathStack = Vec<(Vec3, Vec3, Vec3, u32)>;

/// One grid ray: depth-first over both branches at every hit. `stack` is scratch space (empty
/// on entry and on return), kept by the caller so that a row allocates it once.
fn trace_one(
    accel: &Accel,
    origin: Vec3,
    dir: Vec3,
    params: &CslParams,
    stack: &mut PathStack,
    out: &mut Vec<CausticRay>,
    tot: &mut TraceTotals,
) {
    stack.push((origin, dir, Vec3::ONE, 0));
    while let Some((o, d, e, depth)) = stack.pop() {
        let Some(hit) = accel.intersect(o, d, f32::INFINITY) else {
            if depth > 0 {
                out.push(CausticRay {
                    origin: o,
                    dir: d,
                    energy: e,
                });
                tot.exiting += (e.element_sum() / 3.0) as f64;
            }
            continue;
        };
        if depth == 0 {
            tot.hits += 1;
        }
        let mat = accel.material(&hit);
        let e = e * optics::segment_transmittance(&hit, mat);
        if depth >= params.max_depth {
            tot.dropped += (e.element_sum() / 3.0) as f64;
            continue;
        }
        let branches = optics::specular_branches(&hit, d, mat);
        if branches.iter().all(Option::is_none) {
            // A non-specular part of the object absorbs (its diffuse light is not a caustic).
            tot.dropped += (e.element_sum() / 3.0) as f64;
            continue;
        }
        // Push refraction first so that reflection is traced first: the order is fixed, so the
        // output order is deterministic.
        for b in branches.into_iter().rev().flatten() {
            let eb = e * b.weight;
            if eb.element_sum() / 3.0 < params.min_energy {
                tot.dropped += (eb.element_sum() / 3.0) as f64;
                continue;
            }
            stack.push((hit.spawn(b.dir), b.dir, eb, depth + 1));
        }
    }
}
