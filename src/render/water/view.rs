//! What each pixel sees under the water: the receiver point straight along the camera ray
//! (camera under water, or a receiver outside the surface's rectangle), or refracted through
//! the wave surface from above, with the transmittance of the way back to the camera.

use super::{Receivers, RecvPoint};
use crate::cancel::{Canceled, KeepGoing, Stop};
use crate::scene::World;
use crate::trace::optics::{fresnel_dielectric, refract};
use glam::Vec3;
use rayon::prelude::*;

/// A pixel's receiver under a water body.
#[derive(Clone, Copy, Debug)]
pub struct ViewPoint {
    /// Index in `World::water`.
    pub body: usize,
    pub point: RecvPoint,
    /// Shading normal (towards the viewer's side).
    pub shading: Vec3,
    pub material: u32,
    /// Unit direction towards the camera along the (last segment of the) view path.
    pub wo: Vec3,
    /// Fresnel transmittance through the surface and Beer-Lambert along the water.
    pub throughput: Vec3,
    /// Seen through the wave surface (from above), not directly.
    pub through: bool,
}

/// On a grid of `k` × `k` sub-pixels per pixel (row-major over the image `k` times the
/// camera's size), the receiver under water each sees through its centre, if any.
/// `keep_going` is asked at the start of each row; Err(Canceled) once it says stop.
pub fn view_points(
    world: &World,
    recv: &Receivers,
    k: u32,
    keep_going: KeepGoing,
) -> Result<Vec<Option<ViewPoint>>, Canceled> {
    let cam = &world.camera;
    let rays = cam.rays();
    let (w, h) = (cam.width * k, cam.height * k);
    let s = 1.0 / k as f32;
    let stop = Stop::new(keep_going);
    let views = (0..w * h)
        .into_par_iter()
        .map(|i| {
            if !stop.go_at(i as usize, w as usize) {
                return None;
            }
            let d = rays.dir(((i % w) as f32 + 0.5) * s, ((i / w) as f32 + 0.5) * s);
            view_point(world, recv, cam.eye, d)
        })
        .collect();
    stop.checked()?;
    Ok(views)
}

/// The receiver under water that the ray eye + t·d reaches.
pub fn view_point(world: &World, recv: &Receivers, eye: Vec3, d: Vec3) -> Option<ViewPoint> {
    let hit = recv.accel.intersect(eye, d, f32::INFINITY);
    let t_hit = hit.map_or(f32::INFINITY, |h| h.t);
    // The nearest water surface before the receiver.
    let surface = world
        .water
        .iter()
        .enumerate()
        .filter_map(|(bi, b)| b.surface.intersect(eye, d, t_hit).map(|(t, p)| (t, p, bi)))
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let seen = |h: crate::trace::Hit, body: usize, wo: Vec3, throughput: Vec3, through: bool| {
        let material = recv.accel.material(&h);
        if material.is_specular() {
            return None;
        }
        Some(ViewPoint {
            body,
            point: RecvPoint {
                pos: h.point,
                normal: h.geo_normal,
                object: h.object,
            },
            shading: h.normal,
            material: h.material,
            wo,
            throughput,
            through,
        })
    };
    match surface {
        Some((_, s, bi)) => {
            let body = &world.water[bi];
            let n = body.surface.normal(s.x, s.z);
            if d.dot(n) >= 0.0 {
                // Leaving the water from below: what lies above is not under water.
                return None;
            }
            let cos_i = -d.dot(n);
            let eta = 1.0 / body.ior;
            let t = refract(d, n, eta)?;
            let fr = fresnel_dielectric(cos_i, eta);
            let o = s + t * 1e-4;
            let h = recv.accel.intersect(o, t, f32::INFINITY)?;
            // Radiance leaving the water for the air is divided by n² (L/n² is invariant).
            let tr = body.transmittance(o, h.point) * ((1.0 - fr) * eta * eta);
            seen(h, bi, -t, tr, true)
        }
        None => {
            let h = hit?;
            let bi = world
                .water
                .iter()
                .position(|b| b.contains(h.point + h.geo_normal * 1e-3))?;
            seen(h, bi, -d, world.water_transmittance(eye, h.point), false)
        }
    }
}
