//! Stage 1 of the CSL bake: a regular grid of parallel rays over the object's silhouette, traced
//! recursively through the object alone (both Fresnel branches, total internal reflection,
//! Beer-Lambert absorption) until they leave it for good.

use super::CslParams;
use crate::trace::{Accel, optics, simd};
use glam::Vec3;
use rayon::prelude::*;

/// A ray leaving the caustic object: where it last left the surface, its direction, and the
/// energy it carries relative to one unit per grid ray (RGB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticRay {
    pub origin: Vec3,
    pub dir: Vec3,
    pub energy: Vec3,
}

impl CausticRay {
    /// Scalar energy used for clustering and coverage: the RGB mean.
    pub fn weight(&self) -> f32 {
        self.energy.element_sum() / 3.0
    }
}

/// The ray grid: light direction and an orthonormal frame of the plane the rays start on.
#[derive(Clone, Copy, Debug)]
pub struct RayGrid {
    pub light: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub centre: Vec3,
    pub radius: f32,
    pub n: u32,
}

impl RayGrid {
    /// Distance between neighbouring rays, metres.
    pub fn spacing(&self) -> f32 {
        2.0 * self.radius / self.n as f32
    }

    /// Start of grid ray (i, j), cell centres, on a plane 2 radii before the bounding sphere
    /// centre; None outside the projected bounding sphere (such a ray cannot hit the object).
    pub fn origin(&self, i: u32, j: u32) -> Option<Vec3> {
        let s = self.spacing();
        let x = -self.radius + (i as f32 + 0.5) * s;
        let y = -self.radius + (j as f32 + 0.5) * s;
        if x * x + y * y > self.radius * self.radius {
            return None;
        }
        Some(self.centre - self.light * (2.0 * self.radius) + self.u * x + self.v * y)
    }
}

/// No triangle on a grid ray ([`first_triangles`]).
const NONE: u32 = u32::MAX;

/// The triangle of `accel` each grid ray meets first (row-major, `u32::MAX` where none), by
/// rasterising the triangles onto the grid along the light: an orthographic z-buffer whose
/// pixel centres are the grid rays, a few ten milliseconds for the 1.6 M rays of a 1280² grid
/// instead of a BVH query per ray. A triangle claims the rays within a small tolerance of its
/// edges, so that no ray the exact ray-triangle test would give it is lost; the tracer checks
/// the claim with that test and asks the BVH where it fails.
pub fn first_triangles(accel: &Accel, grid: &RayGrid) -> Vec<u32> {
    first_triangles_with(accel, grid, &|| true).expect("never asked to stop")
}

/// Triangles [`first_triangles_with`] bins between two questions to its `keep_going`.
pub const BIN_CHUNK: usize = 1 << 16;

/// [`first_triangles`] that asks `keep_going` every [`BIN_CHUNK`] triangles as they are
/// binned and before each band of 16 rows is rasterised; None once it says stop.
pub fn first_triangles_with(
    accel: &Accel,
    grid: &RayGrid,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Option<Vec<u32>> {
    let stop = crate::cancel::Stop::new(keep_going);
    let n = grid.n as usize;
    let (r, s) = (grid.radius as f64, grid.spacing() as f64);
    let frame = [grid.u, grid.v, grid.light].map(|a| a.as_dvec3());
    // Triangles in pixel units (pixel (i, j) centred on (i, j)) with their depth along the light.
    let project = |v: Vec3| {
        let q = (v - grid.centre).as_dvec3();
        glam::DVec3::new(
            (q.dot(frame[0]) + r) / s - 0.5,
            (q.dot(frame[1]) + r) / s - 0.5,
            q.dot(frame[2]),
        )
    };
    const BAND: usize = 16;
    let bands = n.div_ceil(BAND);
    let mut binned: Vec<Vec<u32>> = vec![Vec::new(); bands];
    let tris: Vec<[glam::DVec3; 3]> = (0..accel.triangle_count())
        .map(|p| accel.triangle_vertices(p).map(project))
        .collect();
    let span = |lo: f64, hi: f64| -> Option<(usize, usize)> {
        let (a, b) = ((lo - 1e-3).ceil(), (hi + 1e-3).floor());
        (b >= 0.0 && a <= (n - 1) as f64 && a <= b)
            .then(|| (a.max(0.0) as usize, b.min((n - 1) as f64) as usize))
    };
    for (p, t) in tris.iter().enumerate() {
        if !stop.go_at(p, BIN_CHUNK) {
            return None;
        }
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        if let Some((j0, j1)) = span(lo.y, hi.y) {
            for list in &mut binned[j0 / BAND..=j1 / BAND] {
                list.push(p as u32);
            }
        }
    }
    let rows: Vec<Vec<u32>> = binned
        .par_iter()
        .enumerate()
        .map(|(band, list)| {
            let (b0, b1) = (band * BAND, ((band + 1) * BAND).min(n));
            let mut depth = vec![f64::INFINITY; (b1 - b0) * n];
            let mut first = vec![NONE; (b1 - b0) * n];
            if !stop.go() {
                return first;
            }
            for &p in list {
                let [a, b, c] = tris[p as usize];
                let area = (b - a).truncate().perp_dot((c - a).truncate());
                if area.abs() < 1e-12 {
                    continue;
                }
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                let (Some((i0, i1)), Some((j0, j1))) = (span(lo.x, hi.x), span(lo.y, hi.y)) else {
                    continue;
                };
                for j in j0.max(b0)..=j1.min(b1 - 1) {
                    for i in i0..=i1 {
                        let q = glam::DVec2::new(i as f64, j as f64);
                        let wa = (b.truncate() - q).perp_dot(c.truncate() - q) / area;
                        let wb = (c.truncate() - q).perp_dot(a.truncate() - q) / area;
                        let wc = 1.0 - wa - wb;
                        const TOL: f64 = -1e-4;
                        if wa < TOL || wb < TOL || wc < TOL {
                            continue;
                        }
                        let z = wa * a.z + wb * b.z + wc * c.z;
                        let k = (j - b0) * n + i;
                        if z < depth[k] {
                            depth[k] = z;
                            first[k] = p;
                        }
                    }
                }
            }
            first
        })
        .collect();
    (!stop.stopped()).then(|| rows.concat())
}

/// Totals of the trace stage.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceTotals {
    /// Grid rays that hit the object.
    pub hits: u64,
    /// Energy (RGB mean) that left the object in recorded rays.
    pub exiting: f64,
    /// Energy dropped below the threshold or by the depth limit.
    pub dropped: f64,
}

/// Trace every grid ray; rows run in parallel and are concatenated in order, so the result is
/// deterministic. `progress(rows_done)` may return false to stop (then None); it is asked
/// every 16 rows, and with 0 rows done while the first triangles and the object's convexity
/// are worked out.
pub fn trace_grid(
    accel: &Accel,
    grid: &RayGrid,
    params: &CslParams,
    progress: &(dyn Fn(u32) -> bool + Sync),
) -> Option<(Vec<CausticRay>, TraceTotals)> {
    // The z-buffer pays wherever the rays are at least a quarter as many as the triangles
    // (measured on the dynamic bake's 128² tracking grids, 42 directions: the 65k-triangle
    // sphere's tracking 39.0 → 35.6 s, the 6.3k-triangle teapot's 36.0 → 33.7 s), not for the
    // tiny grids of tests.
    // The object's convexity (worked out once per BVH) beside it, not on the first ray.
    let asked = || progress(0);
    let stop = crate::cancel::Stop::new(&asked);
    let (first, convex) = rayon::join(
        || {
            (4 * (grid.n as usize).pow(2) >= accel.triangle_count())
                .then(|| first_triangles_with(accel, grid, &|| stop.go()))
        },
        || accel.convex_orientation_with(&|| stop.go()),
    );
    if stop.stopped() || convex.is_none() {
        return None;
    }
    let first = first.flatten();
    // Objects that are not convex are traced in waves ([`trace_row_waves`]); a convex one
    // ray by ray, where a path's exit guess saves most of the tree walks.
    let waved = accel.convex_orientation().is_none() && params.max_depth <= WAVE_MAX_DEPTH;
    let done = std::sync::atomic::AtomicU32::new(0);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let rows: Vec<(Vec<CausticRay>, TraceTotals)> = (0..grid.n)
        .into_par_iter()
        .map(|j| {
            let mut out = Vec::new();
            let mut stack = Vec::new();
            let mut waves = Waves::default();
            let mut tot = TraceTotals::default();
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                return (out, tot);
            }
            let n = grid.n as usize;
            let row = Row {
                j,
                first: first
                    .as_ref()
                    .map(|f| &f[j as usize * n..(j as usize + 1) * n]),
            };
            if waved {
                trace_row_waves(accel, grid, row, params, &mut waves, &mut out, &mut tot);
            } else {
                simd::dispatch!(
                    ["avx2"],
                    fn(
                        accel: &Accel,
                        grid: &RayGrid,
                        row: Row,
                        params: &CslParams,
                        stack: &mut PathStack = &mut stack,
                        out: &mut Vec<CausticRay> = &mut out,
                        tot: &mut TraceTotals = &mut tot,
                    ) {
                        trace_row(accel, grid, row, params, stack, out, tot)
                    }
                );
            }
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            if d.is_multiple_of(16) && !progress(d) {
                cancel.store(true, std::sync::atomic::Ordering::Relaxed);
            }
            (out, tot)
        })
        .collect();
    if cancel.load(std::sync::atomic::Ordering::Relaxed) {
        return None;
    }
    let mut tot = TraceTotals::default();
    let mut rays = Vec::with_capacity(rows.iter().map(|r| r.0.len()).sum());
    for (r, t) in rows {
        rays.extend(r);
        tot.hits += t.hits;
        tot.exiting += t.exiting;
        tot.dropped += t.dropped;
    }
    Some((rays, tot))
}

/// Row `j` of the grid, with the triangle each of its rays meets first where known.
#[derive(Clone, Copy)]
struct Row<'a> {
    j: u32,
    first: Option<&'a [u32]>,
}

/// The grid rays of one row.
#[inline(always)]
fn trace_row(
    accel: &Accel,
    grid: &RayGrid,
    row: Row,
    params: &CslParams,
    stack: &mut PathStack,
    out: &mut Vec<CausticRay>,
    tot: &mut TraceTotals,
) {
    let mut exits = [NONE; EXIT_GUESSES];
    for i in 0..grid.n {
        let first = row.first.map(|f| f[i as usize]);
        if first == Some(NONE) {
            continue;
        }
        if let Some(o) = grid.origin(i, row.j) {
            trace_one(
                accel, o, grid.light, first, params, stack, &mut exits, out, tot,
            );
        }
    }
}

/// The deepest paths [`trace_row_waves`] keys (two bits a level in a u64, and one more
/// level for what the deepest leave behind).
const WAVE_MAX_DEPTH: u32 = 31;

/// A path of [`trace_row_waves`]: its grid ray (place in the row), its key (the branches it
/// took, see [`key_at`]), interactions so far, origin, direction and energy.
#[derive(Clone, Copy)]
struct Path {
    key: u64,
    ray: u32,
    depth: u32,
    o: Vec3,
    d: Vec3,
    e: Vec3,
}

/// What a path leaves behind: a ray leaving the object (`out`) or energy dropped, with the
/// energy; sorted by grid ray and key they come in the order [`trace_one`] makes them.
#[derive(Clone, Copy)]
struct Event {
    ray: u32,
    key: u64,
    out: bool,
    o: Vec3,
    d: Vec3,
    e: Vec3,
}

/// Scratch space of [`trace_row_waves`], kept by the caller so that a row allocates it once.
#[derive(Default)]
struct Waves {
    paths: Vec<Path>,
    next: Vec<Path>,
    /// The reflected and the refracted branches of the paths of one key.
    branches: [Vec<Path>; 2],
    events: Vec<Event>,
    /// The events' order, and the start of each grid ray's events in it.
    order: Vec<u32>,
    starts: Vec<u32>,
}

/// `key` with digit `v` at level `depth`: two bits a level, first level highest, so that keys
/// sort as [`trace_one`]'s depth-first order visits. At a path's level, 0 marks what it leaves
/// behind itself (an exit, or energy dropped at the depth limit or on a non-specular part) or
/// its refracted branch's dropped energy, 1 its reflected branch's dropped energy (the order
/// [`trace_one`] drops them in), 2 its reflected branch and 3 its refracted one (reflection
/// is traced first).
#[inline(always)]
fn key_at(key: u64, depth: u32, v: u64) -> u64 {
    key | v << (62 - 2 * depth)
}

/// The row's grid rays traced in waves, a level of every ray's path tree at a time, so that
/// the paths of neighbouring rays that took the same branches are traced together, eight to a
/// packet ([`Accel::intersect_packet`]): the same hits as [`trace_one`] finds, and the same
/// rays and totals in the same order (what each path leaves behind is put into its
/// depth-first order before it is written or summed).
///
/// Each wave is in order of key, then grid ray: the branches of the paths of one key are
/// appended reflected ones first, so the next wave is in that order too without a sort.
fn trace_row_waves(
    accel: &Accel,
    grid: &RayGrid,
    row: Row,
    params: &CslParams,
    w: &mut Waves,
    out: &mut Vec<CausticRay>,
    tot: &mut TraceTotals,
) {
    w.paths.clear();
    w.events.clear();
    for i in 0..grid.n {
        if row.first.is_some_and(|f| f[i as usize] == NONE) {
            continue;
        }
        if let Some(o) = grid.origin(i, row.j) {
            w.paths.push(Path {
                key: 0,
                ray: i,
                depth: 0,
                o,
                d: grid.light,
                e: Vec3::ONE,
            });
        }
    }
    while !w.paths.is_empty() {
        let paths = std::mem::take(&mut w.paths);
        w.next.clear();
        let mut start = 0;
        while start < paths.len() {
            let key = paths[start].key;
            let end = start + paths[start..].partition_point(|p| p.key == key);
            for run in paths[start..end].chunks(8) {
                let mut hits = [None; 8];
                if run[0].depth == 0 {
                    for (h, p) in hits.iter_mut().zip(run) {
                        let first = row.first.map(|f| f[p.ray as usize] as usize);
                        *h = match first {
                            Some(f) => accel.triangle_hit(f, p.o, p.d, f32::INFINITY),
                            None => None,
                        }
                        .or_else(|| accel.intersect(p.o, p.d, f32::INFINITY));
                    }
                } else if run.len() == 1 {
                    hits[0] = accel
                        .intersect_prim(run[0].o, run[0].d, f32::INFINITY)
                        .map(|(_, h)| h);
                } else {
                    let rays: [(Vec3, Vec3); 8] = std::array::from_fn(|k| {
                        run.get(k).map_or((Vec3::ZERO, Vec3::Z), |p| (p.o, p.d))
                    });
                    let mut found = [None; 8];
                    accel.intersect_packet(&rays[..run.len()], &mut found[..run.len()]);
                    for (h, f) in hits.iter_mut().zip(found) {
                        *h = f.map(|(_, h)| h);
                    }
                }
                for (p, hit) in run.iter().zip(hits) {
                    shade_path(accel, params, p, hit, w, tot);
                }
            }
            let [reflected, refracted] = &mut w.branches;
            w.next.append(reflected);
            w.next.append(refracted);
            start = end;
        }
        w.paths = paths;
        std::mem::swap(&mut w.paths, &mut w.next);
    }
    // The events by grid ray (a counting sort, keeping their order), then each ray's by key.
    let n = grid.n as usize;
    w.starts.clear();
    w.starts.resize(n + 1, 0);
    for ev in &w.events {
        w.starts[ev.ray as usize + 1] += 1;
    }
    for i in 0..n {
        w.starts[i + 1] += w.starts[i];
    }
    w.order.clear();
    w.order.resize(w.events.len(), 0);
    let mut fill = w.starts.clone();
    for (k, ev) in w.events.iter().enumerate() {
        let slot = &mut fill[ev.ray as usize];
        w.order[*slot as usize] = k as u32;
        *slot += 1;
    }
    for i in 0..n {
        let (a, b) = (w.starts[i] as usize, w.starts[i + 1] as usize);
        let events = &w.events;
        w.order[a..b].sort_unstable_by_key(|&k| events[k as usize].key);
    }
    for &k in &w.order {
        let ev = &w.events[k as usize];
        let weight = (ev.e.element_sum() / 3.0) as f64;
        if ev.out {
            out.push(CausticRay {
                origin: ev.o,
                dir: ev.d,
                energy: ev.e,
            });
            tot.exiting += weight;
        } else {
            tot.dropped += weight;
        }
    }
}

/// One path of [`trace_row_waves`] at its hit (None: it left the object): [`trace_one`]'s
/// steps for an object that is not convex, its branches joining `w.branches` and what it
/// leaves behind `w.events`.
#[inline(always)]
fn shade_path(
    accel: &Accel,
    params: &CslParams,
    p: &Path,
    hit: Option<crate::trace::Hit>,
    w: &mut Waves,
    tot: &mut TraceTotals,
) {
    let event = |v: u64, out: bool, e: Vec3| Event {
        ray: p.ray,
        key: key_at(p.key, p.depth, v),
        out,
        o: p.o,
        d: p.d,
        e,
    };
    let Some(hit) = hit else {
        if p.depth > 0 {
            w.events.push(event(0, true, p.e));
        }
        return;
    };
    if p.depth == 0 {
        tot.hits += 1;
    }
    let mat = accel.material(&hit);
    let e = p.e * optics::segment_transmittance(&hit, mat);
    if p.depth >= params.max_depth {
        w.events.push(event(0, false, e));
        return;
    }
    let branches = optics::specular_branches(&hit, p.d, mat);
    if branches.iter().all(Option::is_none) {
        w.events.push(event(0, false, e));
        return;
    }
    for (k, b) in branches.into_iter().enumerate().rev() {
        let Some(b) = b else { continue };
        let eb = e * b.weight;
        if eb.element_sum() / 3.0 < params.min_energy {
            w.events.push(event(1 - k as u64, false, eb));
            continue;
        }
        w.branches[k].push(Path {
            key: key_at(p.key, p.depth, 2 + k as u64),
            ray: p.ray,
            depth: p.depth + 1,
            o: hit.spawn(b.dir),
            d: b.dir,
            e: eb,
        });
    }
}

/// Places of a path in its ray's tree (heap order: the grid ray 1, the branches of place k
/// 2k and 2k + 1) whose last exit triangle is kept: the first five interactions.
const EXIT_GUESSES: usize = 64;

/// Paths waiting to be traced: (origin, direction, energy, interactions so far, whether it
/// leaves a convex object and so meets nothing more, place in the ray's tree).
type PathStack = Vec<(Vec3, Vec3, Vec3, u32, bool, u32)>;

/// One grid ray, whose first triangle is `first` where known ([`first_triangles`]): depth-first
/// over both branches at every hit. `stack` is scratch space (empty on entry and on return),
/// kept by the caller so that a row allocates it once.
///
/// Inside a convex object a path meets exactly one triangle, where it leaves, so whatever
/// triangle it hits is the one: the triangle the same place of the previous ray's tree left
/// through (`exits`, kept along a row, where neighbouring rays take nearly the same paths) is
/// tried before the BVH.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn trace_one(
    accel: &Accel,
    origin: Vec3,
    dir: Vec3,
    first: Option<u32>,
    params: &CslParams,
    stack: &mut PathStack,
    exits: &mut [u32; EXIT_GUESSES],
    out: &mut Vec<CausticRay>,
    tot: &mut TraceTotals,
) {
    let convex = accel.convex_orientation();
    stack.push((origin, dir, Vec3::ONE, 0, false, 1));
    while let Some((o, d, e, depth, leaves, place)) = stack.pop() {
        let hit = if leaves {
            None
        } else if let (0, Some(first)) = (depth, first) {
            accel
                .triangle_hit(first as usize, o, d, f32::INFINITY)
                .or_else(|| accel.intersect(o, d, f32::INFINITY))
        } else if convex.is_some() && depth > 0 && (place as usize) < EXIT_GUESSES {
            let guess = exits[place as usize];
            let known = (guess != NONE)
                .then(|| accel.triangle_hit(guess as usize, o, d, f32::INFINITY))
                .flatten();
            known.or_else(|| {
                let (id, hit) = accel.intersect_prim(o, d, f32::INFINITY)?;
                exits[place as usize] = id as u32;
                Some(hit)
            })
        } else {
            accel.intersect(o, d, f32::INFINITY)
        };
        let Some(hit) = hit else {
            if depth > 0 {
                out.push(CausticRay {
                    origin: o,
                    dir: d,
                    energy: e,
                });
                tot.exiting += (e.element_sum() / 3.0) as f64;
            }
            continue;
        };
        if depth == 0 {
            tot.hits += 1;
        }
        let mat = accel.material(&hit);
        let e = e * optics::segment_transmittance(&hit, mat);
        if depth >= params.max_depth {
            tot.dropped += (e.element_sum() / 3.0) as f64;
            continue;
        }
        let branches = optics::specular_branches(&hit, d, mat);
        if branches.iter().all(Option::is_none) {
            // A non-specular part of the object absorbs (its diffuse light is not a caustic).
            tot.dropped += (e.element_sum() / 3.0) as f64;
            continue;
        }
        // Push refraction first so that reflection is traced first: the order is fixed, so the
        // output order is deterministic.
        // The outward normal of the hit triangle, where the object is convex.
        let outward = convex.map(|sign| {
            let winding = if hit.front_face {
                hit.geo_normal
            } else {
                -hit.geo_normal
            };
            winding * sign
        });
        for (k, b) in branches.into_iter().enumerate().rev() {
            let Some(b) = b else { continue };
            let eb = e * b.weight;
            if eb.element_sum() / 3.0 < params.min_energy {
                tot.dropped += (eb.element_sum() / 3.0) as f64;
                continue;
            }
            let leaves = outward.is_some_and(|n| b.dir.dot(n) > 0.0);
            let next = (2 * place + k as u32).min(EXIT_GUESSES as u32);
            stack.push((hit.spawn(b.dir), b.dir, eb, depth + 1, leaves, next));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_z_buffer_finds_the_triangle_the_bvh_finds() {
        // A torus seen obliquely (rays through the hole, rays meeting it twice, silhouette
        // rays) and a cube lit along an axis (rays on shared edges): every grid ray's first
        // triangle gives the BVH's closest hit, or the tracer's fallback asks the BVH; a ray
        // with no triangle misses.
        let world = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
                 "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
                 "objects": [
                   {"name": "ring", "shape": {"type": "torus", "major_radius": 0.5,
                    "minor_radius": 0.2, "segments": 48}, "material": "glass"},
                   {"name": "box", "shape": {"type": "box", "size": [0.4, 0.4, 0.4]},
                    "material": "glass", "transform": {"translation": [2, 0, 0]}}]}"#,
        )
        .expect("scene resolves");
        for (name, light) in [
            ("ring", Vec3::new(0.3, -1.0, 0.45).normalize()),
            ("box", Vec3::NEG_Y),
        ] {
            let object = world.object(name).unwrap();
            let local = super::super::rigid_frame_world(&world, object);
            let accel = Accel::build(&local);
            let (lo, hi) = local.bounds();
            let centre = 0.5 * (lo + hi);
            let (u, v) = light.any_orthonormal_pair();
            let grid = RayGrid {
                light,
                u,
                v,
                centre,
                radius: 0.5 * (hi - lo).length(),
                n: 200,
            };
            let first = first_triangles(&accel, &grid);
            let (mut hits, mut claims_checked) = (0, 0);
            for j in 0..grid.n {
                for i in 0..grid.n {
                    let Some(o) = grid.origin(i, j) else { continue };
                    let want = accel.intersect(o, light, f32::INFINITY);
                    let p = first[(j * grid.n + i) as usize];
                    if p == NONE {
                        assert!(want.is_none(), "{name}: ray ({i}, {j}) has no triangle");
                        continue;
                    }
                    hits += want.is_some() as u32;
                    if let Some(got) = accel.triangle_hit(p as usize, o, light, f32::INFINITY) {
                        claims_checked += 1;
                        let want = want.expect("a hit");
                        assert!(
                            (got.t - want.t).abs() <= 1e-5 * want.t,
                            "{name} ({i}, {j}): {} vs {}",
                            got.t,
                            want.t
                        );
                    }
                }
            }
            eprintln!("{name}: {hits} hits, {claims_checked} claims checked");
            assert!(hits > 5000, "{name}: {hits}");
            assert!(
                claims_checked * 100 >= hits * 99,
                "{claims_checked} of {hits}"
            );
        }
    }

    /// Waves and packets trace what the ray-by-ray tracer traces, bit for bit and in the same
    /// order: the caustic rays and the totals, row by row, for a torus and the glass teapot
    /// (neither convex: total internal reflection, rays leaving and meeting the object again),
    /// with and without the z-buffer's first triangles.
    #[test]
    fn waves_trace_what_the_ray_by_ray_tracer_traces() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let teapot = crate::scene::load_scene_file(
            &dir.join("scenes/glass-teapot.json"),
            &Default::default(),
        )
        .expect("teapot scene");
        let torus = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 3, 3], "target": [0, 0, 0]},
                 "materials": {"glass": {"type": "dielectric", "ior": 1.5}},
                 "objects": [{"name": "ring", "shape": {"type": "torus", "major_radius": 0.5,
                              "minor_radius": 0.2, "segments": 48}, "material": "glass"}]}"#,
        )
        .expect("scene resolves");
        let params = CslParams::default();
        for (world, name, light) in [
            (&torus, "ring", Vec3::new(0.3, -1.0, 0.45).normalize()),
            (&teapot, "teapot", Vec3::new(-0.2, -1.0, 0.3).normalize()),
        ] {
            let object = world.object(name).expect("the object");
            let local = super::super::rigid_frame_world(world, object);
            let accel = Accel::build(&local);
            assert!(accel.convex_orientation().is_none());
            let (lo, hi) = local.bounds();
            let (u, v) = light.any_orthonormal_pair();
            let grid = RayGrid {
                light,
                u,
                v,
                centre: 0.5 * (lo + hi),
                radius: 0.5 * (hi - lo).length(),
                n: 96,
            };
            let first = first_triangles(&accel, &grid);
            let n = grid.n as usize;
            let (mut stack, mut waves) = (Vec::new(), Waves::default());
            let mut rays = 0;
            for j in 0..grid.n {
                for zbuffer in [false, true] {
                    let row = Row {
                        j,
                        first: zbuffer.then(|| &first[j as usize * n..(j as usize + 1) * n]),
                    };
                    let (mut want, mut got) = (Vec::new(), Vec::new());
                    let (mut want_tot, mut got_tot) = Default::default();
                    trace_row(
                        &accel,
                        &grid,
                        row,
                        &params,
                        &mut stack,
                        &mut want,
                        &mut want_tot,
                    );
                    trace_row_waves(
                        &accel,
                        &grid,
                        row,
                        &params,
                        &mut waves,
                        &mut got,
                        &mut got_tot,
                    );
                    let bits = |r: &CausticRay| {
                        [r.origin, r.dir, r.energy].map(|v| v.to_array().map(f32::to_bits))
                    };
                    assert_eq!(
                        want.iter().map(bits).collect::<Vec<_>>(),
                        got.iter().map(bits).collect::<Vec<_>>(),
                        "{name}: row {j}"
                    );
                    let tot = |t: TraceTotals| (t.hits, t.exiting.to_bits(), t.dropped.to_bits());
                    assert_eq!(tot(want_tot), tot(got_tot), "{name}: row {j}");
                    rays += want.len();
                }
            }
            eprintln!("{name}: {rays} rays");
            assert!(rays > 10_000, "{name}: {rays} rays");
        }
    }
}
