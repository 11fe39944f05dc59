//! Liu et al. 2008 §4.1: the CSL set for any light direction, interpolated from the triples of
//! the dynamic bake's icosahedron face it passes through. This runs every frame, so it lives on
//! the render side; it depends on the bake only through public items ([`DynamicSet`]'s fields
//! and accessors, [`Triple`](crate::bake::csl::dynamic::Triple), [`Share`],
//! [`Icosphere::locate`](crate::bake::csl::dynamic::Icosphere::locate)).

use crate::bake::Fnv64;
use crate::bake::csl::dynamic::{DynamicSet, Share};
use crate::bake::csl::image::quantise;
use crate::bake::csl::{Csl, CslSet};
use crate::render::csl::pass::MAX_FRAME_CSLS;
use glam::{Quat, Vec3};
use rayon::prelude::*;

impl DynamicSet {
    /// The CSLs of face `fi` at barycentric weights `w` (corner order): one per member of a
    /// triple that lends light there.
    pub fn interpolate_face(&self, fi: usize, w: [f32; 3]) -> Vec<Csl> {
        self.interpolate_in(self.icosphere().faces[fi], fi, w)
    }

    /// [`Self::interpolate_face`] for face `fi` whose corners `f` the caller has.
    fn interpolate_in(&self, f: [u32; 3], fi: usize, w: [f32; 3]) -> Vec<Csl> {
        self.interpolate_capped(f, fi, w, MAX_FRAME_CSLS)
    }

    /// [`Self::interpolate_in`] with at most `cap` CSLs where blending triples can make it so.
    fn interpolate_capped(&self, f: [u32; 3], fi: usize, w: [f32; 3], cap: usize) -> Vec<Csl> {
        let centre = self.sets[0].centre;
        // Each triple's members: weights for the geometry and for the images.
        type Members<'a> = (Vec<(&'a Csl, f32)>, Vec<(&'a Csl, f32)>);
        let triples: Vec<Members> = self.triples[fi]
            .iter()
            .map(|t| {
                let c = [0, 1, 2].map(|k| self.csl(f[k] as usize, t.members[k].csl));
                let mut geometry: Vec<(&Csl, f32)> = (0..3).map(|k| (c[k], w[k])).collect();
                if let Some(z) = t.split {
                    // A pair triple: its third corner's weight shared by the partners of its
                    // two image members there, in proportion to those members' weights.
                    let Some(k) = (0..3).find(|&k| t.members[k].image == Share::None) else {
                        return (Vec::new(), Vec::new());
                    };
                    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                    let sum = w[i] + w[j];
                    let share = if sum > 0.0 { w[i] / sum } else { 0.5 };
                    geometry[k].1 = w[k] * share;
                    geometry.push((self.csl(f[k] as usize, z), w[k] * (1.0 - share)));
                }
                // In the order of the corners' vertex numbers, so that the two faces of an edge
                // give the same CSLs in the same order.
                let mut corners = [0usize, 1, 2];
                corners.sort_by_key(|&k| f[k]);
                let image: Vec<(&Csl, f32)> = corners
                    .iter()
                    .map(|&k| (c[k], w[k] * t.members[k].image.fraction()))
                    .collect();
                (geometry, image)
            })
            .collect();
        let mut groups: Vec<Vec<Csl>> = triples
            .par_iter()
            .map(|(geometry, image)| interpolate_csl(geometry, image, centre))
            .collect();
        // A complex object's set (hundreds of triples a face) can be more CSLs than a frame
        // takes when every member is its own: then the triples of least flux are blended into
        // one CSL each, as the paper does, until the set fits.
        let mut count: usize = groups.iter().map(Vec::len).sum();
        if count > cap {
            let flux = |g: &Vec<Csl>| g.iter().map(|c| c.flux).sum::<f32>();
            let mut order: Vec<usize> =
                (0..groups.len()).filter(|&i| groups[i].len() > 1).collect();
            order.sort_by(|&a, &b| {
                flux(&groups[a])
                    .total_cmp(&flux(&groups[b]))
                    .then(a.cmp(&b))
            });
            let mut merge = Vec::new();
            for i in order {
                if count <= cap {
                    break;
                }
                count -= groups[i].len() - 1;
                merge.push(i);
            }
            let blended: Vec<(usize, Option<Csl>)> = merge
                .par_iter()
                .map(|&i| (i, blend_csl(&triples[i].0, &triples[i].1, centre)))
                .collect();
            for (i, c) in blended {
                groups[i] = c.into_iter().collect();
            }
        }
        groups.into_iter().flatten().collect()
    }

    /// The CSL set for light travel direction `light_dir` (object rigid frame), interpolated
    /// from the triples of the face it passes through (§4.1): axes by spherical interpolation,
    /// the axis line's position linearly, and each member moved onto the new axis by the
    /// rotation about â × âᵢ with its own focus law and its image weighted
    /// ([`interpolate_csl`]).
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

/// What both interpolations of a triple start from: the members that lend light (`lit`, with
/// their image weights), the blended axis and a point of the blended axis line.
struct Blend<'a> {
    lit: Vec<(&'a Csl, f32)>,
    axis: Vec3,
    origin: Vec3,
}

impl<'a> Blend<'a> {
    /// None when no image member lends light. The axis line's point: the light-plane origins
    /// relative to the bounding centre, each turned with its axis, blended (the paper's linear
    /// blend of the origins, but one that does not pull the plane towards the centre when the
    /// axes differ, by 1 - cos(θ/2) of its distance between axes θ apart).
    fn of(geometry: &[(&Csl, f32)], image: &[(&'a Csl, f32)], centre: Vec3) -> Option<Self> {
        let lit: Vec<(&Csl, f32)> = image
            .iter()
            .copied()
            .filter(|(c, w)| *w > 1e-6 && !c.texels.is_empty() && c.scale > 0.0)
            .collect();
        if lit.is_empty() {
            return None;
        }
        let axis = blend_axes(geometry);
        let origin = centre
            + geometry
                .iter()
                .map(|(c, w)| Quat::from_rotation_arc(c.axis, axis) * (c.origin - centre) * *w)
                .fold(Vec3::ZERO, |a, b| a + b);
        Some(Blend { lit, axis, origin })
    }
}

/// `v` made perpendicular to unit `axis` and unit (any perpendicular where it is along it).
fn in_plane(v: Vec3, axis: Vec3) -> Vec3 {
    let p = v - axis * v.dot(axis);
    if p.length() > 1e-3 {
        p.normalize()
    } else {
        axis.any_orthonormal_vector()
    }
}

/// The interpolated CSLs of one triple, from `geometry` (CSLs and their weights for the axis
/// and the light plane's position) and `image` (CSLs and the weights of their intensity images):
/// one CSL per member that lends light, none when no member does.
///
/// The paper (§4.1) blends the members into one CSL: axes by spherical interpolation, light-plane
/// origins, α and β linearly, and the intensity images, each turned onto the new axis by the
/// rotation about â × âᵢ, blended linearly. Here the axis and the axis line are blended as the
/// paper's steps 1–2 do, but each member keeps its own focus law (α, β), its light plane's depth
/// along the axis and its image, and is moved rigidly onto the blended axis by that same
/// rotation, its image weighted by the member's barycentric weight: the image moves with its
/// axis instead of being resampled and cross-faded, and each ray keeps the focus its bake
/// measured. At a corner it is that corner's CSL; each member's flux is carried exactly (the
/// weights sum to one), and the members' sum is the paper's blended image wherever their focus
/// laws agree. Two members whose bundles focus differently (the concentric rings of a sphere,
/// split differently at neighbouring directions) no longer get one focus law that is neither
/// of theirs: on the glass sphere at the paper's settings that took the error near a face's
/// centre, in the sphere's shadow against Mitsuba 3, from 0.136–0.139 to 0.114 relative L1
/// and the flux from 0.965–0.968 to 0.989 (`docs/methods/csl.md`). A frame draws up to three
/// CSLs per triple instead of one ([`blend_csl`] where that is too many).
fn interpolate_csl(geometry: &[(&Csl, f32)], image: &[(&Csl, f32)], centre: Vec3) -> Vec<Csl> {
    let Some(Blend { lit, axis, origin }) = Blend::of(geometry, image, centre) else {
        return Vec::new();
    };
    let depth = |c: &Csl| (c.origin - centre).dot(c.axis);
    let line_depth = (origin - centre).dot(axis);
    lit.iter()
        .map(|&(c, w)| {
            let q = Quat::from_rotation_arc(c.axis, axis);
            Csl {
                origin: origin + axis * (depth(c) - line_depth),
                axis,
                x_axis: in_plane(q * c.x_axis, axis),
                scale: c.scale * w,
                flux: c.flux * w,
                ..c.clone()
            }
        })
        .collect()
}

/// The paper's interpolation of one triple (§4.1), for sets whose members would be more CSLs
/// than a frame takes ([`MAX_FRAME_CSLS`]): one CSL from `geometry` (CSLs and their weights for
/// the axis, origin and focus law) and `image` (CSLs and the weights of their intensity
/// images), or None when no image member lends it light. Axes by spherical interpolation,
/// light-plane origins and the focus law (κ = 1/α, γ = β/α) linearly, and the intensity images,
/// each turned onto the new axis by the rotation about â × âᵢ, resampled and blended linearly.
fn blend_csl(geometry: &[(&Csl, f32)], image: &[(&Csl, f32)], centre: Vec3) -> Option<Csl> {
    let Blend { lit, axis, origin } = Blend::of(geometry, image, centre)?;
    let turn = |c: &Csl| Quat::from_rotation_arc(c.axis, axis);
    let sum = |f: &dyn Fn(&Csl) -> Vec3| {
        geometry
            .iter()
            .map(|(c, w)| f(c) * *w)
            .fold(Vec3::ZERO, |a, b| a + b)
    };
    let kappa = geometry.iter().map(|(c, w)| c.kappa * w).sum();
    let gamma = geometry.iter().map(|(c, w)| c.gamma * w).sum();
    // The new image frame: the members' x axes turned onto the new axis, blended with the
    // weights (symmetric in the members, so the two faces of an edge agree on it).
    let x_axis = in_plane(sum(&|c| turn(c) * c.x_axis), axis);
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

    /// Where the members would be more CSLs than a frame takes, the triples of least flux are
    /// blended into one CSL each (the paper's interpolation) until the set fits; the flux stays.
    #[test]
    fn too_many_members_are_blended_until_the_set_fits() {
        let d = rotated_copies(1, 0.25);
        let ico = d.icosphere();
        let (fi, w) = (5, [0.5, 0.3, 0.2]);
        let f = ico.faces[fi];
        let all = d.interpolate_face(fi, w);
        let flux = |s: &[Csl]| s.iter().map(|c| c.flux as f64).sum::<f64>();
        assert!(all.len() > 2, "{}", all.len());
        for cap in [all.len() - 1, all.len() / 2, 1] {
            let some = d.interpolate_capped(f, fi, w, cap);
            assert!(some.len() < all.len() && !some.is_empty());
            // Each blended triple is one CSL; only triples of one CSL cannot shrink.
            let singles = d.triples[fi].len();
            assert!(some.len() <= cap.max(singles), "{} > {cap}", some.len());
            assert!((flux(&some) - flux(&all)).abs() < 1e-4 * flux(&all));
        }
    }

    /// For copies turned with the light (axes along it, as a sphere's), the interpolated set
    /// anywhere is the copy turned to that direction, light plane and flux, even at the 63°
    /// spacing of the bare icosahedron: every interpolated CSL is a turned copy of one of the
    /// set's, and together they carry the set's flux and the peaks of its images.
    #[test]
    fn interpolating_turned_copies_turns_the_set() {
        let d = rotated_copies(0, 0.0);
        let base_dir = d.sets[0].light_dir;
        let centre = d.sets[0].centre;
        let peak =
            |c: &Csl| c.texels.iter().map(|t| t[0]).max().unwrap() as f32 * c.scale / 65535.0;
        for dir in [Vec3::new(0.3, -0.9, 0.2), Vec3::new(-0.5, 0.1, 0.8)] {
            let dir = dir.normalize();
            let got = d.interpolate(dir).csls;
            let q = Quat::from_rotation_arc(base_dir, dir);
            let (mut flux, mut peaks) = (0.0f32, 0.0f32);
            for g in &got {
                assert!(
                    d.sets[0].csls.iter().any(|c| {
                        g.axis.dot(q * c.axis) > 1.0 - 1e-6
                            && (g.origin - (centre + q * (c.origin - centre))).length() < 1e-4
                            && (g.kappa, g.gamma) == (c.kappa, c.gamma)
                    }),
                    "{g:?} is no turned copy"
                );
                flux += g.flux;
                peaks += peak(g);
            }
            // (The two copies are alike here: an axis through the centre turns with the light.)
            let want: f32 = d.sets[0].csls.iter().map(|c| c.flux).sum();
            assert!((flux - want).abs() < 1e-4 * want, "{flux} {want}");
            let want: f32 = d.sets[0].csls.iter().map(peak).sum();
            assert!((peaks - want).abs() < 1e-3 * want, "{peaks} {want}");
        }
    }
}
