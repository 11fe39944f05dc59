//! A fitted CSL whose rays its focus law misses split into rings of light-plane radius, each
//! fitted again: the paper's focus law 1/f(r) = κ + γr (Liu et al. 2008 Eq. 1) is linear in
//! the radius, while a lens's longitudinal spherical aberration grows with r² near the axis, so
//! one law fitted to a whole glass sphere's bundle leaves its outer tenth of rays 0.39° off
//! (RMS; 0.06° near the axis), which on a floor near the caustic's waist moves the focus's
//! light by pixels (the canonical sphere lit from 69° above the horizon: 0.137 relative L1 in its
//! shadow, 0.109 of it in the brightest tenth of the pixels; in three rings 0.063). A ring is a
//! CSL of its own (the same axis, its own light plane, focus law and intensity image, its rays
//! only), so the renderer and the dynamic bake take it as any other CSL; the law becomes
//! piecewise linear in r, which follows the aberration.

use super::bundle::{Bundle, det_sum};
use super::fit::{self, Fit, csl_dir};
use super::trace::CausticRay;

/// A CSL is split while the RMS direction error of its worst tenth of rays ([`worst_error`]) is
/// above this (radians: 0.25°, about a pixel at a metre in a 256² view of a couple of metres).
pub const SPLIT_RMS: f64 = 0.25 * std::f64::consts::PI / 180.0;

/// Rings a CSL is split into at a time.
const RINGS: usize = 3;

/// Fewest rays a ring keeps: below, a split is not tried (a ring's image and fit need rays).
const MIN_RING_RAYS: usize = 2048;

/// A CSL that carries less than this fraction of the energy leaving the object is not split.
pub const WORTH: f64 = 0.02;

/// Most CSLs one fitted bundle becomes.
pub const MAX_PIECES: usize = 9;

/// For each kept ray of `fit`: its light-plane radius, its squared direction error under the
/// fitted CSL (‖d̂ − ê‖², about the angle²), and its weight.
fn residuals(rays: &[CausticRay], fit: &Fit) -> Vec<(f64, f64, f64)> {
    let a = fit.axis.as_dvec3();
    let c = fit.origin.as_dvec3();
    fit.kept
        .iter()
        .map(|&i| {
            let r = &rays[i as usize];
            let q = r.origin.as_dvec3();
            let d = r.dir.as_dvec3();
            let s = (c - q).dot(a) / d.dot(a);
            let u = q + d * s - c;
            let u = u - a * u.dot(a);
            let e = csl_dir(a, u, fit.kappa, fit.gamma);
            (u.length(), (d - e).length_squared(), r.weight() as f64)
        })
        .collect()
}

/// The direction error (radians, small-angle) of `fit`'s kept rays where its law is worst: the
/// largest of the energy-weighted RMS errors of the ten tenths of its rays by light-plane
/// radius (a law that misses one ring of rays, the marginal rays of a lens say, moves that
/// ring's light however well it fits the rest).
pub fn worst_error(rays: &[CausticRay], fit: &Fit) -> f64 {
    worst_and_reach(rays, fit).0
}

/// [`worst_error`], and the largest light-plane radius of `fit`'s kept rays.
fn worst_and_reach(rays: &[CausticRay], fit: &Fit) -> (f64, f64) {
    let mut res = residuals(rays, fit);
    res.sort_by(|x, y| x.0.total_cmp(&y.0));
    let n = res.len();
    let worst = (0..10)
        .map(|q| {
            let part = &res[q * n / 10..(q + 1) * n / 10];
            let (e2, w) = part
                .iter()
                .fold((0.0, 0.0), |(e, s), &(_, d2, w)| (e + d2 * w, s + w));
            if w > 0.0 { (e2 / w).sqrt() } else { 0.0 }
        })
        .fold(0.0, f64::max);
    (worst, res.last().map_or(0.0, |r| r.0))
}

/// `fit` as one or more CSL fits: while a piece's worst tenth of rays misses its law by more
/// than [`SPLIT_RMS`], or its rays reach farther than twice `fine` from the axis (its image
/// would be coarser than they need: a lens's steep marginal rays spread over metres of light
/// plane), and it has rays enough, it is cut into [`RINGS`] rings of equal energy by
/// light-plane radius and each ring is fitted again on the same axis (`args`: the bake's
/// length, plane weight, angle threshold and fit samples, as [`fit::fit_bundle`] takes them);
/// a ring's dismissed rays return to the pool as the fit's do. At most `most` pieces; a piece
/// that carries less energy than `worth` is not split (a faint reflection spread over the floor
/// gains little and would cost every frame CSLs); a split is taken only when its rings keep 98 %
/// of the piece's energy and lower its worst error by a fifth (or, for a split made for its
/// reach, keep it within [`SPLIT_RMS`] or the piece's). Deterministic: the same pieces for the
/// same rays.
pub fn split(
    rays: &[CausticRay],
    fit: Fit,
    args: (f64, f64, f64, usize),
    (most, worth): (usize, f64),
    fine: f64,
    beside: bool,
) -> Vec<Fit> {
    let mut done = Vec::new();
    let mut open = vec![fit];
    while let Some(f) = open.pop() {
        let pieces = done.len() + open.len() + 1;
        let kept = |f: &Fit| det_sum(&f.kept, 0.0, |&i| rays[i as usize].weight() as f64);
        let before = kept(&f);
        if before < worth {
            done.push(f);
            continue;
        }
        let (error, reach) = worst_and_reach(rays, &f);
        let wide = reach > 2.0 * fine;
        if (error <= SPLIT_RMS && !wide)
            || f.kept.len() < RINGS * MIN_RING_RAYS
            || pieces + RINGS - 1 > most
        {
            done.push(f);
            continue;
        }
        let rings = rings_of(rays, &f);
        let fits: Vec<Fit> = rings
            .into_iter()
            .map(|members| {
                let bundle = Bundle {
                    origin: f.origin,
                    axis: f.axis,
                    members,
                    iterations: 0,
                };
                fit::fit_bundle(rays, &bundle, args.0, args.1, args.2, args.3, beside)
            })
            .collect();
        // Taken only when the rings together fit better (or, cut for their reach, no worse)
        // and keep (nearly) the light.
        let after: f64 = fits.iter().map(kept).sum();
        let worst = fits
            .iter()
            .map(|g| worst_error(rays, g))
            .fold(0.0, f64::max);
        let better = worst < 0.8 * error || (wide && worst <= error.max(SPLIT_RMS));
        if fits.iter().any(|g| g.kept.is_empty()) || after < 0.98 * before || !better {
            done.push(f);
            continue;
        }
        open.extend(fits);
    }
    // Brightest first, as the bake makes its CSLs (each piece's energy summed once).
    let mut lit: Vec<(f64, Fit)> = done
        .into_iter()
        .map(|f| {
            (
                det_sum(&f.kept, 0.0, |&i| rays[i as usize].weight() as f64),
                f,
            )
        })
        .collect();
    lit.sort_by(|x, y| y.0.total_cmp(&x.0));
    lit.into_iter().map(|(_, f)| f).collect()
}

/// `fit`'s kept rays in [`RINGS`] rings of about equal energy by light-plane radius, each in
/// ascending ray order.
fn rings_of(rays: &[CausticRay], fit: &Fit) -> Vec<Vec<u32>> {
    let res = residuals(rays, fit);
    let mut order: Vec<usize> = (0..res.len()).collect();
    order.sort_by(|&x, &y| res[x].0.total_cmp(&res[y].0).then(x.cmp(&y)));
    let total: f64 = res.iter().map(|r| r.2).sum();
    let mut rings = vec![Vec::new(); RINGS];
    let mut acc = 0.0;
    for k in order {
        let ring = ((acc / total * RINGS as f64) as usize).min(RINGS - 1);
        rings[ring].push(fit.kept[k]);
        acc += res[k].2;
    }
    for r in &mut rings {
        r.sort_unstable();
    }
    rings
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Rays of a lens with spherical aberration: from radius r on the plane z = 0 towards the
    /// axis point at f(r) = 1 − 0.5 r² (not of the form 1/(κ + γr)).
    fn aberrated(n: u32) -> Vec<CausticRay> {
        let mut out = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let x = (i as f32 + 0.5) / n as f32 * 2.0 - 1.0;
                let y = (j as f32 + 0.5) / n as f32 * 2.0 - 1.0;
                let r = (x * x + y * y).sqrt();
                if r > 1.0 {
                    continue;
                }
                let o = Vec3::new(0.5 * x, 0.5 * y, 0.0);
                let focus = Vec3::new(0.0, 0.0, 1.0 - 0.5 * (0.5 * r).powi(2) * 4.0);
                out.push(CausticRay {
                    origin: o,
                    dir: (focus - o).normalize(),
                    energy: Vec3::ONE,
                });
            }
        }
        out
    }

    #[test]
    fn an_aberrated_bundle_is_split_into_rings_that_fit_it_closer() {
        let rays = aberrated(160);
        let bundle = Bundle {
            origin: Vec3::ZERO,
            axis: Vec3::Z,
            members: (0..rays.len() as u32).collect(),
            iterations: 0,
        };
        let args = (0.5, 4.0, 3f64.to_radians(), 4096);
        let whole = fit::fit_bundle(&rays, &bundle, args.0, args.1, args.2, args.3, false);
        let one = worst_error(&rays, &whole);
        let pieces = split(
            &rays,
            whole.clone(),
            args,
            (MAX_PIECES, 0.0),
            f64::INFINITY,
            false,
        );
        assert!(pieces.len() > 1, "one law fits this bundle to {one}");
        assert!(pieces.len() <= MAX_PIECES);
        let w = |f: &Fit| f.kept.len() as f64;
        let after = (pieces
            .iter()
            .map(|p| worst_error(&rays, p).powi(2) * w(p))
            .sum::<f64>()
            / pieces.iter().map(w).sum::<f64>())
        .sqrt();
        eprintln!("{} pieces: RMS {one:.2e} -> {after:.2e}", pieces.len());
        assert!(after < 0.5 * one, "{one} -> {after}");
        // No ray is in two pieces; the pieces keep nearly every ray the whole fit kept.
        let mut all: Vec<u32> = pieces.iter().flat_map(|p| p.kept.clone()).collect();
        let n = all.len();
        all.sort_unstable();
        all.dedup();
        assert_eq!(all.len(), n);
        assert!(n as f64 >= 0.98 * whole.kept.len() as f64);
        // The same pieces again.
        let again = split(&rays, whole, args, (MAX_PIECES, 0.0), f64::INFINITY, true);
        assert_eq!(
            again.iter().map(|p| p.kept.clone()).collect::<Vec<_>>(),
            pieces.iter().map(|p| p.kept.clone()).collect::<Vec<_>>()
        );
    }
}
