//! The shadow pass (`shaders/shadow.wgsl`): the depth of every object, as each delta light
//! sees it, into one layer of the shadow map array per light view ([`super::lights`] plans
//! them), and as each of the environment's sky directions sees it into a second, coarser array
//! ([`super::sky`]). The direct pass samples both with a comparison sampler.

use super::direct::DEPTH_FORMAT;
use super::lights::LightPlan;
use super::scene::{SceneBuffers, vertex_layout};
use super::shaders;
use super::timestamps::Timestamps;
use wgpu::util::DeviceExt;

/// Stride of the per-layer shadow matrices in their dynamic uniform buffer.
const LAYER_STRIDE: u64 = 256;

/// The depth-only pipeline, created once per device.
pub struct ShadowPipeline {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl ShadowPipeline {
    pub fn new(device: &wgpu::Device) -> ShadowPipeline {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shadow.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("shadow.wgsl").into()),
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let attributes = [wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x3,
            offset: 0,
            shader_location: 0,
        }];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    attributes: &attributes,
                    ..vertex_layout()
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                front_face: wgpu::FrontFace::Ccw,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::LessEqual),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState {
                    constant: 0,
                    slope_scale: 1.5,
                    clamp: 0.0,
                },
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        ShadowPipeline { pipeline, layout }
    }
}

/// The shadow map array (`resolution`² × `layers`) and the sky's
/// ([`super::lights::SKY_SHADOW_RESOLUTION`]² × `sky_layers`), kept between frames and grown as
/// needed.
pub struct ShadowAtlas {
    pub resolution: u32,
    pub layers: u32,
    pub texture: wgpu::Texture,
    pub sky_layers: u32,
    pub sky: wgpu::Texture,
    /// What the array holds: the scene generation and the layers last drawn into it. A frame
    /// whose scene and light views are the same (only the camera, the caustics or the image
    /// size changed) draws no shadow pass.
    drawn: Option<ShadowKey>,
}

/// The scene generation ([`super::scene::SceneCache`]) and every layer's matrix and
/// visibility: all that the depths in the array depend on.
#[derive(Clone, Debug, PartialEq)]
struct ShadowKey {
    generation: u64,
    layers: Vec<([f32; 16], bool)>,
}

impl ShadowKey {
    fn of(generation: u64, lights: &LightPlan) -> ShadowKey {
        ShadowKey {
            generation,
            layers: lights
                .layers
                .iter()
                .chain(&lights.sky_layers)
                .map(|l| (l.view_proj.to_cols_array(), l.visible))
                .collect(),
        }
    }
}

/// A depth array of `layers` layers of `resolution`² (a 1×1 placeholder, keeping the binding
/// valid, without layers).
fn depth_array(device: &wgpu::Device, label: &str, resolution: u32, layers: u32) -> wgpu::Texture {
    let (res, n) = if layers == 0 {
        (1, 1)
    } else {
        (resolution, layers)
    };
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
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
    })
}

fn array_view(t: &wgpu::Texture, label: &str) -> wgpu::TextureView {
    t.create_view(&wgpu::TextureViewDescriptor {
        label: Some(label),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

impl ShadowAtlas {
    pub fn new(
        device: &wgpu::Device,
        resolution: u32,
        layers: u32,
        sky_layers: u32,
    ) -> ShadowAtlas {
        ShadowAtlas {
            resolution,
            layers,
            texture: depth_array(device, "shadow maps", resolution, layers),
            sky_layers,
            sky: depth_array(
                device,
                "sky shadow maps",
                super::lights::SKY_SHADOW_RESOLUTION,
                sky_layers,
            ),
            drawn: None,
        }
    }

    /// Forgets what the array holds: the next frame draws its shadow pass whatever its key.
    pub fn invalidate(&mut self) {
        self.drawn = None;
    }

    pub fn fits(&self, resolution: u32, layers: u32, sky_layers: u32) -> bool {
        (layers == 0 || (self.resolution == resolution && self.layers >= layers))
            && self.sky_layers >= sky_layers
    }

    /// The whole array, as the direct pass samples it.
    pub fn view(&self) -> wgpu::TextureView {
        array_view(&self.texture, "shadow maps")
    }

    /// The sky's array.
    pub fn sky_view(&self) -> wgpu::TextureView {
        array_view(&self.sky, "sky shadow maps")
    }
}

/// Encodes one depth pass per layer of `lights` (none without shadowed lights); the first
/// begins and the last ends the `shadow_maps` timing. Nothing is encoded when `atlas` already
/// holds these layers of scene generation `generation` (the frame before drew them); returns
/// whether the pass was encoded. The caller submits what was encoded, or
/// [`ShadowAtlas::invalidate`]s the array.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &ShadowPipeline,
    scene: &SceneBuffers,
    generation: u64,
    lights: &LightPlan,
    atlas: &mut ShadowAtlas,
    timestamps: Option<&mut Timestamps>,
) -> bool {
    let n_layers = lights.layers.len() + lights.sky_layers.len();
    if n_layers == 0 {
        return false;
    }
    let key = ShadowKey::of(generation, lights);
    if atlas.drawn.as_ref() == Some(&key) {
        return false;
    }
    atlas.drawn = Some(key);
    let mut bytes = vec![0u8; n_layers * LAYER_STRIDE as usize];
    for (i, l) in lights.layers.iter().chain(&lights.sky_layers).enumerate() {
        let at = i * LAYER_STRIDE as usize;
        bytes[at..at + 64].copy_from_slice(bytemuck::bytes_of(&l.view_proj.to_cols_array()));
    }
    let layer_mats = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("shadow layers"),
        contents: &bytes,
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("shadow"),
        layout: &p.layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &layer_mats,
                offset: 0,
                size: wgpu::BufferSize::new(64),
            }),
        }],
    });
    let ts = timestamps.map(|t| {
        let k = t.pass("shadow_maps");
        (&*t, k)
    });
    let main = lights.layers.len();
    for (i, layer) in lights.layers.iter().chain(&lights.sky_layers).enumerate() {
        let (texture, at) = if i < main {
            (&atlas.texture, i)
        } else {
            (&atlas.sky, i - main)
        };
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("shadow layer"),
            dimension: Some(wgpu::TextureViewDimension::D2),
            base_array_layer: at as u32,
            array_layer_count: Some(1),
            ..Default::default()
        });
        let (first, last) = (i == 0, i + 1 == n_layers);
        let writes = ts
            .filter(|_| first || last)
            .map(|(t, k)| t.writes(k, first, last));
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
            timestamp_writes: writes,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if let (true, Some((vb, ib))) = (layer.visible, scene.geometry()) {
            pass.set_pipeline(&p.pipeline);
            pass.set_bind_group(0, &bg, &[(i as u64 * LAYER_STRIDE) as u32]);
            pass.set_vertex_buffer(0, vb.slice(..));
            pass.set_index_buffer(ib.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..scene.index_count, 0, 0..1);
        }
    }
    true
}
