//! Stage 4 of the CSL bake, the intensity image: every kept ray's flux is splatted onto the
//! light plane where its line crosses it, with an elliptical Gaussian (EWA) whose axes are
//! δ/(d̂·â) along the radial direction p − c and δ across it (the paper's ellipse), convolved
//! with a half-pixel Gaussian prefilter (Zwicker et al.'s EWA resampling filter) and truncated
//! at two standard deviations. Weights are normalised per splat so that each ray's flux lands
//! in the image exactly. Values are flux per square metre of light plane per unit irradiance of
//! the light, then quantised to 16 bits.

use super::trace::CausticRay;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The rays of one image are splatted in this many fixed shares, in parallel, each into an
/// image of its own; the shares' images are added in order, so the image does not depend on
/// the thread count.
const SHARES: usize = 8;

/// A float intensity image on the light plane: square, `size` texels per side, covering
/// [-half, half]² in the plane frame (x̂, ŷ).
pub struct PlaneImage {
    pub size: u32,
    pub half: f32,
    pub texels: Vec<Vec3>,
    /// Flux actually deposited (per unit irradiance, m²).
    pub flux: f64,
    /// The image's grain: the mean contribution of one ray to a texel, weighted by the texels'
    /// values (texel units), in the channel where it is finest. A texel of value v holds about
    /// v / grain rays' worth, so its sampling noise is about √(v · grain) (sums of weighted
    /// rays: the variance of a texel is the sum of its contributions' squares, whose ratio to
    /// their sum this averages). 0 for an empty image.
    pub grain: f64,
}

/// Texels per side of an image covering [-half, half]² (m): 128, 256 or 512 (the paper's
/// sizes), the one nearest (in ratio) to a texel of `texel` metres, at most `max_size`.
pub fn image_size(half: f32, texel: f32, max_size: u32) -> u32 {
    let raw = 2.0 * half / texel;
    let n = if raw < 128.0 * std::f32::consts::SQRT_2 {
        128
    } else if raw < 256.0 * std::f32::consts::SQRT_2 {
        256
    } else {
        512
    };
    n.min(max_size)
}

/// Splat `kept` rays onto the plane through `c` with normal `a` and in-plane axes `x`, `y`.
/// `delta` is the splat size (m), `area` the cross-section of one grid ray (m²); the image's
/// size follows the extent the rays cover ([`image_size`] for texels of `texel` metres, at most
/// `max_size` per side).
#[allow(clippy::too_many_arguments)]
pub fn splat(
    rays: &[CausticRay],
    kept: &[u32],
    c: Vec3,
    a: Vec3,
    x: Vec3,
    y: Vec3,
    delta: f32,
    area: f32,
    texel: f32,
    max_size: u32,
) -> PlaneImage {
    // Plane positions, radial unit vectors and the ellipse's radial semi-axis per ray.
    let pts: Vec<(f32, f32, f32, Vec3)> = kept
        .par_iter()
        .map(|&i| {
            let r = &rays[i as usize];
            let da = r.dir.dot(a).max(1e-3);
            let s = (c - r.origin).dot(a) / da;
            let p = r.origin + r.dir * s - c;
            (p.dot(x), p.dot(y), delta / da, r.energy * area)
        })
        .collect();
    let mut half = pts
        .iter()
        .map(|&(px, py, major, _)| (px * px + py * py).sqrt() + major)
        .fold(delta, f32::max);
    let size = image_size(half, texel, max_size);
    half *= 1.0 + 1.0 / size as f32;
    let pix = 2.0 * half / size as f32;
    let pre = 0.25 * pix * pix; // (pix/2)² prefilter variance
    let share = pts.len().div_ceil(SHARES).max(1);
    let parts: Vec<(Vec<Vec3>, DVec3, DVec3)> = pts
        .par_chunks(share)
        .map(|part| splat_share(part, half, pix, pre, delta, size))
        .collect();
    let mut parts = parts.into_iter();
    let (mut texels, mut flux, mut squares) = parts.next().unwrap_or_else(|| {
        (
            vec![Vec3::ZERO; (size * size) as usize],
            DVec3::ZERO,
            DVec3::ZERO,
        )
    });
    for (t, f, q) in parts {
        for (a, b) in texels.iter_mut().zip(&t) {
            *a += *b;
        }
        flux += f;
        squares += q;
    }
    // Per channel, Σ over texels of the values is the flux over the texel area.
    let area = pix as f64 * pix as f64;
    let grain = (0..3)
        .filter(|&k| flux[k] > 0.0)
        .map(|k| squares[k] * area / flux[k])
        .fold(f64::INFINITY, f64::min);
    PlaneImage {
        size,
        half,
        texels,
        flux: flux.element_sum() / 3.0,
        grain: if grain.is_finite() { grain } else { 0.0 },
    }
}

/// The image of one share of the splats (plane x, y, radial semi-axis, flux), its flux and the
/// sum over its texels of the squares of the rays' contributions, per channel.
fn splat_share(
    pts: &[(f32, f32, f32, Vec3)],
    half: f32,
    pix: f32,
    pre: f32,
    delta: f32,
    size: u32,
) -> (Vec<Vec3>, DVec3, DVec3) {
    let mut texels = vec![Vec3::ZERO; (size * size) as usize];
    let (mut flux, mut squares) = (DVec3::ZERO, DVec3::ZERO);
    let mut weights: Vec<(usize, f32)> = Vec::new();
    for &(px, py, major, e) in pts {
        let r = (px * px + py * py).sqrt();
        let (ux, uy) = if r > 1e-9 {
            (px / r, py / r)
        } else {
            (1.0, 0.0)
        };
        // Covariance in (radial, tangential) coordinates: σ = semi-axis / 2.
        let sr = 0.25 * major * major + pre;
        let st = 0.25 * delta * delta + pre;
        let ext = 2.0 * sr.sqrt().max(st.sqrt());
        let gx = |v: f32| ((v + half) / pix - 0.5).round() as i64;
        let (x0, x1) = (gx(px - ext).max(0), gx(px + ext).min(size as i64 - 1));
        let (y0, y1) = (gx(py - ext).max(0), gx(py + ext).min(size as i64 - 1));
        weights.clear();
        let mut sum = 0.0f32;
        for j in y0..=y1 {
            for i in x0..=x1 {
                let cx = -half + (i as f32 + 0.5) * pix - px;
                let cy = -half + (j as f32 + 0.5) * pix - py;
                let dr = cx * ux + cy * uy;
                let dt = -cx * uy + cy * ux;
                let m2 = dr * dr / sr + dt * dt / st;
                if m2 <= 4.0 {
                    let wgt = (-0.5 * m2).exp();
                    weights.push(((j as u32 * size + i as u32) as usize, wgt));
                    sum += wgt;
                }
            }
        }
        if sum <= 0.0 {
            // Narrower than a texel and between centres: the nearest texel takes it all.
            let (i, j) = (
                gx(px).clamp(0, size as i64 - 1),
                gx(py).clamp(0, size as i64 - 1),
            );
            weights.push(((j as u32 * size + i as u32) as usize, 1.0));
            sum = 1.0;
        }
        let scale = 1.0 / (sum * pix * pix);
        let mut w2 = 0.0f32;
        for &(k, wgt) in &weights {
            texels[k] += e * (wgt * scale);
            w2 += wgt * wgt;
        }
        let e = e.as_dvec3();
        flux += e;
        squares += e * e * (w2 * scale * scale) as f64;
    }
    (texels, flux, squares)
}

/// Linear 16-bit quantisation with one scale per image: value = q / 65535 · scale.
pub fn quantise(texels: &[Vec3]) -> (f32, Vec<[u16; 3]>) {
    let max = texels.iter().fold(0.0f32, |m, t| m.max(t.max_element()));
    if max <= 0.0 {
        return (0.0, vec![[0; 3]; texels.len()]);
    }
    let k = 65535.0 / max;
    let q = texels
        .iter()
        .map(|t| {
            let v = (*t * k).round().clamp(Vec3::ZERO, Vec3::splat(65535.0));
            [v.x as u16, v.y as u16, v.z as u16]
        })
        .collect();
    (max, q)
}

/// The image of `c` at half its resolution (2×2 box: the same flux over the same extent),
/// re-quantised. An odd size drops its last row and column into the one before.
pub fn halve(c: &super::Csl) -> super::Csl {
    let n = c.size as usize;
    let m = (n / 2).max(1);
    let mut f = vec![Vec3::ZERO; m * m];
    let k = c.scale / 65535.0;
    for j in 0..n {
        for i in 0..n {
            let t = c.texels[j * n + i];
            let (a, b) = ((i / 2).min(m - 1), (j / 2).min(m - 1));
            f[b * m + a] += Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32) * k;
        }
    }
    // Each coarse texel covers (n/m)² fine ones: the mean keeps the flux per m².
    let area = (n * n) as f32 / (m * m) as f32;
    for v in &mut f {
        *v /= area;
    }
    let (scale, texels) = quantise(&f);
    super::Csl {
        size: m as u32,
        scale,
        // A ray's contribution to a coarse texel is between a quarter of its contribution to a
        // fine one (a narrow splat) and all of it (a splat over the four): the smaller bound
        // keeps the grain's promise (noise no smaller than it says).
        grain: if scale > 0.0 {
            c.grain * c.scale / (4.0 * scale)
        } else {
            0.0
        },
        texels,
        ..c.clone()
    }
}

/// When the images of `csls` hold more than `max_texels` texels, copies with the images of
/// the CSLs of least flux halved in resolution (repeatedly, down to 16²) until they fit, and
/// how many halvings that took; None when they fit already (or cannot be made to).
pub fn fit_images(csls: &[super::Csl], max_texels: u64) -> Option<(Vec<super::Csl>, u32)> {
    let total = |c: &[super::Csl]| c.iter().map(|c| c.texels.len() as u64).sum::<u64>();
    if total(csls) <= max_texels {
        return None;
    }
    let mut out = csls.to_vec();
    let mut order: Vec<usize> = (0..out.len()).collect();
    order.sort_by(|&a, &b| out[a].flux.total_cmp(&out[b].flux).then(a.cmp(&b)));
    let mut halved = 0;
    let mut sum = total(&out);
    while sum > max_texels {
        let mut changed = false;
        for &i in &order {
            if out[i].size <= 16 || out[i].texels.is_empty() {
                continue;
            }
            let before = out[i].texels.len() as u64;
            out[i] = halve(&out[i]);
            sum = sum - before + out[i].texels.len() as u64;
            halved += 1;
            changed = true;
            if sum <= max_texels {
                break;
            }
        }
        if !changed {
            return None;
        }
    }
    Some((out, halved))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::csl::Csl;

    fn csl(size: u32, flux: f32) -> Csl {
        let texels: Vec<Vec3> = (0..size * size)
            .map(|i| {
                let (x, y) = ((i % size) as f32, (i / size) as f32);
                Vec3::new(1.0 + x, 2.0 + y, (x * y).sqrt())
            })
            .collect();
        let (scale, texels) = quantise(&texels);
        Csl {
            origin: Vec3::ZERO,
            axis: Vec3::Z,
            x_axis: Vec3::X,
            kappa: 1.0,
            gamma: 0.0,
            half_extent: 0.5,
            size,
            scale,
            flux,
            grain: 0.0,
            texels,
        }
    }

    fn image_flux(c: &Csl) -> Vec3 {
        let pix = 2.0 * c.half_extent / c.size as f32;
        c.texels
            .iter()
            .map(|t| Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32))
            .fold(Vec3::ZERO, |a, b| a + b)
            * (c.scale / 65535.0 * pix * pix)
    }

    /// The image's size follows the extent its rays cover on the light plane: 128, 256 or 512
    /// texels a side, whichever gives texels nearest the wanted width, at most the cap; the
    /// flux is the rays' whatever the size.
    #[test]
    fn image_size_follows_the_light_planes_extent() {
        let t = 1e-3;
        assert_eq!(image_size(10.0 * t, t, 512), 128);
        assert_eq!(image_size(90.0 * t, t, 512), 128); // 180 texels wanted: nearer 128
        assert_eq!(image_size(92.0 * t, t, 512), 256); // 184: nearer 256
        assert_eq!(image_size(180.0 * t, t, 512), 256);
        assert_eq!(image_size(182.0 * t, t, 512), 512);
        assert_eq!(image_size(2000.0 * t, t, 512), 512);
        assert_eq!(image_size(2000.0 * t, t, 256), 256);
        assert_eq!(image_size(2000.0 * t, t, 128), 128);
        // Rays parallel to the axis through a disc of radius ρ: an image of half-width ρ
        // (plus the splat).
        for (rho, want) in [(0.02f32, 128u32), (0.12, 256), (0.4, 512)] {
            let rays: Vec<CausticRay> = (0..2000)
                .map(|k| {
                    let (r, phi) = (rho * ((k as f32 + 0.5) / 2000.0).sqrt(), k as f32 * 2.4);
                    CausticRay {
                        origin: Vec3::new(r * phi.cos(), r * phi.sin(), -1.0),
                        dir: Vec3::Z,
                        energy: Vec3::ONE,
                    }
                })
                .collect();
            let kept: Vec<u32> = (0..2000).collect();
            let img = splat(
                &rays,
                &kept,
                Vec3::ZERO,
                Vec3::Z,
                Vec3::X,
                Vec3::Y,
                t,
                1e-6,
                t,
                512,
            );
            assert_eq!(img.size, want, "ρ = {rho}");
            assert!((img.flux / 2000e-6 - 1.0).abs() < 1e-3, "{}", img.flux);
        }
    }

    #[test]
    fn halving_keeps_the_flux_and_fitting_halves_the_faintest_first() {
        let c = csl(64, 1.0);
        let h = halve(&c);
        assert_eq!(h.size, 32);
        let (a, b) = (image_flux(&c), image_flux(&h));
        assert!(((a - b).abs() / a).max_element() < 1e-3, "{a} {b}");
        let set = vec![csl(64, 0.5), csl(64, 0.01), csl(64, 0.2)];
        assert!(fit_images(&set, 3 * 64 * 64).is_none());
        let (fitted, halved) = fit_images(&set, 3 * 64 * 64 - 1).unwrap();
        assert_eq!(halved, 1);
        assert_eq!(
            fitted.iter().map(|c| c.size).collect::<Vec<_>>(),
            [64, 32, 64]
        );
        // Cannot fit below 16² each: refused.
        assert!(fit_images(&set, 100).is_none());
    }
}
