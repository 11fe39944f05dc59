//! Sample points on a reflector's surface, by the four strategies of Wand and Straßer 2003
//! §3.2, with a density uniform over area.
//!
//! A pattern is made per mesh in the object's *shape frame*: its vertices under the object's
//! transform without the rotation and translation (the scale stays), so that a rigidly moving
//! object carries the same pattern with it (no flicker from resampling). Points are stored as
//! (triangle, barycentric coordinates), and the quantised strategy's grid-cell centres in the
//! shape frame; every frame evaluates them on the mesh as it is then. A deforming mesh with
//! the same triangles keeps its points attached to the surface (their density drifts where
//! triangles stretch); a mesh whose vertices change gets a new pattern, since the pattern is
//! keyed by the mesh's content. The work is deterministic (seeded), so re-making a pattern
//! every frame gives the same points; a small cache keeps the last ones.

use crate::sampling::Pcg;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};

/// How sample points are chosen (§3.2).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// Uniformly at random over the area: noisy.
    Random,
    /// A dense random set thinned to one point per cell of a 3D grid: less noise, biased
    /// towards surfaces parallel to the grid.
    Grid,
    /// As `grid`, each point moved to its cell's centre: least noise, aliasing and
    /// displacement (the paper finds it unfavourable).
    Quantized,
    /// A dense random set thinned greedily: a point within a fixed distance of a kept one is
    /// removed (Poisson-disc-like): uniform, unbiased, no structure. The paper's choice.
    #[default]
    Neighbourhood,
}

impl Strategy {
    pub const ALL: [Strategy; 4] = [
        Strategy::Random,
        Strategy::Grid,
        Strategy::Quantized,
        Strategy::Neighbourhood,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Random => "random",
            Strategy::Grid => "grid",
            Strategy::Quantized => "quantized",
            Strategy::Neighbourhood => "neighbourhood",
        }
    }
}

/// One sample point of a pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub triangle: u32,
    /// Weights of the triangle's second and third vertices.
    pub bary: Vec2,
    /// `quantized`: the grid cell's centre in the shape frame (where the point is drawn).
    pub snapped: Option<Vec3>,
}

/// The sample points of one mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Pattern {
    pub points: Vec<SurfacePoint>,
    /// The mesh's area in the shape frame (m²; a rigid motion keeps it).
    pub area: f32,
    /// The characteristic spacing: the grid cell or the removal distance, or √(area/N) for
    /// `random`.
    pub spacing: f32,
}

/// Dense candidate sets are this many times the points asked for (at most
/// [`MAX_CANDIDATES`]).
const OVERSAMPLING: usize = 8;
const MAX_CANDIDATES: usize = 800_000;

/// The pattern of about `n` points (exactly `n` for `random`; the thinning strategies land
/// within a few per cent) on the triangles `indices` of vertices `q` (shape frame).
pub fn make_pattern(
    q: &[Vec3],
    indices: &[[u32; 3]],
    n: usize,
    strategy: Strategy,
    seed: u64,
) -> Pattern {
    make_pattern_with(q, indices, n, strategy, seed, &|| true).expect("never asked to stop")
}

/// [`make_pattern`] that asks `keep_going` before each thinning of the candidates (up to 22
/// of up to 800k candidates each); None once it says stop.
pub fn make_pattern_with(
    q: &[Vec3],
    indices: &[[u32; 3]],
    n: usize,
    strategy: Strategy,
    seed: u64,
    keep_going: &dyn Fn() -> bool,
) -> Option<Pattern> {
    let cdf = area_cdf(q, indices);
    let area = cdf.last().copied().unwrap_or(0.0);
    if n == 0 || area <= 0.0 {
        return Some(Pattern {
            points: Vec::new(),
            area,
            spacing: 0.0,
        });
    }
    if !keep_going() {
        return None;
    }
    let mut rng = Pcg::new(seed, 0x5eed_0f91);
    let m = match strategy {
        Strategy::Random => n,
        _ => (n * OVERSAMPLING).clamp(n, MAX_CANDIDATES.max(n)),
    };
    let cands: Vec<(SurfacePoint, Vec3)> = (0..m)
        .map(|_| {
            let u = rng.f32() * area;
            let t = cdf.partition_point(|&c| c <= u).min(indices.len() - 1);
            let (r1, r2) = (rng.f32().sqrt(), rng.f32());
            let bary = Vec2::new(r1 * (1.0 - r2), r1 * r2);
            let [a, b, c] = indices[t].map(|i| q[i as usize]);
            let p = a + (b - a) * bary.x + (c - a) * bary.y;
            (
                SurfacePoint {
                    triangle: t as u32,
                    bary,
                    snapped: None,
                },
                p,
            )
        })
        .collect();
    let h0 = (area / n as f32).sqrt();
    Some(match strategy {
        Strategy::Random => Pattern {
            points: cands.into_iter().map(|c| c.0).collect(),
            area,
            spacing: h0,
        },
        Strategy::Grid | Strategy::Quantized => {
            let h = fit_scale(n, h0, |h| grid_thin(&cands, h).len(), keep_going)?;
            let mut points = grid_thin(&cands, h);
            if strategy == Strategy::Quantized {
                for (sp, cell) in &mut points {
                    sp.snapped = Some((cell.as_vec3() + Vec3::splat(0.5)) * h);
                }
            }
            Pattern {
                points: points.into_iter().map(|p| p.0).collect(),
                area,
                spacing: h,
            }
        }
        Strategy::Neighbourhood => {
            let r = fit_scale(n, h0, |r| poisson_thin(&cands, r).len(), keep_going)?;
            Pattern {
                points: poisson_thin(&cands, r),
                area,
                spacing: r,
            }
        }
    })
}

/// Cumulative areas of the triangles.
fn area_cdf(q: &[Vec3], indices: &[[u32; 3]]) -> Vec<f32> {
    let mut acc = 0f64;
    indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| q[i as usize]);
            acc += 0.5 * f64::from((b - a).cross(c - a).length());
            acc as f32
        })
        .collect()
}

/// The scale (cell size or removal distance) at which `count` keeps about `n` points: count
/// falls as the scale grows, so bisect in log scale around `h0` and keep the closest. None
/// when `keep_going`, asked before each count, says stop.
fn fit_scale(
    n: usize,
    h0: f32,
    count: impl Fn(f32) -> usize,
    keep_going: &dyn Fn() -> bool,
) -> Option<f32> {
    let (mut lo, mut hi) = ((h0 / 16.0).ln(), (h0 * 4.0).ln());
    let mut best = (usize::MAX, h0);
    for _ in 0..22 {
        if !keep_going() {
            return None;
        }
        let mid = 0.5 * (lo + hi);
        let c = count(mid.exp());
        let err = c.abs_diff(n);
        if err < best.0 {
            best = (err, mid.exp());
        }
        if err == 0 {
            break;
        }
        if c > n {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(best.1)
}

fn cell(p: Vec3, h: f32) -> glam::IVec3 {
    (p / h).floor().as_ivec3()
}

/// The first candidate of each grid cell of side `h`, with its cell.
fn grid_thin(cands: &[(SurfacePoint, Vec3)], h: f32) -> Vec<(SurfacePoint, glam::IVec3)> {
    let mut seen = HashSet::with_capacity(cands.len());
    cands
        .iter()
        .filter_map(|(sp, p)| {
            let c = cell(*p, h);
            seen.insert(c).then_some((*sp, c))
        })
        .collect()
}

/// Greedy removal: a candidate closer than `r` to a kept point is dropped.
fn poisson_thin(cands: &[(SurfacePoint, Vec3)], r: f32) -> Vec<SurfacePoint> {
    let mut grid: HashMap<glam::IVec3, Vec<Vec3>> = HashMap::new();
    let mut kept = Vec::new();
    let r2 = r * r;
    'next: for (sp, p) in cands {
        let c = cell(*p, r);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if let Some(v) = grid.get(&(c + glam::IVec3::new(dx, dy, dz)))
                        && v.iter().any(|k| k.distance_squared(*p) < r2)
                    {
                        continue 'next;
                    }
                }
            }
        }
        grid.entry(c).or_default().push(*p);
        kept.push(*sp);
    }
    kept
}

type Key = (u64, usize, Strategy, u64);

/// The last patterns made, by (mesh content in the shape frame, n, strategy, seed).
static CACHE: Mutex<Vec<(Key, Arc<Pattern>)>> = Mutex::new(Vec::new());
const CACHE_ENTRIES: usize = 32;

/// [`make_pattern`] through the cache.
pub fn pattern(
    q: &[Vec3],
    indices: &[[u32; 3]],
    n: usize,
    strategy: Strategy,
    seed: u64,
) -> Arc<Pattern> {
    pattern_with(q, indices, n, strategy, seed, &|| true).expect("never asked to stop")
}

/// [`make_pattern_with`] through the cache (a pattern whose making stopped is not kept);
/// None once `keep_going` says stop.
pub fn pattern_with(
    q: &[Vec3],
    indices: &[[u32; 3]],
    n: usize,
    strategy: Strategy,
    seed: u64,
    keep_going: &dyn Fn() -> bool,
) -> Option<Arc<Pattern>> {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for p in q {
        p.to_array().map(f32::to_bits).hash(&mut h);
    }
    indices.hash(&mut h);
    let key = (h.finish(), n, strategy, seed);
    if let Some((_, p)) = CACHE
        .lock()
        .expect("pattern cache")
        .iter()
        .find(|(k, _)| *k == key)
    {
        return Some(p.clone());
    }
    let p = Arc::new(make_pattern_with(
        q, indices, n, strategy, seed, keep_going,
    )?);
    let mut c = CACHE.lock().expect("pattern cache");
    if c.len() >= CACHE_ENTRIES {
        c.remove(0);
    }
    c.push((key, p.clone()));
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    fn positions(m: &crate::scene::Mesh, p: &Pattern) -> Vec<Vec3> {
        p.points
            .iter()
            .map(|s| {
                s.snapped.unwrap_or_else(|| {
                    let [a, b, c] = m.indices[s.triangle as usize].map(|i| m.positions[i as usize]);
                    a + (b - a) * s.bary.x + (c - a) * s.bary.y
                })
            })
            .collect()
    }

    /// Nearest-neighbour distances of `pts`, sorted.
    fn nn(pts: &[Vec3]) -> Vec<f32> {
        let mut d: Vec<f32> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| {
                pts.iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, q)| p.distance(*q))
                    .fold(f32::INFINITY, f32::min)
            })
            .collect();
        d.sort_by(f32::total_cmp);
        d
    }

    #[test]
    fn every_strategy_lands_near_the_count_asked_for_and_is_deterministic() {
        let m = shapes::torus(0.6, 0.1, 96);
        for s in Strategy::ALL {
            let a = make_pattern(&m.positions, &m.indices, 500, s, 3);
            let n = a.points.len();
            assert!((475..=525).contains(&n), "{s:?}: {n} points for 500");
            assert_eq!(
                a,
                make_pattern(&m.positions, &m.indices, 500, s, 3),
                "{s:?}"
            );
            let area = 4.0 * std::f32::consts::PI.powi(2) * 0.6 * 0.1;
            assert!((a.area / area - 1.0).abs() < 0.01, "{}", a.area);
        }
    }

    #[test]
    fn thinning_spreads_points_more_evenly_than_random() {
        // The smallest gaps: random sampling clumps, the neighbourhood removal never keeps two
        // points closer than its distance.
        let m = shapes::sphere(1.0, 48);
        let gap = |s| {
            let p = make_pattern(&m.positions, &m.indices, 400, s, 1);
            let d = nn(&positions(&m, &p));
            (d[d.len() / 20], p.spacing)
        };
        let (random, _) = gap(Strategy::Random);
        let (grid, _) = gap(Strategy::Grid);
        let (nb, r) = gap(Strategy::Neighbourhood);
        assert!(
            nb >= r * 0.999,
            "neighbourhood keeps its distance: {nb} < {r}"
        );
        assert!(
            nb > 2.0 * random && grid > random,
            "random {random}, grid {grid}, nb {nb}"
        );
    }

    #[test]
    fn quantized_points_sit_at_cell_centres() {
        let m = shapes::sphere(1.0, 32);
        let p = make_pattern(&m.positions, &m.indices, 300, Strategy::Quantized, 1);
        for s in &p.points {
            let c = s.snapped.expect("snapped") / p.spacing - Vec3::splat(0.5);
            assert!((c - c.round()).abs().max_element() < 1e-3, "{c}");
        }
    }

    #[test]
    fn density_is_uniform_over_area() {
        // A plane of two triangles of very different shapes: points per half follow its area.
        let q = [
            Vec3::ZERO,
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(3.0, 0.0, 1.0),
        ];
        let idx = [[0, 2, 1], [1, 2, 3]];
        for s in Strategy::ALL {
            let p = make_pattern(&q, &idx, 2000, s, 9);
            let left = positions_of(&q, &idx, &p)
                .iter()
                .filter(|v| v.x < 1.0)
                .count();
            let frac = left as f32 / p.points.len() as f32;
            assert!((frac - 1.0 / 3.0).abs() < 0.04, "{s:?}: {frac}");
        }
    }

    fn positions_of(q: &[Vec3], idx: &[[u32; 3]], p: &Pattern) -> Vec<Vec3> {
        let m = crate::scene::Mesh {
            positions: q.to_vec(),
            normals: vec![Vec3::Y; q.len()],
            indices: idx.to_vec(),
        };
        positions(&m, p)
    }

    #[test]
    fn the_cache_returns_the_same_pattern() {
        let m = shapes::torus(0.5, 0.1, 32);
        let a = pattern(&m.positions, &m.indices, 100, Strategy::Neighbourhood, 7);
        let b = pattern(&m.positions, &m.indices, 100, Strategy::Neighbourhood, 7);
        assert!(Arc::ptr_eq(&a, &b));
    }
}
