// Caustic spot light evaluation (seed 000 §2, Eqs. 2-4), shared by the CSL passes. Mirrors
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
    let g = c.kappa + c.gamma * r;
    let u = c.x_axis * px + c.y_axis * py;
    let dir = normalize(c.axis - u * g);
    let k = (*out).count;
    (*out).dir[k] = dir;
    (*out).density[k] = i / (sigma * max(dot(dir, c.axis), 1e-4));
    (*out).count = k + 1u;
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
    // Early out: no ray from the image (radii up to rmax) comes this far from the axis at this
    // height. |h(r)| = |r (b - a r)| is largest at rmax or at the extremum r = b / 2a.
    let rmax = c.half_extent * 1.4142136;
    var hmax = abs(rmax * (b - a * rmax));
    if (a != 0.0) {
        let rs = b / (2.0 * a);
        if (rs > 0.0 && rs < rmax) {
            hmax = max(hmax, abs(rs * (b - a * rs)));
        }
    }
    if (rho > hmax * 1.0001 + 1e-7) {
        return out;
    }
    // Radii are collected as Csl radii() does (at most three), then turned into arrivals.
    var found = 0u;
    for (var s = 0; s < 2; s++) {
        let side = select(-1.0, 1.0, s == 0);
        let cc = side * rho;
        if (abs(a) <= 1e-9 * max(abs(b), 1e-30)) {
            if (b != 0.0 && found < 3u) {
                let r = cc / b;
                if (r > 0.0) {
                    csl_arrival(c, r, side, ux, uy, a, b, &out);
                    found += 1u;
                }
            }
            continue;
        }
        let disc = b * b - 4.0 * a * cc;
        if (disc < 0.0) {
            continue;
        }
        let sgn = select(-1.0, 1.0, b >= 0.0);
        let q = 0.5 * (b + sgn * sqrt(disc));
        if (q != 0.0) {
            let r1 = q / a;
            if (r1 > 0.0 && found < 3u) {
                csl_arrival(c, r1, side, ux, uy, a, b, &out);
                found += 1u;
            }
            let r2 = cc / q;
            if (r2 > 0.0 && found < 3u) {
                csl_arrival(c, r2, side, ux, uy, a, b, &out);
                found += 1u;
            }
        }
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

// Pixel filter (Csl::arrivals_filtered, eval.rs): the mean over a disc of the pixel's area.

// Angle of the circle of radius t around the axis inside a disc of radius f centred rho from it.
fn csl_arc_inside(t: f32, rho: f32, f: f32) -> f32 {
    if (t <= f - rho) {
        return 3.141592653589793;
    }
    if (t <= 0.0 || t >= rho + f || t <= rho - f) {
        return 0.0;
    }
    return acos(clamp((t * t + rho * rho - f * f) / (2.0 * t * rho), -1.0, 1.0));
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

// ∫ 2 r θ(g(r)) dr over [ra, rb] by 8-point Gauss-Legendre (disc_measure in eval.rs).
fn csl_disc_measure(a: f32, b: f32, side: f32, ra: f32, rb: f32, rho: f32, f: f32) -> f32 {
    let xs = array<f32, 8>(-0.9602899, -0.7966665, -0.5255324, -0.18343464, 0.18343464, 0.5255324, 0.7966665, 0.9602899);
    let ws = array<f32, 8>(0.10122854, 0.22238103, 0.31370664, 0.3626838, 0.3626838, 0.31370664, 0.22238103, 0.10122854);
    let lo = min(ra, rb);
    let hi = max(ra, rb);
    let mid = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo);
    var sum = 0.0;
    for (var k = 0; k < 8; k++) {
        let r = mid + half * xs[k];
        let t = side * r * (b - a * r);
        sum += ws[k] * 2.0 * r * csl_arc_inside(t, rho, f);
    }
    return sum * half;
}

// The light of CSL c reaching a pixel whose footprint on the receiver around x has side
// `footprint`, averaged over a disc of the pixel's area: one arrival per side of the axis and
// monotonic branch of the ray map.
fn csl_arrivals_px(c: Csl, x: vec3<f32>, footprint: f32) -> CslArrivals {
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
    let rmax = c.half_extent * 1.4142135;
    let f = footprint / sqrt(3.141592653589793);
    let pa = max(rho - f, 0.0);
    let pb = rho + f;
    var cuts = array<f32, 3>(0.0, rmax, rmax);
    var pieces = 1;
    if (a != 0.0) {
        let rs = b / (2.0 * a);
        if (rs > 0.0 && rs < rmax) {
            cuts = array<f32, 3>(0.0, rs, rmax);
            pieces = 2;
        }
    }
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
            if (!(abs(rb * rb - ra * ra) > 0.0) || !(r > 0.0)) {
                continue;
            }
            let px = side * r * ux;
            let py = side * r * uy;
            let i = csl_intensity(c, px, py);
            if (i.x < 0.0) {
                continue;
            }
            let m = csl_disc_measure(a, b, side, ra, rb, rho, f);
            if (!(m > 0.0)) {
                continue;
            }
            csl_push(c, r, px, py, i, 3.141592653589793 * f * f / m, &out);
        }
    }
    return out;
}
