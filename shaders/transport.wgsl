// Transport-table caustics (Iwasaki et al. 2005 §5.2) over arbitrary receivers: one instance per
// illumination volume (bake/transport/eval.rs builds them per frame on the CPU), drawn as the
// screen rectangle its six corners project to; every covered pixel reads its receiver point and
// normal from the G-buffer (gbuffer.wgsl), intersects the volume's three exit rays with the
// receiver's tangent plane (the cross-section S_p of Eq. 2), and adds the volume's light
// averaged over the pixel's footprint on that plane: S · Σ bᵢFᵢ · |S_p ∩ footprint| /
// (|S_p| · |footprint|), b at the overlap's centroid (Sutherland-Hodgman clip of the
// triangle by the footprint quadrilateral). The arriving ray there is shaded with the
// receiver's BRDF and dropped when an occluder (occlusion.inc.wgsl: everything but the caustic
// objects) lies between the receiver and where it left the object. Mirrors
// `Volume::arrival` with a footprint and `eval::render_caustics`; additive blending sums the
// volumes into the caustics layer.

#include "common.inc.wgsl"
#include "hull.inc.wgsl"
#include "occlusion.inc.wgsl"

struct Volume {
    // xyz: exit point of corner 0; w: area S of the object's triangle.
    e0: vec4<f32>,
    // xyz: exit point of corner 1; w: how far the volume reaches along its rays.
    e1: vec4<f32>,
    e2: vec4<f32>,
    // Unit exit directions.
    d0: vec4<f32>,
    d1: vec4<f32>,
    d2: vec4<f32>,
    // rgb: flux per unit triangle area entering at each corner and leaving the object.
    f0: vec4<f32>,
    f1: vec4<f32>,
    f2: vec4<f32>,
}

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(10) var gbuf_position: texture_2d<f32>;
@group(0) @binding(11) var gbuf_normal: texture_2d<f32>;
@group(0) @binding(12) var<storage, read> volumes: array<Volume>;

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) volume: u32,
}

@vertex
fn vs_volume(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VsOut {
    let v = volumes[ii];
    let len = v.e1.w;
    var corners = array<vec3<f32>, 6>(
        v.e0.xyz, v.e1.xyz, v.e2.xyz,
        v.e0.xyz + v.d0.xyz * len, v.e1.xyz + v.d1.xyz * len, v.e2.xyz + v.d2.xyz * len,
    );
    var out: VsOut;
    out.volume = ii;
    out.clip = hull_outline(corners, vi, 1.5, g.view_proj, g.viewport.xy);
    return out;
}

// The viewing ray through pixel position `xy` (pixels, y down).
fn pixel_ray(xy: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>(xy.x / g.viewport.x * 2.0 - 1.0, 1.0 - xy.y / g.viewport.y * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    return normalize(far.xyz / far.w - g.eye.xyz);
}

struct Overlap {
    // xy: centroid (plane coordinates); z: overlap area; w: 0 when none.
    c: vec4<f32>,
}

// Area and centroid of triangle t ∩ convex quad f (counter-clockwise), 2D.
fn clip_overlap(t0: vec2<f32>, t1: vec2<f32>, t2: vec2<f32>, f: array<vec2<f32>, 4>) -> Overlap {
    var a: array<vec2<f32>, 8>;
    var b: array<vec2<f32>, 8>;
    a[0] = t0;
    a[1] = t1;
    a[2] = t2;
    var n = 3u;
    var out: Overlap;
    out.c = vec4<f32>(0.0);
    for (var e = 0u; e < 4u; e++) {
        let p0 = f[e];
        let edge = f[(e + 1u) % 4u] - p0;
        var m = 0u;
        for (var k = 0u; k < n; k++) {
            let cur = a[k];
            let prev = a[(k + n - 1u) % n];
            let dc = cross2(edge, cur - p0);
            let dp = cross2(edge, prev - p0);
            if (dc >= 0.0) != (dp >= 0.0) {
                b[m] = prev + (cur - prev) * (dp / (dp - dc));
                m += 1u;
            }
            if dc >= 0.0 {
                b[m] = cur;
                m += 1u;
            }
        }
        n = m;
        if n < 3u {
            return out;
        }
        for (var k = 0u; k < n; k++) {
            a[k] = b[k];
        }
    }
    var area = 0.0;
    var c = vec2<f32>(0.0);
    for (var k = 0u; k < n; k++) {
        let p = a[k];
        let r = a[(k + 1u) % n];
        let cr = cross2(p, r);
        area += cr;
        c += (p + r) * cr;
    }
    area = 0.5 * area;
    if abs(area) <= 0.0 {
        return out;
    }
    c = c / (6.0 * area);
    out.c = vec4<f32>(c, abs(area), 1.0);
    return out;
}

// Whether point c lies farther than r outside edge a→b of a triangle of orientation s.
fn outside_edge(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, s: f32, r: f32) -> bool {
    let edge = b - a;
    return s * cross2(edge, c - a) < -r * length(edge);
}

@fragment
fn fs_volume(in: VsOut) -> @location(0) vec4<f32> {
    let frag = in.clip;
    let texel = vec2<u32>(frag.xy);
    let gp = textureLoad(gbuf_position, texel, 0);
    if gp.w <= 0.0 {
        discard;
    }
    let gn = textureLoad(gbuf_normal, texel, 0);
    let p = gp.xyz;
    let n = normalize(gn.xyz);
    let v = volumes[in.volume];
    let len = v.e1.w;
    // Cross-section with the receiver's tangent plane (unrolled: llvmpipe spills indexed
    // local arrays to memory).
    let den = vec3<f32>(dot(v.d0.xyz, n), dot(v.d1.xyz, n), dot(v.d2.xyz, n));
    if any(den >= vec3<f32>(0.0)) {
        discard;
    }
    let t = vec3<f32>(dot(p - v.e0.xyz, n), dot(p - v.e1.xyz, n), dot(p - v.e2.xyz, n)) / den;
    if any(t < vec3<f32>(0.0)) || any(t > vec3<f32>(len)) {
        discard;
    }
    let q0 = v.e0.xyz + v.d0.xyz * t.x;
    let q1 = v.e1.xyz + v.d1.xyz * t.y;
    let q2 = v.e2.xyz + v.d2.xyz * t.z;
    // Plane coordinates around q0.
    var ax = cross(n, vec3<f32>(1.0, 0.0, 0.0));
    if dot(ax, ax) < 1e-4 {
        ax = cross(n, vec3<f32>(0.0, 1.0, 0.0));
    }
    ax = normalize(ax);
    let ay = cross(n, ax);
    let t0 = vec2<f32>(0.0);
    let t1 = vec2<f32>(dot(q1 - q0, ax), dot(q1 - q0, ay));
    let t2 = vec2<f32>(dot(q2 - q0, ax), dot(q2 - q0, ay));
    let area_q2 = cross2(t1, t2);
    if area_q2 == 0.0 {
        discard;
    }
    // Cheap rejection before the footprint: the pixel centre farther outside an edge of the
    // cross-section than its footprint reaches (gp.w) cannot overlap it.
    let pc = vec2<f32>(dot(p - q0, ax), dot(p - q0, ay));
    let s = sign(area_q2);
    if outside_edge(t0, t1, pc, s, gp.w) || outside_edge(t1, t2, pc, s, gp.w)
        || outside_edge(t2, t0, pc, s, gp.w) {
        discard;
    }
    // The pixel's footprint on the plane.
    let base = floor(frag.xy);
    var f: array<vec2<f32>, 4>;
    let offs = array<vec2<f32>, 4>(vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0), vec2<f32>(0.0, 1.0));
    for (var k = 0u; k < 4u; k++) {
        let d = pixel_ray(base + offs[k]);
        let dn = dot(d, n);
        if abs(dn) < 1e-6 {
            discard;
        }
        let w = g.eye.xyz + d * (dot(p - g.eye.xyz, n) / dn) - q0;
        f[k] = vec2<f32>(dot(w, ax), dot(w, ay));
    }
    var area_f = 0.0;
    for (var k = 0u; k < 4u; k++) {
        area_f += cross2(f[k], f[(k + 1u) % 4u]);
    }
    if area_f < 0.0 {
        let tmp = f[1];
        f[1] = f[3];
        f[3] = tmp;
    }
    area_f = 0.5 * abs(area_f);
    if area_f <= 0.0 {
        discard;
    }
    let o = clip_overlap(t0, t1, t2, f);
    if o.c.w < 0.5 {
        discard;
    }
    // Barycentrics of the overlap's centroid.
    let c = o.c.xy;
    var b1 = cross2(c, t2) / area_q2;
    var b2 = cross2(t1, c) / area_q2;
    var b0 = 1.0 - b1 - b2;
    b0 = max(b0, 0.0);
    b1 = max(b1, 0.0);
    b2 = max(b2, 0.0);
    let bs = b0 + b1 + b2;
    b0 /= bs;
    b1 /= bs;
    b2 /= bs;
    let dir = normalize(b0 * v.d0.xyz + b1 * v.d1.xyz + b2 * v.d2.xyz);
    let flux = b0 * v.f0.rgb + b1 * v.f1.rgb + b2 * v.f2.rgb;
    let e = flux * (v.e0.w * o.c.z / (0.5 * abs(area_q2) * area_f));
    let wi = -dir;
    let cos_i = dot(n, wi);
    if cos_i <= 0.0 || all(e <= vec3<f32>(0.0)) {
        discard;
    }
    let at = q0 + ax * c.x + ay * c.y;
    let exit = b0 * v.e0.xyz + b1 * v.e1.xyz + b2 * v.e2.xyz;
    let m = materials[u32(gn.w)];
    let vdir = normalize(g.eye.xyz - p);
    var brdf = m.albedo.rgb / PI;
    if m.kind == MAT_GLOSSY {
        brdf = glossy_brdf(n, wi, vdir, m.albedo.rgb, m.specular.rgb, m.roughness);
    }
    let eps = 1e-4 * (1.0 + max(max(abs(p.x), abs(p.y)), abs(p.z)));
    let origin = p + n * eps;
    if occluded(origin, wi, length(at - exit)) {
        discard;
    }
    return vec4<f32>(brdf * e, 0.0);
}
