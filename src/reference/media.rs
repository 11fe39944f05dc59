//! The reference's participating medium along its paths: free flights (spectral MIS), the
//! transmittance of a segment (none inside glass), and light tracing's connection of a
//! scattering to the camera.

use crate::sampling::*;
use crate::scene::medium::hg;
use crate::scene::{Material, World};
use crate::trace::{Accel, Hit};
use glam::Vec3;

/// Whether the segment that ends at `hit` ran inside a glass object (it ends on the back of a
/// dielectric that is not a water surface): no medium there.
pub(super) fn inside_glass(world: &World, accel: &Accel, hit: &Hit) -> bool {
    !hit.front_face
        && matches!(accel.material(hit), Material::Dielectric { .. })
        && world.water_of(hit.object).is_none()
}

/// The medium's part of a segment's transmittance: none inside glass.
pub(super) fn fog(world: &World, accel: &Accel, a: Vec3, end: &Hit) -> Vec3 {
    if world.media.is_empty() || inside_glass(world, accel, end) {
        Vec3::ONE
    } else {
        world.media_transmittance_ray(a, (end.point - a).normalize_or_zero(), end.t)
    }
}

/// What a free flight through the medium did along o + t·d, 0 ≤ t ≤ t_end.
pub(super) enum Flight {
    /// The segment misses the medium.
    Outside,
    /// It crossed it; the path's weight is multiplied by T / P(crossing).
    Pass(Vec3),
    /// It interacted at distance t (from o), with weight T(t) / pdf(t): the path goes on with
    /// σs times it; σa times it is the light absorbed there.
    Scatter(f32, Vec3),
}

/// Samples where light along o + t·d first interacts with the medium: a channel chosen
/// uniformly, a distance from its exponential, weighted by the mixture of the three
/// channels' densities (spectral MIS, the one-sample model).
pub(super) fn free_flight(
    m: &crate::scene::Medium,
    o: Vec3,
    d: Vec3,
    t_end: f32,
    rng: &mut Pcg,
) -> Flight {
    let parts = m.intervals(o, d, t_end);
    if parts.is_empty() {
        return Flight::Outside;
    }
    let st = m.sigma_t();
    let c = ((rng.f32() * 3.0) as usize).min(2);
    let u = rng.f32();
    let t = if st[c] > 0.0 {
        -(1.0 - u).ln() / st[c]
    } else {
        f32::INFINITY
    };
    // The distance counts the medium only: walk the parts of the ray inside it.
    let len: f32 = parts.iter().map(|(a, b)| b - a).sum();
    if t < len {
        let tr = (-st * t).exp();
        let pdf = (st * tr).element_sum() / 3.0;
        let mut left = t;
        let mut at = parts[0].0 + t;
        for &(a, b) in &parts {
            if left < b - a {
                at = a + left;
                break;
            }
            left -= b - a;
        }
        Flight::Scatter(at, tr / pdf)
    } else {
        let tr = (-st * len).exp();
        Flight::Pass(tr / (tr.element_sum() / 3.0))
    }
}

/// Light-tracing connection of a scattering in the medium at `p` (light travelling along
/// `d`) to the pinhole: Φ·p_HG·T / (dist²·cos³θc·A_pixel).
pub(super) fn connect_medium_to_camera(
    world: &World,
    accel: &Accel,
    m: &crate::scene::Medium,
    p: Vec3,
    d: Vec3,
    flux: Vec3,
    pixel_area: f32,
) -> Option<(u32, Vec3)> {
    let cam = &world.camera;
    let to_cam = cam.eye - p;
    let dist = to_cam.length();
    let wo = to_cam / dist;
    let (px, py, cos_c) = cam.project(p)?;
    if px < 0.0 || py < 0.0 || px >= cam.width as f32 || py >= cam.height as f32 {
        return None;
    }
    if accel.occluded(p, wo, dist * (1.0 - 1e-5)) {
        return None;
    }
    let pixel = py as u32 * cam.width + px as u32;
    let value = flux * hg(m.g, d, wo) * world.medium_transmittance(p, cam.eye)
        / (dist * dist * cos_c.powi(3) * pixel_area);
    Some((pixel, value))
}
