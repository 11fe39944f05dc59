// Direct pass: one forward pass over all geometry that writes three HDR layers of linear
// radiance W/(m²·sr). `direct`: receivers (diffuse, glossy) lit by every delta light with PCF
// shadows from the shadow map array (an environment's suns among them, render/sky.rs), plus
// environment irradiance from spherical harmonics (diffuse lobe only) shadowed by the sky's
// visibility (`sky_visibility`), and the visible environment behind everything (fullscreen
// background draw). `specular`: the specular objects themselves, mirror = reflectance
// × environment in the reflected direction, glass = Schlick-Fresnel mix of the environment in
// the reflected and (first-interface) refracted directions, or, under method transport, the
// reflected environment plus what the vertices' refracted viewing rays see (the `view`
// attribute, interpolated). Specular objects are 0 in `direct`, receivers 0 in `specular`.
// `caustics` is cleared by this pass (rgb 0, alpha 1) and written by no fragment of it; the
// caustics methods' passes write it afterwards (method csl: csl.wgsl). Surfaces are one-sided
// like Mitsuba's BSDFs: seen from the back, or lit from behind, they get nothing.

#include "shadow_lookup.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(5) var env_map: texture_2d<f32>;
// The sky directions' shadow maps (render/sky.rs), compared with `shadow_sampler`.
@group(0) @binding(10) var sky_maps: texture_depth_2d_array;

// What the frame needs compiled in (render/direct.rs `Variant`): an environment map, a medium
// on the light's way (method beams), glossy receivers, the sky's shadow maps. Without them the pipeline is made
// without their code, which every pixel would otherwise run under a mask on llvmpipe.
override HAS_ENV_MAP: bool = true;
override HAS_MEDIUM: bool = true;
override HAS_GLOSSY: bool = true;
override HAS_SKY: bool = true;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
    // Method transport, glass: radiance seen through the object (rgb) and how much of the
    // pixel it covers (w, 1 inside triangles whose vertices all have it).
    @location(3) view: vec4<f32>,
}

// Location 2, the caustics layer, is cleared by the pass and written by no fragment here.
struct FsOut {
    @location(0) direct: vec4<f32>,
    @location(1) specular: vec4<f32>,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) material: u32, @location(3) view: vec4<f32>) -> VsOut {
    var out: VsOut;
    out.clip = g.view_proj * vec4<f32>(position, 1.0);
    out.world = position;
    out.normal = normal;
    out.material = material;
    out.view = view;
    return out;
}

// Radiance arriving from direction d (unit), as scene/world.rs EnvMap::lookup: bilinear as
// Mitsuba's `envmap`, column i centred on u = (i + 0.5)/W (u wraps), row j on v = j/(H - 1).
fn env_radiance(d: vec3<f32>) -> vec3<f32> {
    var l = g.env_radiance.rgb;
    if HAS_ENV_MAP && g.env_map_scale.w > 0.5 {
        let uv = env_uv(d);
        let w = g.counts.y;
        let h = g.counts.z;
        let hm = max(h, 2u);
        let x = fract(uv.x - 0.5 / f32(w)) * f32(w);
        let y = clamp(uv.y, 0.0, 1.0) * f32(hm - 1u);
        let x0 = min(u32(x), w - 1u);
        let y0 = min(u32(y), hm - 2u);
        let fx = x - f32(x0);
        let fy = y - f32(y0);
        let x1 = (x0 + 1u) % w;
        let y1 = min(y0 + 1u, h - 1u);
        let yt = min(y0, h - 1u);
        let top = mix(textureLoad(env_map, vec2<u32>(x0, yt), 0).rgb,
                      textureLoad(env_map, vec2<u32>(x1, yt), 0).rgb, fx);
        let bottom = mix(textureLoad(env_map, vec2<u32>(x0, y1), 0).rgb,
                         textureLoad(env_map, vec2<u32>(x1, y1), 0).rgb, fx);
        l += g.env_map_scale.rgb * mix(top, bottom, fy);
    }
    return l;
}

// The direct pass of a frame whose caustics pass reads a G-buffer: the same shading, and the
// G-buffer (gbuffer.wgsl's outputs, at locations 3..5) from the same fragments, instead of a
// second pass over the geometry.
struct FsOutG {
    @location(0) direct: vec4<f32>,
    @location(1) specular: vec4<f32>,
    @location(3) position: vec4<f32>,
    @location(4) normal: vec4<f32>,
    @location(5) geometric: vec4<f32>,
}

@fragment
fn fs_main_gbuffer(in: VsOut) -> FsOutG {
    let shaded = shade(in);
    let gb = gbuffer_texel(in.world, in.normal, in.material, materials[in.material].kind, g.eye.xyz);
    var out: FsOutG;
    out.direct = shaded.direct;
    out.specular = shaded.specular;
    out.position = gb.position;
    out.normal = gb.normal;
    out.geometric = gb.geometric;
    return out;
}

@fragment
fn fs_main(in: VsOut) -> FsOut {
    return shade(in);
}

fn shade(in: VsOut) -> FsOut {
    let p = in.world;
    let n = normalize(in.normal);
    let dx = dpdx(p);
    let dy = dpdy(p);
    let ng = facing_geometric_normal(dx, dy, n);
    let v = normalize(g.eye.xyz - p);
    let m = materials[in.material];
    var out: FsOut;
    out.direct = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    out.specular = vec4<f32>(0.0, 0.0, 0.0, 1.0);

    if m.kind == MAT_DIELECTRIC || m.kind == MAT_MIRROR {
        var ns = n;
        if dot(ng, v) < 0.0 {
            ns = -ns; // open meshes seen from behind: reflect off the side we see
        }
        let cos_o = clamp(dot(ns, v), 0.0, 1.0);
        let r = reflect(-v, ns);
        if m.kind == MAT_MIRROR {
            out.specular = vec4<f32>(m.albedo.rgb * env_radiance(r), 1.0);
        } else {
            let f = fresnel_schlick_ior(cos_o, m.ior);
            let t = refract(-v, ns, 1.0 / m.ior);
            // Through the glass: the transport tables' refracted viewing rays where they were
            // followed (Iwasaki et al. 2005 §5.3; the transmittance is in `view`), else the environment
            // in the first-interface refracted direction.
            let through = in.view.rgb + (1.0 - clamp(in.view.w, 0.0, 1.0)) * (1.0 - f) * env_radiance(t);
            out.specular = vec4<f32>(f * env_radiance(r) + through, 1.0);
        }
        return out;
    }

    // Receivers: one-sided.
    let cos_o = dot(n, v);
    if dot(ng, v) <= 0.0 || cos_o <= 0.0 {
        return out;
    }
    let albedo = m.albedo.rgb;
    var l = vec3<f32>(0.0);
    for (var i = 0u; i < g.counts.x; i++) {
        let kind = lights[i].kind;
        let at = light_at(i, p);
        let wi = at.wi;
        var e = at.e;
        let dist = at.dist;
        let cos_i = dot(n, wi);
        if cos_i <= 0.0 || dot(ng, wi) <= 0.0 || all(e <= vec3<f32>(0.0)) {
            continue;
        }
        let vis = shadow_factor(i, p, ng, dist);
        if vis <= 0.0 {
            continue;
        }
        // The medium on the light's way here (method beams; none otherwise).
        if HAS_MEDIUM {
            e *= light_transmittance(g, p, at, kind == LIGHT_DIRECTIONAL);
        }
        var f = albedo / PI;
        if HAS_GLOSSY && m.kind == MAT_GLOSSY {
            f = glossy_brdf(n, wi, v, albedo, m.specular.rgb, m.roughness);
        }
        l += f * e * cos_i * vis;
    }
    // Environment (without its suns, lit above): diffuse lobe only, shadowed.
    var sky = 1.0;
    if HAS_SKY {
        sky = sky_visibility(p, n, ng);
    }
    l += albedo / PI * sh_irradiance(g.sh, n) * sky;
    if HAS_MEDIUM && g.medium_half.w > 0.5 {
        // A water body (render/water/gpu.rs DirectMedium): its water on the way back to the
        // camera too (method beams adds the fog's on that way in a pass of its own).
        let to_p = p - g.eye.xyz;
        let dist = length(to_p);
        let iv = box_interval(g.medium_to_local, g.medium_half.xyz, g.eye.xyz, to_p / dist);
        l *= exp(-g.medium_sigma_t.rgb * max(min(iv.y, dist) - iv.x, 0.0));
    }
    out.direct = vec4<f32>(l, 1.0);
    return out;
}

// The fraction of the environment's SH irradiance that reaches p: the sky's median-cut
// directions (render/sky.rs; `lights[g.sky.x ..][.. g.sky.y]`, each weighing its region's power
// in intensity.x, its map a layer of `sky_maps`) above the surface, weighted by power × cosine,
// each seen through one bilinear compare of its shadow map (their many edges blur into each
// other). 1 where no direction lies above the surface.
fn sky_visibility(p: vec3<f32>, n: vec3<f32>, ng: vec3<f32>) -> f32 {
    var seen = 0.0;
    var total = 0.0;
    for (var k = g.sky.x; k < g.sky.x + g.sky.y; k++) {
        let wi = -lights[k].direction.xyz;
        let c = dot(n, wi);
        if c <= 0.0 || dot(ng, wi) <= 0.0 {
            continue;
        }
        let w = lights[k].intensity.x * c;
        total += w;
        let q = p + ng * (2.0 * lights[k].params.z);
        let clip = lights[k].mats[0] * vec4<f32>(q, 1.0);
        let ndc = clip.xyz / clip.w;
        let uv = vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
        var v = 1.0;
        if all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0)) && ndc.z <= 1.0 {
            v = textureSampleCompareLevel(sky_maps, shadow_sampler, uv, lights[k].first_layer, ndc.z);
        }
        seen += w * v;
    }
    if total <= 0.0 {
        return 1.0;
    }
    return seen / total;
}

// Background: a fullscreen triangle at the far plane, drawn after the geometry with a
// less-equal depth test, so it only covers pixels no surface did.
@vertex
fn vs_background(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    let x = f32((vi << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(vi & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 1.0, 1.0);
}

@fragment
fn fs_background(@builtin(position) frag: vec4<f32>) -> FsOut {
    let ndc = vec2<f32>(frag.x / g.viewport.x * 2.0 - 1.0, 1.0 - frag.y / g.viewport.y * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let d = normalize(far.xyz / far.w - g.eye.xyz);
    var out: FsOut;
    // The environment seen directly is emitted light reaching the camera with no bounce: it
    // belongs to `direct`, as in the reference renderer.
    out.direct = vec4<f32>(env_radiance(d), 1.0);
    out.specular = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    return out;
}
