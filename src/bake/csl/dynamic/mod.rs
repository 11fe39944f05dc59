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
//!   coordinates of [`Icosphere::locate`]) and light-plane origins turn with their axes before
//!   the linear blend; the focus law and the image are not blended: each member of a triple is
//!   moved onto the blended axis with its own α, β and image, weighted (see
//!   `render/csl/interpolate.rs`).
//!
//! The bake is laid out by stage: [`Icosphere`] (the light directions, `icosphere.rs`),
//! tracking and matching along the edges (`tracking.rs`), the triples of each face
//! (`triples.rs`) and the artifact (`codec.rs`); this file holds the parameters, the set and
//! [`bake_dynamic`], which runs the stages in turn. The per-frame interpolation is on the
//! render side ([`crate::render::csl::interpolate`]).

mod codec;
mod icosphere;
mod tracking;
mod triples;

pub use codec::{CODE_NOISE, MAGIC, VERSION, code_levels};
pub use icosphere::Icosphere;
pub use triples::{Member, Share, Triple};

use super::{
    BakeError, Csl, CslParams, CslSet, bake_accel, bake_csl_with, object_hash, rigid_frame_world,
};
use crate::bake::Fnv64;
use crate::scene::World;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};
use tracking::{EdgeMatch, End, Match, StepRays, image_band, match_edge};
use triples::face_triples;

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
    /// tracking steps trace 96² rays (the paper does not give its count). Measured on a
    /// 12-direction bake of the glass teapot, the worst fitting object, its interpolated sets'
    /// fit against fresh photons: 0.42 with 128² rays, 0.43 with 96², 0.54 with 64² (the
    /// sphere's matches do not change from 48² to 128²); 96² takes the tracking's time from
    /// 7.5 s to 5.1 s there, and the sphere's at the paper's settings from 136 s to 74 s.
    pub const fn paper() -> Self {
        DynamicParams {
            subdivisions: 2,
            steps: 20,
            track_grid: 96,
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

impl DynamicSet {
    /// Bytes it holds in memory: its static sets, black CSLs and triples.
    pub fn heap_bytes(&self) -> usize {
        let csls = |v: &Vec<Csl>| v.iter().map(Csl::heap_bytes).sum::<usize>();
        std::mem::size_of::<DynamicSet>()
            + self.sets.iter().map(CslSet::heap_bytes).sum::<usize>()
            + self.blacks.iter().map(csls).sum::<usize>()
            + self
                .triples
                .iter()
                .map(|t| t.len() * std::mem::size_of::<Triple>())
                .sum::<usize>()
    }
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

/// Bake the dynamic CSL set of object `object_name`: a static set per icosahedron direction
/// (directions in parallel), axis tracking and matching per edge (edges in parallel), triples
/// per face. `progress` may return false to cancel.
pub fn bake_dynamic(
    world: &World,
    object_name: &str,
    params: &DynamicParams,
    progress: &(dyn Fn(DynamicProgress) -> bool + Sync),
) -> Result<DynamicSet, BakeError> {
    bake_dynamic_within(world, object_name, params, progress, codec::MAX_BODY)
}

/// Bytes a set's CSLs take in memory, and a bound on what they add to the artifact's body
/// before it is deflated (what the reader checks): six a texel (coded or not, a texel is written
/// as three u16), and 384 a CSL for its header (about 70) and its share of the black partners
/// and triples (about three blacks of 44 bytes and seven triple entries of 11 bytes a CSL on
/// the teapot).
fn set_bytes(set: &CslSet) -> u64 {
    set.csls
        .iter()
        .map(|c| c.texels.len() as u64 * 6 + 384)
        .sum()
}

/// [`bake_dynamic`] that stops, with an error naming the sizes, as soon as the sets baked so
/// far take more than `max_bytes` (the artifact reader's bound, [`codec::MAX_BODY`]): a set the
/// renderer could not load is refused while it bakes, not written. (The glass teapot at the
/// paper's settings, 208 CSLs a direction, took 8.8 GB and 12 minutes before its 184 MB
/// artifact was refused on loading.)
fn bake_dynamic_within(
    world: &World,
    object_name: &str,
    params: &DynamicParams,
    progress: &(dyn Fn(DynamicProgress) -> bool + Sync),
    max_bytes: u64,
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
    let (bytes, too_large) = (AtomicU64::new(0), AtomicU32::new(0));
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
                // Asks the caller while a direction bakes, not only between directions.
                &|_| check("directions", done.load(Ordering::Relaxed), nv as u32),
                false,
                Some(&accel),
            )?;
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            let size = set_bytes(&set);
            let held = bytes.fetch_add(size, Ordering::Relaxed) + size;
            if held > max_bytes {
                too_large.store(d, Ordering::Relaxed);
                cancel.store(true, Ordering::Relaxed);
                return Err(BakeError::Canceled);
            }
            if !check("directions", d, nv as u32) {
                return Err(BakeError::Canceled);
            }
            Ok(set)
        })
        .collect();
    let baked = too_large.load(Ordering::Relaxed);
    if baked > 0 {
        return Err(BakeError::InvalidParams(format!(
            "the dynamic set is too large: its intensity images passed {:.1} GiB after {baked} \
             of its {nv} directions, more than a render can load; bake with fewer subdivisions, \
             a smaller grid or the fast preset, or render this object with method photons",
            max_bytes as f64 / (1u64 << 30) as f64
        )));
    }
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
    // The tracing polls `cancel`; a watcher asks the caller every 100 ms and sets it, so that a
    // long edge stops soon after the caller says so (not only between edges).
    let tracked = AtomicBool::new(false);
    // Set when the tracking ends, by a panic too, so that the watcher always stops.
    struct Done<'a>(&'a AtomicBool);
    impl Drop for Done<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::Relaxed);
        }
    }
    let (along, matches) = std::thread::scope(|sc| {
        let _done = Done(&tracked);
        sc.spawn(|| {
            while !tracked.load(Ordering::Relaxed)
                && check("tracking", done.load(Ordering::Relaxed), edges.len() as u32)
            {
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
        });
        let along: Vec<Option<StepRays>> = sets
            .par_iter()
            .map(|s| StepRays::trace(&accel, s.light_dir, bounds, params, &cancel))
            .collect();
        let along = along.into_iter().collect::<Option<Vec<_>>>();
        let matches: Vec<Option<EdgeMatch>> = match &along {
            None => vec![],
            Some(along) => {
                let end = |i: u32| End {
                    set: &sets[i as usize],
                    bands: &bands[i as usize],
                    rays: &along[i as usize],
                };
                edges
                    .par_iter()
                    .map(|&[i, j]| {
                        let m = match_edge(&accel, [end(i), end(j)], params, &cancel)?;
                        let d = done.fetch_add(1, Ordering::Relaxed) + 1;
                        check("tracking", d, edges.len() as u32).then_some(m)
                    })
                    .collect()
            }
        };
        (along, matches)
    });
    if along.is_none() || cancel.load(Ordering::Relaxed) || matches.iter().any(Option::is_none) {
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
pub(crate) mod tests {
    use super::*;
    use glam::{Mat3, Quat, Vec3};

    /// A dynamic set whose images would pass the bound stops while its directions bake, with
    /// an error that says so, instead of writing an artifact no render can load.
    #[test]
    fn a_set_too_large_to_load_is_refused_while_it_bakes() {
        let json = r#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
             "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
             "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.5,
                          "segments": 24}, "material": "glass"}]}"#;
        let world = crate::scene::load_scene_json(json.as_bytes()).expect("scene resolves");
        let params = DynamicParams {
            subdivisions: 0,
            steps: 2,
            track_grid: 16,
            csl: CslParams {
                grid: 48,
                ..CslParams::fast()
            },
            ..DynamicParams::paper()
        };
        let whole = bake_dynamic(&world, "ball", &params, &|_| true).expect("bake");
        let need: u64 = whole.sets.iter().map(set_bytes).sum();
        let r = bake_dynamic_within(&world, "ball", &params, &|_| true, need / 2);
        match r {
            Err(BakeError::InvalidParams(m)) => {
                assert!(
                    m.contains("too large") && m.contains("of its 12 directions"),
                    "{m}"
                )
            }
            other => panic!("{:?}", other.map(|d| d.sets.len())),
        }
        // Within the bound it bakes the same set.
        let again = bake_dynamic_within(&world, "ball", &params, &|_| true, need).expect("bake");
        assert!(again.to_bytes() == whole.to_bytes());
    }

    /// Copies of one set turned with the light (what a sphere would give), matched one to one;
    /// the CSL axes lie `tilt` off the light direction and the image blobs `tilt` off centre
    /// (with 0, radially symmetric: no twist of the images' frames can change them).
    pub(crate) fn rotated_copies(sub: u32, tilt: f32) -> DynamicSet {
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
                        .map(|c| c.clone().turned(centre, Mat3::from_quat(q)))
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
}
