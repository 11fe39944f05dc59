//! §4.2: the CSLs of an edge's two directions followed while the light moves along it
//! ([`Tracked`], on the rays traced at each step, [`StepRays`]) and matched by the distance of
//! their moved axes ([`match_edge`]); a CSL left unmatched gets a black partner.

use super::DynamicParams;
use crate::bake::csl::bundle::{self, Columns};
use crate::bake::csl::trace::{self, CausticRay, RayGrid};
use crate::bake::csl::{Csl, CslParams, CslSet};
use crate::trace::Accel;
use glam::{Quat, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// The point of the axis line (b, a) nearest to `c`.
fn axis_point(b: Vec3, a: Vec3, c: Vec3) -> Vec3 {
    b + a * (c - b).dot(a)
}

/// §4.2's axis distance, with B = R² so that both terms are squared lengths.
fn axis_distance(p: (Vec3, Vec3), q: (Vec3, Vec3), centre: Vec3, radius: f32) -> f32 {
    let (bp, bq) = (axis_point(p.0, p.1, centre), axis_point(q.0, q.1, centre));
    ((bp - bq).length_squared() + radius * radius * (p.1 - q.1).length_squared()).sqrt()
}

/// A black CSL standing for `src` at the tracked axis (b, a): the light plane as far along the
/// axis from the bounding centre as `src`'s, the image frame turned with the axis, no texels.
fn black_partner(src: &Csl, b: Vec3, a: Vec3, centre: Vec3) -> Csl {
    let depth = (src.origin - centre).dot(src.axis);
    let p = axis_point(b, a, centre);
    let rot = Quat::from_rotation_arc(src.axis, a);
    let x = rot * src.x_axis;
    Csl {
        origin: p + a * depth,
        axis: a,
        x_axis: (x - a * x.dot(a)).normalize(),
        scale: 0.0,
        flux: 0.0,
        grain: 0.0,
        texels: Vec::new(),
        ..src.clone()
    }
}

/// A CSL's axis followed while the light moves (§4.2 step 3): at each step the rays of the new
/// light that the CSL's model still describes (crossing its light plane inside the band of
/// radii its image covers, in a direction within the fit threshold of what its focus law
/// gives there) are taken as its bundle, and the axis is moved to their least-squares fit
/// (§3.1.1 steps 4–5), until it settles. Assigning by the thresholds of §3.1.1 step 3 alone
/// lets every CSL of a sphere slide onto the axis of its brightest one (measured: all fifteen
/// CSLs of one set ended within 0.01 R of one axis), so the fit threshold of §3.1.2 takes part.
struct Tracked {
    origin: Vec3,
    axis: Vec3,
    kappa: f32,
    gamma: f32,
    band: (f32, f32),
    /// The CSL's flux (m² per unit irradiance).
    flux: f32,
}

impl Tracked {
    /// `band`: the CSL's [`image_band`].
    fn new(c: &Csl, &(lo, hi, _): &(f32, f32, f32)) -> Tracked {
        let margin = 2.0 * c.patch();
        Tracked {
            origin: c.origin,
            axis: c.axis,
            kappa: c.kappa,
            gamma: c.gamma,
            band: ((lo - margin).max(0.0), hi + margin),
            flux: c.flux,
        }
    }

    /// The rays (indices, ascending) of a step the CSL's model still describes, found among
    /// the groups of directions within the angle threshold of its axis.
    fn members(&self, step: &StepRays, cos_angle: f32, fit_cos: f32) -> Vec<u32> {
        let (o, a, kappa, gamma) = (self.origin, self.axis, self.kappa, self.gamma);
        let band2 = (self.band.0 * self.band.0, self.band.1 * self.band.1);
        let fit_cos2 = fit_cos * fit_cos;
        let acute = fit_cos > 0.0;
        let near = step.near(a, cos_angle.clamp(-1.0, 1.0).acos());
        step.cols.filter_ranges(near, move |q, d| {
            // Every test made, and the outcomes combined without branches, so that columns of
            // rays are tested several at a time; the same operations as one at a time. The
            // radius and the angle to the direction the focus law wants (w) are compared
            // squared: d·ŵ ≥ cos is d·w ≥ 0, (d·w)² ≥ cos²·|w|² and w ≠ 0 for a positive cos,
            // d·w ≥ 0 or (d·w)² ≤ cos²·|w|² otherwise.
            let da = d.dot(a);
            let p = q + d * ((o - q).dot(a) / da) - o;
            let r2 = p.length_squared();
            let w = a - p * (kappa + gamma * r2.sqrt());
            let (dw, w2) = (d.dot(w), w.length_squared());
            let fits = if acute {
                (dw >= 0.0) & (dw * dw >= fit_cos2 * w2) & (w2 > 0.0)
            } else {
                (dw >= 0.0) | (dw * dw <= fit_cos2 * w2)
            };
            (da >= cos_angle) & (r2 >= band2.0) & (r2 <= band2.1) & fits
        })
    }

    /// `area`: cross-section of one traced ray (m²). A membership carrying more than twice or
    /// less than half the CSL's flux has taken in another bundle's rays or lost its own: the
    /// predicted axis is kept.
    fn step(&mut self, step: &StepRays, cos_angle: f32, fit_cos: f32, area: f32) {
        let rays = &step.rays;
        let mut members: Vec<u32> = Vec::new();
        for _ in 0..3 {
            let next = self.members(step, cos_angle, fit_cos);
            if next.is_empty() || next == members {
                return;
            }
            let flux = area * next.iter().map(|&i| rays[i as usize].weight()).sum::<f32>();
            if !(0.5 * self.flux..=2.0 * self.flux).contains(&flux) {
                return;
            }
            let (o, a) = bundle::optimise_axis(rays, &next, self.origin);
            // Keep the light plane where it was along the axis.
            let o = axis_point(o, a, self.origin);
            let settled = (o - self.origin).length() < 1e-4 * (1.0 + self.band.1)
                && a.dot(self.axis) > 1.0 - 5e-7;
            self.origin = o;
            self.axis = a;
            members = next;
            if settled {
                return;
            }
        }
    }
}

/// Radii of the light plane a CSL's image covers: (smallest, largest) of the texels above
/// 1/1000 of its peak, and the flux-weighted mean radius.
pub(super) fn image_band(c: &Csl) -> (f32, f32, f32) {
    let n = c.size as usize;
    if c.texels.is_empty() || n == 0 {
        return (0.0, 0.0, 0.0);
    }
    let pix = 2.0 * c.half_extent / n as f32;
    let peak = c
        .texels
        .iter()
        .map(|t| t[0].max(t[1]).max(t[2]))
        .max()
        .unwrap_or(0) as f32;
    let (mut lo, mut hi, mut sw, mut swr) = (f32::INFINITY, 0.0f32, 0.0f64, 0.0f64);
    for j in 0..n {
        let y = -c.half_extent + (j as f32 + 0.5) * pix;
        for i in 0..n {
            let t = c.texels[j * n + i];
            let v = (t[0] as f32 + t[1] as f32 + t[2] as f32) / 3.0;
            if v <= 1e-3 * peak {
                continue;
            }
            let x = -c.half_extent + (i as f32 + 0.5) * pix;
            let r = (x * x + y * y).sqrt();
            lo = lo.min(r);
            hi = hi.max(r);
            sw += v as f64;
            swr += (v * r) as f64;
        }
    }
    if sw <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    (lo, hi, (swr / sw) as f32)
}

/// A matched pair on an edge: the CSL at the edge's first end, the CSL at its second end (real
/// ones first, then blacks) and their axis distance (infinite for a black partner).
pub(super) type Match = (u16, u16, f32);

/// Result of tracking one edge.
pub(super) struct EdgeMatch {
    /// (index at the lower vertex, index at the higher vertex, distance); indices of blacks are
    /// provisional (`u16::MAX - k` for the k-th black of this edge at that end) until placed.
    pub(super) pairs: Vec<Match>,
    /// Blacks this edge adds at its lower and its higher vertex.
    pub(super) blacks: [Vec<Csl>; 2],
    pub(super) matched: u32,
    pub(super) rays: u64,
}

/// The rays of one tracking step: the caustic rays of a grid of `params.track_grid`² rays
/// along `light`, as columns grouped by direction ([`DIRECTION_BINS`]), and how many grid rays
/// hit the object.
pub(super) struct StepRays {
    rays: Vec<CausticRay>,
    cols: Columns,
    /// Per group of directions: the axis of a cone holding them, its half-angle (radians),
    /// that angle's cosine and sine, and the group's positions in `cols`.
    bins: Vec<(Vec3, f32, [f32; 2], std::ops::Range<usize>)>,
    hits: u64,
}

/// Cells per side of each cube face by which a step's rays are grouped by direction: 384
/// groups of about 11°, so that a CSL's membership test passes over the groups that lie
/// wholly outside its angle threshold (60°). Two thirds of a teapot's tracking rays are
/// outside a CSL's 65°.
const DIRECTION_BINS: usize = 8;

/// The group of direction `d` (a cube-map cell).
fn direction_bin(d: Vec3) -> usize {
    let a = d.abs();
    let (face, u, v, m) = if a.x >= a.y && a.x >= a.z {
        (usize::from(d.x < 0.0), d.y, d.z, a.x)
    } else if a.y >= a.z {
        (2 + usize::from(d.y < 0.0), d.x, d.z, a.y)
    } else {
        (4 + usize::from(d.z < 0.0), d.x, d.y, a.z)
    };
    let cell = |t: f32| {
        (((t / m.max(1e-30) + 1.0) * 0.5 * DIRECTION_BINS as f32) as usize).min(DIRECTION_BINS - 1)
    };
    (face * DIRECTION_BINS + cell(u)) * DIRECTION_BINS + cell(v)
}

impl StepRays {
    fn of(rays: Vec<CausticRay>, hits: u64) -> StepRays {
        let mut order: Vec<(u32, u32)> = rays
            .iter()
            .enumerate()
            .map(|(i, r)| (direction_bin(r.dir) as u32, i as u32))
            .collect();
        order.sort_unstable();
        let idx: Vec<u32> = order.iter().map(|&(_, i)| i).collect();
        let cols = Columns::of(&rays, &idx);
        let mut bins = Vec::new();
        let mut start = 0;
        while start < order.len() {
            let bin = order[start].0;
            let end = start + order[start..].partition_point(|&(b, _)| b == bin);
            let members = || idx[start..end].iter().map(|&i| rays[i as usize].dir);
            let axis = members()
                .sum::<Vec3>()
                .normalize_or(members().next().unwrap_or(Vec3::Z));
            let cos = members().map(|d| d.dot(axis)).fold(1.0f32, f32::min);
            let half = cos.clamp(-1.0, 1.0).acos();
            bins.push((axis, half, [half.cos(), half.sin()], start..end));
            start = end;
        }
        StepRays {
            rays,
            cols,
            bins,
            hits,
        }
    }

    /// The positions of the groups with directions within `angle` (radians) of `axis`: a
    /// group is left out where its cone lies wholly beyond (by a margin far above rounding).
    fn near(&self, axis: Vec3, angle: f32) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        // Apart by at most angle + 1e-3 + half: the cosine of the angle between the axes at
        // least that of the sum, from the sum's cosine formula (no arc cosine per group).
        let reach = angle + 1e-3;
        let (cos_r, sin_r) = (reach.cos(), reach.sin());
        self.bins
            .iter()
            .filter_map(move |(a, half, [cos_h, sin_h], range)| {
                let within = reach + half >= std::f32::consts::PI
                    || a.dot(axis) >= cos_r * cos_h - sin_r * sin_h;
                within.then(|| range.clone())
            })
    }

    /// The rays along `light`; None when canceled.
    pub(super) fn trace(
        accel: &Accel,
        light: Vec3,
        (centre, radius): (Vec3, f32),
        params: &DynamicParams,
        cancel: &AtomicBool,
    ) -> Option<StepRays> {
        let (u, v) = light.any_orthonormal_pair();
        let grid = RayGrid {
            light,
            u,
            v,
            centre,
            radius,
            n: params.track_grid,
        };
        let trace_params = CslParams {
            grid: params.track_grid,
            ..params.csl
        };
        let (rays, tot) = trace::trace_grid(accel, &grid, &trace_params, &|_| {
            !cancel.load(Ordering::Relaxed)
        })?;
        Some(StepRays::of(rays, tot.hits))
    }
}

/// One end of an edge: its set, the [`image_band`] of each of its CSLs, and the rays traced
/// along its direction for tracking (shared by the five or six edges that meet there).
pub(super) struct End<'a> {
    pub(super) set: &'a CslSet,
    pub(super) bands: &'a [(f32, f32, f32)],
    pub(super) rays: &'a StepRays,
}

/// Track the CSLs of both ends of edge (s0, s1) across it and match them.
pub(super) fn match_edge(
    accel: &Accel,
    ends: [End; 2],
    params: &DynamicParams,
    cancel: &AtomicBool,
) -> Option<EdgeMatch> {
    let sets = [ends[0].set, ends[1].set];
    let (s0, s1) = (sets[0].light_dir, sets[1].light_dir);
    let (centre, radius) = (sets[0].centre, sets[0].radius);
    let cos_angle = params.csl.angle_threshold_deg.to_radians().cos();
    let n = params.steps;
    let angle = s0.angle_between(s1);
    // The ends exactly (their rays are those traced along the sets' directions).
    let dir_at = |k: u32| -> Vec3 {
        let t = k as f32 / n as f32;
        if k == 0 || angle < 1e-6 {
            return s0;
        }
        if k == n {
            return s1;
        }
        ((s0 * ((1.0 - t) * angle).sin() + s1 * (t * angle).sin()) / angle.sin()).normalize()
    };
    // Rays of every step; those of step 0 (s0) and step n (s1) are traced once for all the
    // edges that meet there.
    let mut inner = Vec::with_capacity(n as usize);
    let mut traced = ends[0].rays.hits + ends[1].rays.hits;
    for k in 1..n {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        let r = StepRays::trace(accel, dir_at(k), (centre, radius), params, cancel)?;
        traced += r.hits;
        inner.push(r);
    }
    let step: Vec<&StepRays> = std::iter::once(ends[0].rays)
        .chain(&inner)
        .chain(std::iter::once(ends[1].rays))
        .collect();
    let fit_cos = params.csl.fit_threshold_deg.to_radians().cos();
    let area = (2.0 * radius / params.track_grid as f32).powi(2);
    // Each step first turns the axes with the light about the bounding centre (exact for a
    // sphere, a prediction otherwise; a CSL whose rays are lost keeps moving that way), then
    // corrects them on the step's rays. Each CSL is tracked on its own, so only those of
    // `end` for which `wanted` holds are.
    let track = |end: &End, steps: &[usize], wanted: &dyn Fn(usize) -> bool| {
        let csls = end.set.csls.iter().zip(end.bands).enumerate();
        let mut axes: Vec<(usize, Tracked)> = csls
            .filter(|(i, _)| wanted(*i))
            .map(|(i, (c, band))| (i, Tracked::new(c, band)))
            .collect();
        for w in steps.windows(2) {
            let q = Quat::from_rotation_arc(dir_at(w[0] as u32), dir_at(w[1] as u32));
            axes.par_iter_mut().for_each(|(_, t)| {
                t.origin = centre + q * (t.origin - centre);
                t.axis = (q * t.axis).normalize();
                t.step(step[w[1]], cos_angle, fit_cos, area)
            });
        }
        let mut out = vec![None; end.set.csls.len()];
        for (i, t) in axes {
            out[i] = Some((t.origin, t.axis));
        }
        out
    };
    let steps: Vec<usize> = (0..=n as usize).collect();
    let fwd: Vec<(Vec3, Vec3)> = track(&ends[0], &steps, &|_| true)
        .into_iter()
        .flatten()
        .collect();
    // Beyond the paper's axis distance: the CSLs' mean image radii and their fluxes (a
    // quarter radius per factor e), which tell apart the concentric CSLs of one axis.
    let (band0, band1) = (ends[0].bands, ends[1].bands);
    let log_flux = |c: &Csl| c.flux.max(1e-12).ln();

    // Pairs by increasing distance between s0's moved axes and s1's axes.
    let mut cand: Vec<(f32, u16, u16)> = Vec::new();
    for (i, a) in fwd.iter().enumerate() {
        for (j, c) in sets[1].csls.iter().enumerate() {
            let dr = band0[i].2 - band1[j].2;
            let df = 0.25 * radius * (log_flux(&sets[0].csls[i]) - log_flux(c));
            let d =
                (axis_distance(*a, (c.origin, c.axis), centre, radius).powi(2) + dr * dr + df * df)
                    .sqrt();
            if d <= params.match_threshold * radius {
                cand.push((d, i as u16, j as u16));
            }
        }
    }
    cand.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut used = [
        vec![false; sets[0].csls.len()],
        vec![false; sets[1].csls.len()],
    ];
    let mut pairs = Vec::new();
    for (d, i, j) in cand {
        if used[0][i as usize] || used[1][j as usize] {
            continue;
        }
        used[0][i as usize] = true;
        used[1][j as usize] = true;
        pairs.push((i, j, d));
    }
    let matched = pairs.len() as u32;
    let mut blacks: [Vec<Csl>; 2] = [Vec::new(), Vec::new()];
    // Unmatched CSLs of s0 get a black partner at s1 where they were tracked to, and those of
    // s1 one at s0 (the paper's rule, applied from both ends so that every CSL has a partner).
    for (i, c) in sets[0].csls.iter().enumerate() {
        if !used[0][i] {
            let (b, a) = fwd[i];
            blacks[1].push(black_partner(c, b, a, centre));
            pairs.push((
                i as u16,
                u16::MAX - (blacks[1].len() as u16 - 1),
                f32::INFINITY,
            ));
        }
    }
    // The CSLs of s1 are tracked back to s0 only to place the blacks of those left unmatched.
    let back: Vec<usize> = steps.iter().rev().copied().collect();
    let bwd = track(&ends[1], &back, &|j| !used[1][j]);
    for (j, c) in sets[1].csls.iter().enumerate() {
        if let Some((b, a)) = bwd[j] {
            blacks[0].push(black_partner(c, b, a, centre));
            pairs.push((
                u16::MAX - (blacks[0].len() as u16 - 1),
                j as u16,
                f32::INFINITY,
            ));
        }
    }
    Some(EdgeMatch {
        pairs,
        blacks,
        matched,
        rays: traced,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg;
    use std::collections::BTreeSet;

    #[test]
    fn tracking_membership_is_the_model_test() {
        // The squared comparisons of `Tracked::members` take the rays the direct test takes:
        // within the angle of the axis, crossing the light plane inside the band, within the
        // fit threshold of the direction the focus law wants there. Rays within rounding of a
        // threshold may go either way.
        let mut rng = Pcg::new(2, 0);
        let mut next = move || rng.f32() * 2.0 - 1.0;
        let a = Vec3::new(0.1, -1.0, 0.2).normalize();
        // Directions near the axis, many near the focus law's (focus 1 m ahead); a third in
        // every direction, as a teapot leaves them.
        let rays: Vec<CausticRay> = (0..300_000)
            .map(|k| {
                let origin = Vec3::new(next(), next(), next()) * 0.3 + a * 0.5;
                let dir = if k % 3 == 2 {
                    Vec3::new(next(), next(), next()).normalize_or(a)
                } else {
                    let aim = a * 1.5 - Vec3::new(next(), next(), next()) * 0.3;
                    (aim - origin * 0.7 + Vec3::new(next(), next(), next()) * 0.05).normalize()
                };
                CausticRay {
                    origin,
                    dir,
                    energy: Vec3::ONE,
                }
            })
            .collect();
        let step = StepRays::of(rays.clone(), 0);
        // Every ray in one group; the groups within 60° of the axis are a part of them.
        assert_eq!(step.bins.len(), 6 * DIRECTION_BINS * DIRECTION_BINS);
        let mut seen: Vec<u32> = step.cols.filter_ranges(step.near(a, 7.0), |_, _| true);
        assert_eq!(seen.len(), rays.len());
        seen.dedup();
        assert_eq!(seen.len(), rays.len());
        let near: usize = step.near(a, 60f32.to_radians()).map(|r| r.len()).sum();
        // The uniform third: a quarter of the sphere within 60°, less than half with the
        // groups' width.
        assert!(
            (200_000..250_000).contains(&near),
            "{near} rays in the groups near the axis"
        );
        for (fit_deg, kappa, gamma) in [(3.0f32, 1.0, 0.4), (20.0, 0.5, -0.3), (120.0, 1.0, 0.0)] {
            let t = Tracked {
                origin: a * 0.5,
                axis: a,
                kappa,
                gamma,
                band: (0.02, 0.2),
                flux: 1.0,
            };
            let (cos_angle, fit_cos) = (60f32.to_radians().cos(), fit_deg.to_radians().cos());
            let got = t.members(&step, cos_angle, fit_cos);
            assert!(got.windows(2).all(|w| w[0] < w[1]), "members ascending");
            let got: BTreeSet<u32> = got.into_iter().collect();
            let (mut taken, mut unsure) = (0, 0);
            for (i, r) in rays.iter().enumerate() {
                let (q, d) = (r.origin, r.dir);
                let da = d.dot(a);
                let p = q + d * ((t.origin - q).dot(a) / da) - t.origin;
                let rho = p.length();
                let want = (a - p * (kappa + gamma * rho)).normalize_or_zero();
                let c = d.dot(want);
                let margin = (da - cos_angle)
                    .abs()
                    .min((rho - t.band.0).abs())
                    .min((rho - t.band.1).abs())
                    .min((c - fit_cos).abs());
                if margin < 1e-5 {
                    unsure += 1;
                    continue;
                }
                let want_in = da >= cos_angle && rho >= t.band.0 && rho <= t.band.1 && c >= fit_cos;
                assert_eq!(
                    got.contains(&(i as u32)),
                    want_in,
                    "ray {i}, fit {fit_deg}°"
                );
                taken += want_in as u32;
            }
            eprintln!("fit {fit_deg}°: {taken} members, {unsure} within rounding");
            assert!(
                taken > 1000 && unsure < 1000,
                "{taken} members, {unsure} unsure"
            );
        }
    }
}
