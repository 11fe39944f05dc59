//! The article's mode (Sánchez-Crespo 2003): backward from each receiver point.
//!
//! From the point q a ray goes towards the sun as the flat surface would refract it (the
//! article sends it straight up, for a sun overhead; here the sun may stand anywhere) to the
//! wave surface at s; the surface normal at s (analytic gradient, or finite differences in the
//! per-vertex variant as in the article's first version) refracts the ray out into the air,
//! and the closer it comes to the sun the brighter q is: the "sun map", here
//! b(θ) = exp(−(θ/width)²) of the angle θ between the refracted ray and the sun. The irradiance
//! is that of the flat surface, E·cosθᵢ·T_Fresnel/cosθₜ on a surface facing the refracted sun,
//! times b·k and the Beer-Lambert attenuation over |q − s|; the calibration k makes b's mean
//! over the water's floor 1, so that the mean irradiance is right (the article's brightness
//! has no physical scale: it says so itself).

use super::{Receivers, RecvPoint, Sun, WaterParams, WaterStats, refracted_sun};
use crate::cancel::{Canceled, KeepGoing, Stop};
use crate::scene::{WaterBody, WaterSurface};
use crate::trace::optics::{fresnel_dielectric, refract};
use glam::Vec3;
use rayon::prelude::*;

/// The sun-map brightness seen from a point whose backward ray leaves the water at `s` going
/// `u` (up), for the sun travelling along `l`; `fd`: finite-difference step for the normal.
fn brightness(
    surface: &WaterSurface,
    s: Vec3,
    u: Vec3,
    l: Vec3,
    ior: f32,
    width: f32,
    fd: Option<f32>,
) -> f32 {
    let n = match fd {
        Some(h) => surface.normal_finite_differences(s.x, s.z, h),
        None => surface.normal(s.x, s.z),
    };
    // Leaving the water: the normal facing the ray is −n.
    let Some(a) = refract(u, -n, ior) else {
        return 0.0;
    };
    let theta = a.dot(-l).clamp(-1.0, 1.0).acos();
    (-(theta / width).powi(2)).exp()
}

/// Irradiance under a flat surface on a receiver facing the refracted sun (travelling along
/// `t0`, the flat surface's refraction of the sun): E·cosθᵢ·T_Fresnel/cosθₜ.
pub fn flat_beam(sun: &Sun, ior: f32, t0: Vec3) -> Vec3 {
    let cos_i = (-sun.dir.y).max(0.0);
    sun.irradiance * (cos_i * (1.0 - fresnel_dielectric(cos_i, 1.0 / ior)) / (-t0.y).max(1e-6))
}

/// The calibration k: 1 / the mean brightness over a 64 × 64 grid of the water's floor (the
/// floor points whose ray towards the sun leaves through the grid's surface points).
pub fn calibration(body: &WaterBody, sun: &Sun, width: f32, fd: Option<f32>) -> f32 {
    let Some(t0) = refracted_sun(sun, body.ior) else {
        return 0.0;
    };
    let u = -t0;
    let s = &body.surface;
    let n = 64;
    let (sum, hits) = (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let x = s.centre.x + ((i as f32 + 0.5) / n as f32 - 0.5) * s.size.x;
            let z = s.centre.z + ((j as f32 + 0.5) / n as f32 - 0.5) * s.size.y;
            // The point on the floor under (x, z) along the refracted sun.
            let q = Vec3::new(x, s.centre.y, z) - u * (body.depth / u.y);
            match s.intersect(q, u, f32::INFINITY) {
                Some((_, p)) => (
                    f64::from(brightness(s, p, u, sun.dir, body.ior, width, fd)),
                    1u32,
                ),
                None => (0.0, 0),
            }
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    let mean = sum / f64::from(hits.max(1));
    if mean > 0.0 { (1.0 / mean) as f32 } else { 0.0 }
}

/// Points of [`irradiance`] between two questions to its `keep_going`.
pub const POINTS_PER_CHECK: usize = 4096;

/// E at `points` from `sun` through `body`'s surface, the article's way. `keep_going` is
/// asked every [`POINTS_PER_CHECK`] points; Err(Canceled) once it says stop.
#[allow(clippy::too_many_arguments)]
pub fn irradiance(
    recv: &Receivers,
    body: &WaterBody,
    sun: &Sun,
    params: &WaterParams,
    points: &[RecvPoint],
    fd: Option<f32>,
    stats: &mut WaterStats,
    keep_going: KeepGoing,
) -> Result<Vec<Vec3>, Canceled> {
    let Some(t0) = refracted_sun(sun, body.ior) else {
        return Ok(vec![Vec3::ZERO; points.len()]);
    };
    let stop = Stop::new(keep_going);
    stop.check()?;
    let u = -t0;
    let width = params.sun_map_width;
    let k = calibration(body, sun, width, fd);
    stats.calibration.push(k);
    let e_beam = flat_beam(sun, body.ior, t0);
    let s = &body.surface;
    let e = points
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            if !stop.go_at(i, POINTS_PER_CHECK) {
                return Vec3::ZERO;
            }
            let facing = p.normal.dot(u);
            if facing <= 0.0 {
                return Vec3::ZERO;
            }
            let Some((t, hit)) = s.intersect(p.pos + p.normal * 1e-4, u, f32::INFINITY) else {
                return Vec3::ZERO;
            };
            if recv.accel.occluded(p.pos + p.normal * 1e-4, u, t) {
                return Vec3::ZERO;
            }
            let b = brightness(s, hit, u, sun.dir, body.ior, width, fd);
            e_beam * (facing * b * k) * body.transmittance(p.pos, hit)
        })
        .collect();
    stop.checked()?;
    Ok(e)
}
