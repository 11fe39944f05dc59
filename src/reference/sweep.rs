//! Light directions drawn over the sphere of directions that light a floor, and the view that
//! sees an object's shadow under each: how the glass methods are measured away from the light
//! they were built on (the sweep test, `examples/glass_sweep.rs`).

use crate::sampling::Pcg;
use crate::scene::{Camera, Light, World};
use glam::Vec3;

/// Lowest elevation of a drawn light above the horizon, degrees.
pub const MIN_ELEVATION_DEG: f32 = 20.0;

/// One light direction of a sweep.
#[derive(Clone, Copy, Debug)]
pub struct SweepCase {
    /// Unit direction the light travels (downwards).
    pub direction: Vec3,
    pub elevation_deg: f32,
    pub azimuth_deg: f32,
}

/// `n` directions uniform in solid angle over the upper hemisphere above
/// [`MIN_ELEVATION_DEG`], from `seed`: the same list for the same arguments.
pub fn directions(n: usize, seed: u64) -> Vec<SweepCase> {
    let mut rng = Pcg::new(seed, 56);
    let lo = MIN_ELEVATION_DEG.to_radians().sin();
    (0..n)
        .map(|_| {
            let s = lo + (1.0 - lo) * rng.f32();
            let phi = std::f32::consts::TAU * rng.f32();
            let c = (1.0 - s * s).max(0.0).sqrt();
            SweepCase {
                direction: Vec3::new(-c * phi.cos(), -s, -c * phi.sin()),
                elevation_deg: s.asin().to_degrees(),
                azimuth_deg: phi.to_degrees(),
            }
        })
        .collect()
}

/// `base` with its first light (directional) turned to travel along `direction` and a
/// `size`² camera that looks down on `object`'s shadow on the plane y = 0 from the side away
/// from the light, 35° above the floor, the whole shadow and a margin in view.
pub fn lit_from(base: &World, object: &str, direction: Vec3, size: u32) -> World {
    let mut w = base.clone();
    let d = direction.normalize();
    if let Some(Light::Directional { direction, .. }) = w.lights.first_mut() {
        *direction = d;
    }
    let (lo, hi) = w
        .objects
        .iter()
        .find(|o| o.name == object)
        .map(|o| {
            o.parts.iter().flat_map(|p| p.mesh.positions.iter()).fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| {
                    let q = o.transform.transform_point3(*p);
                    (lo.min(q), hi.max(q))
                },
            )
        })
        .unwrap_or((Vec3::ZERO, Vec3::ZERO));
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    // Where the line from the object's centre along the light meets the floor.
    let shadow = centre + d * (centre.y / (-d.y).max(1e-3));
    let across = Vec3::new(d.x, 0.0, d.z);
    let along = across.try_normalize().unwrap_or(Vec3::X);
    // Half the shadow's length along the light's azimuth, and a margin.
    let half = radius / (-d.y).max(0.3) + 0.25 * radius;
    let fov_y = 40.0f32;
    let distance = 1.3 * half / (0.5 * fov_y).to_radians().tan();
    let up_angle = 35f32.to_radians();
    let eye = shadow + distance * (along * up_angle.cos() + Vec3::Y * up_angle.sin());
    w.camera = Camera {
        eye,
        target: shadow,
        up: Vec3::Y,
        fov_y,
        width: size,
        height: size,
    };
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_are_fixed_by_the_seed_and_above_the_lowest_elevation() {
        let a = directions(64, 7);
        let b = directions(64, 7);
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
        for c in &a {
            assert!(c.direction.is_normalized());
            assert!(c.elevation_deg >= MIN_ELEVATION_DEG - 1e-3, "{c:?}");
            assert!(c.direction.y < 0.0);
        }
        // Uniform in solid angle: about half lie above the cap's median height.
        let median = 0.5 * (MIN_ELEVATION_DEG.to_radians().sin() + 1.0);
        let above = a.iter().filter(|c| -c.direction.y > median).count();
        assert!((20..=44).contains(&above), "{above} of 64");
    }
}
