// Transport-table caustics (Iwasaki et al. 2005 §5.2) over arbitrary receivers: one instance per
// illumination volume (render/transport/volumes.rs builds them per frame on the CPU), drawn as
// the outline its six corners project to (made once a volume by `outline`, hull.inc.wgsl) at a
// depth no point of the volume lies behind, over a culling depth of the receivers
// (`fs_cull_depth`); every covered pixel reads its receiver point and normal from the G-buffer
// (gbuffer.wgsl), intersects the volume's three exit rays with the receiver's tangent plane
// (the cross-section S_p of Eq. 2), and adds the volume's light averaged over the pixel's
// footprint on that plane: S · Σ bᵢFᵢ · |S_p ∩ footprint| / (|S_p| · |footprint|), b at the
// overlap's centroid (the overlap of the triangle and the footprint quadrilateral from its
// boundary, clip_overlap). The arriving ray there is shaded with the receiver's BRDF and
// dropped when an occluder (occlusion.inc.wgsl: everything but the caustic objects) lies
// between the receiver and where it left the object. Mirrors `Volume::arrival` with a
// footprint and `volumes::render_caustics`.
//
// Two ways to sum the volumes into the caustics layer. llvmpipe runs every branch of a shader
// under a mask, discarded fragments included, so a fragment that fails the cheap tests would
// still pay for the whole evaluation. Hence, by default: `fs_select` draws the hulls running
// only the cheap tests (cross-section, edges) and appends each (pixel, volume) that passes to
// a list; `evaluate` (compute, one invocation an entry, sized on the GPU by `list_args`)
// evaluates the entries and adds their light to the pixel's sum in 64-bit fixed point (a unit
// of 2⁻⁸ of the frame's brightest volume's radiance on a white receiver, ListParams, in steps
// of 2⁻³² of a unit; integer sums do not depend on the order the entries come in, so the frame
// is the same every time); `resolve` writes the sums into the layer. When the list overflows,
// every pixel is flagged (alpha 2) and the renderer draws the frame again with `fs_volume`,
// which evaluates every covered fragment and blends additively.

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
// The list of fs_select (how many entries were appended, possibly more than it holds; the
// dispatch of `evaluate`), its entries (pixel, volume), and the sums (per pixel, per channel,
// low and high word).
struct ListState {
    count: atomic<u32>,
    groups_x: u32,
    groups_y: u32,
    groups_z: u32,
}
@group(0) @binding(13) var<storage, read_write> list: ListState;
@group(0) @binding(14) var<storage, read_write> entries: array<vec2<u32>>;
@group(0) @binding(15) var<storage, read_write> sums: array<atomic<u32>>;
struct ListParams {
    // W/(m²·sr) a unit of the sums (render/transport `sums_unit`).
    unit: f32,
    pad0: f32,
    pad1: f32,
    pad2: f32,
}
@group(0) @binding(16) var<uniform> list_params: ListParams;

const EVAL_GROUP: u32 = 64u;
const MAX_GROUPS_X: u32 = 65535u;

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) volume: u32,
}

// A volume's outline on screen (hull.inc.wgsl's polygon, two points a vec4) and its depth
// bound: `info.x` the polygon's point count, and the plane depth = y + z·px + w·py over the
// screen (px, py: pixels, y up) that no point of the volume lies behind (see `outline`).
struct Outline {
    p01: vec4<f32>,
    p23: vec4<f32>,
    p45: vec4<f32>,
    info: vec4<f32>,
}
@group(0) @binding(17) var<storage, read> outlines: array<Outline>;

@vertex
fn vs_volume(@builtin(vertex_index) vi: u32, @builtin(instance_index) ii: u32) -> VsOut {
    let o = outlines[ii];
    var poly: HullPolygon;
    poly.p = array<vec2<f32>, 6>(o.p01.xy, o.p01.zw, o.p23.xy, o.p23.zw, o.p45.xy, o.p45.zw);
    poly.n = u32(o.info.x);
    var out: VsOut;
    out.volume = ii;
    out.clip = hull_fan_vertex(poly, vi, g.viewport.xy);
    // At the volume's depth bound (the outline's w is 1, or 0 when the vertex is degenerate):
    // the depth test drops the pixels whose receiver lies farther than that (fs_cull_depth).
    let px = poly.p[min(fan_index(vi), 5u)];
    let bound = o.info.y + o.info.z * px.x + o.info.w * px.y;
    out.clip.z = clamp(bound, 0.0, 1.0) * out.clip.w;
    return out;
}

// The outlines of the frame's volumes, one invocation a volume (made once instead of once per
// vertex of its fan). Its bind group holds g, volumes and this.
@group(0) @binding(18) var<storage, read_write> outlines_out: array<Outline>;

@compute @workgroup_size(64, 1, 1)
fn outline(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.y * groups.x * 64u + gid.x;
    if i >= arrayLength(&volumes) {
        return;
    }
    let v = volumes[i];
    let len = v.e1.w;
    var corners = array<vec3<f32>, 6>(
        v.e0.xyz, v.e1.xyz, v.e2.xyz,
        v.e0.xyz + v.d0.xyz * len, v.e1.xyz + v.d1.xyz * len, v.e2.xyz + v.d2.xyz * len,
    );
    let poly = hull_polygon(corners, 1.5, g.view_proj, g.viewport.xy);
    // The corners on screen: pixels (y up) and depth.
    var q: array<vec3<f32>, 6>;
    var far = 0.0;
    var behind = false;
    for (var k = 0u; k < 6u; k++) {
        let c = g.view_proj * vec4<f32>(corners[k], 1.0);
        if c.w > NEAR_W {
            far = max(far, c.z / c.w);
            q[k] = vec3<f32>((c.xy / c.w + 1.0) * 0.5 * g.viewport.xy, c.z / c.w);
        } else {
            behind = true;
        }
    }
    // The depth bound: a plane over the screen with every corner on its near side, so the
    // whole volume (their convex hull, convex on screen too while no corner is behind the eye)
    // is; raised by what it climbs over half a pixel, because the light a pixel receives
    // comes from a point of the volume within its square, not at its centre. Of the planes
    // through three corners (lifted to clear the others) and the flat one at the farthest
    // corner, the one lowest at the outline's centre: over a long volume seen from the side
    // that is its back face, which lies far nearer than its farthest corner. Where the chosen
    // plane passes depth 1 within the outline (clamping it there would lower it), or a corner
    // is behind the eye, the flat one.
    var plane = vec3<f32>(clamp(far, 0.0, 1.0), 0.0, 0.0);
    if !behind && poly.n >= 3u {
        var centre = vec2<f32>(0.0);
        for (var k = 0u; k < 6u; k++) {
            if k < poly.n {
                centre += poly.p[k];
            }
        }
        centre /= f32(poly.n);
        var best = plane.x;
        for (var i0 = 0u; i0 < 4u; i0++) {
            for (var i1 = i0 + 1u; i1 < 5u; i1++) {
                for (var i2 = i1 + 1u; i2 < 6u; i2++) {
                    let d1 = q[i1] - q[i0];
                    let d2 = q[i2] - q[i0];
                    let det = d1.x * d2.y - d1.y * d2.x;
                    if abs(det) < 1e-3 {
                        continue;
                    }
                    let a = (d1.z * d2.y - d2.z * d1.y) / det;
                    let b = (d1.x * d2.z - d2.x * d1.z) / det;
                    var c = -3.0e38;
                    for (var m = 0u; m < 6u; m++) {
                        c = max(c, q[m].z - a * q[m].x - b * q[m].y);
                    }
                    c += 0.75 * (abs(a) + abs(b)) + 1e-6;
                    let at = c + a * centre.x + b * centre.y;
                    var top = -3.0e38;
                    for (var k = 0u; k < 6u; k++) {
                        if k < poly.n {
                            top = max(top, c + a * poly.p[k].x + b * poly.p[k].y);
                        }
                    }
                    if at < best && top <= 1.0 {
                        best = at;
                        plane = vec3<f32>(c, a, b);
                    }
                }
            }
        }
    }
    var o: Outline;
    o.p01 = vec4<f32>(poly.p[0], poly.p[1]);
    o.p23 = vec4<f32>(poly.p[2], poly.p[3]);
    o.p45 = vec4<f32>(poly.p[4], poly.p[5]);
    o.info = vec4<f32>(f32(poly.n), plane);
    outlines_out[i] = o;
}

// A triangle over the whole target.
@vertex
fn vs_fullscreen(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((vi << 1u) & 2u), f32(vi & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

// The culling depth of the select draw: per pixel, the depth of its receiver point moved
// towards the eye along the view axis by twice its footprint's reach (and 10⁻⁴ of its
// distance for rounding); 1 where the pixel has no receiver. A volume can light the pixel only
// where its cross-section overlaps the footprint, whose corners all lie within the reach of
// the receiver point p, and within the pixel's square on screen: that point of the volume's
// hull lies no farther than the volume's depth bound there (`outline`: a plane on screen, lifted
// by half a pixel's climb), and p no farther along the view axis than that point plus the reach.
// The volume's outline, drawn at its bound with the test greater-or-equal, keeps every such
// pixel and drops those whose receiver lies behind the volume (most of a long hull's
// outline): the frame's sums are the same with and without the cull.
@fragment
fn fs_cull_depth(@builtin(position) frag: vec4<f32>) -> @builtin(frag_depth) f32 {
    let gp = textureLoad(gbuf_position, vec2<u32>(frag.xy), 0);
    if gp.w <= 0.0 {
        return 1.0;
    }
    let centre = g.inv_view_proj * vec4<f32>(0.0, 0.0, 1.0, 1.0);
    let axis = normalize(centre.xyz / centre.w - g.eye.xyz);
    let moved = gp.xyz - axis * (2.0 * gp.w + 1e-4 * (1.0 + length(gp.xyz - g.eye.xyz)));
    let c = g.view_proj * vec4<f32>(moved, 1.0);
    if c.w <= NEAR_W {
        return 0.0;
    }
    return clamp(c.z / c.w, 0.0, 1.0);
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

// The parameter range `r` of a segment cut to where d(t) = da + t (db - da) >= 0 (its part
// inside a half-plane, da and db its ends' signed distances to the edge); empty (x >= y) when
// none is.
fn clip_range(r: vec2<f32>, da: f32, db: f32) -> vec2<f32> {
    if da < 0.0 && db < 0.0 {
        return vec2<f32>(1.0, 0.0);
    }
    var out = r;
    if da < 0.0 {
        out.x = max(out.x, da / (da - db));
    } else if db < 0.0 {
        out.y = min(out.y, da / (da - db));
    }
    return out;
}

// The part r of segment a→b as a boundary piece p→q of an overlap: x = cross(p, q) (twice its
// signed area about the origin), yz = (p + q)·cross(p, q) (six times that triangle's first
// moment).
fn boundary_piece(a: vec2<f32>, b: vec2<f32>, r: vec2<f32>) -> vec3<f32> {
    if r.x >= r.y {
        return vec3<f32>(0.0);
    }
    let p = a + (b - a) * r.x;
    let q = a + (b - a) * r.y;
    let c = cross2(p, q);
    return vec3<f32>(c, (p + q) * c);
}

fn side(p: vec2<f32>, r: vec2<f32>, x: vec2<f32>) -> f32 {
    return cross2(r - p, x - p);
}

// Triangle edge a→b within quad f0..f3.
fn edge_in_quad(a: vec2<f32>, b: vec2<f32>, f0: vec2<f32>, f1: vec2<f32>, f2: vec2<f32>, f3: vec2<f32>) -> vec3<f32> {
    var r = vec2<f32>(0.0, 1.0);
    r = clip_range(r, side(f0, f1, a), side(f0, f1, b));
    r = clip_range(r, side(f1, f2, a), side(f1, f2, b));
    r = clip_range(r, side(f2, f3, a), side(f2, f3, b));
    r = clip_range(r, side(f3, f0, a), side(f3, f0, b));
    return boundary_piece(a, b, r);
}

// Quad edge a→b within triangle t0 t1 t2.
fn edge_in_triangle(a: vec2<f32>, b: vec2<f32>, t0: vec2<f32>, t1: vec2<f32>, t2: vec2<f32>) -> vec3<f32> {
    var r = vec2<f32>(0.0, 1.0);
    r = clip_range(r, side(t0, t1, a), side(t0, t1, b));
    r = clip_range(r, side(t1, t2, a), side(t1, t2, b));
    r = clip_range(r, side(t2, t0, a), side(t2, t0, b));
    return boundary_piece(a, b, r);
}

// Area and centroid of triangle t ∩ convex quad f (f counter-clockwise, t either way), 2D.
// The overlap's boundary is the part of each polygon's edges inside the other, so its area and
// first moment are sums over those pieces (Green's theorem): seven segments clipped against
// three or four half-planes each, in straight-line code without arrays (llvmpipe spills
// arrays indexed at run time, which a polygon clipper needs).
fn clip_overlap(t0: vec2<f32>, t1_in: vec2<f32>, t2_in: vec2<f32>, f: array<vec2<f32>, 4>) -> Overlap {
    var out: Overlap;
    out.c = vec4<f32>(0.0);
    // Counter-clockwise.
    var t1 = t1_in;
    var t2 = t2_in;
    if cross2(t1 - t0, t2 - t0) < 0.0 {
        t1 = t2_in;
        t2 = t1_in;
    }
    let f0 = f[0];
    let f1 = f[1];
    let f2 = f[2];
    let f3 = f[3];
    let sum = edge_in_quad(t0, t1, f0, f1, f2, f3) + edge_in_quad(t1, t2, f0, f1, f2, f3)
        + edge_in_quad(t2, t0, f0, f1, f2, f3) + edge_in_triangle(f0, f1, t0, t1, t2)
        + edge_in_triangle(f1, f2, t0, t1, t2) + edge_in_triangle(f2, f3, t0, t1, t2)
        + edge_in_triangle(f3, f0, t0, t1, t2);
    let area = 0.5 * sum.x;
    if area <= 0.0 {
        return out;
    }
    out.c = vec4<f32>(sum.yz / (6.0 * area), area, 1.0);
    return out;
}

// Whether point c lies farther than r outside edge a→b of a triangle of orientation s.
fn outside_edge(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, s: f32, r: f32) -> bool {
    let edge = b - a;
    return s * cross2(edge, c - a) < -r * length(edge);
}

// A volume's cross-section with a receiver's tangent plane, in plane coordinates around q0
// (t0 = 0), when the cheap tests pass (ok): the plane meets all three exit rays within the
// volume's length, and the pixel's centre is within its footprint's reach of the triangle.
struct Cross {
    ok: bool,
    q0: vec3<f32>,
    ax: vec3<f32>,
    ay: vec3<f32>,
    t1: vec2<f32>,
    t2: vec2<f32>,
    area_q2: f32,
}

fn cross_section(v: Volume, p: vec3<f32>, n: vec3<f32>, reach: f32) -> Cross {
    var cr: Cross;
    cr.ok = false;
    let len = v.e1.w;
    // Cross-section with the receiver's tangent plane (unrolled: llvmpipe spills indexed
    // local arrays to memory).
    let den = vec3<f32>(dot(v.d0.xyz, n), dot(v.d1.xyz, n), dot(v.d2.xyz, n));
    if any(den >= vec3<f32>(0.0)) {
        return cr;
    }
    let t = vec3<f32>(dot(p - v.e0.xyz, n), dot(p - v.e1.xyz, n), dot(p - v.e2.xyz, n)) / den;
    if any(t < vec3<f32>(0.0)) || any(t > vec3<f32>(len)) {
        return cr;
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
        return cr;
    }
    // Cheap rejection before the footprint: the pixel centre farther outside an edge of the
    // cross-section than its footprint reaches (gp.w) cannot overlap it.
    let pc = vec2<f32>(dot(p - q0, ax), dot(p - q0, ay));
    let s = sign(area_q2);
    if outside_edge(t0, t1, pc, s, reach) || outside_edge(t1, t2, pc, s, reach)
        || outside_edge(t2, t0, pc, s, reach) {
        return cr;
    }
    cr.ok = true;
    cr.q0 = q0;
    cr.ax = ax;
    cr.ay = ay;
    cr.t1 = t1;
    cr.t2 = t2;
    cr.area_q2 = area_q2;
    return cr;
}

// The light of volume v averaged over the footprint of the pixel at `frag` (pixel centre,
// pixels, y down) on the receiver at p (normal n, material index `mat`), given its cross
// section; 0 where none arrives.
fn volume_light(v: Volume, cr: Cross, p: vec3<f32>, n: vec3<f32>, mat: u32, frag: vec2<f32>) -> vec3<f32> {
    let none = vec3<f32>(0.0);
    let q0 = cr.q0;
    let ax = cr.ax;
    let ay = cr.ay;
    let t0 = vec2<f32>(0.0);
    let t1 = cr.t1;
    let t2 = cr.t2;
    let area_q2 = cr.area_q2;
    // The pixel's footprint on the plane.
    let base = floor(frag);
    var f: array<vec2<f32>, 4>;
    let offs = array<vec2<f32>, 4>(vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0), vec2<f32>(0.0, 1.0));
    for (var k = 0u; k < 4u; k++) {
        let d = pixel_ray(base + offs[k]);
        let dn = dot(d, n);
        if abs(dn) < 1e-6 {
            return none;
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
        return none;
    }
    let o = clip_overlap(t0, t1, t2, f);
    if o.c.w < 0.5 {
        return none;
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
        return none;
    }
    let at = q0 + ax * c.x + ay * c.y;
    let exit = b0 * v.e0.xyz + b1 * v.e1.xyz + b2 * v.e2.xyz;
    let m = materials[mat];
    let vdir = normalize(g.eye.xyz - p);
    var brdf = m.albedo.rgb / PI;
    if m.kind == MAT_GLOSSY {
        brdf = glossy_brdf(n, wi, vdir, m.albedo.rgb, m.specular.rgb, m.roughness);
    }
    let eps = 1e-4 * (1.0 + max(max(abs(p.x), abs(p.y)), abs(p.z)));
    let origin = p + n * eps;
    if occluded(origin, wi, length(at - exit)) {
        return none;
    }
    return brdf * e;
}

// Every covered fragment evaluated, blended additively (the fallback when a pixel's list
// overflowed).
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
    let cr = cross_section(v, p, n, gp.w);
    if !cr.ok {
        discard;
    }
    let l = volume_light(v, cr, p, n, u32(gn.w), frag.xy);
    if all(l <= vec3<f32>(0.0)) {
        discard;
    }
    return vec4<f32>(l, 0.0);
}

// The cheap tests only; a volume that passes is appended to the list. Writes no colour (the
// pipeline's write mask is empty). The depth test runs before it (forced: the shader appends
// to the list), so pixels it drops cost nothing; without the feature the attribute is removed
// (render/transport `select_source`) and the depth test has no effect on the list.
@fragment @early_depth_test(force)
fn fs_select(in: VsOut) -> @location(0) vec4<f32> {
    let texel = vec2<u32>(in.clip.xy);
    let gp = textureLoad(gbuf_position, texel, 0);
    if gp.w > 0.0 {
        let n = normalize(textureLoad(gbuf_normal, texel, 0).xyz);
        if cross_section(volumes[in.volume], gp.xyz, n, gp.w).ok {
            let k = atomicAdd(&list.count, 1u);
            if k < arrayLength(&entries) {
                entries[k] = vec2<u32>(texel.y * u32(g.viewport.x) + texel.x, in.volume);
            }
        }
    }
    return vec4<f32>(0.0);
}

fn listed() -> u32 {
    return min(atomicLoad(&list.count), arrayLength(&entries));
}

@compute @workgroup_size(1, 1, 1)
fn list_args() {
    let groups = (listed() + EVAL_GROUP - 1u) / EVAL_GROUP;
    list.groups_x = min(groups, MAX_GROUPS_X);
    list.groups_y = (groups + MAX_GROUPS_X - 1u) / MAX_GROUPS_X;
    list.groups_z = 1u;
}

// Adds v (>= 0, in units) to the 64-bit fixed-point sum at words k, k + 1: the low word
// counts 2⁻³² of a unit.
fn add_fixed(k: u32, v: f32) {
    let whole = floor(v);
    let lo = u32(min((v - whole) * 4294967296.0, 4294967040.0));
    let hi = u32(min(whole, 4294967040.0));
    let old = atomicAdd(&sums[k], lo);
    let carry = select(0u, 1u, old + lo < old);
    if hi + carry != 0u {
        atomicAdd(&sums[k + 1u], hi + carry);
    }
}

@compute @workgroup_size(64, 1, 1)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.y * groups.x * EVAL_GROUP + gid.x;
    if i >= listed() {
        return;
    }
    let e = entries[i];
    let width = u32(g.viewport.x);
    let texel = vec2<u32>(e.x % width, e.x / width);
    let gp = textureLoad(gbuf_position, texel, 0);
    let gn = textureLoad(gbuf_normal, texel, 0);
    let n = normalize(gn.xyz);
    let v = volumes[e.y];
    let cr = cross_section(v, gp.xyz, n, gp.w);
    let l = volume_light(v, cr, gp.xyz, n, u32(gn.w), vec2<f32>(texel) + 0.5);
    if any(l > vec3<f32>(0.0)) {
        for (var c = 0u; c < 3u; c++) {
            add_fixed(e.x * 6u + 2u * c, l[c] / list_params.unit);
        }
    }
}

@group(1) @binding(0) var caustics: texture_storage_2d<rgba32float, write>;

// The sums into the layer (over what the direct pass left: nothing); alpha 2 everywhere when
// the list overflowed.
@compute @workgroup_size(8, 8, 1)
fn resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = vec2<u32>(u32(g.viewport.x), u32(g.viewport.y));
    if gid.x >= size.x || gid.y >= size.y {
        return;
    }
    let k = (gid.y * size.x + gid.x) * 6u;
    var l = vec3<f32>(0.0);
    for (var c = 0u; c < 3u; c++) {
        l[c] = f32(atomicLoad(&sums[k + 2u * c + 1u])) + f32(atomicLoad(&sums[k + 2u * c])) * 2.3283064e-10;
    }
    l *= list_params.unit;
    let overflow = atomicLoad(&list.count) > arrayLength(&entries);
    textureStore(caustics, gid.xy, vec4<f32>(l, select(1.0, 2.0, overflow)));
}
