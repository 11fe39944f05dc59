// Pinhole caustics (Wand & Strasser 2003; render/pinhole/mod.rs): every sample point on the
// reflectors is a reflecting pinhole camera. Per receiver pixel of the G-buffer and per point:
// the vector d from the receiver to the point, reflected at the point's normal, looks up the
// light arriving there; the contribution is weighted by <n_s,-d><n_d,d>/(<d,d>+eps) times the
// area the point stands for, its reflectance (Fresnel for glass) and the receiver's BRDF.
//
// Anti-aliasing (section 3.3): the reflected direction varies over the point's area with its
// principal curvatures (and with the direction to the receiver); the first-order spread J of
// that variation over a disc of the point's area gives a footprint in direction space. The
// environment map is read from its mip pyramid over that footprint (footprint assembly: taps
// along the major axis at the minor axis' level), delta lights (directional, point, spot) are
// Gaussian lobes of the footprint widened by their angular radius. Without filtering a map is
// read bilinearly at level 0 and a delta light is a disc of its angular radius.

#include "common.inc.wgsl"
#include "occlusion.inc.wgsl"

struct Sample {
    // xyz: position; w: area the point stands for.
    position: vec4<f32>,
    // xyz: unit normal; w: eps.
    normal: vec4<f32>,
    // xyz: principal direction; w: its curvature.
    dir1: vec4<f32>,
    dir2: vec4<f32>,
    // Mirror: rgb reflectance, w 0. Glass: w its ior (reflectance by Fresnel), x 1 when the
    // part is an open surface that also transmits.
    reflectance: vec4<f32>,
}

// A run of points close together (render/pinhole/mod.rs, Morton order within a part): a
// receiver farther than FAR radii from it takes it as one pinhole, its representative point
// standing for their summed area; a nearer one takes every point.
struct Cluster {
    // xyz: the representative's position; w: the radius around it that holds every point.
    centre: vec4<f32>,
    // x: the representative point, y: the first point, z: the points; w: unused.
    range: vec4<u32>,
    // x: the points' summed area; y: its eps; zw: unused.
    area: vec4<f32>,
}

const FAR: f32 = 6.0;

struct SampleLight {
    // xyz: unit direction to the light; w: angular radius.
    dir: vec4<f32>,
    // rgb: irradiance facing the light (0 when shadowed); w: 1 / distance (0: directional).
    irradiance: vec4<f32>,
}

struct Pinhole {
    // x: points, y: delta lights per point, z: clusters, w: mip levels.
    counts: vec4<u32>,
    // rgb: constant environment radiance; w: 1 when a map is bound.
    env: vec4<f32>,
    env_scale: vec4<f32>,
    env_size: vec4<f32>,
    // x: clusters per draw: the pass is split into draws (instance index: the first cluster
    // of the draw) that add up, each under llvmpipe's limit on loop iterations per invocation.
    draw: vec4<u32>,
}

// The pipeline is specialised on what a frame uses (PinholePipeline::fit): llvmpipe pays for
// code in the loop over points even where a uniform flag skips it (about half the time).
override FILTER: bool = true;
override SHADOWS: bool = false;
// Delta lights per point (directional, point, spot, line points) are bound.
override DELTA: bool = true;
// An environment (map or constant) is bound.
override ENV: bool = true;
// Some points lie on an open glass surface (a single interface, section 5) and also send light
// they refract to receivers behind them.
override TRANSMIT: bool = false;
const MAX_TAPS: f32 = 8.0;

@group(0) @binding(0) var<uniform> g: Globals;
@group(0) @binding(2) var<storage, read> materials: array<Material>;
@group(0) @binding(10) var gbuf_position: texture_2d<f32>;
@group(0) @binding(11) var gbuf_normal: texture_2d<f32>;
@group(0) @binding(12) var<storage, read> samples: array<Sample>;
@group(0) @binding(13) var<storage, read> sample_lights: array<SampleLight>;
@group(0) @binding(14) var<uniform> ph: Pinhole;
@group(0) @binding(15) var env_tex: texture_2d<f32>;
@group(0) @binding(16) var env_sampler: sampler;
@group(0) @binding(17) var<storage, read> clusters: array<Cluster>;
struct VsOut {
    @builtin(position) position: vec4<f32>,
    // The draw's first cluster.
    @location(0) @interpolate(flat) first: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) i: u32, @builtin(instance_index) first: u32) -> VsOut {
    // One triangle over the whole target.
    let x = f32((i << 1u) & 2u);
    let y = f32(i & 2u);
    return VsOut(vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0), first);
}

// Orthonormal tangents of unit n (Duff et al. 2017), as sampling::frame.
fn tangent(n: vec3<f32>) -> vec3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    return vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
}

// Change of the reflected direction l = reflect(dn, n) for a step t (unit tangent) on the
// reflector where the normal bends by k: through the normal (n + k t) and through the
// direction to the receiver (dn moves by the step's part across it, over the distance).
fn reflect_spread(dn: vec3<f32>, n: vec3<f32>, t: vec3<f32>, k: f32, dist: f32) -> vec3<f32> {
    let ddn = (t - dn * dot(dn, t)) / dist;
    let dnn = t * k;
    return ddn - 2.0 * ((dot(ddn, n) + dot(dn, dnn)) * n + dot(dn, n) * dnn);
}

// The same for the direction l = refract(dn, -n, ior) on the air side of an interface seen from
// inside it (section 5): a finite difference over a step that turns the normal and the
// direction to the receiver by at most 1e-3 radians.
fn refract_spread(
    dn: vec3<f32>,
    n: vec3<f32>,
    t: vec3<f32>,
    k: f32,
    dist: f32,
    ior: f32,
    l: vec3<f32>,
) -> vec3<f32> {
    let h = 1e-3 / max(max(abs(k), 1.0 / dist), 1.0);
    let d2 = normalize(dn + (t - dn * dot(dn, t)) * (h / dist));
    let n2 = normalize(n + t * (k * h));
    let l2 = refract(d2, -n2, ior);
    if dot(l2, l2) == 0.0 {
        return vec3<f32>(0.0);
    }
    return (l2 - l) / h;
}

// The environment map along direction l (towards the light), bilinearly at level 0.
fn env_point(l: vec3<f32>) -> vec3<f32> {
    return textureSampleLevel(env_tex, env_sampler, env_uv(l), 0.0).rgb;
}

// The environment map averaged over the footprint spanned by the direction-space vectors f1,
// f2 (one standard deviation each) around l.
fn env_filtered(l: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>) -> vec3<f32> {
    let size = ph.env_size.xy;
    // Texels per unit change of direction: gradients of u = atan2(x, -z)/2pi, v = acos(y)/pi.
    let rho2 = max(l.x * l.x + l.z * l.z, 1e-6);
    let gu = vec3<f32>(-l.z, 0.0, l.x) / (2.0 * PI * rho2) * size.x;
    let gv = vec3<f32>(0.0, -1.0 / (PI * sqrt(rho2)), 0.0) * size.y;
    let a = vec2<f32>(dot(gu, f1), dot(gv, f1));
    let b = vec2<f32>(dot(gu, f2), dot(gv, f2));
    // Covariance in texels and its axes.
    let sxx = a.x * a.x + b.x * b.x;
    let syy = a.y * a.y + b.y * b.y;
    let sxy = a.x * a.y + b.x * b.y;
    let mean = 0.5 * (sxx + syy);
    let r = sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
    let major = sqrt(max(mean + r, 0.0));
    var minor = sqrt(max(mean - r, 0.0));
    // Taps 2 minor axes apart, each filtered over that width, so that they leave no gaps.
    minor = max(max(minor, 2.0 * major / MAX_TAPS), 0.5);
    let theta = 0.5 * atan2(2.0 * sxy, sxx - syy);
    let axis = vec2<f32>(cos(theta), sin(theta));
    let level = clamp(log2(2.0 * minor), 0.0, f32(ph.counts.w) - 1.0);
    let uv0 = env_uv(l);
    let n = u32(clamp(ceil(2.0 * major / minor), 1.0, MAX_TAPS));
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var i = 0u; i < n; i++) {
        // Taps spread over +-2 standard deviations of the major axis, Gaussian-weighted.
        let x = select(0.0, (f32(i) + 0.5) / f32(n) * 4.0 - 2.0, n > 1u);
        let w = exp(-0.5 * x * x);
        let uv = uv0 + axis * (x * major) / size;
        sum += w * textureSampleLevel(env_tex, env_sampler, uv, level).rgb;
        wsum += w;
    }
    return sum / wsum;
}

// A delta light seen in direction l through the footprint (f1, f2): a Gaussian lobe around
// its direction w, widened by the disc of angular radius r it appears as.
fn delta_filtered(l: vec3<f32>, f1: vec3<f32>, f2: vec3<f32>, w: vec3<f32>, r: f32) -> f32 {
    if dot(w, l) <= 0.0 {
        return 0.0;
    }
    let t = tangent(l);
    let b = cross(l, t);
    let disc = 0.25 * r * r;
    let sxx = dot(t, f1) * dot(t, f1) + dot(t, f2) * dot(t, f2) + disc;
    let syy = dot(b, f1) * dot(b, f1) + dot(b, f2) * dot(b, f2) + disc;
    let sxy = dot(t, f1) * dot(b, f1) + dot(t, f2) * dot(b, f2);
    let det = max(sxx * syy - sxy * sxy, 1e-30);
    let x = vec2<f32>(dot(t, w), dot(b, w));
    let q = (syy * x.x * x.x - 2.0 * sxy * x.x * x.y + sxx * x.y * x.y) / det;
    if q > 40.0 {
        return 0.0;
    }
    return exp(-0.5 * q) / (2.0 * PI * sqrt(det));
}

// A delta light as a disc of angular radius r around w, per steradian, seen along l.
fn delta_disc(l: vec3<f32>, w: vec3<f32>, r: f32) -> f32 {
    let c = cos(max(r, 1e-4));
    return select(0.0, 1.0 / (2.0 * PI * (1.0 - c)), dot(l, w) >= c);
}

// The light point i, standing for `area` (with its eps), sends to the receiver at p (normal
// nd, towards the eye v, material mat; lift_d: its offset for shadow rays).
fn point_light(
    i: u32,
    area: f32,
    eps: f32,
    p: vec3<f32>,
    nd: vec3<f32>,
    v: vec3<f32>,
    mat: Material,
    lift_d: f32,
) -> vec3<f32> {
    let filtered = FILTER;
    let shadows = SHADOWS;
    let nl = select(0u, ph.counts.y, DELTA);
    let s = samples[i];
    let ps = s.position.xyz;
    let ns = s.normal.xyz;
    let dv = ps - p;
    let dist2 = dot(dv, dv);
    let dist = sqrt(dist2);
    let dn = dv / dist;
    let cos_d = dot(nd, dn);
    var cos_s = -dot(ns, dn);
    if cos_d <= 0.0 {
        return vec3<f32>(0.0);
    }
    let ior = s.reflectance.w;
    // Towards the light that the point sends to the receiver: reflected, or (an open glass
    // surface seen from behind) refracted out of the glass.
    var l = dn + 2.0 * cos_s * ns;
    var refl = s.reflectance.rgb;
    var transmitted = false;
    if cos_s > 0.0 {
        if ior > 0.0 {
            refl = vec3<f32>(fresnel_dielectric(cos_s, 1.0 / ior));
        }
    } else if TRANSMIT && cos_s < 0.0 && ior > 0.0 && s.reflectance.x > 0.5 {
        l = refract(dn, -ns, ior);
        if dot(l, l) == 0.0 {
            return vec3<f32>(0.0);
        }
        // Fresnel transmittance (the same both ways) and the radiance's gain of ior² on
        // entering the denser medium.
        refl = vec3<f32>((1.0 - fresnel_dielectric(dot(l, ns), 1.0 / ior)) * ior * ior);
        cos_s = -cos_s;
        transmitted = true;
    } else {
        return vec3<f32>(0.0);
    }
    var f = mat.albedo.rgb / PI;
    if mat.kind == MAT_GLOSSY {
        f = glossy_brdf(nd, dn, v, mat.albedo.rgb, mat.specular.rgb, mat.roughness);
    }
    let weight = refl * f * (cos_s * cos_d / (dist2 + eps) * area);
    if max(max(weight.r, weight.g), weight.b) <= 0.0 {
        return vec3<f32>(0.0);
    }
    // The footprint: a Gaussian of half the points' spacing, which tiles with its neighbours
    // (a disc of the same area has a deviation of 0.28 spacings and leaves gaps).
    let sigma = 0.5 * sqrt(area);
    var f1 = vec3<f32>(0.0);
    var f2 = vec3<f32>(0.0);
    if filtered && transmitted {
        f1 = sigma * refract_spread(dn, ns, s.dir1.xyz, s.dir1.w, dist, ior, l);
        f2 = sigma * refract_spread(dn, ns, s.dir2.xyz, s.dir2.w, dist, ior, l);
    } else if filtered {
        f1 = sigma * reflect_spread(dn, ns, s.dir1.xyz, s.dir1.w, dist);
        f2 = sigma * reflect_spread(dn, ns, s.dir2.xyz, s.dir2.w, dist);
    }
    var radiance = vec3<f32>(0.0);
    for (var k = 0u; k < nl; k++) {
        let sl = sample_lights[i * nl + k];
        let e = sl.irradiance.rgb;
        if max(max(e.r, e.g), e.b) <= 0.0 {
            continue;
        }
        let w = sl.dir.xyz;
        if filtered {
            // A near light's direction moves across the point's area too.
            let inv = sl.irradiance.w;
            let g1 = f1 + sigma * inv * (s.dir1.xyz - w * dot(w, s.dir1.xyz));
            let g2 = f2 + sigma * inv * (s.dir2.xyz - w * dot(w, s.dir2.xyz));
            radiance += e * delta_filtered(l, g1, g2, w, sl.dir.w);
        } else {
            radiance += e * delta_disc(l, w, sl.dir.w);
        }
    }
    if ENV {
        var le = ph.env.rgb;
        if ph.env.w > 0.5 {
            var m: vec3<f32>;
            if filtered {
                m = env_filtered(l, f1, f2);
            } else {
                m = env_point(l);
            }
            le += ph.env_scale.rgb * m;
        }
        if shadows && max(max(le.r, le.g), le.b) > 0.0 {
            let lift_s = 1e-3 * sqrt(eps);
            if occluded(ps + ns * lift_s, l, 1e30) {
                le = vec3<f32>(0.0);
            }
        }
        radiance += le;
    }
    if max(max(radiance.r, radiance.g), radiance.b) <= 0.0 {
        return vec3<f32>(0.0);
    }
    if shadows {
        let o = p + nd * lift_d;
        let to = ps - o;
        let len = length(to);
        if occluded(o, to / len, len * (1.0 - 1e-4) - 1e-3 * sqrt(eps)) {
            return vec3<f32>(0.0);
        }
    }
    return weight * radiance;
}

@fragment
fn fs_main(vin: VsOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(vin.position.xy);
    let gp = textureLoad(gbuf_position, px, 0);
    if gp.w <= 0.0 {
        return vec4<f32>(0.0);
    }
    let gn = textureLoad(gbuf_normal, px, 0);
    let p = gp.xyz;
    let nd = normalize(gn.xyz);
    let mat = materials[u32(gn.w)];
    let v = normalize(g.eye.xyz - p);
    let lift_d = 0.5 * gp.w;
    var sum = vec3<f32>(0.0);
    let last = min(ph.counts.z, vin.first + ph.draw.x);
    // The cluster after the last one begun: short of `last` when the adapter ended the loop
    // early (llvmpipe's cap on loop iterations). Alpha reports it: the draws add their alphas to
    // the 1 the direct pass left, and the renderer draws again with fewer clusters a draw.
    var next = vin.first;
    for (var c = vin.first; c < last; c++) {
        next = c + 1u;
        let cl = clusters[c];
        if distance(p, cl.centre.xyz) > FAR * cl.centre.w {
            sum += point_light(cl.range.x, cl.area.x, cl.area.y, p, nd, v, mat, lift_d);
        } else {
            for (var i = cl.range.y; i < cl.range.y + cl.range.z; i++) {
                let s = samples[i];
                sum += point_light(i, s.position.w, s.normal.w, p, nd, v, mat, lift_d);
            }
        }
    }
    return vec4<f32>(sum, select(0.0, 1.0, next < last));
}
