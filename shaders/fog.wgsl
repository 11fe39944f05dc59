// Method beams' in-scattering pass (render/beams/gpu.rs): the fog lit directly by the delta
// lights, single scattering (the `volume` component; the light that reached the fog through
// glass or off mirrors is the beams' own). Per pixel, the view ray's part inside the medium, up
// to the first surface, is ray-marched at stratified, jittered points: at each, every light's
// irradiance (spot falloff, 1/r²), its shadow map's visibility, the medium's transmittance on
// the light's way and on the eye's, σs and the Henyey-Greenstein phase function. The paper
// drew this part with a ray-marched pass of its own as well (Liktor and Dachsbacher 2010, §5).

#include "shadow_lookup.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(11) var gbuf_position: texture_2d<f32>;
@group(0) @binding(12) var gbuf_normal: texture_2d<f32>;

// Points along each view ray.
const MARCH_STEPS: u32 = 64u;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

fn view_dir(xy: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>((xy.x / g.viewport.x) * 2.0 - 1.0, 1.0 - (xy.y / g.viewport.y) * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    return normalize(far.xyz / far.w - g.eye.xyz);
}


// A number in [0, 1) from the pixel (the march's jitter).
fn jitter(p: vec2<u32>) -> f32 {
    var x = p.x * 1664525u + p.y * 22695477u + 1013904223u;
    x = (x ^ (x >> 16u)) * 2246822519u;
    x = (x ^ (x >> 13u)) * 3266489917u;
    x = x ^ (x >> 16u);
    return f32(x >> 8u) / 16777216.0;
}

@fragment
fn fs_inscatter(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let px = vec2<i32>(frag.xy);
    let eye = g.eye.xyz;
    let d = view_dir(frag.xy);
    let gn = textureLoad(gbuf_normal, px, 0);
    var s_scene = 1e30;
    if dot(gn.xyz, gn.xyz) > 0.0 {
        s_scene = distance(textureLoad(gbuf_position, px, 0).xyz, eye);
    }
    let m = box_interval(g.medium_to_local, g.medium_half.xyz, eye, d);
    let lo = m.x;
    let hi = min(m.y, s_scene);
    if hi <= lo {
        return vec4<f32>(0.0);
    }
    let ds = (hi - lo) / f32(MARCH_STEPS);
    let j = jitter(vec2<u32>(px));
    let st = g.medium_sigma_t.rgb;
    let gg = g.medium_sigma_s.w;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < MARCH_STEPS; k++) {
        let t = lo + (f32(k) + j) * ds;
        let x = eye + d * t;
        let to_eye = exp(-st * (t - lo));
        for (var i = 0u; i < g.counts.x; i++) {
            let at = light_at(i, x);
            if all(at.e <= vec3<f32>(0.0)) {
                continue;
            }
            let vis = shadow_factor(i, x, at.wi, at.dist);
            if vis <= 0.0 {
                continue;
            }
            let directional = lights[i].kind == LIGHT_DIRECTIONAL;
            let through = light_transmittance(g, x, at, directional);
            // The light travels along −wi; the eye is along −d from x.
            sum += at.e * vis * through * hg(gg, dot(at.wi, d)) * to_eye;
        }
    }
    return vec4<f32>(sum * g.medium_sigma_s.rgb * ds, 0.0);
}
