// The CSL passes (method `csl`, Liu et al. 2008 §2-3): the caustic spot lights evaluated per
// pixel on the receivers of the G-buffer, in compute passes laid out for adapters that run
// every branch of a shader (llvmpipe executes both sides of a divergent `if` under a mask, and
// a GPU's SIMD group waits for its slowest lane): so that a pixel runs only the code it needs,
// the work is split where it diverges.
//
// `csl_tiles` (one workgroup per 16×16 tile): the tile's receivers are bounded (a box and the
// largest pixel footprint), and every CSL whose lit region cannot reach the box (its cone
// against the box's heights and distances from the axis) is culled for the whole tile. Each
// pixel then walks the tile's CSLs in order and decides per CSL what its footprint needs: where
// the ray map is smooth on the pixel's scale it evaluates the point arrivals (Eqs. 2-4) and
// shades them at once; where it is not (near foci and caustic curves, about one pixel in eight)
// it only marks the CSL and leaves it to the next pass. A pixel with marks takes a slot in the
// list of wide pixels (its point sum, its marks).
// `csl_wide_args` sizes the next dispatch from the slot count; `csl_wide` (one invocation per
// wide pixel) evaluates the marked CSLs averaged over the pixel's footprint and writes the
// pixel's sum. The evaluation itself is csl.inc.wgsl's, which mirrors src/render/csl/eval.rs;
// occlusion (everything but the caustic objects) is occlusion.inc.wgsl's.

#include "common.inc.wgsl"
#include "csl.inc.wgsl"
#include "occlusion.inc.wgsl"

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(6) var<storage, read> csls: array<Csl>;
// The G-buffer (gbuffer.wgsl): position and footprint reach (w > 0 on receivers), shading
// normal and material, geometric normal facing the camera.
@group(0) @binding(10) var gb_position: texture_2d<f32>;
@group(0) @binding(11) var gb_normal: texture_2d<f32>;
@group(0) @binding(12) var gb_geometric: texture_2d<f32>;
@group(0) @binding(13) var caustics: texture_storage_2d<rgba32float, write>;

// The wide pixels: how many took a slot, and the dispatch of `csl_wide` (workgroups).
struct WideState {
    count: atomic<u32>,
    groups_x: u32,
    groups_y: u32,
    groups_z: u32,
}
@group(0) @binding(14) var<storage, read_write> wide: WideState;
// Per slot: the pixel's point sum (rgb, per unit light irradiance) and its index (w, bits).
@group(0) @binding(15) var<storage, read_write> wide_slots: array<vec4<f32>>;
// Per slot, CSL_WORDS(n) words: bit i of word w marks CSL 32 w + i.
@group(0) @binding(16) var<storage, read_write> wide_marks: array<u32>;

// Whether the frame has glossy receivers: without, the pipelines are made without the glossy
// BRDF's code (which every pixel would otherwise run under a mask).
override HAS_GLOSSY: bool = true;

const TILE: u32 = 16u;
// Most CSLs a frame evaluates (the tile's workgroup mask has one bit each); the renderer refuses
// more (render::csl::MAX_FRAME_CSLS).
const MAX_WORDS: u32 = 32u;
const WIDE_GROUP: u32 = 64u;

var<workgroup> tile_lo: array<atomic<u32>, 3>;
var<workgroup> tile_hi: array<atomic<u32>, 3>;
var<workgroup> tile_margin: atomic<u32>;
var<workgroup> tile_any: atomic<u32>;
var<workgroup> tile_mask: array<atomic<u32>, 32>;
// The box of the light planes' images of the tile's CSLs, and whether no occluder can stand
// between the tile's receivers and them (unoccluded_tile).
var<workgroup> light_lo: array<atomic<u32>, 3>;
var<workgroup> light_hi: array<atomic<u32>, 3>;
var<workgroup> tile_clear: vec4<f32>;
// Most occluder hierarchy nodes the test visits before it gives up (the tile then takes the
// path with occlusion rays).
const CLEAR_NODES: u32 = 256u;

fn csl_words() -> u32 {
    return (g.counts.w + 31u) / 32u;
}

// f32 → u32 with the same order (for atomicMin/atomicMax on coordinates).
fn ordered(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn unordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

// The unit direction of the camera ray through pixel coordinates (x, y) (y down, pixel centres
// at half integers), as fs_background in direct.wgsl.
fn camera_dir(x: f32, y: f32) -> vec3<f32> {
    let ndc = vec2<f32>(x / g.viewport.x * 2.0 - 1.0, 1.0 - y / g.viewport.y * 2.0);
    let far = g.inv_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    return normalize(far.xyz / far.w - g.eye.xyz);
}

// A receiver pixel as the passes see it: the point, its normals and material, and its
// footprint on the receiver's plane, the parallelogram with edges e1, e2 between the points the
// rays through the middles of the pixel's sides meet (render::csl::eval::render_caustics).
struct Receiver {
    ok: bool,
    p: vec3<f32>,
    n: vec3<f32>,
    ng: vec3<f32>,
    v: vec3<f32>,
    e1: vec3<f32>,
    e2: vec3<f32>,
    material: u32,
}

fn on_plane(x: f32, y: f32, p: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let d = camera_dir(x, y);
    let eye = g.eye.xyz;
    return eye + d * (dot(p - eye, ng) / dot(d, ng));
}

fn receiver(px: vec2<u32>) -> Receiver {
    var r: Receiver;
    let pos = textureLoad(gb_position, px, 0);
    r.ok = pos.w > 0.0;
    if !r.ok {
        return r;
    }
    let nm = textureLoad(gb_normal, px, 0);
    r.p = pos.xyz;
    r.n = nm.xyz;
    r.material = u32(nm.w);
    r.ng = textureLoad(gb_geometric, px, 0).xyz;
    r.v = normalize(g.eye.xyz - r.p);
    let x = f32(px.x) + 0.5;
    let y = f32(px.y) + 0.5;
    r.e1 = on_plane(x + 0.5, y, r.p, r.ng) - on_plane(x - 0.5, y, r.p, r.ng);
    r.e2 = on_plane(x, y + 0.5, r.p, r.ng) - on_plane(x, y - 0.5, r.p, r.ng);
    return r;
}

// The radiance one arriving ray (unit travel direction `dir`, flux density `density` per unit
// light irradiance) sends towards the camera, occlusion aside.
fn shade_unoccluded(r: Receiver, m: Material, dir: vec3<f32>, density: vec3<f32>) -> vec3<f32> {
    let wi = -dir;
    let cos_i = dot(r.n, wi);
    if cos_i <= 0.0 || all(density <= vec3<f32>(0.0)) {
        return vec3<f32>(0.0);
    }
    var f = m.albedo.rgb / PI;
    if HAS_GLOSSY && m.kind == MAT_GLOSSY {
        f = glossy_brdf(r.n, wi, r.v, m.albedo.rgb, m.specular.rgb, m.roughness);
    }
    return f * density * cos_i;
}

// The same, 0 where an occluder lies between the receiver and the CSL's light plane (what
// direct.wgsl's csl_shade did per arrival before).
fn shade_arrival(c: Csl, r: Receiver, m: Material, dir: vec3<f32>, density: vec3<f32>) -> vec3<f32> {
    let l = shade_unoccluded(r, m, dir, density);
    if all(l <= vec3<f32>(0.0)) {
        return l;
    }
    let wi = -dir;
    // Shadow rays start off the surface, on the side they leave towards, by a margin scaled to
    // the coordinates' magnitude (as trace::Hit::spawn).
    let eps = 1e-4 * (1.0 + max(max(abs(r.p.x), abs(r.p.y)), abs(r.p.z)));
    let t_plane = dot(r.p - c.origin, c.axis) / max(dot(dir, c.axis), 1e-4);
    let o = r.p + r.ng * select(-eps, eps, dot(wi, r.ng) >= 0.0);
    if occluded(o, wi, t_plane) {
        return vec3<f32>(0.0);
    }
    return l;
}

// The point arrivals of CSL c at the receiver (csl_arrivals), shaded as they are found (in a
// tile no occluder can reach: csl_tiles): the candidate radii first, then one arrival a loop
// iteration, so that the arrival's code is there once, not once per candidate.
fn shade_point(c: Csl, l: CslLocal, r: Receiver, m: Material) -> vec3<f32> {
    let rho = l.rho;
    let a = l.a;
    let b = l.b;
    if rho > csl_reach(c, a, b) * 1.0001 + 1e-7 {
        return vec3<f32>(0.0);
    }
    let cand = csl_candidates(rho, a, b);
    var sum = vec3<f32>(0.0);
    let dr = c.half_extent / f32(c.size);
    for (var k = 0u; k < cand.count; k++) {
        let rr = cand.radius[k];
        if !(rr > 0.0) || rr > 3.0e38 {
            continue;
        }
        let px = cand.side[k] * rr * l.ux;
        let py = cand.side[k] * rr * l.uy;
        let i = csl_intensity(c, px, py);
        if i.x < 0.0 {
            continue;
        }
        let ray = csl_ray(c, rr, px, py, i, csl_area_ratio(a, b, rr, dr));
        sum += shade_unoccluded(r, m, ray.dir, ray.density);
    }
    return sum;
}

// Whether CSL c at the receiver needs the footprint's average (csl_arrivals_px's `wide`): some
// branch of the ray map spreads the pixel over more than a texel of the image. 0: nothing
// arrives; 1: the point evaluation is the mean; 2: wide.
fn footprint_need(c: Csl, l: CslLocal, r: Receiver) -> u32 {
    let q = csl_quad(
        vec2<f32>(l.rho * l.ux, l.rho * l.uy),
        vec2<f32>(dot(r.e1, c.x_axis), dot(r.e1, c.y_axis)),
        vec2<f32>(dot(r.e2, c.x_axis), dot(r.e2, c.y_axis)),
    );
    if !q.ok {
        return 1u;
    }
    let a = l.a;
    let b = l.b;
    let band = csl_quad_distances(q);
    if band.x > csl_reach(c, a, b) * 1.0001 + 1e-7 {
        return 0u;
    }
    let rmax = c.half_extent * 1.4142135;
    var rs = rmax;
    var pieces = 1;
    if a != 0.0 {
        let s = b / (2.0 * a);
        if s > 0.0 && s < rmax {
            rs = s;
            pieces = 2;
        }
    }
    let texel = 2.0 * c.half_extent / f32(c.size);
    for (var s = 0; s < 2; s++) {
        let side = select(-1.0, 1.0, s == 0);
        for (var k = 0; k < pieces; k++) {
            let lo = select(rs, 0.0, k == 0);
            let hi = select(rmax, rs, k == 0 && pieces == 2);
            let glo = side * lo * (b - a * lo);
            let ghi = side * hi * (b - a * hi);
            // csl_arrivals_px also asks for a band of positive area and a centre radius
            // r >= 0: both hold wherever the band is wider than a texel (r is clamped into
            // [lo, hi], lo >= 0).
            let ra = csl_pre(a, b, side, lo, hi, glo, ghi, band.x);
            let rb = csl_pre(a, b, side, lo, hi, glo, ghi, band.y);
            if abs(rb - ra) > texel {
                return 2u;
            }
        }
    }
    return 1u;
}

// The farthest CSL c reaches from its axis at heights z in [z0, z1] (z0 >= 0): the largest
// |h(r)| over the image is convex in z, so its largest value is at an end.
fn reach_over(c: Csl, z0: f32, z1: f32) -> f32 {
    return max(csl_reach(c, z0 * c.gamma, 1.0 - z0 * c.kappa), csl_reach(c, z1 * c.gamma, 1.0 - z1 * c.kappa));
}

// Whether CSL c can light any point of the box [lo, hi] whose pixels' footprints reach at most
// `margin` from their points (the test csl_arrivals_px makes per pixel, bounded over the box).
fn may_reach(c: Csl, lo: vec3<f32>, hi: vec3<f32>, margin: f32) -> bool {
    let centre = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    let d = centre - c.origin;
    let zc = dot(d, c.axis);
    let zr = dot(abs(c.axis), half);
    let z1 = zc + zr;
    if !(z1 > 0.0) {
        return false;
    }
    let z0 = max(zc - zr, 0.0);
    let w = d - c.axis * zc;
    let rho_lo = length(w) - length(half) - margin;
    return !(rho_lo > reach_over(c, z0, z1) * 1.0001 + 1e-7);
}

fn boxes_overlap(alo: vec3<f32>, ahi: vec3<f32>, blo: vec3<f32>, bhi: vec3<f32>) -> bool {
    return all(alo <= bhi) && all(blo <= ahi);
}

fn box_corner(lo: vec3<f32>, hi: vec3<f32>, k: u32) -> vec3<f32> {
    return select(lo, hi, vec3<bool>((k & 1u) != 0u, (k & 2u) != 0u, (k & 4u) != 0u));
}

// The unit normal of occluder triangle t when the receivers' box [lo, hi] lies in its plane
// (within tol), else 0. Such a triangle stops no shadow ray of a receiver in that plane: the
// ray starts off the plane by more than tol (on the side it leaves towards) and moves away
// from it (a floor under its own caustic).
fn coplanar_normal(t: BlockerTri, lo: vec3<f32>, hi: vec3<f32>, tol: f32) -> vec3<f32> {
    let nn = cross(t.e1.xyz, t.e2.xyz);
    let len = length(nn);
    if !(len > 0.0) {
        return vec3<f32>(0.0);
    }
    let n = nn / len;
    let d0 = dot(n, t.v0.xyz);
    for (var k = 0u; k < 8u; k++) {
        if abs(dot(n, box_corner(lo, hi, k)) - d0) > tol {
            return vec3<f32>(0.0);
        }
    }
    return n;
}

// Whether no occluder can stop a caustic ray from the receivers' box [lo, hi] to the light
// planes' box [llo, lhi], for receivers whose geometric normal is the returned plane's (xyz;
// w = 1 when there is one, 0 when no occluder triangle is near at all): every occluder
// triangle whose box meets the box around both lies in one plane with the receivers.
// Degenerate triangles (the placeholder of a scene without occluders) stop nothing. Gives up
// (w = -1) past CLEAR_NODES nodes or when the triangles near are not all in that plane.
fn unoccluded_tile(lo: vec3<f32>, hi: vec3<f32>, llo: vec3<f32>, lhi: vec3<f32>) -> vec4<f32> {
    let qlo = min(lo, llo);
    let qhi = max(hi, lhi);
    let tol = 1e-5 * (1.0 + max(max(abs(lo.x), abs(lo.y)), max(max(abs(lo.z), abs(hi.x)), max(abs(hi.y), abs(hi.z)))));
    var plane = vec4<f32>(0.0);
    var stack: array<u32, 48>;
    var sp = 1u;
    stack[0] = 0u;
    var visited = 0u;
    while sp > 0u {
        sp -= 1u;
        visited += 1u;
        if visited > CLEAR_NODES {
            return vec4<f32>(-1.0);
        }
        let node = blocker_nodes[stack[sp]];
        if !boxes_overlap(node.lo - tol, node.hi + tol, qlo, qhi) {
            continue;
        }
        if node.count == 0u {
            if sp + 2u > BVH_STACK {
                return vec4<f32>(-1.0);
            }
            stack[sp] = node.first;
            stack[sp + 1u] = node.first + 1u;
            sp += 2u;
            continue;
        }
        for (var k = node.first; k < node.first + node.count; k++) {
            let t = blocker_tris[k];
            if !(length(cross(t.e1.xyz, t.e2.xyz)) > 0.0) {
                continue;
            }
            let a = t.v0.xyz;
            let b = a + t.e1.xyz;
            let c = a + t.e2.xyz;
            if !boxes_overlap(min(a, min(b, c)) - tol, max(a, max(b, c)) + tol, qlo, qhi) {
                continue;
            }
            let n = coplanar_normal(t, lo, hi, tol);
            if all(n == vec3<f32>(0.0)) || (plane.w > 0.0 && abs(dot(n, plane.xyz)) < 0.99999) {
                return vec4<f32>(-1.0);
            }
            plane = vec4<f32>(n, 1.0);
        }
    }
    return plane;
}

@compute @workgroup_size(16, 16, 1)
fn csl_tiles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32) {
    let size = vec2<u32>(u32(g.viewport.x), u32(g.viewport.y));
    let inside = gid.x < size.x && gid.y < size.y;
    if li < 3u {
        atomicStore(&tile_lo[li], 0xffffffffu);
        atomicStore(&tile_hi[li], 0u);
    }
    if li < 3u {
        atomicStore(&light_lo[li], 0xffffffffu);
        atomicStore(&light_hi[li], 0u);
    }
    if li == 0u {
        atomicStore(&tile_margin, 0u);
        atomicStore(&tile_any, 0u);
        tile_clear = vec4<f32>(-1.0);
    }
    for (var w = li; w < MAX_WORDS; w += TILE * TILE) {
        atomicStore(&tile_mask[w], 0u);
    }
    workgroupBarrier();
    var r: Receiver;
    r.ok = false;
    if inside {
        r = receiver(gid.xy);
    }
    if r.ok {
        for (var k = 0u; k < 3u; k++) {
            atomicMin(&tile_lo[k], ordered(r.p[k]));
            atomicMax(&tile_hi[k], ordered(r.p[k]));
        }
        // The footprint's corners are within half its edges' lengths of the point (and their
        // projections onto a light plane closer still).
        atomicMax(&tile_margin, bitcast<u32>(0.5 * (length(r.e1) + length(r.e2))));
        atomicStore(&tile_any, 1u);
    }
    workgroupBarrier();
    let n = g.counts.w;
    if atomicLoad(&tile_any) != 0u {
        let lo = vec3<f32>(unordered(atomicLoad(&tile_lo[0])), unordered(atomicLoad(&tile_lo[1])), unordered(atomicLoad(&tile_lo[2])));
        let hi = vec3<f32>(unordered(atomicLoad(&tile_hi[0])), unordered(atomicLoad(&tile_hi[1])), unordered(atomicLoad(&tile_hi[2])));
        let margin = bitcast<f32>(atomicLoad(&tile_margin));
        for (var i = li; i < n; i += TILE * TILE) {
            let c = csls[i];
            if may_reach(c, lo, hi, margin) {
                atomicOr(&tile_mask[i / 32u], 1u << (i % 32u));
                // The CSL's image square on its light plane, where its rays start.
                for (var k = 0u; k < 4u; k++) {
                    let sx = select(-1.0, 1.0, (k & 1u) != 0u);
                    let sy = select(-1.0, 1.0, (k & 2u) != 0u);
                    let q = c.origin + c.half_extent * (sx * c.x_axis + sy * c.y_axis);
                    for (var j = 0u; j < 3u; j++) {
                        atomicMin(&light_lo[j], ordered(q[j]));
                        atomicMax(&light_hi[j], ordered(q[j]));
                    }
                }
            }
        }
    }
    workgroupBarrier();
    if li == 0u && atomicLoad(&tile_any) != 0u && atomicLoad(&light_hi[0]) != 0u {
        let lo = vec3<f32>(unordered(atomicLoad(&tile_lo[0])), unordered(atomicLoad(&tile_lo[1])), unordered(atomicLoad(&tile_lo[2])));
        let hi = vec3<f32>(unordered(atomicLoad(&tile_hi[0])), unordered(atomicLoad(&tile_hi[1])), unordered(atomicLoad(&tile_hi[2])));
        let llo = vec3<f32>(unordered(atomicLoad(&light_lo[0])), unordered(atomicLoad(&light_lo[1])), unordered(atomicLoad(&light_lo[2])));
        let lhi = vec3<f32>(unordered(atomicLoad(&light_hi[0])), unordered(atomicLoad(&light_hi[1])), unordered(atomicLoad(&light_hi[2])));
        tile_clear = unoccluded_tile(lo, hi, llo, lhi);
    }
    workgroupBarrier();
    if !r.ok {
        if inside {
            textureStore(caustics, gid.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        }
        return;
    }
    let m = materials[r.material];
    // Where an occluder may stand between the tile and its CSLs, every CSL goes to csl_wide,
    // which traces the occlusion rays; elsewhere the point evaluations are shaded here.
    let tc = tile_clear;
    let clear = tc.w == 0.0 || (tc.w > 0.0 && abs(dot(r.ng, tc.xyz)) > 0.99999);
    var sum = vec3<f32>(0.0);
    var marks: array<u32, 32>;
    var any_marks = false;
    let words = csl_words();
    for (var w = 0u; w < words; w++) {
        var bits = atomicLoad(&tile_mask[w]);
        var word = 0u;
        while bits != 0u {
            let bit = firstTrailingBit(bits);
            bits &= bits - 1u;
            let c = csls[w * 32u + bit];
            let l = csl_local(c, r.p);
            if !(l.z > 0.0) {
                continue;
            }
            if !clear {
                word |= 1u << bit;
                continue;
            }
            let need = footprint_need(c, l, r);
            if need == 2u {
                word |= 1u << bit;
            } else if need == 1u {
                sum += shade_point(c, l, r, m);
            }
        }
        marks[w] = word;
        any_marks = any_marks || word != 0u;
    }
    if any_marks {
        let slot = atomicAdd(&wide.count, 1u);
        wide_slots[slot] = vec4<f32>(sum, bitcast<f32>(gid.y * size.x + gid.x));
        for (var w = 0u; w < words; w++) {
            wide_marks[slot * words + w] = marks[w];
        }
    }
    textureStore(caustics, gid.xy, vec4<f32>(sum * g.csl_irradiance.rgb, 1.0));
}

@compute @workgroup_size(1, 1, 1)
fn csl_wide_args() {
    let n = atomicLoad(&wide.count);
    wide.groups_x = (n + WIDE_GROUP - 1u) / WIDE_GROUP;
    wide.groups_y = 1u;
    wide.groups_z = 1u;
}

@compute @workgroup_size(64, 1, 1)
fn csl_wide(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = gid.x;
    if slot >= atomicLoad(&wide.count) {
        return;
    }
    let s = wide_slots[slot];
    let index = bitcast<u32>(s.w);
    let width = u32(g.viewport.x);
    let px = vec2<u32>(index % width, index / width);
    let r = receiver(px);
    let m = materials[r.material];
    var sum = s.xyz;
    let words = csl_words();
    for (var w = 0u; w < words; w++) {
        var bits = wide_marks[slot * words + w];
        while bits != 0u {
            let bit = firstTrailingBit(bits);
            bits &= bits - 1u;
            let c = csls[w * 32u + bit];
            let arr = csl_arrivals_px(c, r.p, r.e1, r.e2);
            for (var k = 0u; k < arr.count; k++) {
                sum += shade_arrival(c, r, m, arr.dir[k], arr.density[k]);
            }
        }
    }
    textureStore(caustics, px, vec4<f32>(sum * g.csl_irradiance.rgb, 1.0));
}
