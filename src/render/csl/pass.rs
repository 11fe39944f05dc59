//! The CSL passes on the GPU (`shaders/csl.wgsl`): after the G-buffer, one compute dispatch a
//! 16×16 tile culls the frame's CSLs against the tile's receivers and evaluates, per pixel,
//! every CSL whose ray map is smooth on the pixel's scale; the pixels where some CSL needs the
//! average over the footprint take a slot in a list, and a second dispatch (sized on the GPU
//! from the list's length) evaluates those. Split so that no pixel runs the footprint average's
//! code unless it needs it: llvmpipe runs both sides of every divergent branch, and a GPU's
//! SIMD group waits for its slowest lane.

use super::super::gbuffer::GBuffer;
use super::super::scene::BlockerBuffers;
use super::super::timestamps::Timestamps;
use super::super::{STORAGE_BINDING, UNIFORM_BINDING, layout_entry, shaders, texture_binding};

/// Most CSLs a frame evaluates (csl.wgsl's `MAX_WORDS` × 32: one bit each in a tile's mask).
pub const MAX_FRAME_CSLS: usize = 1024;
/// Pixels of a tile's side (`TILE` in csl.wgsl).
const TILE: u32 = 16;

/// Bytes of the per-frame scratch of `pixels` pixels and `csls` CSLs: a slot (point sum and
/// pixel) and a mark word per 32 CSLs for every pixel, the most that can need the footprint
/// average.
pub fn scratch_bytes(pixels: u64, csls: usize) -> u64 {
    pixels * (16 + 4 * words(csls) as u64) + 16
}

fn words(csls: usize) -> u32 {
    (csls as u32).div_ceil(32).max(1)
}

/// The three compute pipelines of one variant.
struct PassPipelines {
    tiles: wgpu::ComputePipeline,
    wide_args: wgpu::ComputePipeline,
    wide: wgpu::ComputePipeline,
}

/// The layout, made once per device, and the pipelines of each variant, made on first use:
/// with and without the glossy BRDF (`HAS_GLOSSY`).
pub struct CslPipelines {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
    variants: [Option<PassPipelines>; 2],
}

impl CslPipelines {
    pub fn new(device: &wgpu::Device) -> CslPipelines {
        let cs = wgpu::ShaderStages::COMPUTE;
        let rw = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("csl"),
            entries: &[
                layout_entry(0, cs, UNIFORM_BINDING),
                layout_entry(2, cs, STORAGE_BINDING),
                layout_entry(6, cs, STORAGE_BINDING),
                layout_entry(7, cs, STORAGE_BINDING),
                layout_entry(8, cs, STORAGE_BINDING),
                layout_entry(9, cs, STORAGE_BINDING),
                layout_entry(10, cs, texture_binding(false)),
                layout_entry(11, cs, texture_binding(false)),
                layout_entry(12, cs, texture_binding(false)),
                layout_entry(
                    13,
                    cs,
                    wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: wgpu::TextureFormat::Rgba32Float,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                ),
                layout_entry(14, cs, rw),
                layout_entry(15, cs, rw),
                layout_entry(16, cs, rw),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("csl.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("csl.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("csl"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        CslPipelines {
            layout,
            pipeline_layout,
            module,
            variants: [None, None],
        }
    }

    /// Makes the pipelines of the variant a frame with (`glossy`) or without glossy receivers
    /// needs, when not made yet.
    pub fn prepare(&mut self, device: &wgpu::Device, glossy: bool) {
        let slot = &mut self.variants[glossy as usize];
        if slot.is_some() {
            return;
        }
        let constants = [("HAS_GLOSSY", if glossy { 1.0 } else { 0.0 })];
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&self.pipeline_layout),
                module: &self.module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: &constants,
                    ..Default::default()
                },
                cache: None,
            })
        };
        *slot = Some(PassPipelines {
            tiles: pipeline("csl_tiles"),
            wide_args: pipeline("csl_wide_args"),
            wide: pipeline("csl_wide"),
        });
    }
}

/// The list of pixels that need the footprint average, kept between frames of one size and
/// CSL word count.
pub struct CslScratch {
    pixels: u64,
    words: u32,
    /// The slot count and the second dispatch's workgroups (`WideState`).
    state: wgpu::Buffer,
    /// The workgroups copied out of `state` (a buffer cannot be both the dispatch's storage
    /// and its indirect arguments).
    args: wgpu::Buffer,
    slots: wgpu::Buffer,
    marks: wgpu::Buffer,
}

impl CslScratch {
    pub fn new(device: &wgpu::Device, pixels: u64, csls: usize) -> CslScratch {
        let words = words(csls);
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        CslScratch {
            pixels,
            words,
            state: buffer(
                "csl wide state",
                16,
                wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            ),
            args: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("csl wide dispatch"),
                size: 12,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            slots: buffer("csl wide slots", pixels * 16, wgpu::BufferUsages::empty()),
            marks: buffer(
                "csl wide marks",
                pixels * 4 * words as u64,
                wgpu::BufferUsages::empty(),
            ),
        }
    }

    /// Whether this scratch serves a frame of `pixels` pixels and `csls` CSLs.
    pub fn fits(&self, pixels: u64, csls: usize) -> bool {
        self.pixels == pixels && self.words == words(csls)
    }
}

/// What the passes read besides the G-buffer and write besides the scratch.
pub struct CslInputs<'a> {
    pub globals: &'a wgpu::Buffer,
    pub materials: &'a wgpu::Buffer,
    pub csls: &'a wgpu::Buffer,
    pub texels: &'a wgpu::Buffer,
    pub blockers: &'a BlockerBuffers,
    /// Whether the scene has glossy receivers (the variant [`CslPipelines::prepare`] made).
    pub glossy: bool,
}

/// Encodes the CSL passes: the caustics layer of `gbuf`'s receivers into `caustics`
/// (rgb: radiance, a: 1), timed together as pass `csl`.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &CslPipelines,
    gbuf: &GBuffer,
    inputs: &CslInputs,
    scratch: &CslScratch,
    caustics: &wgpu::Texture,
    timestamps: Option<&mut Timestamps>,
) {
    let pp = p.variants[inputs.glossy as usize]
        .as_ref()
        .expect("CslPipelines::prepare made the variant");
    let (pos, nrm) = gbuf.views();
    let geo = gbuf.geometric.create_view(&Default::default());
    let out = caustics.create_view(&Default::default());
    let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let tv = wgpu::BindingResource::TextureView;
    let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("csl"),
        layout: &p.layout,
        entries: &[
            entry(0, inputs.globals.as_entire_binding()),
            entry(2, inputs.materials.as_entire_binding()),
            entry(6, inputs.csls.as_entire_binding()),
            entry(7, inputs.texels.as_entire_binding()),
            entry(8, inputs.blockers.nodes.as_entire_binding()),
            entry(9, inputs.blockers.triangles.as_entire_binding()),
            entry(10, tv(&pos)),
            entry(11, tv(&nrm)),
            entry(12, tv(&geo)),
            entry(13, tv(&out)),
            entry(14, scratch.state.as_entire_binding()),
            entry(15, scratch.slots.as_entire_binding()),
            entry(16, scratch.marks.as_entire_binding()),
        ],
    });
    enc.clear_buffer(&scratch.state, 0, None);
    let ts = timestamps.map(|t| {
        let k = t.pass("csl");
        (&*t, k)
    });
    let (w, h) = (gbuf.width, gbuf.height);
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("csl tiles"),
            timestamp_writes: ts.map(|(t, k)| t.compute_writes(k, true, false)),
        });
        pass.set_bind_group(0, &bg, &[]);
        pass.set_pipeline(&pp.tiles);
        pass.dispatch_workgroups(w.div_ceil(TILE), h.div_ceil(TILE), 1);
    }
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("csl wide args"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &bg, &[]);
        pass.set_pipeline(&pp.wide_args);
        pass.dispatch_workgroups(1, 1, 1);
    }
    enc.copy_buffer_to_buffer(&scratch.state, 4, &scratch.args, 0, 12);
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some("csl wide"),
        timestamp_writes: ts.map(|(t, k)| t.compute_writes(k, false, true)),
    });
    pass.set_bind_group(0, &bg, &[]);
    pass.set_pipeline(&pp.wide);
    pass.dispatch_workgroups_indirect(&scratch.args, 0);
}
