//! Homogeneous participating media (fog, haze, murky water): scattering and absorption
//! coefficients per metre and colour channel and a Henyey-Greenstein phase function, filling a
//! box (translated, rotated, scaled), the whole scene (a box around every object and the
//! camera) or the inside of a closed mesh (any shape: a ray may cross it several times). The reference traces light through them (free flights, in-scattering towards the
//! camera); every path segment is attenuated by them.

use glam::{Mat4, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// The closed surface a medium fills when it is not a box: its triangles in a BVH.
#[derive(Clone)]
pub struct Boundary(Arc<crate::trace::Accel>);

impl std::fmt::Debug for Boundary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Boundary({} triangles)", self.0.triangle_count())
    }
}

/// Most crossings of a closed boundary one ray is followed through.
const MAX_CROSSINGS: usize = 64;

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
    /// A closed mesh the medium fills (the box is then its bounding box).
    boundary: Option<Boundary>,
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
            boundary: None,
        }
    }

    /// A medium filling the inside of `mesh` (world space), which must be closed (see
    /// [`is_closed`]).
    pub fn inside_mesh(sigma_s: Vec3, sigma_a: Vec3, g: f32, mesh: &super::Mesh) -> Medium {
        let (lo, hi) = mesh.bounds();
        let world = super::World {
            name: String::new(),
            camera: super::Camera {
                eye: Vec3::ZERO,
                target: Vec3::Z,
                up: Vec3::Y,
                fov_y: 45.0,
                width: 1,
                height: 1,
            },
            lights: Vec::new(),
            materials: vec![super::Material::Diffuse { albedo: Vec3::ONE }],
            objects: vec![super::Object {
                name: String::new(),
                parts: vec![super::Part {
                    mesh: Arc::new(mesh.clone()),
                    material: 0,
                }],
                transform: Mat4::IDENTITY,
            }],
            warnings: Vec::new(),
            water: Vec::new(),
            media: Vec::new(),
            has_ground: false,
        };
        let accel = crate::trace::Accel::build_with(
            &world,
            |_| true,
            obvhs::BvhBuildParams::medium_build(),
        );
        let pad = (hi - lo) * 1e-4 + Vec3::splat(1e-5);
        Medium {
            boundary: Some(Boundary(Arc::new(accel))),
            ..Medium::new(
                sigma_s,
                sigma_a,
                g,
                Mat4::from_translation((lo + hi) * 0.5),
                (hi - lo) * 0.5 + pad,
            )
        }
    }

    /// Whether the medium fills a closed mesh rather than a box.
    /// Triangles of the closed mesh it fills (0 for a box).
    pub fn boundary_triangles(&self) -> usize {
        self.boundary.as_ref().map_or(0, |b| b.0.triangle_count())
    }

    pub fn has_boundary_mesh(&self) -> bool {
        self.boundary.is_some()
    }

    /// The parts of o + t·d, 0 ≤ t ≤ t_max, inside the medium, in order (any d, not only
    /// unit): one for a box, as many as the ray's crossings of a closed mesh give.
    pub fn intervals(&self, o: Vec3, d: Vec3, t_max: f32) -> Vec<(f32, f32)> {
        let Some(Boundary(accel)) = &self.boundary else {
            return self.box_interval(o, d, t_max).into_iter().collect();
        };
        if self.box_interval(o, d, t_max).is_none() {
            return Vec::new();
        }
        let len = d.length();
        if len <= 0.0 {
            return Vec::new();
        }
        let dn = d / len;
        let tm = t_max * len;
        // Inside at o when the first surface along the ray is met from behind.
        let mut start = accel
            .intersect(o, dn, f32::INFINITY)
            .is_some_and(|h| !h.front_face)
            .then_some(0.0f32);
        let mut out = Vec::new();
        let mut t = 0.0f32;
        for _ in 0..MAX_CROSSINGS {
            let Some(h) = accel.intersect(o + dn * t, dn, tm - t) else {
                break;
            };
            let th = t + h.t;
            if h.front_face {
                start = Some(th);
            } else if let Some(s) = start.take()
                && th > s
            {
                out.push((s / len, th / len));
            }
            t = th + 1e-5 * (1.0 + th.abs());
            if t >= tm {
                break;
            }
        }
        if let Some(s) = start
            && tm.is_finite()
            && tm > s
        {
            out.push((s / len, t_max));
        }
        out
    }

    /// Length of o + t·d (unit d), 0 ≤ t ≤ t_max, inside the medium.
    fn length_inside(&self, o: Vec3, d: Vec3, t_max: f32) -> f32 {
        self.intervals(o, d, t_max).iter().map(|(a, b)| b - a).sum()
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

    /// From where o + t·d, 0 ≤ t ≤ t_max, first enters the medium to where it last leaves it
    /// (any d, not only unit): the whole part inside for a box, its hull for a closed mesh.
    pub fn interval(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        if self.boundary.is_none() {
            return self.box_interval(o, d, t_max);
        }
        let iv = self.intervals(o, d, t_max);
        Some((iv.first()?.0, iv.last()?.1))
    }

    /// The part [t0, t1] of o + t·d, 0 ≤ t ≤ t_max, inside the box (any d, not only unit).
    fn box_interval(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let o = self.to_local.transform_point3(o);
        box_interval(o, self.to_local.transform_vector3(d), self.half, t_max)
    }

    /// Whether `p` lies inside.
    pub fn contains(&self, p: Vec3) -> bool {
        let l = self.to_local.transform_point3(p);
        let in_box = l.abs().cmple(self.half).all();
        match &self.boundary {
            None => in_box,
            Some(Boundary(accel)) => {
                in_box
                    && accel
                        .intersect(p, Vec3::new(0.267, 0.535, 0.802), f32::INFINITY)
                        .is_some_and(|h| !h.front_face)
            }
        }
    }

    /// Transmittance along o + t·d (unit d), 0 ≤ t ≤ t_max (t_max may be infinite).
    pub fn transmittance_ray(&self, o: Vec3, d: Vec3, t_max: f32) -> Vec3 {
        let len = self.length_inside(o, d, t_max);
        if len > 0.0 {
            (-self.sigma_t() * len).exp()
        } else {
            Vec3::ONE
        }
    }

    /// Transmittance of the straight segment a → b.
    pub fn transmittance(&self, a: Vec3, b: Vec3) -> Vec3 {
        let len = self.length_inside(a, b - a, 1.0) * a.distance(b);
        if len > 0.0 {
            (-self.sigma_t() * len).exp()
        } else {
            Vec3::ONE
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

/// Whether `mesh` is closed: with its vertices welded (positions equal to within 1e-5 of its
/// size), every edge of a non-degenerate triangle is shared by exactly two triangles.
pub fn is_closed(mesh: &super::Mesh) -> bool {
    let (lo, hi) = mesh.bounds();
    let q = ((hi - lo).max_element() * 1e-5).max(1e-9);
    let mut ids = std::collections::HashMap::new();
    let welded: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let key = ((*p - lo) / q).round().as_ivec3().to_array();
            let n = ids.len() as u32;
            *ids.entry(key).or_insert(n)
        })
        .collect();
    let mut edges: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    let mut any = false;
    for t in &mesh.indices {
        let v = t.map(|i| welded[i as usize]);
        if v[0] == v[1] || v[1] == v[2] || v[2] == v[0] {
            continue;
        }
        any = true;
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    any && edges.values().all(|&n| n == 2)
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

/// The part [t0, t1] of o + t·d, 0 ≤ t ≤ t_max, inside the box of half extents `half` about
/// the origin (any d, not only unit); None where the line misses it.
pub fn box_interval(o: Vec3, d: Vec3, half: Vec3, t_max: f32) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (0.0f32, t_max);
    for k in 0..3 {
        if d[k].abs() < 1e-20 {
            if o[k].abs() > half[k] {
                return None;
            }
            continue;
        }
        let a = (-half[k] - o[k]) / d[k];
        let b = (half[k] - o[k]) / d[k];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 < t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_shapes_are_closed_and_open_ones_are_not() {
        use crate::scene::shapes;
        for m in [
            shapes::sphere(0.5, 32),
            shapes::cuboid(Vec3::new(1.0, 2.0, 3.0)),
            shapes::torus(1.0, 0.25, 24),
            shapes::cylinder(0.5, 1.0, 24),
        ] {
            assert!(is_closed(&m));
        }
        assert!(!is_closed(&shapes::plane(1.0, 1.0)));
        assert!(!is_closed(&shapes::paraboloid(0.5, 0.5, 16)));
    }

    #[test]
    fn a_mesh_medium_is_crossed_as_often_as_its_surface() {
        use crate::scene::shapes;
        let one = Vec3::ONE;
        // A torus (R 1, r 0.25) in the y = 0 plane: a ray along x through its middle crosses
        // the tube twice, each time for 0.5 m, and not the hole.
        let torus = Medium::inside_mesh(one, Vec3::ZERO, 0.0, &shapes::torus(1.0, 0.25, 96));
        let iv = torus.intervals(Vec3::new(-2.0, 0.0, 0.0), Vec3::X, f32::INFINITY);
        assert_eq!(iv.len(), 2, "{iv:?}");
        for (a, b) in &iv {
            assert!((b - a - 0.5).abs() < 0.01, "{iv:?}");
        }
        assert!(!torus.contains(Vec3::ZERO) && torus.contains(Vec3::new(1.0, 0.0, 0.0)));
        let t = torus.transmittance(Vec3::new(-2.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0));
        assert!((t.x - (-1.0f32).exp()).abs() < 0.01, "{t}");
        // From inside a sphere, to a point beyond it and up to a point inside.
        let ball = Medium::inside_mesh(one, Vec3::ZERO, 0.0, &shapes::sphere(1.0, 128));
        let iv = ball.intervals(Vec3::ZERO, Vec3::X, 5.0);
        assert_eq!(iv.len(), 1);
        assert!(iv[0].0 == 0.0 && (iv[0].1 - 1.0).abs() < 1e-3, "{iv:?}");
        let iv = ball.intervals(Vec3::new(-3.0, 0.0, 0.0), Vec3::X * 2.0, 1.25);
        assert!(
            iv.len() == 1 && (iv[0].0 - 1.0).abs() < 1e-3 && iv[0].1 == 1.25,
            "{iv:?}"
        );
        assert!(
            ball.intervals(Vec3::new(-3.0, 2.0, 0.0), Vec3::X, 9.0)
                .is_empty()
        );
    }

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
