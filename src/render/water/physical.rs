//! The physical mode: irradiance from the area ratio of a refracted grid of sun rays.
//!
//! The sun's rays through the surface points s(x, z) of a grid over the water's rectangle carry
//! E·(−L·ñ) per unit of dx·dz (ñ = (−∂h/∂x, 1, −∂h/∂z), the surface's projected area) times the
//! Fresnel transmittance; refracted by the analytic normal, each reaches a receiver point q,
//! attenuated by Beer-Lambert over |q − s|. A grid triangle's flux over the area of the
//! triangle its three points q form on the receiver is the irradiance it contributes there; a
//! receiver point gathers every triangle that covers it, so that the images of all parts of the
//! surface that focus on it add up. Triangles whose corners land on different receivers (an
//! object's silhouette) or not at all are dropped; their flux is counted as lost.

use super::{Receivers, RecvPoint, Sun, WaterParams, WaterStats};
use crate::cancel::{Canceled, KeepGoing, Stop};
use crate::sampling::frame;
use crate::scene::WaterBody;
use crate::trace::optics::{fresnel_dielectric, refract};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;

/// Where one grid vertex's refracted ray lands.
#[derive(Clone, Copy)]
struct Landing {
    q: Vec3,
    /// Length of the refracted ray, surface to receiver.
    path: f32,
    /// Geometric normal of the receiver, towards the ray's side.
    n: Vec3,
    object: u32,
    /// Flux per unit dx·dz of the grid, after Fresnel and absorption.
    w: Vec3,
}

/// Receiver points binned in a uniform grid, for the triangles to find the points they cover.
struct PointIndex {
    cell: f32,
    order: Vec<u32>,
    ranges: HashMap<(i32, i32, i32), (u32, u32)>,
}

impl PointIndex {
    fn new(points: &[RecvPoint], cell: f32) -> PointIndex {
        let key = |p: Vec3| {
            let c = (p / cell).floor();
            (c.x as i32, c.y as i32, c.z as i32)
        };
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        order.sort_unstable_by_key(|&i| key(points[i as usize].pos));
        let mut ranges = HashMap::new();
        let mut a = 0usize;
        while a < order.len() {
            let k = key(points[order[a] as usize].pos);
            let mut b = a + 1;
            while b < order.len() && key(points[order[b] as usize].pos) == k {
                b += 1;
            }
            ranges.insert(k, (a as u32, b as u32));
            a = b;
        }
        PointIndex {
            cell,
            order,
            ranges,
        }
    }

    /// Calls `f` with every point index in cells overlapping [lo, hi]; false when the box spans
    /// more than `max_cells` cells (nothing is visited).
    fn visit(&self, lo: Vec3, hi: Vec3, max_cells: i64, mut f: impl FnMut(u32)) -> bool {
        let a = (lo / self.cell).floor();
        let b = (hi / self.cell).floor();
        let n = (b - a + Vec3::ONE).max(Vec3::ZERO);
        if f64::from(n.x) * f64::from(n.y) * f64::from(n.z) > max_cells as f64 {
            return false;
        }
        for x in a.x as i32..=b.x as i32 {
            for y in a.y as i32..=b.y as i32 {
                for z in a.z as i32..=b.z as i32 {
                    if let Some(&(s, e)) = self.ranges.get(&(x, y, z)) {
                        for &i in &self.order[s as usize..e as usize] {
                            f(i);
                        }
                    }
                }
            }
        }
        true
    }
}

/// The index's cell for `points`: about four points' spacing (taken as if they covered their
/// bounding box's two largest sides evenly), within [½, 2] sun-grid cells.
fn index_cell(points: &[RecvPoint], grid_cell: f32) -> f32 {
    let (lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p.pos), hi.max(p.pos)),
    );
    let e = (hi - lo).max(Vec3::splat(1e-6)).to_array();
    let mut e = e.to_vec();
    e.sort_by(f32::total_cmp);
    let spacing = (e[1] * e[2] / points.len().max(1) as f32).sqrt();
    (4.0 * spacing).clamp(0.5 * grid_cell, 2.0 * grid_cell)
}

/// `k` directions over a disc of angular radius `r` around `dir` (a Fibonacci spiral, equal
/// areas); `dir` alone for a point-like disc.
pub fn disc_directions(dir: Vec3, r: f32, k: u32) -> Vec<Vec3> {
    if r <= 0.0 || k <= 1 {
        return vec![dir];
    }
    let (t, b) = frame(dir);
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..k)
        .map(|i| {
            let rho = r * ((i as f32 + 0.5) / k as f32).sqrt();
            let phi = i as f32 * golden;
            (dir + (t * phi.cos() + b * phi.sin()) * rho.tan()).normalize()
        })
        .collect()
}

/// E at `points` from `sun` through `body`'s surface. `keep_going` is asked before each
/// direction over the sun's disc and at each row of the grid, as its rays are traced and as
/// their triangles are splatted; Err(Canceled) once it says stop.
pub fn irradiance(
    recv: &Receivers,
    body: &WaterBody,
    sun: &Sun,
    params: &WaterParams,
    points: &[RecvPoint],
    stats: &mut WaterStats,
    keep_going: KeepGoing,
) -> Result<Vec<Vec3>, Canceled> {
    let stop = Stop::new(keep_going);
    let s = &body.surface;
    let g = params.grid.max(1);
    let cell = Vec2::new(s.size.x / g as f32, s.size.y / g as f32);
    let dirs = disc_directions(sun.dir, sun.radius, params.sun_samples);
    let k = dirs.len() as f32;
    let index = PointIndex::new(points, index_cell(points, cell.max_element()));
    let eta = 1.0 / body.ior;
    // Receivers above the water can shade the surface.
    let shade = recv.top > s.centre.y - s.amplitude_bound();
    let tol = 0.5 * cell.max_element() + 1e-4;
    // The sun's disc blurs what lands at distance d by a disc of radius d·tan r′ on the
    // receiver (r′: the disc's angular radius in the water, r·cosθᵢ/(n·cosθₜ) about the mean
    // direction); each of the k directions stands for 1/k of the disc, so its landed
    // triangles are spread over at least π(d·tan r′)²/k. A floor of a quarter cell keeps a
    // point light's cusps finite.
    let blur = {
        let cos_i = -sun.dir.y;
        let cos_t = refract(sun.dir, Vec3::Y, eta).map_or(1.0, |t| -t.y);
        (sun.radius * cos_i / (body.ior * cos_t.max(1e-3))).tan() / k.sqrt()
    };
    let floor_radius = 0.25 * cell.min_element();
    let mut total = vec![Vec3::ZERO; points.len()];
    for l in dirs {
        stop.check()?;
        if l.y >= 0.0 {
            continue;
        }
        let e_sun = sun.irradiance / k;
        let landings: Vec<Option<Landing>> = (0..(g + 1) * (g + 1))
            .into_par_iter()
            .map(|v| {
                // Asked at the start of each row.
                if !stop.go_at(v as usize, g as usize + 1) {
                    return None;
                }
                let (i, j) = (v % (g + 1), v / (g + 1));
                let x = s.centre.x + (i as f32 / g as f32 - 0.5) * s.size.x;
                let z = s.centre.z + (j as f32 / g as f32 - 0.5) * s.size.y;
                let (h, grad) = s.height_gradient(x, z);
                let p = Vec3::new(x, s.centre.y + h, z);
                let nt = Vec3::new(-grad.x, 1.0, -grad.y);
                let n = nt.normalize();
                let cos_i = -l.dot(n);
                if cos_i <= 0.0 {
                    return None;
                }
                if shade && recv.accel.occluded(p + n * 1e-4, -l, f32::INFINITY) {
                    return None;
                }
                let t = refract(l, n, eta)?;
                let fr = fresnel_dielectric(cos_i, eta);
                let o = p + t * 1e-4;
                let hit = recv.accel.intersect(o, t, f32::INFINITY)?;
                let w = e_sun * ((-l.dot(nt)) * (1.0 - fr)) * body.transmittance(o, hit.point);
                Some(Landing {
                    path: hit.t,
                    q: hit.point,
                    n: hit.geo_normal,
                    object: hit.object,
                    w,
                })
            })
            .collect();
        stop.checked()?;
        stats.rays += landings.len() as u64;
        let dxdz = cell.x * cell.y * 0.5;
        let rows = g as usize;
        let (acc, sent, kept) = (0..rows)
            .into_par_iter()
            // At most four accumulators of the points (they are the memory: 12 bytes a point
            // each), whatever the threads.
            .with_min_len(
                rows.div_ceil(rayon::current_num_threads().clamp(1, 4))
                    .max(1),
            )
            .fold(
                || (vec![Vec3::ZERO; points.len()], 0.0f64, 0.0f64),
                |(mut acc, mut sent, mut kept), j| {
                    if !stop.go() {
                        return (acc, sent, kept);
                    }
                    let at = |i: usize, j: usize| landings[j * (rows + 1) + i];
                    for i in 0..rows {
                        let quad = [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)];
                        for tri in [[0, 2, 1], [1, 2, 3]] {
                            let [a, b, c] = tri.map(|t| quad[t]);
                            let flux_of = |v: &Option<Landing>| v.map_or(Vec3::ZERO, |v| v.w);
                            let flux = (flux_of(&a) + flux_of(&b) + flux_of(&c)) * (dxdz / 3.0);
                            let f = f64::from(flux.element_sum() / 3.0);
                            sent += f;
                            let (Some(a), Some(b), Some(c)) = (a, b, c) else {
                                continue;
                            };
                            if a.object != b.object
                                || a.object != c.object
                                || a.n.dot(b.n) < 0.99
                                || a.n.dot(c.n) < 0.99
                            {
                                continue;
                            }
                            let d = (a.path + b.path + c.path) / 3.0;
                            let min_area =
                                std::f32::consts::PI * (d * blur).max(floor_radius).powi(2);
                            let q = [a.q, b.q, c.q];
                            if splat(&index, points, &mut acc, q, a.n, flux, min_area, tol) {
                                kept += f;
                            }
                        }
                    }
                    (acc, sent, kept)
                },
            )
            .reduce(
                || (vec![Vec3::ZERO; points.len()], 0.0, 0.0),
                |(mut a, s1, k1), (b, s2, k2)| {
                    a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                    (a, s1 + s2, k1 + k2)
                },
            );
        stop.checked()?;
        total.iter_mut().zip(acc).for_each(|(t, a)| *t += a);
        stats.flux_transmitted += sent;
        stats.flux_splatted += kept;
    }
    Ok(total)
}

/// Adds the irradiance `flux / area` of the landed triangle `q` (receiver normal `n`) to every
/// point it covers (within `tol` of its plane, facing the same way); a triangle smaller than
/// `min_area` is first grown about its centroid to that area. False when the triangle is
/// degenerate or too large to splat.
#[allow(clippy::too_many_arguments)]
fn splat(
    index: &PointIndex,
    points: &[RecvPoint],
    acc: &mut [Vec3],
    mut q: [Vec3; 3],
    n: Vec3,
    flux: Vec3,
    min_area: f32,
    tol: f32,
) -> bool {
    let mut cr = (q[1] - q[0]).cross(q[2] - q[0]);
    let mut area2 = cr.length();
    if area2 <= 1e-14 {
        return false;
    }
    if area2 < 2.0 * min_area {
        let c = (q[0] + q[1] + q[2]) / 3.0;
        let s = (2.0 * min_area / area2).sqrt();
        q = q.map(|v| c + (v - c) * s);
        cr = (q[1] - q[0]).cross(q[2] - q[0]);
        area2 = cr.length();
    }
    let (e1, e2) = (q[1] - q[0], q[2] - q[0]);
    let nt = cr / area2;
    let e = flux * (2.0 / area2);
    let lo = q[0].min(q[1]).min(q[2]) - Vec3::splat(tol);
    let hi = q[0].max(q[1]).max(q[2]) + Vec3::splat(tol);
    // Barycentric coordinates in the triangle's plane.
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d00 * d11 - d01 * d01;
    if den <= 0.0 {
        return false;
    }
    // Room for any triangle up to four times the sun's blur, and some.
    let blur_cells = 4.0 * min_area.sqrt() / index.cell + 2.0;
    let max_cells = (blur_cells * blur_cells * 2.0).max(4096.0) as i64;
    index.visit(lo, hi, max_cells, |i| {
        let p = &points[i as usize];
        if p.normal.dot(n) < 0.9 {
            return;
        }
        let v = p.pos - q[0];
        if v.dot(nt).abs() > tol {
            return;
        }
        let (d20, d21) = (v.dot(e1), v.dot(e2));
        let b1 = (d11 * d20 - d01 * d21) / den;
        let b2 = (d00 * d21 - d01 * d20) / den;
        if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 {
            acc[i as usize] += e;
        }
    })
}
