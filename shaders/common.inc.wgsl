// Shared code for Caustica's passes: the uniform layouts the Rust side mirrors
// (render/direct.rs), Mitsuba's spot falloff, the Glossy BRDF that scene/types.rs defines as
// the contract (albedo/π + GGX D · height-correlated Smith G2 · Schlick F / (4 cosθi cosθo),
// α = roughness²), Schlick Fresnel for dielectrics and the equirectangular mapping of
// scene/world.rs `env_uv`. It is pasted textually where a pass says `#include`, so it holds
// types and functions only, no bindings.

const PI: f32 = 3.141592653589793;

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;

const MAT_DIFFUSE: u32 = 0u;
const MAT_GLOSSY: u32 = 1u;
const MAT_DIELECTRIC: u32 = 2u;
const MAT_MIRROR: u32 = 3u;

struct Globals {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz: camera position.
    eye: vec4<f32>,
    // rgb: constant environment radiance (sum of constant environment lights).
    env_radiance: vec4<f32>,
    // rgb: multiplier of the environment map; w: 1 when a map is bound.
    env_map_scale: vec4<f32>,
    // x: number of lights (the sky's directions follow them, see `sky`), y/z: environment map
    // size, w: number of caustic spot lights.
    counts: vec4<u32>,
    // xy: viewport size in pixels.
    viewport: vec4<f32>,
    // Irradiance from the environment as 9 SH coefficients (cosine lobe already applied).
    sh: array<vec4<f32>, 9>,
    // rgb: irradiance (W/m²) of the directional light the caustic spot lights carry.
    csl_irradiance: vec4<f32>,
    // The participating medium the direct light crosses on its way to a surface (method beams
    // sets it, or a water body's absorption: render/water/gpu.rs DirectMedium; medium_half.x =
    // 0: none): world → its box's frame, the box's half extents (w: 1 when the way back to the
    // camera crosses it too, as a water body's), σt, σs and g.
    medium_to_local: mat4x4<f32>,
    medium_half: vec4<f32>,
    medium_sigma_t: vec4<f32>,
    // rgb: σs; w: Henyey-Greenstein g.
    medium_sigma_s: vec4<f32>,
    // The environment's sky directions in `lights` (render/sky.rs): x the first, y how many.
    sky: vec4<u32>,
}

// A shadowed delta light. Line lights arrive as several point lights.
struct Light {
    kind: u32,
    // First layer of the shadow map array; n_layers: 0 (unshadowed), 1, or 6 (cube faces +X, -X, +Y, -Y, +Z, -Z).
    first_layer: u32,
    n_layers: u32,
    // 1 for an orthographic shadow map (texel size constant), 0 for perspective.
    ortho: u32,
    position: vec4<f32>,
    // xyz: travel direction (directional) or beam axis (spot).
    direction: vec4<f32>,
    // rgb: irradiance W/m² (directional) or intensity W/sr (point, spot).
    intensity: vec4<f32>,
    // x: cutoff (rad), y: beam width (rad), z: shadow texel size (world units; per unit distance when perspective).
    params: vec4<f32>,
    mats: array<mat4x4<f32>, 6>,
}

struct Material {
    kind: u32,
    roughness: f32,
    ior: f32,
    _pad: u32,
    // rgb: albedo (diffuse, glossy) or reflectance (mirror).
    albedo: vec4<f32>,
    // rgb: F0 of the glossy lobe; a dielectric's absorption coefficient (1/m, method photons).
    specular: vec4<f32>,
}

// The part [t0, t1] of o + t·d (t ≥ 0) inside the box of half extents `h` in the frame that
// `to_local` maps the world into; t0 > t1 when none (or when h.x is 0: no box).
fn box_interval(to_local: mat4x4<f32>, h: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    if h.x <= 0.0 {
        return vec2<f32>(1.0, 0.0);
    }
    let lo = (to_local * vec4<f32>(o, 1.0)).xyz;
    let ld = (to_local * vec4<f32>(d, 0.0)).xyz;
    var t0 = 0.0;
    var t1 = 1e30;
    for (var k = 0; k < 3; k++) {
        if abs(ld[k]) < 1e-20 {
            if abs(lo[k]) > h[k] {
                return vec2<f32>(1.0, 0.0);
            }
        } else {
            let a = (-h[k] - lo[k]) / ld[k];
            let b = (h[k] - lo[k]) / ld[k];
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        }
    }
    return vec2<f32>(t0, t1);
}

// Henyey-Greenstein (1/sr) for cos θ between the light's travel before and after scattering
// (scene/medium.rs `hg`; g > 0 forward).
fn hg(gg: f32, cos_t: f32) -> f32 {
    let d = 1.0 + gg * gg - 2.0 * gg * cos_t;
    return (1.0 - gg * gg) / (4.0 * PI * d * sqrt(max(d, 1e-12)));
}

// Mitsuba's spot: 1 inside the beam width, linear in angle down to 0 at the cutoff.
fn spot_falloff(cos_theta: f32, cutoff: f32, beam_width: f32) -> f32 {
    if cos_theta <= cos(cutoff) {
        return 0.0;
    }
    if cos_theta >= cos(beam_width) {
        return 1.0;
    }
    let theta = acos(clamp(cos_theta, -1.0, 1.0));
    return clamp((cutoff - theta) / max(cutoff - beam_width, 1e-6), 0.0, 1.0);
}

fn smith_lambda(cos_t: f32, a2: f32) -> f32 {
    let c2 = max(cos_t * cos_t, 1e-12);
    let tan2 = max(1.0 - c2, 0.0) / c2;
    return 0.5 * (-1.0 + sqrt(1.0 + a2 * tan2));
}

// f(wi, wo) of the Glossy material; n, wi, wo unit, wi and wo pointing away from the surface.
fn glossy_brdf(n: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>, albedo: vec3<f32>, f0: vec3<f32>, roughness: f32) -> vec3<f32> {
    let ci = dot(n, wi);
    let co = dot(n, wo);
    if ci <= 0.0 || co <= 0.0 {
        return vec3<f32>(0.0);
    }
    let alpha = max(roughness * roughness, 1e-3);
    let a2 = alpha * alpha;
    let h = normalize(wi + wo);
    let nh = max(dot(n, h), 0.0);
    let d0 = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * d0 * d0);
    let g2 = 1.0 / (1.0 + smith_lambda(ci, a2) + smith_lambda(co, a2));
    let f = f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - clamp(dot(wi, h), 0.0, 1.0), 5.0);
    return albedo / PI + d * g2 * f / (4.0 * ci * co);
}

// Unpolarised Fresnel reflectance of a dielectric for cos_i of the incident angle and
// eta = n_incident / n_transmitted (1 beyond the critical angle), as trace::optics.
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let c = clamp(cos_i, 0.0, 1.0);
    let sin2_t = eta * eta * (1.0 - c * c);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (eta * c - cos_t) / (eta * c + cos_t);
    let rp = (c - eta * cos_t) / (c + eta * cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

// Schlick's approximation for a dielectric interface with relative index `ior`.
fn fresnel_schlick_ior(cos_i: f32, ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    let f0 = r * r;
    return f0 + (1.0 - f0) * pow(1.0 - clamp(cos_i, 0.0, 1.0), 5.0);
}

// Equirectangular coordinates in [0,1)² of the direction d towards the light, as Mitsuba 3's
// `envmap`: u = atan2(d.x, -d.z)/2π wrapped (0 at -Z, 1/4 at +X), v = acos(d.y)/π (0 at +Y).
fn env_uv(d: vec3<f32>) -> vec2<f32> {
    let u = atan2(d.x, -d.z) / (2.0 * PI);
    let v = acos(clamp(d.y, -1.0, 1.0)) / PI;
    return vec2<f32>(fract(u), v);
}

// Environment irradiance on a surface with normal n, from 9 SH coefficients (Ramamoorthi &
// Hanrahan 2001, cosine convolution already folded into the coefficients).
fn sh_irradiance(sh: array<vec4<f32>, 9>, n: vec3<f32>) -> vec3<f32> {
    var e = sh[0].rgb * 0.282095;
    e += sh[1].rgb * (0.488603 * n.y);
    e += sh[2].rgb * (0.488603 * n.z);
    e += sh[3].rgb * (0.488603 * n.x);
    e += sh[4].rgb * (1.092548 * n.x * n.y);
    e += sh[5].rgb * (1.092548 * n.y * n.z);
    e += sh[6].rgb * (0.315392 * (3.0 * n.z * n.z - 1.0));
    e += sh[7].rgb * (1.092548 * n.x * n.z);
    e += sh[8].rgb * (0.546274 * (n.x * n.x - n.y * n.y));
    return max(e, vec3<f32>(0.0));
}

// Unit geometric normal from the screen derivatives dx, dy of the world position, turned to the
// side of the shading normal n (n itself where the derivatives are degenerate).
fn facing_geometric_normal(dx: vec3<f32>, dy: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let ng = cross(dx, dy);
    let l = length(ng);
    if l <= 0.0 {
        return n;
    }
    return select(ng / l, -ng / l, dot(ng, n) < 0.0);
}

// What the G-buffer holds of a fragment at world point p with interpolated normal `normal`, of
// material `material` (its `kind`), seen from `eye` (gbuffer.wgsl's pass, and direct.wgsl's
// fs_main_gbuffer that writes it in the direct pass; fragment stage only): `position.w` is the
// pixel's reach (> 0) on a receiver seen from its front (the side Mitsuba-like one-sided BSDFs
// answer), 0 elsewhere (specular objects, back faces); `normal.w` is the material index;
// `geometric` the surface's geometric normal, facing the camera.
struct GOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) geometric: vec4<f32>,
}

fn gbuffer_texel(p: vec3<f32>, normal: vec3<f32>, material: u32, kind: u32, eye: vec3<f32>) -> GOut {
    let n = normalize(normal);
    let ng = facing_geometric_normal(dpdx(p), dpdy(p), n);
    let v = normalize(eye - p);
    var out: GOut;
    let receiver = kind != MAT_DIELECTRIC && kind != MAT_MIRROR && dot(ng, v) > 0.0 && dot(n, v) > 0.0;
    // Half the footprint's two sides, with margin for the perspective (no corner is farther).
    let reach = max(0.75 * (length(dpdx(p)) + length(dpdy(p))), 1e-9);
    out.position = vec4<f32>(p, select(0.0, reach, receiver));
    out.normal = vec4<f32>(n, f32(material));
    out.geometric = vec4<f32>(ng, 0.0);
    return out;
}
