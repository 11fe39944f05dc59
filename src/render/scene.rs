//! The world flattened for the GPU: one vertex buffer in world space (position, smooth normal,
//! material index), one index buffer, the material table. Rebuilt per render; later passes
//! (caustics) draw the same buffers.

use crate::scene::{Material, World};
use bytemuck::{Pod, Zeroable};

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

/// `Material` of `common.inc.wgsl` (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuMaterial {
    pub kind: u32,
    pub roughness: f32,
    pub ior: f32,
    pub _pad: u32,
    pub albedo: [f32; 4],
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
            Material::Dielectric { ior, .. } => {
                g.kind = MAT_DIELECTRIC;
                g.ior = ior;
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
