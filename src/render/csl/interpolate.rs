//! Liu et al. 2008 §4.1: the CSL set for any light direction, interpolated from the triples of
//! the dynamic bake's icosahedron face it passes through. This runs every frame, so it lives on
//! the render side; it depends on the bake only through public items ([`DynamicSet`]'s fields
//! and accessors, [`Triple`](crate::bake::csl::dynamic::Triple), [`Share`],
//! [`Icosphere::locate`](crate::bake::csl::dynamic::Icosphere::locate)).

use crate::bake::Fnv64;
use crate::bake::csl::dynamic::{DynamicSet, Share};
use crate::bake::csl::image::quantise;
use crate::bake::csl::{Csl, CslSet};
use glam::{Quat, Vec3};
use rayon::prelude::*;

impl DynamicSet {
    /// The CSLs of face `fi` at barycentric weights `w` (corner order): one per triple that has
    /// light there.
    pub fn interpolate_face(&self, fi: usize, w: [f32; 3]) -> Vec<Csl> {
        self.interpolate_in(self.icosphere().faces[fi], fi, w)
    }

    /// [`Self::interpolate_face`] for face `fi` whose corners `f` the caller has.
    fn interpolate_in(&self, f: [u32; 3], fi: usize, w: [f32; 3]) -> Vec<Csl> {
        let centre = self.sets[0].centre;
        self.triples[fi]
            .par_iter()
            .filter_map(|t| {
                let c = [0, 1, 2].map(|k| self.csl(f[k] as usize, t.members[k].csl));
                let mut geometry: Vec<(&Csl, f32)> = (0..3).map(|k| (c[k], w[k])).collect();
                if let Some(z) = t.split {
                    // A pair triple: its third corner's weight shared by the partners of its
                    // two image members there, in proportion to those members' weights.
                    let k = (0..3).find(|&k| t.members[k].image == Share::None)?;
                    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                    let sum = w[i] + w[j];
                    let share = if sum > 0.0 { w[i] / sum } else { 0.5 };
                    geometry[k].1 = w[k] * share;
                    geometry.push((self.csl(f[k] as usize, z), w[k] * (1.0 - share)));
                }
                let image: Vec<(&Csl, f32)> = (0..3)
                    .map(|k| (c[k], w[k] * t.members[k].image.fraction()))
                    .collect();
                interpolate_csl(&geometry, &image, centre)
            })
            .collect()
    }

    /// The CSL set for light travel direction `light_dir` (object rigid frame), interpolated
    /// from the triples of the face it passes through (§4.1): axes by spherical interpolation,
    /// light-plane origins and the focus law (κ = 1/α, γ = β/α) linearly, and the intensity
    /// images, each turned onto the new axis by the rotation about â × âᵢ, blended linearly.
    pub fn interpolate(&self, light_dir: Vec3) -> CslSet {
        let ico = self.icosphere();
        let (fi, w) = ico.locate(light_dir);
        let csls = self.interpolate_in(ico.faces[fi], fi, w);
        let s0 = &self.sets[0];
        let mut h = Fnv64::new();
        h.write(&self.source_hash.to_le_bytes());
        for v in light_dir.normalize().to_array() {
            h.write_f32(v);
        }
        CslSet {
            source_hash: h.finish(),
            params_hash: self.params_hash,
            light_dir: light_dir.normalize(),
            centre: s0.centre,
            radius: s0.radius,
            spacing: s0.spacing,
            csls,
            stats: Default::default(),
        }
    }
}

/// Spherical interpolation of unit vectors with the barycentric weights of
/// [`Icosphere::locate`](super::Icosphere::locate): those are gnomonic (the point on the face's
/// plane), so the blend that agrees with them is the normalised weighted sum, which carries the
/// three icosahedron directions exactly onto the light direction; on an edge it runs along the
/// great arc, and at a corner it is that corner's vector. (Nested slerps of the same weights
/// missed a face centre by 1.5° at 63° spacing.)
fn blend_axes(members: &[(&Csl, f32)]) -> Vec3 {
    members
        .iter()
        .map(|(c, w)| c.axis * *w)
        .fold(Vec3::ZERO, |a, b| a + b)
        .normalize_or(members[0].0.axis)
}

/// One interpolated CSL from `geometry` (CSLs and their weights for the axis, origin and focus
/// law) and `image` (CSLs and the weights of their intensity images), or None when no image
/// member lends it light.
fn interpolate_csl(geometry: &[(&Csl, f32)], image: &[(&Csl, f32)], centre: Vec3) -> Option<Csl> {
    let lit: Vec<(&Csl, f32)> = image
        .iter()
        .copied()
        .filter(|(c, w)| *w > 1e-6 && !c.texels.is_empty() && c.scale > 0.0)
        .collect();
    if lit.is_empty() {
        return None;
    }
    let axis = blend_axes(geometry);
    let turn = |c: &Csl| Quat::from_rotation_arc(c.axis, axis);
    let sum = |f: &dyn Fn(&Csl) -> Vec3| {
        geometry
            .iter()
            .map(|(c, w)| f(c) * *w)
            .fold(Vec3::ZERO, |a, b| a + b)
    };
    let kappa = geometry.iter().map(|(c, w)| c.kappa * w).sum();
    let gamma = geometry.iter().map(|(c, w)| c.gamma * w).sum();
    // Light-plane origins relative to the bounding centre, each turned with its axis: the
    // paper's linear blend of the origins, but one that does not pull the plane towards the
    // centre when the axes differ (by 1 - cos(θ/2) of its distance between axes θ apart).
    let origin = centre + sum(&|c| turn(c) * (c.origin - centre));
    // The new image frame: the members' x axes turned onto the new axis, blended with the
    // weights (symmetric in the members, so the two faces of an edge agree on it).
    let xs = sum(&|c| turn(c) * c.x_axis);
    let xs = xs - axis * xs.dot(axis);
    let x_axis = if xs.length() > 1e-3 {
        xs.normalize()
    } else {
        axis.any_orthonormal_vector()
    };
    let y_axis = axis.cross(x_axis);
    let size = lit.iter().map(|(c, _)| c.size).max().unwrap_or(128);
    let half = lit
        .iter()
        .map(|(c, _)| c.half_extent)
        .fold(0.0f32, f32::max);
    // Member k's image coordinates of the new plane's in-plane vector p: rot[k]⁻¹ p in k's frame.
    let frames: Vec<(&Csl, f32, Vec3, Vec3)> = lit
        .iter()
        .map(|&(c, w)| {
            let inv = turn(c).inverse();
            let (xk, yk) = (c.x_axis, c.y_axis());
            // (x̄ · …, ȳ · …) → k's (x, y): columns of the 2×2 map.
            let ex = inv * x_axis;
            let ey = inv * y_axis;
            (
                c,
                w,
                Vec3::new(ex.dot(xk), ex.dot(yk), 0.0),
                Vec3::new(ey.dot(xk), ey.dot(yk), 0.0),
            )
        })
        .collect();
    let pix = 2.0 * half / size as f32;
    let mut texels = vec![Vec3::ZERO; (size * size) as usize];
    for j in 0..size {
        let y = -half + (j as f32 + 0.5) * pix;
        for i in 0..size {
            let x = -half + (i as f32 + 0.5) * pix;
            let mut v = Vec3::ZERO;
            for &(c, w, ex, ey) in &frames {
                let (u, t) = (x * ex.x + y * ey.x, x * ex.y + y * ey.y);
                if let Some(val) = c.intensity(u, t) {
                    v += val * w;
                }
            }
            texels[(j * size + i) as usize] = v;
        }
    }
    let (scale, q) = quantise(&texels);
    let flux = lit.iter().map(|(c, w)| c.flux * w).sum();
    Some(Csl {
        origin,
        axis,
        x_axis,
        kappa,
        gamma,
        half_extent: half,
        size,
        scale,
        flux,
        // Only baked images are coded by their grain; this one is never written.
        grain: 0.0,
        texels: q,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::csl::dynamic::tests::rotated_copies;

    fn same_csl(a: &Csl, b: &Csl, tol: f32) {
        assert!((a.origin - b.origin).length() < tol, "{a:?} {b:?}");
        assert!(a.axis.dot(b.axis) > 1.0 - tol);
        assert!((a.kappa - b.kappa).abs() < tol && (a.gamma - b.gamma).abs() < tol);
        assert_eq!(a.size, b.size);
        let v = |c: &Csl, i: usize| {
            Vec3::new(
                c.texels[i][0] as f32,
                c.texels[i][1] as f32,
                c.texels[i][2] as f32,
            ) * (c.scale / 65535.0)
        };
        let peak = a.scale.max(b.scale);
        for i in 0..a.texels.len() {
            assert!(
                (v(a, i) - v(b, i)).abs().max_element() <= 2e-3 * peak,
                "texel {i}"
            );
        }
    }

    #[test]
    fn interpolation_is_exact_at_the_corners_and_agrees_across_an_edge() {
        let d = rotated_copies(1, 0.25);
        let ico = d.icosphere();
        for (fi, f) in ico.faces.iter().enumerate().take(12) {
            for k in 0..3 {
                let mut w = [0.0; 3];
                w[k] = 1.0;
                let got = d.interpolate_face(fi, w);
                let want = &d.sets[f[k] as usize].csls;
                assert_eq!(got.len(), want.len());
                for (g, c) in got.iter().zip(want) {
                    same_csl(g, c, 1e-5);
                }
            }
        }
        // A point on the edge between two faces, from both sides.
        let edge = |f: [u32; 3]| [[f[0], f[1]], [f[1], f[2]], [f[2], f[0]]];
        let (fa, fb) = (0..ico.faces.len())
            .flat_map(|a| (0..ico.faces.len()).map(move |b| (a, b)))
            .find(|&(a, b)| {
                a != b
                    && edge(ico.faces[a])
                        .iter()
                        .any(|e| edge(ico.faces[b]).contains(&[e[1], e[0]]))
            })
            .unwrap();
        let [p, q] = *edge(ico.faces[fa])
            .iter()
            .find(|e| edge(ico.faces[fb]).contains(&[e[1], e[0]]))
            .unwrap();
        let weights = |f: [u32; 3]| {
            f.map(|v| {
                if v == p {
                    0.3
                } else if v == q {
                    0.7
                } else {
                    0.0
                }
            })
        };
        let a = d.interpolate_face(fa, weights(ico.faces[fa]));
        let b = d.interpolate_face(fb, weights(ico.faces[fb]));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            same_csl(x, y, 1e-5);
        }
    }

    /// For copies turned with the light (axes along it, as a sphere's), the interpolated set
    /// anywhere is the copy turned to that direction, light plane and flux, even at the 63°
    /// spacing of the bare icosahedron.
    #[test]
    fn interpolating_turned_copies_turns_the_set() {
        let d = rotated_copies(0, 0.0);
        let base_dir = d.sets[0].light_dir;
        for dir in [Vec3::new(0.3, -0.9, 0.2), Vec3::new(-0.5, 0.1, 0.8)] {
            let dir = dir.normalize();
            let got = d.interpolate(dir).csls;
            for (g, c) in got.iter().zip(&d.sets[0].csls) {
                let q = Quat::from_rotation_arc(base_dir, dir);
                let want_axis = q * c.axis;
                assert!(
                    g.axis.dot(want_axis) > 1.0 - 1e-6,
                    "{} {}",
                    g.axis,
                    want_axis
                );
                let centre = d.sets[0].centre;
                let want_origin = centre + q * (c.origin - centre);
                assert!((g.origin - want_origin).length() < 1e-4, "{}", g.origin);
                // Flux is carried through: the image peak is the members' peak.
                let peak = |c: &Csl| {
                    c.texels.iter().map(|t| t[0]).max().unwrap() as f32 * c.scale / 65535.0
                };
                assert!(
                    (peak(g) - peak(c)).abs() < 0.05 * peak(c),
                    "{} {}",
                    peak(g),
                    peak(c)
                );
            }
        }
    }
}
