// G-buffer of the per-pixel caustics passes (render/gbuffer.rs; transport and pinhole read it):
// per pixel, the visible surface's world position and shading normal, for receivers only.
// `position.w` is the pixel's reach (> 0) on a receiver seen from its front (the side Mitsuba-like one-sided BSDFs answer), 0 elsewhere
// (specular objects, back faces, background); `normal.w` is the material index; `geometric` is
// the surface's geometric normal, facing the camera (method csl's footprints and shadow rays).

#include "common.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
}

struct GOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) geometric: vec4<f32>,
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
    let p = in.world;
    let n = normalize(in.normal);
    let ng = facing_geometric_normal(dpdx(p), dpdy(p), n);
    let v = normalize(g.eye.xyz - p);
    let kind = materials[in.material].kind;
    var out: GOut;
    let receiver = kind != MAT_DIELECTRIC && kind != MAT_MIRROR && dot(ng, v) > 0.0 && dot(n, v) > 0.0;
    // Half the footprint's two sides, with margin for the perspective (no corner is farther).
    let reach = max(0.75 * (length(dpdx(p)) + length(dpdy(p))), 1e-9);
    out.position = vec4<f32>(p, select(0.0, reach, receiver));
    out.normal = vec4<f32>(n, f32(in.material));
    out.geometric = vec4<f32>(ng, 0.0);
    return out;
}
