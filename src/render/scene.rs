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

/// An object's triangles in the index buffer, and where a raster pass may cull its back faces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectDraw {
    /// Its first index and how many it has.
    pub first: u32,
    pub count: u32,
    /// The world bounds of an object whose every part is closed and wound outwards
    /// ([`Mesh::is_closed_outward`]): seen from outside them, its back faces are hidden behind
    /// its front faces. None for the others.
    pub closed_bounds: Option<(glam::Vec3, glam::Vec3)>,
}

impl ObjectDraw {
    /// Whether a camera of `view_proj` (depth 0 at its near plane) sees only this object's
    /// front faces: it is closed and all of its bounds lie beyond the near plane, so the eye is
    /// outside it and no front face is clipped away to show a back face behind it.
    pub fn back_faces_hidden(&self, view_proj: Mat4) -> bool {
        self.closed_bounds.is_some_and(|(lo, hi)| {
            super::lights::corners(lo, hi).iter().all(|c| {
                let p = view_proj * c.extend(1.0);
                p.w > 0.0 && p.z > 0.0
            })
        })
    }
}

/// Whether `mesh` is closed and wound outwards, remembered while it lives: a scene is packed
/// again whenever an object moves, and the check welds and sorts every edge. Sound for the
/// reason [`crate::bake::memo_by_meshes`] gives; a memo of its own, so that a scene of many
/// meshes does not push the bake hashes out of that one.
fn closed_outward(mesh: &Arc<Mesh>) -> bool {
    use std::sync::{Mutex, Weak};
    /// Meshes remembered at most (the oldest forgotten first).
    const KEEP: usize = 4096;
    static MEMO: Mutex<Vec<(Weak<Mesh>, bool)>> = Mutex::new(Vec::new());
    let memo = || MEMO.lock().unwrap_or_else(|e| e.into_inner());
    let same = |e: &(Weak<Mesh>, bool)| e.0.as_ptr() == Arc::as_ptr(mesh) && e.0.strong_count() > 0;
    if let Some(e) = memo().iter().find(|e| same(e)) {
        return e.1;
    }
    let closed = mesh.is_closed_outward();
    let mut memo = memo();
    memo.retain(|e| e.0.strong_count() > 0);
    if !memo.iter().any(same) {
        if memo.len() >= KEEP {
            memo.remove(0);
        }
        memo.push((Arc::downgrade(mesh), closed));
    }
    closed
}

/// CPU-side packed geometry.
#[derive(Clone, Debug, Default)]
pub struct PackedScene {
    pub vertices: Vec<Vertex>,
    pub indices: Vec<u32>,
    /// Per object, in order: its range of `indices`.
    pub draws: Vec<ObjectDraw>,
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
            // A mirroring transform turns the winding over; the indices are turned back below,
            // so a mesh wound outwards stays so in the world.
            let flip = o.transform.determinant() < 0.0;
            let first = s.indices.len() as u32;
            let first_vertex = s.vertices.len();
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
            let closed = !o.parts.is_empty() && o.parts.iter().all(|p| closed_outward(&p.mesh));
            let closed_bounds = closed.then(|| {
                s.vertices[first_vertex..].iter().fold(
                    (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
                    |(lo, hi), v| {
                        let p = glam::Vec3::from(v.position);
                        (lo.min(p), hi.max(p))
                    },
                )
            });
            s.draws.push(ObjectDraw {
                first,
                count: s.indices.len() as u32 - first,
                closed_bounds,
            });
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
    /// Each object's range of the index buffer, and whether it is closed.
    pub draws: Vec<ObjectDraw>,
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
            draws: s.draws.clone(),
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

#[cfg(test)]
mod tests {
    use super::PackedScene;
    use crate::scene::{Camera, Material, Object, Part, World, shapes};
    use glam::{Mat4, Vec3};
    use std::sync::Arc;

    /// The pack marks the closed sphere (moved and mirrored: its winding turned back) with its
    /// world bounds and the open floor not; the sphere's back faces are hidden from a camera
    /// outside it, not from one inside it or one whose near plane cuts into its bounds.
    #[test]
    fn closed_objects_seen_from_outside_hide_their_back_faces() {
        let part = |mesh, material| Part {
            mesh: Arc::new(mesh),
            material,
        };
        let centre = Vec3::new(0.0, 0.6, 0.0);
        let world = World {
            name: "cull".into(),
            camera: Camera {
                eye: Vec3::new(0.0, 3.0, 3.0),
                target: Vec3::ZERO,
                up: Vec3::Y,
                fov_y: 40.0,
                width: 64,
                height: 48,
            },
            lights: vec![],
            materials: vec![Material::Diffuse {
                albedo: Vec3::splat(0.5),
            }],
            objects: vec![
                Object {
                    name: "floor".into(),
                    parts: vec![part(shapes::plane(4.0, 4.0), 0)],
                    transform: Mat4::IDENTITY,
                },
                Object {
                    name: "ball".into(),
                    parts: vec![part(shapes::sphere(0.5, 24), 0)],
                    transform: Mat4::from_translation(centre)
                        * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
                },
            ],
            warnings: vec![],
            water: vec![],
            media: vec![],
            has_ground: false,
        };
        let s = PackedScene::pack(&world);
        assert_eq!(s.draws.len(), 2);
        assert_eq!(s.draws[0].first, 0);
        assert_eq!(s.draws[1].first, s.draws[0].count);
        assert_eq!(s.draws[1].first + s.draws[1].count, s.indices.len() as u32);
        assert!(s.draws[0].closed_bounds.is_none(), "the floor is open");
        let (lo, hi) = s.draws[1].closed_bounds.expect("the ball is closed");
        assert!((lo - (centre - 0.5)).abs().max_element() < 1e-5, "{lo}");
        assert!((hi - (centre + 0.5)).abs().max_element() < 1e-5, "{hi}");
        let view_proj = |eye: Vec3, near: f32| {
            let cam = Camera {
                eye,
                ..world.camera.clone()
            };
            cam.proj_matrix(near, 100.0) * cam.view_matrix()
        };
        let ball = s.draws[1];
        assert!(ball.back_faces_hidden(view_proj(Vec3::new(0.0, 3.0, 3.0), 0.01)));
        assert!(!ball.back_faces_hidden(view_proj(centre, 0.01)), "inside");
        assert!(
            !ball.back_faces_hidden(view_proj(Vec3::new(0.0, 0.6, 0.7), 0.5)),
            "the near plane cuts into it"
        );
        assert!(!s.draws[0].back_faces_hidden(view_proj(Vec3::new(0.0, 3.0, 3.0), 0.01)));
    }
}
