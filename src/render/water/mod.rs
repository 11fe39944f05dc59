//! The caustics layer of method `water` (Sánchez-Crespo 2003): sunlight refracted by a
//! procedural water surface onto what lies below it, on the CPU (the GPU's passes, variants
//! `shader` and `shader_texture`, are in [`gpu`]).
//!
//! Two modes compute the irradiance E at receiver points under the water:
//! - [`Mode::Physical`] ([`physical`]): a grid of the sun's rays is refracted at the analytic
//!   surface and carried to the receivers; each grid triangle's transmitted flux (Fresnel, the
//!   surface's projected area, Beer-Lambert along the path) is spread over the triangle its
//!   corners land on, so that E is flux over area, and every triangle covering a point adds up
//!   (folds and focal lines included). Several directions over the sun's disc blur it.
//! - [`Mode::Article`] ([`article`]): the article's backward test: from the receiver point a
//!   ray towards the sun to the surface, the surface normal there, the ray refracted out into
//!   the air, and a brightness from its angle to the sun (a Gaussian "sun map"), attenuated
//!   along the path in the water. Its overall brightness is calibrated so that its mean over
//!   the floor equals the flat surface's irradiance.
//!
//! Three variants place the points where E is computed: [`Variant::Pixel`] (per pixel, at the
//! receiver each pixel sees, directly or refracted through the surface from above);
//! [`Variant::Texture`] (a light map of fixed resolution over the water's rectangle, on the
//! receivers seen from above, mipmapped and sampled per pixel); [`Variant::Vertex`] (the
//! article's first version: a coarser grid of vertices, interpolated bilinearly, normals by
//! finite differences in the article mode). [`Variant::Shader`] and [`Variant::ShaderTexture`]
//! compute it on the GPU ([`gpu`]); [`render_layer`] takes them as `Pixel` and `Texture`.

pub mod article;
pub mod gpu;
pub mod physical;
pub mod view;

use crate::cancel::{Canceled, KeepGoing, Stop};
use crate::frame::Frame;
use crate::scene::{Light, WaterBody, World};
use crate::trace::Accel;
use crate::trace::optics::{brdf, refract};
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::time::{Duration, Instant};

/// How E is computed.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Refracted grid of sun rays, irradiance from the area ratio (converges to the reference).
    Physical,
    /// The article's sun-map lookup, brightness calibrated to the mean.
    Article,
}

/// Where E is computed.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// Per pixel, at the receiver point it sees.
    Pixel,
    /// A mipmapped light map over the water's rectangle.
    Texture,
    /// A grid of vertices interpolated bilinearly (the article's per-vertex version).
    Vertex,
    /// Per pixel in a fragment shader on the GPU ([`gpu`]): the article's method evaluated
    /// per pixel, or the physical mode's refracted grid splatted into a light map read at its
    /// finest level. The CPU's [`render_layer`] takes it as `Pixel`.
    Shader,
    /// In texture space on the GPU ([`gpu`]): a mipmapped light map (the article's
    /// irradiance per texel, or the physical mode's splat) read trilinearly at the pixel's
    /// footprint. The CPU's [`render_layer`] takes it as `Texture`.
    #[value(name = "shader_texture", alias = "shader-texture")]
    ShaderTexture,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Physical => "physical",
            Mode::Article => "article",
        }
    }
}

impl Variant {
    pub fn name(self) -> &'static str {
        match self {
            Variant::Pixel => "pixel",
            Variant::Texture => "texture",
            Variant::Vertex => "vertex",
            Variant::Shader => "shader",
            Variant::ShaderTexture => "shader_texture",
        }
    }

    /// Whether the GPU computes the layer.
    pub fn on_gpu(self) -> bool {
        matches!(self, Variant::Shader | Variant::ShaderTexture)
    }
}

/// Largest `grid`, `map_resolution`, `mesh_resolution`, `sun_samples`.
pub const MAX_GRID: u32 = 2048;
pub const MAX_MAP: u32 = 2048;
/// Most receiver points of a frame (pixels × `pixel_samples`²): what bounds its memory
/// (about 80 bytes a point).
pub const MAX_POINTS: u64 = 8 << 20;
pub const MAX_SUN_SAMPLES: u32 = 64;
pub const MAX_PIXEL_SAMPLES: u32 = 8;

/// Settings of the water layer.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterParams {
    pub mode: Mode,
    pub variant: Variant,
    /// Physical: sun rays per side of each water rectangle.
    pub grid: u32,
    /// Physical: directions over the sun's disc (1 when the light has no disc).
    pub sun_samples: u32,
    /// Texture, shader, shader_texture: texels per side of the light map.
    pub map_resolution: u32,
    /// Vertex: quads per side of the receiver grid.
    pub mesh_resolution: u32,
    /// Article: the sun map's width (radians): brightness exp(−(θ/width)²) at angle θ from the
    /// sun.
    pub sun_map_width: f32,
    /// Pixel and texture variants: receiver points per pixel, `pixel_samples`² on a grid (the
    /// pixel's area average, as the reference's).
    pub pixel_samples: u32,
}

impl Default for WaterParams {
    fn default() -> Self {
        WaterParams {
            mode: Mode::Physical,
            variant: Variant::Pixel,
            grid: 512,
            sun_samples: 4,
            map_resolution: 1024,
            mesh_resolution: 128,
            sun_map_width: 4f32.to_radians(),
            pixel_samples: 3,
        }
    }
}

/// A directional light as the water sees it.
#[derive(Clone, Copy, Debug)]
pub struct Sun {
    /// Unit travel direction.
    pub dir: Vec3,
    /// W/m² facing it.
    pub irradiance: Vec3,
    /// Disc radius, radians.
    pub radius: f32,
}

/// The directional lights of `world`.
pub fn suns(world: &World) -> Vec<Sun> {
    world
        .lights
        .iter()
        .filter_map(|l| match *l {
            Light::Directional {
                direction,
                irradiance,
                angular_radius,
            } => Some(Sun {
                dir: direction,
                irradiance,
                radius: angular_radius,
            }),
            _ => None,
        })
        .collect()
}

/// A receiver point where E is wanted: position, unit geometric normal on the side light
/// arrives from, and its object.
#[derive(Clone, Copy, Debug)]
pub struct RecvPoint {
    pub pos: Vec3,
    pub normal: Vec3,
    pub object: u32,
}

/// The receivers: every object but the water surfaces (which the water layer treats
/// analytically). Kept between the frames of a sequence: only the surfaces move.
pub struct Receivers {
    pub accel: Accel,
    /// The highest point of any receiver (−∞ without receivers).
    pub top: f32,
}

/// The highest point of any receiver of `world` (every object but the water surfaces; −∞
/// without any).
pub fn receivers_top(world: &World) -> f32 {
    let keep = |i: usize| world.water_of(i as u32).is_none();
    world
        .objects
        .iter()
        .enumerate()
        .filter(|(i, _)| keep(*i))
        .flat_map(|(_, o)| {
            o.parts.iter().flat_map(move |p| {
                p.mesh
                    .positions
                    .iter()
                    .map(move |v| o.transform.transform_point3(*v).y)
            })
        })
        .fold(f32::NEG_INFINITY, f32::max)
}

impl Receivers {
    pub fn build(world: &World) -> Receivers {
        let keep = |i: usize| world.water_of(i as u32).is_none();
        Receivers {
            accel: Accel::build_with(world, keep, obvhs::BvhBuildParams::fast_build()),
            top: receivers_top(world),
        }
    }
}

/// What the water layer did.
#[derive(Clone, Debug, Default)]
pub struct WaterStats {
    /// Receiver points E was computed at.
    pub points: usize,
    /// Physical: sun rays traced, and the share of the transmitted flux that reached no point
    /// (missed every receiver, or landed on a triangle split between receivers).
    pub rays: u64,
    pub flux_transmitted: f64,
    pub flux_splatted: f64,
    /// Article: the calibration factor of the brightness.
    pub calibration: Vec<f32>,
    pub stages: Vec<(String, Duration)>,
}

/// E at `points` from every sun through `body`.
pub fn irradiance(
    world: &World,
    recv: &Receivers,
    body: &WaterBody,
    params: &WaterParams,
    points: &[RecvPoint],
    finite_differences: Option<f32>,
    stats: &mut WaterStats,
) -> Vec<Vec3> {
    irradiance_with(
        world,
        recv,
        body,
        params,
        points,
        finite_differences,
        stats,
        &|| true,
    )
    .expect("never asked to stop")
}

/// [`irradiance`] that asks `keep_going` before each sun and within its loops (per row of
/// the sun grid, per few thousand points); Err(Canceled) once it says stop.
#[allow(clippy::too_many_arguments)]
pub fn irradiance_with(
    world: &World,
    recv: &Receivers,
    body: &WaterBody,
    params: &WaterParams,
    points: &[RecvPoint],
    finite_differences: Option<f32>,
    stats: &mut WaterStats,
    keep_going: KeepGoing,
) -> Result<Vec<Vec3>, Canceled> {
    let mut e = vec![Vec3::ZERO; points.len()];
    for sun in suns(world) {
        if !keep_going() {
            return Err(Canceled);
        }
        let add = match params.mode {
            Mode::Physical => {
                physical::irradiance(recv, body, &sun, params, points, stats, keep_going)?
            }
            Mode::Article => article::irradiance(
                recv,
                body,
                &sun,
                params,
                points,
                finite_differences,
                stats,
                keep_going,
            )?,
        };
        e.iter_mut().zip(add).for_each(|(a, b)| *a += b);
    }
    Ok(e)
}

/// The sun's direction in the water under a flat surface (None when it is below the horizon).
pub fn refracted_sun(sun: &Sun, ior: f32) -> Option<Vec3> {
    if sun.dir.y >= 0.0 {
        return None;
    }
    refract(sun.dir, Vec3::Y, 1.0 / ior)
}

/// A frame's light from the water: per pixel, the radiance the receivers under water reflect
/// from the refracted sunlight, seen directly (camera under water: the `caustics` layer) or
/// through the surface (camera above: the `specular` layer, with the sunlight the body's open
/// sides let in). A path the camera sees through a specular surface is specular light, in
/// every method and in the reference.
#[derive(Clone, Debug)]
pub struct WaterLayers {
    pub caustics: Frame,
    pub specular: Frame,
}

impl WaterLayers {
    /// Both layers added.
    pub fn sum(&self) -> Frame {
        self.caustics.add(&self.specular)
    }
}

/// The water's layers of a frame ([`WaterLayers`]).
pub fn render_layer(
    world: &World,
    recv: &Receivers,
    params: &WaterParams,
    stats: &mut WaterStats,
) -> WaterLayers {
    render_layer_with(world, recv, params, stats, &|| true).expect("never asked to stop")
}

/// [`render_layer`] that asks `keep_going` as it goes (per row of sub-pixels, per row of the
/// light map and of each sun grid, per few thousand receiver points, before each water body
/// and sun); Err(Canceled) once it says stop.
pub fn render_layer_with(
    world: &World,
    recv: &Receivers,
    params: &WaterParams,
    stats: &mut WaterStats,
    keep_going: KeepGoing,
) -> Result<WaterLayers, Canceled> {
    let stop = Stop::new(keep_going);
    let keep_going = &|| stop.go();
    let cam = &world.camera;
    let t = Instant::now();
    let k = params.pixel_samples.max(1);
    let views = view::view_points(world, recv, k, keep_going)?;
    let sub_width = cam.width * k;
    // The pixel of a sub-pixel.
    let pixel = |i: usize| {
        let (x, y) = (i as u32 % sub_width / k, i as u32 / sub_width / k);
        (y * cam.width + x) as usize
    };
    let weight = 1.0 / (k * k) as f32;
    stats.stages.push(("view".into(), t.elapsed()));
    let mut caustics = Frame::new(cam.width, cam.height);
    let mut specular = Frame::new(cam.width, cam.height);
    let sun = suns(world).into_iter().next();
    for (bi, body) in world.water.iter().enumerate() {
        stop.check()?;
        let t = Instant::now();
        // The pixels that see a receiver under this water.
        let mine: Vec<usize> = (0..views.len())
            .filter(|&i| views[i].as_ref().is_some_and(|v| v.body == bi))
            .collect();
        if mine.is_empty() {
            continue;
        }
        let pts: Vec<RecvPoint> = mine
            .iter()
            .map(|&i| views[i].as_ref().expect("kept").point)
            .collect();
        let e = match params.variant {
            Variant::Pixel | Variant::Shader => {
                irradiance_with(world, recv, body, params, &pts, None, stats, keep_going)?
            }
            Variant::Texture | Variant::ShaderTexture | Variant::Vertex => {
                let vertex = params.variant == Variant::Vertex;
                let res = if vertex {
                    params.mesh_resolution + 1
                } else {
                    params.map_resolution
                };
                let map =
                    LightMap::build(world, recv, body, params, res, vertex, stats, keep_going)?;
                let mut out = map.lookup(&pts, &mine, &views, sub_width, k, !vertex);
                // Points the map does not hold (not the receiver seen from above there).
                let missing: Vec<usize> = (0..pts.len()).filter(|&k| out[k].is_none()).collect();
                if !missing.is_empty() {
                    let sub: Vec<RecvPoint> = missing.iter().map(|&k| pts[k]).collect();
                    let fd = vertex.then_some(map.texel);
                    let e =
                        irradiance_with(world, recv, body, params, &sub, fd, stats, keep_going)?;
                    for (k, v) in missing.into_iter().zip(e) {
                        out[k] = Some(v);
                    }
                }
                out.into_iter().map(|v| v.unwrap_or(Vec3::ZERO)).collect()
            }
        };
        stats.points += pts.len();
        let wi = sun
            .as_ref()
            .and_then(|s| refracted_sun(s, body.ior))
            .map_or(Vec3::Y, |d| -d);
        for (&i, e) in mine.iter().zip(e) {
            let v = views[i].as_ref().expect("kept");
            let m = &world.materials[v.material as usize];
            let mut l = v.throughput * brdf(m, v.shading, wi, v.wo) * e;
            if v.through {
                // Seen directly, the direct pass draws the light the sides let in.
                if let Some((wi, e)) = sun
                    .as_ref()
                    .and_then(|s| side_light(recv, body, s, &v.point))
                {
                    l += v.throughput * brdf(m, v.shading, wi, v.wo) * e;
                }
                specular.pixels[pixel(i)] += l * weight;
            } else {
                caustics.pixels[pixel(i)] += l * weight;
            }
        }
        stats
            .stages
            .push((format!("irradiance[{bi}]"), t.elapsed()));
    }
    stop.check()?;
    Ok(WaterLayers { caustics, specular })
}

/// The sunlight that reaches `p` (under `body`) through the body's open sides: the straight
/// ray towards the sun leaves the rectangle under the surface without crossing it, and no
/// receiver blocks it. Its direction towards the sun and the irradiance E·cosθ, through the
/// water up to the side (the reference traces the same light).
pub fn side_light(
    recv: &Receivers,
    body: &WaterBody,
    sun: &Sun,
    p: &RecvPoint,
) -> Option<(Vec3, Vec3)> {
    let l = -sun.dir;
    let c = p.normal.dot(l);
    if c <= 0.0 {
        return None;
    }
    let s = &body.surface;
    let o = p.pos + p.normal * 1e-4;
    // Where the ray leaves the body's box (longer than any way across it): through a side
    // under the surface, or else through its top, having crossed the surface.
    let reach = s.size.length() + body.depth + 2.0 * s.amplitude_bound();
    let t_out = reach * body.clip(o, o + l * reach)?.1;
    let exit = o + l * t_out;
    if exit.y >= s.height(exit.x, exit.z) || s.intersect(o, l, t_out).is_some() {
        return None;
    }
    if recv.accel.occluded(o, l, f32::INFINITY) {
        return None;
    }
    Some((
        l,
        sun.irradiance * c * (-body.absorption * t_out.max(0.0)).exp(),
    ))
}

/// E on a grid over a water's rectangle, at the receivers seen straight down from above the
/// surface: the article's texture-space light map (mipmapped) and its per-vertex mesh.
pub struct LightMap {
    res: u32,
    /// Texel (or vertex) spacing, metres (x).
    pub texel: f32,
    origin: Vec3,
    size: glam::Vec2,
    /// Mip levels, finest first: texels per side and E per texel; heights of the receiver at
    /// level 0.
    levels: Vec<(u32, Vec<Vec3>)>,
    heights: Vec<f32>,
    /// Vertex grid: samples at the grid's corners (bilinear between them); texture: at texel
    /// centres.
    corners: bool,
}

impl LightMap {
    /// The map of `body` at `res` texels (or vertices) a side; `keep_going` is asked per row
    /// of its probes and within [`irradiance_with`].
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        world: &World,
        recv: &Receivers,
        body: &WaterBody,
        params: &WaterParams,
        res: u32,
        corners: bool,
        stats: &mut WaterStats,
        keep_going: KeepGoing,
    ) -> Result<LightMap, Canceled> {
        let stop = Stop::new(keep_going);
        let s = &body.surface;
        let top = s.centre.y + s.amplitude_bound() + 1e-3;
        let at = |k: u32| -> f32 {
            if corners {
                k as f32 / (res - 1).max(1) as f32 - 0.5
            } else {
                (k as f32 + 0.5) / res as f32 - 0.5
            }
        };
        let probes: Vec<Option<RecvPoint>> = (0..res * res)
            .into_par_iter()
            .map(|k| {
                // Asked at the start of each row.
                if !stop.go_at(k as usize, res as usize) {
                    return None;
                }
                let (i, j) = (k % res, k / res);
                let o = Vec3::new(
                    s.centre.x + at(i) * s.size.x,
                    top,
                    s.centre.z + at(j) * s.size.y,
                );
                let h = recv.accel.intersect(o, -Vec3::Y, f32::INFINITY)?;
                (h.point.y < s.centre.y - s.amplitude_bound()).then_some(RecvPoint {
                    pos: h.point,
                    normal: h.geo_normal,
                    object: h.object,
                })
            })
            .collect();
        stop.checked()?;
        let live: Vec<usize> = (0..probes.len()).filter(|&k| probes[k].is_some()).collect();
        let pts: Vec<RecvPoint> = live.iter().map(|&k| probes[k].expect("live")).collect();
        // The spacing of the samples along x (of the vertices, or of the texels).
        let step = if corners {
            s.size.x / (res - 1).max(1) as f32
        } else {
            s.size.x / res.max(1) as f32
        };
        let e = irradiance_with(
            world,
            recv,
            body,
            params,
            &pts,
            corners.then_some(step),
            stats,
            &|| stop.go(),
        )?;
        let mut base = vec![Vec3::ZERO; (res * res) as usize];
        let mut heights = vec![f32::NAN; (res * res) as usize];
        for (&k, (v, p)) in live.iter().zip(e.into_iter().zip(&pts)) {
            base[k] = v;
            heights[k] = p.pos.y;
        }
        let mut levels = vec![(res, base)];
        if !corners {
            // 2×2 box mips down to one texel.
            let mut r = res;
            while r > 1 {
                let prev = &levels.last().expect("level").1;
                let n = r.div_ceil(2);
                let mut next = vec![Vec3::ZERO; (n * n) as usize];
                for j in 0..n {
                    for i in 0..n {
                        let mut sum = Vec3::ZERO;
                        let mut c = 0.0;
                        for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            let (x, y) = (2 * i + di, 2 * j + dj);
                            if x < r && y < r {
                                sum += prev[(y * r + x) as usize];
                                c += 1.0;
                            }
                        }
                        next[(j * n + i) as usize] = sum / c;
                    }
                }
                levels.push((n, next));
                r = n;
            }
        }
        Ok(LightMap {
            res,
            texel: step,
            origin: s.centre,
            size: s.size,
            levels,
            heights,
            corners,
        })
    }

    /// Continuous texel coordinates of world (x, z) at level 0.
    fn coords(&self, p: Vec3) -> (f32, f32) {
        let u = (p.x - self.origin.x) / self.size.x + 0.5;
        let v = (p.z - self.origin.z) / self.size.y + 0.5;
        if self.corners {
            (u * (self.res - 1) as f32, v * (self.res - 1) as f32)
        } else {
            (u * self.res as f32 - 0.5, v * self.res as f32 - 0.5)
        }
    }

    fn bilinear(&self, level: usize, x: f32, y: f32) -> Vec3 {
        let (r, data) = (self.levels[level].0, &self.levels[level].1);
        let fetch = |i: i64, j: i64| {
            let i = i.clamp(0, r as i64 - 1) as u32;
            let j = j.clamp(0, r as i64 - 1) as u32;
            data[(j * r + i) as usize]
        };
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (x0 as i64, y0 as i64);
        fetch(i, j) * ((1.0 - fx) * (1.0 - fy))
            + fetch(i + 1, j) * (fx * (1.0 - fy))
            + fetch(i, j + 1) * ((1.0 - fx) * fy)
            + fetch(i + 1, j + 1) * (fx * fy)
    }

    /// E at each point from the map (None where the map does not hold that receiver): mip
    /// level from the pixel's footprint in texels (the distance to the next pixel's point),
    /// trilinear between levels when `mips`.
    pub fn lookup(
        &self,
        pts: &[RecvPoint],
        pixels: &[usize],
        views: &[Option<view::ViewPoint>],
        width: u32,
        sub: u32,
        mips: bool,
    ) -> Vec<Option<Vec3>> {
        let tol = 2.0 * self.texel + 1e-3;
        pts.iter()
            .zip(pixels)
            .map(|(p, &pix)| {
                let (x, y) = self.coords(p.pos);
                let (i, j) = (x.round() as i64, y.round() as i64);
                if i < 0 || j < 0 || i >= self.res as i64 || j >= self.res as i64 {
                    return None;
                }
                let hgt = self.heights[(j as u32 * self.res + i as u32) as usize];
                if hgt.is_nan() || (hgt - p.pos.y).abs() > tol {
                    return None;
                }
                if !mips {
                    return Some(self.bilinear(0, x, y));
                }
                // The pixel's footprint: the largest distance to a neighbouring sub-pixel's
                // receiver point, times the sub-pixels per side.
                let w = width as usize;
                let mut foot = 0.0f32;
                for n in [pix + 1, pix.wrapping_sub(1), pix + w, pix.wrapping_sub(w)] {
                    if let Some(Some(v)) = views.get(n) {
                        foot = foot.max((v.point.pos - p.pos).length());
                    }
                }
                foot *= sub as f32;
                let lod = (foot / self.texel).max(1.0).log2();
                let l0 = (lod.floor() as usize).min(self.levels.len() - 1);
                let l1 = (l0 + 1).min(self.levels.len() - 1);
                let f = (lod - l0 as f32).clamp(0.0, 1.0);
                let at = |l: usize| {
                    let s = self.res as f32 / self.levels[l].0 as f32;
                    self.bilinear(l, (x + 0.5) / s - 0.5, (y + 0.5) / s - 0.5)
                };
                Some(at(l0) * (1.0 - f) + at(l1) * f)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cancel::assert_cancels;

    /// The CPU variants ask to go on inside their loops (rows of sub-pixels, of the light map
    /// and of the sun grid, runs of points, suns) and end canceled whenever told to stop:
    /// never a partial layer.
    #[test]
    fn the_cpu_variants_stop_inside_their_loops_when_asked() {
        let world = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 2.4, 2.9], "target": [0, -0.7, 0], "fov_y": 45,
                            "width": 40, "height": 30},
                 "lights": [{"type": "directional", "direction": [0.2, -1, 0.1],
                             "irradiance": 3.0, "angular_radius": 0.265}],
                 "objects": [{"name": "pool", "shape": {"type": "water", "size": [3, 3],
                   "depth": 0.8, "floor": [0.55, 0.75, 0.8], "waves": {"preset": "article"},
                   "time": 0, "resolution": 32}}]}"#,
        )
        .expect("scene resolves");
        let recv = Receivers::build(&world);
        // The least questions: 30 rows of pixels; the physical mode's 2 directions × (49 rows
        // of rays + 48 of triangles), the light map's 48 rows of probes, the vertex grid's 17.
        for (mode, variant, least) in [
            (Mode::Physical, Variant::Pixel, 30 + 2 * 97),
            (Mode::Physical, Variant::Texture, 30 + 48 + 2 * 97),
            (Mode::Article, Variant::Pixel, 30),
            (Mode::Article, Variant::Vertex, 30 + 17),
        ] {
            let params = WaterParams {
                mode,
                variant,
                grid: 48,
                sun_samples: 2,
                map_resolution: 48,
                mesh_resolution: 16,
                pixel_samples: 1,
                ..WaterParams::default()
            };
            let whole = render_layer(&world, &recv, &params, &mut WaterStats::default()).sum();
            assert!(whole.pixels.iter().any(|p| p.max_element() > 0.0));
            let asked = assert_cancels(
                least,
                |k| {
                    let f =
                        render_layer_with(&world, &recv, &params, &mut WaterStats::default(), k)?
                            .sum();
                    // Asking changes nothing.
                    assert_eq!(f.pixels, whole.pixels);
                    Ok::<_, Canceled>(f)
                },
                |_| true,
            );
            eprintln!("{mode:?} {variant:?}: asked {asked} times");
        }
    }
}
