//! A compute entry (`csl_points.wgsl` beside this file) that evaluates CSL sets at a list of
//! receiver points with the functions of the CSL pass (shaders/csl.inc.wgsl): the csl_gpu
//! tests check the GPU's CSL evaluation against the CPU's at arbitrary points and normals.

use caustica::bake::csl::Csl;
use caustica::gpu::{GpuContext, GpuError};
use caustica::render::csl::{pack_params, pack_texels};
use caustica::render::shaders::{FILES, expand_includes};
use glam::Vec3;
use wgpu::util::DeviceExt;

/// The compute shader with the renderer's includes expanded.
pub fn source() -> String {
    let lookup = |n: &str| {
        FILES
            .iter()
            .find(|(f, _)| *f == n)
            .map(|(_, s)| s.to_string())
    };
    expand_includes(include_str!("csl_points.wgsl"), &lookup).expect("includes expand")
}

/// Compute pipeline evaluating CSL sets at points.
pub struct CslEvaluator {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl CslEvaluator {
    pub fn new(ctx: &GpuContext) -> Result<Self, GpuError> {
        let device = ctx.device();
        ctx.scoped(&device, || {
            let storage = |binding, read_only| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            };
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("csl eval"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    storage(1, true),
                    storage(7, true),
                    storage(3, true),
                    storage(4, true),
                    storage(5, false),
                ],
            });
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("csl_points.wgsl"),
                source: wgpu::ShaderSource::Wgsl(source().into()),
            });
            let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("csl eval"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("csl eval"),
                layout: Some(&pl),
                module: &module,
                entry_point: Some("eval_points"),
                compilation_options: Default::default(),
                cache: None,
            });
            CslEvaluator { pipeline, layout }
        })
    }

    /// Summed irradiance of `csls` (per unit light irradiance, no occlusion) at each
    /// (point, unit normal), evaluated on the GPU.
    pub fn irradiance(
        &self,
        ctx: &GpuContext,
        csls: &[Csl],
        points: &[(Vec3, Vec3)],
    ) -> Result<Vec<Vec3>, GpuError> {
        if points.is_empty() {
            return Ok(Vec::new());
        }
        let device = ctx.device();
        let queue = ctx.queue();
        // Both never empty: placeholders when there is no CSL.
        let (params, words) = (pack_params(csls), pack_texels(csls));
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let (bg, out, read) = ctx.scoped(&device, || {
            let uniform = init(
                "csl params",
                bytemuck::cast_slice(&[csls.len() as u32, points.len() as u32, 0, 0]),
                wgpu::BufferUsages::UNIFORM,
            );
            let s = wgpu::BufferUsages::STORAGE;
            let cbuf = init("csls", bytemuck::cast_slice(&params), s);
            let tbuf = init("csl texels", bytemuck::cast_slice(&words), s);
            let p: Vec<[f32; 4]> = points.iter().map(|(p, _)| p.extend(1.0).into()).collect();
            let n: Vec<[f32; 4]> = points.iter().map(|(_, n)| n.extend(0.0).into()).collect();
            let pbuf = init("points", bytemuck::cast_slice(&p), s);
            let nbuf = init("normals", bytemuck::cast_slice(&n), s);
            let size = (points.len() * 16) as u64;
            let out = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("csl result"),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let read = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("csl readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("csl eval"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: cbuf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 7,
                        resource: tbuf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: pbuf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: nbuf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: out.as_entire_binding(),
                    },
                ],
            });
            (bg, out, read)
        })?;
        let size = (points.len() * 16) as u64;
        let mut enc = device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bg, &[]);
            pass.dispatch_workgroups((points.len() as u32).div_ceil(64), 1, 1);
        }
        enc.copy_buffer_to_buffer(&out, 0, &read, 0, size);
        queue.submit([enc.finish()]);
        let bytes = ctx.map_read(&device, &read)?;
        let v: &[[f32; 4]] = bytemuck::cast_slice(&bytes);
        Ok(v.iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect())
    }
}
