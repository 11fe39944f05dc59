// Underwater caustics, the pass that lights the receivers (Sanchez-Crespo 2003;
// render/water/gpu.rs). Each pixel's receiver point q under the water is the G-buffer's, or,
// where the camera looks at the water from above, the first receiver the view ray meets once
// the wave surface has refracted it (a ray cast through the frame's blockers, which are every
// object but the water surfaces). Its irradiance comes, by water.counts.w, from
//   0: the article's method per pixel: a ray towards the sun as a flat surface refracts it, up
//      to the wave surface at s; the waves' analytic normal at s refracts it out into the air,
//      and the sun map exp(-(theta/width)^2) of its angle theta to the sun gives the
//      brightness, calibrated on the CPU so that its mean over the floor is 1; times the flat
//      surface's irradiance and Beer-Lambert along |q - s|, shadowed by blockers on the way;
//   1, 2: the light map (water_map.wgsl: the physical mode's splatted refracted grid, or the
//      article's irradiance per texel), read at q's texel where nothing lies between q and the
//      surface along the refracted sun: at 3 x 3 points over the pixel's footprint, each
//      trilinearly at the level of a third of it (1), or once, trilinearly at the level of
//      the whole footprint (2).
// The receiver reflects it (albedo / pi, or its glossy lobe) towards the camera, attenuated
// along the water the view ray crosses and, from above, by the surface's Fresnel
// transmittance times eta^2. Seen from above it also reflects the sunlight the body's open
// sides let in (side_light; seen directly, the direct pass draws that light).
// What the camera sees directly goes to the caustics layer (location 0), what it sees through
// the waves to the specular layer (location 1): a path the camera sees through a specular
// surface is specular light, in every method and in the reference (docs/design.md).

#include "water.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(10) var gbuf_position: texture_2d<f32>;
@group(0) @binding(11) var gbuf_normal: texture_2d<f32>;
// The light map's levels, finest first, each row by row (water_map.wgsl; one placeholder
// texel when the pass evaluates per pixel).
@group(0) @binding(12) var<storage, read> pyramid: array<vec4<f32>>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle over the whole target.
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

// The receiver's BRDF for light from the refracted sun (wi) seen from wo.
fn receiver_brdf(m: Material, n: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if m.kind == MAT_GLOSSY {
        return glossy_brdf(n, water.up.xyz, wo, m.albedo.rgb, m.specular.rgb, m.roughness);
    }
    return m.albedo.rgb / PI;
}

// Where level `level` of the light map lies in the pyramid: its first texel (x) and its texels
// a side (y). Level k has ceil(res / 2^k) texels a side, after those of the finer levels.
fn map_level(level: u32) -> vec2<u32> {
    var first = 0u;
    var n = water.grid.w;
    for (var k = 0u; k < level; k++) {
        first += n * n;
        n = (n + 1u) >> 1u;
    }
    return vec2<u32>(first, n);
}

// Bilinear read of the light map's level at `lv` (map_level's) at map coordinates uv; 0
// outside the map.
fn map_read(uv: vec2<f32>, lv: vec2<u32>) -> vec3<f32> {
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) {
        return vec3<f32>(0.0);
    }
    let first = lv.x;
    let n = lv.y;
    let c = uv * f32(n) - 0.5;
    let f = floor(c);
    let w = c - f;
    let i = vec2<i32>(f);
    let hi = i32(n) - 1;
    let x0 = u32(clamp(i.x, 0, hi));
    let x1 = u32(clamp(i.x + 1, 0, hi));
    let y0 = u32(clamp(i.y, 0, hi));
    let y1 = u32(clamp(i.y + 1, 0, hi));
    let t00 = pyramid[first + y0 * n + x0].rgb;
    let t10 = pyramid[first + y0 * n + x1].rgb;
    let t01 = pyramid[first + y1 * n + x0].rgb;
    let t11 = pyramid[first + y1 * n + x1].rgb;
    return mix(mix(t00, t10, w.x), mix(t01, t11, w.x), w.y);
}

// The two levels a footprint of `texels` finest texels falls between, and the weight of the
// coarser one.
struct MapLod {
    fine: vec2<u32>,
    coarse: vec2<u32>,
    t: f32,
}

fn map_lod(texels: f32) -> MapLod {
    let top = f32(water.counts.z - 1u);
    let lod = clamp(log2(max(texels, 1.0)), 0.0, top);
    let l0 = u32(floor(lod));
    let l1 = min(l0 + 1u, water.counts.z - 1u);
    return MapLod(map_level(l0), map_level(l1), lod - f32(l0));
}

// The light map read trilinearly at uv between the levels of `lod`.
fn map_trilinear(uv: vec2<f32>, lod: MapLod) -> vec3<f32> {
    return mix(map_read(uv, lod.fine), map_read(uv, lod.coarse), lod.t);
}

// The light map's irradiance at q (unit normal n), `foot` metres across the pixel's footprint.
fn map_irradiance(q: vec3<f32>, n: vec3<f32>, foot: f32) -> vec3<f32> {
    let u = water.up.xyz;
    if dot(n, u) <= 0.0 {
        return vec3<f32>(0.0);
    }
    // Shadowed along the refracted sun up to below the lowest trough: the light landing on
    // q's texel belongs to what shadows it.
    let o = q + n * 1e-4;
    let t = (water.centre.y - water.beam.w - o.y) / u.y;
    if t > 0.0 && occluded(o, u, t) {
        return vec3<f32>(0.0);
    }
    let uv = map_uv(q);
    let texel = max(water.map.z, water.map.w) / f32(water.grid.w);
    if water.counts.w == 1u {
        // The pixel's area average, as the CPU's 3 x 3 points a pixel: 3 x 3 reads over a
        // square of the footprint's side, each at the level of its third of it.
        let h = foot / max(water.map.z, water.map.w);
        let lod = map_lod(foot / (3.0 * texel));
        var sum = vec3<f32>(0.0);
        for (var k = 0; k < 9; k++) {
            let o = vec2<f32>(f32(k % 3 - 1), f32(k / 3 - 1)) * (h / 3.0);
            sum += map_trilinear(uv + o, lod);
        }
        return sum / 9.0;
    }
    return map_trilinear(uv, map_lod(foot / texel));
}

// The irradiance at q (unit normal n) under the water, the way the pass was asked for.
fn irradiance_at(q: vec3<f32>, n: vec3<f32>, foot: f32) -> vec3<f32> {
    if water.counts.w == 0u {
        return irradiance(q, n);
    }
    return map_irradiance(q, n, foot);
}

// The view ray through pixel position xy (framebuffer coordinates).
fn view_dir(xy: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>((xy.x / g.viewport.x) * 2.0 - 1.0, 1.0 - (xy.y / g.viewport.y) * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    return normalize(far.xyz / far.w - g.eye.xyz);
}

// The pass's two layers.
struct Layers {
    @location(0) caustics: vec4<f32>,
    @location(1) specular: vec4<f32>,
}

const NONE = Layers(vec4<f32>(0.0), vec4<f32>(0.0));

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> Layers {
    let px = vec2<i32>(frag.xy);
    let gp = textureLoad(gbuf_position, px, 0);
    let gn = textureLoad(gbuf_normal, px, 0);
    let eye = g.eye.xyz;
    let d = view_dir(frag.xy);
    // The angle one pixel spans, for the footprint.
    let pixel_angle = length(view_dir(frag.xy + vec2<f32>(1.0, 0.0)) - d);
    if gp.w > 0.0 {
        // A receiver seen directly: under the water, or not lit by it.
        let q = gp.xyz;
        if !in_water(q + normalize(gn.xyz) * 1e-3) {
            return NONE;
        }
        let m = materials[u32(gn.w)];
        let through = water_beer(eye, q);
        let n = normalize(gn.xyz);
        let wo = normalize(eye - q);
        let foot = distance(eye, q) * pixel_angle / sqrt(max(dot(n, wo), 0.0625));
        let e = irradiance_at(q, n, foot);
        return Layers(vec4<f32>(receiver_brdf(m, n, wo) * e * through, 0.0), vec4<f32>(0.0));
    }
    // Seen through the waves from above: the view ray refracted at the surface, on to the
    // first receiver under it.
    var t_max = 1e30;
    if gp.w < 0.0 || dot(gp.xyz, gp.xyz) > 0.0 {
        // Something is drawn there: the surface must come before it (or at it).
        t_max = distance(eye, gp.xyz) + 0.05;
    }
    let t = cross_surface(eye, d, t_max);
    if t < 0.0 {
        return NONE;
    }
    let s = eye + d * t;
    let ns = normal_at(s);
    if dot(d, ns) >= 0.0 {
        return NONE;
    }
    let eta = 1.0 / water.size.w;
    let r = refract(d, ns, eta);
    if dot(r, r) == 0.0 {
        return NONE;
    }
    let o = s + r * 1e-4;
    let hit = closest_hit(o, r, 1e30);
    if hit.tri == 0xffffffffu {
        return NONE;
    }
    let q = o + r * hit.t;
    let n = blocker_normal(hit.tri, r);
    if !in_water(q + n * 1e-3) {
        return NONE;
    }
    let m = materials[u32(blocker_tris[hit.tri].v0.w)];
    let tr = (1.0 - fresnel_dielectric(-dot(d, ns), eta)) * eta * eta;
    // The footprint grows along the refracted ray about as the path's length; its side is
    // the geometric mean of its axes (1 across, 1 / cos along the receiver's slope).
    let foot = (t + hit.t) * pixel_angle / sqrt(max(dot(n, -r), 0.0625));
    let e = irradiance_at(q, n, foot) + side_light(q, n);
    return Layers(vec4<f32>(0.0), vec4<f32>(receiver_brdf(m, n, -r) * e * tr * beer(hit.t), 0.0));
}
