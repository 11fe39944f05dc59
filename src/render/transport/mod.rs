//! The transport pass (Iwasaki et al. 2005 §5.2, method `transport`): the illumination volumes
//! of the frame ([`volumes::build_volumes`], built on the CPU from the tables every frame) are
//! uploaded as one storage buffer and drawn over a G-buffer of the receivers, so caustics land
//! on any scene geometry, not only a plane. See `shaders/transport.wgsl` for the evaluation
//! and `shaders/gbuffer.wgsl` for the G-buffer. What the camera sees through the glass
//! (§5.3) is gathered on the CPU too ([`view`]) and drawn by the direct pass.
//!
//! The pass blends additively into the 32-bit float caustics layer, which needs
//! `FLOAT32_BLENDABLE` (Vulkan adapters, lavapipe included, have it; the GL backend does not:
//! the render then fails with a message saying so).

pub mod view;
pub mod volumes;

use super::direct::{HDR_FORMAT, Targets};
use super::gbuffer::GBuffer;
use super::scene::{BlockerBuffers, SceneBuffers};
use super::shaders;
use super::timestamps::Timestamps;
use crate::bake::transport::TransportTable;
use crate::scene::World;
use bytemuck::{Pod, Zeroable};
use volumes::{EvalError, Source, Volume, VolumeStats};
use wgpu::util::DeviceExt;

/// `Volume` of transport.wgsl: `e`, `d`, `f` are its members `e0..e2`, `d0..d2`, `f0..f2`
/// (layout checked against naga's in `render::shaders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuVolume {
    pub e: [[f32; 4]; 3],
    pub d: [[f32; 4]; 3],
    pub f: [[f32; 4]; 3],
}

impl GpuVolume {
    pub fn pack(v: &Volume) -> GpuVolume {
        let w = [v.source_area, v.length, 0.0];
        GpuVolume {
            e: std::array::from_fn(|i| v.exits[i].extend(w[i]).to_array()),
            d: std::array::from_fn(|i| v.dirs[i].extend(0.0).to_array()),
            f: std::array::from_fn(|i| v.flux_density[i].extend(0.0).to_array()),
        }
    }
}

/// The caustics of a frame from transport tables: the illumination volumes of every caustic
/// object under the scene's lights.
#[derive(Clone, Debug, Default)]
pub struct TransportLayer {
    pub volumes: Vec<Volume>,
    /// Indices into `World::objects` of the caustic objects: they do not occlude their own
    /// caustic light (and are shadowed from the light by everything else).
    pub caustic_objects: Vec<usize>,
    pub stats: VolumeStats,
    /// Per caustic object, per table vertex: the radiance seen through it
    /// ([`view::view_refraction`]); the direct pass draws the glass with it.
    pub view: Vec<(usize, Vec<[f32; 4]>)>,
}

impl TransportLayer {
    /// The volumes of `tables` (object index, its table) for the delta lights of `world`, line
    /// lights as `line_points` point lights.
    pub fn build(
        world: &World,
        tables: &[(usize, &TransportTable)],
        line_points: u32,
    ) -> Result<TransportLayer, EvalError> {
        Self::build_with(world, tables, line_points, &|| true)
    }

    /// [`TransportLayer::build`] that stops with [`EvalError::Canceled`] soon after
    /// `keep_going` returns false (checked between objects and stages, and while gathering the
    /// caustics seen through the glass).
    pub fn build_with(
        world: &World,
        tables: &[(usize, &TransportTable)],
        line_points: u32,
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<TransportLayer, EvalError> {
        let go = || {
            if keep_going() {
                Ok(())
            } else {
                Err(EvalError::Canceled)
            }
        };
        let sources: Vec<Source> = volumes::sources(&world.lights, line_points);
        let caustic_objects: Vec<usize> = tables.iter().map(|t| t.0).collect();
        let blockers = crate::trace::Accel::shared_fast(world, |i| !caustic_objects.contains(&i));
        let mut layer = TransportLayer {
            caustic_objects: caustic_objects.clone(),
            ..Default::default()
        };
        for &(oi, table) in tables {
            go()?;
            let name = &world.objects[oi].name;
            let (v, s) =
                volumes::build_volumes(world, name, table, &sources, Some(&blockers), keep_going)?;
            go()?;
            let (r, rs) = volumes::build_reflection_volumes(
                world,
                name,
                &sources,
                Some(&blockers),
                keep_going,
            )?;
            layer.volumes.extend(v);
            layer.volumes.extend(r);
            layer.stats.vertices += s.vertices;
            layer.stats.lit_vertices += s.lit_vertices;
            layer.stats.volumes += s.volumes + rs.volumes;
            layer.stats.flux += s.flux;
            layer.stats.reflection_volumes += rs.reflection_volumes;
            layer.stats.reflected_flux += rs.reflected_flux;
            volumes::check_volume_count(layer.volumes.len(), &sources)?;
        }
        // Viewing rays through each object see the others' caustics too.
        let scene = crate::trace::Accel::shared_fast(world, |_| true);
        for &(oi, table) in tables {
            let view = view::view_refraction(
                world,
                &world.objects[oi].name,
                table,
                world.camera.eye,
                &sources,
                &layer.volumes,
                &blockers,
                &scene,
                keep_going,
            )?;
            layer.view.push((oi, view));
        }
        Ok(layer)
    }

    /// Writes the view-refraction radiance into the packed vertices of the caustic objects'
    /// glass parts (in the tables' vertex order).
    pub fn apply_view(&self, world: &World, scene: &mut super::scene::PackedScene) {
        use crate::scene::Material;
        for (oi, view) in &self.view {
            let bases = super::scene::PackedScene::part_bases(world, *oi);
            let mut k = 0usize;
            for (part, base) in world.objects[*oi].parts.iter().zip(bases) {
                if !matches!(
                    world.materials[part.material as usize],
                    Material::Dielectric { .. }
                ) {
                    continue;
                }
                for j in 0..part.mesh.positions.len() {
                    if let (Some(v), Some(dst)) = (view.get(k), scene.vertices.get_mut(base + j)) {
                        dst.view = *v;
                    }
                    k += 1;
                }
            }
        }
    }
}

/// Entries of the list of (pixel, volume) pairs per pixel of the frame (transport.wgsl's
/// `fs_select` appends them); the measured mean on the canonical sphere under its point light
/// is 4.8 a receiver pixel, with a tail of a few thousand in a few pixels.
pub const LIST_ENTRIES_PER_PIXEL: u64 = 16;

/// The list, the sums and the culling depth of a frame size.
struct Lists {
    size: (u32, u32),
    per_pixel: u64,
    capacity: u64,
    /// `ListState`: the count and the dispatch of `evaluate`.
    state: wgpu::Buffer,
    /// The dispatch copied out of `state` (one buffer cannot be a dispatch's storage and its
    /// indirect arguments).
    args: wgpu::Buffer,
    entries: wgpu::Buffer,
    sums: wgpu::Buffer,
    /// The culling depth of the volume draws (`fs_cull_depth`).
    depth: wgpu::Texture,
}

/// The volume pipelines, created once per device: the select draw and the evaluate and
/// resolve dispatches (the default), and the blended draw that evaluates every covered
/// fragment (the fallback when the list overflows); the list, kept per image size.
pub struct TransportPipelines {
    pub volume: wgpu::RenderPipeline,
    select: wgpu::RenderPipeline,
    cull_depth: wgpu::RenderPipeline,
    outline: wgpu::ComputePipeline,
    outline_layout: wgpu::BindGroupLayout,
    list_args: wgpu::ComputePipeline,
    evaluate: wgpu::ComputePipeline,
    resolve: wgpu::ComputePipeline,
    pub volume_layout: wgpu::BindGroupLayout,
    output_layout: wgpu::BindGroupLayout,
    lists: Option<Lists>,
}

/// Bytes a pixel of the list (at most), the sums and the culling depth take; a volume's
/// entries add [`LIST_ENTRIES_PER_VOLUME`] × 8 more, and its outline 64.
pub const LIST_BYTES_PER_PIXEL: u64 = LIST_ENTRIES_PER_PIXEL * 8 + 24 + 4;

/// Entries of the list per illumination volume besides those per pixel: in a small image every
/// volume still covers a pixel or a few (the canonical sphere's 34.7k volumes overflowed 16
/// entries a pixel at 160 × 120).
pub const LIST_ENTRIES_PER_VOLUME: u64 = 16;

fn list_capacity(pixels: u64, per_pixel: u64, volumes: u64, max_binding: u64) -> u64 {
    (pixels * per_pixel + volumes * per_pixel.min(LIST_ENTRIES_PER_VOLUME))
        .min(max_binding / 8)
        .max(1)
}

/// Vertices drawn per volume or beam (`HULL_VERTICES` of hull.inc.wgsl).
pub const HULL_VERTICES: u32 = 12;

/// Bytes of a volume's `Outline` (transport.wgsl).
const OUTLINE_BYTES: u64 = 64;

/// The format of the volume draws' culling depth.
const CULL_DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The culling depth's state in a volume pipeline: written (`fs_cull_depth`) or tested.
fn cull_depth_state(
    write: bool,
    compare: wgpu::CompareFunction,
) -> Option<wgpu::DepthStencilState> {
    Some(wgpu::DepthStencilState {
        format: CULL_DEPTH_FORMAT,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil: wgpu::StencilState::default(),
        bias: wgpu::DepthBiasState::default(),
    })
}

/// transport.wgsl for a device with `features`: as written (`fs_select` forces the depth test
/// before it runs) where the device has `SHADER_EARLY_DEPTH_TEST`, else without that attribute
/// (the depth test then comes after the shader, whose appends it cannot stop: the same list,
/// without the saving).
pub fn select_source(features: wgpu::Features) -> String {
    let src = shaders::source("transport.wgsl");
    if features.contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST) {
        src
    } else {
        src.replace("@early_depth_test(force)", "")
    }
}

impl TransportPipelines {
    pub fn new(device: &wgpu::Device) -> TransportPipelines {
        let entry = super::layout_entry;
        let cs = wgpu::ShaderStages::COMPUTE;
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT | cs;
        let frag = wgpu::ShaderStages::FRAGMENT | cs;
        let (uniform, storage) = (super::UNIFORM_BINDING, super::STORAGE_BINDING);
        let texture = super::texture_binding(false);
        let rw = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: false },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let volume_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("transport volumes"),
            entries: &[
                entry(0, vf, uniform),
                entry(2, frag, storage),
                entry(8, frag, storage),
                entry(9, frag, storage),
                entry(10, frag, texture),
                entry(11, frag, texture),
                entry(12, vf, storage),
                entry(13, frag, rw),
                entry(14, frag, rw),
                entry(15, frag, rw),
                entry(16, frag, uniform),
                entry(17, wgpu::ShaderStages::VERTEX, storage),
            ],
        });
        let outline_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("transport outlines"),
            entries: &[
                entry(0, cs, uniform),
                entry(12, cs, storage),
                entry(18, cs, rw),
            ],
        });
        let output_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("transport gather"),
            entries: &[entry(
                0,
                cs,
                wgpu::BindingType::StorageTexture {
                    access: wgpu::StorageTextureAccess::WriteOnly,
                    format: HDR_FORMAT,
                    view_dimension: wgpu::TextureViewDimension::D2,
                },
            )],
        });
        let tmod = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("transport.wgsl"),
            source: wgpu::ShaderSource::Wgsl(select_source(device.features()).into()),
        });
        let layout = |l: &wgpu::BindGroupLayout| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: None,
                bind_group_layouts: &[Some(l)],
                immediate_size: 0,
            })
        };
        let primitive = wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        };
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
        let volume_pl = layout(&volume_layout);
        let draw = |label, entry: &str, blend, write_mask| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&volume_pl),
                vertex: wgpu::VertexState {
                    module: &tmod,
                    entry_point: Some("vs_volume"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive,
                // Drawn at the volume's depth bound: kept where the receiver is no farther
                // (fs_cull_depth).
                depth_stencil: cull_depth_state(false, wgpu::CompareFunction::GreaterEqual),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &tmod,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: HDR_FORMAT,
                        blend,
                        write_mask,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let volume = draw(
            "transport volumes",
            "fs_volume",
            Some(add),
            wgpu::ColorWrites::ALL,
        );
        let select = draw(
            "transport select",
            "fs_select",
            None,
            wgpu::ColorWrites::empty(),
        );
        let cull_depth = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("transport cull depth"),
            layout: Some(&volume_pl),
            vertex: wgpu::VertexState {
                module: &tmod,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: cull_depth_state(true, wgpu::CompareFunction::Always),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &tmod,
                entry_point: Some("fs_cull_depth"),
                compilation_options: Default::default(),
                targets: &[],
            }),
            multiview_mask: None,
            cache: None,
        });
        let compute_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&volume_layout), Some(&output_layout)],
            immediate_size: 0,
        });
        let compute = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&compute_pl),
                module: &tmod,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let outline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("outline"),
            layout: Some(&layout(&outline_layout)),
            module: &tmod,
            entry_point: Some("outline"),
            compilation_options: Default::default(),
            cache: None,
        });
        TransportPipelines {
            volume,
            outline,
            outline_layout,
            select,
            cull_depth,
            list_args: compute("list_args"),
            evaluate: compute("evaluate"),
            resolve: compute("resolve"),
            volume_layout,
            output_layout,
            lists: None,
        }
    }

    /// Makes the list (`per_pixel` entries a pixel, and as many a volume up to
    /// [`LIST_ENTRIES_PER_VOLUME`], for `volumes` volumes), the sums and the culling depth for
    /// frames of `size` (kept while they are the same and the list is long enough), no buffer
    /// over `max_binding` bytes.
    pub fn fit(
        &mut self,
        device: &wgpu::Device,
        size: (u32, u32),
        per_pixel: u64,
        volumes: u64,
        max_binding: u64,
    ) {
        let pixels = u64::from(size.0) * u64::from(size.1);
        let capacity = list_capacity(pixels, per_pixel, volumes, max_binding);
        if self
            .lists
            .as_ref()
            .is_some_and(|l| (l.size, l.per_pixel) == (size, per_pixel) && l.capacity >= capacity)
        {
            return;
        }
        drop(self.lists.take());
        let buffer = |label, size: u64, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        self.lists = Some(Lists {
            size,
            per_pixel,
            capacity,
            state: buffer("transport list state", 16, storage | copy),
            args: buffer(
                "transport evaluate dispatch",
                12,
                wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            ),
            entries: buffer("transport list", capacity * 8, storage),
            sums: buffer(
                "transport sums",
                pixels * 24,
                storage | wgpu::BufferUsages::COPY_DST,
            ),
            depth: super::texture_2d(
                device,
                "transport cull depth",
                size,
                CULL_DEPTH_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            ),
        });
    }
}

/// The volumes buffer of a frame (never empty: a zero volume that covers nothing when there is
/// none, so the binding stays valid), their outlines (`Outline` of transport.wgsl, written by
/// its `outline` pass) and the uniform of the list's sums.
pub struct VolumeBuffers {
    pub volumes: wgpu::Buffer,
    outlines: wgpu::Buffer,
    /// `ListParams` of transport.wgsl: the fixed-point sums' unit.
    params: wgpu::Buffer,
}

/// The fixed-point unit of a frame's sums: 2⁻⁸ of the largest flux density any volume carries
/// over π (the radiance a white diffuse receiver sends under it). A sum holds up to 2³² units
/// (1.7·10⁷ times that radiance, room for foci) in steps of 2⁻³² of a unit (~10⁻¹² of it),
/// whatever units the scene's lights are in.
pub fn sums_unit(volumes: &[Volume]) -> f32 {
    let peak = volumes
        .iter()
        .flat_map(|v| v.flux_density.iter().map(|f| f.max_element()))
        .filter(|f| f.is_finite())
        .fold(0.0f32, f32::max);
    (peak / std::f32::consts::PI * 2f32.powi(-8)).max(f32::MIN_POSITIVE)
}

pub fn upload_volumes(device: &wgpu::Device, volumes: &[Volume]) -> VolumeBuffers {
    let mut packed: Vec<GpuVolume> = volumes.iter().map(GpuVolume::pack).collect();
    if packed.is_empty() {
        packed.push(GpuVolume::zeroed());
    }
    let init = |label, contents: &[u8], usage| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    };
    VolumeBuffers {
        volumes: init(
            "transport volumes",
            bytemuck::cast_slice(&packed),
            wgpu::BufferUsages::STORAGE,
        ),
        outlines: device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("transport outlines"),
            size: packed.len() as u64 * OUTLINE_BYTES,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        }),
        params: init(
            "transport list params",
            bytemuck::cast_slice(&[sums_unit(volumes), 0.0, 0.0, 0.0]),
            wgpu::BufferUsages::UNIFORM,
        ),
    }
}

/// Encodes the volume pass over the G-buffer `gbuf` (drawn before it, after the direct pass,
/// which cleared the caustics layer); `globals` is the frame's camera uniform. `blended`: every
/// covered fragment evaluated and blended instead of listed; `cull`: the outlines culled by
/// the culling depth (else it is cleared to 0 and keeps every pixel).
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &TransportPipelines,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    blockers: &BlockerBuffers,
    volumes: &VolumeBuffers,
    count: u32,
    blended: bool,
    cull: bool,
    targets: &Targets,
    timestamps: Option<&mut Timestamps>,
) {
    let lists = p
        .lists
        .as_ref()
        .expect("TransportPipelines::fit made the list");
    let (pos_view, nrm_view) = gbuf.views();
    let vbg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("transport volumes"),
        layout: &p.volume_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: scene.materials.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 8,
                resource: blockers.nodes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 9,
                resource: blockers.triangles.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 10,
                resource: wgpu::BindingResource::TextureView(&pos_view),
            },
            wgpu::BindGroupEntry {
                binding: 11,
                resource: wgpu::BindingResource::TextureView(&nrm_view),
            },
            wgpu::BindGroupEntry {
                binding: 12,
                resource: volumes.volumes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 13,
                resource: lists.state.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 14,
                resource: lists.entries.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 15,
                resource: lists.sums.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 16,
                resource: volumes.params.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 17,
                resource: volumes.outlines.as_entire_binding(),
            },
        ],
    });
    let outline_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("transport outlines"),
        layout: &p.outline_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 12,
                resource: volumes.volumes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 18,
                resource: volumes.outlines.as_entire_binding(),
            },
        ],
    });
    let cv = targets.caustics.create_view(&Default::default());
    let dv = lists.depth.create_view(&Default::default());
    // One timed pass from the outlines to the layer.
    let ts = timestamps.map(|t| {
        let k = t.pass("transport");
        (&*t, k)
    });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("transport outlines"),
            timestamp_writes: ts.map(|(t, k)| t.compute_writes(k, true, false)),
        });
        if count > 0 {
            pass.set_pipeline(&p.outline);
            pass.set_bind_group(0, &outline_bg, &[]);
            let groups = count.div_ceil(64);
            pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
        }
    }
    {
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("transport cull depth"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &dv,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(if cull { 1.0 } else { 0.0 }),
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        if count > 0 && cull {
            pass.set_pipeline(&p.cull_depth);
            pass.set_bind_group(0, &vbg, &[]);
            pass.draw(0..3, 0..1);
        }
    }
    let depth = wgpu::RenderPassDepthStencilAttachment {
        view: &dv,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Load,
            store: wgpu::StoreOp::Discard,
        }),
        stencil_ops: None,
    };
    if blended {
        let mut pass = super::caustics_pass_timed(
            enc,
            &cv,
            "transport",
            ts.map(|(t, k)| t.writes(k, false, true)),
            Some(depth),
        );
        if count > 0 {
            pass.set_pipeline(&p.volume);
            pass.set_bind_group(0, &vbg, &[]);
            pass.draw(0..HULL_VERTICES, 0..count);
        }
        return;
    }
    enc.clear_buffer(&lists.state, 0, None);
    enc.clear_buffer(&lists.sums, 0, None);
    {
        let mut pass = super::caustics_pass_timed(enc, &cv, "transport select", None, Some(depth));
        if count > 0 {
            pass.set_pipeline(&p.select);
            pass.set_bind_group(0, &vbg, &[]);
            pass.draw(0..HULL_VERTICES, 0..count);
        }
    }
    let obg = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("transport gather"),
        layout: &p.output_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&cv),
        }],
    });
    {
        let mut pass = compute_pass(enc, "transport list args", None, [&vbg, &obg]);
        pass.set_pipeline(&p.list_args);
        pass.dispatch_workgroups(1, 1, 1);
    }
    enc.copy_buffer_to_buffer(&lists.state, 4, &lists.args, 0, 12);
    {
        let mut pass = compute_pass(enc, "transport evaluate", None, [&vbg, &obg]);
        pass.set_pipeline(&p.evaluate);
        pass.dispatch_workgroups_indirect(&lists.args, 0);
    }
    let mut pass = compute_pass(
        enc,
        "transport resolve",
        ts.map(|(t, k)| t.compute_writes(k, false, true)),
        [&vbg, &obg],
    );
    pass.set_pipeline(&p.resolve);
    pass.dispatch_workgroups(gbuf.width.div_ceil(8), gbuf.height.div_ceil(8), 1);
}

/// A compute pass with the volume and output bind groups set.
fn compute_pass<'e>(
    enc: &'e mut wgpu::CommandEncoder,
    label: &str,
    timestamp_writes: Option<wgpu::ComputePassTimestampWrites<'_>>,
    groups: [&wgpu::BindGroup; 2],
) -> wgpu::ComputePass<'e> {
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes,
    });
    pass.set_bind_group(0, groups[0], &[]);
    pass.set_bind_group(1, groups[1], &[]);
    pass
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The sums' unit follows the frame's brightest volume, so a scene lit a billion times more
    /// dimly keeps the same relative precision; without volumes it is still positive.
    #[test]
    fn the_sums_unit_scales_with_the_light() {
        let volume = |f: f32| Volume {
            exits: [Vec3::ZERO; 3],
            dirs: [Vec3::NEG_Y; 3],
            flux_density: [Vec3::splat(f), Vec3::splat(0.5 * f), Vec3::ZERO],
            source_area: 1.0,
            length: 1.0,
        };
        let bright = sums_unit(&[volume(3.0), volume(1.0)]);
        assert!((bright - 3.0 / std::f32::consts::PI / 256.0).abs() < 1e-6 * bright);
        let dim = sums_unit(&[volume(3e-9), volume(1e-9)]);
        assert!((dim / bright - 1e-9).abs() < 1e-12, "{dim} {bright}");
        assert!(sums_unit(&[]) > 0.0);
    }
}
