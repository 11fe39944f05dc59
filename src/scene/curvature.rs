//! Curvature of smooth-shaded meshes: the shape operator S of the shading-normal field
//! (dn = S dp for a step dp in the tangent plane) per vertex, and its principal curvatures and
//! directions at any point (method `pinhole` uses them as Kalaiah and Varshney's 2001
//! "differential point samples", Wand and Straßer 2003 §3.3).
//!
//! Per face, the normals interpolated over the triangle have a constant derivative: the 2×2
//! operator that maps the two edges onto the differences of their vertex normals, symmetrised
//! (Rusinkiewicz 2004's per-face step; with three vertices the fit is exact). Per vertex, the
//! area-weighted mean of its faces' operators, kept as 3×3 matrices in world space; at a point,
//! the barycentric mix of its triangle's vertices, projected onto the tangent plane. Because
//! renderers reflect at the interpolated shading normal, this is the curvature that shapes a
//! mesh's caustics; for procedural shapes (analytic normals) it converges to the analytic
//! curvature (tested on the sphere, the torus and the cylinder).
//!
//! Sign: positive where the surface bends away from its normal (a sphere with outward normals
//! has k = 1/r).

use crate::sampling::frame;
use glam::{Mat3, Vec3};

/// The shape operator of one triangle from its vertex positions and shading normals, as a
/// symmetric 3×3 matrix acting on tangent vectors (zero along the face normal); None for a
/// degenerate triangle.
pub fn face_shape_operator(p: [Vec3; 3], n: [Vec3; 3]) -> Option<Mat3> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let nf = e1.cross(e2);
    let area2 = nf.length();
    if area2 <= 1e-20 || e1.length_squared() <= 1e-30 {
        return None;
    }
    let nf = nf / area2;
    let u = e1.normalize();
    let w = nf.cross(u);
    let (d1, d2) = (n[1] - n[0], n[2] - n[0]);
    // E maps (a, b) edge weights to tangent coordinates; D the same for the normal differences.
    let (e11, e12, e21, e22) = (e1.dot(u), e2.dot(u), e1.dot(w), e2.dot(w));
    let (d11, d12, d21, d22) = (d1.dot(u), d2.dot(u), d1.dot(w), d2.dot(w));
    let det = e11 * e22 - e12 * e21;
    if det.abs() <= 1e-30 {
        return None;
    }
    // S2 = D · E⁻¹.
    let (i11, i12, i21, i22) = (e22 / det, -e12 / det, -e21 / det, e11 / det);
    let s11 = d11 * i11 + d12 * i21;
    let s12 = d11 * i12 + d12 * i22;
    let s21 = d21 * i11 + d22 * i21;
    let s22 = d21 * i12 + d22 * i22;
    let m = 0.5 * (s12 + s21);
    Some(outer(u, u) * s11 + (outer(u, w) + outer(w, u)) * m + outer(w, w) * s22)
}

fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Per-vertex shape operators: the area-weighted mean of the operators of the faces around
/// each vertex (zero for a vertex of degenerate faces only).
pub fn vertex_shape_operators(
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[[u32; 3]],
) -> Vec<Mat3> {
    let mut acc = vec![Mat3::ZERO; positions.len()];
    let mut weight = vec![0f32; positions.len()];
    for t in indices {
        let p = t.map(|i| positions[i as usize]);
        let n = t.map(|i| normals[i as usize]);
        let Some(s) = face_shape_operator(p, n) else {
            continue;
        };
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        for &i in t {
            acc[i as usize] += s * area;
            weight[i as usize] += area;
        }
    }
    acc.into_iter()
        .zip(weight)
        .map(|(s, w)| if w > 0.0 { s * (1.0 / w) } else { Mat3::ZERO })
        .collect()
}

/// Principal curvatures (k1 ≥ k2) and their unit directions, both perpendicular to `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principal {
    pub k1: f32,
    pub k2: f32,
    pub d1: Vec3,
    pub d2: Vec3,
}

/// The principal curvatures of shape operator `s` at a point with unit normal `n`: `s`
/// restricted to the tangent plane, symmetrised, diagonalised.
pub fn principal(s: Mat3, n: Vec3) -> Principal {
    let (t, b) = frame(n);
    let m11 = t.dot(s * t);
    let m22 = b.dot(s * b);
    let m12 = 0.5 * (t.dot(s * b) + b.dot(s * t));
    let mean = 0.5 * (m11 + m22);
    let half = 0.5 * (m11 - m22);
    let r = (half * half + m12 * m12).sqrt();
    let theta = 0.5 * (2.0 * m12).atan2(m11 - m22);
    let (sin, cos) = theta.sin_cos();
    let d1 = t * cos + b * sin;
    Principal {
        k1: mean + r,
        k2: mean - r,
        d1,
        d2: n.cross(d1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    /// Principal curvatures at the vertex of `mesh` nearest to `at`.
    fn at_vertex(mesh: &crate::scene::Mesh, at: Vec3) -> Principal {
        let s = vertex_shape_operators(&mesh.positions, &mesh.normals, &mesh.indices);
        let (i, _) = mesh
            .positions
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.distance(at).total_cmp(&b.1.distance(at)))
            .unwrap();
        principal(s[i], mesh.normals[i])
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    #[test]
    fn sphere_bends_by_one_over_its_radius_everywhere() {
        let m = shapes::sphere(0.5, 64);
        for at in [Vec3::X * 0.5, Vec3::new(0.3, 0.3, 0.3).normalize() * 0.5] {
            let p = at_vertex(&m, at);
            assert!(close(p.k1, 2.0, 0.03) && close(p.k2, 2.0, 0.03), "{p:?}");
        }
    }

    #[test]
    fn torus_outer_and_inner_equators_match_the_analytic_curvatures() {
        let (big, small) = (0.6f32, 0.1f32);
        let m = shapes::torus(big, small, 192);
        // Outer equator: 1/small across the tube, 1/(big + small) around the ring.
        let p = at_vertex(&m, Vec3::X * (big + small));
        assert!(close(p.k1, 1.0 / small, 0.02), "{p:?}");
        assert!(close(p.k2, 1.0 / (big + small), 0.05), "{p:?}");
        assert!(
            p.d1.y.abs() > 0.99,
            "the strong bend is across the tube: {p:?}"
        );
        // Inner equator: saddle, -1/(big - small) around the ring.
        let p = at_vertex(&m, Vec3::X * (big - small));
        assert!(close(p.k1, 1.0 / small, 0.02), "{p:?}");
        assert!(close(p.k2, -1.0 / (big - small), 0.05), "{p:?}");
    }

    #[test]
    fn cylinder_side_bends_around_only_and_planes_are_flat() {
        let m = shapes::cylinder(0.25, 1.0, 128);
        let p = at_vertex(&m, Vec3::new(0.25, 0.0, 0.0));
        assert!(close(p.k1, 4.0, 0.02) && p.k2.abs() < 0.05, "{p:?}");
        assert!(p.d2.y.abs() > 0.99, "flat along the axis: {p:?}");
        let m = shapes::plane(2.0, 2.0);
        let p = at_vertex(&m, Vec3::ZERO);
        assert!(p.k1.abs() < 1e-6 && p.k2.abs() < 1e-6, "{p:?}");
    }

    #[test]
    fn principal_directions_are_an_orthonormal_tangent_frame() {
        let n = Vec3::new(0.2, 0.9, -0.3).normalize();
        let (t, b) = frame(n);
        let s = outer(t, t) * 3.0 + (outer(t, b) + outer(b, t)) * 0.5 - outer(b, b);
        let p = principal(s, n);
        for d in [p.d1, p.d2] {
            assert!((d.length() - 1.0).abs() < 1e-5 && d.dot(n).abs() < 1e-5);
        }
        assert!(p.d1.dot(p.d2).abs() < 1e-5);
        // The eigen-directions: S d = k d in the tangent plane.
        let r1 = s * p.d1 - p.d1 * p.k1;
        assert!(r1.length() < 1e-4, "{r1}");
        assert!((p.k1 + p.k2 - 2.0).abs() < 1e-4);
    }
}
