//! The ground truth: CPU photon tracing (light tracing splatted to the camera, plus a caustic
//! photon map) and camera paths, against which every other method is measured.
//!
//! Components (all linear radiance, W/(m²·sr), averaged over each pixel with a box filter):
//! - `direct`: camera ray → first non-specular surface → every light, with shadow rays in which
//!   specular objects block light (light through them is caustics). Background radiance too.
//! - `caustics`: light paths whose every vertex before the non-specular one the camera sees is
//!   specular, L S+ D → camera (Jensen's caustic paths: light from the light, focused by
//!   specular surfaces onto the first diffuse one; what every caustics method here models), by
//!   *light tracing*: every such photon vertex is connected to the pinhole and splatted into the
//!   pixel it projects to (the estimator of Mitsuba's `ptracer`). Per pixel it is a histogram
//!   density estimate whose bin is the pixel footprint, so it converges without bias as photons
//!   grow.
//! - `indirect`: every other light path of two or more bounces, L (S|D)* D (S|D)* D → camera (a
//!   non-specular vertex before the one seen), by the same light tracing. Light a diffuse
//!   surface sends into a glass object and the glass focuses (L D S+ D) is indirect light here,
//!   not caustics: no method that starts from the light's caustic objects can carry it.
//! - `specular`: camera paths through specular chains (glass and mirrors are visible and
//!   refract the scene): E S+ D, with direct lighting at D plus caustics at D from a photon map
//!   of caustic photons (a density estimate over a disc of the pixel's footprint at D, the
//!   path's length times the pixel's angle, kept between a quarter of the map's radius and
//!   its radius, which shrinks as N^-1/6).
//! - `total` = direct + caustics + indirect + specular.
//!
//! Photons are aimed where they matter: for each (light, specular object) pair, photons are
//! emitted only towards the object's bounding sphere and kept only if their first hit is a
//! specular surface of that object; a second population covers the whole scene and keeps only
//! paths whose first hit is non-specular (their first vertex is the `direct` component's, so it
//! is not splatted). Each path is thus sampled by exactly one population.
//!
//! Deterministic for a seed: work is cut into fixed chunks with their own random stream and
//! their results are summed in chunk order.

mod camera;
pub mod compare;
mod media;
pub mod probe;
pub mod sweep;

use camera::{PhotonMap, camera_pixel};
use media::{Flight, connect_medium_to_camera, fog, free_flight, inside_glass};

use crate::frame::Frame;
use crate::sampling::*;
use crate::scene::medium::sample_hg;
use crate::scene::{EnvSampler, Light, Material, World};
use crate::trace::optics::{brdf, sample_specular, segment_transmittance};
use crate::trace::{Accel, Hit};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Reference render settings.
#[derive(Clone, Debug)]
pub struct ReferenceParams {
    pub seed: u64,
    /// Photons (light paths) to trace in all.
    pub photons: u64,
    /// Camera samples per pixel for `direct` and `specular`.
    pub spp: u32,
    /// Longest path, in bounces (Mitsuba's `max_depth` 16 for the canonical scenes).
    pub max_depth: u32,
    /// Stop photon tracing after this long (the result stays unbiased; it is just noisier).
    pub time_budget: Option<Duration>,
    /// Shadow-ray samples for line and environment lights at each shading point.
    pub area_light_samples: u32,
    /// Scattering events in the scene's medium a light path may have: 1 for single scattering
    /// (the beam methods' model), `u32::MAX` for multiple scattering.
    pub volume_bounces: u32,
    /// Only the `caustics` component (the others stay black): photons aimed at the glass and
    /// mirror objects only, no photon map, no camera pass (the methods' self-check,
    /// `methods::check`).
    pub caustics_only: bool,
    /// Only the light of these glass or mirror objects (indices into the world's objects; None:
    /// all of them).
    pub caustic_objects: Option<Vec<usize>>,
}

impl Default for ReferenceParams {
    fn default() -> Self {
        ReferenceParams {
            seed: 1,
            photons: 4_000_000,
            spp: 16,
            max_depth: 16,
            time_budget: None,
            area_light_samples: 8,
            volume_bounces: u32::MAX,
            caustics_only: false,
            caustic_objects: None,
        }
    }
}

/// The component images.
#[derive(Clone, Debug)]
pub struct Components {
    pub direct: Frame,
    pub caustics: Frame,
    pub indirect: Frame,
    pub specular: Frame,
    /// Light scattered in the medium towards the camera: after specular objects
    /// (`volume_caustics`, L S+ V … E) and the rest (`volume`).
    pub volume: Frame,
    pub volume_caustics: Frame,
}

impl Components {
    pub fn total(&self) -> Frame {
        self.direct
            .add(&self.caustics)
            .add(&self.indirect)
            .add(&self.specular)
            .add(&self.volume)
            .add(&self.volume_caustics)
    }

    /// One component of the frame.
    pub fn get(&self, c: crate::frame::Component) -> Frame {
        use crate::frame::Component as C;
        match c {
            C::Direct => self.direct.clone(),
            C::Caustics => self.caustics.clone(),
            C::Indirect => self.indirect.clone(),
            C::Specular => self.specular.clone(),
            C::Volume => self.volume.clone(),
            C::VolumeCaustics => self.volume_caustics.clone(),
            C::Total => self.total(),
        }
    }
}

/// What the reference did and how long each stage took.
#[derive(Clone, Debug, Default)]
pub struct ReferenceStats {
    pub photons_traced: u64,
    /// Tracing stopped at [`ReferenceParams::time_budget`], before all the photons asked for.
    pub stopped_by_time: bool,
    pub caustic_photons_stored: usize,
    pub camera_samples: u64,
    pub stages: Vec<(String, Duration)>,
    /// Where the traced light went, in W (None when photons are aimed at specular objects:
    /// their light is shared between populations by where it first lands).
    pub flux: Option<FluxBalance>,
}

/// The light paths' estimate of where the emitted light went, in W per channel: absorbed by the
/// medium (the collision estimate σa·T/pdf at each sampled scattering), absorbed by surfaces
/// (1 − albedo or reflectance at each vertex, Beer-Lambert in glass and water), or escaped the
/// scene. A check of the weights: emitted = absorbed + escaped + cut.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluxBalance {
    pub emitted: Vec3,
    pub absorbed_medium: Vec3,
    pub absorbed_surfaces: Vec3,
    pub escaped: Vec3,
    /// Paths ended by the depth limit or by a direction sampled below the surface: light no
    /// term accounts for.
    pub cut: Vec3,
}

impl FluxBalance {
    fn add(&mut self, o: &FluxBalance, scale: f32) {
        self.emitted += o.emitted * scale;
        self.absorbed_medium += o.absorbed_medium * scale;
        self.absorbed_surfaces += o.absorbed_surfaces * scale;
        self.escaped += o.escaped * scale;
        self.cut += o.cut * scale;
    }

    /// Absorbed + escaped + cut.
    pub fn accounted(&self) -> Vec3 {
        self.absorbed_medium + self.absorbed_surfaces + self.escaped + self.cut
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error("canceled")]
    Canceled,
}

/// Photons per chunk of work: one random stream, one result buffer.
const CHUNK: u64 = 4096;

/// A source of photons: one light, aimed at one object's bounding sphere or at the whole scene.
#[derive(Clone, Debug)]
struct Population {
    light: usize,
    /// `Some(object)`: first hit must be a specular part of that object. `None`: first hit must
    /// be non-specular.
    target: Option<u32>,
    centre: Vec3,
    radius: f32,
    /// Planned photons.
    count: u64,
}

/// A stored caustic photon for the density estimate seen through specular chains.
#[derive(Clone, Copy, Debug)]
struct Photon {
    pos: Vec3,
    /// Unit direction the light came from (away from the surface).
    wi: Vec3,
    /// Flux, not yet divided by the population's photon count.
    flux: Vec3,
    pop: u32,
}

/// The light-traced images a splat adds to.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    Caustics = 0,
    Indirect = 1,
    Volume = 2,
    VolumeCaustics = 3,
}

/// One splat of light tracing into a pixel.
struct Splat {
    pixel: u32,
    value: Vec3,
    target: Target,
}

/// Render every component of the reference.
///
/// `progress(fraction)` is called as work completes; returning false cancels.
pub fn render(
    world: &World,
    accel: &Accel,
    params: &ReferenceParams,
    progress: &(dyn Fn(f32) -> bool + Sync),
) -> Result<(Components, ReferenceStats), ReferenceError> {
    let mut stats = ReferenceStats::default();
    let cam = &world.camera;
    let (w, h) = (cam.width, cam.height);
    let t0 = Instant::now();

    // Importance sampling of each environment map (None: constant, or not an environment).
    let env = EnvSampler::for_lights(world);
    let env = env.as_slice();

    // --- Photon pass -----------------------------------------------------------------------
    let pops = populations(world, params);
    let guide = Guide::new(&pops);
    // Caustics, indirect, volume, volume caustics (Target's order). Summed in f64: a focus
    // pixel takes millions of splats, and an f32 sum rounds each one away as it grows (the
    // focus lost 3 % at 128 M photons).
    let blank = || vec![DVec3::ZERO; (w * h) as usize];
    let mut traced: [Vec<DVec3>; 4] = [blank(), blank(), blank(), blank()];
    let mut photons: Vec<Photon> = Vec::new();
    let mut emitted = vec![0u64; pops.len()];
    let mut balance = vec![FluxBalance::default(); pops.len()];
    // Chunks listed round-robin over populations so that stopping early (time budget) leaves
    // every population with a fair share; each population is normalised by its own count.
    let mut chunks: Vec<(usize, u64, u64)> = Vec::new(); // (population, first photon, count)
    let max_chunks = pops
        .iter()
        .map(|p| p.count.div_ceil(CHUNK))
        .max()
        .unwrap_or(0);
    for c in 0..max_chunks {
        for (pi, p) in pops.iter().enumerate() {
            let first = c * CHUNK;
            if first < p.count {
                chunks.push((pi, first, CHUNK.min(p.count - first)));
            }
        }
    }
    let batch = (rayon::current_num_threads() * 8).max(1);
    let mut done = 0usize;
    let multi = pops.len() > 1;
    // Per population when there are several (each is normalised by its own count); the
    // volume images only where the scene has a medium.
    let images = if world.media.is_empty() { 2 } else { 4 };
    let mut per_pop_splat: Vec<Vec<Vec<DVec3>>> = if multi {
        pops.iter()
            .map(|_| (0..images).map(|_| blank()).collect())
            .collect()
    } else {
        Vec::new()
    };
    while done < chunks.len() {
        let end = (done + batch).min(chunks.len());
        let results: Vec<(Vec<Splat>, Vec<Photon>, FluxBalance)> = chunks[done..end]
            .par_iter()
            .map(|&(pi, first, n)| {
                trace_photon_chunk(world, accel, params, env, &guide, &pops, pi, first, n)
            })
            .collect();
        for (&(pi, _, n), (splats, ph, fb)) in chunks[done..end].iter().zip(results) {
            emitted[pi] += n;
            balance[pi].add(&fb, 1.0);
            for s in splats {
                let img = if multi {
                    &mut per_pop_splat[pi][s.target as usize]
                } else {
                    &mut traced[s.target as usize]
                };
                img[s.pixel as usize] += s.value.as_dvec3();
            }
            photons.extend(ph);
        }
        done = end;
        if !progress(0.8 * done as f32 / chunks.len() as f32) {
            return Err(ReferenceError::Canceled);
        }
        if params.time_budget.is_some_and(|b| t0.elapsed() > b) {
            stats.stopped_by_time = done < chunks.len();
            break;
        }
    }
    stats.photons_traced = emitted.iter().sum();
    // Normalise by photons actually emitted per population.
    let norm: Vec<f64> = emitted
        .iter()
        .map(|&n| if n > 0 { 1.0 / n as f64 } else { 0.0 })
        .collect();
    if multi {
        for (pi, imgs) in per_pop_splat.iter().enumerate() {
            for (t, img) in imgs.iter().enumerate() {
                for (acc, v) in traced[t].iter_mut().zip(img) {
                    *acc += *v * norm[pi];
                }
            }
        }
    } else if let Some(&s) = norm.first() {
        traced
            .iter_mut()
            .for_each(|img| img.iter_mut().for_each(|v| *v *= s));
    }
    for p in &mut photons {
        p.flux *= norm[p.pop as usize] as f32;
    }
    stats.flux = pops.iter().all(|p| p.target.is_none()).then(|| {
        let mut total = FluxBalance::default();
        for (b, s) in balance.iter().zip(&norm) {
            total.add(b, *s as f32);
        }
        total
    });
    stats.caustic_photons_stored = photons.len();
    stats.stages.push(("photons".into(), t0.elapsed()));

    if params.caustics_only {
        let caustics = Frame {
            width: w,
            height: h,
            pixels: traced[0].iter().map(|v| v.as_vec3()).collect(),
        };
        let black = Frame::new(w, h);
        return Ok((
            Components {
                direct: black.clone(),
                caustics,
                indirect: black.clone(),
                specular: black.clone(),
                volume: black.clone(),
                volume_caustics: black,
            },
            stats,
        ));
    }

    // --- Photon map for caustics seen through specular chains ------------------------------
    let t1 = Instant::now();
    let caustic_photons: u64 = pops
        .iter()
        .zip(&emitted)
        .filter(|(p, _)| p.target.is_some())
        .map(|(_, n)| *n)
        .sum();
    let radius = pops
        .iter()
        .filter(|p| p.target.is_some())
        .map(|p| p.radius)
        .fold(0.0f32, f32::max)
        * 0.25
        * (caustic_photons.max(1) as f32).powf(-1.0 / 6.0);
    let pmap = PhotonMap::new(photons, radius.max(1e-5), &|| progress(0.8))
        .ok_or(ReferenceError::Canceled)?;
    stats.stages.push(("photon map".into(), t1.elapsed()));

    // --- Camera pass -----------------------------------------------------------------------
    let t2 = Instant::now();
    // Checked after every row (reporting 0.8..1.0), so that a large frame stops soon after it
    // is canceled; rows after the stop are left empty and the result is discarded.
    let stop = std::sync::atomic::AtomicBool::new(false);
    let rows_done = std::sync::atomic::AtomicU32::new(0);
    let rows: Vec<Vec<(Vec3, Vec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            if stop.load(Ordering::Relaxed) {
                return Vec::new();
            }
            let row = (0..w)
                .map(|x| camera_pixel(world, accel, params, env, &pmap, x, y))
                .collect();
            let n = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            if !progress(0.8 + 0.2 * n as f32 / h as f32) {
                stop.store(true, Ordering::Relaxed);
            }
            row
        })
        .collect();
    if stop.load(Ordering::Relaxed) || !progress(1.0) {
        return Err(ReferenceError::Canceled);
    }
    stats.camera_samples = u64::from(w) * u64::from(h) * u64::from(params.spp);
    stats.stages.push(("camera".into(), t2.elapsed()));
    let mut direct = Frame::new(w, h);
    let mut specular = Frame::new(w, h);
    for (y, row) in rows.into_iter().enumerate() {
        for (x, (d, s)) in row.into_iter().enumerate() {
            direct.pixels[y * w as usize + x] = d;
            specular.pixels[y * w as usize + x] = s;
        }
    }
    let [caustics, indirect, volume, volume_caustics] = traced.map(|pixels| Frame {
        width: w,
        height: h,
        pixels: pixels.into_iter().map(|v| v.as_vec3()).collect(),
    });
    Ok((
        Components {
            direct,
            caustics,
            indirect,
            specular,
            volume,
            volume_caustics,
        },
        stats,
    ))
}

/// Bounding sphere of a world-space point set.
pub(crate) fn object_sphere(world: &World, oi: usize) -> (Vec3, f32) {
    let o = &world.objects[oi];
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in &o.parts {
        for v in &p.mesh.positions {
            let w = o.transform.transform_point3(*v);
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    let c = (lo + hi) * 0.5;
    let mut r = 0.0f32;
    for p in &o.parts {
        for v in &p.mesh.positions {
            r = r.max((o.transform.transform_point3(*v) - c).length());
        }
    }
    (c, r * 1.001 + 1e-5)
}

/// A rough flux estimate of photons from `light` towards a sphere, used to share photons.
pub(crate) fn power_towards(light: &Light, centre: Vec3, radius: f32) -> f32 {
    let lum = |c: Vec3| c.dot(Vec3::new(0.2126, 0.7152, 0.0722)).max(0.0);
    match light {
        Light::Directional { irradiance, .. } => {
            lum(*irradiance) * std::f32::consts::PI * radius * radius
        }
        Light::Point {
            position,
            intensity,
        } => lum(*intensity) * cone_solid_angle(cone_cos(*position, centre, radius)),
        Light::Spot {
            position,
            intensity,
            ..
        } => lum(*intensity) * cone_solid_angle(cone_cos(*position, centre, radius)),
        Light::Line {
            start,
            end,
            intensity,
        } => lum(*intensity) * cone_solid_angle(cone_cos((*start + *end) * 0.5, centre, radius)),
        Light::Environment { radiance, .. } => {
            lum(*radiance) * SPHERE_SOLID_ANGLE * std::f32::consts::PI * radius * radius
        }
    }
}

/// Cosine of the half-angle of the cone from `p` that contains the sphere; -1 when inside.
fn cone_cos(p: Vec3, c: Vec3, r: f32) -> f32 {
    let d = (c - p).length();
    if d <= r * 1.0001 {
        -1.0
    } else {
        (1.0 - (r / d).powi(2)).max(0.0).sqrt()
    }
}

fn populations(world: &World, params: &ReferenceParams) -> Vec<Population> {
    let photons = params.photons;
    let mut specular_objects = world.objects_with(Material::is_specular);
    if let Some(only) = &params.caustic_objects {
        specular_objects.retain(|o| only.contains(o));
    }
    // The global population covers the media too: light scatters there before any surface.
    let (lo, hi) = world.bounds_with_media();
    let scene_centre = (lo + hi) * 0.5;
    let scene_radius = ((hi - lo).length() * 0.5).max(1e-3) * 1.001;
    let mut targeted = Vec::new();
    for (li, l) in world.lights.iter().enumerate() {
        for &oi in &specular_objects {
            let (c, r) = object_sphere(world, oi);
            targeted.push((
                power_towards(l, c, r),
                Population {
                    light: li,
                    target: Some(oi as u32),
                    centre: c,
                    radius: r,
                    count: 0,
                },
            ));
        }
    }
    let mut global: Vec<(f32, Population)> = world
        .lights
        .iter()
        .enumerate()
        .map(|(li, l)| {
            (
                power_towards(l, scene_centre, scene_radius),
                Population {
                    light: li,
                    target: None,
                    centre: scene_centre,
                    radius: scene_radius,
                    count: 0,
                },
            )
        })
        .collect();
    // Caustics get 80% of the photons when there is anything specular, shared by flux (all of
    // them, and no global population, for the caustics alone).
    let (n_targeted, n_global) = if params.caustics_only {
        (photons, 0)
    } else if targeted.is_empty() {
        (0, photons)
    } else {
        (photons - photons / 5, photons / 5)
    };
    let mut out = Vec::new();
    for (list, n) in [(&mut targeted, n_targeted), (&mut global, n_global)] {
        let sum: f32 = list.iter().map(|(p, _)| *p).sum();
        for (p, pop) in list.iter_mut() {
            let share = if sum > 0.0 { *p / sum } else { 0.0 };
            pop.count = (n as f64 * f64::from(share)).round() as u64;
            if pop.count > 0 {
                out.push(pop.clone());
            }
        }
    }
    out
}

/// Emit one photon of a population: origin, unit direction and flux (not divided by the count).
fn emit(
    world: &World,
    env: &[Option<EnvSampler>],
    pop: &Population,
    rng: &mut Pcg,
) -> Option<(Vec3, Vec3, Vec3)> {
    let light = &world.lights[pop.light];
    let towards = |p: Vec3, rng: &mut Pcg| -> (Vec3, f32) {
        let cos_max = cone_cos(p, pop.centre, pop.radius);
        let axis = (pop.centre - p).normalize_or(Vec3::Y);
        (
            uniform_cone(axis, cos_max, rng.vec2()),
            cone_solid_angle(cos_max),
        )
    };
    let from_far = |d: Vec3, rng: &mut Pcg| -> Vec3 {
        let (t, b) = frame(d);
        let q = disk(rng.vec2()) * pop.radius;
        pop.centre + t * q.x + b * q.y - d * (pop.radius * 2.0 + 1.0)
    };
    let disk_area = std::f32::consts::PI * pop.radius * pop.radius;
    match light {
        Light::Directional {
            direction,
            irradiance,
            angular_radius,
        } => {
            // A disc source: directions uniform over its cone, each carrying its share.
            let d = if *angular_radius > 0.0 {
                uniform_cone(*direction, angular_radius.cos(), rng.vec2())
            } else {
                *direction
            };
            Some((from_far(d, rng), d, *irradiance * disk_area))
        }
        Light::Point {
            position,
            intensity,
        } => {
            let (d, omega) = towards(*position, rng);
            Some((*position, d, *intensity * omega))
        }
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff,
            beam_width,
        } => {
            // Whole scene: sample the spot's own cone, it bounds the emission.
            let (d, omega) = if pop.target.is_none() {
                let c = cutoff.cos();
                (uniform_cone(*direction, c, rng.vec2()), cone_solid_angle(c))
            } else {
                towards(*position, rng)
            };
            let f = Light::spot_falloff(d.dot(*direction), *cutoff, *beam_width);
            if f <= 0.0 {
                return None;
            }
            Some((*position, d, *intensity * (f * omega)))
        }
        Light::Line {
            start,
            end,
            intensity,
        } => {
            let p = start.lerp(*end, rng.f32());
            let (d, omega) = towards(p, rng);
            Some((p, d, *intensity * omega))
        }
        Light::Environment { map, radiance } => {
            // Light arriving from direction `from` travels along -from. A map's directions are
            // importance-sampled (its luminance × sin θ), a constant sky's uniformly; the
            // origin is uniform on the disc facing `from` that covers the target's sphere, so
            // the flux is L · A_disc / pdf(from) (Mitsuba's `envmap` `sample_ray`).
            let (from, pdf) = match (&env[pop.light], map) {
                (Some(s), _) => {
                    let u = rng.vec2();
                    s.sample(u.x, u.y)?
                }
                _ => (uniform_sphere(rng.vec2()), 1.0 / SPHERE_SOLID_ANGLE),
            };
            let l = *radiance * map.as_ref().map_or(Vec3::ONE, |m| m.lookup(from));
            let d = -from;
            Some((from_far(d, rng), d, l * (disk_area / pdf)))
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn trace_photon_chunk(
    world: &World,
    accel: &Accel,
    params: &ReferenceParams,
    env: &[Option<EnvSampler>],
    guide: &Guide,
    pops: &[Population],
    pi: usize,
    first: u64,
    n: u64,
) -> (Vec<Splat>, Vec<Photon>, FluxBalance) {
    let pop = &pops[pi];
    let mut fb = FluxBalance::default();
    let cam = &world.camera;
    let pixel_area = cam.pixel_area();
    let mut rng = Pcg::new(params.seed, ((pi as u64) << 40) | (first / CHUNK));
    let mut splats = Vec::new();
    let mut stored = Vec::new();
    for _ in 0..n {
        let Some((mut o, mut d, mut flux)) = emit(world, env, pop, &mut rng) else {
            continue;
        };
        // A targeted population's photon from a far light (directional, environment) starts
        // on a disc in front of its object: the medium between where the light enters it and
        // that start attenuates it (a scattering there is the global population's). Point,
        // spot and line lights emit from the light itself.
        if pop.target.is_some()
            && !world.media.is_empty()
            && matches!(
                world.lights[pop.light],
                Light::Directional { .. } | Light::Environment { .. }
            )
        {
            flux *= world.media_transmittance_ray(o, -d, f32::INFINITY);
        }
        fb.emitted += flux;
        let mut cut = true;
        let mut specular_seen = false;
        let mut diffuse_vertices = 0u32;
        let mut volume_vertices = 0u32;
        for depth in 0..params.max_depth {
            let hit = intersect(world, accel, o, d);
            // A free flight through the medium (no number is drawn without one). A scattering
            // before the first surface belongs to the global population.
            if let Some(m) = world.media.first()
                && hit.as_ref().is_none_or(|h| !inside_glass(world, accel, h))
            {
                match free_flight(
                    m,
                    o,
                    d,
                    hit.as_ref().map_or(f32::INFINITY, |h| h.t),
                    &mut rng,
                ) {
                    Flight::Pass(weight) => flux *= weight,
                    Flight::Scatter(t, weight) => {
                        if depth == 0 && pop.target.is_some() {
                            cut = false;
                            break;
                        }
                        fb.absorbed_medium += flux * m.sigma_a * weight;
                        flux *= m.sigma_s * weight;
                        volume_vertices += 1;
                        let p = o + d * t;
                        if let Some((pixel, value)) =
                            connect_medium_to_camera(world, accel, m, p, d, flux, pixel_area)
                        {
                            splats.push(Splat {
                                pixel,
                                value,
                                // Through specular objects, and no other vertex before this.
                                target: if specular_seen
                                    && diffuse_vertices == 0
                                    && volume_vertices == 1
                                {
                                    Target::VolumeCaustics
                                } else {
                                    Target::Volume
                                },
                            });
                        }
                        if volume_vertices >= params.volume_bounces {
                            break;
                        }
                        let albedo = m.sigma_s / m.sigma_t().max(Vec3::splat(1e-12));
                        if depth >= 3 {
                            let keep = albedo.max_element().clamp(0.05, 0.95);
                            if rng.f32() >= keep {
                                cut = false;
                                break;
                            }
                            flux /= keep;
                        }
                        o = p;
                        d = sample_hg(m.g, d, rng.f32(), rng.f32());
                        continue;
                    }
                    Flight::Outside => {}
                }
            }
            let Some(hit) = hit else {
                fb.escaped += flux;
                cut = false;
                break;
            };
            let mat = accel.material(&hit);
            if depth == 0 {
                let ok = match pop.target {
                    Some(t) => hit.object == t && mat.is_specular(),
                    None => !mat.is_specular(),
                };
                if !ok {
                    cut = false;
                    break;
                }
            }
            // The water's absorption (the medium's was the free flight's).
            let through =
                segment_transmittance(&hit, mat) * world.water_transmittance(o, hit.point);
            fb.absorbed_surfaces += flux * (Vec3::ONE - through);
            flux *= through;
            if mat.is_specular() {
                let Some(b) = sample_specular(&hit, d, mat, rng.f32()) else {
                    break;
                };
                // Glass splits its light without loss; a mirror keeps its reflectance.
                if let Material::Mirror { reflectance } = mat {
                    fb.absorbed_surfaces += flux * (Vec3::ONE - *reflectance);
                }
                let Some(adjoint) = shading_correction(&hit, -d, b.dir) else {
                    break;
                };
                flux *= b.weight * adjoint;
                specular_seen = true;
                o = hit.spawn(b.dir);
                d = b.dir;
                continue;
            }
            // Non-specular vertex: splat to the camera unless it is the direct component's.
            diffuse_vertices += 1;
            let wi = -d;
            // L S+ D: only specular vertices before this, the first diffuse one.
            let caustic = specular_seen && diffuse_vertices == 1 && volume_vertices == 0;
            if specular_seen || diffuse_vertices >= 2 || volume_vertices > 0 {
                if let Some(s) = connect_to_camera(world, accel, &hit, mat, wi, flux, pixel_area) {
                    splats.push(Splat {
                        pixel: s.0,
                        value: s.1,
                        target: if caustic {
                            Target::Caustics
                        } else {
                            Target::Indirect
                        },
                    });
                }
                if caustic && !params.caustics_only {
                    stored.push(Photon {
                        pos: hit.point,
                        wi,
                        flux,
                        pop: pi as u32,
                    });
                }
            }
            // Continue diffusely: a direction from the cosine lobe or, where the scene has
            // specular objects, towards one of them (their caustics of light the floor sends
            // up, L D S+ D, are otherwise rare), weighted by f·cos / pdf of the mixture.
            let (nd, pdf) = guide.sample(hit.point, hit.normal, &mut rng);
            let Some(adjoint) = shading_correction(&hit, wi, nd) else {
                break;
            };
            let weight = brdf(mat, hit.normal, wi, nd) * (hit.normal.dot(nd) * adjoint / pdf);
            fb.absorbed_surfaces += flux * (Vec3::ONE - weight);
            flux *= weight;
            // Russian roulette after a few bounces keeps long paths cheap but unbiased.
            if depth >= 3 {
                let keep = weight.max_element().clamp(0.05, 0.95);
                if rng.f32() >= keep {
                    cut = false;
                    break;
                }
                flux /= keep;
            }
            if flux.max_element() <= 0.0 {
                cut = false;
                break;
            }
            o = hit.spawn(nd);
            d = nd;
        }
        if cut {
            fb.cut += flux;
        }
    }
    (splats, stored, fb)
}

/// Light-tracing connection of a photon vertex to the pinhole: the pixel and the radiance it
/// adds there, Φ·f·|cosθx| / (d²·cos³θc·A_pixel).
fn connect_to_camera(
    world: &World,
    accel: &Accel,
    hit: &Hit,
    mat: &Material,
    wi: Vec3,
    flux: Vec3,
    pixel_area: f32,
) -> Option<(u32, Vec3)> {
    let cam = &world.camera;
    let to_cam = cam.eye - hit.point;
    let dist = to_cam.length();
    let wo = to_cam / dist;
    let cos_x = hit.geo_normal.dot(wo);
    if cos_x <= 0.0 {
        return None;
    }
    let (px, py, cos_c) = cam.project(hit.point)?;
    if px < 0.0 || py < 0.0 || px >= cam.width as f32 || py >= cam.height as f32 {
        return None;
    }
    let f = brdf(mat, hit.normal, wi, wo);
    if f == Vec3::ZERO {
        return None;
    }
    let adjoint = shading_correction(hit, wi, wo)?;
    let origin = hit.spawn(wo);
    if accel.occluded(origin, wo, (cam.eye - origin).length() * (1.0 - 1e-5)) {
        return None;
    }
    let pixel = py as u32 * cam.width + px as u32;
    let value = flux
        * f
        * world.medium_transmittance(hit.point, cam.eye)
        * (hit.normal.dot(wo) * adjoint / (dist * dist * cos_c.powi(3) * pixel_area));
    Some((pixel, value))
}

/// The adjoint BSDF's correction for shading normals on a light path (Veach 1997, §5.3):
/// light arriving from `wi` and leaving towards `wo` (both pointing away from the surface) is
/// scattered by f_s(wi, wo)·|cos_s wo| times |cos_s wi · cos_g wo| / |cos_s wo · cos_g wi|,
/// where cos_s is taken with the shading normal and cos_g with the geometric one. None for a
/// light leak: a direction on different sides of the two normals, which Mitsuba's particle
/// tracer drops too.
fn shading_correction(hit: &Hit, wi: Vec3, wo: Vec3) -> Option<f32> {
    let (si, gi) = (hit.normal.dot(wi), hit.geo_normal.dot(wi));
    let (so, go) = (hit.normal.dot(wo), hit.geo_normal.dot(wo));
    if si * gi <= 0.0 || so * go <= 0.0 {
        return None;
    }
    Some(((si * go) / (so * gi)).abs())
}

/// How a light path leaves a non-specular vertex: from the shading normal's cosine lobe or, with
/// probability [`Guide::TOWARDS`], uniformly in the cone towards one specular object's bounding
/// sphere. One-sample MIS: the weight divides by the mixture's pdf, so it stays unbiased.
struct Guide {
    spheres: Vec<(Vec3, f32)>,
}

impl Guide {
    const TOWARDS: f32 = 0.5;

    fn new(pops: &[Population]) -> Guide {
        let mut spheres: Vec<(Vec3, f32)> = Vec::new();
        for p in pops.iter().filter(|p| p.target.is_some()) {
            if !spheres.contains(&(p.centre, p.radius)) {
                spheres.push((p.centre, p.radius));
            }
        }
        Guide { spheres }
    }

    /// A direction leaving `x` (shading normal `n`) and its pdf (solid angle).
    fn sample(&self, x: Vec3, n: Vec3, rng: &mut Pcg) -> (Vec3, f32) {
        if self.spheres.is_empty() {
            let d = cosine_hemisphere(n, rng.vec2());
            return (d, n.dot(d).max(0.0) / PI);
        }
        let d = if rng.f32() < Self::TOWARDS {
            let k = ((rng.f32() * self.spheres.len() as f32) as usize).min(self.spheres.len() - 1);
            let (c, r) = self.spheres[k];
            uniform_cone((c - x).normalize_or(Vec3::Y), cone_cos(x, c, r), rng.vec2())
        } else {
            cosine_hemisphere(n, rng.vec2())
        };
        (d, self.pdf(x, n, d))
    }

    fn pdf(&self, x: Vec3, n: Vec3, d: Vec3) -> f32 {
        let cosine = n.dot(d).max(0.0) / PI;
        if self.spheres.is_empty() {
            return cosine;
        }
        let cones: f32 = self
            .spheres
            .iter()
            .map(|&(c, r)| {
                let cos_max = cone_cos(x, c, r);
                if d.dot((c - x).normalize_or(Vec3::Y)) >= cos_max {
                    1.0 / cone_solid_angle(cos_max)
                } else {
                    0.0
                }
            })
            .sum();
        Self::TOWARDS * cones / self.spheres.len() as f32 + (1.0 - Self::TOWARDS) * cosine
    }
}

/// The first hit along o + t·d; on a water surface, with the shading normal of the waves'
/// analytic gradient (the tessellation only places the hit).
fn intersect(world: &World, accel: &Accel, o: Vec3, d: Vec3) -> Option<Hit> {
    let mut hit = accel.intersect(o, d, f32::INFINITY)?;
    if let Some(w) = world.water_of(hit.object)
        && accel.material(&hit).is_specular()
    {
        let n = w.surface.normal(hit.point.x, hit.point.z);
        hit.normal = if n.dot(hit.geo_normal) < 0.0 { -n } else { n };
    }
    Some(hit)
}
