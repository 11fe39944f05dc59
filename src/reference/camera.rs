//! The reference's camera pass: per pixel, the `direct` component (camera ray → first
//! non-specular surface → every light) and the `specular` one (camera paths through glass and
//! mirrors, with direct light and the caustic photon map's estimate at their end).

use super::{Photon, ReferenceParams, fog, intersect};
use crate::sampling::*;
use crate::scene::{EnvSampler, Light, Material, World};
use crate::trace::optics::{brdf, sample_specular, segment_transmittance};
use crate::trace::{Accel, Hit};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Uniform grid over stored caustic photons for fixed-radius gathers.
pub(super) struct PhotonMap {
    photons: Vec<Photon>,
    radius: f32,
    cells: std::collections::HashMap<(i32, i32, i32), Vec<u32>>,
}

impl PhotonMap {
    /// The map of `photons`; None when `keep_going` (asked every million photons) says stop.
    pub(super) fn new(
        photons: Vec<Photon>,
        radius: f32,
        keep_going: &dyn Fn() -> bool,
    ) -> Option<PhotonMap> {
        let mut cells: std::collections::HashMap<(i32, i32, i32), Vec<u32>> =
            std::collections::HashMap::new();
        for (i, p) in photons.iter().enumerate() {
            if i % (1 << 20) == (1 << 20) - 1 && !keep_going() {
                return None;
            }
            cells
                .entry(Self::cell(p.pos, radius))
                .or_default()
                .push(i as u32);
        }
        Some(PhotonMap {
            photons,
            radius,
            cells,
        })
    }

    fn cell(p: Vec3, r: f32) -> (i32, i32, i32) {
        let c = (p / (2.0 * r)).floor();
        (c.x as i32, c.y as i32, c.z as i32)
    }

    /// Reflected radiance from caustic photons around `hit` towards `wo`, gathered over a disc
    /// of about the pixel's footprint there (`footprint`, metres), between a quarter of the
    /// map's radius (not to gather too few photons) and the whole radius.
    fn radiance(&self, hit: &Hit, mat: &Material, wo: Vec3, footprint: f32) -> Vec3 {
        if self.photons.is_empty() {
            return Vec3::ZERO;
        }
        let r = footprint.clamp(0.25 * self.radius, self.radius);
        let r2 = r * r;
        let (cx, cy, cz) = Self::cell(hit.point, self.radius);
        let mut sum = Vec3::ZERO;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get(&(cx + dx, cy + dy, cz + dz)) else {
                        continue;
                    };
                    for &i in list {
                        let p = &self.photons[i as usize];
                        let v = p.pos - hit.point;
                        // Same surface: within the disk and close to its plane.
                        if v.length_squared() < r2 && v.dot(hit.geo_normal).abs() < 0.1 * r {
                            sum += p.flux * brdf(mat, hit.normal, p.wi, wo);
                        }
                    }
                }
            }
        }
        sum / (std::f32::consts::PI * r2)
    }
}

/// Direct (and background) and specular radiance of one pixel.
pub(super) fn camera_pixel(
    world: &World,
    accel: &Accel,
    params: &ReferenceParams,
    env: &[Option<EnvSampler>],
    pmap: &PhotonMap,
    x: u32,
    y: u32,
) -> (Vec3, Vec3) {
    let cam = &world.camera;
    let mut rng = Pcg::new(
        params.seed ^ 0x5eed_cafe,
        u64::from(y) * u64::from(cam.width) + u64::from(x),
    );
    let spp = params.spp.max(1);
    // Stratified jitter on a k×k grid (k² ≥ spp; extra cells wrap).
    let k = (spp as f32).sqrt().ceil() as u32;
    let rays = cam.rays();
    // The angle a pixel spans here: a camera path's footprint grows by it per metre travelled.
    let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
    let pixel_angle = (rays.dir(cx + 1.0, cy) - rays.dir(cx, cy)).length();
    let (mut direct, mut spec) = (Vec3::ZERO, Vec3::ZERO);
    for s in 0..spp {
        let cell = Vec2::new((s % k) as f32, ((s / k) % k) as f32);
        let j = (cell + rng.vec2()) / k as f32;
        let d = rays.dir(x as f32 + j.x, y as f32 + j.y);
        let Some(hit) = intersect(world, accel, cam.eye, d) else {
            direct +=
                background(world, d) * world.media_transmittance_ray(cam.eye, d, f32::INFINITY);
            continue;
        };
        let mat = accel.material(&hit);
        let medium =
            world.water_transmittance(cam.eye, hit.point) * fog(world, accel, cam.eye, &hit);
        if !mat.is_specular() {
            direct += medium * shade(world, accel, params, env, &hit, mat, -d, &mut rng);
            continue;
        }
        // Specular chain.
        let mut throughput = medium;
        let mut travelled = hit.t;
        let (mut h, mut dir) = (hit, d);
        for _ in 0..params.max_depth {
            let m = accel.material(&h);
            throughput *= segment_transmittance(&h, m);
            if !m.is_specular() {
                spec += throughput
                    * (shade(world, accel, params, env, &h, m, -dir, &mut rng)
                        + pmap.radiance(&h, m, -dir, travelled * pixel_angle));
                break;
            }
            let Some(b) = sample_specular(&h, dir, m, rng.f32()) else {
                break;
            };
            throughput *= b.weight;
            // Radiance crossing into a medium of index n_t from n_i scales by (n_t/n_i)²: along
            // the camera path (against the light) by η² = (n_i/n_t)² of the path's direction
            // (cancels through a closed glass object; not into open water).
            if let (true, Material::Dielectric { ior, .. }) = (b.transmitted, m) {
                let eta = if h.front_face { 1.0 / ior } else { *ior };
                throughput *= eta * eta;
            }
            let o = h.spawn(b.dir);
            dir = b.dir;
            match intersect(world, accel, o, dir) {
                Some(n) => {
                    throughput *= world.water_transmittance(o, n.point) * fog(world, accel, o, &n);
                    travelled += n.t;
                    h = n
                }
                None => {
                    spec += throughput
                        * background(world, dir)
                        * world.media_transmittance_ray(o, dir, f32::INFINITY);
                    break;
                }
            }
        }
    }
    (direct / spp as f32, spec / spp as f32)
}

/// Radiance arriving from the environment along a ray travelling in `d`.
fn background(world: &World, d: Vec3) -> Vec3 {
    world
        .lights
        .iter()
        .map(|l| match l {
            Light::Environment { map, radiance } => {
                *radiance * map.as_ref().map_or(Vec3::ONE, |m| m.lookup(d))
            }
            _ => Vec3::ZERO,
        })
        .sum()
}

/// A shadow ray towards a directional light, as a segment for [`World::water_transmittance`]:
/// long enough to leave any water body.
const FAR_SEGMENT: f32 = 1e4;

/// Reflected radiance at a non-specular hit towards `wo` from every light, shadowed by all
/// geometry (specular objects included).
#[allow(clippy::too_many_arguments)]
fn shade(
    world: &World,
    accel: &Accel,
    params: &ReferenceParams,
    env: &[Option<EnvSampler>],
    hit: &Hit,
    mat: &Material,
    wo: Vec3,
    rng: &mut Pcg,
) -> Vec3 {
    let n = hit.normal;
    let mut sum = Vec3::ZERO;
    // Unshadowed-by-self check and shadow ray towards a point light at `p`.
    let point = |p: Vec3| -> Option<(Vec3, f32)> {
        let v = p - hit.point;
        let dist = v.length();
        let wi = v / dist;
        if wi.dot(hit.geo_normal) <= 0.0 || n.dot(wi) <= 0.0 {
            return None;
        }
        let o = hit.spawn(wi);
        if accel.occluded(o, wi, (p - o).length() * (1.0 - 1e-5)) {
            return None;
        }
        Some((wi, dist))
    };
    // Lights under water reach the point through its medium.
    let medium = |p: Vec3| world.medium_transmittance(hit.point, p);
    for (li, l) in world.lights.iter().enumerate() {
        match l {
            Light::Directional {
                direction,
                irradiance,
                angular_radius,
            } => {
                let wi = if *angular_radius > 0.0 {
                    -uniform_cone(*direction, angular_radius.cos(), rng.vec2())
                } else {
                    -*direction
                };
                if wi.dot(hit.geo_normal) > 0.0
                    && n.dot(wi) > 0.0
                    && !accel.occluded(hit.spawn(wi), wi, f32::INFINITY)
                {
                    // Sunlight reaching a point under water without crossing its surface
                    // came in through the body's open side: through the water on the way.
                    let far = hit.point + wi * FAR_SEGMENT;
                    sum += brdf(mat, n, wi, wo)
                        * *irradiance
                        * world.media_transmittance_ray(hit.point, wi, f32::INFINITY)
                        * world.water_transmittance(hit.point, far)
                        * n.dot(wi);
                }
            }
            Light::Point {
                position,
                intensity,
            } => {
                if let Some((wi, d)) = point(*position) {
                    sum += brdf(mat, n, wi, wo)
                        * *intensity
                        * medium(*position)
                        * (n.dot(wi) / (d * d));
                }
            }
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff,
                beam_width,
            } => {
                if let Some((wi, d)) = point(*position) {
                    let f = Light::spot_falloff((-wi).dot(*direction), *cutoff, *beam_width);
                    if f > 0.0 {
                        sum += brdf(mat, n, wi, wo)
                            * *intensity
                            * medium(*position)
                            * (f * n.dot(wi) / (d * d));
                    }
                }
            }
            Light::Line {
                start,
                end,
                intensity,
            } => {
                let m = params.area_light_samples.max(1);
                for k in 0..m {
                    let p = start.lerp(*end, (k as f32 + rng.f32()) / m as f32);
                    if let Some((wi, d)) = point(p) {
                        sum += brdf(mat, n, wi, wo)
                            * *intensity
                            * medium(p)
                            * (n.dot(wi) / (d * d * m as f32));
                    }
                }
            }
            Light::Environment { map, radiance } => {
                let m = params.area_light_samples.max(1);
                let le = |wi: Vec3| {
                    *radiance
                        * map.as_ref().map_or(Vec3::ONE, |e| e.lookup(wi))
                        * world.media_transmittance_ray(hit.point, wi, f32::INFINITY)
                };
                let visible = |wi: Vec3| {
                    wi.dot(hit.geo_normal) > 0.0
                        && n.dot(wi) > 0.0
                        && !accel.occluded(hit.spawn(wi), wi, f32::INFINITY)
                };
                let Some(sampler) = &env[li] else {
                    // Constant sky: cosine-sampled shadow rays, f·L·cos / pdf with pdf = cos/π.
                    for _ in 0..m {
                        let wi = cosine_hemisphere(n, rng.vec2());
                        if visible(wi) {
                            sum += brdf(mat, n, wi, wo) * le(wi) * (PI / m as f32);
                        }
                    }
                    continue;
                };
                // A map: one direction from the map's distribution and one cosine-sampled
                // direction per sample, combined by the power heuristic (Veach & Guibas 1995).
                let power = |a: f32, b: f32| a * a / (a * a + b * b);
                for _ in 0..m {
                    let u = rng.vec2();
                    if let Some((wi, pdf_l)) = sampler.sample(u.x, u.y)
                        && visible(wi)
                    {
                        let cos = n.dot(wi);
                        let w = power(pdf_l, cos / PI);
                        sum += brdf(mat, n, wi, wo) * le(wi) * (cos * w / (pdf_l * m as f32));
                    }
                    let wi = cosine_hemisphere(n, rng.vec2());
                    if visible(wi) {
                        let pdf_b = n.dot(wi) / PI;
                        let w = power(pdf_b, sampler.pdf(wi));
                        sum += brdf(mat, n, wi, wo) * le(wi) * (PI * w / m as f32);
                    }
                }
            }
        }
    }
    sum
}
