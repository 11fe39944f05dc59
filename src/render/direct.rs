//! The direct pass (`shaders/direct.wgsl`): one forward pass over the scene after the shadow
//! pass, writing the `direct` and `specular` HDR layers and clearing `caustics` (see the shader
//! for what each holds; the caustics methods' passes write that layer afterwards), then the
//! visible environment behind everything. For a frame whose caustics pass reads a G-buffer it
//! writes that too, where the adapter allows ([`Variant::gbuffer`]).

use super::csl::GpuCsl;
use super::lights::{GpuLight, LightPlan};
use super::scene::{SceneBuffers, vertex_layout};
use super::shaders;
use super::shadow::ShadowAtlas;
use super::timestamps::Timestamps;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wgpu::util::DeviceExt;

pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

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
    /// The medium the direct light crosses (set for method `beams`; `medium_half` 0: none).
    pub medium_to_local: [f32; 16],
    pub medium_half: [f32; 4],
    pub medium_sigma_t: [f32; 4],
    /// rgb σs, w g.
    pub medium_sigma_s: [f32; 4],
    /// The environment's sky directions in the lights: the first, how many.
    pub sky: [u32; 4],
}

/// What a frame's direct pass needs compiled in (`override` constants of direct.wgsl): code
/// for an environment map, the sky's shadows, a medium, glossy receivers. llvmpipe runs every branch of a shader
/// under a mask, so code a scene never takes still costs its time in every pixel unless the
/// pipeline is made without it (measured on the glass sphere at 800 × 600: 129 ms → 84 ms).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Variant {
    pub env_map: bool,
    /// The environment's sky directions shadow its SH irradiance (`sky_visibility`).
    pub sky: bool,
    pub medium: bool,
    pub glossy: bool,
    /// The pass writes the G-buffer too (`fs_main_gbuffer`: locations 3..5), for a frame whose
    /// caustics pass reads one, instead of a G-buffer pass over the geometry again.
    pub gbuffer: bool,
}

impl Variant {
    fn index(self) -> usize {
        self.env_map as usize
            | (self.medium as usize) << 1
            | (self.glossy as usize) << 2
            | (self.gbuffer as usize) << 3
            | (self.sky as usize) << 4
    }
}

/// Bytes a sample of the direct pass's attachments takes when it writes the G-buffer too: its
/// three layers and the G-buffer's three textures, all four floats. An adapter whose limit is
/// lower draws the G-buffer in a pass of its own.
pub const GBUFFER_IN_DIRECT_BYTES: u32 = 6 * 16;

/// The main and background pipelines of one [`Variant`].
struct VariantPipelines {
    main: wgpu::RenderPipeline,
    /// `main` culling back faces.
    culled: wgpu::RenderPipeline,
    background: wgpu::RenderPipeline,
}

/// Pipelines and layouts of the direct pass: the layout, module and sampler created once per
/// device, the pipelines of each [`Variant`] on first use.
pub struct DirectPipelines {
    pub main_layout: wgpu::BindGroupLayout,
    pub shadow_sampler: wgpu::Sampler,
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    variants: [Option<VariantPipelines>; 32],
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
                // The sky directions' shadow maps (render/sky.rs).
                wgpu::BindGroupLayoutEntry {
                    binding: 10,
                    visibility: frag,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
        let direct_mod = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("direct.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("direct.wgsl").into()),
        });
        let main_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("direct"),
            bind_group_layouts: &[Some(&main_layout)],
            immediate_size: 0,
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
            main_layout,
            shadow_sampler,
            module: direct_mod,
            pipeline_layout: main_pl,
            variants: Default::default(),
        }
    }

    /// Makes the pipelines of `variant` when not made yet.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        if self.variants[variant.index()].is_some() {
            return;
        }
        let direct_mod = &self.module;
        let main_pl = &self.pipeline_layout;
        let flag = |on: bool| if on { 1.0 } else { 0.0 };
        let constants = [
            ("HAS_ENV_MAP", flag(variant.env_map)),
            ("HAS_MEDIUM", flag(variant.medium)),
            ("HAS_GLOSSY", flag(variant.glossy)),
            ("HAS_SKY", flag(variant.sky)),
        ];
        let options = || wgpu::PipelineCompilationOptions {
            constants: &constants,
            ..Default::default()
        };
        let hdr_target = Some(wgpu::ColorTargetState {
            format: HDR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        // The caustics layer is cleared by the pass (to alpha 1, as the shader used to write
        // it) and written by no fragment here: no shader output, nothing written.
        let caustics_target = Some(wgpu::ColorTargetState {
            format: HDR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::empty(),
        });
        let gbuf = |write_mask| {
            Some(wgpu::ColorTargetState {
                format: super::gbuffer::GBUF_FORMAT,
                blend: None,
                write_mask,
            })
        };
        let all = wgpu::ColorWrites::ALL;
        let none = wgpu::ColorWrites::empty();
        let targets = [hdr_target.clone(), hdr_target, caustics_target];
        // With the G-buffer: the background writes none of it (it stays cleared to 0).
        let with_gbuffer = |m| {
            [
                targets[0].clone(),
                targets[1].clone(),
                targets[2].clone(),
                gbuf(m),
                gbuf(m),
                gbuf(m),
            ]
        };
        let (main_targets, background_targets) = if variant.gbuffer {
            (with_gbuffer(all).to_vec(), with_gbuffer(none).to_vec())
        } else {
            (targets.to_vec(), targets.to_vec())
        };
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
        // The main pipeline, and the same culling back faces for closed objects seen from
        // outside (`ObjectDraw::back_faces_hidden`).
        let main_with = |label, cull_mode| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(main_pl),
                vertex: wgpu::VertexState {
                    module: direct_mod,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(vertex_layout())],
                },
                primitive: wgpu::PrimitiveState {
                    cull_mode,
                    ..primitive
                },
                depth_stencil: depth(
                    true,
                    wgpu::CompareFunction::Less,
                    wgpu::DepthBiasState::default(),
                ),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: direct_mod,
                    entry_point: Some(if variant.gbuffer {
                        "fs_main_gbuffer"
                    } else {
                        "fs_main"
                    }),
                    compilation_options: options(),
                    targets: &main_targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let main = main_with("direct", None);
        let culled = main_with("direct, back faces culled", Some(wgpu::Face::Back));
        let background = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("background"),
            layout: Some(main_pl),
            vertex: wgpu::VertexState {
                module: direct_mod,
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
                module: direct_mod,
                entry_point: Some("fs_background"),
                compilation_options: options(),
                targets: &background_targets,
            }),
            multiview_mask: None,
            cache: None,
        });
        self.variants[variant.index()] = Some(VariantPipelines {
            main,
            culled,
            background,
        });
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
        let tex =
            |label, format, usage| super::texture_2d(device, label, (width, height), format, usage);
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        Targets {
            width,
            height,
            direct: tex("direct", HDR_FORMAT, color),
            specular: tex("specular", HDR_FORMAT, color),
            // Method csl's compute passes write the layer as a storage texture.
            caustics: tex(
                "caustics",
                HDR_FORMAT,
                color | wgpu::TextureUsages::STORAGE_BINDING,
            ),
            depth: tex(
                "depth",
                DEPTH_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            ),
        }
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

/// The uniforms and storage a frame's direct pass reads besides the scene: the camera, the
/// lights, and the caustic spot lights (placeholders without them).
pub struct FrameBuffers {
    pub globals: wgpu::Buffer,
    pub lights: wgpu::Buffer,
    /// The CSLs' parameters ([`super::csl::pack_params`]; their images are kept with the
    /// device's resources).
    pub csls: wgpu::Buffer,
    /// Caustic spot lights to evaluate (0: the CSL passes do not run).
    pub csl_count: u32,
}

impl FrameBuffers {
    pub fn upload(
        device: &wgpu::Device,
        globals: &Globals,
        plan: &LightPlan,
        csls: &[GpuCsl],
    ) -> FrameBuffers {
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let mut lights = plan.lights.clone();
        if lights.is_empty() {
            lights.push(GpuLight::zeroed()); // storage bindings must not be empty
        }
        FrameBuffers {
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
            csls: init(
                "csls",
                bytemuck::cast_slice(csls),
                wgpu::BufferUsages::STORAGE,
            ),
            csl_count: globals.counts[3],
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
        // The sky's directions come last and light nothing themselves.
        counts: [(plan.lights.len() - plan.sky.len()) as u32, map_w, map_h, 0],
        viewport: [width as f32, height as f32, 0.0, 0.0],
        sh: plan.env.sh.map(|v| [v.x, v.y, v.z, 0.0]),
        csl_irradiance: [0.0; 4],
        medium_to_local: glam::Mat4::IDENTITY.to_cols_array(),
        medium_half: [0.0; 4],
        medium_sigma_t: [0.0; 4],
        medium_sigma_s: [0.0; 4],
        sky: [plan.sky.start, plan.sky.len() as u32, 0, 0],
    }
}

/// Encodes the direct pass (after the shadow pass filled `atlas`).
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &DirectPipelines,
    scene: &SceneBuffers,
    frame: &FrameBuffers,
    variant: Variant,
    targets: &Targets,
    atlas: &ShadowAtlas,
    env: &EnvTexture,
    gbuffer: Option<&super::gbuffer::GBuffer>,
    (view_proj, cull_back_faces): (glam::Mat4, bool),
    timestamps: Option<&mut Timestamps>,
) {
    let vp = p.variants[variant.index()]
        .as_ref()
        .expect("DirectPipelines::prepare made the variant");
    let shadow_view = atlas.view();
    let sky_view = atlas.sky_view();
    let env_view = env.texture.create_view(&Default::default());
    let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("direct"),
        layout: &p.main_layout,
        entries: &[
            entry(0, frame.globals.as_entire_binding()),
            entry(1, frame.lights.as_entire_binding()),
            entry(2, scene.materials.as_entire_binding()),
            entry(3, wgpu::BindingResource::TextureView(&shadow_view)),
            entry(4, wgpu::BindingResource::Sampler(&p.shadow_sampler)),
            entry(5, wgpu::BindingResource::TextureView(&env_view)),
            entry(10, wgpu::BindingResource::TextureView(&sky_view)),
        ],
    });
    let dv = targets.direct.create_view(&Default::default());
    let sv = targets.specular.create_view(&Default::default());
    let cv = targets.caustics.create_view(&Default::default());
    let depth = targets.depth.create_view(&Default::default());
    let clear = super::cleared_attachment;
    let ts = timestamps.map(|t| {
        let k = t.pass("direct");
        (&*t, k)
    });
    let gviews = gbuffer.filter(|_| variant.gbuffer).map(|g| {
        let (p, n) = g.views();
        (p, n, g.geometric.create_view(&Default::default()))
    });
    let mut attachments = vec![
        clear(&dv),
        clear(&sv),
        Some(wgpu::RenderPassColorAttachment {
            view: &cv,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                store: wgpu::StoreOp::Store,
            },
        }),
    ];
    if let Some((p, n, g)) = &gviews {
        attachments.extend([clear(p), clear(n), clear(g)]);
    }
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("direct"),
        color_attachments: &attachments,
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: ts.map(|(t, k)| t.writes(k, true, true)),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_bind_group(0, &bg, &[]);
    if let Some((vb, ib)) = scene.geometry() {
        pass.set_vertex_buffer(0, vb.slice(..));
        pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
        // Runs of objects drawn alike: closed objects the camera sees from outside without
        // their back faces (hidden behind their front faces: the same image, half the
        // triangles rasterised), the others whole.
        let mut runs: Vec<(std::ops::Range<u32>, bool)> = Vec::new();
        for d in &scene.draws {
            let cull = cull_back_faces && d.back_faces_hidden(view_proj);
            match runs.last_mut() {
                Some((r, c)) if *c == cull && r.end == d.first => r.end = d.first + d.count,
                _ => runs.push((d.first..d.first + d.count, cull)),
            }
        }
        for (range, cull) in runs {
            pass.set_pipeline(if cull { &vp.culled } else { &vp.main });
            pass.draw_indexed(range, 0, 0..1);
        }
    }
    pass.set_pipeline(&vp.background);
    pass.draw(0..3, 0..1);
}
