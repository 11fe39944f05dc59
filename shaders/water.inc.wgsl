// The water for the passes of method water (Sanchez-Crespo 2003; render/water/gpu.rs): its
// uniform, the wave function and its analytic gradient, the march to the wave surface, Beer-
// Lambert, and the article's irradiance at a receiver point. Brings common.inc.wgsl and
// occlusion.inc.wgsl with it.

#include "common.inc.wgsl"
#include "occlusion.inc.wgsl"

struct Water {
    // xyz: the rectangle's centre at the mean surface height; w: depth of the body.
    centre: vec4<f32>,
    // xy: the rectangle's size (x, z); z: time (s, for the record); w: the water's index of
    // refraction.
    size: vec4<f32>,
    // rgb: absorption per metre; w: 0 for the article's waves, 1 for sine waves.
    absorption: vec4<f32>,
    // The article's waves: amplitude, frequency, factor, and the phase time x speed (modulo
    // 2 pi, reduced on the CPU in f64).
    article: vec4<f32>,
    // x: octaves; y: sine waves; z: mip levels of the light map; w: how the pass finds the
    // irradiance: 0 the article per pixel, 1 the light map at 3 x 3 points over the pixel's
    // footprint, 2 the light map once at the footprint's level.
    counts: vec4<u32>,
    // xyz: the sun's travel direction; w: the sun map's width (radians).
    sun: vec4<f32>,
    // rgb: irradiance on a surface facing the refracted sun under a flat surface, times the
    // calibration; w: a bound on |height - mean|.
    beam: vec4<f32>,
    // xyz: towards the sun in the water (the flat surface's refraction, reversed); w: the
    // march step along the surface, metres (a sixteenth of the shortest wavelength).
    up: vec4<f32>,
    // The light map (render/water/gpu.rs): xy, its corner (x, z) on the mean surface plane;
    // zw, its extent (x, z) in metres. A receiver point q maps to where the line through it
    // along the refracted sun meets that plane, so that whatever shadows q along the sun
    // shares its texel.
    map: vec4<f32>,
    // x: the physical mode's sun rays per side, minus one (grid quads); y: its directions over
    // the sun's disc; z: 1 when receivers above the water can shade the surface; w: light
    // map texels per side.
    grid: vec4<u32>,
    // rgb: the sun's irradiance per direction over its disc (E / directions); w: those
    // directions (so that rgb * w is E).
    sun_e: vec4<f32>,
    // The physical splat: x, the least spread radius per metre of refracted path (the sun
    // disc's blur per direction); y, the least spread radius (metres); z, how far a landed
    // triangle's corners may lie off one plane; w, a grid triangle's area dx dz / 2.
    splat: vec4<f32>,
}

@group(0) @binding(20) var<uniform> water: Water;
// Two per sine wave: (k.x, k.z, amplitude, omega), (phase - omega t modulo 2 pi, 0, 0, 0).
@group(0) @binding(21) var<storage, read> waves: array<vec4<f32>>;

// Height above the mean surface (x) and its gradient (y: d/dx, z: d/dz) at world (px, pz).
fn wave(px: f32, pz: f32) -> vec3<f32> {
    let lx = px - water.centre.x;
    let lz = pz - water.centre.z;
    if water.absorption.w < 0.5 {
        // z = 2 A d sum_i -f_i cos(t S + u v W / f_i), u, v in [0, 1] across the rectangle,
        // heights in units of its x side.
        let a = water.article;
        let s = water.size.xy;
        let u = lx / s.x + 0.5;
        let v = lz / s.y + 0.5;
        let d = sqrt(u * u + v * v);
        var c = 0.0;
        var sn = 0.0;
        var f = a.z;
        for (var i = 0u; i < water.counts.x; i++) {
            let ph = a.w + u * v * a.y / f;
            c -= f * cos(ph);
            sn += sin(ph);
            f *= 0.5;
        }
        let z = 2.0 * a.x * d * c;
        var du = 0.0;
        var dv = 0.0;
        if d > 0.0 {
            du = u / d;
            dv = v / d;
        }
        let zu = 2.0 * a.x * (du * c + d * sn * v * a.y);
        let zv = 2.0 * a.x * (dv * c + d * sn * u * a.y);
        return vec3<f32>(z * s.x, zu, zv * s.x / s.y);
    }
    var h = 0.0;
    var gx = 0.0;
    var gz = 0.0;
    for (var i = 0u; i < water.counts.y; i++) {
        let w = waves[2u * i];
        let ph = w.x * lx + w.y * lz + waves[2u * i + 1u].x;
        h += w.z * sin(ph);
        let c = w.z * cos(ph);
        gx += w.x * c;
        gz += w.y * c;
    }
    return vec3<f32>(h, gx, gz);
}

fn inside_rect(p: vec3<f32>) -> bool {
    let l = abs(p.xz - water.centre.xz);
    return l.x <= 0.5 * water.size.x && l.y <= 0.5 * water.size.y;
}

fn above(p: vec3<f32>) -> f32 {
    return p.y - (water.centre.y + wave(p.x, p.z).x);
}

// The first crossing of o + t d (0 < t < t_max) with the surface over the rectangle: marched
// inside the slab the waves stay in, refined by regula falsi; t < 0 when there is none.
fn cross_surface(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> f32 {
    let a = water.beam.w + 1e-4;
    var t0 = 1e-6;
    var t1 = t_max;
    if abs(d.y) < 1e-9 {
        if abs(o.y - water.centre.y) > a {
            return -1.0;
        }
    } else {
        let ta = (water.centre.y - a - o.y) / d.y;
        let tb = (water.centre.y + a - o.y) / d.y;
        t0 = max(t0, min(ta, tb));
        t1 = min(t1, max(ta, tb));
    }
    // And inside the rectangle's x and z slabs.
    let half = 0.5 * water.size.xy;
    let lo = water.centre.xz - half;
    let hi = water.centre.xz + half;
    for (var k = 0u; k < 2u; k++) {
        let oc = select(o.z, o.x, k == 0u);
        let dc = select(d.z, d.x, k == 0u);
        let l = select(lo.y, lo.x, k == 0u);
        let h = select(hi.y, hi.x, k == 0u);
        if abs(dc) < 1e-12 {
            if oc < l || oc > h {
                return -1.0;
            }
        } else {
            let ta = (l - oc) / dc;
            let tb = (h - oc) / dc;
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    if t0 >= t1 {
        return -1.0;
    }
    let horiz = max(length(d.xz), 1e-6);
    let step = max(water.up.w / horiz, (t1 - t0) / 256.0);
    var ta = t0;
    var fa = above(o + d * ta);
    for (var k = 0u; k < 256u && ta < t1; k++) {
        let tb = min(ta + step, t1);
        let fb = above(o + d * tb);
        if sign(fa) != sign(fb) {
            var lo = ta;
            var hi = tb;
            var flo = fa;
            var fhi = fb;
            var t = 0.5 * (lo + hi);
            for (var j = 0u; j < 16u; j++) {
                t = (lo * fhi - hi * flo) / (fhi - flo);
                if !(t > lo && t < hi) {
                    t = 0.5 * (lo + hi);
                }
                let ft = above(o + d * t);
                if abs(ft) < 1e-7 {
                    break;
                }
                if sign(ft) == sign(flo) {
                    lo = t;
                    flo = ft;
                } else {
                    hi = t;
                    fhi = ft;
                }
            }
            if inside_rect(o + d * t) {
                return t;
            }
        }
        ta = tb;
        fa = fb;
    }
    return -1.0;
}

fn normal_at(p: vec3<f32>) -> vec3<f32> {
    let w = wave(p.x, p.z);
    return normalize(vec3<f32>(-w.y, 1.0, -w.z));
}

fn beer(len: f32) -> vec3<f32> {
    return exp(-water.absorption.rgb * len);
}

fn in_water(p: vec3<f32>) -> bool {
    return inside_rect(p) && p.y > water.centre.y - water.centre.w - 1e-3 && above(p) < 0.0;
}


// The part [t0, t1] of o + t d (any d) inside the body's box (the rectangle, from the bottom
// up to the highest crest): common.inc.wgsl's box_interval about the box's centre; t0 >= t1
// where the line misses it.
fn body_interval(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let bottom = -water.centre.w - 1e-3;
    let top = water.beam.w;
    let c = water.centre.xyz + vec3<f32>(0.0, 0.5 * (bottom + top), 0.0);
    let h = vec3<f32>(0.5 * water.size.x, 0.5 * (top - bottom), 0.5 * water.size.y);
    let to_local = mat4x4<f32>(
        vec4<f32>(1.0, 0.0, 0.0, 0.0),
        vec4<f32>(0.0, 1.0, 0.0, 0.0),
        vec4<f32>(0.0, 0.0, 1.0, 0.0),
        vec4<f32>(-c, 1.0),
    );
    return box_interval(to_local, h, o, d);
}

// Beer-Lambert along the segment a -> b, which crosses no surface: over its part inside the
// body's box, when that part lies in the water (as scene/water.rs WaterBody::transmittance:
// a segment may enter through the body's open sides).
fn water_beer(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let d = b - a;
    let iv = body_interval(a, d);
    let t1 = min(iv.y, 1.0);
    if iv.x >= t1 || !in_water(a + d * (0.5 * (iv.x + t1))) {
        return vec3<f32>(1.0);
    }
    return beer(length(d) * (t1 - iv.x));
}

// Where the line through q along the refracted sun meets the mean surface plane, in light
// map coordinates (0..1 over the map).
fn map_uv(q: vec3<f32>) -> vec2<f32> {
    let u = water.up.xyz;
    let m = q.xz + u.xz * ((water.centre.y - q.y) / u.y);
    return (m - water.map.xy) / water.map.zw;
}

// The irradiance at q (unit normal n) under the water, the article's way.
fn irradiance(q: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let u = water.up.xyz;
    let facing = dot(n, u);
    if facing <= 0.0 {
        return vec3<f32>(0.0);
    }
    let o = q + n * 1e-4;
    let t = cross_surface(o, u, 1e30);
    if t < 0.0 {
        return vec3<f32>(0.0);
    }
    if occluded(o, u, t) {
        return vec3<f32>(0.0);
    }
    let s = o + u * t;
    let ns = normal_at(s);
    // Leaving the water: the normal facing the ray is -ns, eta = ior / 1.
    let a = refract(u, -ns, water.size.w);
    if dot(a, a) == 0.0 {
        return vec3<f32>(0.0);
    }
    let theta = acos(clamp(dot(a, -water.sun.xyz), -1.0, 1.0));
    let b = exp(-(theta / water.sun.w) * (theta / water.sun.w));
    return water.beam.rgb * (facing * b) * beer(t);
}

// Sunlight that reaches q (unit normal n, in the water) through the body's open sides: the
// straight ray towards the sun leaves the rectangle under the surface, without crossing it,
// and nothing blocks it; E cos, through the water up to the side. The reference traces the
// same light (its shadow rays and photons cross no surface there).
fn side_light(q: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let l = -water.sun.xyz;
    let c = dot(n, l);
    if c <= 0.0 {
        return vec3<f32>(0.0);
    }
    let o = q + n * 1e-4;
    // Where the ray leaves the body's box: through a side under the surface, or else through
    // its top, having crossed the surface.
    let t_out = body_interval(o, l).y;
    if t_out >= 1e29 || above(o + l * t_out) >= 0.0 || cross_surface(o, l, t_out) >= 0.0 {
        return vec3<f32>(0.0);
    }
    if occluded(o, l, 1e30) {
        return vec3<f32>(0.0);
    }
    return water.sun_e.rgb * water.sun_e.w * c * beer(max(t_out, 0.0));
}
