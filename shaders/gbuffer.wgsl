// G-buffer of the per-pixel caustics passes (render/gbuffer.rs; csl, transport, pinhole, water,
// beams and photons read it) as a pass of its own, for adapters whose render passes cannot take
// it beside the direct pass's layers (direct.wgsl's fs_main_gbuffer writes it there otherwise):
// per pixel, the visible surface's world position and shading normal, for receivers only
// (common.inc.wgsl's gbuffer_texel; 0 on the background).

#include "common.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) material: u32) -> VsOut {
    var out: VsOut;
    out.clip = g.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.normal = normal;
    out.material = material;
    return out;
}

@fragment
fn fs_main(in: VsOut) -> GOut {
    return gbuffer_texel(in.world, in.normal, in.material, materials[in.material].kind, g.eye.xyz);
}
