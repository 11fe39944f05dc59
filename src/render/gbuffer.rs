//! The G-buffer of the receivers (`shaders/gbuffer.wgsl`): per pixel, the visible surface's
//! world position and shading normal, flagged where it is a receiver seen from its front, and its
//! geometric normal. The passes that gather caustics per pixel read it: `csl` (caustic spot
//! lights), `transport` (illumination volumes), `pinhole` (reflector samples) and the others.
//! Where the adapter's render passes take the six float4 attachments
//! ([`super::direct::GBUFFER_IN_DIRECT_BYTES`]), the direct pass writes it from its own fragments
//! (`fs_main_gbuffer`) and this pass is not drawn: one raster of the geometry instead of two.

use super::scene::{SceneBuffers, vertex_layout};
use super::shaders;

pub const GBUF_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// The G-buffer pipeline, created once per device.
pub struct GBufferPipeline {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl GBufferPipeline {
    pub fn new(device: &wgpu::Device) -> GBufferPipeline {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("gbuffer"),
            entries: &[
                super::layout_entry(
                    0,
                    wgpu::ShaderStages::VERTEX_FRAGMENT,
                    super::UNIFORM_BINDING,
                ),
                super::layout_entry(2, wgpu::ShaderStages::FRAGMENT, super::STORAGE_BINDING),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gbuffer.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("gbuffer.wgsl").into()),
        });
        let target = Some(wgpu::ColorTargetState {
            format: GBUF_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("gbuffer"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: None,
                    bind_group_layouts: &[Some(&layout)],
                    immediate_size: 0,
                }),
            ),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: super::direct::DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[target.clone(), target.clone(), target],
            }),
            multiview_mask: None,
            cache: None,
        });
        GBufferPipeline { pipeline, layout }
    }
}

/// G-buffer textures kept between frames of one size.
pub struct GBuffer {
    pub width: u32,
    pub height: u32,
    pub position: wgpu::Texture,
    pub normal: wgpu::Texture,
    pub geometric: wgpu::Texture,
    pub depth: wgpu::Texture,
}

impl GBuffer {
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> GBuffer {
        let tex =
            |label, format, usage| super::texture_2d(device, label, (width, height), format, usage);
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        GBuffer {
            width,
            height,
            position: tex("gbuffer position", GBUF_FORMAT, color),
            normal: tex("gbuffer normal", GBUF_FORMAT, color),
            geometric: tex("gbuffer geometric normal", GBUF_FORMAT, color),
            depth: tex(
                "gbuffer depth",
                super::direct::DEPTH_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            ),
        }
    }

    /// Views of the position and normal textures.
    pub fn views(&self) -> (wgpu::TextureView, wgpu::TextureView) {
        (
            self.position.create_view(&Default::default()),
            self.normal.create_view(&Default::default()),
        )
    }
}

/// Encodes the G-buffer pass of `scene`; `globals` is the frame's camera uniform.
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &GBufferPipeline,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    timestamps: Option<&mut super::timestamps::Timestamps>,
) {
    let ts = timestamps.map(|t| {
        let k = t.pass("gbuffer");
        (&*t, k)
    });
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("gbuffer"),
        layout: &p.layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: scene.materials.as_entire_binding(),
            },
        ],
    });
    let (pos_view, nrm_view) = gbuf.views();
    let geo_view = gbuf.geometric.create_view(&Default::default());
    let depth_view = gbuf.depth.create_view(&Default::default());
    let clear = super::cleared_attachment;
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("gbuffer"),
        color_attachments: &[clear(&pos_view), clear(&nrm_view), clear(&geo_view)],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: &depth_view,
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
    if let Some((vb, ib)) = scene.geometry() {
        pass.set_pipeline(&p.pipeline);
        pass.set_bind_group(0, &bg, &[]);
        pass.set_vertex_buffer(0, vb.slice(..));
        pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..scene.index_count, 0, 0..1);
    }
}
