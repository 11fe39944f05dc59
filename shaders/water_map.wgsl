// The water's light map (Sanchez-Crespo 2003; render/water/gpu.rs): irradiance over the
// receivers under the water, stored over the water's rectangle as seen along the refracted
// sun (map_uv in water.inc.wgsl), for water.wgsl to read per pixel.
//
// The physical mode fills it in two steps:
//   land: one invocation per vertex of a grid of the sun's rays over the rectangle, per
//     direction over the sun's disc. The ray meets the wave surface at s(x, z) and carries
//     E (-L . n~) dx dz (n~ = (-dh/dx, 1, -dh/dz): the surface's projected area) times the
//     Fresnel transmittance; refracted by the analytic normal, it is followed through the
//     blockers (every object but the water surfaces) to the first receiver point q.
//   vs_splat / fs_splat: each grid triangle whose three rays landed on one plane (normals
//     within 8 degrees, corners within the tolerance of its plane) adds its flux over the area
//     of the triangle they form there, E = flux / area, to the texels it covers (additive
//     blending); a triangle smaller than the sun disc's blur at its distance (or the least
//     spread) is first grown to it about its centroid. All triangles that focus on a texel
//     add up, so folds and focal lines are right. Beer-Lambert attenuates each corner over
//     its path.
// The article's texture-space variant instead evaluates the article's irradiance at the first
// receiver under each texel (fs_article_map). Either map is then copied into a storage buffer
// (mip0) with, for the footprint lookup, 2 x 2 box mips after it (mip): water.wgsl reads the
// levels from there, as a per-pixel level in textureLoad is not read right by every adapter.

#include "water.inc.wgsl"

// Where one grid ray lands: q and w = (-L . n~) (1 - F) (0: it does not land); n, the
// receiver's unit normal facing the ray; path, the refracted ray's length, negative when its
// midpoint is outside the water (no absorption).
struct Landing {
    q: vec3<f32>,
    w: f32,
    n: vec3<f32>,
    path: f32,
}

@group(0) @binding(22) var<storage, read_write> landings_out: array<Landing>;
@group(0) @binding(23) var<storage, read> landings: array<Landing>;
// xyz: a travel direction over the sun's disc.
@group(0) @binding(24) var<storage, read> sun_dirs: array<vec4<f32>>;
// The level above the one being made.
// The light map's finest level as rendered.
@group(0) @binding(25) var finest: texture_2d<f32>;
// Its levels, finest first, each row by row (rgb; w unused).
@group(0) @binding(26) var<storage, read_write> pyramid: array<vec4<f32>>;
// The level a mip dispatch makes: x, its first texel in the pyramid; y, its texels a side;
// z, the finer level's first texel; w, the finer level's texels a side.
@group(0) @binding(27) var<uniform> level: vec4<u32>;

@compute @workgroup_size(8, 8, 1)
fn land(@builtin(global_invocation_id) id: vec3<u32>) {
    let g = water.grid.x;
    let n1 = g + 1u;
    if id.x > g || id.y > g || id.z >= water.grid.y {
        return;
    }
    let k = id.z * n1 * n1 + id.y * n1 + id.x;
    var out = Landing(vec3<f32>(0.0), 0.0, vec3<f32>(0.0, 1.0, 0.0), 0.0);
    let l = sun_dirs[id.z].xyz;
    let x = water.centre.x + (f32(id.x) / f32(g) - 0.5) * water.size.x;
    let z = water.centre.z + (f32(id.y) / f32(g) - 0.5) * water.size.y;
    let h = wave(x, z);
    let p = vec3<f32>(x, water.centre.y + h.x, z);
    let nt = vec3<f32>(-h.y, 1.0, -h.z);
    let n = normalize(nt);
    let cos_i = -dot(l, n);
    let eta = 1.0 / water.size.w;
    let t = refract(l, n, eta);
    if cos_i <= 0.0 || dot(t, t) == 0.0 {
        landings_out[k] = out;
        return;
    }
    if water.grid.z == 1u && occluded(p + n * 1e-4, -l, 1e30) {
        landings_out[k] = out;
        return;
    }
    let o = p + t * 1e-4;
    let hit = closest_hit(o, t, 1e30);
    if hit.tri == 0xffffffffu {
        landings_out[k] = out;
        return;
    }
    let q = o + t * hit.t;
    out.q = q;
    out.w = -dot(l, nt) * (1.0 - fresnel_dielectric(cos_i, eta));
    out.n = blocker_normal(hit.tri, t);
    out.path = select(-hit.t, hit.t, in_water(0.5 * (o + q)));
    landings_out[k] = out;
}

struct Splat {
    @builtin(position) pos: vec4<f32>,
    @location(0) @interpolate(flat) e: vec3<f32>,
}

fn absorbed(l: Landing) -> vec3<f32> {
    if l.path > 0.0 {
        return beer(l.path);
    }
    return vec3<f32>(1.0);
}

// Vertex c of triangle (vertex_index / 3) of the grid for sun direction instance_index: two
// triangles per quad, (i, j) (i, j+1) (i+1, j) and (i+1, j) (i, j+1) (i+1, j+1).
@vertex
fn vs_splat(@builtin(vertex_index) vi: u32, @builtin(instance_index) si: u32) -> Splat {
    var out = Splat(vec4<f32>(2.0, 2.0, 2.0, 1.0), vec3<f32>(0.0));
    let g = water.grid.x;
    let n1 = g + 1u;
    let cell = vi / 6u;
    let c = vi % 6u;
    let i = cell % g;
    let j = cell / g;
    let base = si * n1 * n1 + j * n1 + i;
    var ids = array<u32, 3>(base, base + n1, base + 1u);
    if c >= 3u {
        ids = array<u32, 3>(base + 1u, base + n1, base + n1 + 1u);
    }
    let a = landings[ids[0]];
    let b = landings[ids[1]];
    let d = landings[ids[2]];
    if a.w <= 0.0 || b.w <= 0.0 || d.w <= 0.0 {
        return out;
    }
    if dot(a.n, b.n) < 0.99 || dot(a.n, d.n) < 0.99 {
        return out;
    }
    let tol = water.splat.z;
    if abs(dot(b.q - a.q, a.n)) > tol || abs(dot(d.q - a.q, a.n)) > tol {
        return out;
    }
    var q = array<vec3<f32>, 3>(a.q, b.q, d.q);
    var area2 = length(cross(q[1] - q[0], q[2] - q[0]));
    if area2 <= 1e-14 {
        return out;
    }
    let mean_path = (abs(a.path) + abs(b.path) + abs(d.path)) / 3.0;
    let r = max(mean_path * water.splat.x, water.splat.y);
    let min_area = PI * r * r;
    var corner = q[c % 3u];
    if area2 < 2.0 * min_area {
        let centroid = (q[0] + q[1] + q[2]) / 3.0;
        corner = centroid + (corner - centroid) * sqrt(2.0 * min_area / area2);
        area2 = 2.0 * min_area;
    }
    let flux = water.sun_e.rgb
        * (a.w * absorbed(a) + b.w * absorbed(b) + d.w * absorbed(d))
        * (water.splat.w / 3.0);
    out.e = flux * (2.0 / area2);
    let uv = map_uv(corner);
    out.pos = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.5, 1.0);
    return out;
}

@fragment
fn fs_splat(in: Splat) -> @location(0) vec4<f32> {
    return vec4<f32>(in.e, 0.0);
}

@vertex
fn vs_full(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle over the whole target.
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

// The article's irradiance at the first receiver along the refracted sun under the texel's
// point of the mean surface plane.
@fragment
fn fs_article_map(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    let uv = frag.xy / f32(water.grid.w);
    let m = water.map.xy + uv * water.map.zw;
    let u = water.up.xyz;
    // Start under the lowest trough, on the line through (m, mean height) along -u.
    let drop = water.beam.w + 1e-3;
    let o = vec3<f32>(m.x, water.centre.y, m.y) - u * (drop / u.y);
    let hit = closest_hit(o, -u, 1e30);
    if hit.tri == 0xffffffffu {
        return vec4<f32>(0.0);
    }
    let q = o - u * hit.t;
    let n = blocker_normal(hit.tri, -u);
    if !in_water(q + n * 1e-3) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(irradiance(q, n), 0.0);
}

// The finest level into the pyramid.
@compute @workgroup_size(8, 8, 1)
fn mip0(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = level.y;
    if id.x < n && id.y < n {
        pyramid[level.x + id.y * n + id.x] = textureLoad(finest, vec2<i32>(id.xy), 0);
    }
}

// One texel of a coarser level: the mean of the (up to) 2 x 2 texels of the finer one under it.
@compute @workgroup_size(8, 8, 1)
fn mip(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = level.y;
    if id.x >= n || id.y >= n {
        return;
    }
    let m = level.w;
    var sum = vec4<f32>(0.0);
    var c = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let x = 2u * id.x + (k & 1u);
        let y = 2u * id.y + (k >> 1u);
        if x < m && y < m {
            sum += pyramid[level.z + y * m + x];
            c += 1.0;
        }
    }
    pyramid[level.x + id.y * n + id.x] = sum / max(c, 1.0);
}
