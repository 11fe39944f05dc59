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
        let blockers = crate::trace::Accel::build_with(
            world,
            |i| !caustic_objects.contains(&i),
            obvhs::BvhBuildParams::fast_build(),
        );
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
        let scene =
            crate::trace::Accel::build_with(world, |_| true, obvhs::BvhBuildParams::fast_build());
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

/// The volume pipeline, created once per device.
pub struct TransportPipelines {
    pub volume: wgpu::RenderPipeline,
    pub volume_layout: wgpu::BindGroupLayout,
}

/// Vertices drawn per volume or beam (`HULL_VERTICES` of hull.inc.wgsl).
pub const HULL_VERTICES: u32 = 12;

impl TransportPipelines {
    pub fn new(device: &wgpu::Device) -> TransportPipelines {
        let entry = super::layout_entry;
        let vf = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let frag = wgpu::ShaderStages::FRAGMENT;
        let (uniform, storage) = (super::UNIFORM_BINDING, super::STORAGE_BINDING);
        let texture = super::texture_binding(false);
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
            ],
        });
        let module = |name: &str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(shaders::source(name).into()),
            })
        };
        let tmod = module("transport.wgsl");
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
        let volume = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("transport volumes"),
            layout: Some(&layout(&volume_layout)),
            vertex: wgpu::VertexState {
                module: &tmod,
                entry_point: Some("vs_volume"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive,
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &tmod,
                entry_point: Some("fs_volume"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR_FORMAT,
                    blend: Some(add),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        TransportPipelines {
            volume,
            volume_layout,
        }
    }
}

/// The volumes buffer of a frame (never empty: a zero volume that covers nothing when there is
/// none, so the binding stays valid).
pub fn upload_volumes(device: &wgpu::Device, volumes: &[Volume]) -> wgpu::Buffer {
    let mut packed: Vec<GpuVolume> = volumes.iter().map(GpuVolume::pack).collect();
    if packed.is_empty() {
        packed.push(GpuVolume::zeroed());
    }
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("transport volumes"),
        contents: bytemuck::cast_slice(&packed),
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// Encodes the volume pass over the G-buffer `gbuf` (drawn before it, after the direct pass,
/// which cleared the caustics layer); `globals` is the frame's camera uniform.
#[allow(clippy::too_many_arguments)]
pub fn encode(
    device: &wgpu::Device,
    enc: &mut wgpu::CommandEncoder,
    p: &TransportPipelines,
    gbuf: &GBuffer,
    scene: &SceneBuffers,
    globals: &wgpu::Buffer,
    blockers: &BlockerBuffers,
    volumes: &wgpu::Buffer,
    count: u32,
    targets: &Targets,
    timestamps: Option<&mut Timestamps>,
) {
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
                resource: volumes.as_entire_binding(),
            },
        ],
    });
    let cv = targets.caustics.create_view(&Default::default());
    let mut pass = super::caustics_pass(enc, &cv, "transport", timestamps);
    if count > 0 {
        pass.set_pipeline(&p.volume);
        pass.set_bind_group(0, &vbg, &[]);
        pass.draw(0..HULL_VERTICES, 0..count);
    }
}
