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
}

impl CslLayer {
    /// The layer of a render: every (object index, its set) placed where the object is now, lit
    /// by a directional light of `irradiance` (W/m²).
    pub fn new(world: &World, sets: &[(usize, &CslSet)], irradiance: Vec3) -> CslLayer {
        let mut csls = Vec::new();
        let mut caustic_objects = Vec::new();
        for &(oi, set) in sets {
            csls.extend(set.to_world(world.objects[oi].rigid_transform()));
            caustic_objects.push(oi);
        }
        CslLayer {
            csls,
            irradiance,
            caustic_objects,
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

/// CSL parameters and packed texels (two u32 words per RGB texel) for upload.
pub fn pack(csls: &[Csl]) -> (Vec<GpuCsl>, Vec<u32>) {
    let mut params = Vec::with_capacity(csls.len());
    let mut words = Vec::new();
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
            texel_offset: words.len() as u32,
            pad: [0; 2],
        });
        for t in &c.texels {
            words.push(t[0] as u32 | (t[1] as u32) << 16);
            words.push(t[2] as u32);
        }
    }
    if words.is_empty() {
        words.push(0);
    }
    (params, words)
}

/// The CSLs of a frame packed for upload: never-empty arrays (placeholders when no CSL is
/// bound; `Globals::counts[3]` says how many are real).
pub struct CslBuffers {
    pub params: Vec<GpuCsl>,
    pub texels: Vec<u32>,
}

impl CslBuffers {
    pub fn new(csls: &[Csl]) -> Self {
        let (mut params, texels) = pack(csls);
        if params.is_empty() {
            params.push(GpuCsl::zeroed());
        }
        CslBuffers { params, texels }
    }
}
