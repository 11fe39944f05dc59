//! Homogeneous participating media (fog, haze, murky water): scattering and absorption
//! coefficients per metre and colour channel and a Henyey-Greenstein phase function, filling a
//! box (translated, rotated, scaled) or the whole scene (a box around every object and the
//! camera). The reference traces light through them (free flights, in-scattering towards the
//! camera); every path segment is attenuated by them.

use glam::{Mat4, Vec3};
use std::f32::consts::PI;

/// A resolved medium: its coefficients and the box it fills.
#[derive(Clone, Debug)]
pub struct Medium {
    /// Scattering and absorption coefficients, per metre and channel.
    pub sigma_s: Vec3,
    pub sigma_a: Vec3,
    /// Henyey-Greenstein asymmetry, −1 < g < 1 (0: isotropic; > 0: forward).
    pub g: f32,
    /// World → the box's frame, where it spans [−half, half].
    to_local: Mat4,
    from_local: Mat4,
    half: Vec3,
}

impl Medium {
    /// A medium filling the box of half extents `half` placed by `transform` (an affine map,
    /// invertible).
    pub fn new(sigma_s: Vec3, sigma_a: Vec3, g: f32, transform: Mat4, half: Vec3) -> Medium {
        Medium {
            sigma_s,
            sigma_a,
            g,
            to_local: transform.inverse(),
            from_local: transform,
            half,
        }
    }

    /// World → the box's frame, where it spans [−half, half].
    pub fn to_local(&self) -> Mat4 {
        self.to_local
    }

    /// The box's half extents in its frame.
    pub fn half(&self) -> Vec3 {
        self.half
    }

    /// Extinction σt = σs + σa.
    pub fn sigma_t(&self) -> Vec3 {
        self.sigma_s + self.sigma_a
    }

    /// The part [t0, t1] of o + t·d, 0 ≤ t ≤ t_max, inside the box (any d, not only unit).
    pub fn interval(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let lo_ = self.to_local.transform_point3(o);
        let ld = self.to_local.transform_vector3(d);
        let (mut t0, mut t1) = (0.0f32, t_max);
        for k in 0..3 {
            if ld[k].abs() < 1e-20 {
                if lo_[k].abs() > self.half[k] {
                    return None;
                }
                continue;
            }
            let a = (-self.half[k] - lo_[k]) / ld[k];
            let b = (self.half[k] - lo_[k]) / ld[k];
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        (t0 < t1).then_some((t0, t1))
    }

    /// Whether `p` lies inside.
    pub fn contains(&self, p: Vec3) -> bool {
        let l = self.to_local.transform_point3(p);
        l.abs().cmple(self.half).all()
    }

    /// Transmittance along o + t·d (unit d), 0 ≤ t ≤ t_max (t_max may be infinite).
    pub fn transmittance_ray(&self, o: Vec3, d: Vec3, t_max: f32) -> Vec3 {
        match self.interval(o, d, t_max) {
            Some((t0, t1)) => (-self.sigma_t() * (t1 - t0)).exp(),
            None => Vec3::ONE,
        }
    }

    /// Transmittance of the straight segment a → b.
    pub fn transmittance(&self, a: Vec3, b: Vec3) -> Vec3 {
        match self.interval(a, b - a, 1.0) {
            Some((t0, t1)) => (-self.sigma_t() * ((t1 - t0) * a.distance(b))).exp(),
            None => Vec3::ONE,
        }
    }

    /// The box's world-space bounds.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            ) * self.half;
            let w = self.from_local.transform_point3(c);
            lo = lo.min(w);
            hi = hi.max(w);
        }
        (lo, hi)
    }
}

/// The Henyey-Greenstein phase function (1/sr) for light travelling along `wi` scattered into
/// `wo` (both unit, travel directions): (1 − g²) / (4π (1 + g² − 2g cosθ)^{3/2}), cosθ = wi·wo;
/// g > 0 scatters forward (Mitsuba's convention).
pub fn hg(g: f32, wi: Vec3, wo: Vec3) -> f32 {
    // Isotropic below the threshold where [`sample_hg`] is, so that both agree exactly.
    let g = if g.abs() < 1e-3 { 0.0 } else { g };
    let c = wi.dot(wo).clamp(-1.0, 1.0);
    let d = 1.0 + g * g - 2.0 * g * c;
    (1.0 - g * g) / (4.0 * PI * d * d.max(1e-12).sqrt())
}

/// A direction drawn from [`hg`] about the travel direction `wi`, from two uniform numbers
/// (its density is exactly `hg(g, wi, ·)`).
pub fn sample_hg(g: f32, wi: Vec3, u1: f32, u2: f32) -> Vec3 {
    let cos = if g.abs() < 1e-3 {
        1.0 - 2.0 * u1
    } else {
        let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u1);
        ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u2;
    let (t, b) = crate::sampling::frame(wi);
    (wi * cos + (t * phi.cos() + b * phi.sin()) * sin).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_integrates_to_one_its_samples_have_mean_cosine_g_and_follow_its_density() {
        let wi = Vec3::new(0.3, -0.8, 0.2).normalize();
        for g in [-0.6f32, 0.0, 0.3, 0.85] {
            // ∫ p dω over a fine grid in (cos, φ) about wi.
            let n = 2000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let c = -1.0 + (i as f32 + 0.5) * 2.0 / n as f32;
                let (t, _) = crate::sampling::frame(wi);
                let wo = wi * c + t * (1.0 - c * c).sqrt();
                sum += f64::from(hg(g, wi, wo)) * 2.0 / n as f64 * 2.0 * std::f64::consts::PI;
            }
            assert!((sum - 1.0).abs() < 1e-3, "g {g}: ∫p = {sum}");
            // Mean cosine of the samples, and the share of them in the forward hemisphere
            // against the density's.
            let m = 200_000;
            let mut mean = 0.0f64;
            let mut forward = 0usize;
            let mut rng = crate::sampling::Pcg::new(7, 1);
            for _ in 0..m {
                let wo = sample_hg(g, wi, rng.f32(), rng.f32());
                mean += f64::from(wi.dot(wo));
                forward += usize::from(wi.dot(wo) > 0.0);
            }
            mean /= m as f64;
            assert!(
                (mean - f64::from(g)).abs() < 0.01,
                "g {g}: mean cosine {mean}"
            );
            let expect: f64 = (0..n / 2)
                .map(|i| {
                    let c = (i as f32 + 0.5) * 2.0 / n as f32;
                    let (t, _) = crate::sampling::frame(wi);
                    let wo = wi * c + t * (1.0 - c * c).sqrt();
                    f64::from(hg(g, wi, wo)) * 2.0 / n as f64 * 2.0 * std::f64::consts::PI
                })
                .sum();
            let got = forward as f64 / m as f64;
            assert!(
                (got - expect).abs() < 0.01,
                "g {g}: forward {got} vs {expect}"
            );
        }
    }

    #[test]
    fn a_rotated_box_clips_rays_and_attenuates_by_the_length_inside() {
        let m = Medium::new(
            Vec3::splat(0.5),
            Vec3::new(0.1, 0.2, 0.3),
            0.0,
            Mat4::from_rotation_y(0.7) * Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0)),
            Vec3::new(1.0, 0.5, 2.0),
        );
        // Straight down through the box's centre: 1 m of medium.
        let c = Mat4::from_rotation_y(0.7).transform_point3(Vec3::new(0.0, 1.0, 0.0));
        let t = m.transmittance(c + Vec3::Y * 3.0, c - Vec3::Y * 3.0);
        let want = (-m.sigma_t()).exp();
        assert!((t - want).abs().max_element() < 1e-5, "{t} {want}");
        assert!(m.contains(c) && !m.contains(c + Vec3::Y * 0.6));
        let (lo, hi) = m.bounds();
        assert!((hi.y - lo.y - 1.0).abs() < 1e-5 && lo.y > 0.49);
        // A ray that misses, and one that starts inside.
        assert_eq!(
            m.transmittance_ray(c + Vec3::X * 9.0, Vec3::Y, f32::INFINITY),
            Vec3::ONE
        );
        let half = m.transmittance_ray(c, -Vec3::Y, f32::INFINITY);
        assert!((half - (-m.sigma_t() * 0.5).exp()).abs().max_element() < 1e-5);
    }
}
