//! Specular optics shared by the reference renderer and the bakes: mirror reflection, Snell
//! refraction, exact unpolarised Fresnel reflectance, total internal reflection, Beer-Lambert.

use super::Hit;
use crate::scene::Material;
use glam::Vec3;

/// Mirror `d` about the unit normal `n`.
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refract unit `d` through the surface with unit normal `n` facing against `d`, with
/// `eta` = n_incident / n_transmitted. None on total internal reflection.
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((eta * d + (eta * cos_i - cos_t) * n).normalize())
}

/// Exact Fresnel reflectance of unpolarised light at a dielectric interface, `cos_i` the cosine
/// of the incident angle (> 0) and `eta` = n_incident / n_transmitted. 1 beyond the critical angle.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Beer-Lambert transmittance over `distance` metres with per-channel coefficient `sigma`.
pub fn beer_lambert(sigma: Vec3, distance: f32) -> Vec3 {
    Vec3::new(
        (-sigma.x * distance).exp(),
        (-sigma.y * distance).exp(),
        (-sigma.z * distance).exp(),
    )
}

/// One outgoing branch of a specular interaction.
#[derive(Clone, Copy, Debug)]
pub struct Branch {
    pub dir: Vec3,
    /// Energy carried along `dir` relative to the incident energy.
    pub weight: Vec3,
    /// True when this branch goes through the surface.
    pub transmitted: bool,
}

/// Both branches at a specular hit for a ray travelling along `dir`: the reflection and, for a
/// dielectric below the critical angle, the refraction, each weighted by Fresnel (mirrors reflect
/// with their reflectance). Absorption along the segment that reached the hit is *not* included;
/// see [`segment_transmittance`].
#[inline]
pub fn specular_branches(hit: &Hit, dir: Vec3, mat: &Material) -> [Option<Branch>; 2] {
    match *mat {
        Material::Mirror { reflectance } => [
            Some(Branch {
                dir: reflect(dir, hit.normal),
                weight: reflectance,
                transmitted: false,
            }),
            None,
        ],
        Material::Dielectric { ior, .. } => {
            // Entering through a front face goes from air (1) into the medium (ior).
            let eta = if hit.front_face { 1.0 / ior } else { ior };
            let cos_i = (-dir.dot(hit.normal)).clamp(0.0, 1.0);
            let f = fresnel_dielectric(cos_i, eta);
            let r = Branch {
                dir: reflect(dir, hit.normal),
                weight: Vec3::splat(f),
                transmitted: false,
            };
            let t = if f < 1.0 {
                refract(dir, hit.normal, eta).map(|d| Branch {
                    dir: d,
                    weight: Vec3::splat(1.0 - f),
                    transmitted: true,
                })
            } else {
                None
            };
            [Some(r), t]
        }
        _ => [None, None],
    }
}

/// Pick one branch with probability proportional to its mean weight, using `u` in [0,1); the
/// returned weight is divided by that probability (unbiased).
pub fn sample_specular(hit: &Hit, dir: Vec3, mat: &Material, u: f32) -> Option<Branch> {
    let [a, b] = specular_branches(hit, dir, mat);
    match (a, b) {
        (Some(a), Some(b)) => {
            let wa = a.weight.element_sum();
            let wb = b.weight.element_sum();
            let pa = wa / (wa + wb).max(1e-12);
            if u < pa {
                Some(Branch {
                    weight: a.weight / pa,
                    ..a
                })
            } else {
                Some(Branch {
                    weight: b.weight / (1.0 - pa),
                    ..b
                })
            }
        }
        (Some(a), None) | (None, Some(a)) => Some(a),
        (None, None) => None,
    }
}

/// Transmittance of the segment that ended at `hit`: Beer-Lambert when the ray travelled inside
/// an absorbing dielectric (it hits that object's surface from the inside).
pub fn segment_transmittance(hit: &Hit, mat: &Material) -> Vec3 {
    match *mat {
        // Clear glass skips the exponentials (exp(−0·t) = 1 for the finite t of a hit).
        Material::Dielectric { absorption, .. } if !hit.front_face && absorption != Vec3::ZERO => {
            beer_lambert(absorption, hit.t)
        }
        _ => Vec3::ONE,
    }
}

/// BRDF of a non-specular material for unit normal `n`, light direction `wi` and view direction
/// `wo` (both pointing away from the surface). Zero below the surface; specular materials
/// (delta BSDFs) return zero here.
pub fn brdf(mat: &Material, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    let (ci, co) = (n.dot(wi), n.dot(wo));
    if ci <= 0.0 || co <= 0.0 {
        return Vec3::ZERO;
    }
    match *mat {
        Material::Diffuse { albedo } => albedo * std::f32::consts::FRAC_1_PI,
        Material::Glossy {
            albedo,
            specular,
            roughness,
        } => albedo * std::f32::consts::FRAC_1_PI + ggx_specular(specular, roughness, n, wi, wo),
        _ => Vec3::ZERO,
    }
}

/// GGX microfacet specular lobe D·G2·F / (4 cosθi cosθo) with α = roughness², height-correlated
/// Smith G2 and Schlick Fresnel from `f0`. The WGSL in `shaders/` evaluates the same formula.
pub fn ggx_specular(f0: Vec3, roughness: f32, n: Vec3, wi: Vec3, wo: Vec3) -> Vec3 {
    let (ci, co) = (n.dot(wi), n.dot(wo));
    if ci <= 0.0 || co <= 0.0 {
        return Vec3::ZERO;
    }
    let a = roughness * roughness;
    let a2 = a * a;
    let h = (wi + wo).normalize();
    let nh = n.dot(h).max(0.0);
    let d = a2 / (std::f32::consts::PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
    let lambda = |c: f32| ((a2 + (1.0 - a2) * c * c).sqrt() / c - 1.0) * 0.5;
    let g2 = 1.0 / (1.0 + lambda(ci) + lambda(co));
    let f = f0 + (Vec3::ONE - f0) * (1.0 - wi.dot(h).clamp(0.0, 1.0)).powi(5);
    f * (d * g2 / (4.0 * ci * co))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence_and_beyond_critical() {
        // ((1.5-1)/(1.5+1))^2 = 0.04
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Critical angle inside glass: asin(1/1.5) = 41.8°; at 45° all is reflected.
        assert_eq!(fresnel_dielectric(45f32.to_radians().cos(), 1.5), 1.0);
        // Grazing incidence reflects everything.
        assert!(fresnel_dielectric(1e-4, 1.0 / 1.5) > 0.99);
    }

    #[test]
    fn snell_holds() {
        let n = Vec3::Y;
        let theta = 30f32.to_radians();
        let d = Vec3::new(theta.sin(), -theta.cos(), 0.0);
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        let sin_t = t.x;
        assert!((theta.sin() - 1.5 * sin_t).abs() < 1e-6);
        assert!(t.y < 0.0 && (t.length() - 1.0).abs() < 1e-6);
        // Total internal reflection from inside at 60°.
        let d = Vec3::new(60f32.to_radians().sin(), -60f32.to_radians().cos(), 0.0);
        assert!(refract(d, n, 1.5).is_none());
    }

    #[test]
    fn branches_conserve_energy() {
        let hit = Hit {
            t: 1.0,
            point: Vec3::ZERO,
            geo_normal: Vec3::Y,
            normal: Vec3::Y,
            front_face: true,
            material: 0,
            object: 0,
            triangle: 0,
        };
        let m = Material::Dielectric {
            ior: 1.5,
            absorption: Vec3::ZERO,
        };
        for deg in [0.0f32, 20.0, 50.0, 80.0] {
            let d = Vec3::new(deg.to_radians().sin(), -deg.to_radians().cos(), 0.0);
            let [r, t] = specular_branches(&hit, d, &m);
            let sum = r.unwrap().weight.x + t.map_or(0.0, |t| t.weight.x);
            assert!((sum - 1.0).abs() < 1e-6);
        }
    }
}
