//! Stage 4 of the CSL bake, the intensity image: every kept ray's flux is splatted onto the
//! light plane where its line crosses it, with an elliptical Gaussian (EWA) whose axes are
//! δ/(d̂·â) along the radial direction p − c and δ across it (the paper's ellipse), convolved
//! with a half-pixel Gaussian prefilter (Zwicker et al.'s EWA resampling filter) and truncated
//! at two standard deviations. Weights are normalised per splat so that each ray's flux lands
//! in the image exactly. Values are flux per square metre of light plane per unit irradiance of
//! the light, then quantised to 16 bits.

use super::trace::CausticRay;
use glam::Vec3;

/// A float intensity image on the light plane: square, `size` texels per side, covering
/// [-half, half]² in the plane frame (x̂, ŷ).
pub struct PlaneImage {
    pub size: u32,
    pub half: f32,
    pub texels: Vec<Vec3>,
    /// Flux actually deposited (per unit irradiance, m²).
    pub flux: f64,
}

/// Splat `kept` rays onto the plane through `c` with normal `a` and in-plane axes `x`, `y`.
/// `delta` is the splat size (m), `area` the cross-section of one grid ray (m²).
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
    size: u32,
) -> PlaneImage {
    // Plane positions, radial unit vectors and the ellipse's radial semi-axis per ray.
    let pts: Vec<(f32, f32, f32, Vec3)> = kept
        .iter()
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
    half *= 1.0 + 1.0 / size as f32;
    let pix = 2.0 * half / size as f32;
    let mut texels = vec![Vec3::ZERO; (size * size) as usize];
    let mut flux = 0.0f64;
    let pre = 0.25 * pix * pix; // (pix/2)² prefilter variance
    let mut weights: Vec<(usize, f32)> = Vec::new();
    for &(px, py, major, e) in &pts {
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
        for &(k, wgt) in &weights {
            texels[k] += e * (wgt * scale);
        }
        flux += (e.element_sum() / 3.0) as f64;
    }
    PlaneImage {
        size,
        half,
        texels,
        flux,
    }
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
