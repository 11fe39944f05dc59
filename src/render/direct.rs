//! The direct pass: shadow maps for every delta light, then one forward pass writing the
//! `direct`, `specular` and `caustics` HDR layers (see `shaders/direct.wgsl` for what each
//! holds; `caustics` is non-zero only when caustic spot lights are bound, method `csl`).

use super::lights::{GpuLight, LightPlan};
use super::scene::{GpuMaterial, PackedScene, vertex_layout};
use super::{RenderError, shaders};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Stride of the per-layer shadow matrices in their dynamic uniform buffer.
const LAYER_STRIDE: u64 = 256;

/// `Globals` of `common.inc.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Globals {
    pub view_proj: [f32; 16],
    pub inv_view_proj: [f32; 16],
    pub eye: [f32; 4],
    pub env_radiance: [f32; 4],
    pub env_map_scale: [f32; 4],
    pub counts: [u32; 4],
    pub viewport: [f32; 4],
    pub sh: [[f32; 4]; 9],
    pub csl_irradiance: [f32; 4],
}

/// Pipelines and layouts of the direct pass, created once per device.
pub struct DirectPipelines {
    pub main: wgpu::RenderPipeline,
    /// `main` with the caustics layer compiled in (`CSL_LAYER`).
    pub main_csl: wgpu::RenderPipeline,
    pub background: wgpu::RenderPipeline,
    pub shadow: wgpu::RenderPipeline,
    pub main_layout: wgpu::BindGroupLayout,
    pub shadow_layout: wgpu::BindGroupLayout,
    pub shadow_sampler: wgpu::Sampler,
}

impl DirectPipelines {
    pub fn new(device: &wgpu::Device) -> DirectPipelines {
        let frag = wgpu::ShaderStages::FRAGMENT;
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let storage = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: frag,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let main_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("direct"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: vf,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: wgpu::BufferSize::new(
                            std::mem::size_of::<Globals>() as u64
                        ),
                    },
                    count: None,
                },
                storage(1),
                storage(2),
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: frag,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 4,
                    visibility: frag,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 5,
                    visibility: frag,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                // Caustic spot lights, their texels, the occluder hierarchy's nodes and
                // triangles.
                storage(6),
                storage(7),
                storage(8),
                storage(9),
            ],
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(64),
                },
                count: None,
            }],
        });
        let direct_src = shaders::source("direct.wgsl");
        let shadow_src = shaders::source("shadow.wgsl");
        let direct_mod = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("direct.wgsl"),
            source: wgpu::ShaderSource::Wgsl(direct_src.into()),
        });
        let shadow_mod = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shadow.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shadow_src.into()),
        });
        let main_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("direct"),
            bind_group_layouts: &[Some(&main_layout)],
            immediate_size: 0,
        });
        let shadow_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow"),
            bind_group_layouts: &[Some(&shadow_layout)],
            immediate_size: 0,
        });
        let hdr_target = Some(wgpu::ColorTargetState {
            format: HDR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let targets = [hdr_target.clone(), hdr_target.clone(), hdr_target];
        let primitive = wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            front_face: wgpu::FrontFace::Ccw,
            ..Default::default()
        };
        let depth = |write: bool, compare, bias| {
            Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(write),
                depth_compare: Some(compare),
                stencil: wgpu::StencilState::default(),
                bias,
            })
        };
        let main_pipeline = |label, csl: bool| {
            let constants = [("CSL_LAYER", if csl { 1.0 } else { 0.0 })];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&main_pl),
                vertex: wgpu::VertexState {
                    module: &direct_mod,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(vertex_layout())],
                },
                primitive,
                depth_stencil: depth(
                    true,
                    wgpu::CompareFunction::Less,
                    wgpu::DepthBiasState::default(),
                ),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &direct_mod,
                    entry_point: Some("fs_main"),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let main = main_pipeline("direct", false);
        let main_csl = main_pipeline("direct+csl", true);
        let background = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("background"),
            layout: Some(&main_pl),
            vertex: wgpu::VertexState {
                module: &direct_mod,
                entry_point: Some("vs_background"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive,
            depth_stencil: depth(
                false,
                wgpu::CompareFunction::LessEqual,
                wgpu::DepthBiasState::default(),
            ),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &direct_mod,
                entry_point: Some("fs_background"),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        let shadow_attr = [wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 0,
            shader_location: 0,
        }];
        let shadow = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow"),
            layout: Some(&shadow_pl),
            vertex: wgpu::VertexState {
                module: &shadow_mod,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    attributes: &shadow_attr,
                    ..vertex_layout()
                })],
            },
            primitive,
            depth_stencil: depth(
                true,
                wgpu::CompareFunction::LessEqual,
                wgpu::DepthBiasState {
                    constant: 0,
                    slope_scale: 1.5,
                    clamp: 0.0,
                },
            ),
            multisample: wgpu::MultisampleState::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow"),
            address_mode_u: wgpu::AddressMode::ClampToEdge,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        DirectPipelines {
            main,
            main_csl,
            background,
            shadow,
            main_layout,
            shadow_layout,
            shadow_sampler,
        }
    }
}

/// Textures kept between renders of the same size (and device).
pub struct Targets {
    pub width: u32,
    pub height: u32,
    pub direct: wgpu::Texture,
    pub specular: wgpu::Texture,
    pub caustics: wgpu::Texture,
    pub depth: wgpu::Texture,
}

impl Targets {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Targets {
        let tex = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        Targets {
            width,
            height,
            direct: tex("direct", HDR_FORMAT, color),
            specular: tex("specular", HDR_FORMAT, color),
            caustics: tex("caustics", HDR_FORMAT, color),
            depth: tex(
                "depth",
                DEPTH_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            ),
        }
    }
}

/// The shadow map array (`resolution`² × `layers`), grown as needed.
pub struct ShadowAtlas {
    pub resolution: u32,
    pub layers: u32,
    pub texture: wgpu::Texture,
}

impl ShadowAtlas {
    pub fn new(device: &wgpu::Device, resolution: u32, layers: u32) -> ShadowAtlas {
        // Without shadowed lights a 1×1 placeholder keeps the binding valid.
        let (res, n) = if layers == 0 {
            (1, 1)
        } else {
            (resolution, layers)
        };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("shadow maps"),
            size: wgpu::Extent3d {
                width: res,
                height: res,
                depth_or_array_layers: n,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        ShadowAtlas {
            resolution,
            layers,
            texture,
        }
    }

    pub fn fits(&self, resolution: u32, layers: u32) -> bool {
        if layers == 0 {
            return true;
        }
        self.resolution == resolution && self.layers >= layers
    }
}

/// Per-device cached resources for the environment map.
pub struct EnvTexture {
    /// Identity of the `EnvMap` it was uploaded from (Arc pointer), or 0 for the placeholder.
    pub key: usize,
    pub texture: wgpu::Texture,
}

impl EnvTexture {
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        map: Option<&crate::scene::EnvMap>,
        key: usize,
    ) -> EnvTexture {
        let (w, h, data): (u32, u32, Vec<[f32; 4]>) = match map {
            Some(m) => (
                m.width,
                m.height,
                m.texels.iter().map(|t| [t.x, t.y, t.z, 1.0]).collect(),
            ),
            None => (1, 1, vec![[1.0; 4]]),
        };
        let texture = device.create_texture_with_data(
            queue,
            &wgpu::TextureDescriptor {
                label: Some("environment"),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            bytemuck::cast_slice(&data),
        );
        EnvTexture { key, texture }
    }
}

/// Near and far planes for the camera so that the whole scene box is inside.
pub fn camera_near_far(eye: Vec3, lo: Vec3, hi: Vec3) -> (f32, f32) {
    let mut far = 0.0f32;
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        far = far.max(c.distance(eye));
    }
    let far = far * 1.05 + 1e-2;
    ((far * 1e-4).max(1e-4), far)
}

/// GPU buffers for one render.
pub struct FrameBuffers {
    pub vertices: Option<wgpu::Buffer>,
    pub indices: Option<wgpu::Buffer>,
    pub index_count: u32,
    pub globals: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    pub materials: wgpu::Buffer,
    pub layer_mats: Option<wgpu::Buffer>,
    pub csls: wgpu::Buffer,
    /// Caustic spot lights to evaluate (0: the direct-only pipeline draws).
    pub csl_count: u32,
    pub csl_texels: wgpu::Buffer,
    pub blocker_nodes: wgpu::Buffer,
    pub blocker_tris: wgpu::Buffer,
}

impl FrameBuffers {
    pub fn upload(
        device: &wgpu::Device,
        scene: &PackedScene,
        globals: &Globals,
        plan: &LightPlan,
        csl: &CslBuffers,
    ) -> FrameBuffers {
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let (vertices, indices) = if scene.indices.is_empty() {
            (None, None)
        } else {
            (
                Some(init(
                    "vertices",
                    bytemuck::cast_slice(&scene.vertices),
                    wgpu::BufferUsages::VERTEX,
                )),
                Some(init(
                    "indices",
                    bytemuck::cast_slice(&scene.indices),
                    wgpu::BufferUsages::INDEX,
                )),
            )
        };
        let mut lights = plan.lights.clone();
        if lights.is_empty() {
            lights.push(GpuLight::zeroed()); // storage bindings must not be empty
        }
        let materials: &[GpuMaterial] = &scene.materials;
        let layer_mats = if plan.layers.is_empty() {
            None
        } else {
            let mut bytes = vec![0u8; plan.layers.len() * LAYER_STRIDE as usize];
            for (i, l) in plan.layers.iter().enumerate() {
                let at = i * LAYER_STRIDE as usize;
                bytes[at..at + 64]
                    .copy_from_slice(bytemuck::bytes_of(&l.view_proj.to_cols_array()));
            }
            Some(init("shadow layers", &bytes, wgpu::BufferUsages::UNIFORM))
        };
        FrameBuffers {
            vertices,
            indices,
            index_count: scene.indices.len() as u32,
            globals: init(
                "globals",
                bytemuck::bytes_of(globals),
                wgpu::BufferUsages::UNIFORM,
            ),
            lights: init(
                "lights",
                bytemuck::cast_slice(&lights),
                wgpu::BufferUsages::STORAGE,
            ),
            materials: init(
                "materials",
                bytemuck::cast_slice(materials),
                wgpu::BufferUsages::STORAGE,
            ),
            layer_mats,
            csls: init(
                "csls",
                bytemuck::cast_slice(&csl.params),
                wgpu::BufferUsages::STORAGE,
            ),
            csl_count: globals.counts[3],
            csl_texels: init(
                "csl texels",
                bytemuck::cast_slice(&csl.texels),
                wgpu::BufferUsages::STORAGE,
            ),
            blocker_nodes: init(
                "occluder nodes",
                bytemuck::cast_slice(&csl.blockers.nodes),
                wgpu::BufferUsages::STORAGE,
            ),
            blocker_tris: init(
                "occluder triangles",
                bytemuck::cast_slice(&csl.blockers.triangles),
                wgpu::BufferUsages::STORAGE,
            ),
        }
    }
}

/// What the `caustics` layer evaluates, packed for upload: never-empty arrays (placeholders
/// when no CSL is bound; `Globals::counts[3]` says how many are real).
pub struct CslBuffers {
    pub params: Vec<super::csl::GpuCsl>,
    pub texels: Vec<u32>,
    pub blockers: super::blockers::Blockers,
}

impl CslBuffers {
    pub fn new(csls: &[crate::bake::csl::Csl], blockers: super::blockers::Blockers) -> Self {
        let (mut params, texels) = super::csl::pack(csls);
        if params.is_empty() {
            params.push(super::csl::GpuCsl::zeroed());
        }
        CslBuffers {
            params,
            texels,
            blockers,
        }
    }
}

/// The camera uniforms for an image of `width`×`height`.
pub fn globals(world: &crate::scene::World, width: u32, height: u32, plan: &LightPlan) -> Globals {
    let mut cam = world.camera.clone();
    cam.width = width;
    cam.height = height;
    let (lo, hi) = world.bounds();
    let (near, far) = camera_near_far(cam.eye, lo, hi);
    let vp = cam.proj_matrix(near, far) * cam.view_matrix();
    let (map_scale, map_w, map_h) = match &plan.env.map {
        Some((m, s)) => ([s.x, s.y, s.z, 1.0], m.width, m.height),
        None => ([0.0; 4], 1, 1),
    };
    let c = plan.env.constant;
    Globals {
        view_proj: vp.to_cols_array(),
        inv_view_proj: vp.inverse().to_cols_array(),
        eye: [cam.eye.x, cam.eye.y, cam.eye.z, 1.0],
        env_radiance: [c.x, c.y, c.z, 0.0],
        env_map_scale: map_scale,
        counts: [plan.lights.len() as u32, map_w, map_h, 0],
        viewport: [width as f32, height as f32, 0.0, 0.0],
        sh: plan.env.sh.map(|v| [v.x, v.y, v.z, 0.0]),
        csl_irradiance: [0.0; 4],
    }
}

/// Encodes the shadow passes and the main pass. `timestamps`: query set with 4 slots
/// (shadow begin/end, main begin/end) when the device has timestamp queries.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &DirectPipelines,
    bufs: &FrameBuffers,
    plan: &LightPlan,
    targets: &Targets,
    atlas: &ShadowAtlas,
    env: &EnvTexture,
    timestamps: Option<&wgpu::QuerySet>,
) -> Result<(), RenderError> {
    let n_layers = plan.layers.len();
    if let Some(layer_mats) = &bufs.layer_mats {
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow"),
            layout: &p.shadow_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: layer_mats,
                    offset: 0,
                    size: wgpu::BufferSize::new(64),
                }),
            }],
        });
        for (i, layer) in plan.layers.iter().enumerate() {
            let view = atlas.texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("shadow layer"),
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_array_layer: i as u32,
                array_layer_count: Some(1),
                ..Default::default()
            });
            let (first, last) = (i == 0, i + 1 == n_layers);
            let ts =
                timestamps
                    .filter(|_| first || last)
                    .map(|q| wgpu::RenderPassTimestampWrites {
                        query_set: q,
                        beginning_of_pass_write_index: first.then_some(0),
                        end_of_pass_write_index: last.then_some(1),
                    });
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: ts,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if let (true, Some(vb), Some(ib)) = (layer.visible, &bufs.vertices, &bufs.indices) {
                pass.set_pipeline(&p.shadow);
                pass.set_bind_group(0, &bg, &[(i as u64 * LAYER_STRIDE) as u32]);
                pass.set_vertex_buffer(0, vb.slice(..));
                pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..bufs.index_count, 0, 0..1);
            }
        }
    }

    let shadow_view = atlas.texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("shadow maps"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let env_view = env.texture.create_view(&Default::default());
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("direct"),
        layout: &p.main_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: bufs.globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: bufs.lights.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: bufs.materials.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&shadow_view),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::Sampler(&p.shadow_sampler),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: wgpu::BindingResource::TextureView(&env_view),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: bufs.csls.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: bufs.csl_texels.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 8,
                resource: bufs.blocker_nodes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 9,
                resource: bufs.blocker_tris.as_entire_binding(),
            },
        ],
    });
    let dv = targets.direct.create_view(&Default::default());
    let sv = targets.specular.create_view(&Default::default());
    let cv = targets.caustics.create_view(&Default::default());
    let depth = targets.depth.create_view(&Default::default());
    let clear = super::cleared_attachment;
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("direct"),
        color_attachments: &[clear(&dv), clear(&sv), clear(&cv)],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: timestamps.map(|q| wgpu::RenderPassTimestampWrites {
            query_set: q,
            beginning_of_pass_write_index: Some(2),
            end_of_pass_write_index: Some(3),
        }),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_bind_group(0, &bg, &[]);
    if let (Some(vb), Some(ib)) = (&bufs.vertices, &bufs.indices) {
        pass.set_pipeline(if bufs.csl_count > 0 {
            &p.main_csl
        } else {
            &p.main
        });
        pass.set_vertex_buffer(0, vb.slice(..));
        pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..bufs.index_count, 0, 0..1);
    }
    pass.set_pipeline(&p.background);
    pass.draw(0..3, 0..1);
    Ok(())
}
