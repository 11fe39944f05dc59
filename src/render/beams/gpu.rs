//! The beams passes on the GPU. With a medium, first the fog the lights light directly,
//! ray-marched over the shadow maps (`shaders/fog.wgsl`, the `volume` layer), and the fog's
//! transmittance over the direct and specular layers. Then `shaders/beams.wgsl`: one instanced
//! draw of every beam over the G-buffer of the receivers, blending the in-scattered radiance
//! into the volume-caustics layer and the surface caustics into the caustics layer; or,
//! downsampled, that volume at a fraction of the resolution, upsampled with depth-aware
//! weights, and the surface caustics at full resolution.

use super::super::direct::{HDR_FORMAT, Targets};
use super::super::gbuffer::GBuffer;
use super::super::scene::SceneBuffers;
use super::super::shaders;
use super::super::timestamps::Timestamps;
use super::super::transport::HULL_VERTICES;
use super::{BeamsLayer, GpuBeam, MAX_AREA_RATIO};
use bytemuck::{Pod, Zeroable};
use wgpu::BindingResource::{Sampler, TextureView};
use wgpu::util::DeviceExt;

/// `Params` of beams.wgsl (the medium is the frame's `Globals`', see `render::plan`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuBeamsParams {
    /// Samples per beam, flags (1: shadows), downsampling, beams.
    pub counts: [u32; 4],
    /// The largest area ratio.
    pub misc: [f32; 4],
}

impl GpuBeamsParams {
    pub fn new(layer: &BeamsLayer) -> GpuBeamsParams {
        let p = &layer.params;
        GpuBeamsParams {
            counts: [
                p.samples.max(1),
                u32::from(p.shadows),
                p.downsample.max(1),
                layer.beams.len() as u32,
            ],
            misc: [MAX_AREA_RATIO, 0.0, 0.0, 0.0],
        }
    }
}

/// The low-resolution target's size for a `size` frame downsampled `ds` times.
fn low_size((w, h): (u32, u32), ds: u32) -> (u32, u32) {
    (w.div_ceil(ds).max(1), h.div_ceil(ds).max(1))
}

/// Pipelines and targets, made once per device (the targets per frame size).
pub struct BeamsPipeline {
    layout: wgpu::BindGroupLayout,
    up_layout: wgpu::BindGroupLayout,
    both: wgpu::RenderPipeline,
    volume: wgpu::RenderPipeline,
    surface: wgpu::RenderPipeline,
    upsample: wgpu::RenderPipeline,
    /// Multiplies the direct and specular layers by the fog's transmittance.
    fog: wgpu::RenderPipeline,
    /// The fog lit directly by the lights (`shaders/fog.wgsl`), and its layout.
    inscatter: wgpu::RenderPipeline,
    inscatter_layout: wgpu::BindGroupLayout,
    /// The volume layer at full resolution, and the low-resolution one.
    targets: Option<BeamTargets>,
}

struct BeamTargets {
    size: (u32, u32),
    ds: u32,
    volume: wgpu::Texture,
    /// The `volume` component (the fog lit directly).
    inscatter: wgpu::Texture,
    low: Option<wgpu::Texture>,
}

impl BeamsPipeline {
    pub fn new(device: &wgpu::Device) -> BeamsPipeline {
        use super::super::{STORAGE_BINDING, UNIFORM_BINDING, layout_entry, texture_binding};
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frag = wgpu::ShaderStages::FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("beams"),
            entries: &[
                layout_entry(0, vf, UNIFORM_BINDING),
                layout_entry(1, vf, UNIFORM_BINDING),
                layout_entry(2, frag, STORAGE_BINDING),
                layout_entry(3, vf, STORAGE_BINDING),
                layout_entry(4, frag, texture_binding(false)),
                layout_entry(5, frag, texture_binding(false)),
            ],
        });
        let up_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("beams upsample"),
            entries: &[
                layout_entry(0, vf, UNIFORM_BINDING),
                layout_entry(1, vf, UNIFORM_BINDING),
                layout_entry(4, frag, texture_binding(false)),
                layout_entry(5, frag, texture_binding(false)),
                layout_entry(6, frag, texture_binding(false)),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("beams.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("beams.wgsl").into()),
        });
        let add = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
        };
        let target = |blend| {
            Some(wgpu::ColorTargetState {
                format: HDR_FORMAT,
                blend,
                write_mask: wgpu::ColorWrites::ALL,
            })
        };
        let make = |module: &wgpu::ShaderModule,
                    label: &str,
                    layout: &wgpu::BindGroupLayout,
                    vs: &str,
                    fs: &str,
                    targets: &[Option<wgpu::ColorTargetState>]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(
                    &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                        label: None,
                        bind_group_layouts: &[Some(layout)],
                        immediate_size: 0,
                    }),
                ),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let inscatter_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fog in-scattering"),
            entries: &[
                layout_entry(0, vf, UNIFORM_BINDING),
                layout_entry(1, frag, STORAGE_BINDING),
                layout_entry(
                    3,
                    frag,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                ),
                layout_entry(
                    4,
                    frag,
                    wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                ),
                layout_entry(11, frag, texture_binding(false)),
                layout_entry(12, frag, texture_binding(false)),
            ],
        });
        let fog_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("fog.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("fog.wgsl").into()),
        });
        let inscatter = make(
            &fog_module,
            "fog in-scattering",
            &inscatter_layout,
            "vs_full",
            "fs_inscatter",
            &[target(None)],
        );
        let multiply = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::Src,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
        };
        BeamsPipeline {
            inscatter,
            inscatter_layout,
            fog: make(
                &module,
                "beams fog",
                &layout,
                "vs_full",
                "fs_fog",
                &[target(Some(multiply)), target(Some(multiply))],
            ),
            both: make(
                &module,
                "beams",
                &layout,
                "vs_beam",
                "fs_both",
                &[target(Some(add)), target(Some(add))],
            ),
            volume: make(
                &module,
                "beams volume",
                &layout,
                "vs_beam",
                "fs_volume",
                &[target(Some(add))],
            ),
            surface: make(
                &module,
                "beams surface",
                &layout,
                "vs_beam",
                "fs_surface",
                &[target(Some(add))],
            ),
            upsample: make(
                &module,
                "beams upsample",
                &up_layout,
                "vs_full",
                "fs_upsample",
                &[target(None)],
            ),
            layout,
            up_layout,
            targets: None,
        }
    }

    /// Makes the targets of a `size` frame downsampled `ds` times.
    pub fn fit(&mut self, device: &wgpu::Device, size: (u32, u32), ds: u32) {
        if self
            .targets
            .as_ref()
            .is_some_and(|t| t.size == size && t.ds == ds)
        {
            return;
        }
        let color = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        self.targets = Some(BeamTargets {
            size,
            ds,
            volume: super::super::texture_2d(device, "beams volume", size, HDR_FORMAT, color),
            inscatter: super::super::texture_2d(
                device,
                "fog in-scattering",
                size,
                HDR_FORMAT,
                color,
            ),
            low: (ds > 1).then(|| {
                super::super::texture_2d(
                    device,
                    "beams volume (low resolution)",
                    low_size(size, ds),
                    HDR_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                )
            }),
        });
    }

    /// The volume layer (the beams' volumetric caustics) of the last frame.
    pub fn volume(&self) -> &wgpu::Texture {
        &self.targets.as_ref().expect("fitted").volume
    }

    /// The fog lit directly by the lights, of the last frame.
    pub fn inscatter(&self) -> &wgpu::Texture {
        &self.targets.as_ref().expect("fitted").inscatter
    }
}

/// A frame's buffers.
pub struct BeamsBuffers {
    params: wgpu::Buffer,
    beams: wgpu::Buffer,
    count: u32,
    surface: bool,
    /// The scene has a medium.
    medium: bool,
}

impl BeamsBuffers {
    pub fn upload(device: &wgpu::Device, layer: &BeamsLayer) -> BeamsBuffers {
        let params = GpuBeamsParams::new(layer);
        let placeholder = [GpuBeam::zeroed()];
        let beams: &[GpuBeam] = if layer.beams.is_empty() {
            &placeholder
        } else {
            &layer.beams
        };
        BeamsBuffers {
            params: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("beams params"),
                contents: bytemuck::bytes_of(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            beams: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("beams"),
                contents: bytemuck::cast_slice(beams),
                usage: wgpu::BufferUsages::STORAGE,
            }),
            count: layer.beams.len() as u32,
            surface: layer.params.surface,
            medium: layer.medium.half[0] > 0.0,
        }
    }

    /// Bytes of the beams' storage buffer.
    pub fn storage_bytes(layer: &BeamsLayer) -> u64 {
        (layer.beams.len().max(1) * std::mem::size_of::<GpuBeam>()) as u64
    }
}

/// A colour attachment that `load`s or clears.
fn attachment(
    view: &wgpu::TextureView,
    clear: bool,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load: if clear {
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
            } else {
                wgpu::LoadOp::Load
            },
            store: wgpu::StoreOp::Store,
        },
    })
}

/// The direct pass's lights and shadow maps, which the in-scattering pass reads.
pub struct Lights<'a> {
    pub buffer: &'a wgpu::Buffer,
    pub shadow_maps: &'a wgpu::TextureView,
    pub sampler: &'a wgpu::Sampler,
}

/// Encodes the beams passes: with a medium, the fog lit directly by `lights` (the in-scattering
/// layer) and its transmittance over the `direct` and `specular` layers; the volume layer
/// (cleared first) and, with surface caustics, additions to the caustics layer.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &BeamsPipeline,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    b: &BeamsBuffers,
    targets: &Targets,
    lights: &Lights,
    mut timestamps: Option<&mut Timestamps>,
) {
    let caustics = &targets.caustics;
    let t = p.targets.as_ref().expect("fitted");
    let (pos_view, nrm_view) = gbuf.views();
    let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("beams"),
        layout: &p.layout,
        entries: &[
            entry(0, globals.as_entire_binding()),
            entry(1, b.params.as_entire_binding()),
            entry(2, scene.materials.as_entire_binding()),
            entry(3, b.beams.as_entire_binding()),
            entry(4, TextureView(&pos_view)),
            entry(5, TextureView(&nrm_view)),
        ],
    });
    let vol_view = t.volume.create_view(&Default::default());
    let cv = caustics.create_view(&Default::default());
    let mut begin = |enc: &mut wgpu::CommandEncoder,
                     name: &'static str,
                     attachments: &[Option<wgpu::RenderPassColorAttachment>]| {
        let ts = timestamps.as_deref_mut().map(|t| {
            let k = t.pass(name);
            (&*t, k)
        });
        let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(name),
            color_attachments: attachments,
            depth_stencil_attachment: None,
            timestamp_writes: ts.map(|(t, k)| t.writes(k, true, true)),
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.forget_lifetime()
    };
    let in_view = t.inscatter.create_view(&Default::default());
    if b.medium {
        let ibg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fog in-scattering"),
            layout: &p.inscatter_layout,
            entries: &[
                entry(0, globals.as_entire_binding()),
                entry(1, lights.buffer.as_entire_binding()),
                entry(3, TextureView(lights.shadow_maps)),
                entry(4, Sampler(lights.sampler)),
                entry(11, TextureView(&pos_view)),
                entry(12, TextureView(&nrm_view)),
            ],
        });
        let mut pass = begin(enc, "fog_inscatter", &[attachment(&in_view, true)]);
        pass.set_pipeline(&p.inscatter);
        pass.set_bind_group(0, &ibg, &[]);
        pass.draw(0..3, 0..1);
        drop(pass);
        let (dv, sv) = (
            targets.direct.create_view(&Default::default()),
            targets.specular.create_view(&Default::default()),
        );
        let mut pass = begin(
            enc,
            "beams_fog",
            &[attachment(&dv, false), attachment(&sv, false)],
        );
        pass.set_pipeline(&p.fog);
        pass.set_bind_group(0, &bg, &[]);
        pass.draw(0..3, 0..1);
    }
    let Some(low) = &t.low else {
        let surface = b.surface.then(|| attachment(&cv, false)).flatten();
        let mut pass = begin(enc, "beams", &[attachment(&vol_view, true), surface]);
        if b.count > 0 {
            pass.set_pipeline(&p.both);
            pass.set_bind_group(0, &bg, &[]);
            pass.draw(0..HULL_VERTICES, 0..b.count);
        }
        return;
    };
    let low_view = low.create_view(&Default::default());
    {
        let mut pass = begin(enc, "beams_volume", &[attachment(&low_view, true)]);
        if b.count > 0 {
            pass.set_pipeline(&p.volume);
            pass.set_bind_group(0, &bg, &[]);
            pass.draw(0..HULL_VERTICES, 0..b.count);
        }
    }
    if b.surface {
        let mut pass = begin(enc, "beams_surface", &[attachment(&cv, false)]);
        if b.count > 0 {
            pass.set_pipeline(&p.surface);
            pass.set_bind_group(0, &bg, &[]);
            pass.draw(0..HULL_VERTICES, 0..b.count);
        }
    }
    let ubg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("beams upsample"),
        layout: &p.up_layout,
        entries: &[
            entry(0, globals.as_entire_binding()),
            entry(1, b.params.as_entire_binding()),
            entry(4, TextureView(&pos_view)),
            entry(5, TextureView(&nrm_view)),
            entry(6, TextureView(&low_view)),
        ],
    });
    let mut pass = begin(enc, "beams_upsample", &[attachment(&vol_view, true)]);
    pass.set_pipeline(&p.upsample);
    pass.set_bind_group(0, &ubg, &[]);
    pass.draw(0..3, 0..1);
}
