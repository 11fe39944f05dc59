// Caustic spot light evaluation (Liu et al. 2008 §2, Eqs. 2-4), shared by the CSL passes. Mirrors
// src/bake/csl/eval.rs line for line so that the GPU and CPU agree number for number: with
// 1/f(r) = kappa + gamma*r a ray from light-plane radius r is at h(r) = r*(B - A*r) from the
// axis at height z (A = z*gamma, B = 1 - z*kappa); the rays through a point solve
// A*r^2 - B*r +- rho = 0 (at most three); Eq. 4 is evaluated over the half-texel patch.

struct Csl {
    origin: vec3<f32>,
    kappa: f32,
    axis: vec3<f32>,
    gamma: f32,
    x_axis: vec3<f32>,
    half_extent: f32,
    y_axis: vec3<f32>,
    // Dequantisation factor: scale / 65535.
    scale: f32,
    size: u32,
    // Index of the first texel's first word in `csl_texels` (two u32 words per RGB texel).
    texel_offset: u32,
    pad0: u32,
    pad1: u32,
}

// The intensity images of all CSLs, two words per RGB texel (r | g << 16, b), 16-bit linear.
// Declared here so that this file validates on its own; includers use group 0, binding 7.
@group(0) @binding(7) var<storage, read> csl_texels: array<u32>;

fn csl_texel(c: Csl, i: i32, j: i32) -> vec3<f32> {
    let n = i32(c.size);
    let ii = clamp(i, 0, n - 1);
    let jj = clamp(j, 0, n - 1);
    let k = c.texel_offset + 2u * u32(jj * n + ii);
    let w0 = csl_texels[k];
    let w1 = csl_texels[k + 1u];
    return vec3<f32>(f32(w0 & 0xffffu), f32(w0 >> 16u), f32(w1 & 0xffffu));
}

// Bilinear, dequantised image value at light-plane coordinates; negative when outside.
fn csl_intensity(c: Csl, x: f32, y: f32) -> vec3<f32> {
    let h = c.half_extent;
    if (abs(x) > h || abs(y) > h) {
        return vec3<f32>(-1.0);
    }
    let pix = 2.0 * h / f32(c.size);
    let fx = (x + h) / pix - 0.5;
    let fy = (y + h) / pix - 0.5;
    let x0 = floor(fx);
    let y0 = floor(fy);
    let tx = fx - x0;
    let ty = fy - y0;
    let i = i32(x0);
    let j = i32(y0);
    let v = csl_texel(c, i, j) * ((1.0 - tx) * (1.0 - ty))
        + csl_texel(c, i + 1, j) * (tx * (1.0 - ty))
        + csl_texel(c, i, j + 1) * ((1.0 - tx) * ty)
        + csl_texel(c, i + 1, j + 1) * (tx * ty);
    return v * c.scale;
}

fn csl_h(a: f32, b: f32, r: f32) -> f32 {
    return r * (b - a * r);
}

// Eq. 4 over the light-plane annulus [r - dr, r + dr].
fn csl_area_ratio(a: f32, b: f32, r: f32, dr: f32) -> f32 {
    let r0 = max(r - dr, 0.0);
    let r1 = r + dr;
    let h0 = csl_h(a, b, r0);
    let h1 = csl_h(a, b, r1);
    var lo = min(abs(h0), abs(h1));
    var hi = max(abs(h0), abs(h1));
    if (a != 0.0) {
        let rs = b / (2.0 * a);
        if (rs > r0 && rs < r1) {
            let hs = abs(csl_h(a, b, rs));
            hi = max(hi, hs);
            lo = min(lo, hs);
        }
    }
    if (h0 * h1 < 0.0) {
        lo = 0.0;
    }
    return max((hi * hi - lo * lo) / (r1 * r1 - r0 * r0), 1e-12);
}

// The CSL rays reaching a point (at most three): unit travel direction and flux per unit area
// perpendicular to the ray, per unit light irradiance. Mirrors Csl::arrivals.
struct CslArrivals {
    dir: array<vec3<f32>, 4>,
    density: array<vec3<f32>, 4>,
    count: u32,
}

// One candidate radius: appends its arrival when r is valid and on the image.
fn csl_arrival(c: Csl, r: f32, side: f32, ux: f32, uy: f32, a: f32, b: f32, out: ptr<function, CslArrivals>) {
    if (!(r > 0.0) || r > 3.0e38) {
        return;
    }
    let px = side * r * ux;
    let py = side * r * uy;
    let i = csl_intensity(c, px, py);
    if (i.x < 0.0) {
        return;
    }
    csl_push(c, r, px, py, i, csl_area_ratio(a, b, r, c.half_extent / f32(c.size)), out);
}

// Appends the ray from light-plane point (px, py) at radius r, with image value i and Eq. 4's
// area ratio sigma (Csl::arrival).
fn csl_push(c: Csl, r: f32, px: f32, py: f32, i: vec3<f32>, sigma: f32, out: ptr<function, CslArrivals>) {
    let ray = csl_ray(c, r, px, py, i, sigma);
    let k = (*out).count;
    (*out).dir[k] = ray.dir;
    (*out).density[k] = ray.density;
    (*out).count = k + 1u;
}

// The ray from light-plane point (px, py) at radius r with image value i and area ratio sigma:
// its unit travel direction and its flux per unit area perpendicular to it.
struct CslRay {
    dir: vec3<f32>,
    density: vec3<f32>,
}

fn csl_ray(c: Csl, r: f32, px: f32, py: f32, i: vec3<f32>, sigma: f32) -> CslRay {
    let g = c.kappa + c.gamma * r;
    let u = c.x_axis * px + c.y_axis * py;
    let dir = normalize(c.axis - u * g);
    return CslRay(dir, i / (sigma * max(dot(dir, c.axis), 1e-4)));
}

// A receiver point in a CSL's frame (Csl::local): height z above the light plane, distance rho
// from the axis, unit in-plane direction (ux, uy) towards it, ray-map coefficients a = z*gamma,
// b = 1 - z*kappa.
struct CslLocal {
    z: f32,
    rho: f32,
    ux: f32,
    uy: f32,
    a: f32,
    b: f32,
}

fn csl_local(c: Csl, x: vec3<f32>) -> CslLocal {
    var l: CslLocal;
    let d = x - c.origin;
    l.z = dot(d, c.axis);
    let w = d - c.axis * l.z;
    let wx = dot(w, c.x_axis);
    let wy = dot(w, c.y_axis);
    l.rho = sqrt(wx * wx + wy * wy);
    l.ux = 1.0;
    l.uy = 0.0;
    if (l.rho > 0.0) {
        l.ux = wx / l.rho;
        l.uy = wy / l.rho;
    }
    l.a = l.z * c.gamma;
    l.b = 1.0 - l.z * c.kappa;
    return l;
}

// The farthest any ray of the image (radii up to its corner rmax) comes from the axis where the
// ray map has coefficients a, b: |h(r)| = |r (b - a r)| is largest at rmax or at r = b / 2a.
fn csl_reach(c: Csl, a: f32, b: f32) -> f32 {
    let rmax = c.half_extent * 1.4142136;
    var hmax = abs(rmax * (b - a * rmax));
    if (a != 0.0) {
        let rs = b / (2.0 * a);
        if (rs > 0.0 && rs < rmax) {
            hmax = max(hmax, abs(rs * (b - a * rs)));
        }
    }
    return hmax;
}

// The candidate light-plane radii of the rays through a point at distance rho from the axis
// where the ray map has coefficients a, b, and the side of the axis each leaves on: as Csl
// radii() finds them (at most three, in its order; a candidate may still be off the image).
struct CslCandidates {
    radius: vec3<f32>,
    side: vec3<f32>,
    count: u32,
}

fn csl_candidates(rho: f32, a: f32, b: f32) -> CslCandidates {
    var out: CslCandidates;
    out.radius = vec3<f32>(0.0);
    out.side = vec3<f32>(0.0);
    out.count = 0u;
    let linear = abs(a) <= 1e-9 * max(abs(b), 1e-30);
    for (var s = 0; s < 2; s++) {
        let side = select(-1.0, 1.0, s == 0);
        let cc = side * rho;
        if linear {
            if b != 0.0 && out.count < 3u {
                let r = cc / b;
                if r > 0.0 {
                    out.radius[out.count] = r;
                    out.side[out.count] = side;
                    out.count += 1u;
                }
            }
            continue;
        }
        let disc = b * b - 4.0 * a * cc;
        if disc < 0.0 {
            continue;
        }
        let q = 0.5 * (b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
        if q != 0.0 {
            let r1 = q / a;
            if r1 > 0.0 && out.count < 3u {
                out.radius[out.count] = r1;
                out.side[out.count] = side;
                out.count += 1u;
            }
            let r2 = cc / q;
            if r2 > 0.0 && out.count < 3u {
                out.radius[out.count] = r2;
                out.side[out.count] = side;
                out.count += 1u;
            }
        }
    }
    return out;
}

// The rays of CSL c through point x.
fn csl_arrivals(c: Csl, x: vec3<f32>) -> CslArrivals {
    var out: CslArrivals;
    out.count = 0u;
    let l = csl_local(c, x);
    if (!(l.z > 0.0)) {
        return out;
    }
    let rho = l.rho;
    let ux = l.ux;
    let uy = l.uy;
    let a = l.a;
    let b = l.b;
    // Early out: no ray from the image comes this far from the axis at this height.
    if (rho > csl_reach(c, a, b) * 1.0001 + 1e-7) {
        return out;
    }
    let cand = csl_candidates(rho, a, b);
    for (var k = 0u; k < cand.count; k++) {
        csl_arrival(c, cand.radius[k], cand.side[k], ux, uy, a, b, &out);
    }
    return out;
}

// Irradiance of CSL c at point x on a surface with unit normal n, per unit light irradiance.
fn csl_irradiance(c: Csl, x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let arr = csl_arrivals(c, x);
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < arr.count; k++) {
        sum += arr.density[k] * max(-dot(arr.dir[k], n), 0.0);
    }
    return sum;
}

// Pixel filter (Csl::arrivals_filtered, eval.rs): the mean over the pixel's footprint, the
// parallelogram centre + s*e1 + u*e2 (|s|, |u| <= 1/2) it projects to along the axis in the
// light plane's coordinates (PixelQuad): neighbouring pixels tile the plane, so a focus lands
// in exactly one of them. The two slabs |m_i . (q - centre)| <= 1/2 whose intersection it is:
// m_i, |m_i|, the angle of m_i and m_i . centre.
struct CslQuad {
    centre: vec2<f32>,
    e1: vec2<f32>,
    e2: vec2<f32>,
    m: array<vec2<f32>, 2>,
    len: array<f32, 2>,
    psi: array<f32, 2>,
    c: array<f32, 2>,
    area: f32,
    ok: bool,
}

fn csl_quad(centre: vec2<f32>, e1: vec2<f32>, e2: vec2<f32>) -> CslQuad {
    var q: CslQuad;
    q.centre = centre;
    q.e1 = e1;
    q.e2 = e2;
    let det = e1.x * e2.y - e1.y * e2.x;
    let scale = max(dot(e1, e1), dot(e2, e2));
    q.ok = abs(det) > 1e-6 * scale && abs(det) < 3.0e38;
    if (!q.ok) {
        return q;
    }
    q.m[0] = vec2<f32>(e2.y, -e2.x) / det;
    q.m[1] = vec2<f32>(-e1.y, e1.x) / det;
    for (var i = 0; i < 2; i++) {
        q.len[i] = length(q.m[i]);
        q.c[i] = dot(q.m[i], centre);
    }
    q.area = abs(det);
    return q;
}

// Nearest and farthest distance of the parallelogram from the axis (PixelQuad::distances).
fn csl_quad_distances(q: CslQuad) -> vec2<f32> {
    let w = q.centre;
    let corners = array<vec2<f32>, 4>(
        w - 0.5 * q.e1 - 0.5 * q.e2,
        w + 0.5 * q.e1 - 0.5 * q.e2,
        w + 0.5 * q.e1 + 0.5 * q.e2,
        w - 0.5 * q.e1 + 0.5 * q.e2,
    );
    var far = 0.0;
    var near = 3.0e38;
    for (var k = 0; k < 4; k++) {
        let p = corners[k];
        let d = corners[(k + 1) % 4] - p;
        far = max(far, length(p));
        let s = clamp(-dot(p, d) / max(dot(d, d), 1e-30), 0.0, 1.0);
        near = min(near, length(p + d * s));
    }
    if (abs(q.c[0]) <= 0.5 && abs(q.c[1]) <= 0.5) {
        near = 0.0;
    }
    return vec2<f32>(near, far);
}

// Length of the intersection of the arcs [s1, s1 + l1] and [s2, s2 + l2] (lengths <= pi).
fn csl_arc_overlap(s1: f32, l1: f32, s2: f32, l2: f32) -> f32 {
    let tau = 6.283185307179586;
    let d = (s2 - s1) - tau * floor((s2 - s1) / tau);
    let a = max(min(l1, d + l2) - max(d, 0.0), 0.0);
    let b = max(min(l1, d - tau + l2) - max(d - tau, 0.0), 0.0);
    return a + b;
}

// Angle of the circle of radius t around the axis inside the parallelogram (PixelQuad::arc).
fn csl_quad_arc(q: CslQuad, t: f32) -> f32 {
    var start: array<vec2<f32>, 2>;
    var span = vec2<f32>(0.0);
    for (var i = 0; i < 2; i++) {
        let k = max(t, 0.0) * q.len[i];
        var lo = -1.0;
        var hi = 1.0;
        if (k > 0.0) {
            lo = (q.c[i] - 0.5) / k;
            hi = (q.c[i] + 0.5) / k;
        } else if (abs(q.c[i]) > 0.5) {
            return 0.0;
        }
        if (lo >= 1.0 || hi <= -1.0) {
            return 0.0;
        }
        let a0 = acos(min(hi, 1.0));
        let a1 = acos(max(lo, -1.0));
        start[i] = vec2<f32>(q.psi[i] + a0, q.psi[i] - a1);
        span[i] = a1 - a0;
    }
    var sum = 0.0;
    for (var i = 0; i < 2; i++) {
        for (var j = 0; j < 2; j++) {
            sum += csl_arc_overlap(start[0][i], span[0], start[1][j], span[1]);
        }
    }
    return sum;
}

// Pre-image of level c under g(r) = side*r*(b - a*r) on [lo, hi] (monotonic there), clamped.
fn csl_pre(a: f32, b: f32, side: f32, lo: f32, hi: f32, glo: f32, ghi: f32, c: f32) -> f32 {
    let gmin = min(glo, ghi);
    let gmax = max(glo, ghi);
    if (c <= gmin) {
        return select(hi, lo, glo <= ghi);
    }
    if (c >= gmax) {
        return select(lo, hi, glo <= ghi);
    }
    var x: f32;
    if (abs(a) <= 1e-9 * max(abs(b), 1e-30)) {
        x = side * c / b;
    } else {
        let disc = max(b * b - 4.0 * a * side * c, 0.0);
        let q = 0.5 * (b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
        let x1 = q / a;
        var x2 = x1;
        if (q != 0.0) {
            x2 = side * c / q;
        }
        let mid = 0.5 * (lo + hi);
        x = select(x2, x1, abs(x1 - mid) <= abs(x2 - mid));
    }
    return clamp(x, lo, hi);
}

// Flux of the rays of branch [ra, rb] landing in the parallelogram: ∫ I(r) r Θ(g(r)) dr, I read
// along the pixel centre's direction (ux, uy), or `fixed` where `use_fixed`, by 8-point
// Gauss-Legendre (Csl::quad_flux).
fn csl_quad_flux(c: Csl, a: f32, b: f32, side: f32, ra: f32, rb: f32, ux: f32, uy: f32, q: CslQuad, fixed: vec3<f32>, use_fixed: bool) -> vec3<f32> {
    let xs = array<f32, 8>(-0.9602899, -0.7966665, -0.5255324, -0.18343464, 0.18343464, 0.5255324, 0.7966665, 0.9602899);
    let ws = array<f32, 8>(0.10122854, 0.22238103, 0.31370664, 0.3626838, 0.3626838, 0.31370664, 0.22238103, 0.10122854);
    let lo = min(ra, rb);
    let hi = max(ra, rb);
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    if (use_fixed) {
        var m = 0.0;
        for (var k = 0; k < 8; k++) {
            let r = mid + half * xs[k];
            m += ws[k] * r * csl_quad_arc(q, side * r * (b - a * r));
        }
        return fixed * (m * half);
    }
    var sum = vec3<f32>(0.0);
    for (var k = 0; k < 8; k++) {
        let r = mid + half * xs[k];
        let arc = csl_quad_arc(q, side * r * (b - a * r));
        if (arc > 0.0) {
            let i = csl_intensity(c, side * r * ux, side * r * uy);
            if (i.x >= 0.0) {
                sum += i * (ws[k] * r * arc);
            }
        }
    }
    return sum * half;
}

// The light of CSL c reaching a pixel whose footprint on the receiver is the parallelogram
// around x with edges e1, e2, averaged over it: one arrival per side of the axis and monotonic
// branch of the ray map.
fn csl_arrivals_px(c: Csl, x: vec3<f32>, e1: vec3<f32>, e2: vec3<f32>) -> CslArrivals {
    var out: CslArrivals;
    out.count = 0u;
    let l = csl_local(c, x);
    if (!(l.z > 0.0)) {
        return out;
    }
    let rho = l.rho;
    let ux = l.ux;
    let uy = l.uy;
    let a = l.a;
    let b = l.b;
    var q = csl_quad(
        vec2<f32>(rho * ux, rho * uy),
        vec2<f32>(dot(e1, c.x_axis), dot(e1, c.y_axis)),
        vec2<f32>(dot(e2, c.x_axis), dot(e2, c.y_axis)),
    );
    if (!q.ok) {
        return csl_arrivals(c, x);
    }
    let rmax = c.half_extent * 1.4142135;
    let band = csl_quad_distances(q);
    let pa = band.x;
    let pb = band.y;
    if (pa > csl_reach(c, a, b) * 1.0001 + 1e-7) {
        return out;
    }
    var cuts = array<f32, 3>(0.0, rmax, rmax);
    var pieces = 1;
    if (a != 0.0) {
        let rs = b / (2.0 * a);
        if (rs > 0.0 && rs < rmax) {
            cuts = array<f32, 3>(0.0, rs, rmax);
            pieces = 2;
        }
    }
    // Each branch's band of light-plane radii (side, ra, rb, r); where every band lies within a
    // texel, the ray map is smooth on the pixel's scale and the point evaluation is the mean.
    var bands: array<vec4<f32>, 4>;
    var count = 0;
    var wide = false;
    let texel = 2.0 * c.half_extent / f32(c.size);
    for (var s = 0; s < 2; s++) {
        let side = select(-1.0, 1.0, s == 0);
        for (var k = 0; k < pieces; k++) {
            let lo = cuts[k];
            let hi = cuts[k + 1];
            let glo = side * lo * (b - a * lo);
            let ghi = side * hi * (b - a * hi);
            let ra = csl_pre(a, b, side, lo, hi, glo, ghi, pa);
            let rb = csl_pre(a, b, side, lo, hi, glo, ghi, pb);
            let r = csl_pre(a, b, side, lo, hi, glo, ghi, rho);
            if (!(abs(rb * rb - ra * ra) > 0.0) || !(r >= 0.0)) {
                continue;
            }
            wide = wide || abs(rb - ra) > texel;
            bands[count] = vec4<f32>(side, ra, rb, r);
            count += 1;
        }
    }
    if (!wide) {
        return csl_arrivals(c, x);
    }
    // The slabs' angles, needed by the arcs of the filtered path only (PixelQuad::new computes
    // them up front: the same values; here most pixels never need them).
    for (var i = 0; i < 2; i++) {
        q.psi[i] = atan2(q.m[i].y, q.m[i].x);
    }
    for (var k = 0; k < count; k++) {
        let side = bands[k].x;
        let ra = bands[k].y;
        let rb = bands[k].z;
        let r = bands[k].w;
        // A band within a texel of the image: the intensity of the centre's ray stands for all
        // of it (one lookup instead of one a node).
        let px = side * r * ux;
        let py = side * r * uy;
        let use_fixed = abs(rb - ra) <= texel;
        var fixed = vec3<f32>(0.0);
        if (use_fixed) {
            fixed = csl_intensity(c, px, py);
            if (fixed.x < 0.0) {
                continue;
            }
        }
        let flux = csl_quad_flux(c, a, b, side, ra, rb, ux, uy, q, fixed, use_fixed);
        if (!(max(max(flux.x, flux.y), flux.z) > 0.0)) {
            continue;
        }
        // The pixel's mean flux density, in the direction of the ray through its centre.
        csl_push(c, r, px, py, flux, q.area, &out);
    }
    return out;
}
