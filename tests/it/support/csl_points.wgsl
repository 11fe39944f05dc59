// CSL evaluation at a list of receiver points (position, normal): the summed irradiance of all
// CSLs per unit light irradiance, without occlusion. It runs the same functions the per-pixel
// CSL pass uses (shaders/csl.inc.wgsl); the csl_gpu tests check it against the CPU.

struct Params {
    csl_count: u32,
    point_count: u32,
    pad0: u32,
    pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> csls: array<Csl>;
@group(0) @binding(3) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> normals: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> result: array<vec4<f32>>;

#include "csl.inc.wgsl"

@compute @workgroup_size(64)
fn eval_points(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if (k >= params.point_count) {
        return;
    }
    let x = points[k].xyz;
    let n = normals[k].xyz;
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < params.csl_count; i++) {
        sum += csl_irradiance(csls[i], x, n);
    }
    result[k] = vec4<f32>(sum, 1.0);
}
