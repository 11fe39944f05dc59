// Method photons, pass 2 of 2 (render/photons): every photon photons.wgsl stored is drawn as a
// screen parallelogram around its footprint, and each pixel of the G-buffer's receivers that the
// footprint's ellipse overlaps gets flux · f(wi, wo) · K, with K the Epanechnikov kernel
// 2/(π·a·b)·(1 − ρ²) over the ellipse of semi-axes a, b, averaged over the pixel's footprint
// (its integral over the surface is 1, so the splats of N photons sum to the irradiance's
// density estimate, box-filtered per pixel like the reference's). Blended additively into a
// 32-bit float layer.

#include "common.inc.wgsl"

struct PhotonRecord {
    p: vec4<f32>,
    u: vec4<f32>,
    v: vec4<f32>,
    wi: vec4<f32>,
}

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(1) var<storage, read> records: array<PhotonRecord>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var g_position: texture_2d<f32>;
@group(0) @binding(4) var g_normal: texture_2d<f32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) k: u32,
}

// The screen position (pixels) of world point w, and its clip w (> 0 in front of the eye).
fn screen(w: vec3<f32>) -> vec3<f32> {
    let c = g.view_proj * vec4<f32>(w, 1.0);
    let ndc = c.xy / c.w;
    return vec3<f32>(0.5 * (ndc.x + 1.0) * g.viewport.x, 0.5 * (1.0 - ndc.y) * g.viewport.y, c.w);
}

// The photon's kernel as a screen parallelogram: the projection of its ellipse's bounding
// parallelogram, each edge moved half a pixel outwards, so that every pixel whose footprint the
// kernel overlaps gets a fragment even where the kernel is about a pixel wide.
@vertex
fn vs_splat(@builtin(vertex_index) vi: u32, @builtin(instance_index) k: u32) -> VsOut {
    let r = records[k];
    var out: VsOut;
    out.k = k;
    // Outside the clip volume (nothing is drawn) when the kernel reaches behind the eye.
    out.clip = vec4<f32>(2.0, 2.0, 2.0, 1.0);
    let c = screen(r.p.xyz);
    let pu = screen(r.p.xyz + r.u.xyz);
    let mu = screen(r.p.xyz - r.u.xyz);
    let pv = screen(r.p.xyz + r.v.xyz);
    let mv = screen(r.p.xyz - r.v.xyz);
    if min(min(c.z, pu.z), min(min(mu.z, pv.z), mv.z)) <= 0.0 {
        return out;
    }
    var a = 0.5 * (pu.xy - mu.xy);
    var b = 0.5 * (pv.xy - mv.xy);
    // Edge parallel to a is |a×b|/|a| from the centre: scaling b by 1 + δ|a|/|a×b| moves it δ.
    let area = abs(a.x * b.y - a.y * b.x);
    let delta = 0.51;
    let la = length(a);
    let lb = length(b);
    if area > 1e-6 * max(la * lb, 1e-12) {
        let a2 = a * (1.0 + delta * lb / area);
        b *= 1.0 + delta * la / area;
        a = a2;
    } else {
        // A sliver: its bounding square.
        let h = max(la, lb) + delta;
        a = vec2<f32>(h, 0.0);
        b = vec2<f32>(0.0, h);
    }
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    let q = corners[vi];
    let s = c.xy + q.x * a + q.y * b;
    out.clip = vec4<f32>(2.0 * s.x / g.viewport.x - 1.0, 1.0 - 2.0 * s.y / g.viewport.y, 0.5, 1.0);
    return out;
}

// The world-space step to the next pixel along `step` from the receiver point gp (normal n),
// from the G-buffer's neighbour on that side or the other; zero where neither lies on the same
// surface.
fn pixel_step(px: vec2<i32>, step: vec2<i32>, gp: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let size = vec2<i32>(g.viewport.xy);
    let a = px + step;
    if all(a >= vec2<i32>(0)) && all(a < size) {
        let q = textureLoad(g_position, a, 0);
        let d = q.xyz - gp;
        if q.w > 0.0 && abs(dot(d, n)) <= 0.1 * length(d) {
            return d;
        }
    }
    let b = px - step;
    if all(b >= vec2<i32>(0)) && all(b < size) {
        let q = textureLoad(g_position, b, 0);
        let d = gp - q.xyz;
        if q.w > 0.0 && abs(dot(d, n)) <= 0.1 * length(d) {
            return d;
        }
    }
    return vec3<f32>(0.0);
}

const SUB: u32 = 4u;

@fragment
fn fs_splat(in: VsOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(in.clip.xy);
    let gp = textureLoad(g_position, px, 0);
    if gp.w <= 0.0 {
        discard;
    }
    let r = records[in.k];
    let u = r.u.xyz;
    let v = r.v.xyz;
    let lu2 = dot(u, u);
    let lv2 = dot(v, v);
    // A degenerate footprint has no kernel (written so that NaN fails too).
    if !(lu2 > 1e-30 && lv2 > 1e-30) {
        discard;
    }
    // The same surface: near the footprint's plane, facing the same way, lit from the front.
    let plane = normalize(cross(u, v));
    let d = gp.xyz - r.p.xyz;
    if abs(dot(d, plane)) > 0.5 * sqrt(max(lu2, lv2)) + gp.w {
        discard;
    }
    let gn = textureLoad(g_normal, px, 0);
    let n = gn.xyz;
    let wi = r.wi.xyz;
    if dot(n, wi) <= 0.0 || abs(dot(n, plane)) < 0.5 {
        discard;
    }
    // The kernel averaged over the pixel's footprint (SUB × SUB points), as the reference's
    // pixels average the light over what they see: a kernel smaller than a pixel, in a focus,
    // is then neither missed between pixel centres nor counted at its peak.
    // A kernel over 2 pixels wide in both axes is smooth enough at one point a pixel.
    let dx = pixel_step(px, vec2<i32>(1, 0), gp.xyz, n);
    let dy = pixel_step(px, vec2<i32>(0, 1), gp.xyz, n);
    let step2 = max(dot(dx, dx), dot(dy, dy));
    let sub = select(SUB, 1u, min(lu2, lv2) >= 4.0 * step2);
    var sum = 0.0;
    for (var j = 0u; j < sub; j++) {
        for (var i = 0u; i < sub; i++) {
            let o = (vec2<f32>(f32(i), f32(j)) + 0.5) / f32(sub) - 0.5;
            let q = d + o.x * dx + o.y * dy;
            let a = dot(q, u) / lu2;
            let b = dot(q, v) / lv2;
            sum += max(1.0 - a * a - b * b, 0.0);
        }
    }
    let kernel = 2.0 / (PI * sqrt(lu2 * lv2)) * sum / f32(sub * sub);
    if !(kernel > 0.0 && kernel < 1e30) {
        discard;
    }
    let m = materials[u32(gn.w)];
    var f = m.albedo.rgb / PI;
    if m.kind == MAT_GLOSSY {
        let wo = normalize(g.eye.xyz - gp.xyz);
        f = glossy_brdf(n, wi, wo, m.albedo.rgb, m.specular.rgb, m.roughness);
    }
    return vec4<f32>(vec3<f32>(r.p.w, r.u.w, r.v.w) * f * kernel, 0.0);
}
