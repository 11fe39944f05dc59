//! CPU evaluation of CSLs at a receiver point (§2.2–2.4), the reference the GPU pass is
//! checked against.
//!
//! With 1/f(r) = κ + γr, a CSL ray from light-plane radius r is at distance
//! h(r) = r·(1 − z/f(r)) = r·(B − A·r), A = zγ, B = 1 − zκ, from the axis at height z above the
//! plane (negative h: on the other side of the axis). A point at height z and distance ρ from
//! the axis is reached by the rays with h(r) = ±ρ, i.e. the positive roots of
//! A·r² − B·r ± ρ = 0: the paper's r₁, r₂ (case i, Eq. 2) and r₃ (case ii, Eq. 3) when
//! α > 0, β ≥ 0, and at most three in every case. Radii whose light-plane point falls outside
//! the intensity image are dropped. The focusing correction (Eq. 4) is
//! σ = |h·h′/r| = |(B − A·r)(B − 2A·r)|, written without the division by r, so the central ray
//! on the optical axis (§2.4) gets its exact limit σ = B² instead of a perturbed point. Where a
//! ray bundle really focuses (σ → 0: the on-axis focus of the ring of rays with B = A·r, or a
//! fold caustic with B = 2A·r) the model's intensity is infinite; we bound the concentration
//! by the image resolution: σ ≥ texel / half_extent (a texel cannot be focused into less than
//! that fraction of its area, the finest detail the CSL's image can represent).

use super::Csl;
use glam::Vec3;

/// A CSL ray arriving at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    /// Unit travel direction.
    pub dir: Vec3,
    /// Flux per unit area perpendicular to the ray, per unit irradiance of the light.
    pub density: Vec3,
}

/// The light-plane radii of the rays through a point at height `z` and axis distance `rho`:
/// (radius, side) with side +1 when the ray starts on the point's side of the axis.
pub fn radii(kappa: f32, gamma: f32, z: f32, rho: f32) -> ([(f32, f32); 3], usize) {
    let (a, b) = (z * gamma, 1.0 - z * kappa);
    let mut out = [(0.0, 0.0); 3];
    let mut n = 0;
    for side in [1.0f32, -1.0] {
        // a·r² − b·r + side·ρ = 0
        let c = side * rho;
        let mut push = |r: f32| {
            if r > 0.0 && r.is_finite() && n < 3 {
                out[n] = (r, side);
                n += 1;
            }
        };
        if a.abs() <= 1e-9 * b.abs().max(1e-30) {
            if b != 0.0 {
                push(c / b);
            }
            continue;
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            continue;
        }
        // Stable roots of a·r² + (−b)·r + c = 0.
        let q = 0.5 * (b + b.signum() * disc.sqrt());
        if q != 0.0 {
            push(q / a);
            push(c / q);
        } else {
            push(0.0);
        }
    }
    (out, n)
}

impl Csl {
    /// Dequantised, bilinearly interpolated image value at light-plane coordinates (x, y);
    /// None outside the image.
    pub fn intensity(&self, x: f32, y: f32) -> Option<Vec3> {
        let h = self.half_extent;
        if x.abs() > h || y.abs() > h {
            return None;
        }
        let n = self.size as i64;
        let pix = 2.0 * h / self.size as f32;
        let fx = (x + h) / pix - 0.5;
        let fy = (y + h) / pix - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let texel = |i: i64, j: i64| {
            let (i, j) = (i.clamp(0, n - 1), j.clamp(0, n - 1));
            let t = self.texels[(j * n + i) as usize];
            Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32)
        };
        let (i, j) = (x0 as i64, y0 as i64);
        let v = texel(i, j) * ((1.0 - tx) * (1.0 - ty))
            + texel(i + 1, j) * (tx * (1.0 - ty))
            + texel(i, j + 1) * ((1.0 - tx) * ty)
            + texel(i + 1, j + 1) * (tx * ty);
        Some(v * (self.scale / 65535.0))
    }

    /// The smallest focusing factor σ the evaluation uses (see the module notes).
    pub fn sigma_min(&self) -> f32 {
        1.0 / (0.5 * self.size as f32)
    }

    /// The CSL rays reaching `x` (same frame as the CSL), at most three.
    pub fn arrivals(&self, x: Vec3) -> ([Arrival; 3], usize) {
        let mut out = [Arrival {
            dir: Vec3::ZERO,
            density: Vec3::ZERO,
        }; 3];
        let d = x - self.origin;
        let z = d.dot(self.axis);
        if z <= 0.0 {
            return (out, 0);
        }
        let w = d - self.axis * z;
        let (wx, wy) = (w.dot(self.x_axis), w.dot(self.y_axis()));
        let rho = (wx * wx + wy * wy).sqrt();
        // Unit direction from the axis towards x in the plane (any one on the axis).
        let (ux, uy) = if rho > 0.0 {
            (wx / rho, wy / rho)
        } else {
            (1.0, 0.0)
        };
        let (roots, count) = radii(self.kappa, self.gamma, z, rho);
        let (a, b) = (z * self.gamma, 1.0 - z * self.kappa);
        let mut n = 0;
        for &(r, side) in &roots[..count] {
            let (px, py) = (side * r * ux, side * r * uy);
            let Some(i) = self.intensity(px, py) else {
                continue;
            };
            let sigma = ((b - a * r) * (b - 2.0 * a * r))
                .abs()
                .max(self.sigma_min());
            let g = self.kappa + self.gamma * r;
            let u = self.x_axis * px + self.y_axis() * py;
            let dir = (self.axis - u * g).normalize();
            out[n] = Arrival {
                dir,
                density: i / (sigma * dir.dot(self.axis).max(1e-4)),
            };
            n += 1;
        }
        (out, n)
    }

    /// Irradiance on a surface with unit normal `n` at `x`, per unit irradiance of the light.
    pub fn irradiance(&self, x: Vec3, n: Vec3) -> Vec3 {
        let (arr, k) = self.arrivals(x);
        arr[..k]
            .iter()
            .map(|a| a.density * (-a.dir.dot(n)).max(0.0))
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plug each root back: h(r) = side·ρ.
    #[test]
    fn radii_solve_the_ray_equation() {
        for &(kappa, gamma) in &[(1.3f32, 0.8f32), (0.0, 0.0), (-0.7, -0.2), (2.0, 0.0)] {
            for &z in &[0.1f32, 0.5, 0.9, 2.0] {
                for &rho in &[0.0f32, 0.01, 0.2, 0.6] {
                    let (r, n) = radii(kappa, gamma, z, rho);
                    for &(r, side) in &r[..n] {
                        let h = r * (1.0 - z * (kappa + gamma * r));
                        assert!(
                            (h - side * rho).abs() < 1e-4,
                            "{kappa} {gamma} {z} {rho}: {r}"
                        );
                    }
                }
            }
        }
        // Case (i) and (ii) of the paper: α = 1, β = 1 at z = 0.25, ρ = 0.05 gives three radii.
        let (_, n) = radii(1.0, 1.0, 0.25, 0.05);
        assert_eq!(n, 3);
        // Collimated: the one ray at r = ρ.
        let (r, n) = radii(0.0, 0.0, 1.0, 0.3);
        assert_eq!(n, 1);
        assert!((r[0].0 - 0.3).abs() < 1e-6 && r[0].1 == 1.0);
    }
}
