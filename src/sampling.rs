//! Deterministic random numbers (PCG) and the few warps the reference needs; the bakes and the
//! tests draw from the same generator.

use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// PCG32 (O'Neill): small, fast, and seekable by stream so that every photon chunk and every
/// pixel draws the same numbers however the work is scheduled.
#[derive(Clone, Debug)]
pub struct Pcg {
    state: u64,
    inc: u64,
}

impl Pcg {
    pub fn new(seed: u64, stream: u64) -> Pcg {
        let mut r = Pcg {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed ^ 0x853c_49e6_748f_ea9b);
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn vec2(&mut self) -> Vec2 {
        Vec2::new(self.f32(), self.f32())
    }
}

/// Orthonormal tangents of unit `n` (Duff et al. 2017).
pub fn frame(n: Vec3) -> (Vec3, Vec3) {
    let s = 1f32.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// Uniform point on the unit disk (concentric map would be nicer; polar is enough here).
pub fn disk(u: Vec2) -> Vec2 {
    let r = u.x.sqrt();
    let phi = TAU * u.y;
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction around `n`; pdf = cos/π.
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let d = disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    let (t, b) = frame(n);
    (t * d.x + b * d.y + n * z).normalize()
}

/// Uniform direction in the cone of half-angle acos(`cos_max`) around `axis`; pdf = 1/solid angle.
pub fn uniform_cone(axis: Vec3, cos_max: f32, u: Vec2) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = TAU * u.y;
    let (t, b) = frame(axis);
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Solid angle of a cone of half-angle acos(`cos_max`).
pub fn cone_solid_angle(cos_max: f32) -> f32 {
    TAU * (1.0 - cos_max)
}

/// Uniform direction on the unit sphere.
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    uniform_cone(Vec3::Z, -1.0, u)
}

pub const SPHERE_SOLID_ANGLE: f32 = 4.0 * PI;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..4).map(|_| Pcg::new(7, 3).next_u32()).collect();
        assert!(a.windows(2).all(|w| w[0] == w[1]));
        let mut x = Pcg::new(7, 3);
        let mut y = Pcg::new(7, 4);
        assert_ne!(
            (0..4).map(|_| x.next_u32()).collect::<Vec<_>>(),
            (0..4).map(|_| y.next_u32()).collect::<Vec<_>>()
        );
    }

    #[test]
    fn cone_samples_stay_in_cone() {
        let mut r = Pcg::new(1, 1);
        let axis = Vec3::new(1.0, -1.0, 0.5).normalize();
        for _ in 0..1000 {
            let d = uniform_cone(axis, 0.9, r.vec2());
            assert!(d.dot(axis) >= 0.9 - 1e-5 && (d.length() - 1.0).abs() < 1e-5);
        }
    }
}
