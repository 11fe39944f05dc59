// Occlusion of caustic light: one shadow ray through the occluder hierarchy that
// src/render/blockers.rs builds (every triangle except the caustic objects', median-split BVH,
// children stored side by side). The traversal and the Moller-Trumbore test are the same as
// Blockers::occluded on the CPU. Declares its two storage buffers itself (group 0, bindings 8
// and 9) so that it validates on its own.

struct BvhNode {
    lo: vec3<f32>,
    // Inner node (count == 0): index of the left child, the right one follows it.
    // Leaf: index of its first triangle.
    first: u32,
    hi: vec3<f32>,
    count: u32,
}

struct BlockerTri {
    v0: vec4<f32>,
    e1: vec4<f32>,
    e2: vec4<f32>,
}

@group(0) @binding(8) var<storage, read> blocker_nodes: array<BvhNode>;
@group(0) @binding(9) var<storage, read> blocker_tris: array<BlockerTri>;

const BVH_STACK: u32 = 48u;
const EDGE_SLACK: f32 = 1e-5;

fn bvh_slab(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, inv: vec3<f32>, t_max: f32) -> bool {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let tmin = min(t0, t1);
    let tmax = max(t0, t1);
    let tn = max(max(max(tmin.x, tmin.y), tmin.z), 0.0);
    let tf = min(min(min(tmax.x, tmax.y), tmax.z), t_max);
    return tn <= tf;
}

fn blocker_hit(t: BlockerTri, o: vec3<f32>, d: vec3<f32>) -> f32 {
    let p = cross(d, t.e2.xyz);
    let det = dot(t.e1.xyz, p);
    if abs(det) < 1e-12 {
        return -1.0;
    }
    let inv = 1.0 / det;
    let s = o - t.v0.xyz;
    // Edges widened by EDGE_SLACK (barycentric units, as on the CPU) so that a ray through
    // the shared edge of two triangles meets at least one of them.
    let u = dot(s, p) * inv;
    if u < -EDGE_SLACK || u > 1.0 + EDGE_SLACK {
        return -1.0;
    }
    let q = cross(s, t.e1.xyz);
    let v = dot(d, q) * inv;
    if v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return -1.0;
    }
    return dot(t.e2.xyz, q) * inv;
}

// The nearest occluder triangle on origin + t*dir, 0 < t < t_max (with `first_found`, the
// first one found): its distance and index (tri == 0xffffffff: none). v0.w holds the
// triangle's material index, for passes that follow a ray to whatever it meets first (the
// water's refracted sun rays and view rays).
struct BlockerHit {
    t: f32,
    tri: u32,
}

fn traverse(o: vec3<f32>, d: vec3<f32>, t_max: f32, first_found: bool) -> BlockerHit {
    let inv = 1.0 / d;
    var best = BlockerHit(t_max, 0xffffffffu);
    var stack: array<u32, 48>;
    var sp = 1u;
    stack[0] = 0u;
    while sp > 0u {
        sp -= 1u;
        let n = blocker_nodes[stack[sp]];
        if !bvh_slab(n.lo, n.hi, o, inv, best.t) {
            continue;
        }
        if n.count == 0u {
            if sp + 2u <= BVH_STACK {
                stack[sp] = n.first;
                stack[sp + 1u] = n.first + 1u;
                sp += 2u;
            }
            continue;
        }
        for (var k = n.first; k < n.first + n.count; k++) {
            let t = blocker_hit(blocker_tris[k], o, d);
            if t > 0.0 && t < best.t {
                best = BlockerHit(t, k);
                if first_found {
                    return best;
                }
            }
        }
    }
    return best;
}

// Whether an occluder lies on origin + t*dir, 0 < t < t_max.
fn occluded(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> bool {
    return traverse(o, d, t_max, true).tri != 0xffffffffu;
}

// The nearest occluder on origin + t*dir, 0 < t < t_max.
fn closest_hit(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> BlockerHit {
    return traverse(o, d, t_max, false);
}

// The unit geometric normal of blocker triangle k, facing against d.
fn blocker_normal(k: u32, d: vec3<f32>) -> vec3<f32> {
    let tri = blocker_tris[k];
    let n = normalize(cross(tri.e1.xyz, tri.e2.xyz));
    return select(n, -n, dot(n, d) > 0.0);
}
