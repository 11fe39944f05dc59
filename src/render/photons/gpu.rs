//! The photons passes on the GPU: per frame, `shaders/photons.wgsl` traces the frame's photons
//! (compute) and stores those that reach a receiver with their footprint, then
//! `shaders/photon_splat.wgsl` draws them over the G-buffer (one indirect instanced draw, its
//! instance count written by the trace's atomic counter), blending into one of two
//! accumulation layers: odd frames into the first, even frames into the second.

use super::super::direct::HDR_FORMAT;
use super::super::gbuffer::GBuffer;
use super::super::shaders;
use super::super::timestamps::Timestamps;
use super::{GpuPhotonFrame, PhotonsLayer};
use crate::frame::Frame;
use crate::gpu::{GpuContext, GpuError};
use crate::render::RenderError;
use crate::scene::World;
use glam::Vec3;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// Pipelines and the two accumulation layers (per frame size), made once per device.
pub struct PhotonsPipeline {
    trace_layout: wgpu::BindGroupLayout,
    trace: wgpu::ComputePipeline,
    splat_layout: wgpu::BindGroupLayout,
    splat: wgpu::RenderPipeline,
    accum: Option<((u32, u32), [wgpu::Texture; 2])>,
}

impl PhotonsPipeline {
    pub fn new(device: &wgpu::Device) -> PhotonsPipeline {
        use super::super::{STORAGE_BINDING, UNIFORM_BINDING, layout_entry, texture_binding};
        let cs = wgpu::ShaderStages::COMPUTE;
        let rw = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let trace_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("photons trace"),
            entries: &[
                layout_entry(0, cs, UNIFORM_BINDING),
                layout_entry(1, cs, STORAGE_BINDING),
                layout_entry(2, cs, STORAGE_BINDING),
                layout_entry(3, cs, STORAGE_BINDING),
                layout_entry(4, cs, STORAGE_BINDING),
                layout_entry(5, cs, rw),
                layout_entry(6, cs, rw),
                layout_entry(8, cs, STORAGE_BINDING),
                layout_entry(9, cs, STORAGE_BINDING),
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("photons.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("photons.wgsl").into()),
        });
        let trace = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("photons trace"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: None,
                    bind_group_layouts: &[Some(&trace_layout)],
                    immediate_size: 0,
                }),
            ),
            module: &module,
            entry_point: Some("trace"),
            compilation_options: Default::default(),
            cache: None,
        });
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frag = wgpu::ShaderStages::FRAGMENT;
        let splat_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("photons splat"),
            entries: &[
                layout_entry(0, vf, UNIFORM_BINDING),
                layout_entry(1, vf, STORAGE_BINDING),
                layout_entry(2, frag, STORAGE_BINDING),
                layout_entry(3, frag, texture_binding(false)),
                layout_entry(4, frag, texture_binding(false)),
            ],
        });
        let splat_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("photon_splat.wgsl"),
            source: wgpu::ShaderSource::Wgsl(shaders::source("photon_splat.wgsl").into()),
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
            dst_factor: wgpu::BlendFactor::One,
            operation: wgpu::BlendOperation::Add,
        };
        let splat = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("photons splat"),
            layout: Some(
                &device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: None,
                    bind_group_layouts: &[Some(&splat_layout)],
                    immediate_size: 0,
                }),
            ),
            vertex: wgpu::VertexState {
                module: &splat_module,
                entry_point: Some("vs_splat"),
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
                module: &splat_module,
                entry_point: Some("fs_splat"),
                compilation_options: Default::default(),
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
        PhotonsPipeline {
            trace_layout,
            trace,
            splat_layout,
            splat,
            accum: None,
        }
    }

    /// Makes the accumulation layers of a `size` frame.
    pub fn fit(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if self.accum.as_ref().is_some_and(|(s, _)| *s == size) {
            return;
        }
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let layer = |label| super::super::texture_2d(device, label, size, HDR_FORMAT, usage);
        self.accum = Some((
            size,
            [
                layer("photons (odd frames)"),
                layer("photons (even frames)"),
            ],
        ));
    }
}

/// One render's buffers.
pub struct PhotonsBuffers {
    frame: wgpu::Buffer,
    pops: wgpu::Buffer,
    normals: wgpu::Buffer,
    env: wgpu::Buffer,
    records: wgpu::Buffer,
    draw: wgpu::Buffer,
    nodes: wgpu::Buffer,
    tris: wgpu::Buffer,
}

impl PhotonsBuffers {
    pub fn upload(device: &wgpu::Device, layer: &PhotonsLayer) -> PhotonsBuffers {
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let copy = wgpu::BufferUsages::COPY_DST;
        let pops = if layer.populations.is_empty() {
            vec![bytemuck::Zeroable::zeroed()]
        } else {
            layer.populations.clone()
        };
        PhotonsBuffers {
            frame: init(
                "photons frame",
                bytemuck::bytes_of(&<GpuPhotonFrame as bytemuck::Zeroable>::zeroed()),
                wgpu::BufferUsages::UNIFORM | copy,
            ),
            pops: init("photon populations", bytemuck::cast_slice(&pops), storage),
            normals: init(
                "photons normals",
                bytemuck::cast_slice(&layer.normals),
                storage,
            ),
            env: init(
                "photons environment",
                bytemuck::cast_slice(&layer.env_directions(1)),
                storage | copy,
            ),
            records: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("photon records"),
                size: layer.record_bytes(),
                usage: storage,
                mapped_at_creation: false,
            }),
            draw: init(
                "photons draw",
                bytemuck::cast_slice(&[6u32, 0, 0, 0]),
                storage | wgpu::BufferUsages::INDIRECT | copy,
            ),
            nodes: init(
                "photons bvh nodes",
                bytemuck::cast_slice(&layer.bvh.nodes),
                storage,
            ),
            tris: init(
                "photons bvh triangles",
                bytemuck::cast_slice(&layer.bvh.triangles),
                storage,
            ),
        }
    }
}

/// What the progressive loop did.
#[derive(Clone, Debug, Default)]
pub struct PhotonsRun {
    pub frames: u32,
    pub photons: u64,
    /// The last noise estimate (relative L1 of the mean), when one was made.
    pub error_estimate: Option<f32>,
    /// Why the loop stopped: "frames", "time budget", "error target" or "canceled".
    pub stopped_by: &'static str,
    /// Wall time of the photon frames (trace and splat, submitted and waited for one by one).
    pub time: Duration,
    /// GPU time of the first frame's passes ("gpu:photons_trace", "gpu:photons_splat") when
    /// the adapter has timestamps.
    pub gpu_times: Vec<(String, Duration)>,
}

/// Encodes photon frame `k` (1-based) into `enc`.
#[allow(clippy::too_many_arguments)]
fn encode_frame(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    pipe: &PhotonsPipeline,
    bufs: &PhotonsBuffers,
    gbuffer: &GBuffer,
    globals: &wgpu::Buffer,
    materials: &wgpu::Buffer,
    layer: &PhotonsLayer,
    k: u32,
    timestamps: Option<&mut Timestamps>,
) {
    let trace_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("photons trace"),
        layout: &pipe.trace_layout,
        entries: &[
            entry(0, &bufs.frame),
            entry(1, &bufs.pops),
            entry(2, materials),
            entry(3, &bufs.normals),
            entry(4, &bufs.env),
            entry(5, &bufs.records),
            entry(6, &bufs.draw),
            entry(8, &bufs.nodes),
            entry(9, &bufs.tris),
        ],
    });
    let (pos, nrm) = gbuffer.views();
    let splat_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("photons splat"),
        layout: &pipe.splat_layout,
        entries: &[
            entry(0, globals),
            entry(1, &bufs.records),
            entry(2, materials),
            wgpu::BindGroupEntry {
                binding: 3,
                resource: wgpu::BindingResource::TextureView(&pos),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: wgpu::BindingResource::TextureView(&nrm),
            },
        ],
    });
    let (ts_trace, ts_splat) = match timestamps {
        Some(t) if k == 1 => {
            let a = t.pass("photons_trace");
            let b = t.pass("photons_splat");
            (Some((&*t, a)), Some((&*t, b)))
        }
        _ => (None, None),
    };
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("photons trace"),
            timestamp_writes: ts_trace.map(|(t, a)| t.compute_writes(a, true, true)),
        });
        pass.set_pipeline(&pipe.trace);
        pass.set_bind_group(0, &trace_group, &[]);
        pass.dispatch_workgroups(layer.photons_per_frame.div_ceil(64).max(1), 1, 1);
    }
    let (_, accum) = pipe.accum.as_ref().expect("fitted");
    let view = accum[((k - 1) % 2) as usize].create_view(&Default::default());
    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("photons splat"),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: &view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                // Frames 1 and 2 start their layer.
                load: if k <= 2 {
                    wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
                } else {
                    wgpu::LoadOp::Load
                },
                store: wgpu::StoreOp::Store,
            },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: ts_splat.map(|(t, b)| t.writes(b, true, true)),
        occlusion_query_set: None,
        multiview_mask: None,
    });
    pass.set_pipeline(&pipe.splat);
    pass.set_bind_group(0, &splat_group, &[]);
    pass.draw_indirect(&bufs.draw, 0);
}

fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// The progressive loop: photon frames until the layer's frame count, time budget or error
/// target, or until `keep_going` says no, each submitted and waited for; then the mean of both
/// layers as the caustics frame.
/// The first frame's passes are timed when the adapter has timestamps.
#[allow(clippy::too_many_arguments)]
pub fn run(
    ctx: &GpuContext,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipe: &PhotonsPipeline,
    gbuffer: &GBuffer,
    globals: &wgpu::Buffer,
    materials: &wgpu::Buffer,
    world: &World,
    layer: &PhotonsLayer,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<(Frame, PhotonsRun), RenderError> {
    let t0 = Instant::now();
    let (bufs, mut timestamps) = ctx.scoped(device, || {
        (
            PhotonsBuffers::upload(device, layer),
            Timestamps::new(ctx, device, 2),
        )
    })?;
    let p = &layer.params;
    let mut run = PhotonsRun {
        stopped_by: "frames",
        ..Default::default()
    };
    let mut last: Option<(Layer, Layer)> = None;
    for k in 1..=p.frames.max(1) {
        if k > 1 && !keep_going() {
            run.stopped_by = "canceled";
            break;
        }
        queue.write_buffer(
            &bufs.frame,
            0,
            bytemuck::bytes_of(&layer.frame_uniform(world, k)),
        );
        queue.write_buffer(&bufs.draw, 0, bytemuck::cast_slice(&[6u32, 0, 0, 0]));
        if k > 1 && layer.has_environment() {
            queue.write_buffer(&bufs.env, 0, bytemuck::cast_slice(&layer.env_directions(k)));
        }
        ctx.scoped(device, || {
            let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("photons frame"),
            });
            encode_frame(
                device,
                &mut enc,
                pipe,
                &bufs,
                gbuffer,
                globals,
                materials,
                layer,
                k,
                timestamps.as_mut(),
            );
            if k == 1
                && let Some(t) = &timestamps
            {
                t.resolve(&mut enc);
            }
            queue.submit([enc.finish()]);
        })?;
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Lost(format!("poll: {e}")))?;
        if ctx.is_lost() {
            return Err(GpuError::Lost("device lost during a photon frame".into()).into());
        }
        run.frames = k;
        run.photons += u64::from(layer.photons_per_frame);
        if k == 1
            && let Some(t) = &timestamps
        {
            run.gpu_times = t.read(ctx, device, queue)?;
        }
        if p.time_budget.is_some_and(|b| t0.elapsed() >= b) {
            run.stopped_by = "time budget";
            break;
        }
        if let Some(target) = p.error_target
            && k % 2 == 0
        {
            let layers = read_layers(ctx, pipe)?;
            let e = noise_estimate(&layers.0, &layers.1);
            run.error_estimate = Some(e);
            if e <= target {
                run.stopped_by = "error target";
                // The layers just read are the last frame's: no second readback.
                last = Some(layers);
                break;
            }
        }
    }
    run.time = t0.elapsed();
    let frames = run.frames;
    let (a, b) = match last {
        Some(layers) => layers,
        None => read_layers(ctx, pipe)?,
    };
    let (w, h) = pipe.accum.as_ref().expect("fitted").0;
    // Frame 1 alone leaves the second layer as it was: only what frames wrote counts.
    let scale = 1.0 / frames as f32;
    let pixels = a
        .iter()
        .zip(&b)
        .map(|(x, y)| {
            let s = Vec3::new(x[0], x[1], x[2])
                + if frames >= 2 {
                    Vec3::new(y[0], y[1], y[2])
                } else {
                    Vec3::ZERO
                };
            s * scale
        })
        .collect();
    Ok((
        Frame {
            width: w,
            height: h,
            pixels,
        },
        run,
    ))
}

/// One accumulation layer as read back: RGBA per pixel.
type Layer = Vec<[f32; 4]>;

fn read_layers(ctx: &GpuContext, pipe: &PhotonsPipeline) -> Result<(Layer, Layer), RenderError> {
    let (_, accum) = pipe.accum.as_ref().expect("fitted");
    Ok((
        ctx.readback_rgba32f(&accum[0])?,
        ctx.readback_rgba32f(&accum[1])?,
    ))
}

/// The noise of the mean of two independent halves a and b (sums of as many frames each), per
/// pixel: Σ|a − b| / Σ(a + b). Each half's mean is off by about √2 times the whole mean's
/// error, their difference by √2 times a half's, and Σ(a + b) is twice a half's sum.
pub fn noise_estimate(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    let (mut diff, mut sum) = (0f64, 0f64);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            diff += f64::from((x[c] - y[c]).abs());
            sum += f64::from(x[c] + y[c]);
        }
    }
    if sum <= 0.0 {
        return 0.0;
    }
    (diff / sum) as f32
}

#[cfg(test)]
mod tests {
    use super::noise_estimate;

    #[test]
    fn the_noise_estimate_is_the_halves_relative_difference() {
        let a = vec![[1.0, 2.0, 3.0, 0.0]; 10];
        assert_eq!(noise_estimate(&a, &a), 0.0);
        let b: Vec<[f32; 4]> = a
            .iter()
            .map(|p| [p[0] * 2.0, p[1] * 2.0, p[2] * 2.0, 0.0])
            .collect();
        assert!((noise_estimate(&a, &b) - 1.0 / 3.0).abs() < 1e-6);
        assert_eq!(noise_estimate(&[[0.0; 4]], &[[0.0; 4]]), 0.0);
    }
}
