//! Method `photons`: progressive GPU photon tracing with photon differentials. No bake, so it
//! fits any glass or mirror object and any light, and every frame of a still scene adds
//! photons to the last ones:
//!
//! 1. **Populations** (CPU, [`PhotonsLayer::build`]): one per light and specular object, its
//!    photons aimed at the object's bounding sphere and shared by the light's power towards it,
//!    as the reference's targeted populations (so its `caustics` layer, L S+ D, is the one to
//!    compare with). Environment lights get a fresh set of importance-sampled directions each
//!    frame.
//! 2. **Trace** (`shaders/photons.wgsl`, compute): every photon through the glass and mirrors of
//!    the whole scene (a BVH of every triangle with its vertex normals in storage buffers), with
//!    Fresnel, total internal reflection, Beer-Lambert absorption and the adjoint BSDF's
//!    shading-normal correction (Veach 1997), carrying ray differentials (Igehy 1999) from the
//!    spacing of neighbouring photons at the light. At the first receiver it is stored with the
//!    ellipse its differentials span there (photon differentials, Schjøth et al. 2007).
//! 3. **Splat** (`shaders/photon_splat.wgsl`, render): each stored photon drawn as a quad over
//!    the G-buffer, adding flux · f · K to the receivers inside its ellipse (an Epanechnikov
//!    kernel normalised over the ellipse). Focused photons get small kernels, spread ones large.
//! 4. **Progression** ([`gpu::run`]): frames alternate between two accumulation layers until
//!    the frame count, the time budget or the error target is reached. Frame k's kernels are
//!    k^(−1/3) of the first's (as progressive photon mapping shrinks its radius), so the blur
//!    vanishes as frames accumulate while each frame still averages several photons a pixel. The
//!    two layers are independent halves: their difference estimates the noise of the mean.

pub mod gpu;

use crate::reference::{object_sphere, power_towards};
use crate::render::blockers::Blockers;
use crate::render::lights::{KIND_DIRECTIONAL, KIND_POINT, KIND_SPOT};
use crate::scene::{EnvMap, EnvSampler, Light, Material, World};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::sync::Arc;
use std::time::Duration;

/// Most photons in one frame: 65,535 workgroups of 64.
pub const MAX_PHOTONS: u32 = 65_535 * 64;
/// Most frames of one render.
pub const MAX_FRAMES: u32 = 4096;
/// Directions drawn per frame for each environment light.
pub const ENV_DIRECTIONS: usize = 4096;
/// The smallest footprint semi-axis in pixels: in a focus, where the differentials shrink to
/// nothing, the kernel still spans the 4 × 4 points at which the splat pass averages it over a
/// pixel.
pub const MIN_AXIS_PIXELS: f32 = 1.0;
/// The largest footprint semi-axis in pixels: it bounds a splat's cost where photons spread
/// far apart (a kernel clamped there averages fewer photons: noisier, not biased).
pub const MAX_AXIS_PIXELS: f32 = 16.0;
/// Bytes of one stored photon (`PhotonRecord`).
pub const RECORD_BYTES: u64 = 64;

/// What a photons render does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonsParams {
    /// Photons per frame, 1024..=[`MAX_PHOTONS`].
    pub photons: u32,
    /// Most frames, 1..=[`MAX_FRAMES`].
    pub frames: u32,
    /// Stop after the frame that passes this much time (from the first photon frame).
    pub time_budget: Option<Duration>,
    /// Stop once the estimated noise (relative L1 between the two halves' means, halved) is
    /// at most this, checked every second frame.
    pub error_target: Option<f32>,
    /// The first frame's kernel half-size, in spacings of neighbouring photons. 0.5..=8.
    pub footprint: f32,
    pub seed: u64,
}

impl Default for PhotonsParams {
    fn default() -> Self {
        PhotonsParams {
            photons: 1 << 19,
            frames: 4,
            time_budget: None,
            error_target: None,
            footprint: 3.0,
            seed: 1,
        }
    }
}

/// `PhotonFrame` of photons.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuPhotonFrame {
    pub counts: [u32; 4],
    pub footprint: [f32; 4],
    pub eye: [f32; 4],
}

/// `Population` of photons.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuPopulation {
    pub ids: [u32; 4],
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub end: [f32; 4],
    pub intensity: [f32; 4],
    pub spot: [f32; 4],
    pub target_sphere: [f32; 4],
}

/// `TriNormals` of photons.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuTriNormals {
    pub n0: [f32; 4],
    pub n1: [f32; 4],
    pub n2: [f32; 4],
}

/// `EnvDir` of photons.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuEnvDir {
    pub dir: [f32; 4],
    pub weight: [f32; 4],
}

// A population's light kind: the direct pass's three (`render::lights`, LIGHT_* in
// common.inc.wgsl) and two more.
const KIND_LINE: u32 = 3;
const KIND_ENVIRONMENT: u32 = 4;

/// Everything a photons render needs, built once per request on the CPU.
#[derive(Debug)]
pub struct PhotonsLayer {
    pub params: PhotonsParams,
    /// The populations with their photon ranges within a frame (environment ones point at
    /// their directions through `end`).
    pub populations: Vec<GpuPopulation>,
    /// Photons a frame actually emits (the populations' sum).
    pub photons_per_frame: u32,
    /// Every triangle of the scene, and its normals in the tree's order.
    pub bvh: Blockers,
    pub normals: Vec<GpuTriNormals>,
    /// Per environment population: its light's map and the map's sampler (None: constant sky).
    env: Vec<EnvSource>,
    /// A pixel's angle (radians per metre of distance): the smallest footprint semi-axis.
    pub pixel_angle: f32,
    /// The largest footprint semi-axis (m).
    pub max_axis: f32,
}

type EnvSource = (Option<Arc<EnvMap>>, Option<EnvSampler>);

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    v.extend(w).to_array()
}

impl PhotonsLayer {
    /// The populations of `world` (one per light and glass or mirror object) and its BVH.
    pub fn build(world: &World, params: &PhotonsParams) -> PhotonsLayer {
        let specular = world.objects_with(Material::is_specular);
        let mut pops: Vec<(f32, GpuPopulation)> = Vec::new();
        let mut env = Vec::new();
        let mut max_radius = 0.0f32;
        for l in &world.lights {
            for &oi in &specular {
                let (c, r) = object_sphere(world, oi);
                max_radius = max_radius.max(r);
                let mut p = GpuPopulation::zeroed();
                p.ids[3] = oi as u32;
                p.target_sphere = v4(c, r);
                match l {
                    Light::Directional {
                        direction,
                        irradiance,
                        angular_radius,
                    } => {
                        p.ids[0] = KIND_DIRECTIONAL;
                        p.position[3] = *angular_radius;
                        p.direction = v4(*direction, 0.0);
                        p.intensity = v4(*irradiance, 0.0);
                    }
                    Light::Point {
                        position,
                        intensity,
                    } => {
                        p.ids[0] = KIND_POINT;
                        p.position = v4(*position, 0.0);
                        p.intensity = v4(*intensity, 0.0);
                    }
                    Light::Spot {
                        position,
                        direction,
                        intensity,
                        cutoff,
                        beam_width,
                    } => {
                        p.ids[0] = KIND_SPOT;
                        p.position = v4(*position, 0.0);
                        p.direction = v4(*direction, 0.0);
                        p.intensity = v4(*intensity, 0.0);
                        p.spot = [*cutoff, *beam_width, 0.0, 0.0];
                    }
                    Light::Line {
                        start,
                        end,
                        intensity,
                    } => {
                        p.ids[0] = KIND_LINE;
                        p.position = v4(*start, 0.0);
                        p.end = v4(*end, 0.0);
                        p.intensity = v4(*intensity, 0.0);
                    }
                    Light::Environment { map, radiance } => {
                        p.ids[0] = KIND_ENVIRONMENT;
                        p.intensity = v4(*radiance, 0.0);
                        let first = env.len() * ENV_DIRECTIONS;
                        p.end = [first as f32, ENV_DIRECTIONS as f32, 0.0, 0.0];
                        env.push((map.clone(), map.as_ref().and_then(|m| EnvSampler::new(m))));
                    }
                }
                pops.push((power_towards(l, c, r), p));
            }
        }
        let sum: f32 = pops.iter().map(|(w, _)| *w).sum();
        let mut populations = Vec::new();
        let mut first = 0u32;
        for (w, mut p) in pops {
            let share = if sum > 0.0 { w / sum } else { 0.0 };
            let n = (f64::from(params.photons) * f64::from(share)).round() as u32;
            if n == 0 {
                continue;
            }
            p.ids[1] = first;
            p.ids[2] = n;
            first += n;
            populations.push(p);
        }
        // Every triangle, tagged with its material, and the vertex normals in the tree's order.
        let mut tris = Vec::new();
        let mut materials = Vec::new();
        let mut normals = Vec::new();
        for (oi, o) in world.objects.iter().enumerate() {
            for part in &o.parts {
                let m = part.mesh.transformed(o.transform);
                for t in &m.indices {
                    let [a, b, c] = t.map(|i| i as usize);
                    tris.push([m.positions[a], m.positions[b], m.positions[c]]);
                    materials.push(part.material);
                    normals.push(GpuTriNormals {
                        n0: v4(m.normals[a], oi as f32),
                        n1: v4(m.normals[b], 0.0),
                        n2: v4(m.normals[c], 0.0),
                    });
                }
            }
        }
        let bvh = Blockers::from_tagged_sah(&tris, &materials);
        let normals = if bvh.source.is_empty() {
            vec![GpuTriNormals::zeroed()]
        } else {
            bvh.source.iter().map(|&i| normals[i as usize]).collect()
        };
        let cam = &world.camera;
        PhotonsLayer {
            params: *params,
            populations,
            photons_per_frame: first,
            bvh,
            normals,
            env,
            pixel_angle: 2.0 * cam.tan_half_fov() / cam.height.max(1) as f32,
            max_axis: 0.5 * max_radius.max(1e-3),
        }
    }

    /// The environment directions of frame `frame` (at least one entry, so the buffer binds).
    pub fn env_directions(&self, frame: u32) -> Vec<GpuEnvDir> {
        let mut out = Vec::with_capacity(self.env.len().max(1) * ENV_DIRECTIONS);
        for (k, (map, sampler)) in self.env.iter().enumerate() {
            let mut rng = crate::sampling::Pcg::new(
                self.params.seed ^ 0xe4f1_d1c5,
                (u64::from(frame) << 8) | k as u64,
            );
            while out.len() < (k + 1) * ENV_DIRECTIONS {
                let u = rng.vec2();
                let (from, pdf) = match sampler {
                    Some(s) => match s.sample(u.x, u.y) {
                        Some(x) => x,
                        None => continue,
                    },
                    None => (
                        crate::sampling::uniform_sphere(u),
                        1.0 / crate::sampling::SPHERE_SOLID_ANGLE,
                    ),
                };
                let look = map.as_ref().map_or(Vec3::ONE, |m| m.lookup(from));
                out.push(GpuEnvDir {
                    dir: v4(-from, 0.0),
                    weight: v4(look / pdf, 0.0),
                });
            }
        }
        if out.is_empty() {
            out.push(GpuEnvDir::zeroed());
        }
        out
    }

    /// The uniforms of frame `k` (1-based).
    pub fn frame_uniform(&self, world: &World, k: u32) -> GpuPhotonFrame {
        let seed = (self.params.seed as u32)
            .wrapping_mul(0x9e37_79b9)
            .wrapping_add(k.wrapping_mul(0x85eb_ca6b));
        GpuPhotonFrame {
            counts: [
                self.photons_per_frame,
                self.populations.len() as u32,
                seed,
                crate::reference::ReferenceParams::default().max_depth,
            ],
            footprint: [
                self.params.footprint * (k.max(1) as f32).powf(-1.0 / 3.0),
                self.pixel_angle * MIN_AXIS_PIXELS,
                self.max_axis,
                MAX_AXIS_PIXELS / MIN_AXIS_PIXELS,
            ],
            eye: v4(world.camera.eye, 0.0),
        }
    }

    /// Whether a population draws environment directions (renewed every frame).
    pub fn has_environment(&self) -> bool {
        !self.env.is_empty()
    }

    /// Bytes of the stored photons of one frame.
    pub fn record_bytes(&self) -> u64 {
        u64::from(self.photons_per_frame.max(1)) * RECORD_BYTES
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world(lights: &str) -> World {
        crate::scene::load_scene_json(
            format!(
                r#"{{"camera": {{"eye": [0, 3, 3], "target": [0, 0, 0], "width": 64, "height": 48}},
                    "lights": {lights},
                    "materials": {{"glass": {{"type": "dielectric", "ior": 1.5}},
                                   "chrome": {{"type": "mirror", "reflectance": 0.9}},
                                   "floor": {{"type": "diffuse", "albedo": 0.5}}}},
                    "objects": [
                      {{"name": "floor", "shape": {{"type": "plane", "size": [4, 4]}}, "material": "floor"}},
                      {{"name": "ball", "shape": {{"type": "sphere", "radius": 0.5, "segments": 16}},
                        "material": "glass", "transform": {{"translation": [-0.6, 0.5, 0]}}}},
                      {{"name": "ring", "shape": {{"type": "torus", "major_radius": 0.4, "minor_radius": 0.05, "segments": 16}},
                        "material": "chrome", "transform": {{"translation": [0.6, 0.1, 0]}}}}]}}"#
            )
            .as_bytes(),
        )
        .expect("scene resolves")
    }

    /// One population per light and glass or mirror object, the frame's photons shared among
    /// them, each with its own range; the tree holds every triangle with its normals.
    #[test]
    fn populations_share_the_frame_and_the_tree_holds_every_triangle() {
        let w = world(
            r#"[{"type": "directional", "direction": [0.3, -1, 0], "irradiance": 3},
                {"type": "environment", "radiance": 0.5}]"#,
        );
        let p = PhotonsParams {
            photons: 100_000,
            ..Default::default()
        };
        let layer = PhotonsLayer::build(&w, &p);
        assert_eq!(layer.populations.len(), 4);
        let sum: u32 = layer.populations.iter().map(|q| q.ids[2]).sum();
        assert_eq!(sum, layer.photons_per_frame);
        assert!(sum.abs_diff(100_000) <= 4, "{sum}");
        let mut first = 0;
        for q in &layer.populations {
            assert_eq!(q.ids[1], first);
            first += q.ids[2];
        }
        let triangles: usize = w.objects.iter().map(|o| o.triangle_count()).sum();
        let mut source = layer.bvh.source.clone();
        source.sort_unstable();
        source.dedup();
        assert_eq!(source.len(), triangles);
        assert_eq!(layer.normals.len(), layer.bvh.triangles.len());
        // The constant sky: uniform directions, each weighing 1/pdf = 4π.
        assert!(layer.has_environment());
        let dirs = layer.env_directions(3);
        assert_eq!(dirs.len(), 2 * ENV_DIRECTIONS);
        for d in &dirs {
            assert!((d.weight[0] - 4.0 * std::f32::consts::PI).abs() < 1e-4);
            assert!((Vec3::from_slice(&d.dir[..3]).length() - 1.0).abs() < 1e-4);
        }
        assert_ne!(
            dirs[0].dir,
            layer.env_directions(4)[0].dir,
            "new directions a frame"
        );
    }

    #[test]
    fn the_kernels_shrink_frame_by_frame() {
        let w = world(r#"[{"type": "point", "position": [0, 2, 0], "intensity": 5}]"#);
        let layer = PhotonsLayer::build(&w, &PhotonsParams::default());
        assert!(!layer.has_environment());
        let f1 = layer.frame_uniform(&w, 1);
        let f8 = layer.frame_uniform(&w, 8);
        assert!((f1.footprint[0] - 3.0).abs() < 1e-6);
        assert!((f8.footprint[0] - 1.5).abs() < 1e-5);
        assert_ne!(f1.counts[2], f8.counts[2], "a seed a frame");
        assert_eq!(f1.counts[3], 16);
    }
}
