//! The article's per-pixel pass on the GPU (`shaders/water.wgsl`; variant `shader`): the
//! wave function, its gradient, the backward ray to the surface, the refraction out and the
//! sun map, evaluated per pixel over the G-buffer, as the article's Cg pixel shader does, with
//! the frame's blockers (every object but the water surfaces) shadowing the ray to the
//! surface. The CPU only packs the water's
//! numbers and the calibration ([`article::calibration`]). Receivers seen from above through
//! the waves are the water's floor plane only (the article's plane intercept): no GPU ray
//! cast finds other receivers there.

use super::article;
use super::{Sun, WaterParams, refracted_sun, suns};
use crate::render::direct::{HDR_FORMAT, Targets};
use crate::render::gbuffer::GBuffer;
use crate::render::scene::{BlockerBuffers, SceneBuffers};
use crate::render::shaders;
use crate::render::timestamps::Timestamps;
use crate::scene::water::phase_at;
use crate::scene::{WaterBody, Waves, World};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

/// The `Water` uniform of `water.wgsl`.
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
}

/// What one frame of the pass needs: the uniform and the sine waves.
#[derive(Clone, Debug)]
pub struct WaterGpuLayer {
    pub uniform: GpuWater,
    /// Two per wave: (k.x, k.z, amplitude, ω), (phase, 0, 0, 0); one zero pair when none.
    pub waves: Vec<[f32; 4]>,
    /// The article's calibration of the brightness.
    pub calibration: f32,
    /// The water surfaces' objects: not among the frame's blockers (the pass meets the
    /// surface analytically).
    pub surfaces: Vec<usize>,
}

impl WaterGpuLayer {
    /// The pass's numbers for `world`'s first water body under its first directional light.
    pub fn build(world: &World, params: &WaterParams) -> Result<WaterGpuLayer, String> {
        let body = world.water.first().ok_or("the scene has no water shape")?;
        let sun = *suns(world)
            .first()
            .ok_or("the scene has no directional light")?;
        if world.water.len() > 1 || suns(world).len() > 1 {
            return Err(
                "variant shader takes one water shape and one directional light; use variant \
                 pixel"
                    .into(),
            );
        }
        Ok(Self::for_body(world, body, &sun, params))
    }

    fn for_body(world: &World, body: &WaterBody, sun: &Sun, params: &WaterParams) -> Self {
        let s = &body.surface;
        let k = article::calibration(body, sun, params.sun_map_width, None);
        let t0 = refracted_sun(sun, body.ior);
        let up = t0.map_or(Vec3::Y, |t| -t);
        let beam = t0.map_or(Vec3::ZERO, |t| article::flat_beam(sun, body.ior, t) * k);
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
        let floor_material = body
            .floor
            .and_then(|f| world.objects.get(f))
            .and_then(|o| o.parts.first())
            .map_or(u32::MAX, |p| p.material);
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
                counts: [octaves, n_waves, floor_material, 0],
                sun: [sun.dir.x, sun.dir.y, sun.dir.z, params.sun_map_width],
                beam: [beam.x, beam.y, beam.z, s.amplitude_bound()],
                up: [up.x, up.y, up.z, s.feature_length() / 16.0],
            },
            waves,
            calibration: k,
            surfaces: world.water.iter().map(|w| w.object).collect(),
        }
    }
}

/// The pass's pipeline, made once per device.
pub struct WaterPipeline {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl WaterPipeline {
    pub fn new(device: &wgpu::Device) -> WaterPipeline {
        let entry =
            |binding, ty| crate::render::layout_entry(binding, wgpu::ShaderStages::FRAGMENT, ty);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("water"),
            entries: &[
                entry(0, crate::render::UNIFORM_BINDING),
                entry(2, crate::render::STORAGE_BINDING),
                entry(8, crate::render::STORAGE_BINDING),
                entry(9, crate::render::STORAGE_BINDING),
                entry(10, crate::render::texture_binding(false)),
                entry(11, crate::render::texture_binding(false)),
                entry(20, crate::render::UNIFORM_BINDING),
                entry(21, crate::render::STORAGE_BINDING),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("water.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("water.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("water"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                // Added to the layer the direct pass cleared (alpha 0 added: stays 1).
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: Some(wgpu::BlendState {
                        color: add,
                        alpha: add,
                    }),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        WaterPipeline { pipeline, layout }
    }
}

/// The frame's buffers of the pass.
pub struct WaterBuffers {
    uniform: wgpu::Buffer,
    waves: wgpu::Buffer,
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
        }
    }
}

/// Encodes the pass: one triangle over the caustics layer, added to it.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &WaterPipeline,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    blockers: &BlockerBuffers,
    buffers: &WaterBuffers,
    targets: &Targets,
    timestamps: Option<&mut Timestamps>,
) {
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
            res(20, buffers.uniform.as_entire_binding()),
            res(21, buffers.waves.as_entire_binding()),
        ],
    });
    let cv = targets.caustics.create_view(&Default::default());
    let mut pass = crate::render::caustics_pass(enc, &cv, "water", timestamps);
    pass.set_pipeline(&p.pipeline);
    pass.set_bind_group(0, &bg, &[]);
    pass.draw(0..3, 0..1);
}
