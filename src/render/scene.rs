//! The world flattened for the GPU: one vertex buffer in world space (position, smooth normal,
//! material index), one index buffer, the material table. Every pass draws the same buffers.
//! They are kept per scene ([`SceneCache`]): a frame of the same objects and materials (camera
//! and lights may differ) uploads nothing.

use super::blockers::Blockers;
use crate::scene::{Material, Mesh, World};
use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// One vertex as the passes read it (44 bytes, locations 0..=3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Vertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub material: u32,
    /// Glass vertices under method `transport`: the radiance seen through the object along
    /// the viewing ray the vertex's table refracts (rgb), w = 1 where set (Iwasaki et al. 2005 §5.3);
    /// zero elsewhere.
    pub view: [f32; 4],
}

pub const VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 4] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Uint32, 3 => Float32x4];

pub fn vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<Vertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &VERTEX_ATTRIBUTES,
    }
}

/// Material kinds, as `common.inc.wgsl` numbers them.
pub const MAT_DIFFUSE: u32 = 0;
pub const MAT_GLOSSY: u32 = 1;
pub const MAT_DIELECTRIC: u32 = 2;
pub const MAT_MIRROR: u32 = 3;

/// `Material` of `common.inc.wgsl` (layout checked against naga's in `render::shaders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub kind: u32,
    pub roughness: f32,
    pub ior: f32,
    pub _pad: u32,
    pub albedo: [f32; 4],
    /// rgb: F0 of the glossy lobe; a dielectric's absorption coefficient (1/m).
    pub specular: [f32; 4],
}

impl GpuMaterial {
    pub fn from_material(m: &Material) -> Self {
        let v4 = |v: glam::Vec3| [v.x, v.y, v.z, 0.0];
        let mut g = GpuMaterial::zeroed();
        match *m {
            Material::Diffuse { albedo } => {
                g.kind = MAT_DIFFUSE;
                g.albedo = v4(albedo);
            }
            Material::Glossy {
                albedo,
                specular,
                roughness,
            } => {
                g.kind = MAT_GLOSSY;
                g.albedo = v4(albedo);
                g.specular = v4(specular);
                g.roughness = roughness;
            }
            Material::Dielectric { ior, absorption } => {
                g.kind = MAT_DIELECTRIC;
                g.ior = ior;
                // Unused by glossy-only code; method photons reads Beer-Lambert from it.
                g.specular = v4(absorption);
            }
            Material::Mirror { reflectance } => {
                g.kind = MAT_MIRROR;
                g.albedo = v4(reflectance);
            }
        }
        g
    }
}

/// CPU-side packed geometry.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    /// Never empty (a grey diffuse default when the world has none), so the buffer binds.
    pub materials: Vec<GpuMaterial>,
}

impl PackedScene {
    /// Index of the first vertex of each part of object `oi` (parts in order).
    pub fn part_bases(world: &World, oi: usize) -> Vec<usize> {
        let mut base: usize = world.objects[..oi]
            .iter()
            .flat_map(|o| &o.parts)
            .map(|p| p.mesh.positions.len())
            .sum();
        world.objects[oi]
            .parts
            .iter()
            .map(|p| {
                let b = base;
                base += p.mesh.positions.len();
                b
            })
            .collect()
    }

    pub fn pack(world: &World) -> PackedScene {
        let mut s = PackedScene::default();
        for o in &world.objects {
            let nm = o.transform.inverse().transpose();
            let flip = o.transform.determinant() < 0.0;
            for part in &o.parts {
                let base = s.vertices.len() as u32;
                let mesh = &part.mesh;
                for (i, p) in mesh.positions.iter().enumerate() {
                    let n = mesh.normals.get(i).copied().unwrap_or(glam::Vec3::Y);
                    let wp = o.transform.transform_point3(*p);
                    let wn = nm.transform_vector3(n).normalize_or(glam::Vec3::Y);
                    s.vertices.push(Vertex {
                        position: wp.to_array(),
                        normal: wn.to_array(),
                        material: part.material,
                        view: [0.0; 4],
                    });
                }
                for t in &mesh.indices {
                    let t = if flip { [t[0], t[2], t[1]] } else { *t };
                    s.indices.extend(t.iter().map(|i| base + i));
                }
            }
        }
        s.materials = world
            .materials
            .iter()
            .map(GpuMaterial::from_material)
            .collect();
        if s.materials.is_empty() {
            s.materials
                .push(GpuMaterial::from_material(&Material::Diffuse {
                    albedo: glam::Vec3::splat(0.5),
                }));
        }
        let max = s.materials.len() as u32 - 1;
        for v in &mut s.vertices {
            v.material = v.material.min(max);
        }
        s
    }
}

/// The scene's buffers on the device.
pub struct SceneBuffers {
    /// None when the world has no triangle (nothing is drawn).
    vertices: Option<wgpu::Buffer>,
    indices: Option<wgpu::Buffer>,
    pub index_count: u32,
    pub materials: wgpu::Buffer,
}

impl SceneBuffers {
    fn upload(device: &wgpu::Device, s: &PackedScene) -> SceneBuffers {
        let init = |label, contents: &[u8], usage| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
        };
        let copy = wgpu::BufferUsages::COPY_DST;
        let (vertices, indices) = if s.indices.is_empty() {
            (None, None)
        } else {
            (
                Some(init(
                    "vertices",
                    bytemuck::cast_slice(&s.vertices),
                    wgpu::BufferUsages::VERTEX | copy,
                )),
                Some(init(
                    "indices",
                    bytemuck::cast_slice(&s.indices),
                    wgpu::BufferUsages::INDEX,
                )),
            )
        };
        SceneBuffers {
            vertices,
            indices,
            index_count: s.indices.len() as u32,
            materials: init(
                "materials",
                bytemuck::cast_slice(&s.materials),
                wgpu::BufferUsages::STORAGE,
            ),
        }
    }

    /// The vertex and index buffers, when there is anything to draw.
    pub fn geometry(&self) -> Option<(&wgpu::Buffer, &wgpu::Buffer)> {
        self.vertices.as_ref().zip(self.indices.as_ref())
    }
}

/// The occluders of caustic light on the device ([`Blockers`]).
pub struct BlockerBuffers {
    pub nodes: wgpu::Buffer,
    pub triangles: wgpu::Buffer,
}

impl BlockerBuffers {
    fn upload(device: &wgpu::Device, b: &Blockers) -> BlockerBuffers {
        let init = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        BlockerBuffers {
            nodes: init("occluder nodes", bytemuck::cast_slice(&b.nodes)),
            triangles: init("occluder triangles", bytemuck::cast_slice(&b.triangles)),
        }
    }
}

type ObjectKey = (Mat4, Vec<(Arc<Mesh>, u32)>);

/// What a scene's buffers are made of: every object's transform and parts (meshes are shared,
/// immutable `Arc`s, so the same mesh is recognised by its pointer before its content) and
/// the materials.
#[derive(Clone, Debug, Default)]
struct SceneKey {
    /// Per object: its transform and (mesh, material index) per part.
    objects: Vec<ObjectKey>,
    materials: Vec<Material>,
}

impl SceneKey {
    fn of(world: &World) -> SceneKey {
        SceneKey {
            objects: world
                .objects
                .iter()
                .map(|o| {
                    let parts = o
                        .parts
                        .iter()
                        .map(|p| (p.mesh.clone(), p.material))
                        .collect();
                    (o.transform, parts)
                })
                .collect(),
            materials: world.materials.clone(),
        }
    }

    fn matches(&self, world: &World) -> bool {
        self.materials == world.materials
            && self.objects.len() == world.objects.len()
            && self
                .objects
                .iter()
                .zip(&world.objects)
                .all(|((t, parts), o)| {
                    *t == o.transform
                        && parts.len() == o.parts.len()
                        && parts.iter().zip(&o.parts).all(|((m, mat), p)| {
                            *mat == p.material && (Arc::ptr_eq(m, &p.mesh) || **m == *p.mesh)
                        })
                })
    }
}

/// The buffers of the last scene rendered.
#[derive(Default)]
pub struct SceneCache {
    key: Option<SceneKey>,
    packed: PackedScene,
    buffers: Option<SceneBuffers>,
    /// Counts uploads: what is derived from the scene ([`OccluderCache`]) is keyed by it.
    generation: u64,
    /// Whether the vertex buffer holds a transport frame's view radiance (else zero).
    view_written: bool,
}

impl SceneCache {
    /// The buffers of `world`, uploaded when its objects or materials changed, and their
    /// generation; with `view` (method transport), its glass vertices carry the radiance seen
    /// through them.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        world: &World,
        view: Option<&super::transport::TransportLayer>,
    ) -> (&SceneBuffers, u64) {
        if self.buffers.is_none() || !self.key.as_ref().is_some_and(|k| k.matches(world)) {
            self.packed = PackedScene::pack(world);
            self.buffers = Some(SceneBuffers::upload(device, &self.packed));
            self.key = Some(SceneKey::of(world));
            self.generation += 1;
            self.view_written = false;
        }
        let buffers = self.buffers.as_ref().expect("uploaded above");
        if let Some(vb) = &buffers.vertices
            && (view.is_some() || self.view_written)
        {
            match view {
                Some(l) => {
                    let mut s = PackedScene {
                        vertices: self.packed.vertices.clone(),
                        ..Default::default()
                    };
                    l.apply_view(world, &mut s);
                    queue.write_buffer(vb, 0, bytemuck::cast_slice(&s.vertices));
                }
                None => queue.write_buffer(vb, 0, bytemuck::cast_slice(&self.packed.vertices)),
            }
            self.view_written = view.is_some();
        }
        (buffers, self.generation)
    }
}

impl SceneCache {
    /// The buffers of the last [`SceneCache::prepare`].
    pub fn buffers(&self) -> Option<&SceneBuffers> {
        self.buffers.as_ref()
    }
}

/// The occluders of the caustic light of the last frame with caustics.
#[derive(Default)]
pub struct OccluderCache {
    /// The scene generation and caustic objects they were built for (None: the placeholder of
    /// a frame without caustics).
    key: Option<(u64, Option<Vec<usize>>)>,
    buffers: Option<BlockerBuffers>,
}

impl OccluderCache {
    /// The occluders of the caustic light of `caustic_objects`: every other object's triangles
    /// (a placeholder without caustics), built when the scene or the set changed.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        world: &World,
        generation: u64,
        caustic_objects: Option<&[usize]>,
    ) -> &BlockerBuffers {
        let key = (generation, caustic_objects.map(<[usize]>::to_vec));
        if self.buffers.is_none() || self.key.as_ref() != Some(&key) {
            let b = match caustic_objects {
                Some(c) => Blockers::build(world, |i| !c.contains(&i)),
                None => Blockers::from_triangles(&[]),
            };
            self.buffers = Some(BlockerBuffers::upload(device, &b));
            self.key = Some(key);
        }
        self.buffers.as_ref().expect("built above")
    }
}
