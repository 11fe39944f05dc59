//! Stage 3 of the CSL bake, parameterisation (§3.1.2): the CSL's light plane sits on the bundle
//! axis at c = b + ℓ·â and its rays meet the axis at f(r) = α / (1 + βr). We fit (α, β, ℓ) by
//! minimising Eq. 5, Σ (t₁² + t₂²)·‖d̂ − ê‖², with Powell's method and Brent line searches;
//! rays whose direction the fitted CSL misses by more than a threshold leave the bundle and the
//! fit is repeated on the rest.
//!
//! Internally the focus function is written 1/f(r) = κ + γ·r with κ = 1/α and γ = β/α. This is
//! the same family (α = 1/κ, β = γ/κ), but it stays finite for collimated bundles (κ = γ = 0,
//! α → ∞) and also represents diverging bundles (κ < 0: a virtual focus behind the light plane,
//! e.g. light reflected by a convex mirror), which the paper's α > 0 excludes.

use super::bundle::{Bundle, det_fold, det_sum};
use super::optimize::powell;
use super::trace::CausticRay;
use crate::trace::simd;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// A fitted CSL before its intensity image: light plane origin and axis, focus function, and
/// the rays it represents.
#[derive(Clone, Debug)]
pub struct Fit {
    pub origin: Vec3,
    pub axis: Vec3,
    pub kappa: f64,
    pub gamma: f64,
    pub kept: Vec<u32>,
    /// Rays dismissed from the bundle (they return to the pool).
    pub dismissed: usize,
    /// Objective evaluations over all rounds.
    pub evaluations: u32,
}

/// The CSL ray direction through light-plane offset `u` (⊥ axis) for focus 1/f = κ + γ|u|.
#[inline]
pub fn csl_dir(axis: DVec3, u: DVec3, kappa: f64, gamma: f64) -> DVec3 {
    let g = kappa + gamma * u.length();
    (axis - u * g).normalize()
}

/// Per-ray terms of Eq. 5 for plane parameter `ell`: (t₁, ‖d̂ − ê‖²).
#[inline]
fn ray_terms(r: &CausticRay, b: DVec3, a: DVec3, ell: f64, kappa: f64, gamma: f64) -> (f64, f64) {
    let q = r.origin.as_dvec3();
    let d = r.dir.as_dvec3();
    let s = ((b - q).dot(a) + ell) / d.dot(a);
    let p = q + d * s;
    let c = b + a * ell;
    let e = csl_dir(a, p - c, kappa, gamma);
    (s.abs(), (d - e).length_squared())
}

/// The rays of a fit's objective with everything that does not depend on (κ, γ, ℓ) computed
/// once, in the frame (x̂, ŷ, â) of the bundle axis: for plane offset ℓ a ray meets the plane at
/// s = s₀ + ℓ/(d·â) along itself, at radial offset u = (qₓ + dₓs, q_y + d_ys) from the axis
/// (q the ray origin relative to the bundle origin), where the CSL ray is
/// ê = (−g·u, 1)/√(1 + g²|u|²) with g = κ + γ|u|. The same terms as [`ray_terms`], a few times
/// cheaper per evaluation (Powell needs hundreds).
///
/// The terms are stored in blocks of [`LANES`] rays, each block one array per term, and summed
/// in [`LANES`] interleaved partial sums, so that the compiler evaluates a block's rays at once
/// in vector registers; the order of every addition is fixed by the ray's index, so the sum is
/// the same on every machine and thread count.
struct Terms {
    /// Per block of [`LANES`] rays, per term, the rays' values: qₓ, q_y, dₓ, d_y, d·â, ‖d‖², s₀,
    /// 1/(d·â), weight.
    blocks: Vec<[[f64; LANES]; 9]>,
    /// The rays after the last whole block, one row each.
    tail: Vec<[f64; 9]>,
}

/// Partial sums of the objective (rays i ≡ k mod LANES go to lane k).
const LANES: usize = 8;

impl Terms {
    /// At most `most` of `members` (evenly strided), for the axis (b, a).
    fn new(rays: &[CausticRay], members: &[u32], most: usize, b: DVec3, a: DVec3) -> Terms {
        let x = a.any_orthonormal_vector();
        let y = a.cross(x);
        let take: Vec<u32> = if members.len() > most {
            (0..most)
                .map(|k| members[k * members.len() / most])
                .collect()
        } else {
            members.to_vec()
        };
        let row = |i: u32| {
            let r = &rays[i as usize];
            let q = r.origin.as_dvec3() - b;
            let d = r.dir.as_dvec3();
            let da = d.dot(a);
            [
                q.dot(x),
                q.dot(y),
                d.dot(x),
                d.dot(y),
                da,
                d.length_squared(),
                -q.dot(a) / da,
                1.0 / da,
                r.weight() as f64,
            ]
        };
        let whole = take.chunks_exact(LANES);
        let tail = whole.remainder().iter().map(|&i| row(i)).collect();
        let blocks = whole
            .map(|chunk| {
                let mut block = [[0.0; LANES]; 9];
                for (k, &i) in chunk.iter().enumerate() {
                    for (c, v) in block.iter_mut().zip(row(i)) {
                        c[k] = v;
                    }
                }
                block
            })
            .collect();
        Terms { blocks, tail }
    }

    /// Eq. 5 with each ray's squared direction error capped at `cap`, on one thread (an
    /// evaluation takes microseconds, less than handing work to another thread and waking it),
    /// with the widest vector instructions the processor has: the same operations either way
    /// (no fused multiply-adds), so the same result on every machine. Square roots and
    /// divisions bound it; with AVX-512 each of them covers a block's eight rays in one
    /// instruction, and a static teapot bake's fit took 497 instead of 812 ms (2 cores, the
    /// same bytes).
    fn objective(&self, ell: f64, kappa: f64, gamma: f64, w: f64, cap: f64) -> f64 {
        let p = [ell, kappa, gamma, w, cap];
        simd::dispatch!(
            ["avx512f", "avx2"],
            fn(terms: &Terms = self, p: [f64; 5]) -> f64 { terms.sum(p) }
        )
    }

    #[inline(always)]
    fn sum(&self, p: [f64; 5]) -> f64 {
        let mut acc = [0.0f64; LANES];
        for b in &self.blocks {
            for (k, a) in acc.iter_mut().enumerate() {
                let row = [
                    b[0][k], b[1][k], b[2][k], b[3][k], b[4][k], b[5][k], b[6][k], b[7][k], b[8][k],
                ];
                *a += term(row, p);
            }
        }
        for (a, &row) in acc.iter_mut().zip(&self.tail) {
            *a += term(row, p);
        }
        acc.iter().sum::<f64>()
    }
}

/// One ray's term of [`Terms::objective`]: row (qₓ, q_y, dₓ, d_y, d·â, ‖d‖², s₀, 1/(d·â), weight),
/// parameters (ℓ, κ, γ, w, cap).
#[inline(always)]
fn term(
    [qx, qy, dx, dy, da, dd, s0, inv, wt]: [f64; 9],
    [ell, kappa, gamma, w, cap]: [f64; 5],
) -> f64 {
    let s = s0 + ell * inv;
    let (ux, uy) = (qx + dx * s, qy + dy * s);
    let r2 = ux * ux + uy * uy;
    let g = kappa + gamma * r2.sqrt();
    let de = (da - g * (dx * ux + dy * uy)) / (1.0 + g * g * r2).sqrt();
    let e2 = dd + 1.0 - 2.0 * de;
    let t1 = s.abs();
    let t2 = t1 + w;
    let e2 = if e2 < cap { e2 } else { cap };
    wt * (t1 * t1 + t2 * t2) * e2
}

/// Fit a CSL to `bundle`. `length` is the object's bounding radius (variable scaling), `w` the
/// paper's far distance (four times the object's bounding box size), `max_angle` the largest
/// direction error (radians) a kept ray may have, `samples` the most rays used in the objective.
///
/// Where the light plane goes: a CSL ray starts on the plane, so a plane beyond a ray's exit
/// from the object cuts off the start of that ray; where a bundle leaves at a grazing angle (a
/// mirror ring's side lit from low) such a plane reaches below the floor the light falls on and
/// the CSL lights nothing there. So the plane is first fitted within the axial range of the
/// bundle's exits (or through its axis origin); when that puts it beyond the first exit, it is
/// fitted again before every exit (by at most one bounding radius; the model's rays then only
/// gain a stretch inside or behind the object, which no receiver sees), and that fit is kept
/// unless it represents under half the first one's energy (a convex mirror's bundles, whose
/// lines cross behind the surface, fit only with the plane among the exits).
///
/// `beside`: make the second fit at the same time as the first, on another core, and throw it
/// away when it is not needed (Powell's method is sequential, so with a core to spare this is
/// faster); without, only when needed (less work in all, for callers that keep every core busy).
/// The result is the same either way.
pub fn fit_bundle(
    rays: &[CausticRay],
    bundle: &Bundle,
    length: f64,
    w: f64,
    max_angle: f64,
    samples: usize,
    beside: bool,
) -> Fit {
    // The bundle's rays side by side, in member order: the fit passes over them a dozen times
    // (the initial guess, each round's samples and dismissal), which then read memory front to
    // back instead of single rays scattered over the pool. The fit sees the members as
    // positions in `local`, ascending as the members are, so it makes the same choices; the
    // rays it keeps are turned back into ray indices.
    let local: Vec<CausticRay> = bundle
        .members
        .par_iter()
        .map(|&i| rays[i as usize])
        .collect();
    let positions = Bundle {
        members: (0..local.len() as u32).collect(),
        ..*bundle
    };
    let args = (length, w, max_angle, samples);
    let mut fit = fit_local(&local, &positions, args, beside);
    for k in &mut fit.kept {
        *k = bundle.members[*k as usize];
    }
    fit
}

/// [`fit_bundle`] on rays whose members are positions in `rays`; `args` are its
/// (length, w, max_angle, samples), as [`fit_in_range`] takes them.
fn fit_local(
    rays: &[CausticRay],
    bundle: &Bundle,
    args: (f64, f64, f64, usize),
    beside: bool,
) -> Fit {
    let length = args.0;
    let b = bundle.origin.as_dvec3();
    let a = bundle.axis.as_dvec3();
    let (lmin, lmax) = rays
        .par_iter()
        .map(|r| {
            let t = (r.origin.as_dvec3() - b).dot(a);
            (t, t)
        })
        .reduce(
            || (f64::INFINITY, f64::NEG_INFINITY),
            |x, y| (x.0.min(y.0), x.1.max(y.1)),
        );
    let free_range = (lmin.min(0.0), lmax.max(0.0));
    let before_range = (lmin - length, lmin);
    // The free plane beyond the first exit (or not a number).
    let needed = |free: &Fit| {
        let ell = (free.origin.as_dvec3() - b).dot(a);
        !matches!(
            ell.partial_cmp(&(lmin + 1e-6 * length)),
            Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
        )
    };
    let (free, before) = if beside {
        let (free, before) = rayon::join(
            || fit_in_range(rays, bundle, args, free_range),
            || fit_in_range(rays, bundle, args, before_range),
        );
        if !needed(&free) {
            return free;
        }
        (free, before)
    } else {
        let free = fit_in_range(rays, bundle, args, free_range);
        if !needed(&free) {
            return free;
        }
        let before = fit_in_range(rays, bundle, args, before_range);
        (free, before)
    };
    let energy = |f: &Fit| det_sum(&f.kept, 0.0, |&i| rays[i as usize].weight() as f64);
    if energy(&before) >= 0.5 * energy(&free) {
        Fit {
            evaluations: before.evaluations + free.evaluations,
            ..before
        }
    } else {
        Fit {
            evaluations: before.evaluations + free.evaluations,
            ..free
        }
    }
}

/// [`fit_bundle`] with the light plane's offset ℓ along the axis from the bundle origin kept in
/// `range`.
fn fit_in_range(
    rays: &[CausticRay],
    bundle: &Bundle,
    (length, w, max_angle, samples): (f64, f64, f64, usize),
    range: (f64, f64),
) -> Fit {
    let b = bundle.origin.as_dvec3();
    let a = bundle.axis.as_dvec3();
    let mut members = bundle.members.clone();
    let clamp_ell = |ell: f64| ell.clamp(range.0, range.1);
    let mut evaluations = 0u32;
    let ell0 = clamp_ell(0.0);
    let mut x = initial_guess(rays, &members, b + a * ell0, a, length);
    x[2] = ell0 / length;
    let mut dismissed = 0;
    // Graduated dismissal: each round minimises Eq. 5 with the error of a ray capped at the
    // round's threshold (so that rays the CSL cannot represent, e.g. internal reflections, do
    // not drag the fit), then dismisses the rays beyond it. The threshold tightens from 20° to
    // the final one.
    let finals = [
        max_angle.max(20f64.to_radians()),
        (3.0 * max_angle).min(max_angle.max(20f64.to_radians())),
        max_angle,
        max_angle,
    ];
    for (round, &limit) in finals.iter().enumerate() {
        let cap = (2.0 * (0.5 * limit).sin()).powi(2);
        // The dismissal rounds only have to find the rays to dismiss: a quarter of the samples
        // do; the last round fits the CSL on all of them.
        let most = if round + 1 < finals.len() {
            (samples / 4).max(16)
        } else {
            samples
        };
        let sample = Terms::new(rays, &members, most, b, a);
        let objective = |v: &[f64]| {
            let (kappa, gamma, ell) = unscale(v, length);
            let ell = clamp_ell(ell);
            sample.objective(ell, kappa, gamma, w, cap)
        };
        let mut count = 0u32;
        let (xv, _, _) = powell(
            |v| {
                count += 1;
                objective(v)
            },
            &x,
            1e-9,
            60,
        );
        evaluations += count;
        x = xv;
        x[2] = clamp_ell(x[2] * length) / length;
        let (kappa, gamma, ell) = unscale(&x, length);
        let before = members.len();
        members = within_cap(rays, &members, b, a, (ell, kappa, gamma), cap);
        dismissed += before - members.len();
        if members.is_empty() {
            break;
        }
    }
    let (kappa, gamma, ell) = unscale(&x, length);
    Fit {
        origin: (b + a * ell).as_vec3(),
        axis: bundle.axis,
        kappa,
        gamma,
        kept: members,
        dismissed,
        evaluations,
    }
}

/// The members whose squared direction error under the CSL (ℓ, κ, γ) is at most `cap`
/// ([`ray_terms`]), in order; in parallel, several rays at a time where the processor has AVX2
/// (the same operations either way, so the same rays).
fn within_cap(
    rays: &[CausticRay],
    members: &[u32],
    b: DVec3,
    a: DVec3,
    csl: (f64, f64, f64),
    cap: f64,
) -> Vec<u32> {
    let parts: Vec<Vec<u32>> = members
        .par_chunks(8192)
        .map(|part| {
            simd::dispatch!(
                ["avx2"],
                fn(
                    rays: &[CausticRay],
                    part: &[u32],
                    line: (DVec3, DVec3) = (b, a),
                    csl: (f64, f64, f64),
                    cap: f64,
                ) -> Vec<u32> {
                    within_cap_part(rays, part, line.0, line.1, csl, cap)
                }
            )
        })
        .collect();
    parts.concat()
}

#[inline(always)]
fn within_cap_part(
    rays: &[CausticRay],
    part: &[u32],
    b: DVec3,
    a: DVec3,
    (ell, kappa, gamma): (f64, f64, f64),
    cap: f64,
) -> Vec<u32> {
    const BLOCK: usize = 64;
    let mut out = Vec::with_capacity(part.len());
    for block in part.chunks(BLOCK) {
        // The block's rays gathered first, so that the arithmetic runs over arrays, several
        // rays at a time.
        let mut gathered = [CausticRay {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
            energy: Vec3::ZERO,
        }; BLOCK];
        for (g, &i) in gathered.iter_mut().zip(block) {
            *g = rays[i as usize];
        }
        let mut pass = [false; BLOCK];
        for (p, r) in pass.iter_mut().zip(&gathered[..block.len()]) {
            *p = ray_terms(r, b, a, ell, kappa, gamma).1 <= cap;
        }
        let mut found = [0u32; BLOCK];
        let mut count = 0;
        for (&p, &i) in pass.iter().zip(block) {
            found[count] = i;
            count += p as usize;
        }
        out.extend_from_slice(&found[..count]);
    }
    out
}

/// Powell's variables are (κL, γL², ℓ/L) so that a unit step is sensible for each.
fn unscale(v: &[f64], l: f64) -> (f64, f64, f64) {
    (v[0] / l, v[1] / (l * l), v[2] * l)
}

/// Start with the light plane through `b` and κ, γ from a weighted linear fit of
/// each ray's own ideal 1/f at its radius.
fn initial_guess(rays: &[CausticRay], members: &[u32], b: DVec3, a: DVec3, l: f64) -> Vec<f64> {
    // Weighted sums (w, wr, wr², wg, wrg) over the rays off the axis.
    let add = |x: [f64; 5], y: [f64; 5]| std::array::from_fn(|k| x[k] + y[k]);
    let sums = det_fold(
        members,
        [0.0f64; 5],
        |&i| {
            let r = &rays[i as usize];
            let q = r.origin.as_dvec3();
            let d = r.dir.as_dvec3();
            let s = (b - q).dot(a) / d.dot(a);
            let u = q + d * s - b;
            let rad = u.length();
            if rad < 1e-3 * l {
                return [0.0; 5];
            }
            // a − g·u ∥ d  ⇒  g = −(d·u) / ((d·a) r²)
            let g = -d.dot(u) / (d.dot(a) * rad * rad);
            let wt = r.weight() as f64;
            [wt, wt * rad, wt * rad * rad, wt * g, wt * rad * g]
        },
        add,
    );
    let [sw, sr, srr, sg, srg] = sums;
    let det = sw * srr - sr * sr;
    let (kappa, gamma) = if sw > 0.0 && det.abs() > 1e-12 * sw * srr.max(1e-30) {
        ((sg * srr - sr * srg) / det, (sw * srg - sr * sg) / det)
    } else if sw > 0.0 {
        (sg / sw, 0.0)
    } else {
        (0.0, 0.0)
    };
    vec![kappa * l, gamma * l * l, 0.0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg;

    #[test]
    fn dismissal_keeps_the_rays_within_the_cap() {
        let mut rng = Pcg::new(8, 2);
        let b = DVec3::new(0.1, 0.0, -0.2);
        let a = DVec3::new(0.2, 1.0, -0.3).normalize();
        let rays: Vec<CausticRay> = (0..20_000)
            .map(|_| {
                let o = Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5;
                let d = a.as_vec3() + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * 0.6;
                CausticRay {
                    origin: o,
                    dir: d.normalize(),
                    energy: Vec3::ONE,
                }
            })
            .collect();
        let members: Vec<u32> = (0..rays.len() as u32).filter(|i| i % 7 != 3).collect();
        let (ell, kappa, gamma, cap) = (0.1, 0.8, -0.2, 0.02);
        let want: Vec<u32> = members
            .iter()
            .copied()
            .filter(|&i| ray_terms(&rays[i as usize], b, a, ell, kappa, gamma).1 <= cap)
            .collect();
        assert!(want.len() > 1000 && want.len() < members.len() - 1000);
        assert_eq!(
            within_cap(&rays, &members, b, a, (ell, kappa, gamma), cap),
            want
        );
    }

    #[test]
    fn precomputed_terms_give_the_objective_of_eq_5() {
        // Rays of a rough converging bundle around an oblique axis: the objective from the
        // precomputed terms equals Eq. 5 summed from the plain per-ray terms.
        let mut rng = Pcg::new(3, 9);
        let b = DVec3::new(0.2, -0.1, 0.4);
        let a = DVec3::new(0.3, -1.0, 0.2).normalize();
        let rays: Vec<CausticRay> = (0..500)
            .map(|_| {
                let o = b.as_vec3() + Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5;
                let target = (b + a * 2.0).as_vec3()
                    + (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * 0.2;
                CausticRay {
                    origin: o,
                    dir: (target - o).normalize(),
                    energy: Vec3::new(rng.f32(), rng.f32(), rng.f32()),
                }
            })
            .collect();
        let members: Vec<u32> = (0..rays.len() as u32).collect();
        let terms = Terms::new(&rays, &members, members.len(), b, a);
        for (ell, kappa, gamma, cap) in [
            (0.0, 0.5, 0.1, 4.0),
            (-0.3, 0.4, -0.2, 0.01),
            (0.2, 0.0, 0.0, 4.0),
        ] {
            let w = 7.0;
            let want: f64 = rays
                .iter()
                .map(|r| {
                    let (t1, e2) = ray_terms(r, b, a, ell, kappa, gamma);
                    let t2 = t1 + w;
                    r.weight() as f64 * (t1 * t1 + t2 * t2) * e2.min(cap)
                })
                .sum();
            let got = terms.objective(ell, kappa, gamma, w, cap);
            // The vector path gives the very same number as the plain one.
            assert_eq!(
                got.to_bits(),
                terms.sum([ell, kappa, gamma, w, cap]).to_bits()
            );
            assert!(
                (got - want).abs() <= 1e-9 * want.abs().max(1e-12),
                "{got} vs {want}"
            );
        }
    }
}
