//! Caustic spot lights under dynamic lighting (Liu et al. 2008 §4): static CSL sets baked for the light
//! directions at the vertices of a subdivided icosahedron, CSLs of neighbouring directions
//! matched by tracking their axes while the light moves along each icosahedron edge (§4.2),
//! matches turned into CSL triples on every face (§4.3, [`Triple`]), and per frame a set for any
//! light direction interpolated from the triples of the face it passes through (§4.1,
//! [`DynamicSet::interpolate`]).
//!
//! All directions are light *travel* directions in the object's rigid frame, as for a static
//! set. A CSL of one direction that finds no partner at a neighbouring direction is matched to a
//! *black* CSL there: the axis it was tracked to, its own focus law, no image. Blacks live in
//! [`DynamicSet::blacks`] and are addressed after the real CSLs of their direction.
//!
//! Where this departs from the paper, and why (each measured on the glass sphere):
//! - Tracking assigns a CSL the rays its own model describes (its image's band of radii and
//!   its focus law within the fit threshold), predicts each step by turning the axis with the
//!   light, and keeps the prediction when the assigned rays carry far more or less than the
//!   CSL's flux: with §3.1.1's thresholds alone every CSL of the sphere slid onto its brightest
//!   one's axis.
//! - The match distance adds the difference of the CSLs' mean image radii and of their log
//!   fluxes (a quarter of R per factor e) to the paper's axis distance (B taken as R², so that
//!   all terms are squared lengths): a sphere's CSLs are concentric rings on one axis, which
//!   the axis distance cannot tell apart (at 1280² rays the sphere's main CSL, 60 % of the
//!   light, was matched to a 0.4 % ring of the same axis and mean radius).
//! - Matches that close no cycle on a face become pair triples ([`Triple`]) instead of the
//!   paper's arbitrary picks, so that the interpolation is continuous across every edge.
//! - Axes blend as the normalised weighted sum (consistent with the gnomonic barycentric
//!   coordinates of [`Icosphere::locate`]), light-plane origins turn with their axes before the
//!   linear blend, and the focus law blends as κ = 1/α, γ = β/α (linear in α passes through
//!   infinity where a bundle turns from converging to diverging).

mod codec;
mod icosphere;
mod interpolate;

pub use codec::{CODE_NOISE, MAGIC, VERSION, code_levels};
pub use icosphere::Icosphere;

use super::bundle::{self, Columns};
use super::trace::{self, CausticRay, RayGrid};
use super::{
    BakeError, Csl, CslParams, CslSet, bake_accel, bake_csl_with, object_hash, rigid_frame_world,
};
use crate::bake::Fnv64;
use crate::scene::World;
use crate::trace::Accel;
use glam::{Quat, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// Parameters of a dynamic bake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicParams {
    /// Subdivisions of the icosahedron of light directions. 0..=3; the paper's 2 (162).
    pub subdivisions: u32,
    /// Steps of the light along an edge while the axes are tracked. 1..=200; the paper's 20.
    pub steps: u32,
    /// Rays per side of the grid traced at each tracking step. 16..=2048.
    pub track_grid: u32,
    /// Largest axis distance (§4.2) of a match, in units of the bounding-sphere radius R. > 0.
    pub match_threshold: f32,
    /// The static bake of each direction.
    pub csl: CslParams,
}

impl DynamicParams {
    /// The paper's settings: 162 directions, 20 tracking steps, 1280² rays per direction;
    /// tracking steps trace 128² rays (the paper does not give its count; on the sphere 48² to
    /// 128² gave the same matches' quality).
    pub const fn paper() -> Self {
        DynamicParams {
            subdivisions: 2,
            steps: 20,
            track_grid: 128,
            match_threshold: 0.5,
            csl: CslParams::paper(),
        }
    }

    pub fn validate(&self) -> Result<(), BakeError> {
        let bad = |what: &str| Err(BakeError::InvalidParams(what.to_string()));
        if self.subdivisions > 3 {
            return bad("subdivisions must be in 0..=3");
        }
        if !(1..=200).contains(&self.steps) {
            return bad("steps must be in 1..=200");
        }
        if !(16..=2048).contains(&self.track_grid) {
            return bad("track_grid must be in 16..=2048");
        }
        if !(self.match_threshold > 0.0 && self.match_threshold.is_finite()) {
            return bad("match_threshold must be > 0");
        }
        self.csl.validate()
    }

    pub fn hash(&self) -> u64 {
        let mut h = Fnv64::new();
        h.write_u32(self.subdivisions);
        h.write_u32(self.steps);
        h.write_u32(self.track_grid);
        h.write_f32(self.match_threshold);
        h.write(&self.csl.hash().to_le_bytes());
        h.finish()
    }
}

impl Default for DynamicParams {
    fn default() -> Self {
        Self::paper()
    }
}

/// How much of a triple member's intensity image the interpolation adds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Share {
    /// None: the member lends its axis, origin and focus law only.
    None,
    /// Half: the member is in two pair triples of the face, one per edge of its corner.
    Half,
    /// All of it: the member is in one matched triple of the face.
    Full,
}

impl Share {
    pub fn fraction(self) -> f32 {
        match self {
            Share::None => 0.0,
            Share::Half => 0.5,
            Share::Full => 1.0,
        }
    }
}

/// One member of a triple: a CSL of the face's corner (index into the corner's real CSLs, then
/// its blacks) and the share of its image the interpolation adds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Member {
    pub csl: u16,
    pub image: Share,
}

/// CSLs of a face's three corners interpolated together (§4.3), in the face's corner order.
///
/// A *matched* triple (three CSLs matched with each other on the face's three edges, rule 1)
/// adds all of each member's image, with the geometry blended by the barycentric weights. Where
/// a face's matches do not close into such cycles, every match (x at corner i, y at corner j)
/// of the face becomes a *pair* triple adding half of x's and half of y's image; its member at
/// the third corner k is x's partner there, and `split` y's partner there, which share k's
/// weight in proportion wᵢ : wⱼ. Both are matches of the edges (i, k) and (j, k) themselves, so
/// on every edge the interpolated set depends on that edge's matches alone and the faces on
/// either side give the same CSLs (rule 2), and a corner's CSLs add exactly their images there
/// (rule 3). On a matched cycle the three pair triples it would give coincide with its matched
/// triple, which is why the matched triple is stored instead.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Triple {
    pub members: [Member; 3],
    /// For a pair triple, the second CSL at its third corner (the corner whose member adds no
    /// image).
    pub split: Option<u16>,
}

/// Figures of a dynamic bake. Times are zero after loading.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DynamicStats {
    pub directions: u32,
    /// Real CSLs over all directions.
    pub csls: u32,
    /// Black partners made for unmatched CSLs.
    pub blacks: u32,
    /// Pairs matched by axis distance (not counting black partners).
    pub matched: u32,
    pub edges: u32,
    pub triples: u32,
    /// Triples whose three members are matched with each other on all three edges (rule 1).
    pub consistent_triples: u32,
    /// Grid rays that hit the object, over all tracking steps of all edges.
    pub tracking_rays: u64,
    pub time_bakes: Duration,
    pub time_tracking: Duration,
    pub time_triples: Duration,
    pub time_total: Duration,
}

/// A dynamic CSL bake of one object.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicSet {
    /// Hash of the object (meshes, materials, scale) and the parameters: the cache key.
    pub source_hash: u64,
    pub object_hash: u64,
    pub params_hash: u64,
    pub subdivisions: u32,
    /// The static set of every icosahedron vertex, in vertex order.
    pub sets: Vec<CslSet>,
    /// Black partners per vertex (texels empty).
    pub blacks: Vec<Vec<Csl>>,
    /// Triples per icosahedron face, members in the face's corner order.
    pub triples: Vec<Vec<Triple>>,
    pub stats: DynamicStats,
}

/// Progress of a dynamic bake.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicProgress {
    /// "directions" (static sets baked), "tracking" (edges tracked and matched), "triples",
    /// "done".
    pub stage: &'static str,
    /// Items of the stage done, of `total`.
    pub done: u32,
    pub total: u32,
    /// Overall completion in [0, 1] (directions count for 0.6 of it, edges for 0.4).
    pub fraction: f32,
}

fn report(
    progress: &(dyn Fn(DynamicProgress) -> bool + Sync),
    stage: &'static str,
    done: u32,
    total: u32,
) -> bool {
    let f = done as f32 / total.max(1) as f32;
    let fraction = match stage {
        "directions" => 0.6 * f,
        "tracking" => 0.6 + 0.4 * f,
        _ => 1.0,
    };
    progress(DynamicProgress {
        stage,
        done,
        total,
        fraction: fraction.min(1.0),
    })
}

/// Hash of a dynamic bake's inputs.
pub fn dynamic_source_hash(
    world: &World,
    object_name: &str,
    params: &DynamicParams,
) -> Option<u64> {
    let object = world.object(object_name)?;
    let mut h = Fnv64::new();
    h.write(b"csl-dynamic");
    h.write_u32(super::ALGORITHM);
    h.write_u32(ALGORITHM);
    h.write(&object_hash(world, object).to_le_bytes());
    h.write(&params.hash().to_le_bytes());
    Some(h.finish())
}

/// Revision of the matching and triple algorithm (part of the source hash). 3: the first and
/// last tracking steps are exactly the bake directions (a few black partners moved).
pub const ALGORITHM: u32 = 3;

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
fn image_band(c: &Csl) -> (f32, f32, f32) {
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
type Match = (u16, u16, f32);

/// Result of tracking one edge.
struct EdgeMatch {
    /// (index at the lower vertex, index at the higher vertex, distance); indices of blacks are
    /// provisional (`u16::MAX - k` for the k-th black of this edge at that end) until placed.
    pairs: Vec<Match>,
    /// Blacks this edge adds at its lower and its higher vertex.
    blacks: [Vec<Csl>; 2],
    matched: u32,
    rays: u64,
}

/// The rays of one tracking step: the caustic rays of a grid of `params.track_grid`² rays
/// along `light`, as columns grouped by direction ([`DIRECTION_BINS`]), and how many grid rays
/// hit the object.
struct StepRays {
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
    fn trace(
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
struct End<'a> {
    set: &'a CslSet,
    bands: &'a [(f32, f32, f32)],
    rays: &'a StepRays,
}

/// Track the CSLs of both ends of edge (s0, s1) across it and match them.
fn match_edge(
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

/// Members by corner: `m[0]` at corner `i`, `m[1]` at the next corner, `m[2]` at the one after.
fn placed(i: usize, m: [(u16, Share); 3]) -> [Member; 3] {
    let mut out = [Member {
        csl: 0,
        image: Share::None,
    }; 3];
    for (n, (csl, image)) in m.into_iter().enumerate() {
        out[(i + n) % 3] = Member { csl, image };
    }
    out
}

/// §4.3: the triples of one face from the matches of its three edges (see [`Triple`]).
/// `matches[e]` are the pairs of the face's edge e = (corner e, corner e+1 mod 3), oriented
/// that way; `len[k]` is the number of CSLs (real and black) at corner k; `lit(k, i)` whether
/// CSL i of corner k has an image. Every CSL of every corner has one match on each of its two
/// edges of the face (a black partner where no CSL matched). Returns the triples and how many
/// are matched triples.
fn face_triples(
    matches: [&[Match]; 3],
    len: [usize; 3],
    lit: &dyn Fn(usize, u16) -> bool,
) -> (Vec<Triple>, u32) {
    // partner[k][i][0]: the partner of CSL i of corner k at the next corner (k+1), [1] at the
    // previous one (k+2).
    let mut partner: [Vec<[Option<u16>; 2]>; 3] = [
        vec![[None; 2]; len[0]],
        vec![[None; 2]; len[1]],
        vec![[None; 2]; len[2]],
    ];
    for (e, m) in matches.iter().enumerate() {
        let (k0, k1) = (e, (e + 1) % 3);
        for &(a, b, _) in m.iter() {
            partner[k0][a as usize][0] = Some(b);
            partner[k1][b as usize][1] = Some(a);
        }
    }
    let mut in_cycle: [Vec<bool>; 3] = [
        vec![false; len[0]],
        vec![false; len[1]],
        vec![false; len[2]],
    ];
    let mut triples = Vec::new();
    let mut cycles = 0u32;
    for a in 0..len[0] {
        let Some(b) = partner[0][a][0] else { continue };
        let Some(c) = partner[1][b as usize][0] else {
            continue;
        };
        if partner[2][c as usize][0] != Some(a as u16) {
            continue;
        }
        in_cycle[0][a] = true;
        in_cycle[1][b as usize] = true;
        in_cycle[2][c as usize] = true;
        let ids = [a as u16, b, c];
        if (0..3).any(|k| lit(k, ids[k])) {
            triples.push(Triple {
                members: ids.map(|csl| Member {
                    csl,
                    image: Share::Full,
                }),
                split: None,
            });
        }
        cycles += 1;
    }
    // A CSL whose partners on both of its edges are blacks (made for it, so with no partner
    // on the face's third edge): its two pair triples would have the same members and weights,
    // so they are one triple adding all of its image.
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        for x in 0..len[i] {
            if in_cycle[i][x] {
                continue;
            }
            let (Some(y), Some(z)) = (partner[i][x][0], partner[i][x][1]) else {
                continue;
            };
            if partner[j][y as usize][0].is_some() || partner[k][z as usize][1].is_some() {
                continue;
            }
            in_cycle[i][x] = true;
            in_cycle[j][y as usize] = true;
            in_cycle[k][z as usize] = true;
            if lit(i, x as u16) {
                triples.push(Triple {
                    members: placed(
                        i,
                        [(x as u16, Share::Full), (y, Share::None), (z, Share::None)],
                    ),
                    split: None,
                });
            }
        }
    }
    for (e, m) in matches.iter().enumerate() {
        let (i, j) = (e, (e + 1) % 3);
        for &(x, y, _) in m.iter() {
            if in_cycle[i][x as usize] || in_cycle[j][y as usize] || !(lit(i, x) || lit(j, y)) {
                continue;
            }
            // x's partner at k is on edge (k, i): x's previous-corner partner; y's on (j, k):
            // y's next-corner partner. A black partner made on one edge has none on the
            // others: the other's partner stands in (its weight only matters where the black's
            // corner has weight, and a black adds no light there).
            let (zx, zy) = (partner[i][x as usize][1], partner[j][y as usize][0]);
            let (Some(zx), Some(zy)) = (zx.or(zy), zy.or(zx)) else {
                continue;
            };
            triples.push(Triple {
                members: placed(i, [(x, Share::Half), (y, Share::Half), (zx, Share::None)]),
                split: Some(zy),
            });
        }
    }
    (triples, cycles)
}

/// Bake the dynamic CSL set of object `object_name`: a static set per icosahedron direction
/// (directions in parallel), axis tracking and matching per edge (edges in parallel), triples
/// per face. `progress` may return false to cancel.
pub fn bake_dynamic(
    world: &World,
    object_name: &str,
    params: &DynamicParams,
    progress: &(dyn Fn(DynamicProgress) -> bool + Sync),
) -> Result<DynamicSet, BakeError> {
    let t_start = Instant::now();
    params.validate()?;
    let object = world
        .object(object_name)
        .ok_or_else(|| BakeError::UnknownObject(object_name.to_string()))?;
    let ico = Icosphere::new(params.subdivisions);
    let cancel = AtomicBool::new(false);
    let check = |stage, done, total| {
        if !cancel.load(Ordering::Relaxed) && !report(progress, stage, done, total) {
            cancel.store(true, Ordering::Relaxed);
        }
        !cancel.load(Ordering::Relaxed)
    };
    // 1. A static set per direction, all on one BVH (also the tracking's).
    let t0 = Instant::now();
    let local = rigid_frame_world(world, object);
    let accel = bake_accel(&local);
    let nv = ico.vertices.len();
    let done = AtomicU32::new(0);
    check("directions", 0, nv as u32);
    let sets: Vec<Result<CslSet, BakeError>> = ico
        .vertices
        .par_iter()
        .map(|&dir| {
            // Directions bake side by side, so no core is spare within one.
            let set = bake_csl_with(
                world,
                object_name,
                dir,
                &params.csl,
                &|_| !cancel.load(Ordering::Relaxed),
                false,
                Some(&accel),
            )?;
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            if !check("directions", d, nv as u32) {
                return Err(BakeError::Canceled);
            }
            Ok(set)
        })
        .collect();
    let sets: Vec<CslSet> = sets.into_iter().collect::<Result<_, _>>()?;
    let time_bakes = t0.elapsed();

    // 2. Tracking and matching per edge, with the rays along every direction traced once for
    // the edges that meet there (and the CSLs' image bands found once).
    let t0 = Instant::now();
    let edges = ico.edges();
    let done = AtomicU32::new(0);
    check("tracking", 0, edges.len() as u32);
    let bounds = (sets[0].centre, sets[0].radius);
    let bands: Vec<Vec<(f32, f32, f32)>> = sets
        .par_iter()
        .map(|s| s.csls.iter().map(image_band).collect())
        .collect();
    let along: Vec<Option<StepRays>> = sets
        .par_iter()
        .map(|s| StepRays::trace(&accel, s.light_dir, bounds, params, &cancel))
        .collect();
    let Some(along) = along.into_iter().collect::<Option<Vec<_>>>() else {
        return Err(BakeError::Canceled);
    };
    let end = |i: u32| End {
        set: &sets[i as usize],
        bands: &bands[i as usize],
        rays: &along[i as usize],
    };
    let matches: Vec<Option<EdgeMatch>> = edges
        .par_iter()
        .map(|&[i, j]| {
            let m = match_edge(&accel, [end(i), end(j)], params, &cancel)?;
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            check("tracking", d, edges.len() as u32).then_some(m)
        })
        .collect();
    if cancel.load(Ordering::Relaxed) || matches.iter().any(Option::is_none) {
        return Err(BakeError::Canceled);
    }
    let time_tracking = t0.elapsed();

    // Place the blacks (edge order) and resolve their provisional indices.
    let t0 = Instant::now();
    let mut blacks: Vec<Vec<Csl>> = vec![Vec::new(); nv];
    let mut edge_pairs: HashMap<(u32, u32), Vec<Match>> = HashMap::new();
    let mut stats = DynamicStats {
        directions: nv as u32,
        csls: sets.iter().map(|s| s.csls.len() as u32).sum(),
        edges: edges.len() as u32,
        ..Default::default()
    };
    for (&[i, j], m) in edges.iter().zip(matches.into_iter().flatten()) {
        let base = [
            (sets[i as usize].csls.len() + blacks[i as usize].len()) as u16,
            (sets[j as usize].csls.len() + blacks[j as usize].len()) as u16,
        ];
        let place = |x: u16, end: usize| {
            if x > u16::MAX - m.blacks[end].len() as u16 {
                base[end] + (u16::MAX - x)
            } else {
                x
            }
        };
        let pairs = m
            .pairs
            .iter()
            .map(|&(a, b, d)| (place(a, 0), place(b, 1), d))
            .collect();
        stats.blacks += (m.blacks[0].len() + m.blacks[1].len()) as u32;
        stats.matched += m.matched;
        stats.tracking_rays += m.rays;
        let [b0, b1] = m.blacks;
        blacks[i as usize].extend(b0);
        blacks[j as usize].extend(b1);
        edge_pairs.insert((i, j), pairs);
    }
    if sets
        .iter()
        .zip(&blacks)
        .any(|(s, b)| s.csls.len() + b.len() >= u16::MAX as usize)
    {
        return Err(BakeError::InvalidParams(
            "too many CSLs at one direction for a dynamic set".into(),
        ));
    }

    // 3. Triples per face.
    check("triples", 0, ico.faces.len() as u32);
    let mut triples = Vec::with_capacity(ico.faces.len());
    for f in &ico.faces {
        let oriented: Vec<Vec<Match>> = (0..3)
            .map(|e| {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                let p = &edge_pairs[&(a.min(b), a.max(b))];
                if a < b {
                    p.clone()
                } else {
                    p.iter().map(|&(x, y, d)| (y, x, d)).collect()
                }
            })
            .collect();
        let len = [0, 1, 2].map(|k| {
            let v = f[k] as usize;
            sets[v].csls.len() + blacks[v].len()
        });
        let lit = |k: usize, i: u16| {
            let v = f[k] as usize;
            (i as usize) < sets[v].csls.len()
        };
        let (t, consistent) = face_triples([&oriented[0], &oriented[1], &oriented[2]], len, &lit);
        stats.triples += t.len() as u32;
        stats.consistent_triples += consistent;
        triples.push(t);
    }
    stats.time_bakes = time_bakes;
    stats.time_tracking = time_tracking;
    stats.time_triples = t0.elapsed();
    stats.time_total = t_start.elapsed();
    report(progress, "done", 1, 1);
    Ok(DynamicSet {
        source_hash: dynamic_source_hash(world, object_name, params).unwrap_or_default(),
        object_hash: object_hash(world, object),
        params_hash: params.hash(),
        subdivisions: params.subdivisions,
        sets,
        blacks,
        triples,
        stats,
    })
}

impl DynamicSet {
    /// Whether this bake was made for `object` (its meshes, materials and scale) of `world`.
    pub fn is_for(&self, world: &World, object: &crate::scene::Object) -> bool {
        self.object_hash == object_hash(world, object)
    }

    pub fn icosphere(&self) -> Icosphere {
        Icosphere::new(self.subdivisions)
    }

    /// CSL `i` of direction `v`: a real one, then the blacks.
    pub fn csl(&self, v: usize, i: u16) -> &Csl {
        let real = &self.sets[v].csls;
        if (i as usize) < real.len() {
            &real[i as usize]
        } else {
            &self.blacks[v][i as usize - real.len()]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::sampling::Pcg;
    use std::collections::BTreeSet;

    /// Every real CSL of a corner adds exactly all its image in a face (rule 3), whatever the
    /// matching; a face whose matches close into cycles gets exactly those cycles as matched
    /// triples (rule 1); a pair triple's geometry-only members are the partners of its image
    /// members on the face's other edges (what makes rule 2 hold).
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn triples_count_every_csl_once_and_keep_cycles() {
        let all = |_: usize, _: u16| true;
        // Cycles: corner k's CSL i matched with CSL i of the next corner.
        let m: Vec<Match> = (0..4).map(|i| (i, i, i as f32)).collect();
        let (t, cycles) = face_triples([&m, &m, &m], [4, 4, 4], &all);
        assert_eq!((t.len(), cycles), (4, 4));
        assert!(t.iter().all(|t| {
            t.split.is_none()
                && t.members
                    .iter()
                    .all(|m| m.image == Share::Full && m.csl == t.members[0].csl)
        }));

        // Scrambled matches with blacks (indices ≥ the real counts).
        let mut seed = 3u32;
        for _ in 0..200 {
            let mut rnd = |n: usize| {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                (seed >> 8) as usize % n
            };
            let real = [1 + rnd(6), 1 + rnd(6), 1 + rnd(6)];
            // Per edge a random bijection between its ends, padded with blacks.
            let mut len = real;
            let mut edges: Vec<Vec<Match>> = Vec::new();
            for e in 0..3 {
                let (k0, k1) = (e, (e + 1) % 3);
                let mut b: Vec<usize> = (0..real[k1]).collect();
                for i in (1..b.len()).rev() {
                    b.swap(i, rnd(i + 1));
                }
                let mut pairs = Vec::new();
                for i in 0..real[k0].max(real[k1]) {
                    let a = if i < real[k0] {
                        i as u16
                    } else {
                        len[k0] += 1;
                        len[k0] as u16 - 1
                    };
                    let c = if i < real[k1] {
                        b[i] as u16
                    } else {
                        len[k1] += 1;
                        len[k1] as u16 - 1
                    };
                    pairs.push((a, c, rnd(100) as f32));
                }
                edges.push(pairs);
            }
            let lit = |k: usize, i: u16| (i as usize) < real[k];
            let (t, _) = face_triples([&edges[0], &edges[1], &edges[2]], len, &lit);
            for k in 0..3 {
                for i in 0..real[k] {
                    let share: f32 = t
                        .iter()
                        .filter(|t| t.members[k].csl as usize == i)
                        .map(|t| t.members[k].image.fraction())
                        .sum();
                    assert_eq!(share, 1.0, "corner {k} CSL {i}: {t:?}");
                }
                assert!(t.iter().all(|t| (t.members[k].csl as usize) < len[k]));
            }
            let partner = |e: usize, a: u16| edges[e].iter().find(|m| m.0 == a).map(|m| m.1);
            let partner_back = |e: usize, b: u16| edges[e].iter().find(|m| m.1 == b).map(|m| m.0);
            for tr in t.iter().filter(|t| t.split.is_some()) {
                let k = (0..3)
                    .find(|&k| tr.members[k].image == Share::None)
                    .unwrap();
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                // x at i: its partner at k is on edge (k, i) = edge k, x at its second end; y at
                // j: on edge (j, k) = edge j, y at its first end. A black has only one of them.
                let (px, py) = (
                    partner_back(k, tr.members[i].csl),
                    partner(j, tr.members[j].csl),
                );
                assert_eq!(px.or(py), Some(tr.members[k].csl));
                assert_eq!(py.or(px), tr.split);
                // x and y are matched on edge (i, j) = edge i.
                assert_eq!(partner(i, tr.members[i].csl), Some(tr.members[j].csl));
            }
        }
    }

    /// Copies of one set turned with the light (what a sphere would give), matched one to one;
    /// the CSL axes lie `tilt` off the light direction and the image blobs `tilt` off centre
    /// (with 0, radially symmetric: no twist of the images' frames can change them).
    pub(super) fn rotated_copies(sub: u32, tilt: f32) -> DynamicSet {
        let ico = Icosphere::new(sub);
        let centre = Vec3::new(0.1, 0.5, -0.2);
        let n = 64u32;
        let image = |cx: f32, cy: f32| -> Vec<[u16; 3]> {
            (0..n * n)
                .map(|i| {
                    let (x, y) = (
                        (i % n) as f32 / n as f32 - cx,
                        (i / n) as f32 / n as f32 - cy,
                    );
                    let v = (-(x * x + y * y) * 60.0).exp();
                    [
                        (v * 65535.0) as u16,
                        (v * 30000.0) as u16,
                        (v * 65535.0) as u16,
                    ]
                })
                .collect()
        };
        let base_dir = ico.vertices[0];
        let base = [(0.5 + tilt, 0.5, tilt), (0.5, 0.5 - tilt, -tilt)].map(|(cx, cy, off)| {
            let x = base_dir.any_orthonormal_vector();
            Csl {
                origin: centre - base_dir * 0.3 + x * off,
                axis: (base_dir + x * off).normalize(),
                x_axis: {
                    let a = (base_dir + x * off).normalize();
                    (x - a * x.dot(a)).normalize()
                },
                kappa: 1.2,
                gamma: 0.3,
                half_extent: 0.4,
                size: n,
                scale: 2.0,
                flux: 0.1,
                grain: 0.0,
                texels: image(cx, cy),
            }
        });
        let sets = ico
            .vertices
            .iter()
            .map(|&v| {
                let q = Quat::from_rotation_arc(base_dir, v);
                CslSet {
                    source_hash: 1,
                    params_hash: 2,
                    light_dir: v,
                    centre,
                    radius: 0.5,
                    spacing: 0.01,
                    csls: base
                        .iter()
                        .map(|c| Csl {
                            origin: centre + q * (c.origin - centre),
                            axis: (q * c.axis).normalize(),
                            x_axis: (q * c.x_axis).normalize(),
                            ..c.clone()
                        })
                        .collect(),
                    stats: Default::default(),
                }
            })
            .collect();
        let triples = ico
            .faces
            .iter()
            .map(|_| {
                (0..2)
                    .map(|i| Triple {
                        members: [Member {
                            csl: i,
                            image: Share::Full,
                        }; 3],
                        split: None,
                    })
                    .collect()
            })
            .collect();
        DynamicSet {
            source_hash: 3,
            object_hash: 4,
            params_hash: 2,
            subdivisions: sub,
            sets,
            blacks: vec![Vec::new(); ico.vertices.len()],
            triples,
            stats: Default::default(),
        }
    }

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
