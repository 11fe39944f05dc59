// Method photons, pass 1 of 2 (render/photons): one invocation per photon. The photon leaves
// its light towards one specular object's bounding sphere (one population per light and
// object, as the reference's targeted populations), is traced through the glass and mirrors of
// the whole scene (the BVH of occlusion.inc.wgsl over every triangle, with the vertex normals
// beside it) with Fresnel, total internal reflection, Beer-Lambert absorption and the adjoint
// BSDF's shading-normal correction (Veach 1997, §5.3), and where it first meets a receiver
// after at least one specular vertex (L S+ D) it is stored with its footprint. The footprint
// comes from ray differentials carried along the path (Igehy 1999; photon differentials,
// Schjøth et al. 2007): the spacing of neighbouring photons at the light, transferred to each
// surface, reflected and refracted with the shading normal's derivative. Pass 2
// (photon_splat.wgsl) draws each stored photon as an elliptic kernel over the G-buffer.

#include "common.inc.wgsl"
#include "occlusion.inc.wgsl"

// A population's light kind: LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT (common.inc.wgsl) and:
const KIND_LINE: u32 = 3u;
const KIND_ENVIRONMENT: u32 = 4u;
const NONE: u32 = 0xffffffffu;

struct PhotonFrame {
    // x: photons in this dispatch, y: populations, z: this frame's seed, w: most vertices of a path.
    counts: vec4<u32>,
    // x: kernel half-size in photon spacings (this frame's), y: the smallest semi-axis per
    // metre from the eye, z: largest semi-axis (m), w: largest semi-axis in those units.
    footprint: vec4<f32>,
    // xyz: the camera.
    eye: vec4<f32>,
}

struct Population {
    // x: light kind, y: first photon of the dispatch, z: photons, w: target object.
    ids: vec4<u32>,
    // xyz: point, spot or line-start position; w: the directional light's angular radius.
    position: vec4<f32>,
    // xyz: travel direction (directional) or beam axis (spot).
    direction: vec4<f32>,
    // xyz: the line's end; environment: x its first direction in env_dirs, y their count.
    end: vec4<f32>,
    // rgb: irradiance W/m² (directional) or intensity W/sr (point, spot, line); radiance
    // scale (environment).
    intensity: vec4<f32>,
    // x: spot cutoff (rad), y: beam width (rad).
    spot: vec4<f32>,
    // xyz: centre of the target object's bounding sphere, w: its radius.
    target_sphere: vec4<f32>,
}

// The shading normals of triangle k of the BVH (its vertices' normals), w of n0: its object.
struct TriNormals {
    n0: vec4<f32>,
    n1: vec4<f32>,
    n2: vec4<f32>,
}

// An importance-sampled direction of an environment light (CPU, per frame): the direction the
// light travels, and its radiance over the direction's pdf.
struct EnvDir {
    dir: vec4<f32>,
    weight: vec4<f32>,
}

// A photon on a receiver: position and flux (W), the footprint's two orthogonal semi-axes in
// the surface's plane, and the unit direction towards where it came from.
struct PhotonRecord {
    p: vec4<f32>,
    u: vec4<f32>,
    v: vec4<f32>,
    wi: vec4<f32>,
}

// The splat pass's indirect draw: 6 vertices per stored photon, the count of stored photons.
struct DrawArgs {
    vertex_count: u32,
    instance_count: atomic<u32>,
    first_vertex: u32,
    first_instance: u32,
}

@group(0) @binding(0) var<uniform> frame: PhotonFrame;
@group(0) @binding(1) var<storage, read> pops: array<Population>;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(3) var<storage, read> tri_normals: array<TriNormals>;
@group(0) @binding(4) var<storage, read> env_dirs: array<EnvDir>;
@group(0) @binding(5) var<storage, read_write> records: array<PhotonRecord>;
@group(0) @binding(6) var<storage, read_write> draw: DrawArgs;

var<private> rng: u32;

fn pcg(v: u32) -> u32 {
    let s = v * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// PCG32 with the RXS-M-XS output (O'Neill 2014): an LCG step, then the permuted output.
fn rnd() -> f32 {
    rng = rng * 747796405u + 2891336453u;
    let w = ((rng >> ((rng >> 28u) + 4u)) ^ rng) * 277803737u;
    return f32(((w >> 22u) ^ w) >> 8u) * (1.0 / 16777216.0);
}

// Two unit vectors completing the unit n to an orthonormal basis.
fn basis(n: vec3<f32>) -> mat2x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return mat2x3<f32>(
        vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        vec3<f32>(b, s + n.y * n.y * a, -n.y),
    );
}

fn uniform_cone(axis: vec3<f32>, cos_max: f32) -> vec3<f32> {
    let c = 1.0 - rnd() * (1.0 - cos_max);
    let s = sqrt(max(1.0 - c * c, 0.0));
    let phi = 2.0 * PI * rnd();
    let t = basis(axis);
    return normalize(t[0] * (s * cos(phi)) + t[1] * (s * sin(phi)) + axis * c);
}

// Cosine of the half-angle of the cone from p that holds the sphere (c, r); -1 inside it.
fn cone_cos(p: vec3<f32>, c: vec3<f32>, r: f32) -> f32 {
    let d = length(c - p);
    if d <= r * 1.0001 {
        return -1.0;
    }
    return sqrt(max(1.0 - (r / d) * (r / d), 0.0));
}

// Where o + t·d (inv = 1/d) enters node n's box before t_max; -1 when it does not.
fn box_entry(n: BvhNode, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> f32 {
    let t0 = (n.lo - o) * inv;
    let t1 = (n.hi - o) * inv;
    let lo = min(t0, t1);
    let hi = max(t0, t1);
    let tn = max(max(max(lo.x, lo.y), lo.z), 0.0);
    let tf = min(min(min(hi.x, hi.y), hi.z), t_max);
    return select(-1.0, tn, tn <= tf);
}

// The nearest triangle on o + t·d, t > 0: occlusion.inc.wgsl's tree walked front to back (the
// nearer child first, a subtree skipped once a hit is nearer than its box), which finds the
// nearest hit in far fewer steps than its fixed-order `closest_hit`.
fn nearest_hit(o: vec3<f32>, d: vec3<f32>) -> BlockerHit {
    let inv = 1.0 / d;
    var best = BlockerHit(1e30, NONE);
    if box_entry(blocker_nodes[0], o, inv, best.t) < 0.0 {
        return best;
    }
    var stack: array<u32, 48>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = blocker_nodes[node];
        var next = NONE;
        if n.count == 0u {
            let ta = box_entry(blocker_nodes[n.first], o, inv, best.t);
            let tb = box_entry(blocker_nodes[n.first + 1u], o, inv, best.t);
            if ta >= 0.0 && tb >= 0.0 {
                let a_first = ta <= tb;
                next = select(n.first + 1u, n.first, a_first);
                if sp < BVH_STACK {
                    stack[sp] = select(n.first, n.first + 1u, a_first);
                    sp += 1u;
                }
            } else if ta >= 0.0 {
                next = n.first;
            } else if tb >= 0.0 {
                next = n.first + 1u;
            }
        } else {
            for (var k = n.first; k < n.first + n.count; k++) {
                let t = blocker_hit(blocker_tris[k], o, d);
                if t > 0.0 && t < best.t {
                    best = BlockerHit(t, k);
                }
            }
        }
        // Else the nearest subtree left on the stack that a hit found since has not ruled out.
        while next == NONE && sp > 0u {
            sp -= 1u;
            let c = stack[sp];
            if box_entry(blocker_nodes[c], o, inv, best.t) >= 0.0 {
                next = c;
            }
        }
        if next == NONE {
            return best;
        }
        node = next;
    }
    return best;
}

// A photon leaving its light: position, direction, flux and the differentials of position and
// direction across neighbouring photons (dp.x/dp.y, dd.x/dd.y).
struct Emitted {
    o: vec3<f32>,
    d: vec3<f32>,
    flux: vec3<f32>,
    dpu: vec3<f32>,
    dpv: vec3<f32>,
    ddu: vec3<f32>,
    ddv: vec3<f32>,
}

// From a point light at p: uniform in the cone holding the target, each photon carrying
// I·Ω/N, neighbours an angle sqrt(Ω/N) apart.
fn from_point(p: vec3<f32>, pop: Population, n: f32) -> Emitted {
    var e: Emitted;
    let c = pop.target_sphere;
    let cos_max = cone_cos(p, c.xyz, c.w);
    let axis = normalize(c.xyz - p);
    let omega = 2.0 * PI * (1.0 - cos_max);
    e.o = p;
    e.d = uniform_cone(axis, cos_max);
    e.flux = pop.intensity.rgb * (omega / n);
    let t = basis(e.d);
    let a = sqrt(omega / n);
    e.ddu = t[0] * a;
    e.ddv = t[1] * a;
    return e;
}

// From a far light along unit d: a uniform point on the disc facing d that covers the target,
// each photon carrying its irradiance times the disc over N, neighbours sqrt(A/N) apart.
fn from_far(d: vec3<f32>, pop: Population, n: f32) -> Emitted {
    var e: Emitted;
    let c = pop.target_sphere;
    let t = basis(d);
    let r = c.w * sqrt(rnd());
    let phi = 2.0 * PI * rnd();
    e.o = c.xyz + t[0] * (r * cos(phi)) + t[1] * (r * sin(phi)) - d * (2.0 * c.w + 1.0);
    e.d = d;
    let area = PI * c.w * c.w;
    e.flux = vec3<f32>(area / n);
    let h = sqrt(area / n);
    e.dpu = t[0] * h;
    e.dpv = t[1] * h;
    return e;
}

fn emit(pop: Population) -> Emitted {
    let n = f32(pop.ids.z);
    let kind = pop.ids.x;
    var e: Emitted;
    if kind == LIGHT_DIRECTIONAL {
        var d = pop.direction.xyz;
        if pop.position.w > 0.0 {
            d = uniform_cone(d, cos(pop.position.w));
        }
        e = from_far(d, pop, n);
        e.flux *= pop.intensity.rgb;
    } else if kind == KIND_ENVIRONMENT {
        let count = u32(pop.end.y);
        let s = env_dirs[u32(pop.end.x) + min(u32(rnd() * f32(count)), count - 1u)];
        e = from_far(s.dir.xyz, pop, n);
        e.flux *= s.weight.rgb * pop.intensity.rgb;
    } else if kind == KIND_LINE {
        e = from_point(mix(pop.position.xyz, pop.end.xyz, rnd()), pop, n);
    } else {
        e = from_point(pop.position.xyz, pop, n);
        if kind == LIGHT_SPOT {
            e.flux *= spot_falloff(dot(e.d, pop.direction.xyz), pop.spot.x, pop.spot.y);
        }
    }
    return e;
}

// The footprint's semi-axes: the ellipse that the differentials du, dv (in the plane of the
// unit normal n) span, its axes clamped to [lo, hi].
fn footprint(du: vec3<f32>, dv: vec3<f32>, n: vec3<f32>, lo: f32, hi: f32) -> mat2x3<f32> {
    let t = basis(n);
    let ju = vec2<f32>(dot(du, t[0]), dot(du, t[1]));
    let jv = vec2<f32>(dot(dv, t[0]), dot(dv, t[1]));
    // The ellipse's shape J·Jᵀ.
    let a = ju.x * ju.x + jv.x * jv.x;
    let c = ju.y * ju.y + jv.y * jv.y;
    let b = ju.x * ju.y + jv.x * jv.y;
    let m = 0.5 * (a + c);
    let q = sqrt(max(0.25 * (a - c) * (a - c) + b * b, 0.0));
    let l1 = m + q;
    let l2 = max(m - q, 0.0);
    var e = vec2<f32>(b, l1 - a);
    let e_alt = vec2<f32>(l1 - c, b);
    if dot(e_alt, e_alt) > dot(e, e) {
        e = e_alt;
    }
    if dot(e, e) < 1e-30 {
        e = vec2<f32>(1.0, 0.0);
    }
    e = normalize(e);
    let ax1 = t[0] * e.x + t[1] * e.y;
    let ax2 = cross(n, ax1);
    return mat2x3<f32>(ax1 * clamp(sqrt(l1), lo, hi), ax2 * clamp(sqrt(l2), lo, hi));
}

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.x;
    if id >= frame.counts.x {
        return;
    }
    var pi = 0u;
    for (var k = 0u; k < frame.counts.y; k++) {
        let p = pops[k].ids;
        if id >= p.y && id < p.y + p.z {
            pi = k;
            break;
        }
    }
    let pop = pops[pi];
    rng = pcg(id + pcg(frame.counts.z));
    var e = emit(pop);
    if all(e.flux <= vec3<f32>(0.0)) {
        return;
    }
    var o = e.o;
    var d = e.d;
    var flux = e.flux;
    var dpu = e.dpu;
    var dpv = e.dpv;
    var ddu = e.ddu;
    var ddv = e.ddv;
    for (var depth = 0u; depth < frame.counts.w; depth++) {
        let h = nearest_hit(o, d);
        if h.tri == NONE {
            return;
        }
        let tri = blocker_tris[h.tri];
        let nrm = tri_normals[h.tri];
        let m = materials[u32(tri.v0.w)];
        let specular = m.kind == MAT_DIELECTRIC || m.kind == MAT_MIRROR;
        if depth == 0u && (!specular || u32(nrm.n0.w) != pop.ids.w) {
            // The direct light's, or another population's path.
            return;
        }
        let p = o + d * h.t;
        let e1 = tri.e1.xyz;
        let e2 = tri.e2.xyz;
        let gw = cross(e1, e2);
        let gg = dot(gw, gw);
        let front = dot(gw, d) < 0.0;
        let ng = select(-gw, gw, front) / sqrt(gg);
        // Transfer the differentials to the hit's plane.
        dpu += h.t * ddu;
        dpv += h.t * ddv;
        let dn_ = dot(d, ng);
        dpu -= d * (dot(dpu, ng) / dn_);
        dpv -= d * (dot(dpv, ng) / dn_);
        // The interpolated shading normal, on the ray's side like the geometric one, and its
        // derivatives along the differentials.
        let r = p - tri.v0.xyz;
        let b1 = dot(cross(r, e2), gw) / gg;
        let b2 = dot(cross(e1, r), gw) / gg;
        // As trace::Accel: the normal turned with the winding, the geometric one where it
        // would face away from it (and then no derivative).
        let raw = nrm.n0.xyz * (1.0 - b1 - b2) + nrm.n1.xyz * b1 + nrm.n2.xyz * b2;
        let len = length(raw);
        let flip = select(-1.0, 1.0, front);
        var ns = raw * (flip / max(len, 1e-30));
        var dnu = vec3<f32>(0.0);
        var dnv = vec3<f32>(0.0);
        if len <= 0.0 || dot(ns, ng) <= 0.0 {
            ns = ng;
        } else {
            let dn1 = nrm.n1.xyz - nrm.n0.xyz;
            let dn2 = nrm.n2.xyz - nrm.n0.xyz;
            let rawu = dn1 * (dot(cross(dpu, e2), gw) / gg) + dn2 * (dot(cross(e1, dpu), gw) / gg);
            let rawv = dn1 * (dot(cross(dpv, e2), gw) / gg) + dn2 * (dot(cross(e1, dpv), gw) / gg);
            dnu = (rawu - ns * dot(ns, rawu)) * (flip / len);
            dnv = (rawv - ns * dot(ns, rawv)) * (flip / len);
        }
        let wi = -d;
        let si = dot(ns, wi);
        let gi = dot(ng, wi);
        if !specular {
            // A receiver after at least one specular vertex: store the photon.
            if si <= 0.0 {
                return;
            }
            let dist = length(p - frame.eye.xyz);
            let s = frame.footprint.x;
            // At least part of a pixel, so that a focus still lands on pixel centres; at most
            // some pixels, which bounds a splat's cost where photons spread far apart.
            let px = frame.footprint.y * dist;
            let hi = max(min(frame.footprint.z, frame.footprint.w * px), px);
            let f = footprint(dpu * s, dpv * s, ng, px, hi);
            // A differential transferred at a grazing hit can overflow: such a photon (and a
            // flux that is not finite) would splat NaN, so it is not stored. Comparisons with
            // NaN are false, so the test is written to pass only finite values.
            let big = vec3<f32>(1e30);
            if !(all(abs(f[0]) < big) && all(abs(f[1]) < big) && all(abs(flux) < big)) {
                return;
            }
            let k = atomicAdd(&draw.instance_count, 1u);
            records[k] = PhotonRecord(
                vec4<f32>(p, flux.r),
                vec4<f32>(f[0], flux.g),
                vec4<f32>(f[1], flux.b),
                vec4<f32>(wi, 0.0),
            );
            return;
        }
        // Leaks: the light arrives on the other side of the shading normal.
        if si <= 0.0 {
            return;
        }
        var nd: vec3<f32>;
        var ddu2: vec3<f32>;
        var ddv2: vec3<f32>;
        let dns = dot(d, ns);
        let ddnu = dot(ddu, ns) + dot(d, dnu);
        let ddnv = dot(ddv, ns) + dot(d, dnv);
        var reflect_it = true;
        var eta = 1.0;
        if m.kind == MAT_MIRROR {
            flux *= m.albedo.rgb;
        } else {
            if !front {
                // Beer-Lambert inside the glass (its absorption rides in `specular`).
                flux *= exp(-m.specular.rgb * h.t);
            }
            eta = select(m.ior, 1.0 / m.ior, front);
            reflect_it = rnd() < fresnel_dielectric(si, eta);
        }
        if reflect_it {
            nd = d - 2.0 * dns * ns;
            ddu2 = ddu - 2.0 * (dns * dnu + ddnu * ns);
            ddv2 = ddv - 2.0 * (dns * dnv + ddnv * ns);
        } else {
            let sin2_t = eta * eta * (1.0 - si * si);
            let cos_t = sqrt(max(1.0 - sin2_t, 0.0));
            nd = normalize(eta * d + (eta * si - cos_t) * ns);
            let dtn = dot(nd, ns);
            let mu = eta * dns - dtn;
            let dmu = eta - eta * eta * dns / dtn;
            ddu2 = eta * ddu - (mu * dnu + dmu * ddnu * ns);
            ddv2 = eta * ddv - (mu * dnv + dmu * ddnv * ns);
        }
        let so = dot(ns, nd);
        let go = dot(ng, nd);
        if so * go <= 0.0 {
            return;
        }
        flux *= abs((si * go) / (so * gi));
        ddu = ddu2;
        ddv = ddv2;
        let side = select(-1.0, 1.0, go >= 0.0);
        let pa = abs(p);
        o = p + ng * (side * 1e-4 * (1.0 + max(pa.x, max(pa.y, pa.z))));
        d = nd;
    }
}
