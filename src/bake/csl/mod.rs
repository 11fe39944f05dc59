//! Caustic spot lights, static lighting (Liu et al. 2008 §2–3). For one caustic object and one light
//! direction fixed relative to it, [`bake_csl`] turns the light the object reflects and
//! refracts into a small set of CSLs:
//!
//! 1. [`trace`]: a regular grid of parallel unit-energy rays over the object's silhouette,
//!    traced recursively through the object alone (Fresnel-weighted reflection and refraction,
//!    total internal reflection, absorption) until they leave it; every leaving ray is kept.
//! 2. [`bundle`]: bundle extraction by 3D-DDA energy rasterisation, seeding at the cell of most
//!    energy, threshold assignment and least-squares axis optimisation (§3.1.1).
//! 3. [`fit`]: the CSL parameters by Powell's method with Brent line searches on Eq. 5; rays
//!    the CSL cannot approximate leave the bundle (§3.1.2).
//! 4. [`image`]: the light plane's intensity image by EWA splatting, quantised to 16 bits.
//! 5. Repeat from 2 until the CSLs cover the target fraction of the traced energy.
//!
//! Everything is in the object's *rigid frame*: the object's local coordinates with the
//! object's scale applied (so absorption distances are real), without its rotation and
//! translation; [`CslSet::to_world`] places the set in the world for a render, so a rigidly
//! moving object (light fixed relative to it) reuses the bake. The set is deterministic: the
//! same inputs give the same bytes ([`CslSet::to_bytes`]), whatever the thread count.

pub mod artifact;
pub mod bundle;
pub mod dynamic;
pub mod fit;
pub mod image;
pub mod make;
pub mod optimize;
pub mod rings;
pub mod trace;
pub mod volume;

use super::{BakeError, Fnv64, Progress};
use crate::scene::{Object, World};
use crate::trace::Accel;
use glam::{Mat3, Mat4, Quat, Vec3};
use std::time::{Duration, Instant};

pub use artifact::ArtifactError;

/// Revision of the bake algorithm, part of every set's content hash: bump it whenever the bake
/// gives other CSLs for the same inputs, so that caches (CLI, service) never hand out a set an
/// older algorithm made.
pub const ALGORITHM: u32 = 14;

/// The texel of an intensity image is about this many grid-ray spacings wide (about 256
/// rays' cross-sections a texel where the rays keep their spacing), which sets each image's
/// size from its extent (Liu et al. 2008 §5: "N chosen as 128, 256, or 512 depending on the actual
/// size of the rectangle covered by the intensity image in the light plane"). On the 1280²
/// glass sphere this gives the brightest CSL 256² (its texel is 4.6 splat sizes δ wide;
/// 512² changed the caustic's L1 against the reference by 0.0006) and the CSLs of small
/// extent 128².
pub const TEXEL_SPACINGS: f32 = 16.0;

/// Parameters of a CSL bake. Lengths relative to the object are in units of its bounding
/// sphere radius R, so that one preset suits objects of any size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CslParams {
    /// Rays per side of the square ray grid over the silhouette (only those inside the
    /// projected bounding sphere are traced). 16..=8192; the paper uses 1280.
    pub grid: u32,
    /// A path is dropped when its energy (RGB mean, fraction of the unit a grid ray starts
    /// with) falls below this. 0..1; e.g. 1e-3.
    pub min_energy: f32,
    /// Most surface interactions of one path. 1..=64.
    pub max_depth: u32,
    /// Fraction of the energy leaving the object that the CSLs must cover. (0, 1]; 0.95.
    pub coverage: f32,
    /// Cells per axis of the rasterisation volume (§3.1.1 step 1). 4..=256.
    pub cells: u32,
    /// Half-size of the rasterisation cube around the bounding-sphere centre, in R. ≥ 1.
    pub volume_extent: f32,
    /// Largest distance between a ray's line and the bundle axis, in R. > 0.
    pub distance_threshold: f32,
    /// Largest angle between a ray and the bundle axis, degrees. (0, 90).
    pub angle_threshold_deg: f32,
    /// Largest direction error of a ray kept by a fitted CSL, degrees. > 0.
    pub fit_threshold_deg: f32,
    /// Most assignment/optimisation iterations of one bundle (paper: 100). ≥ 1.
    pub max_iterations: u32,
    /// Most CSLs in a set, a safety bound: the bake stops by `coverage` (or
    /// `max_image_bytes`) first. ≥ 1.
    pub max_csls: u32,
    /// Most bytes of intensity images in a set (8 a texel): the memory bound of a bake that
    /// needs many small CSLs to reach its coverage. ≥ 1 MiB.
    pub max_image_bytes: u64,
    /// A bundle whose fitted energy is below this fraction of the total is not made a CSL
    /// (energy cut-off; its seed cell is not tried again). [0, 1).
    pub min_csl_energy: f32,
    /// Most rays used in the fitting objective (evenly strided through the bundle). ≥ 16.
    pub fit_samples: u32,
    /// Most texels per side of an intensity image. 128..=512. Each image gets 128, 256 or 512
    /// (the paper's sizes) from the extent of its light plane: the size whose texels come
    /// nearest to [`TEXEL_SPACINGS`] grid-ray spacings, up to this.
    pub image_size: u32,
    /// Splat size δ as a multiple of the ray spacing (paper: 3). > 0.
    pub splat_scale: f32,
}

impl CslParams {
    /// The paper's settings: 1280² rays, images of 128², 256² or 512² by their extent.
    pub const fn paper() -> Self {
        CslParams {
            grid: 1280,
            min_energy: 1e-2,
            max_depth: 16,
            coverage: 0.95,
            cells: 64,
            volume_extent: 3.0,
            distance_threshold: 0.1,
            angle_threshold_deg: 60.0,
            fit_threshold_deg: 3.0,
            max_iterations: 100,
            max_csls: 1024,
            max_image_bytes: 128 << 20,
            min_csl_energy: 1e-4,
            fit_samples: 16384,
            image_size: 512,
            splat_scale: 3.0,
        }
    }

    /// Quick bakes for tests and previews: 256² rays, 128² images, a coarser volume.
    pub const fn fast() -> Self {
        CslParams {
            grid: 256,
            cells: 48,
            image_size: 128,
            fit_samples: 4096,
            ..Self::paper()
        }
    }

    /// Check the documented ranges.
    pub fn validate(&self) -> Result<(), BakeError> {
        let bad = |what: &str| Err(BakeError::InvalidParams(what.to_string()));
        if !(16..=8192).contains(&self.grid) {
            return bad("grid must be in 16..=8192");
        }
        if !(0.0..1.0).contains(&self.min_energy) {
            return bad("min_energy must be in [0, 1)");
        }
        if !(1..=64).contains(&self.max_depth) {
            return bad("max_depth must be in 1..=64");
        }
        if !(self.coverage > 0.0 && self.coverage <= 1.0) {
            return bad("coverage must be in (0, 1]");
        }
        if !(4..=256).contains(&self.cells) {
            return bad("cells must be in 4..=256");
        }
        if !(self.volume_extent >= 1.0 && self.volume_extent.is_finite()) {
            return bad("volume_extent must be ≥ 1");
        }
        if !(self.distance_threshold > 0.0 && self.distance_threshold.is_finite()) {
            return bad("distance_threshold must be > 0");
        }
        if !(self.angle_threshold_deg > 0.0 && self.angle_threshold_deg < 90.0) {
            return bad("angle_threshold_deg must be in (0, 90)");
        }
        if !(self.fit_threshold_deg > 0.0 && self.fit_threshold_deg.is_finite()) {
            return bad("fit_threshold_deg must be > 0");
        }
        if self.max_iterations == 0 || self.max_csls == 0 || self.fit_samples < 16 {
            return bad("max_iterations and max_csls must be ≥ 1, fit_samples ≥ 16");
        }
        if self.max_image_bytes < 1 << 20 {
            return bad("max_image_bytes must be ≥ 1 MiB");
        }
        if !(0.0..1.0).contains(&self.min_csl_energy) {
            return bad("min_csl_energy must be in [0, 1)");
        }
        if !(128..=512).contains(&self.image_size) {
            return bad("image_size must be in 128..=512");
        }
        if !(self.splat_scale > 0.0 && self.splat_scale.is_finite()) {
            return bad("splat_scale must be > 0");
        }
        Ok(())
    }

    /// Stable hash of the parameters (part of the artifact header and the cache key).
    pub fn hash(&self) -> u64 {
        let mut h = Fnv64::new();
        for v in [
            self.grid,
            self.max_depth,
            self.cells,
            self.max_iterations,
            self.max_csls,
            self.fit_samples,
            self.image_size,
        ] {
            h.write_u32(v);
        }
        for v in [
            self.min_energy,
            self.coverage,
            self.volume_extent,
            self.distance_threshold,
            self.angle_threshold_deg,
            self.fit_threshold_deg,
            self.min_csl_energy,
            self.splat_scale,
        ] {
            h.write_f32(v);
        }
        h.write(&self.max_image_bytes.to_le_bytes());
        h.finish()
    }
}

impl Default for CslParams {
    fn default() -> Self {
        Self::paper()
    }
}

/// One caustic spot light, in the rigid frame of its object.
#[derive(Clone, Debug, PartialEq)]
pub struct Csl {
    /// Light plane origin c (m).
    pub origin: Vec3,
    /// Unit optical axis â (the light plane normal; rays travel towards +â).
    pub axis: Vec3,
    /// Unit in-plane direction of the image's +x; +y is â × x̂.
    pub x_axis: Vec3,
    /// 1/f(0) = 1/α (1/m): where the central ray meets the axis. 0 for a collimated bundle,
    /// negative for a diverging one.
    pub kappa: f32,
    /// β/α (1/m²): 1/f(r) = κ + γr.
    pub gamma: f32,
    /// The image covers [-half_extent, half_extent]² of the light plane (m).
    pub half_extent: f32,
    /// Texels per side.
    pub size: u32,
    /// Value of the quantised level 65535: flux per m² of light plane per unit irradiance.
    pub scale: f32,
    /// Flux of the CSL per unit irradiance of the light (m²), i.e. its share of the energy.
    pub flux: f32,
    /// The image's grain relative to `scale`: the mean contribution of one traced ray to a
    /// texel ([`image::PlaneImage::grain`]) over the value of level 65535. It sets the image's
    /// sampling noise; 0 where unknown. The dynamic artifact codes the image no finer than that
    /// noise needs.
    pub grain: f32,
    /// Row-major RGB texels, row 0 at -y.
    pub texels: Vec<[u16; 3]>,
}

impl Csl {
    /// The CSL turned by the rotation `rot` about `centre` (its image unchanged).
    pub fn turned(self, centre: Vec3, rot: Mat3) -> Csl {
        Csl {
            origin: centre + rot * (self.origin - centre),
            axis: (rot * self.axis).normalize(),
            x_axis: (rot * self.x_axis).normalize(),
            ..self
        }
    }

    /// Bytes it holds in memory.
    pub fn heap_bytes(&self) -> usize {
        std::mem::size_of::<Csl>() + self.texels.len() * std::mem::size_of::<[u16; 3]>()
    }

    /// Dequantised, bilinearly interpolated image value at light-plane coordinates (x, y);
    /// None outside the image.
    pub fn intensity(&self, x: f32, y: f32) -> Option<Vec3> {
        let h = self.half_extent;
        if x.abs() > h || y.abs() > h {
            return None;
        }
        let n = self.size as i64;
        let pix = 2.0 * h / self.size as f32;
        let fx = (x + h) / pix - 0.5;
        let fy = (y + h) / pix - 0.5;
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let texel = |i: i64, j: i64| {
            let (i, j) = (i.clamp(0, n - 1), j.clamp(0, n - 1));
            let t = self.texels[(j * n + i) as usize];
            Vec3::new(t[0] as f32, t[1] as f32, t[2] as f32)
        };
        let (i, j) = (x0 as i64, y0 as i64);
        let v = texel(i, j) * ((1.0 - tx) * (1.0 - ty))
            + texel(i + 1, j) * (tx * (1.0 - ty))
            + texel(i, j + 1) * ((1.0 - tx) * ty)
            + texel(i + 1, j + 1) * (tx * ty);
        Some(v * (self.scale / 65535.0))
    }

    /// Half a texel of the intensity image (m): the radial half-width of the light-plane patch
    /// over which Eq. 4 is evaluated.
    pub fn patch(&self) -> f32 {
        self.half_extent / self.size as f32
    }

    /// The paper's α (m), infinite for a collimated CSL.
    pub fn alpha(&self) -> f32 {
        1.0 / self.kappa
    }

    /// The paper's β (1/m).
    pub fn beta(&self) -> f32 {
        self.gamma / self.kappa
    }

    pub fn y_axis(&self) -> Vec3 {
        self.axis.cross(self.x_axis)
    }

    /// Where the rays from radius `r` meet the axis, distance from the light plane (m).
    pub fn focus(&self, r: f32) -> f32 {
        1.0 / (self.kappa + self.gamma * r)
    }
}

/// Figures of one bake. Counts survive serialisation; times are zero after [`CslSet::from_bytes`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BakeStats {
    /// Grid rays traced (inside the projected bounding sphere).
    pub rays_traced: u64,
    /// Grid rays that hit the object.
    pub rays_hit: u64,
    /// Rays leaving the object.
    pub caustic_rays: u64,
    pub csls: u32,
    /// Energy leaving the object, in grid-ray units.
    pub energy_traced: f64,
    /// Energy the CSLs represent, in grid-ray units.
    pub energy_covered: f64,
    /// Energy lost to absorption, the depth limit and the energy threshold, grid-ray units.
    pub energy_dropped: f64,
    /// Bundles whose axis search or fit gave nothing usable.
    pub rejected_bundles: u32,
    /// Rays dismissed by fits (they went back to the pool).
    pub dismissed_rays: u64,
    /// Assignment/optimisation iterations, summed over CSLs.
    pub iterations: u32,
    /// What ended the bake: "coverage" (the target reached), "memory" (`max_image_bytes`),
    /// "count" (`max_csls`), "bundles" (no bundle left to extract). Empty after
    /// [`CslSet::from_bytes`].
    pub stopped_by: &'static str,
    pub time_trace: Duration,
    pub time_raster: Duration,
    pub time_bundles: Duration,
    pub time_fit: Duration,
    pub time_image: Duration,
    pub time_total: Duration,
}

impl BakeStats {
    /// Fraction of the leaving energy the CSLs cover.
    pub fn coverage(&self) -> f64 {
        if self.energy_traced > 0.0 {
            self.energy_covered / self.energy_traced
        } else {
            1.0
        }
    }
}

/// The CSLs of one object for one light direction.
#[derive(Clone, Debug, PartialEq)]
pub struct CslSet {
    /// Content hash of the inputs (object geometry and materials, scale, light, parameters):
    /// the cache key.
    pub source_hash: u64,
    pub params_hash: u64,
    /// Unit light travel direction in the object's rigid frame.
    pub light_dir: Vec3,
    /// Bounding sphere of the object in its rigid frame.
    pub centre: Vec3,
    pub radius: f32,
    /// Distance between grid rays (m).
    pub spacing: f32,
    pub csls: Vec<Csl>,
    pub stats: BakeStats,
}

impl CslSet {
    /// Bytes it holds in memory.
    pub fn heap_bytes(&self) -> usize {
        std::mem::size_of::<CslSet>() + self.csls.iter().map(Csl::heap_bytes).sum::<usize>()
    }
}

impl CslSet {
    /// A copy with every CSL moved by the rigid transform `m` (rotation + translation).
    pub fn to_world(&self, m: Mat4) -> Vec<Csl> {
        let (_, rot, _): (Vec3, Quat, Vec3) = m.to_scale_rotation_translation();
        self.csls
            .iter()
            .map(|c| Csl {
                origin: m.transform_point3(c.origin),
                axis: (rot * c.axis).normalize(),
                x_axis: (rot * c.x_axis).normalize(),
                ..c.clone()
            })
            .collect()
    }
}

/// The light's frame of a bake: `q = rot · (p − centre)` with `rot`'s rows the ray grid's
/// (u, v, light).
struct LightFrame {
    centre: Vec3,
    rot: Mat3,
}

impl LightFrame {
    fn new(centre: Vec3, u: Vec3, v: Vec3, light: Vec3) -> LightFrame {
        LightFrame {
            centre,
            rot: Mat3::from_cols(u, v, light).transpose(),
        }
    }

    /// Every ray into the frame.
    fn take_in(&self, rays: &mut [trace::CausticRay]) {
        use rayon::prelude::*;
        rays.par_chunks_mut(1 << 14).for_each(|chunk| {
            for r in chunk {
                r.origin = self.centre + self.rot * (r.origin - self.centre);
                r.dir = self.rot * r.dir;
            }
        });
    }

    /// A CSL made in the frame, back in the object's rigid frame.
    fn give_back(&self, c: Csl) -> Csl {
        c.turned(self.centre, self.rot.transpose())
    }
}

/// The object alone, scaled, at the origin: the world the bake traces.
pub fn rigid_frame_world(world: &World, object: &Object) -> World {
    let (scale, _, _) = object.transform.to_scale_rotation_translation();
    World {
        name: object.name.clone(),
        camera: world.camera.clone(),
        lights: Vec::new(),
        materials: world.materials.clone(),
        objects: vec![Object {
            name: object.name.clone(),
            parts: object.parts.clone(),
            transform: Mat4::from_scale(scale),
        }],
        warnings: Vec::new(),
        water: Vec::new(),
        media: Vec::new(),
        has_ground: false,
    }
}

/// The BVH a bake traces: over `local`, the object alone in its rigid frame
/// ([`rigid_frame_world`]).
pub fn bake_accel(local: &World) -> Accel {
    Accel::build_with(local, |_| true, obvhs::BvhBuildParams::fast_build())
}

/// Content hash of a bake's inputs (the cache key): the object's meshes, materials and scale,
/// the light direction in its rigid frame and the parameters. Same as [`CslSet::source_hash`].
pub fn csl_source_hash(
    world: &World,
    object_name: &str,
    light_dir: Vec3,
    params: &CslParams,
) -> Result<u64, BakeError> {
    let object = world
        .object(object_name)
        .ok_or_else(|| BakeError::UnknownObject(object_name.to_string()))?;
    Ok(source_hash(world, object, light_dir.normalize(), params))
}

/// Hash of everything the bake reads.
fn source_hash(world: &World, object: &Object, light: Vec3, params: &CslParams) -> u64 {
    let mut h = Fnv64::new();
    h.write(b"csl");
    h.write_u32(ALGORITHM);
    h.write(&object_hash(world, object).to_le_bytes());
    for v in light.to_array() {
        h.write_f32(v);
    }
    h.write(&params.hash().to_le_bytes());
    h.finish()
}

/// Hash of what a bake reads of an object: its scale, meshes and materials (not its rotation
/// and translation: bakes work in the object's rigid frame).
/// Remembered while the object's meshes live ([`crate::bake::memo_by_meshes`]).
pub(crate) fn object_hash(world: &World, object: &Object) -> u64 {
    let (scale, _, _) = object.transform.to_scale_rotation_translation();
    let material = |p: &crate::scene::Part| format!("{:?}", world.materials[p.material as usize]);
    // What the hash reads besides the meshes' content.
    let mut extra = Fnv64::new();
    for v in scale.to_array() {
        extra.write_f32(v);
    }
    for p in &object.parts {
        extra.write(material(p).as_bytes());
    }
    let meshes: Vec<_> = object.parts.iter().map(|p| &p.mesh).collect();
    crate::bake::memo_by_meshes(&meshes, extra.finish(), || {
        let mut h = Fnv64::new();
        for v in scale.to_array() {
            h.write_f32(v);
        }
        for p in &object.parts {
            h.write_u32(p.mesh.positions.len() as u32);
            for v in p.mesh.positions.iter().chain(&p.mesh.normals) {
                for c in v.to_array() {
                    h.write_f32(c);
                }
            }
            for t in &p.mesh.indices {
                for c in t {
                    h.write_u32(*c);
                }
            }
            h.write(material(p).as_bytes());
        }
        h.finish()
    })
}

/// The light a static CSL bake is for: the scene's first directional light, as (unit travel
/// direction, irradiance).
pub fn scene_directional_light(world: &World) -> Option<(Vec3, Vec3)> {
    world.lights.iter().find_map(|l| match l {
        crate::scene::Light::Directional {
            direction,
            irradiance,
            ..
        } => Some((*direction, *irradiance)),
        _ => None,
    })
}

/// Bake the CSL set of object `object_name` lit from unit travel direction `light_dir`
/// (in the object's rigid frame, see [`Object::to_rigid_frame`](crate::scene::Object::to_rigid_frame)). `progress` is called
/// now and then; returning false cancels the bake ([`BakeError::Canceled`]).
pub fn bake_csl(
    world: &World,
    object_name: &str,
    light_dir: Vec3,
    params: &CslParams,
    progress: &(dyn Fn(Progress) -> bool + Sync),
) -> Result<CslSet, BakeError> {
    bake_csl_with(world, object_name, light_dir, params, progress, true, None)
}

/// [`bake_csl`] for callers that run several bakes side by side (`spare_cores` false): the
/// fits then do no work on the chance that a core is idle ([`fit::fit_bundle`]'s `beside`);
/// and that bake one object for many lights: `shared` is then the BVH of the object in its
/// rigid frame ([`rigid_frame_world`], [`bake_accel`]), built once. The same set either way.
pub(crate) fn bake_csl_with(
    world: &World,
    object_name: &str,
    light_dir: Vec3,
    params: &CslParams,
    progress: &(dyn Fn(Progress) -> bool + Sync),
    spare_cores: bool,
    shared: Option<&Accel>,
) -> Result<CslSet, BakeError> {
    let t_start = Instant::now();
    params.validate()?;
    if !light_dir.is_finite() || light_dir.length() < 1e-6 {
        return Err(BakeError::InvalidLight(light_dir.to_array()));
    }
    let light = light_dir.normalize();
    let object = world
        .object(object_name)
        .ok_or_else(|| BakeError::UnknownObject(object_name.to_string()))?;
    if object.triangle_count() == 0 {
        return Err(BakeError::EmptyObject(object_name.to_string()));
    }
    if !object
        .parts
        .iter()
        .any(|p| world.materials[p.material as usize].is_specular())
    {
        return Err(BakeError::NotSpecular(object_name.to_string()));
    }
    let local = rigid_frame_world(world, object);
    let (lo, hi) = local.bounds();
    let centre = 0.5 * (lo + hi);
    let radius = local.objects[0]
        .parts
        .iter()
        .flat_map(|p| p.mesh.positions.iter())
        .map(|v| (local.objects[0].transform.transform_point3(*v) - centre).length())
        .fold(0.0f32, f32::max)
        * 1.0001;
    let built;
    let accel = match shared {
        Some(accel) => accel,
        None => {
            built = bake_accel(&local);
            &built
        }
    };

    // 1. Trace.
    let (u, v) = light.any_orthonormal_pair();
    let grid = trace::RayGrid {
        light,
        u,
        v,
        centre,
        radius,
        n: params.grid,
    };
    let t0 = Instant::now();
    let n = params.grid;
    let report = |stage, fraction| progress(Progress { stage, fraction });
    if !report("trace", 0.0) {
        return Err(BakeError::Canceled);
    }
    let (mut rays, totals) = trace::trace_grid(accel, &grid, params, &|rows| {
        report("trace", 0.5 * rows as f32 / n as f32)
    })
    .ok_or(BakeError::Canceled)?;
    // Bundles are searched in the light's frame: the ray grid's (u, v, light) about `centre`,
    // the frame in which the traced rays turn with the light. The DDA volume's cells then sit
    // where they sat for any other light direction, so a bundle search that seeds at the cell of
    // most energy finds the same bundles for a turned light (the object's own shape aside),
    // where an object-aligned volume cut the same caustic differently at every direction.
    let frame = LightFrame::new(centre, u, v, light);
    frame.take_in(&mut rays);
    let mut stats = BakeStats {
        rays_traced: (0..n)
            .flat_map(|j| (0..n).map(move |i| (i, j)))
            .filter(|&(i, j)| grid.origin(i, j).is_some())
            .count() as u64,
        rays_hit: totals.hits,
        caustic_rays: rays.len() as u64,
        energy_traced: rays.iter().map(|r| r.weight() as f64).sum(),
        energy_dropped: totals.dropped,
        time_trace: t0.elapsed(),
        ..Default::default()
    };

    // 2.–5. Bundles, fits, images until the coverage target is met.
    let t0 = Instant::now();
    let volume = bundle::Volume::new(centre, params.volume_extent * radius, params.cells);
    let mut ex = bundle::Extractor::new(&rays, volume, bundle::search_stride(params.grid));
    stats.time_raster = t0.elapsed();
    let thresholds = bundle::Thresholds {
        distance: params.distance_threshold * radius,
        cos_angle: params.angle_threshold_deg.to_radians().cos(),
        max_iterations: params.max_iterations,
    };
    let spacing = grid.spacing();
    let far = 4.0 * (hi - lo).length() as f64;
    let maker = make::Maker {
        rays: &rays,
        params,
        radius,
        far,
        spacing,
        total: stats.energy_traced,
        spare_cores,
    };
    let csls: Vec<Csl> = maker
        .cover(&mut ex, &thresholds, &mut stats, &|f| report("bundles", f))?
        .into_iter()
        .map(|c| frame.give_back(c))
        .collect();
    stats.csls = csls.len() as u32;
    stats.time_total = t_start.elapsed();
    report("done", 1.0);
    Ok(CslSet {
        source_hash: source_hash(world, object, light, params),
        params_hash: params.hash(),
        light_dir: light,
        centre,
        radius,
        spacing,
        csls,
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glass ball of radius 0.5 named `ball`, of `segments` segments.
    fn glass_ball(segments: u32) -> World {
        let json = format!(
            r#"{{"camera": {{"eye": [0, 3, 3], "target": [0, 0, 0]}},
                 "materials": {{"glass": {{"type": "dielectric", "ior": 1.5}}}},
                 "objects": [{{"name": "ball", "shape": {{"type": "sphere", "radius": 0.5,
                              "segments": {segments}}}, "material": "glass"}}]}}"#
        );
        crate::scene::load_scene_json(json.as_bytes()).expect("scene resolves")
    }

    /// A bake ends when its CSLs cover the target, not at a count; the count and the images'
    /// memory only bound it, and the set says which ended it.
    #[test]
    fn a_bake_stops_by_coverage_within_its_bounds() {
        let world = glass_ball(64);
        let light = Vec3::new(0.3, -1.0, 0.2);
        let bake = |p: CslParams| bake_csl(&world, "ball", light, &p, &|_| true).unwrap();
        let base = CslParams {
            grid: 96,
            ..CslParams::fast()
        };
        let set = bake(base);
        assert_eq!(set.stats.stopped_by, "coverage");
        assert!(set.stats.coverage() >= 0.95, "{}", set.stats.coverage());
        let few = bake(CslParams {
            max_csls: 2,
            ..base
        });
        assert_eq!((few.stats.stopped_by, few.csls.len()), ("count", 2));
        let small = bake(CslParams {
            max_image_bytes: 1 << 20,
            coverage: 1.0,
            ..base
        });
        assert_eq!(small.stats.stopped_by, "memory");
        let bytes: usize = small.csls.iter().map(|c| c.texels.len() * 8).sum();
        // The bound is checked before each new CSL: at most one image past it.
        let last = small.csls.last().map_or(0, |c| c.texels.len() * 8);
        assert!(bytes - last < 1 << 20, "{bytes}");
        assert!(
            CslParams {
                max_image_bytes: 1000,
                ..base
            }
            .validate()
            .is_err()
        );
    }

    /// A ball lit from straight above: its marginal rays leave it steeply and cross its axis
    /// close behind it (the fan, `make`'s docs). They are CSLs on the ball's axis, not
    /// bundles of a mean direction whose axes lean 60–70° off it (7.5 % of the downward flux
    /// before the fan, 1.1 % after: two faint diverging CSLs of other paths).
    #[test]
    fn a_lens_marginal_rays_are_csls_on_its_axis() {
        let world = glass_ball(96);
        let light = Vec3::new(0.0, -1.0, 0.0);
        let params = CslParams {
            grid: 512,
            ..CslParams::fast()
        };
        let set = bake_csl(&world, "ball", light, &params, &|_| true).unwrap();
        let down = |c: &&Csl| c.axis.dot(light) > 0.0;
        let flux: f32 = set.csls.iter().filter(down).map(|c| c.flux).sum();
        let leaning: f32 = set
            .csls
            .iter()
            .filter(down)
            .filter(|c| c.axis.angle_between(light) > 5f32.to_radians())
            .map(|c| c.flux)
            .sum();
        assert!(leaning < 0.02 * flux, "{leaning} of {flux}");
        // The fan's steep rays are among them: its widest CSL's rays reach 85° from the axis
        // (before the fan the on-axis CSLs reached 61°).
        let steep = set
            .csls
            .iter()
            .filter(down)
            .filter(|c| c.axis.angle_between(light) < 1f32.to_radians())
            .map(|c| {
                let r = c.half_extent;
                (r * (c.kappa + c.gamma * r)).atan().to_degrees()
            })
            .fold(0.0f32, f32::max);
        assert!(steep > 75.0, "{steep}");
    }

    /// A ball's caustic only turns with the light, so its bakes should too: the bundle search
    /// runs in the light's frame ([`LightFrame`]), where the five lights' main CSLs agree on
    /// their light plane and focus within a millimetre. In the object's frame the DDA cells cut
    /// the focus differently at each direction, and one of the five put the focus 2.9 cm
    /// further.
    #[test]
    fn a_ball_bakes_the_same_main_csl_for_neighbouring_lights() {
        let world = glass_ball(128);
        let params = CslParams {
            grid: 384,
            ..CslParams::paper()
        };
        let around = Vec3::new(-0.33, -0.79, -0.51).normalize();
        let mut rng = crate::sampling::Pcg::new(56, 1);
        let planes: Vec<(f32, f32)> = (0..5)
            .map(|_| {
                let jitter = Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5;
                let light = (around + 0.08 * jitter).normalize();
                let set = bake_csl(&world, "ball", light, &params, &|_| true).unwrap();
                let main = set
                    .csls
                    .iter()
                    .max_by(|a, b| a.flux.total_cmp(&b.flux))
                    .unwrap();
                assert!(main.axis.angle_between(light) < 1f32.to_radians());
                let depth = (main.origin - set.centre).dot(main.axis);
                (depth, 1.0 / main.kappa + depth)
            })
            .collect();
        let spread = |f: fn(&(f32, f32)) -> f32| {
            let v = planes.iter().map(f);
            v.clone().fold(f32::MIN, f32::max) - v.fold(f32::MAX, f32::min)
        };
        assert!(spread(|p| p.0) < 0.005, "light planes {planes:?}");
        assert!(spread(|p| p.1) < 0.005, "foci {planes:?}");
    }

    #[test]
    fn fits_side_by_side_or_in_turn_and_a_shared_bvh_give_the_same_set() {
        // A glass sphere lit obliquely, whose bundles need the second fit (plane before the
        // exits) as well as the first.
        let world = glass_ball(64);
        let params = CslParams {
            grid: 96,
            ..CslParams::fast()
        };
        let light = Vec3::new(0.3, -1.0, 0.2);
        let a = bake_csl_with(&world, "ball", light, &params, &|_| true, true, None).unwrap();
        let local = rigid_frame_world(&world, world.object("ball").unwrap());
        let accel = bake_accel(&local);
        let b = bake_csl_with(
            &world,
            "ball",
            light,
            &params,
            &|_| true,
            false,
            Some(&accel),
        )
        .unwrap();
        assert!(a.csls.len() > 2, "{}", a.csls.len());
        assert_eq!(a.to_bytes(), b.to_bytes());
    }
}
