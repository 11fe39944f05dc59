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
    dir: array<vec3<f32>, 3>,
    density: array<vec3<f32>, 3>,
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
    let sigma = csl_area_ratio(a, b, r, c.half_extent / f32(c.size));
    let g = c.kappa + c.gamma * r;
    let u = c.x_axis * px + c.y_axis * py;
    let dir = normalize(c.axis - u * g);
    let k = (*out).count;
    (*out).dir[k] = dir;
    (*out).density[k] = i / (sigma * max(dot(dir, c.axis), 1e-4));
    (*out).count = k + 1u;
}

// The rays of CSL c through point x.
fn csl_arrivals(c: Csl, x: vec3<f32>) -> CslArrivals {
    var out: CslArrivals;
    out.count = 0u;
    let d = x - c.origin;
    let z = dot(d, c.axis);
    if (z <= 0.0) {
        return out;
    }
    let w = d - c.axis * z;
    let wx = dot(w, c.x_axis);
    let wy = dot(w, c.y_axis);
    let rho = sqrt(wx * wx + wy * wy);
    var ux = 1.0;
    var uy = 0.0;
    if (rho > 0.0) {
        ux = wx / rho;
        uy = wy / rho;
    }
    let a = z * c.gamma;
    let b = 1.0 - z * c.kappa;
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
