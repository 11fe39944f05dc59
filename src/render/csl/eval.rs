//! CPU evaluation of CSLs at a receiver point (Liu et al. 2008 §2.2–2.4), the reference the
//! GPU pass is checked against.
//!
//! With 1/f(r) = κ + γr, a CSL ray from light-plane radius r is at distance
//! h(r) = r·(1 − z/f(r)) = r·(B − A·r), A = zγ, B = 1 − zκ, from the axis at height z above the
//! plane (negative h: on the other side of the axis). A point at height z and distance ρ from
//! the axis is reached by the rays with h(r) = ±ρ, i.e. the positive roots of
//! A·r² − B·r ± ρ = 0: the paper's r₁, r₂ (case i, Eq. 2) and r₃ (case ii, Eq. 3) when
//! α > 0, β ≥ 0, and at most three in every case. Radii whose light-plane point falls outside
//! the intensity image are dropped. The focusing correction (Eq. 4) is
//! σ = |h·h′/r| = |(B − A·r)(B − 2A·r)|, written without the division by r, so the central ray
//! on the optical axis (§2.4) gets its exact limit σ = B² instead of a perturbed point. Where a
//! ray bundle really focuses (σ → 0: the on-axis focus of the ring of rays with B = A·r, or a
//! fold caustic with B = 2A·r) the limit is infinite. We therefore evaluate Eq. 4 before its
//! limit, over the patch the intensity image resolves: dr = half a texel, and the area the
//! radial interval [r − dr, r + dr] maps to at height z is computed exactly for the quadratic
//! h (a sign change of h folds the annulus onto a disc; an extremum of h inside the interval is
//! included). This equals Eq. 4 wherever h is smooth on the scale of a texel, stays finite at
//! foci, and needs no epsilon.

use crate::bake::csl::Csl;
use glam::Vec3;

/// A CSL ray arriving at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    /// Unit travel direction.
    pub dir: Vec3,
    /// Flux per unit area perpendicular to the ray, per unit irradiance of the light.
    pub density: Vec3,
}

/// The light-plane radii of the rays through a point at height `z` and axis distance `rho`:
/// (radius, side) with side +1 when the ray starts on the point's side of the axis.
pub fn radii(kappa: f32, gamma: f32, z: f32, rho: f32) -> ([(f32, f32); 3], usize) {
    let (a, b) = (z * gamma, 1.0 - z * kappa);
    let mut out = [(0.0, 0.0); 3];
    let mut n = 0;
    for side in [1.0f32, -1.0] {
        // a·r² − b·r + side·ρ = 0
        let c = side * rho;
        let mut push = |r: f32| {
            if r > 0.0 && r.is_finite() && n < 3 {
                out[n] = (r, side);
                n += 1;
            }
        };
        if a.abs() <= 1e-9 * b.abs().max(1e-30) {
            if b != 0.0 {
                push(c / b);
            }
            continue;
        }
        let disc = b * b - 4.0 * a * c;
        if disc < 0.0 {
            continue;
        }
        // Stable roots of a·r² + (−b)·r + c = 0.
        let q = 0.5 * (b + b.signum() * disc.sqrt());
        if q != 0.0 {
            push(q / a);
            push(c / q);
        } else {
            push(0.0);
        }
    }
    (out, n)
}

/// Eq. 4 over a finite patch: the ratio of the area that the light-plane annulus
/// [r − dr, r + dr] covers at the height where h(r) = B·r − A·r², to the annulus' area.
pub fn area_ratio(a: f32, b: f32, r: f32, dr: f32) -> f32 {
    let h = |r: f32| r * (b - a * r);
    let (r0, r1) = ((r - dr).max(0.0), r + dr);
    let (h0, h1) = (h(r0), h(r1));
    let (mut lo, mut hi) = (h0.abs().min(h1.abs()), h0.abs().max(h1.abs()));
    if a != 0.0 {
        let rs = b / (2.0 * a);
        if rs > r0 && rs < r1 {
            let hs = h(rs).abs();
            hi = hi.max(hs);
            lo = lo.min(hs);
        }
    }
    if h0 * h1 < 0.0 {
        lo = 0.0;
    }
    ((hi * hi - lo * lo) / (r1 * r1 - r0 * r0)).max(1e-12)
}

/// Gauss-Legendre nodes and weights on [-1, 1], 8 points.
const GL8: [(f32, f32); 8] = [
    (-0.960_289_9, 0.101_228_54),
    (-0.796_666_5, 0.222_381_03),
    (-0.525_532_4, 0.313_706_64),
    (-0.183_434_64, 0.362_683_8),
    (0.183_434_64, 0.362_683_8),
    (0.525_532_4, 0.313_706_64),
    (0.796_666_5, 0.222_381_03),
    (0.960_289_9, 0.101_228_54),
];

/// A pixel's footprint in a CSL's light-plane coordinates (x̂, ŷ): the parallelogram
/// w + s·E₁ + u·E₂, |s|, |u| ≤ ½, that the pixel's footprint on the receiver (centre x, edges
/// e₁ and e₂) projects to along the axis. Neighbouring pixels' footprints tile the receiver, so
/// their parallelograms tile the plane and the light of a focus lands in exactly one pixel (a
/// disc of the pixel's area, which this replaced, puts a point focus into none, one or two
/// pixels: on the 1280² glass-sphere set the floor's caustic flux moved by 3 % between 5×5 and
/// 8×8 samples a pixel, nearly all of it in the one pixel of the sphere's focus).
#[derive(Clone, Copy, Debug)]
pub struct PixelQuad {
    /// w.
    centre: glam::Vec2,
    /// E₁, E₂.
    edges: [glam::Vec2; 2],
    /// The slabs |mᵢ·(q − w)| ≤ ½ whose intersection is the parallelogram: (mᵢ, |mᵢ|, the
    /// angle of mᵢ, mᵢ·w).
    slabs: [(glam::Vec2, f32, f32, f32); 2],
    /// |E₁ × E₂|.
    pub area: f32,
}

impl PixelQuad {
    /// The parallelogram centred at `centre` with edges `e1`, `e2`; None when it is
    /// degenerate (no area to average over).
    pub fn new(centre: glam::Vec2, e1: glam::Vec2, e2: glam::Vec2) -> Option<Self> {
        let det = e1.perp_dot(e2);
        let scale = e1.length_squared().max(e2.length_squared());
        if !det.is_finite() || det.abs() <= 1e-6 * scale || scale.is_nan() {
            return None;
        }
        // q − w = s·E₁ + u·E₂: s = (q − w) × E₂ / det, u = E₁ × (q − w) / det.
        let slab = |m: glam::Vec2| (m, m.length(), m.y.atan2(m.x), m.dot(centre));
        Some(PixelQuad {
            centre,
            edges: [e1, e2],
            slabs: [
                slab(glam::Vec2::new(e2.y, -e2.x) / det),
                slab(glam::Vec2::new(-e1.y, e1.x) / det),
            ],
            area: det.abs(),
        })
    }

    /// The nearest and farthest distance of the parallelogram from the axis (the origin).
    pub fn distances(&self) -> (f32, f32) {
        let [e1, e2] = self.edges;
        let w = self.centre;
        let corners = [
            w - 0.5 * e1 - 0.5 * e2,
            w + 0.5 * e1 - 0.5 * e2,
            w + 0.5 * e1 + 0.5 * e2,
            w - 0.5 * e1 + 0.5 * e2,
        ];
        let far = corners.iter().map(|c| c.length()).fold(0.0, f32::max);
        if self.slabs.iter().all(|&(_, _, _, c)| c.abs() <= 0.5) {
            return (0.0, far);
        }
        let near = (0..4)
            .map(|k| {
                let (p, q) = (corners[k], corners[(k + 1) % 4]);
                let d = q - p;
                let s = (-p.dot(d) / d.length_squared().max(1e-30)).clamp(0.0, 1.0);
                (p + d * s).length()
            })
            .fold(f32::INFINITY, f32::min);
        (near, far)
    }

    /// Angle (radians, 0..2π) of the circle of radius `t` around the axis that lies inside the
    /// parallelogram: the intersection of the two slabs' arcs.
    pub fn arc(&self, t: f32) -> f32 {
        // On the circle q = t·(cos φ, sin φ), mᵢ·q = t|mᵢ|cos(φ − ψᵢ) must lie in
        // [cᵢ − ½, cᵢ + ½]: two arcs, φ − ψᵢ in [α, β] and [−β, −α].
        let mut arcs = [[(0.0f32, 0.0f32); 2]; 2];
        for (i, &(_, len, psi, c)) in self.slabs.iter().enumerate() {
            let k = t.max(0.0) * len;
            let (lo, hi) = if k > 0.0 {
                ((c - 0.5) / k, (c + 0.5) / k)
            } else if c.abs() <= 0.5 {
                (-1.0, 1.0)
            } else {
                return 0.0;
            };
            if lo >= 1.0 || hi <= -1.0 {
                return 0.0;
            }
            let (a0, a1) = (hi.min(1.0).acos(), lo.max(-1.0).acos());
            arcs[i] = [(psi + a0, a1 - a0), (psi - a1, a1 - a0)];
        }
        let mut sum = 0.0;
        for &(s1, l1) in &arcs[0] {
            for &(s2, l2) in &arcs[1] {
                sum += arc_overlap(s1, l1, s2, l2);
            }
        }
        sum
    }
}

/// Length of the intersection of the circle's arcs [s1, s1 + l1] and [s2, s2 + l2] (lengths
/// at most π, so the intersection is one piece).
pub fn arc_overlap(s1: f32, l1: f32, s2: f32, l2: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    let d = (s2 - s1).rem_euclid(tau);
    let part = |x: f32, y: f32| (l1.min(y) - x.max(0.0)).max(0.0);
    part(d, d + l2) + part(d - tau, d - tau + l2)
}

/// A receiver point in a CSL's frame: height z above the light plane, distance ρ from the axis, the unit in-plane direction
/// (ux, uy) towards it, and the ray-map coefficients A = zγ, B = 1 − zκ at its height z.
struct Local {
    z: f32,
    rho: f32,
    ux: f32,
    uy: f32,
    a: f32,
    b: f32,
}

/// Most arrivals at a point: three for a point (the paper's r₁, r₂, r₃), four for a pixel
/// band (each side of the axis has two monotonic branches).
pub const MAX_ARRIVALS: usize = 4;

/// Pixel filter of Eq. 4 on one branch: the light-plane radii [r_a, r_b] whose rays land in the
/// receiver band [ρ_a, ρ_b] on branch [lo, hi] of the ray map g(r) = side·r(b − a·r) (monotonic
/// there), and the radius whose ray lands at `rho` (clamped to the branch: the branch's end
/// nearest to it when none does). The band's mean irradiance is I·(r_b² − r_a²)/(ρ_b² − ρ_a²):
/// flux-conserving over a pixel, however small the focus or thin the fold in it.
#[allow(clippy::too_many_arguments)]
pub fn branch_band(
    a: f32,
    b: f32,
    side: f32,
    lo: f32,
    hi: f32,
    pa: f32,
    pb: f32,
    rho: f32,
) -> (f32, f32, f32) {
    let g = |x: f32| side * x * (b - a * x);
    let (glo, ghi) = (g(lo), g(hi));
    let pre = |c: f32| -> f32 {
        let (gmin, gmax) = (glo.min(ghi), glo.max(ghi));
        if c <= gmin {
            return if glo <= ghi { lo } else { hi };
        }
        if c >= gmax {
            return if glo <= ghi { hi } else { lo };
        }
        // a·x² − b·x + side·c = 0: the root inside [lo, hi].
        let x = if a.abs() <= 1e-9 * b.abs().max(1e-30) {
            side * c / b
        } else {
            let disc = (b * b - 4.0 * a * side * c).max(0.0);
            let q = 0.5 * (b + b.signum() * disc.sqrt());
            let x1 = q / a;
            let x2 = if q != 0.0 { side * c / q } else { x1 };
            let mid = 0.5 * (lo + hi);
            if (x1 - mid).abs() <= (x2 - mid).abs() {
                x1
            } else {
                x2
            }
        };
        x.clamp(lo, hi)
    };
    (pre(pa), pre(pb), pre(rho))
}

impl Csl {
    /// The ray from light-plane point (px, py) at radius r, with image value `i` and Eq. 4's
    /// area ratio `sigma`.
    fn arrival(&self, r: f32, px: f32, py: f32, i: Vec3, sigma: f32) -> Arrival {
        let g = self.kappa + self.gamma * r;
        let u = self.x_axis * px + self.y_axis() * py;
        let dir = (self.axis - u * g).normalize();
        Arrival {
            dir,
            density: i / (sigma * dir.dot(self.axis).max(1e-4)),
        }
    }

    /// Where `x` is relative to the CSL; None behind the light plane.
    fn local(&self, x: Vec3) -> Option<Local> {
        let d = x - self.origin;
        let z = d.dot(self.axis);
        if z <= 0.0 {
            return None;
        }
        let w = d - self.axis * z;
        let (wx, wy) = (w.dot(self.x_axis), w.dot(self.y_axis()));
        let rho = (wx * wx + wy * wy).sqrt();
        // Unit direction from the axis towards x in the plane (any one on the axis).
        let (ux, uy) = if rho > 0.0 {
            (wx / rho, wy / rho)
        } else {
            (1.0, 0.0)
        };
        Some(Local {
            z,
            rho,
            ux,
            uy,
            a: z * self.gamma,
            b: 1.0 - z * self.kappa,
        })
    }

    /// The farthest any ray of the image (radii up to its corner) comes from the axis at the
    /// height where the ray map has coefficients `a`, `b`: |h(r)| = |r(b − ar)| is largest at
    /// the corner radius or at r = b/2a.
    fn reach(&self, a: f32, b: f32) -> f32 {
        let rmax = self.half_extent * std::f32::consts::SQRT_2;
        let mut hmax = (rmax * (b - a * rmax)).abs();
        if a != 0.0 {
            let rs = b / (2.0 * a);
            if rs > 0.0 && rs < rmax {
                hmax = hmax.max((rs * (b - a * rs)).abs());
            }
        }
        hmax
    }

    /// The CSL rays reaching `x` (same frame as the CSL), at most three.
    pub fn arrivals(&self, x: Vec3) -> ([Arrival; 3], usize) {
        let mut out = [Arrival {
            dir: Vec3::ZERO,
            density: Vec3::ZERO,
        }; 3];
        let Some(Local {
            z,
            rho,
            ux,
            uy,
            a,
            b,
        }) = self.local(x)
        else {
            return (out, 0);
        };
        if rho > self.reach(a, b) * 1.0001 + 1e-7 {
            return (out, 0);
        }
        let (roots, count) = radii(self.kappa, self.gamma, z, rho);
        let mut n = 0;
        for &(r, side) in &roots[..count] {
            let (px, py) = (side * r * ux, side * r * uy);
            let Some(i) = self.intensity(px, py) else {
                continue;
            };
            out[n] = self.arrival(r, px, py, i, area_ratio(a, b, r, self.patch()));
            n += 1;
        }
        (out, n)
    }

    /// The CSL light reaching a pixel whose footprint on the receiver is the parallelogram
    /// around `x` with edges `e1`, `e2` (m; same frame as the CSL), averaged over it. The
    /// footprint is projected along the axis onto the light plane's coordinates
    /// ([`PixelQuad`]); for each side of the axis and each monotonic branch of the ray map, the
    /// rays landing in it carry the flux I·∫r·Θ dr of their light-plane band
    /// ([`branch_band`], [`Self::quad_flux`]), with the intensity and direction of the ray through
    /// the pixel centre (or the nearest one of the branch). Where h is smooth on the pixel's
    /// scale this is Eq. 4; at a focus or fold narrower than the pixel it is the pixel's mean,
    /// which a point sample at the centre misses, and neighbouring pixels share the light
    /// without gap or overlap. Where every branch's band of light-plane radii lies within a
    /// texel (the ray map smooth on the pixel's scale), the point evaluation
    /// [`Self::arrivals`] is that mean already and is used instead (same figures against the
    /// reference, half the time); a band within a texel reads the image once. A degenerate
    /// footprint (zero edges) gives [`Self::arrivals`].
    pub fn arrivals_filtered(
        &self,
        x: Vec3,
        e1: Vec3,
        e2: Vec3,
    ) -> ([Arrival; MAX_ARRIVALS], usize) {
        let mut out = [Arrival {
            dir: Vec3::ZERO,
            density: Vec3::ZERO,
        }; MAX_ARRIVALS];
        let Some(Local {
            rho, ux, uy, a, b, ..
        }) = self.local(x)
        else {
            return (out, 0);
        };
        let (xa, ya) = (self.x_axis, self.y_axis());
        let plane = |e: Vec3| glam::Vec2::new(e.dot(xa), e.dot(ya));
        let Some(quad) = PixelQuad::new(glam::Vec2::new(rho * ux, rho * uy), plane(e1), plane(e2))
        else {
            let (arr, n) = self.arrivals(x);
            out[..3].copy_from_slice(&arr);
            return (out, n);
        };
        let rmax = self.half_extent * std::f32::consts::SQRT_2;
        let (pa, pb) = quad.distances();
        if pa > self.reach(a, b) * 1.0001 + 1e-7 {
            return (out, 0);
        }
        let mut cuts = [0.0f32, rmax, rmax];
        let mut pieces = 1;
        if a != 0.0 {
            let rs = b / (2.0 * a);
            if rs > 0.0 && rs < rmax {
                cuts = [0.0, rs, rmax];
                pieces = 2;
            }
        }
        // Each branch's band of light-plane radii; where every band lies within a texel, the
        // ray map is smooth on the pixel's scale and the point evaluation is the pixel's mean.
        let mut bands = [(0.0f32, 0.0f32, 0.0f32, 0.0f32); 4];
        let mut count = 0;
        let mut wide = false;
        for side in [1.0f32, -1.0] {
            for k in 0..pieces {
                let (ra, rb, r) = branch_band(a, b, side, cuts[k], cuts[k + 1], pa, pb, rho);
                let light = (rb * rb - ra * ra).abs();
                if light <= 0.0 || r.is_nan() || r < 0.0 {
                    continue;
                }
                wide |= (rb - ra).abs() > 2.0 * self.patch();
                bands[count] = (side, ra, rb, r);
                count += 1;
            }
        }
        if !wide {
            let (arr, k) = self.arrivals(x);
            out[..3].copy_from_slice(&arr);
            return (out, k);
        }
        let mut n = 0;
        for &(side, ra, rb, r) in &bands[..count] {
            // A band within a texel of the image: the intensity of the centre's ray stands for
            // all of it (one lookup instead of one a node).
            let (px, py) = (side * r * ux, side * r * uy);
            let fixed = if (rb - ra).abs() <= 2.0 * self.patch() {
                match self.intensity(px, py) {
                    Some(i) => Some(i),
                    None => continue,
                }
            } else {
                None
            };
            let flux = self.quad_flux(a, b, side, ra, rb, ux, uy, &quad, fixed);
            if flux.is_nan() || flux.max_element() <= 0.0 {
                continue;
            }
            // The pixel's mean flux density, in the direction of the ray through its centre.
            out[n] = self.arrival(r, px, py, flux, quad.area);
            n += 1;
        }
        (out, n)
    }

    /// Flux (per unit irradiance of the light) of the rays of one branch [ra, rb] of
    /// g(r) = side·r(b − a·r) that land inside the pixel's parallelogram: ∫ I(r)·r·Θ(g(r)) dr,
    /// Θ from [`PixelQuad::arc`], I read along the pixel centre's direction (ux, uy) from the
    /// axis (or `fixed`, where given), by 8-point Gauss-Legendre.
    #[allow(clippy::too_many_arguments)]
    pub fn quad_flux(
        &self,
        a: f32,
        b: f32,
        side: f32,
        ra: f32,
        rb: f32,
        ux: f32,
        uy: f32,
        quad: &PixelQuad,
        fixed: Option<Vec3>,
    ) -> Vec3 {
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        if let Some(i) = fixed {
            let m: f32 = GL8
                .iter()
                .map(|&(x, w)| {
                    let r = mid + half * x;
                    w * r * quad.arc(side * r * (b - a * r))
                })
                .sum();
            return i * (m * half);
        }
        GL8.iter()
            .map(|&(x, w)| {
                let r = mid + half * x;
                let arc = quad.arc(side * r * (b - a * r));
                match self.intensity(side * r * ux, side * r * uy) {
                    Some(i) if arc > 0.0 => i * (w * r * arc),
                    _ => Vec3::ZERO,
                }
            })
            .sum::<Vec3>()
            * half
    }

    /// Irradiance on a surface with unit normal `n` at `x`, per unit irradiance of the light.
    pub fn irradiance(&self, x: Vec3, n: Vec3) -> Vec3 {
        let (arr, k) = self.arrivals(x);
        arr[..k]
            .iter()
            .map(|a| a.density * (-a.dir.dot(n)).max(0.0))
            .sum()
    }
}

/// CPU render of the caustics component of a frame from a CSL set (§3.2 on the CPU): for every
/// pixel (`spp`² stratified samples) the first surface seen; on a non-specular receiver each
/// CSL's arrivals are shaded with the receiver's BRDF for the known ray direction (diffuse and
/// glossy), times the light's `irradiance`.
///
/// Occlusion: an arrival counts only when nothing lies between the receiver and the CSL's light
/// plane along the arriving ray, tested against `blockers`, an acceleration structure of every
/// object *except* the caustic object (whose own geometry is where the CSL rays come from).
pub fn render_caustics(
    world: &crate::scene::World,
    camera_accel: &crate::trace::Accel,
    blockers: &crate::trace::Accel,
    csls: &[Csl],
    irradiance: Vec3,
    spp: u32,
) -> crate::frame::Frame {
    use rayon::prelude::*;
    let cam = &world.camera;
    let rays = cam.rays();
    let (w, h) = (cam.width, cam.height);
    let pixels: Vec<Vec3> = (0..w * h)
        .into_par_iter()
        .map(|k| {
            let (px, py) = ((k % w) as f32, (k / w) as f32);
            let mut sum = Vec3::ZERO;
            for sy in 0..spp {
                for sx in 0..spp {
                    let (u, v) = (
                        px + (sx as f32 + 0.5) / spp as f32,
                        py + (sy as f32 + 0.5) / spp as f32,
                    );
                    let d = rays.dir(u, v);
                    let Some(hit) = camera_accel.intersect(cam.eye, d, f32::INFINITY) else {
                        continue;
                    };
                    let mat = camera_accel.material(&hit);
                    if mat.is_specular() {
                        continue;
                    }
                    // The sample's footprint on the receiver's plane: where the rays through
                    // the middles of its sides meet it.
                    let h = 0.5 / spp as f32;
                    let on_plane = |u: f32, v: f32| {
                        let d = rays.dir(u, v);
                        let n = hit.geo_normal;
                        cam.eye + d * ((hit.point - cam.eye).dot(n) / d.dot(n))
                    };
                    let e1 = on_plane(u + h, v) - on_plane(u - h, v);
                    let e2 = on_plane(u, v + h) - on_plane(u, v - h);
                    sum += shade(blockers, csls, &hit, -d, mat, [e1, e2]) * irradiance;
                }
            }
            sum / (spp * spp) as f32
        })
        .collect();
    crate::frame::Frame {
        width: w,
        height: h,
        pixels,
    }
}

/// Outgoing radiance towards `wo` per unit light irradiance at a receiver hit, averaged over
/// a sample whose footprint on the receiver is the parallelogram with edges `e1`, `e2` (m)
/// around the hit.
pub fn shade(
    blockers: &crate::trace::Accel,
    csls: &[Csl],
    hit: &crate::trace::Hit,
    wo: Vec3,
    mat: &crate::scene::Material,
    [e1, e2]: [Vec3; 2],
) -> Vec3 {
    let n = hit.normal;
    let mut out = Vec3::ZERO;
    for c in csls {
        let (arr, k) = c.arrivals_filtered(hit.point, e1, e2);
        for a in &arr[..k] {
            let wi = -a.dir;
            let cos = n.dot(wi);
            if cos <= 0.0 || a.density.max_element() <= 0.0 {
                continue;
            }
            let f = crate::trace::optics::brdf(mat, n, wi, wo);
            if f == Vec3::ZERO {
                continue;
            }
            // Distance back to the light plane along the ray.
            let t_plane = (hit.point - c.origin).dot(c.axis) / a.dir.dot(c.axis).max(1e-4);
            if blockers.occluded(hit.spawn(wi), wi, t_plane) {
                continue;
            }
            out += f * a.density * cos;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Away from foci the patch ratio is Eq. 4's |h·h′/r|; at the on-axis focus it stays finite.
    #[test]
    fn area_ratio_matches_eq4_and_is_finite_at_foci() {
        let (a, b) = (0.3f32, 0.8f32);
        for r in [0.2f32, 0.5, 1.0] {
            let exact = ((b - a * r) * (b - 2.0 * a * r)).abs();
            let fd = area_ratio(a, b, r, 1e-3);
            assert!((fd / exact - 1.0).abs() < 1e-3, "{r}: {fd} vs {exact}");
        }
        // Central ray: the limit B².
        assert!((area_ratio(a, b, 0.0, 1e-4) - b * b).abs() < 1e-3);
        // Ring focused on the axis (h(r) = 0 at r = B/A) and fold (h' = 0 at r = B/2A).
        for r in [b / a, b / (2.0 * a)] {
            let s = area_ratio(a, b, r, 1e-2);
            assert!(s > 0.0 && s.is_finite() && s < 0.1, "{r}: {s}");
        }
    }

    /// Parallelograms tiling the plane share every circle around the axis exactly: their arcs
    /// add to 2π for any radius, also 0 (the axis point lies in exactly one of them) and radii
    /// through corners; one parallelogram's arc and distances agree with brute force.
    #[test]
    fn pixel_quads_tiling_the_plane_share_every_circle() {
        use glam::Vec2;
        let mut seed = 0x9e37_79b9u32;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        for case in 0..40 {
            let e1 = Vec2::new(0.5 + rnd(), rnd() - 0.5) * 1e-3;
            let e2 = Vec2::new(rnd() - 0.5, 0.5 + rnd()) * 1e-3;
            let w0 = Vec2::new(rnd() - 0.5, rnd() - 0.5) * 1e-3;
            // Corners of the tiling lie on the circle through w0 ± (e1 + e2)/2.
            let corner = (w0 + 0.5 * (e1 + e2)).length();
            for t in [0.0, 1e-7, 2e-4 * rnd(), corner, 3e-3 * rnd()] {
                let mut sum = 0.0;
                for i in -12..=12 {
                    for j in -12..=12 {
                        let w = w0 + i as f32 * e1 + j as f32 * e2;
                        sum += PixelQuad::new(w, e1, e2).unwrap().arc(t);
                    }
                }
                assert!(
                    (sum - std::f32::consts::TAU).abs() < 2e-3,
                    "case {case}, t {t}: {sum}"
                );
            }
            let q = PixelQuad::new(w0 * 3.0, e1, e2).unwrap();
            let inside = |p: Vec2| {
                let d = p - w0 * 3.0;
                let det = e1.perp_dot(e2);
                (d.perp_dot(e2) / det).abs() <= 0.5 && (e1.perp_dot(d) / det).abs() <= 0.5
            };
            let (near, far) = q.distances();
            let mut lo = f32::INFINITY;
            let mut hi = 0.0f32;
            for t in [0.3e-3, 1e-3, 2e-3] {
                let n = 20000;
                let hits = (0..n)
                    .filter(|&k| {
                        let phi = (k as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
                        inside(t * Vec2::new(phi.cos(), phi.sin()))
                    })
                    .count();
                let brute = hits as f32 / n as f32 * std::f32::consts::TAU;
                assert!(
                    (q.arc(t) - brute).abs() < 2e-3,
                    "{case} {t}: {} vs {brute}",
                    q.arc(t)
                );
            }
            for a in 0..200 {
                for b in 0..200 {
                    let p =
                        w0 * 3.0 + (a as f32 / 199.0 - 0.5) * e1 + (b as f32 / 199.0 - 0.5) * e2;
                    lo = lo.min(p.length());
                    hi = hi.max(p.length());
                }
            }
            assert!(
                (near - lo).abs() < 1e-5 && (far - hi).abs() < 1e-6,
                "{near} {far} {lo} {hi}"
            );
        }
    }

    /// A focus narrower than a pixel lands in the pixels whose footprints hold it, whatever the
    /// pixel grid's offset: the flux over a block of pixels around it does not depend on where
    /// the grid lies (a disc of each pixel's area counted it 0, 1 or 2 times).
    #[test]
    fn a_focus_is_counted_once_wherever_the_pixel_grid_lies() {
        let size = 64u32;
        // A converging CSL with a Gaussian image (1/e radius 25 mm) and spherical aberration
        // γ: the ring at r focuses at height 1/(κ + γr).
        let half = 0.08f32;
        let pix = 2.0 * half / size as f32;
        let texels = (0..size * size)
            .map(|k| {
                let (i, j) = (k % size, k / size);
                let x = -half + (i as f32 + 0.5) * pix;
                let y = -half + (j as f32 + 0.5) * pix;
                let v = (65535.0 * (-(x * x + y * y) / (0.025 * 0.025)).exp()).round() as u16;
                [v, v, v]
            })
            .collect();
        let csl = Csl {
            origin: Vec3::ZERO,
            axis: Vec3::Z,
            x_axis: Vec3::X,
            kappa: 1.0,
            gamma: 0.5,
            half_extent: half,
            size,
            scale: 1.0,
            flux: 0.0,
            grain: 0.0,
            texels,
        };
        // The receiver at z = 1/κ: the central rays focus there, the outer ones before it
        // (h(r) = −r²/2: the light of r ≤ 25 mm lands within 0.3 mm of the axis).
        let z = 1.0;
        let s = 0.5e-3; // pixel side
        let mut totals = Vec::new();
        for k in 0..16 {
            let (ox, oy) = ((k % 4) as f32 / 4.0 * s, (k / 4) as f32 / 4.0 * s);
            let (e1, e2) = (Vec3::X * s, Vec3::Y * s);
            let mut total = 0.0;
            for i in -3..=3 {
                for j in -3..=3 {
                    let x = Vec3::new(ox + i as f32 * s, oy + j as f32 * s, z);
                    let (arr, n) = csl.arrivals_filtered(x, e1, e2);
                    let flux: f32 = arr[..n].iter().map(|a| a.density.x * a.dir.z).sum();
                    total += flux * s * s;
                }
            }
            totals.push(total);
        }
        let (lo, hi) = totals
            .iter()
            .fold((f32::INFINITY, 0.0f32), |(a, b), &t| (a.min(t), b.max(t)));
        // The image's flux: π·(25 mm)² (the Gaussian's tail beyond the image is negligible).
        let flux = std::f32::consts::PI * 0.025 * 0.025;
        assert!(
            lo > 0.98 * flux && hi < 1.02 * flux,
            "flux near the focus varies with the grid: {totals:?} vs {flux}"
        );
    }

    /// Plug each root back: h(r) = side·ρ.
    #[test]
    fn radii_solve_the_ray_equation() {
        for &(kappa, gamma) in &[(1.3f32, 0.8f32), (0.0, 0.0), (-0.7, -0.2), (2.0, 0.0)] {
            for &z in &[0.1f32, 0.5, 0.9, 2.0] {
                for &rho in &[0.0f32, 0.01, 0.2, 0.6] {
                    let (r, n) = radii(kappa, gamma, z, rho);
                    for &(r, side) in &r[..n] {
                        let h = r * (1.0 - z * (kappa + gamma * r));
                        assert!(
                            (h - side * rho).abs() < 1e-4,
                            "{kappa} {gamma} {z} {rho}: {r}"
                        );
                    }
                }
            }
        }
        // Case (i) and (ii) of the paper: α = 1, β = 1 at z = 0.25, ρ = 0.05 gives three radii.
        let (_, n) = radii(1.0, 1.0, 0.25, 0.05);
        assert_eq!(n, 3);
        // Collimated: the one ray at r = ρ.
        let (r, n) = radii(0.0, 0.0, 1.0, 0.3);
        assert_eq!(n, 1);
        assert!((r[0].0 - 0.3).abs() < 1e-6 && r[0].1 == 1.0);
    }
}
