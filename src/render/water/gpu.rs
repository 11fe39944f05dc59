//! The water's caustics on the GPU (variants `shader` and `shader_texture`):
//!
//! - `shaders/water.wgsl` lights each pixel's receiver under the water (from the G-buffer,
//!   or, seen through the waves from above, the first receiver the refracted view ray meets
//!   in the frame's blockers: every object but the water surfaces).
//! - The article's mode per pixel (`shader`) evaluates there, as the article's Cg pixel
//!   shader does, the backward ray to the surface, the refraction out and the sun map, with
//!   the blockers shadowing the ray to the surface. The CPU only packs the water's numbers
//!   and the calibration ([`article::calibration`]).
//! - Every other combination reads a light map that `shaders/water_map.wgsl` makes over the
//!   water's rectangle, parameterised along the refracted sun (a receiver point maps to where
//!   the flat surface's refracted sun ray through it enters the water, so whatever shadows it
//!   shares its texel, as in a shadow map; the pass tests that shadow with one ray):
//!   - physical mode: a compute pass refracts a grid of the sun's rays per direction over its
//!     disc at the analytic surface and follows each through the blockers to the first
//!     receiver; the grid's triangles are rasterised into the map with additive blending,
//!     each adding its flux over the area its landed corners span (the CPU's
//!     [`super::physical`] on the GPU, with texels in place of pixel points);
//!   - the article's mode in texture space: its irradiance at the receiver under each texel.
//! - The map gets 2 × 2 box mips; `shader` reads it at 3 × 3 points over the pixel's footprint,
//!   each at the level of a third of it (the pixel's area average, as the CPU's 3 × 3 points);
//!   `shader_texture` reads it once, at the level of the whole footprint (the article's
//!   texture-space variant).

use super::{
    Mode, Sun, Variant, WaterParams, article, physical, receivers_top, refracted_sun, suns,
};
use crate::render::direct::{HDR_FORMAT, Targets};
use crate::render::gbuffer::GBuffer;
use crate::render::scene::{BlockerBuffers, SceneBuffers};
use crate::render::shaders;
use crate::render::timestamps::Timestamps;
use crate::scene::water::phase_at;
use crate::scene::{WaterBody, Waves, World};
use crate::trace::optics::refract;
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};
use wgpu::util::DeviceExt;

/// The `Water` uniform of `water.inc.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuWater {
    pub centre: [f32; 4],
    pub size: [f32; 4],
    pub absorption: [f32; 4],
    pub article: [f32; 4],
    pub counts: [u32; 4],
    pub sun: [f32; 4],
    pub beam: [f32; 4],
    pub up: [f32; 4],
    pub map: [f32; 4],
    pub grid: [u32; 4],
    pub sun_e: [f32; 4],
    pub splat: [f32; 4],
}

/// Bytes of one landed ray (`Landing` of `water_map.wgsl`).
pub const LANDING_BYTES: u64 = 32;

/// What fills the light map.
#[derive(Clone, Debug, PartialEq)]
pub enum MapSource {
    /// The physical mode: a grid of `grid` quads a side, one ray per vertex and direction.
    Splat { grid: u32, dirs: Vec<[f32; 4]> },
    /// The article's irradiance per texel.
    Article,
}

/// The light map of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct MapLayer {
    /// Texels a side, and mip levels.
    pub resolution: u32,
    pub levels: u32,
    pub source: MapSource,
}

/// Texels a side of each level of a light map of `res` texels a side, finest first: each
/// level halves the last (rounding up) down to one texel.
pub fn level_sizes(res: u32) -> Vec<u32> {
    let mut sizes = vec![res.max(1)];
    while let Some(&n) = sizes.last()
        && n > 1
    {
        sizes.push(n.div_ceil(2));
    }
    sizes
}

impl MapLayer {
    /// Bytes of the map's levels (the storage buffer the lighting pass reads).
    pub fn pyramid_bytes(&self) -> u64 {
        let sizes = level_sizes(self.resolution);
        16 * sizes[..self.levels as usize]
            .iter()
            .map(|&n| u64::from(n) * u64::from(n))
            .sum::<u64>()
    }

    /// Bytes of the landed rays (the storage buffer the splat reads).
    pub fn landing_bytes(&self) -> u64 {
        match &self.source {
            MapSource::Splat { grid, dirs } => {
                LANDING_BYTES * u64::from(grid + 1).pow(2) * dirs.len() as u64
            }
            MapSource::Article => 0,
        }
    }
}

/// What one frame of the water passes needs: the uniform, the sine waves and the light map.
#[derive(Clone, Debug)]
pub struct WaterGpuLayer {
    pub uniform: GpuWater,
    /// Two per wave: (k.x, k.z, amplitude, ω), (phase, 0, 0, 0); one zero pair when none.
    pub waves: Vec<[f32; 4]>,
    /// The article's calibration of the brightness (article mode).
    pub calibration: Option<f32>,
    /// The water surfaces' objects: not among the frame's blockers (the passes meet the
    /// surface analytically).
    pub surfaces: Vec<usize>,
    /// None: the article per pixel.
    pub map: Option<MapLayer>,
}

/// The light map's margin around the water's rectangle, as a share of its longer side: room
/// for the light the waves bend out of the flat surface's refraction.
const MAP_MARGIN: f32 = 0.1;

impl WaterGpuLayer {
    /// The passes' numbers for `world`'s water body under its directional light.
    pub fn build(world: &World, params: &WaterParams) -> Result<WaterGpuLayer, String> {
        let body = world.water.first().ok_or("the scene has no water shape")?;
        let sun = *suns(world)
            .first()
            .ok_or("the scene has no directional light")?;
        if world.water.len() > 1 || suns(world).len() > 1 {
            return Err(format!(
                "variant {} takes one water shape and one directional light; use variant pixel",
                params.variant.name()
            ));
        }
        if !params.variant.on_gpu() {
            return Err(format!(
                "variant {} runs on the CPU, not in a shader",
                params.variant.name()
            ));
        }
        Ok(Self::for_body(world, body, &sun, params))
    }

    fn for_body(world: &World, body: &WaterBody, sun: &Sun, params: &WaterParams) -> Self {
        let s = &body.surface;
        let article_mode = params.mode == Mode::Article;
        let k = article_mode.then(|| article::calibration(body, sun, params.sun_map_width, None));
        let t0 = refracted_sun(sun, body.ior);
        let up = t0.map_or(Vec3::Y, |t| -t);
        let beam = match (t0, k) {
            (Some(t), Some(k)) => article::flat_beam(sun, body.ior, t) * k,
            _ => Vec3::ZERO,
        };
        let (preset, article, octaves, n_waves, waves) = match &s.waves {
            Waves::Article {
                octaves,
                amplitude,
                frequency,
                factor,
                speed,
            } => (
                0.0,
                [*amplitude, *frequency, *factor, phase_at(*speed, s.time())],
                *octaves,
                0,
                vec![[0.0; 4]; 2],
            ),
            Waves::Physical(ws) => (
                1.0,
                [0.0; 4],
                0,
                ws.len() as u32,
                ws.iter()
                    .flat_map(|w| {
                        let ph = (w.phase - phase_at(w.omega, s.time()))
                            .rem_euclid(std::f32::consts::TAU);
                        [[w.k.x, w.k.y, w.amplitude, w.omega], [ph, 0.0, 0.0, 0.0]]
                    })
                    .collect(),
            ),
        };
        // The directions over the sun's disc (the physical mode traces those above the
        // horizon, each with its share of the irradiance).
        let disc = physical::disc_directions(sun.dir, sun.radius, params.sun_samples);
        // The map: the rectangle and a margin, square texels over its longer side.
        let res = params.map_resolution.max(1);
        let side = s.size.max_element() * (1.0 + 2.0 * MAP_MARGIN);
        let corner = Vec2::new(s.centre.x, s.centre.z) - Vec2::splat(0.5 * side);
        let texel = side / res as f32;
        let map = match (params.mode, params.variant) {
            (Mode::Article, Variant::Shader) => None,
            (mode, _) => {
                let levels = level_sizes(res).len() as u32;
                let source = match mode {
                    Mode::Article => MapSource::Article,
                    Mode::Physical => {
                        let dirs = disc
                            .iter()
                            .filter(|l| l.y < 0.0)
                            .map(|l| l.extend(0.0).to_array())
                            .collect();
                        MapSource::Splat {
                            grid: params.grid.max(1),
                            dirs,
                        }
                    }
                };
                Some(MapLayer {
                    resolution: res,
                    levels,
                    source,
                })
            }
        };
        // The physical splat's constants, as the CPU's (physical::irradiance).
        let g = params.grid.max(1);
        let cell = Vec2::new(s.size.x / g as f32, s.size.y / g as f32);
        let n_dirs = disc.len() as f32;
        let blur = {
            let cos_i = -sun.dir.y;
            let cos_t = refract(sun.dir, Vec3::Y, 1.0 / body.ior).map_or(1.0, |t| -t.y);
            (sun.radius * cos_i / (body.ior * cos_t.max(1e-3))).tan() / n_dirs.sqrt()
        };
        let least = (0.25 * cell.min_element()).max(0.5 * texel);
        let shade = receivers_top(world) > s.centre.y - s.amplitude_bound();
        let sun_e = sun.irradiance / n_dirs;
        let landing_dirs = match &map {
            Some(MapLayer {
                source: MapSource::Splat { dirs, .. },
                ..
            }) => dirs.len() as u32,
            _ => 0,
        };
        let (mode_flag, levels) = match &map {
            None => (0, 1),
            Some(m) if params.variant == Variant::Shader => (1, m.levels),
            Some(m) => (2, m.levels),
        };
        WaterGpuLayer {
            uniform: GpuWater {
                centre: [s.centre.x, s.centre.y, s.centre.z, body.depth],
                size: [s.size.x, s.size.y, s.time(), body.ior],
                absorption: [
                    body.absorption.x,
                    body.absorption.y,
                    body.absorption.z,
                    preset,
                ],
                article,
                counts: [octaves, n_waves, levels, mode_flag],
                sun: [sun.dir.x, sun.dir.y, sun.dir.z, params.sun_map_width],
                beam: [beam.x, beam.y, beam.z, s.amplitude_bound()],
                up: [up.x, up.y, up.z, s.feature_length() / 16.0],
                map: [corner.x, corner.y, side, side],
                grid: [g, landing_dirs, u32::from(shade), res],
                sun_e: [sun_e.x, sun_e.y, sun_e.z, n_dirs],
                splat: [
                    blur,
                    least,
                    0.5 * cell.max_element() + 1e-4,
                    0.5 * cell.x * cell.y,
                ],
            },
            waves,
            calibration: k,
            surfaces: world.water.iter().map(|w| w.object).collect(),
            map,
        }
    }
}

/// The light map's texel format (added to by blending: FLOAT32_BLENDABLE, which every frame
/// with caustics needs already).
const MAP_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// The passes' pipelines, made once per device.
pub struct WaterPipeline {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    land: wgpu::ComputePipeline,
    land_layout: wgpu::BindGroupLayout,
    splat: wgpu::RenderPipeline,
    splat_layout: wgpu::BindGroupLayout,
    article_map: wgpu::RenderPipeline,
    article_layout: wgpu::BindGroupLayout,
    mip0: wgpu::ComputePipeline,
    mip: wgpu::ComputePipeline,
    mip_layout: wgpu::BindGroupLayout,
}

/// The first water body as the direct pass's medium: its box (the rectangle, from the bottom
/// up to the mean surface) absorbing at its rate. The direct pass attenuates the light on its
/// way through it to a receiver (the sunlight the open sides let in, a lamp under the water)
/// and, with `half[3]` = 1, the way from a receiver it sees in it back to the camera. None
/// without water, or where it does not absorb.
pub struct DirectMedium {
    pub to_local: [f32; 16],
    pub half: [f32; 4],
    pub sigma_t: [f32; 4],
}

impl DirectMedium {
    pub fn of(world: &World) -> Option<DirectMedium> {
        let b = world.water.iter().find(|b| b.absorption != Vec3::ZERO)?;
        let s = &b.surface;
        let centre = s.centre - Vec3::Y * (0.5 * b.depth);
        let a = b.absorption;
        Some(DirectMedium {
            to_local: glam::Mat4::from_translation(-centre).to_cols_array(),
            half: [0.5 * s.size.x, 0.5 * b.depth, 0.5 * s.size.y, 1.0],
            sigma_t: [a.x, a.y, a.z, 0.0],
        })
    }
}

/// A storage buffer a compute pass writes.
const WRITE_BINDING: wgpu::BindingType = wgpu::BindingType::Buffer {
    ty: wgpu::BufferBindingType::Storage { read_only: false },
    has_dynamic_offset: false,
    min_binding_size: None,
};

const ADD: wgpu::BlendComponent = wgpu::BlendComponent {
    src_factor: wgpu::BlendFactor::One,
    dst_factor: wgpu::BlendFactor::One,
    operation: wgpu::BlendOperation::Add,
};

/// A render pipeline of `module` drawing to `targets` targets of `format`, optionally adding
/// to them.
fn render_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    (vs, fs): (&str, &str),
    (format, targets): (wgpu::TextureFormat, usize),
    add: bool,
) -> wgpu::RenderPipeline {
    let target = Some(wgpu::ColorTargetState {
        format,
        blend: add.then_some(wgpu::BlendState {
            color: ADD,
            alpha: ADD,
        }),
        write_mask: wgpu::ColorWrites::ALL,
    });
    let targets = vec![target; targets];
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(fs),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vs),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl WaterPipeline {
    pub fn new(device: &wgpu::Device) -> WaterPipeline {
        use crate::render::{STORAGE_BINDING, UNIFORM_BINDING, layout_entry, texture_binding};
        use wgpu::ShaderStages as S;
        let layout_of = |label, entries: &[wgpu::BindGroupLayoutEntry]| {
            device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            })
        };
        let module_of = |name: &'static str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(shaders::source(name).into()),
            })
        };
        let f = S::FRAGMENT;
        let layout = layout_of(
            "water",
            &[
                layout_entry(0, f, UNIFORM_BINDING),
                layout_entry(2, f, STORAGE_BINDING),
                layout_entry(8, f, STORAGE_BINDING),
                layout_entry(9, f, STORAGE_BINDING),
                layout_entry(10, f, texture_binding(false)),
                layout_entry(11, f, texture_binding(false)),
                layout_entry(12, f, STORAGE_BINDING),
                layout_entry(20, f, UNIFORM_BINDING),
                layout_entry(21, f, STORAGE_BINDING),
            ],
        );
        let module = module_of("water.wgsl");
        // Added to the caustics layer and to the specular layer the direct pass drew (alpha 0
        // added: stays 1).
        let pipeline = render_pipeline(
            device,
            &module,
            &layout,
            ("vs_main", "fs_main"),
            (HDR_FORMAT, 2),
            true,
        );
        let map_module = module_of("water_map.wgsl");
        let c = S::COMPUTE;
        let land_layout = layout_of(
            "water land",
            &[
                layout_entry(8, c, STORAGE_BINDING),
                layout_entry(9, c, STORAGE_BINDING),
                layout_entry(20, c, UNIFORM_BINDING),
                layout_entry(21, c, STORAGE_BINDING),
                layout_entry(22, c, WRITE_BINDING),
                layout_entry(24, c, STORAGE_BINDING),
            ],
        );
        let compute = |layout: &wgpu::BindGroupLayout, entry: &'static str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(
                    &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: None,
                        bind_group_layouts: &[Some(layout)],
                        immediate_size: 0,
                    }),
                ),
                module: &map_module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let land = compute(&land_layout, "land");
        let v = S::VERTEX;
        let splat_layout = layout_of(
            "water splat",
            &[
                layout_entry(20, v, UNIFORM_BINDING),
                layout_entry(23, v, STORAGE_BINDING),
            ],
        );
        let splat = render_pipeline(
            device,
            &map_module,
            &splat_layout,
            ("vs_splat", "fs_splat"),
            (MAP_FORMAT, 1),
            true,
        );
        let article_layout = layout_of(
            "water article map",
            &[
                layout_entry(8, f, STORAGE_BINDING),
                layout_entry(9, f, STORAGE_BINDING),
                layout_entry(20, f, UNIFORM_BINDING),
                layout_entry(21, f, STORAGE_BINDING),
            ],
        );
        let article_map = render_pipeline(
            device,
            &map_module,
            &article_layout,
            ("vs_full", "fs_article_map"),
            (MAP_FORMAT, 1),
            false,
        );
        let mip_layout = layout_of(
            "water mips",
            &[
                layout_entry(25, c, texture_binding(false)),
                layout_entry(26, c, WRITE_BINDING),
                layout_entry(27, c, UNIFORM_BINDING),
            ],
        );
        let mip0 = compute(&mip_layout, "mip0");
        let mip = compute(&mip_layout, "mip");
        WaterPipeline {
            pipeline,
            layout,
            land,
            land_layout,
            splat,
            splat_layout,
            article_map,
            article_layout,
            mip0,
            mip,
            mip_layout,
        }
    }
}

/// The frame's buffers and light map.
pub struct WaterBuffers {
    uniform: wgpu::Buffer,
    waves: wgpu::Buffer,
    /// The landed rays and the sun's directions (physical mode).
    landings: Option<(wgpu::Buffer, wgpu::Buffer)>,
    /// The light map's finest level as rendered (1 × 1 without a map), its levels in a
    /// storage buffer (one placeholder texel without a map), and each level's `level` uniform
    /// of `water_map.wgsl`.
    map: wgpu::Texture,
    pyramid: wgpu::Buffer,
    levels: Vec<wgpu::Buffer>,
}

impl WaterBuffers {
    pub fn upload(device: &wgpu::Device, layer: &WaterGpuLayer) -> WaterBuffers {
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let landings = layer.map.as_ref().and_then(|m| match &m.source {
            MapSource::Splat { dirs, .. } if !dirs.is_empty() => Some((
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("water landings"),
                    size: m.landing_bytes(),
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                }),
                init(
                    "water sun directions",
                    bytemuck::cast_slice(dirs),
                    wgpu::BufferUsages::STORAGE,
                ),
            )),
            _ => None,
        });
        let (res, levels) = layer
            .map
            .as_ref()
            .map_or((1, 1), |m| (m.resolution, m.levels));
        let map = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("water light map"),
            size: wgpu::Extent3d {
                width: res,
                height: res,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: MAP_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let pyramid = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("water light map levels"),
            size: layer.map.as_ref().map_or(16, MapLayer::pyramid_bytes),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        // (first texel, side, the finer level's first texel, its side) of each level.
        let sizes = level_sizes(res);
        let mut first = 0u32;
        let mut levels_u = Vec::new();
        for k in 0..levels as usize {
            let finer = if k == 0 {
                [0, 0]
            } else {
                [first - sizes[k - 1] * sizes[k - 1], sizes[k - 1]]
            };
            levels_u.push(init(
                "water light map level",
                bytemuck::cast_slice(&[first, sizes[k], finer[0], finer[1]]),
                wgpu::BufferUsages::UNIFORM,
            ));
            first += sizes[k] * sizes[k];
        }
        WaterBuffers {
            uniform: init(
                "water",
                bytemuck::bytes_of(&layer.uniform),
                wgpu::BufferUsages::UNIFORM,
            ),
            waves: init(
                "water waves",
                bytemuck::cast_slice(&layer.waves),
                wgpu::BufferUsages::STORAGE,
            ),
            landings,
            map,
            pyramid,
            levels: levels_u,
        }
    }
}

/// A render pass over `view`, cleared first, timed as the begin of pass `k` when given.
fn map_pass<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    view: &wgpu::TextureView,
    label: &'static str,
    ts: Option<(&Timestamps, u32)>,
) -> wgpu::RenderPass<'e> {
    enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[crate::render::cleared_attachment(view)],
        depth_stencil_attachment: None,
        timestamp_writes: ts.map(|(t, k)| t.writes(k, true, false)),
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// Encodes the light map (its landing rays, splat or article texels, and its levels), timed
/// as `water_map`.
fn encode_map(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &WaterPipeline,
    layer: &WaterGpuLayer,
    blockers: &BlockerBuffers,
    buffers: &WaterBuffers,
    mut timestamps: Option<&mut Timestamps>,
) {
    let Some(m) = &layer.map else {
        return;
    };
    let k = timestamps.as_deref_mut().map(|t| t.pass("water_map"));
    let ts = timestamps.as_deref().zip(k);
    let res = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let base = buffers.map.create_view(&Default::default());
    match (&m.source, &buffers.landings) {
        (MapSource::Splat { grid, dirs }, Some((landings, sun_dirs))) => {
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("water land"),
                layout: &p.land_layout,
                entries: &[
                    res(8, blockers.nodes.as_entire_binding()),
                    res(9, blockers.triangles.as_entire_binding()),
                    res(20, buffers.uniform.as_entire_binding()),
                    res(21, buffers.waves.as_entire_binding()),
                    res(22, landings.as_entire_binding()),
                    res(24, sun_dirs.as_entire_binding()),
                ],
            });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("water land"),
                    timestamp_writes: ts.map(|(t, k)| t.compute_writes(k, true, false)),
                });
                pass.set_pipeline(&p.land);
                pass.set_bind_group(0, &bg, &[]);
                let n = (grid + 1).div_ceil(8);
                pass.dispatch_workgroups(n, n, dirs.len() as u32);
            }
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("water splat"),
                layout: &p.splat_layout,
                entries: &[
                    res(20, buffers.uniform.as_entire_binding()),
                    res(23, landings.as_entire_binding()),
                ],
            });
            let mut pass = map_pass(enc, &base, "water splat", None);
            pass.set_pipeline(&p.splat);
            pass.set_bind_group(0, &bg, &[]);
            pass.draw(0..6 * grid * grid, 0..dirs.len() as u32);
        }
        _ => {
            // The article's texels, or a splat without a direction above the horizon (an
            // empty map).
            let article = m.source == MapSource::Article;
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("water article map"),
                layout: &p.article_layout,
                entries: &[
                    res(8, blockers.nodes.as_entire_binding()),
                    res(9, blockers.triangles.as_entire_binding()),
                    res(20, buffers.uniform.as_entire_binding()),
                    res(21, buffers.waves.as_entire_binding()),
                ],
            });
            let mut pass = map_pass(enc, &base, "water article map", ts);
            if article {
                pass.set_pipeline(&p.article_map);
                pass.set_bind_group(0, &bg, &[]);
                pass.draw(0..3, 0..1);
            }
        }
    }
    let finest = buffers.map.create_view(&Default::default());
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("water mips"),
        timestamp_writes: ts.map(|(t, k)| t.compute_writes(k, false, true)),
    });
    let sizes = level_sizes(m.resolution);
    for (k, uniform) in buffers.levels.iter().enumerate() {
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("water mips"),
            layout: &p.mip_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 25,
                    resource: wgpu::BindingResource::TextureView(&finest),
                },
                res(26, buffers.pyramid.as_entire_binding()),
                res(27, uniform.as_entire_binding()),
            ],
        });
        pass.set_pipeline(if k == 0 { &p.mip0 } else { &p.mip });
        pass.set_bind_group(0, &bg, &[]);
        let n = sizes[k].div_ceil(8);
        pass.dispatch_workgroups(n, n, 1);
    }
}

/// Encodes the frame's water passes: the light map where there is one, then one triangle over
/// the caustics layer, added to it.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &WaterPipeline,
    layer: &WaterGpuLayer,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    blockers: &BlockerBuffers,
    buffers: &WaterBuffers,
    targets: &Targets,
    mut timestamps: Option<&mut Timestamps>,
) {
    encode_map(
        device,
        enc,
        p,
        layer,
        blockers,
        buffers,
        timestamps.as_deref_mut(),
    );
    let (pos_view, nrm_view) = gbuf.views();
    let res = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("water"),
        layout: &p.layout,
        entries: &[
            res(0, globals.as_entire_binding()),
            res(2, scene.materials.as_entire_binding()),
            res(8, blockers.nodes.as_entire_binding()),
            res(9, blockers.triangles.as_entire_binding()),
            res(10, wgpu::BindingResource::TextureView(&pos_view)),
            res(11, wgpu::BindingResource::TextureView(&nrm_view)),
            res(12, buffers.pyramid.as_entire_binding()),
            res(20, buffers.uniform.as_entire_binding()),
            res(21, buffers.waves.as_entire_binding()),
        ],
    });
    let cv = targets.caustics.create_view(&Default::default());
    let sv = targets.specular.create_view(&Default::default());
    let mut pass = crate::render::caustics_pass_to(enc, &[&cv, &sv], "water", timestamps);
    pass.set_pipeline(&p.pipeline);
    pass.set_bind_group(0, &bg, &[]);
    pass.draw(0..3, 0..1);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_levels_halve_rounding_up_down_to_one_texel() {
        assert_eq!(
            level_sizes(1000),
            [1000, 500, 250, 125, 63, 32, 16, 8, 4, 2, 1]
        );
        assert_eq!(level_sizes(1024).len(), 11);
        assert_eq!(level_sizes(1), [1]);
        let m = MapLayer {
            resolution: 4,
            levels: 3,
            source: MapSource::Article,
        };
        assert_eq!(m.pyramid_bytes(), 16 * (16 + 4 + 1));
        assert_eq!(m.landing_bytes(), 0);
        let splat = MapLayer {
            levels: 1,
            source: MapSource::Splat {
                grid: 3,
                dirs: vec![[0.0, -1.0, 0.0, 0.0]; 2],
            },
            ..m
        };
        assert_eq!(splat.pyramid_bytes(), 16 * 16);
        assert_eq!(splat.landing_bytes(), LANDING_BYTES * 16 * 2);
    }
}
