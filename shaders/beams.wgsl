// Volumetric caustics with projected light beams (Liktor and Dachsbacher 2010; render/beams).
// One instance per caustic beam covers the screen-space outline of the beam's hull (the six
// corners of its base and cap); per pixel, the view ray is intersected with the beam through the
// planar triangle of the paper's Fig. 5 and the single-scattering integral is evaluated with one
// sample or more (§3.2). The beams also light the receivers they end on (surface caustics, the
// area ratio at the receiver as in Ernst et al. 2005). Additive blending sums the beams.

#include "common.inc.wgsl"
#include "hull.inc.wgsl"

struct Beam {
    // xyz: v0 (world); w: Y, the height of the hull's cap.
    origin: vec4<f32>,
    // xyz: beam-space x axis; w: the doubled area the flux is counted over.
    ax: vec4<f32>,
    // xyz: y axis, the base's normal towards the beam.
    ay: vec4<f32>,
    // xyz: z = x × y.
    az: vec4<f32>,
    // v1'x, v1'z, v2'x, v2'z.
    k: vec4<f32>,
    // d0'x, d0'z, d1'x, d1'z (each d_i'y = 1).
    d01: vec4<f32>,
    // d2'x, d2'z.
    d2: vec4<f32>,
    // The area function's a, b, c: the doubled signed area of the slice at height y.
    abc: vec4<f32>,
    // rgb: flux per unit of the counted area; w: the height where the vertex's photon ends.
    rho: array<vec4<f32>, 3>,
    // xyz: the bounding volume's cap corners (world): on the photon rays or the touching
    // planes' extrusion rays.
    cap: array<vec4<f32>, 3>,
}

// The medium is Globals' (medium_to_local, medium_half, medium_sigma_t, medium_sigma_s).
struct Params {
    // x: samples per beam; y: flags (1 shadows); z: downsampling factor; w: beams.
    counts: vec4<u32>,
    // x: the largest area ratio.
    misc: vec4<f32>,
}

const FLAG_SHADOWS: u32 = 1u;
const FAR: f32 = 1e30;

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(1) var<uniform> prm: Params;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> beams: array<Beam>;
@group(0) @binding(4) var gbuf_position: texture_2d<f32>;
@group(0) @binding(5) var gbuf_normal: texture_2d<f32>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) beam: u32,
}

// Corner i of the bounding volume: the base (i < 3) or the cap (i ≥ 3), world space.
fn corner(b: Beam, i: u32) -> vec3<f32> {
    if i >= 3u {
        return b.cap[i - 3u].xyz;
    }
    var v = vec2<f32>(0.0);
    if i == 1u {
        v = b.k.xy;
    } else if i == 2u {
        v = b.k.zw;
    }
    return b.origin.xyz + b.ax.xyz * v.x + b.az.xyz * v.y;
}

// The beam's screen-space outline (hull.inc.wgsl): the convex hull of its six corners
// projected, widened by a pixel so that every sample of a pixel's footprint that the beam
// covers is drawn.
@vertex
fn vs_beam(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VsOut {
    let b = beams[ii];
    var corners: array<vec3<f32>, 6>;
    for (var i = 0u; i < 6u; i++) {
        corners[i] = corner(b, i);
    }
    var out: VsOut;
    out.beam = ii;
    out.clip = hull_outline(corners, vi, 1.0, g.view_proj, g.viewport.xy);
    return out;
}

// The view ray through framebuffer position xy of the full-resolution frame.
fn view_dir(xy: vec2<f32>) -> vec3<f32> {
    let ndc = vec2<f32>((xy.x / g.viewport.x) * 2.0 - 1.0, 1.0 - (xy.y / g.viewport.y) * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    return normalize(far.xyz / far.w - g.eye.xyz);
}

// The part [t0, t1] of o + t·d (t ≥ 0) inside the medium's box; t0 > t1 when none.
fn medium_interval(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    return box_interval(g.medium_to_local, g.medium_half.xyz, o, d);
}

// Transmittance of the medium over the segment a → b.
fn medium_transmittance(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let len = distance(a, b);
    if len <= 0.0 {
        return vec3<f32>(1.0);
    }
    let m = medium_interval(a, (b - a) / len);
    let inside = max(min(m.y, len) - m.x, 0.0);
    return exp(-g.medium_sigma_t.xyz * inside);
}


fn cross2(u: vec2<f32>, w: vec2<f32>) -> f32 {
    return u.y * w.x - u.x * w.y;
}

// A point of the beam at beam-space position p: its barycentrics β in the slice at p.y
// (signed, unclamped), and the slice's doubled signed area A(p.y) = a y² + b y + c.
struct Slice {
    beta: vec3<f32>,
    area: f32,
}

fn slice_at(b: Beam, p: vec3<f32>) -> Slice {
    let y = p.y;
    let a0 = y * b.d01.xy;
    let a1 = b.k.xy + y * b.d01.zw;
    let a2 = b.k.zw + y * b.d2.xy;
    let area = dot(vec3<f32>(y * y, y, 1.0), b.abc.xyz);
    let q = p.xz;
    var s: Slice;
    let inv = 1.0 / select(area, 1e-30, abs(area) < 1e-30);
    let b1 = cross2(q - a0, a2 - a0) * inv;
    let b2 = cross2(a1 - a0, q - a0) * inv;
    s.beta = vec3<f32>(1.0 - b1 - b2, b1, b2);
    s.area = area;
    return s;
}

// The light a beam carries at beam-space point p with barycentrics beta (≥ 0, summing to 1):
// rgb the irradiance facing the photons (W/m²), the unit photon direction (world) and where
// its photon left the surface (world).
struct Flux {
    e: vec3<f32>,
    dir: vec3<f32>,
    base: vec3<f32>,
    end: f32,
}

fn flux_at(b: Beam, beta: vec3<f32>, area: f32) -> Flux {
    let dxz = beta.x * b.d01.xy + beta.y * b.d01.zw + beta.z * b.d2.xy;
    let d = vec3<f32>(dxz.x, 1.0, dxz.y);
    let ratio = b.ax.w / max(abs(area), b.ax.w / prm.misc.x);
    let rho = beta.x * b.rho[0] + beta.y * b.rho[1] + beta.z * b.rho[2];
    var f: Flux;
    f.e = rho.xyz * ratio * length(d);
    // Where the photons end: beyond the farthest of the three vertices' ends. (Interpolating
    // them would cut beams that meet a receiver at a grazing angle short, since the height of
    // the hit is not linear across such a beam.)
    f.end = max(b.rho[0].w, max(b.rho[1].w, b.rho[2].w));
    let dw = b.ax.xyz * d.x + b.ay.xyz + b.az.xyz * d.z;
    f.dir = normalize(dw);
    let v = beta.y * b.k.xy + beta.z * b.k.zw;
    f.base = b.origin.xyz + b.ax.xyz * v.x + b.az.xyz * v.y;
    return f;
}

fn to_beam(b: Beam, p: vec3<f32>) -> vec3<f32> {
    let q = p - b.origin.xyz;
    return vec3<f32>(dot(b.ax.xyz, q), dot(b.ay.xyz, q), dot(b.az.xyz, q));
}

fn dir_to_beam(b: Beam, d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(b.ax.xyz, d), dot(b.ay.xyz, d), dot(b.az.xyz, d));
}

// In-scattered radiance from beam b along the view ray o + s·r, 0 ≤ s ≤ s_scene (§3.2).
fn beam_volume(b: Beam, o: vec3<f32>, r: vec3<f32>, s_scene: f32) -> vec3<f32> {
    let m = medium_interval(o, r);
    if m.x >= m.y {
        return vec3<f32>(0.0);
    }
    let op = to_beam(b, o);
    let rp = dir_to_beam(b, r);
    // The plane through the ray most transversal to the beam: n_p ∝ r × (r × y) (Fig. 5).
    let axis = normalize(vec3<f32>((b.d01.x + b.d01.z + b.d2.x) / 3.0, 1.0, (b.d01.y + b.d01.w + b.d2.y) / 3.0));
    var np = axis - dot(axis, rp) * rp;
    if dot(np, np) < 1e-10 {
        np = cross(rp, vec3<f32>(1.0, 0.0, 0.0));
    }
    np = normalize(np);
    let wdir = normalize(cross(np, rp));
    // The edge rays v_i' + t d_i' cut by the plane: the triangle q0 q1 q2, in the plane's
    // coordinates (w across the ray, s along it).
    var w: array<f32, 3>;
    var s: array<f32, 3>;
    for (var i = 0u; i < 3u; i++) {
        var v = vec3<f32>(0.0);
        var d = vec3<f32>(b.d01.x, 1.0, b.d01.y);
        if i == 1u {
            v = vec3<f32>(b.k.x, 0.0, b.k.y);
            d = vec3<f32>(b.d01.z, 1.0, b.d01.w);
        } else if i == 2u {
            v = vec3<f32>(b.k.z, 0.0, b.k.w);
            d = vec3<f32>(b.d2.x, 1.0, b.d2.y);
        }
        let den = dot(np, d);
        if abs(den) < 1e-9 {
            return vec3<f32>(0.0);
        }
        let q = v + d * (dot(np, op - v) / den) - op;
        w[i] = dot(wdir, q);
        s[i] = dot(rp, q);
    }
    // Where the ray crosses the triangle's edges: s_in, s_out.
    var s_in = FAR;
    var s_out = -FAR;
    var crossings = 0u;
    for (var i = 0u; i < 3u; i++) {
        let j = (i + 1u) % 3u;
        if (w[i] < 0.0) != (w[j] < 0.0) {
            let u = w[i] / (w[i] - w[j]);
            let x = s[i] + u * (s[j] - s[i]);
            s_in = min(s_in, x);
            s_out = max(s_out, x);
            crossings += 1u;
        }
    }
    if crossings < 2u {
        return vec3<f32>(0.0);
    }
    // Clipped to the eye, the scene's surface, the medium and the beam's heights 0..Y.
    var lo = max(max(s_in, 0.0), m.x);
    var hi = min(min(s_out, s_scene), m.y);
    let cap = b.origin.w;
    if abs(rp.y) > 1e-9 {
        let a = -op.y / rp.y;
        let c = (cap - op.y) / rp.y;
        lo = max(lo, min(a, c));
        hi = min(hi, max(a, c));
    } else if op.y < 0.0 || op.y > cap {
        return vec3<f32>(0.0);
    }
    let dx = hi - lo;
    if dx <= 0.0 {
        return vec3<f32>(0.0);
    }
    let n = max(prm.counts.x, 1u);
    let ds = dx / f32(n);
    let gg = g.medium_sigma_s.w;
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < n; k++) {
        let t = lo + (f32(k) + 0.5) * ds;
        let p = op + t * rp;
        let sl = slice_at(b, p);
        // The Fig. 5 triangle is a chordal approximation of the beam's section: a sample just
        // outside the slice takes the nearest point of it.
        if min(sl.beta.x, min(sl.beta.y, sl.beta.z)) < -1e-3 { continue; }
        var beta = max(sl.beta, vec3<f32>(0.0));
        beta = beta / max(beta.x + beta.y + beta.z, 1e-12);
        let f = flux_at(b, beta, sl.area);
        if (prm.counts.y & FLAG_SHADOWS) != 0u && p.y > f.end {
            continue;
        }
        let x = o + t * r;
        // Transmittance along the photon's path (s1) and the view ray (s2).
        let t1 = medium_transmittance(f.base, x);
        let t2 = exp(-g.medium_sigma_t.xyz * max(t - m.x, 0.0));
        sum += g.medium_sigma_s.xyz * hg(gg, dot(f.dir, -r)) * f.e * t1 * t2;
    }
    return sum * ds;
}

// Radiance of receiver point x (normal n, material mat) lit by beam b, seen from the eye.
fn beam_surface(b: Beam, x: vec3<f32>, n: vec3<f32>, mat: Material, eye: vec3<f32>) -> vec3<f32> {
    let p = to_beam(b, x);
    let cap = b.origin.w;
    if p.y < 0.0 || p.y > cap * 1.05 + 1e-3 {
        return vec3<f32>(0.0);
    }
    let sl = slice_at(b, p);
    if min(sl.beta.x, min(sl.beta.y, sl.beta.z)) < 0.0 {
        return vec3<f32>(0.0);
    }
    let f = flux_at(b, sl.beta, sl.area);
    // The photons end on the first surface they meet: a receiver farther on is in shadow.
    if (prm.counts.y & FLAG_SHADOWS) != 0u && p.y > f.end * 1.05 + 1e-3 {
        return vec3<f32>(0.0);
    }
    let cos_i = max(dot(n, -f.dir), 0.0);
    let e = f.e * cos_i * medium_transmittance(f.base, x) * medium_transmittance(x, eye);
    return mat.albedo.rgb / PI * e;
}

// The volume at full-resolution position xy (the view ray and the scene's depth there).
fn volume_at(b: Beam, xy: vec2<f32>) -> vec3<f32> {
    let px = vec2<i32>(xy);
    let gn = textureLoad(gbuf_normal, px, 0);
    var s_scene = FAR;
    if dot(gn.xyz, gn.xyz) > 0.0 {
        s_scene = distance(textureLoad(gbuf_position, px, 0).xyz, g.eye.xyz);
    }
    return beam_volume(b, g.eye.xyz, view_dir(xy), s_scene);
}

// The receiver under full-resolution position xy, averaged over the pixel's footprint:
// SURFACE_SAMPLES² rays through the pixel meet the receiver's tangent plane (a caustic's focus
// is far smaller than a pixel; its centre alone would miss it or take its peak).
const SURFACE_SAMPLES: u32 = 8u;

// Two numbers in [0, 1) from three integers (PCG-style integer hashing).
fn hash2(v: vec3<u32>) -> vec2<f32> {
    var x = v.x * 1664525u + v.y * 22695477u + v.z * 2891336453u + 1013904223u;
    x = (x ^ (x >> 16u)) * 2246822519u;
    x = (x ^ (x >> 13u)) * 3266489917u;
    x = x ^ (x >> 16u);
    var y = x * 747796405u + 2891336453u;
    y = ((y >> ((y >> 28u) + 4u)) ^ y) * 277803737u;
    y = (y >> 22u) ^ y;
    return vec2<f32>(f32(x >> 8u), f32(y >> 8u)) / 16777216.0;
}

fn surface_at(b: Beam, xy: vec2<f32>) -> vec3<f32> {
    let px = vec2<i32>(xy);
    let gp = textureLoad(gbuf_position, px, 0);
    if gp.w <= 0.0 {
        return vec3<f32>(0.0);
    }
    // Most beams over a pixel pass through the fog and end elsewhere: the receiver point under
    // the pixel's centre, with the footprint's reach as margin, lies outside their slice.
    let c = to_beam(b, gp.xyz);
    let reach = 2.0 * gp.w;
    if c.y < -reach || c.y > b.origin.w * 1.05 + 1e-3 + reach {
        return vec3<f32>(0.0);
    }
    let sl = slice_at(b, c);
    let a0 = c.y * b.d01.xy;
    let a1 = b.k.xy + c.y * b.d01.zw;
    let a2 = b.k.zw + c.y * b.d2.xy;
    let longest = max(distance(a0, a1), max(distance(a1, a2), distance(a2, a0)));
    // β of a point `reach` outside an edge is about −reach / altitude, altitude = |A| / edge.
    let margin = reach * longest / max(abs(sl.area), 1e-20) + 1e-4;
    if min(sl.beta.x, min(sl.beta.y, sl.beta.z)) < -margin {
        return vec3<f32>(0.0);
    }
    let gn = textureLoad(gbuf_normal, px, 0);
    let n = normalize(gn.xyz);
    let mat = materials[u32(gn.w)];
    let eye = g.eye.xyz;
    let plane = dot(gp.xyz - eye, n);
    var sum = vec3<f32>(0.0);
    for (var j = 0u; j < SURFACE_SAMPLES; j++) {
        for (var i = 0u; i < SURFACE_SAMPLES; i++) {
            // Stratified and jittered (a hash of the pixel and the stratum): a focus smaller
            // than a stratum is then met in proportion to its area rather than aliased.
            let h = hash2(vec3<u32>(vec2<u32>(xy), j * SURFACE_SAMPLES + i));
            let off = (vec2<f32>(f32(i), f32(j)) + h) / f32(SURFACE_SAMPLES) - 0.5;
            let d = view_dir(floor(xy) + vec2<f32>(0.5) + off);
            let cd = dot(d, n);
            if abs(cd) < 1e-6 {
                continue;
            }
            sum += beam_surface(b, eye + d * (plane / cd), n, mat, eye);
        }
    }
    return sum / f32(SURFACE_SAMPLES * SURFACE_SAMPLES);
}

struct BothOut {
    @location(0) volume: vec4<f32>,
    @location(1) surface: vec4<f32>,
}

// Full resolution: the volume and the receivers in one pass.
@fragment
fn fs_both(in: VsOut) -> BothOut {
    let b = beams[in.beam];
    var out: BothOut;
    out.volume = vec4<f32>(volume_at(b, in.clip.xy), 0.0);
    out.surface = vec4<f32>(surface_at(b, in.clip.xy), 0.0);
    return out;
}

// The volume at 1/downsample of the resolution: each pixel takes the ray and depth of the
// full-resolution pixel under its centre.
@fragment
fn fs_volume(in: VsOut) -> @location(0) vec4<f32> {
    let f = f32(prm.counts.z);
    let xy = floor(in.clip.xy * f) + vec2<f32>(0.5);
    return vec4<f32>(volume_at(beams[in.beam], xy), 0.0);
}

// The receivers alone, at full resolution.
@fragment
fn fs_surface(in: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(surface_at(beams[in.beam], in.clip.xy), 0.0);
}

// The fog between the eye and what each pixel sees: the direct and specular layers are
// multiplied by its transmittance (the blend state multiplies).
@fragment
fn fs_fog(@builtin(position) frag: vec4<f32>) -> BothOut {
    let px = vec2<i32>(frag.xy);
    let eye = g.eye.xyz;
    let d = view_dir(frag.xy);
    let gn = textureLoad(gbuf_normal, px, 0);
    var len = FAR;
    if dot(gn.xyz, gn.xyz) > 0.0 {
        len = distance(textureLoad(gbuf_position, px, 0).xyz, eye);
    }
    let m = medium_interval(eye, d);
    let inside = max(min(m.y, len) - m.x, 0.0);
    let t = vec4<f32>(exp(-g.medium_sigma_t.xyz * inside), 1.0);
    var out: BothOut;
    out.volume = t;
    out.surface = t;
    return out;
}

// Edge-aware upsampling of the low-resolution volume: the four nearest low-resolution pixels,
// bilinear weights times the likeness of their depths to this pixel's.
@group(0) @binding(6) var low: texture_2d<f32>;

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

fn depth_at(px: vec2<i32>) -> f32 {
    let gn = textureLoad(gbuf_normal, px, 0);
    if dot(gn.xyz, gn.xyz) > 0.0 {
        return distance(textureLoad(gbuf_position, px, 0).xyz, g.eye.xyz);
    }
    return 1e6;
}

@fragment
fn fs_upsample(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let f = f32(prm.counts.z);
    let size = vec2<i32>(textureDimensions(low));
    let full = vec2<i32>(textureDimensions(gbuf_position));
    let z = depth_at(vec2<i32>(frag.xy));
    let q = frag.xy / f - vec2<f32>(0.5);
    let i0 = vec2<i32>(floor(q));
    let fr = q - floor(q);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    var best = vec3<f32>(0.0);
    var best_dz = FAR;
    for (var k = 0; k < 4; k++) {
        let o = vec2<i32>(k & 1, k >> 1u);
        let c = clamp(i0 + o, vec2<i32>(0), size - vec2<i32>(1));
        let cz = depth_at(min(vec2<i32>((vec2<f32>(c) + vec2<f32>(0.5)) * f), full - vec2<i32>(1)));
        let bw = select(1.0 - fr.x, fr.x, o.x == 1) * select(1.0 - fr.y, fr.y, o.y == 1);
        let dz = abs(cz - z);
        let wgt = bw * exp(-dz / (0.05 * z));
        let v = textureLoad(low, c, 0).rgb;
        sum += wgt * v;
        wsum += wgt;
        if dz < best_dz {
            best_dz = dz;
            best = v;
        }
    }
    if wsum < 1e-4 {
        return vec4<f32>(best, 0.0);
    }
    return vec4<f32>(sum / wsum, 0.0);
}
