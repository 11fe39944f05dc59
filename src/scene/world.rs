//! The resolved scene every method reads: meshes generated or imported, materials and lights
//! in their physical form, camera with the projection helpers all renderers share.

use glam::{Mat4, Vec3};
use std::sync::Arc;

/// Perspective pinhole camera (vertical field of view, square pixels).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// Orthonormal basis: right, true up, forward (towards the target).
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        (r, u, f)
    }

    /// tan(fov_y / 2): half the image plane height at distance 1.
    pub fn tan_half_fov(&self) -> f32 {
        (self.fov_y.to_radians() * 0.5).tan()
    }

    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// Area of one pixel on the image plane at distance 1 in front of the eye.
    pub fn pixel_area(&self) -> f32 {
        let h = 2.0 * self.tan_half_fov() / self.height as f32;
        h * h
    }

    /// Unit direction through image position (x, y) in pixels; (0,0) is the top-left corner
    /// of the image, pixel centres are at i + 0.5.
    pub fn ray_dir(&self, x: f32, y: f32) -> Vec3 {
        self.rays().dir(x, y)
    }

    /// The basis and scale factors of [`Camera::ray_dir`] computed once, for generating many
    /// rays.
    pub fn rays(&self) -> RayGen {
        let (r, u, f) = self.basis();
        let t = self.tan_half_fov();
        RayGen {
            right: r * (2.0 * t * self.aspect() / self.width as f32),
            down: u * (-2.0 * t / self.height as f32),
            corner: f - r * (t * self.aspect()) + u * t,
        }
    }

    /// Image position (pixels, same convention as [`Camera::ray_dir`]) of a world point and the
    /// cosine between the view axis and the direction to it; None behind the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32, f32)> {
        let (r, u, f) = self.basis();
        let d = p - self.eye;
        let z = d.dot(f);
        if z <= 1e-6 {
            return None;
        }
        let t = self.tan_half_fov();
        let sx = d.dot(r) / z / (t * self.aspect());
        let sy = d.dot(u) / z / t;
        let x = (sx + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy) * 0.5 * self.height as f32;
        Some((x, y, z / d.length()))
    }

    pub fn view_matrix(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// Right-handed perspective with a \[0, 1\] depth range (wgpu convention).
    pub fn proj_matrix(&self, near: f32, far: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(
            self.fov_y.to_radians(),
            self.aspect(),
            near,
            far,
        )
    }
}

/// Camera ray directions without recomputing the camera basis per ray.
#[derive(Clone, Copy, Debug)]
pub struct RayGen {
    right: Vec3,
    down: Vec3,
    corner: Vec3,
}

impl RayGen {
    /// Unit direction through image position (x, y) in pixels, as [`Camera::ray_dir`].
    #[inline]
    pub fn dir(&self, x: f32, y: f32) -> Vec3 {
        (self.corner + self.right * x + self.down * y).normalize()
    }
}

/// An equirectangular environment image, linear RGB, row 0 at +Y, laid out as Mitsuba 3's
/// `envmap` reads it: column i is centred on u = (i + 0.5)/W (u wraps), row j on
/// v = j/(H − 1) (rows 0 and H − 1 lie on the poles, v clamps), see [`env_uv`].
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

impl EnvMap {
    /// Radiance arriving *from* direction `d` (unit): bilinear between the four nearest texel
    /// centres, as Mitsuba's `envmap` (`eval_spectrum`).
    pub fn lookup(&self, d: Vec3) -> Vec3 {
        let (u, v) = env_uv(d);
        self.lookup_uv(u, v)
    }

    /// Bilinear lookup at (u, v) ∈ [0, 1]² (u wraps, v clamps).
    pub fn lookup_uv(&self, u: f32, v: f32) -> Vec3 {
        let (w, h) = (self.width, self.height);
        let x = (u - 0.5 / w as f32).rem_euclid(1.0) * w as f32;
        let y = v.clamp(0.0, 1.0) * (h.max(2) - 1) as f32;
        let x0 = (x as u32).min(w - 1);
        let y0 = (y as u32).min(h.max(2) - 2);
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let x1 = (x0 + 1) % w;
        let y1 = (y0 + 1).min(h - 1);
        let y0 = y0.min(h - 1);
        let t = |x: u32, y: u32| self.texels[(y * w + x) as usize];
        let top = t(x0, y0) * (1.0 - fx) + t(x1, y0) * fx;
        let bottom = t(x0, y1) * (1.0 - fx) + t(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The direction towards the light at (u, v), inverse of [`env_uv`] (Mitsuba's
    /// `uv_to_direction`).
    pub fn direction(u: f32, v: f32) -> Vec3 {
        let (sp, cp) = (2.0 * std::f32::consts::PI * u).sin_cos();
        let (st, ct) = (std::f32::consts::PI * v).sin_cos();
        Vec3::new(sp * st, ct, -cp * st)
    }
}

/// Importance sampling of an [`EnvMap`]'s directions: a piecewise-constant density over the
/// cells between texel centres (the patches [`EnvMap::lookup`] interpolates bilinearly), each
/// weighted by the mean luminance of its four corner texels × sin θ at its centre, sampled by
/// a marginal CDF over rows and a conditional CDF per row (Pharr, Jakob & Humphreys 2016,
/// *Physically Based Rendering* 3rd ed., §13.6.7 and §14.2.4; Mitsuba 3's `envmap` samples its
/// bilinear patches the same way). Every direction where the map is not black has a density
/// > 0, so estimators that divide by [`EnvSampler::pdf`] stay unbiased.
#[derive(Clone, Debug)]
pub struct EnvSampler {
    cols: usize,
    rows: usize,
    /// Per row, the cumulative cell weights (length `cols`, last = the row's sum).
    conditional: Vec<f32>,
    /// Cumulative row sums (length `rows`, last = the total).
    marginal: Vec<f32>,
}

impl EnvSampler {
    /// One sampler per light of `world`, in its order: None for a light that is not an
    /// environment map (or a constant or black one).
    pub fn for_lights(world: &World) -> Vec<Option<EnvSampler>> {
        world
            .lights
            .iter()
            .map(|l| match l {
                Light::Environment { map: Some(m), .. } => EnvSampler::new(m),
                _ => None,
            })
            .collect()
    }

    /// The distribution of `map`; None when the map is black (nothing to sample).
    pub fn new(map: &EnvMap) -> Option<EnvSampler> {
        let (w, h) = (map.width as usize, map.height as usize);
        let rows = h.max(2) - 1;
        let lum = |x: usize, y: usize| {
            map.texels[y.min(h - 1) * w + x % w]
                .dot(Vec3::new(0.2126, 0.7152, 0.0722))
                .max(0.0)
        };
        let mut conditional = Vec::with_capacity(w * rows);
        let mut marginal = Vec::with_capacity(rows);
        let mut total = 0.0f64;
        for j in 0..rows {
            let sin_theta = (std::f32::consts::PI * (j as f32 + 0.5) / rows as f32).sin();
            let mut acc = 0.0f64;
            for i in 0..w {
                let mean = 0.25 * (lum(i, j) + lum(i + 1, j) + lum(i, j + 1) + lum(i + 1, j + 1));
                acc += f64::from(mean * sin_theta);
                conditional.push(acc as f32);
            }
            total += acc;
            marginal.push(total as f32);
        }
        (total > 0.0 && total.is_finite()).then_some(EnvSampler {
            cols: w,
            rows,
            conditional,
            marginal,
        })
    }

    /// Index of the first entry of the (non-decreasing) `cdf` above `x`, and where `x` falls
    /// inside that entry's step, in [0, 1).
    fn invert(cdf: &[f32], x: f32) -> (usize, f32) {
        let i = cdf.partition_point(|c| *c <= x).min(cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
        let step = cdf[i] - lo;
        let f = if step > 0.0 { (x - lo) / step } else { 0.5 };
        (i, f.clamp(0.0, 1.0 - f32::EPSILON))
    }

    /// Density of cell (i, j) in (u, v) ∈ [0, 1]².
    fn pdf_uv(&self, i: usize, j: usize) -> f32 {
        let row = &self.conditional[j * self.cols..(j + 1) * self.cols];
        let cell = row[i] - if i == 0 { 0.0 } else { row[i - 1] };
        cell / self.marginal[self.rows - 1] * (self.cols * self.rows) as f32
    }

    /// A direction towards the light and its density per unit solid angle, from two uniform
    /// numbers in [0, 1); None on the (measure-zero) poles.
    pub fn sample(&self, u1: f32, u2: f32) -> Option<(Vec3, f32)> {
        let total = self.marginal[self.rows - 1];
        let (j, fv) = Self::invert(&self.marginal, u1 * total);
        let row = &self.conditional[j * self.cols..(j + 1) * self.cols];
        let (i, fu) = Self::invert(row, u2 * row[self.cols - 1]);
        let u = ((i as f32 + 0.5 + fu) / self.cols as f32).rem_euclid(1.0);
        let v = (j as f32 + fv) / self.rows as f32;
        let sin_theta = (std::f32::consts::PI * v).sin();
        if sin_theta <= 1e-6 {
            return None;
        }
        let pdf = self.pdf_uv(i, j) / (2.0 * std::f32::consts::PI.powi(2) * sin_theta);
        (pdf > 0.0).then(|| (EnvMap::direction(u, v), pdf))
    }

    /// Density per unit solid angle with which [`EnvSampler::sample`] picks direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let (u, v) = env_uv(d);
        let sin_theta = (std::f32::consts::PI * v).sin();
        if sin_theta <= 1e-6 {
            return 0.0;
        }
        let x = (u - 0.5 / self.cols as f32).rem_euclid(1.0) * self.cols as f32;
        let i = (x as usize).min(self.cols - 1);
        let j = ((v * self.rows as f32) as usize).min(self.rows - 1);
        self.pdf_uv(i, j) / (2.0 * std::f32::consts::PI.powi(2) * sin_theta)
    }
}

/// Equirectangular coordinates in [0,1)² of the unit direction `d` towards the light, as
/// Mitsuba 3's `envmap`: u = atan2(d.x, −d.z)/2π wrapped to [0, 1) (u = 0 at −Z, ¼ at +X, ½ at
/// +Z, ¾ at −X), v = acos(d.y)/π (0 at +Y).
pub fn env_uv(d: Vec3) -> (f32, f32) {
    let u = d.x.atan2(-d.z) / (2.0 * std::f32::consts::PI);
    let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
    (u.rem_euclid(1.0), v)
}

/// A light in the form renderers use (directions normalised, angles in radians).
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// `direction`: unit travel direction (the disc's centre). `irradiance`: W/m² facing the
    /// light, from the whole disc. `angular_radius`: the disc's, radians (0: a delta light).
    Directional {
        direction: Vec3,
        irradiance: Vec3,
        angular_radius: f32,
    },
    /// `intensity` in W/sr.
    Point { position: Vec3, intensity: Vec3 },
    /// `direction`: unit axis. Angles in radians.
    Spot {
        position: Vec3,
        direction: Vec3,
        intensity: Vec3,
        cutoff: f32,
        beam_width: f32,
    },
    /// Total `intensity` (W/sr) spread uniformly over the segment.
    Line {
        start: Vec3,
        end: Vec3,
        intensity: Vec3,
    },
    /// Distant light: `radiance` × (map lookup, or 1 without a map).
    Environment {
        map: Option<Arc<EnvMap>>,
        radiance: Vec3,
    },
}

impl Light {
    /// Mitsuba's spot falloff: 1 inside the beam width, linear in angle to 0 at the cutoff.
    pub fn spot_falloff(cos_theta: f32, cutoff: f32, beam_width: f32) -> f32 {
        if cos_theta <= cutoff.cos() {
            return 0.0;
        }
        if cos_theta >= beam_width.cos() {
            return 1.0;
        }
        let theta = cos_theta.clamp(-1.0, 1.0).acos();
        ((cutoff - theta) / (cutoff - beam_width).max(1e-6)).clamp(0.0, 1.0)
    }

    pub fn kind(&self) -> &'static str {
        match self {
            Light::Directional { .. } => "directional",
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::Line { .. } => "line",
            Light::Environment { .. } => "environment",
        }
    }
}

/// Surface material in physical form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Material {
    Diffuse {
        albedo: Vec3,
    },
    /// albedo/π + GGX(α = roughness²) specular with Schlick F0 = `specular`.
    Glossy {
        albedo: Vec3,
        specular: Vec3,
        roughness: f32,
    },
    /// `absorption`: Beer-Lambert coefficient per metre.
    Dielectric {
        ior: f32,
        absorption: Vec3,
    },
    Mirror {
        reflectance: Vec3,
    },
}

impl Material {
    /// Specular (delta) materials carry caustics; the others receive them.
    pub fn is_specular(&self) -> bool {
        matches!(self, Material::Dielectric { .. } | Material::Mirror { .. })
    }
}

/// Triangle mesh with smooth per-vertex normals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// A copy with positions and normals transformed by `m`.
    pub fn transformed(&self, m: Mat4) -> Mesh {
        let nm = m.inverse().transpose();
        let flip = m.determinant() < 0.0;
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|p| m.transform_point3(*p))
                .collect(),
            normals: self
                .normals
                .iter()
                .map(|n| nm.transform_vector3(*n).normalize_or_zero())
                .collect(),
            indices: if flip {
                self.indices.iter().map(|t| [t[0], t[2], t[1]]).collect()
            } else {
                self.indices.clone()
            },
        }
    }

    /// Area-weighted vertex normals (for meshes that come without normals).
    pub fn compute_normals(&mut self) {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let fnrm = (b - a).cross(c - a);
            for &i in t {
                n[i as usize] += fnrm;
            }
        }
        self.normals = n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect();
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        )
    }

    /// Whether the mesh is the closed, outward-wound boundary of solids: with vertices closer
    /// than a millionth of its diagonal taken as one (a sphere's seam, split normals), every
    /// edge of a triangle of non-zero size is crossed by exactly one other triangle, in the
    /// opposite direction, and every connected piece encloses a positive volume (counter-
    /// clockwise seen from outside, glTF's front faces). Seen from a point outside, such a
    /// mesh shows only front faces; its back faces are hidden behind them, so a raster pass may
    /// cull them. False for open or non-manifold meshes, inconsistent or inward winding (a hollow
    /// shell's inner wall included), or indices out of range.
    pub fn is_closed_outward(&self) -> bool {
        let n = self.positions.len();
        if self.indices.is_empty() || self.indices.iter().flatten().any(|&i| i as usize >= n) {
            return false;
        }
        let (lo, hi) = self.bounds();
        let tol = (hi - lo).length() * 1e-6;
        if !tol.is_finite() || tol <= 0.0 {
            return false;
        }
        let id = weld(&self.positions, tol);
        // Directed edges of the triangles that did not collapse; closed and consistently wound
        // when the set of edges equals the set of reversed edges and no edge repeats.
        let tris: Vec<[u32; 3]> = self
            .indices
            .iter()
            .map(|t| t.map(|i| id[i as usize]))
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect();
        if tris.is_empty() {
            return false;
        }
        let mut edges: Vec<(u32, u32)> = tris
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .collect();
        let mut reversed: Vec<(u32, u32)> = edges.iter().map(|&(a, b)| (b, a)).collect();
        edges.sort_unstable();
        reversed.sort_unstable();
        if edges.windows(2).any(|w| w[0] == w[1]) || edges != reversed {
            return false;
        }
        // Connected pieces (union-find over the welded vertices), each of positive volume.
        let mut parent: Vec<u32> = (0..n as u32).collect();
        fn root(parent: &mut [u32], mut i: u32) -> u32 {
            while parent[i as usize] != i {
                let g = parent[parent[i as usize] as usize];
                parent[i as usize] = g;
                i = g;
            }
            i
        }
        for t in &tris {
            let a = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = root(&mut parent, v);
                parent[b as usize] = a;
            }
        }
        let mut volume: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
        for t in &tris {
            let [a, b, c] = t.map(|i| (self.positions[i as usize] - lo).as_dvec3());
            *volume.entry(root(&mut parent, t[0])).or_default() += a.dot(b.cross(c)) / 6.0;
        }
        let scale = f64::from((hi - lo).length()).powi(3) * 1e-12;
        volume.values().all(|&v| v > scale)
    }
}

/// Each position's representative after welding: the index of the first earlier position within
/// `tol` of it (Euclidean; itself when there is none), found in the 27 grid cells of side `tol`
/// around it (cells counted from the lowest corner, so far-off meshes do not overflow them).
/// Vertices split for normals, seams and poles come out as one.
pub fn weld(positions: &[Vec3], tol: f32) -> Vec<u32> {
    let tol = tol.max(f32::MIN_POSITIVE);
    let lo = positions.iter().fold(Vec3::MAX, |lo, p| lo.min(*p));
    let cell = |p: Vec3| ((p - lo) / tol).floor().as_ivec3();
    let mut grid: std::collections::HashMap<glam::IVec3, Vec<u32>> =
        std::collections::HashMap::new();
    let mut weld = Vec::with_capacity(positions.len());
    for (i, p) in positions.iter().enumerate() {
        let c = cell(*p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in grid
                        .get(&(c + glam::IVec3::new(dx, dy, dz)))
                        .into_iter()
                        .flatten()
                    {
                        if positions[j as usize].distance(*p) <= tol {
                            found = Some(j);
                            break 'search;
                        }
                    }
                }
            }
        }
        weld.push(found.unwrap_or_else(|| {
            grid.entry(c).or_default().push(i as u32);
            i as u32
        }));
    }
    weld
}

/// Part of an object drawn with one material; mesh in the object's local frame.
#[derive(Clone, Debug)]
pub struct Part {
    pub mesh: Arc<Mesh>,
    /// Index into [`World::materials`].
    pub material: u32,
}

/// A named object: parts in a local frame plus the object-to-world transform, so that bakes
/// can work in the object's frame and renders can move the object rigidly.
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub parts: Vec<Part>,
    pub transform: Mat4,
}

impl Object {
    /// The object-to-world transform without its scale (rotation and translation): the frame
    /// bakes work in, with the scale baked in, so that a render moves a bake with the object.
    pub fn rigid_transform(&self) -> Mat4 {
        let (_, rot, trans) = self.transform.to_scale_rotation_translation();
        Mat4::from_rotation_translation(rot, trans)
    }

    /// The world direction `dir` (e.g. a light's) in the object's rigid frame, normalised.
    pub fn to_rigid_frame(&self, dir: Vec3) -> Vec3 {
        let (_, rot, _) = self.transform.to_scale_rotation_translation();
        (rot.inverse() * dir).normalize()
    }

    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.mesh.triangle_count()).sum()
    }
}

/// The world-space extent (lo, hi) of `objects`' vertices; lo > hi when there are none.
pub fn objects_extent(objects: &[Object]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for o in objects {
        for p in &o.parts {
            for v in &p.mesh.positions {
                let w = o.transform.transform_point3(*v);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    (lo, hi)
}

/// An extent, or the origin's point when it is empty.
fn or_origin((lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
    if lo.x > hi.x {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (lo, hi)
    }
}

/// The resolved scene.
#[derive(Clone, Debug)]
pub struct World {
    pub name: String,
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub materials: Vec<Material>,
    pub objects: Vec<Object>,
    /// Non-fatal findings while loading (clamped values, ignored glTF features...).
    pub warnings: Vec<String>,
    /// Water bodies (`water` shapes): their surfaces are objects too, their media absorb.
    pub water: Vec<super::water::WaterBody>,
    /// Participating media (the scene's `media`).
    pub media: Vec<super::medium::Medium>,
    /// Whether [`super::ground::add_ground`] put its plane in (it puts one in at most).
    pub has_ground: bool,
}

impl World {
    /// About how many bytes the world holds in memory: its meshes (each shared mesh once),
    /// environment maps and media boundaries — what a cache of worlds counts.
    pub fn heap_bytes(&self) -> u64 {
        use std::collections::HashSet;
        let mut seen = HashSet::new();
        let mut n = 0u64;
        for p in self.objects.iter().flat_map(|o| &o.parts) {
            if seen.insert(Arc::as_ptr(&p.mesh)) {
                let m = &p.mesh;
                n += (m.positions.len() * 12 + m.normals.len() * 12 + m.indices.len() * 12) as u64;
            }
        }
        for l in &self.lights {
            if let Light::Environment { map: Some(m), .. } = l
                && seen.insert(Arc::as_ptr(m).cast())
            {
                n += m.texels.len() as u64 * 12;
            }
        }
        // A medium's boundary is an acceleration structure: ~150 bytes a triangle.
        n += self
            .media
            .iter()
            .map(|m| m.boundary_triangles() as u64 * 150)
            .sum::<u64>();
        n + std::mem::size_of::<World>() as u64
    }

    /// Indices of the objects with a part whose material `pick` accepts (e.g.
    /// [`Material::is_specular`]: the objects that cast caustics).
    pub fn objects_with(&self, pick: impl Fn(&Material) -> bool) -> Vec<usize> {
        self.objects
            .iter()
            .enumerate()
            .filter(|(_, o)| {
                o.parts
                    .iter()
                    .any(|p| pick(&self.materials[p.material as usize]))
            })
            .map(|(i, _)| i)
            .collect()
    }

    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(Object::triangle_count).sum()
    }

    /// World-space bounds of all geometry (not the media: [`Self::bounds_with_media`]).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        or_origin(objects_extent(&self.objects))
    }

    /// World-space bounds of all geometry and the media's boxes.
    pub fn bounds_with_media(&self) -> (Vec3, Vec3) {
        let extent = self
            .media
            .iter()
            .fold(objects_extent(&self.objects), |(lo, hi), m| {
                let (a, b) = m.bounds();
                (lo.min(a), hi.max(b))
            });
        or_origin(extent)
    }

    pub fn object(&self, name: &str) -> Option<&Object> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// The index of the object named `name`.
    pub fn object_index(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name == name)
    }

    /// Transmittance of the straight segment a → b (which crosses no surface) through the
    /// water bodies' media and the participating media.
    pub fn medium_transmittance(&self, a: Vec3, b: Vec3) -> Vec3 {
        self.media
            .iter()
            .fold(self.water_transmittance(a, b), |t, m| {
                t * m.transmittance(a, b)
            })
    }

    /// Transmittance of the straight segment a → b through the water bodies' media alone.
    pub fn water_transmittance(&self, a: Vec3, b: Vec3) -> Vec3 {
        self.water
            .iter()
            .fold(Vec3::ONE, |t, w| t * w.transmittance(a, b))
    }

    /// Transmittance of the participating media along o + t·d (unit d), 0 ≤ t ≤ t_max (which
    /// may be infinite: a shadow ray towards a directional light).
    pub fn media_transmittance_ray(&self, o: Vec3, d: Vec3, t_max: f32) -> Vec3 {
        self.media
            .iter()
            .fold(Vec3::ONE, |t, m| t * m.transmittance_ray(o, d, t_max))
    }

    /// The water body whose surface is object `object`.
    pub fn water_of(&self, object: u32) -> Option<&super::water::WaterBody> {
        self.water.iter().find(|w| w.object == object as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed solids (the sphere with its split seam, a box, a torus, a capped cylinder, two
    /// spheres apart) are found closed and outward; an open plane, a sphere with a hole, one
    /// turned inside out, a hollow shell (its inner wall wound inwards) and a sphere with a
    /// triangle doubled are not.
    #[test]
    fn closed_outward_meshes_are_told_from_the_others() {
        use super::super::shapes;
        let sphere = shapes::sphere(0.5, 32);
        let joined = |a: &Mesh, b: &Mesh| {
            let mut m = a.clone();
            let base = m.positions.len() as u32;
            m.positions.extend(&b.positions);
            m.normals.extend(&b.normals);
            m.indices
                .extend(b.indices.iter().map(|t| t.map(|i| i + base)));
            m
        };
        let inside_out = |m: &Mesh| Mesh {
            indices: m.indices.iter().map(|t| [t[0], t[2], t[1]]).collect(),
            ..m.clone()
        };
        let moved = sphere.transformed(Mat4::from_translation(Vec3::new(3.0, 0.0, 0.0)));
        let inner = inside_out(&shapes::sphere(0.3, 32));
        for (name, mesh, want) in [
            ("sphere", sphere.clone(), true),
            ("box", shapes::cuboid(Vec3::new(1.0, 2.0, 0.5)), true),
            ("torus", shapes::torus(1.0, 0.25, 24), true),
            ("cylinder", shapes::cylinder(0.5, 1.0, 24), true),
            ("two spheres", joined(&sphere, &moved), true),
            ("plane", shapes::plane(2.0, 2.0), false),
            (
                "sphere with a hole",
                {
                    let mut m = sphere.clone();
                    m.indices.remove(100);
                    m
                },
                false,
            ),
            ("inside out", inside_out(&sphere), false),
            ("shell", joined(&sphere, &inner), false),
            (
                "doubled triangle",
                {
                    let mut m = sphere.clone();
                    m.indices.push(m.indices[100]);
                    m
                },
                false,
            ),
            (
                "index out of range",
                {
                    let mut m = sphere.clone();
                    m.indices[0][0] = 1 << 30;
                    m
                },
                false,
            ),
        ] {
            assert_eq!(mesh.is_closed_outward(), want, "{name}");
        }
    }

    #[test]
    fn ray_dir_and_project_are_inverse() {
        let c = Camera {
            eye: Vec3::new(0.0, 3.2, 3.2),
            target: Vec3::new(0.35, 0.0, 0.0),
            up: Vec3::Y,
            fov_y: 40.0,
            width: 320,
            height: 200,
        };
        for (x, y) in [(0.5, 0.5), (160.0, 100.0), (319.5, 12.25)] {
            let p = c.eye + c.ray_dir(x, y) * 3.0;
            let (px, py, _) = c.project(p).unwrap();
            assert!(
                (px - x).abs() < 1e-3 && (py - y).abs() < 1e-3,
                "{x},{y} -> {px},{py}"
            );
        }
        // The centre ray looks at the target; row 0 is the top.
        assert!((c.ray_dir(160.0, 100.0) - (c.target - c.eye).normalize()).length() < 1e-6);
        assert!(c.ray_dir(160.0, 0.0).y > c.ray_dir(160.0, 200.0).y);
    }

    /// The direction towards the light of texel (i, j)'s centre under Mitsuba 3's `envmap`
    /// convention, written out from its `uv_to_direction`.
    fn mitsuba_dir(u: f32, v: f32) -> Vec3 {
        let (sp, cp) = (2.0 * std::f32::consts::PI * u).sin_cos();
        let (st, ct) = (std::f32::consts::PI * v).sin_cos();
        Vec3::new(sp * st, ct, -cp * st)
    }

    #[test]
    fn env_uv_follows_mitsuba() {
        let close = |(u, v): (f32, f32), (eu, ev): (f32, f32)| {
            ((u - eu).abs() < 1e-6 || (u - eu).abs() > 1.0 - 1e-6) && (v - ev).abs() < 1e-6
        };
        assert!(close(env_uv(Vec3::NEG_Z), (0.0, 0.5)));
        assert!(close(env_uv(Vec3::X), (0.25, 0.5)));
        assert!(close(env_uv(Vec3::Z), (0.5, 0.5)));
        assert!(close(env_uv(Vec3::NEG_X), (0.75, 0.5)));
        assert!(env_uv(Vec3::Y).1 < 1e-6 && env_uv(Vec3::NEG_Y).1 > 1.0 - 1e-6);
        for (u, v) in [(0.1, 0.3), (0.6, 0.8), (0.95, 0.5)] {
            assert!(close(env_uv(mitsuba_dir(u, v)), (u, v)), "{u} {v}");
        }
    }

    #[test]
    fn lookup_is_bilinear_between_mitsuba_texel_centres() {
        // 4 × 3 map: columns centred on u = 1/8, 3/8, 5/8, 7/8; rows on v = 0, 1/2, 1.
        let (w, h) = (4u32, 3u32);
        let texels = (0..w * h)
            .map(|i| Vec3::new((i % w) as f32, (i / w) as f32, 1.0))
            .collect();
        let m = EnvMap {
            width: w,
            height: h,
            texels,
        };
        let near = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-4;
        // At a texel centre: that texel.
        assert!(near(m.lookup_uv(3.0 / 8.0, 0.5), Vec3::new(1.0, 1.0, 1.0)));
        // Half-way between columns 1 and 2, a quarter of the way from row 1 to row 2.
        assert!(near(m.lookup_uv(0.5, 0.625), Vec3::new(1.5, 1.25, 1.0)));
        // u wraps: half-way between the last column and the first.
        assert!(near(m.lookup_uv(0.0, 0.0), Vec3::new(1.5, 0.0, 1.0)));
        assert!(near(m.lookup_uv(0.999_999, 0.0), Vec3::new(1.5, 0.0, 1.0)));
        // The poles are rows 0 and H - 1.
        assert_eq!(m.lookup(Vec3::NEG_Y).y, 2.0);
        assert_eq!(m.lookup(Vec3::Y).y, 0.0);
        // direction() inverts env_uv.
        for (u, v) in [(0.2, 0.3), (0.7, 0.9)] {
            let (eu, ev) = env_uv(EnvMap::direction(u, v));
            assert!((eu - u).abs() < 1e-5 && (ev - v).abs() < 1e-5);
        }
    }

    /// A test map: a sky gradient with a bright spot, every texel > 0.
    fn sky_map(w: u32, h: u32) -> EnvMap {
        let texels = (0..w * h)
            .map(|k| {
                let (x, y) = (k % w, k / w);
                let spot = if (x as i32 - 5).abs() <= 1 && (y as i32 - 3).abs() <= 1 {
                    40.0
                } else {
                    0.0
                };
                Vec3::new(0.2 + spot, 0.3 + 0.5 * y as f32 / h as f32, 0.6 + spot)
            })
            .collect();
        EnvMap {
            width: w,
            height: h,
            texels,
        }
    }

    #[test]
    fn env_sampler_pdf_integrates_to_one_and_matches_its_samples() {
        let m = sky_map(32, 17);
        let s = EnvSampler::new(&m).unwrap();
        // ∫ pdf dω over a fine (u, v) grid: dω = 2π² sin θ du dv.
        let (nu, nv) = (512, 512);
        let mut integral = 0.0f64;
        for b in 0..nv {
            let v = (b as f32 + 0.5) / nv as f32;
            let st = (std::f32::consts::PI * v).sin();
            for a in 0..nu {
                let u = (a as f32 + 0.5) / nu as f32;
                let dw = 2.0 * std::f32::consts::PI.powi(2) * st / (nu * nv) as f32;
                integral += f64::from(s.pdf(EnvMap::direction(u, v)) * dw);
            }
        }
        assert!((integral - 1.0).abs() < 2e-3, "∫pdf = {integral}");
        // Histogram of samples over a coarse (u, v) grid against the pdf integrated per bin;
        // every returned pdf is the pdf of the returned direction.
        let (bu, bv) = (8usize, 4usize);
        let mut hist = vec![0u32; bu * bv];
        let mut rng = crate::sampling::Pcg::new(3, 0);
        let n = 200_000;
        let mut mismatched = 0;
        for _ in 0..n {
            let (d, pdf) = s.sample(rng.f32(), rng.f32()).unwrap();
            // The direction's own pdf, up to f32 round-off (acos near the poles, cell edges).
            if (pdf - s.pdf(d)).abs() > 1e-2 * pdf {
                mismatched += 1;
            }
            let (u, v) = env_uv(d);
            let k = ((v * bv as f32) as usize).min(bv - 1) * bu
                + ((u * bu as f32) as usize).min(bu - 1);
            hist[k] += 1;
        }
        assert!(
            mismatched < n / 1000,
            "{mismatched} samples with another pdf"
        );
        for (k, &count) in hist.iter().enumerate() {
            let (a, b) = (k % bu, k / bu);
            let mut p = 0.0f64;
            let sub = 64;
            for y in 0..sub {
                let v = (b as f32 + (y as f32 + 0.5) / sub as f32) / bv as f32;
                let st = (std::f32::consts::PI * v).sin();
                for x in 0..sub {
                    let u = (a as f32 + (x as f32 + 0.5) / sub as f32) / bu as f32;
                    let dw = 2.0 * std::f32::consts::PI.powi(2) * st / (bu * bv * sub * sub) as f32;
                    p += f64::from(s.pdf(EnvMap::direction(u, v)) * dw);
                }
            }
            let expected = p * n as f64;
            let sigma = expected.sqrt().max(1.0);
            assert!(
                (f64::from(count) - expected).abs() < 5.0 * sigma + 0.01 * expected,
                "bin {k}: {count} samples, expected {expected:.0}"
            );
        }
    }

    #[test]
    fn env_sampler_goes_to_the_one_bright_texel() {
        let (w, h) = (64u32, 33u32);
        let mut texels = vec![Vec3::splat(1e-3); (w * h) as usize];
        texels[(12 * w + 40) as usize] = Vec3::splat(1e4);
        let m = EnvMap {
            width: w,
            height: h,
            texels,
        };
        let s = EnvSampler::new(&m).unwrap();
        let centre = EnvMap::direction(40.5 / w as f32, 12.0 / (h - 1) as f32);
        let texel_angle = std::f32::consts::PI / (h - 1) as f32;
        let mut rng = crate::sampling::Pcg::new(5, 1);
        let n = 10_000;
        let near = (0..n)
            .filter(|_| {
                let (d, _) = s.sample(rng.f32(), rng.f32()).unwrap();
                d.dot(centre).clamp(-1.0, 1.0).acos() < 1.5 * texel_angle
            })
            .count();
        assert!(
            near as f32 > 0.99 * n as f32,
            "{near} of {n} near the bright texel"
        );
        // A black map has nothing to sample.
        let black = EnvMap {
            width: 4,
            height: 3,
            texels: vec![Vec3::ZERO; 12],
        };
        assert!(EnvSampler::new(&black).is_none());
    }

    #[test]
    fn one_bright_texel_is_seen_towards_its_direction() {
        // 8 × 5 map, one bright texel at column 1, row 2: u = 1.5/8, v = 1/2 (towards +X, a
        // little towards -Z).
        let (w, h) = (8u32, 5u32);
        let mut texels = vec![Vec3::ZERO; (w * h) as usize];
        texels[(2 * w + 1) as usize] = Vec3::ONE;
        let m = EnvMap {
            width: w,
            height: h,
            texels,
        };
        let d = mitsuba_dir(1.5 / 8.0, 0.5);
        assert!(d.x > 0.9 && d.z < -0.3 && d.y.abs() < 1e-6, "{d}");
        assert!((m.lookup(d) - Vec3::ONE).abs().max_element() < 1e-4);
        // Mirrored directions (the old 180° turn, and the other side) see nothing.
        assert_eq!(m.lookup(Vec3::new(-d.x, d.y, -d.z)), Vec3::ZERO);
        assert_eq!(m.lookup(Vec3::new(-d.x, d.y, d.z)), Vec3::ZERO);
        assert_eq!(m.lookup(Vec3::Y), Vec3::ZERO);
    }
}
