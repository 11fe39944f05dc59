// The delta lights and their shadow maps, as the direct pass reads them (the shadow pass fills
// the maps): declares the lights (group 0, binding 1), the shadow map array (3) and its
// comparison sampler (4) itself, so that it validates on its own; a pass that includes it binds
// them there. Method beams' in-scattering pass shares it with the direct pass.

#include "common.inc.wgsl"

@group(0) @binding(1) var<storage, read> lights: array<Light>;
@group(0) @binding(3) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(4) var shadow_sampler: sampler_comparison;

// Fraction of light `i` reaching p (PCF 3×3 of bilinear compare taps). `n_l` is the surface
// normal turned towards the light, used for the normal-offset bias; `dist` the distance to the
// light (perspective texel size grows with it).
fn shadow_factor(i: u32, p: vec3<f32>, n_l: vec3<f32>, dist: f32) -> f32 {
    let n_layers = lights[i].n_layers;
    if n_layers == 0u {
        return 1.0;
    }
    var texel = lights[i].params.z;
    if lights[i].ortho == 0u {
        texel = texel * dist;
    }
    let q = p + n_l * (2.0 * texel);
    var face = 0u;
    if n_layers == 6u {
        let d = q - lights[i].position.xyz;
        let a = abs(d);
        if a.x >= a.y && a.x >= a.z {
            face = select(1u, 0u, d.x > 0.0);
        } else if a.y >= a.z {
            face = select(3u, 2u, d.y > 0.0);
        } else {
            face = select(5u, 4u, d.z > 0.0);
        }
    }
    let c = lights[i].mats[face] * vec4<f32>(q, 1.0);
    if c.w <= 0.0 {
        return 1.0;
    }
    let ndc = c.xyz / c.w;
    let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || ndc.z > 1.0 {
        return 1.0;
    }
    let layer = lights[i].first_layer + face;
    // PCF 3×3 of bilinear compare taps one texel apart: per axis, the 4 texels around the
    // point weigh (1 - f, 1, 1, f) (f: the point's fraction between texel centres), so the
    // 4×4 block is read with four gathers of 2×2 compares instead of nine filtered taps.
    let size = vec2<f32>(textureDimensions(shadow_maps));
    let t = uv * size - 0.5;
    let base = floor(t);
    let f = t - base;
    let wx = array<f32, 4>(1.0 - f.x, 1.0, 1.0, f.x);
    let wy = array<f32, 4>(1.0 - f.y, 1.0, 1.0, f.y);
    var sum = 0.0;
    for (var b = 0; b < 4; b += 2) {
        for (var a = 0; a < 4; a += 2) {
            // The 2×2 block from texel base + (a - 1, b - 1): x (u_min, v_max), y (u_max,
            // v_max), z (u_max, v_min), w (u_min, v_min).
            let at = (base + vec2<f32>(f32(a), f32(b))) / size;
            let c = textureGatherCompare(shadow_maps, shadow_sampler, at, layer, ndc.z);
            sum += c.x * wx[a] * wy[b + 1] + c.y * wx[a + 1] * wy[b + 1]
                + c.z * wx[a + 1] * wy[b] + c.w * wx[a] * wy[b];
        }
    }
    return sum / 9.0;
}


// Light `i` at p: the unit direction towards it, the irradiance facing it (a spot's falloff and
// 1/r² included) and the distance to it (1 for a directional light).
struct LightAt {
    wi: vec3<f32>,
    e: vec3<f32>,
    dist: f32,
}

fn light_at(i: u32, p: vec3<f32>) -> LightAt {
    var out: LightAt;
    out.dist = 1.0;
    if lights[i].kind == LIGHT_DIRECTIONAL {
        out.wi = -lights[i].direction.xyz;
        out.e = lights[i].intensity.rgb;
        return out;
    }
    let to_l = lights[i].position.xyz - p;
    out.dist = length(to_l);
    out.wi = to_l / max(out.dist, 1e-6);
    var falloff = 1.0;
    if lights[i].kind == LIGHT_SPOT {
        let ct = dot(-out.wi, lights[i].direction.xyz);
        falloff = spot_falloff(ct, lights[i].params.x, lights[i].params.y);
    }
    out.e = lights[i].intensity.rgb * falloff / max(out.dist * out.dist, 1e-12);
    return out;
}

// The medium's transmittance from p to light `at` (Globals' medium; 1 without one).
fn light_transmittance(g: Globals, p: vec3<f32>, at: LightAt, directional: bool) -> vec3<f32> {
    let fog = box_interval(g.medium_to_local, g.medium_half.xyz, p, at.wi);
    if fog.x >= fog.y {
        return vec3<f32>(1.0);
    }
    var reach = 1e30;
    if !directional {
        reach = at.dist;
    }
    return exp(-g.medium_sigma_t.rgb * max(min(fog.y, reach) - fog.x, 0.0));
}
