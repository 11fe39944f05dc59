//! The CSL passes (method `csl`, Liu et al. 2008 §2): caustic spot lights evaluated per pixel
//! on the G-buffer's receivers in compute passes culled per tile ([`pass`], `shaders/csl.wgsl`;
//! the evaluation in `shaders/csl.inc.wgsl`, occlusion by the non-caustic objects in
//! `shaders/occlusion.inc.wgsl` over [`super::blockers`]). Here: the frame's CSLs ([`CslLayer`])
//! and their packing for upload; the set of a dynamic bake for the frame's light direction
//! ([`interpolate`]); the CPU evaluation the passes are checked against ([`eval`]).

pub mod eval;
pub mod interpolate;
pub mod pass;

use crate::bake::csl::{Csl, CslSet};
use crate::scene::World;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// The caustic spot lights of a frame (method `csl`), already placed in the world
/// ([`CslSet::to_world`]).
#[derive(Clone, Debug, Default)]
pub struct CslLayer {
    pub csls: Vec<crate::bake::csl::Csl>,
    /// Irradiance (W/m²) of the directional light the CSLs were baked for.
    pub irradiance: Vec3,
    /// Indices into `World::objects` of the caustic objects: they do not occlude their own
    /// caustic light; every other object does.
    pub caustic_objects: Vec<usize>,
    /// Names the CSLs' intensity images (the sets they came from, by content hash), so that
    /// the renderer keeps them on the device between frames and uploads only the CSLs' few
    /// parameters; None: uploaded every frame.
    pub images_key: Option<u64>,
}

impl CslLayer {
    /// The layer of a render: every (object index, its set) placed where the object is now, lit
    /// by a directional light of `irradiance` (W/m²).
    pub fn new(world: &World, sets: &[(usize, &CslSet)], irradiance: Vec3) -> CslLayer {
        let mut csls = Vec::new();
        let mut caustic_objects = Vec::new();
        // A set's images are those of its bake (placing it moves its CSLs, not their images),
        // and its source hash names its bake's inputs: an interpolated set's includes the
        // light direction.
        let mut key = crate::bake::Fnv64::new();
        key.write(b"csl images");
        for &(oi, set) in sets {
            csls.extend(set.to_world(world.objects[oi].rigid_transform()));
            caustic_objects.push(oi);
            key.write(&set.source_hash.to_le_bytes());
            key.write(&set.params_hash.to_le_bytes());
            for c in &set.csls {
                key.write_u32(c.size);
                key.write(&(c.texels.len() as u64).to_le_bytes());
            }
        }
        CslLayer {
            csls,
            irradiance,
            caustic_objects,
            images_key: Some(key.finish()),
        }
    }
}

/// `struct Csl` of csl.inc.wgsl (layout checked against naga's in `render::shaders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuCsl {
    pub origin: [f32; 3],
    pub kappa: f32,
    pub axis: [f32; 3],
    pub gamma: f32,
    pub x_axis: [f32; 3],
    pub half_extent: f32,
    pub y_axis: [f32; 3],
    pub scale: f32,
    pub size: u32,
    pub texel_offset: u32,
    pub pad: [u32; 2],
}

/// The CSLs' parameters for upload, each pointing at its image in the packed texels of
/// [`pack_texels`]; never empty (a placeholder when no CSL is bound: `Globals::counts[3]` says
/// how many are real).
pub fn pack_params(csls: &[Csl]) -> Vec<GpuCsl> {
    let mut params = Vec::with_capacity(csls.len().max(1));
    let mut offset = 0;
    for c in csls {
        params.push(GpuCsl {
            origin: c.origin.to_array(),
            kappa: c.kappa,
            axis: c.axis.to_array(),
            gamma: c.gamma,
            x_axis: c.x_axis.to_array(),
            half_extent: c.half_extent,
            y_axis: c.y_axis().to_array(),
            scale: c.scale / 65535.0,
            size: c.size,
            texel_offset: offset,
            pad: [0; 2],
        });
        offset += 2 * c.texels.len() as u32;
    }
    if params.is_empty() {
        params.push(GpuCsl::zeroed());
    }
    params
}

/// The CSLs' intensity images packed for upload (two u32 words per RGB texel, in order);
/// never empty.
pub fn pack_texels(csls: &[Csl]) -> Vec<u32> {
    let mut words: Vec<u32> = csls
        .iter()
        .flat_map(|c| &c.texels)
        .flat_map(|t| [t[0] as u32 | (t[1] as u32) << 16, t[2] as u32])
        .collect();
    if words.is_empty() {
        words.push(0);
    }
    words
}
