//! The render side of the light transport tables on the CPU (Iwasaki et al. 2005 §5.1–5.2): per frame,
//! the exit ray of every lit vertex is looked up in its table, and every lit triangle sweeps its
//! three exit rays into an illumination volume; the irradiance at a receiver point inside a
//! volume follows Eq. 2 with the flux ratio of the warped volume at that point.
//!
//! - **Lookup** ([`lookup`]): the light's local travel direction at the vertex as (φ, θ) in the
//!   vertex's tangent frame; the four nearest sampling directions are the corners of the (φ, θ)
//!   grid cell it falls in (two on the ring above, two on the ring below; the pole stands for
//!   both corners of the first ring); position and transmittance are interpolated bilinearly,
//!   the direction by nested slerps (the quaternion interpolation of Fig. 5). A sample the
//!   light cannot use (self-occluded, or trapped inside) carries no light: its weight goes to
//!   the others for position and direction, and its transmittance counts as zero, so light
//!   fades out smoothly where the table stops transmitting.
//! - **Light sources** ([`sources`]): directional (the same travel direction at every vertex),
//!   point and spot (per vertex, with 1/r² and Mitsuba's spot falloff), line lights as N point
//!   lights (§5.1).
//! - **Volumes** ([`build_volumes`]): a triangle is lit when its three vertices are (the light
//!   comes from above each vertex's tangent plane, its table sample transmits, nothing opaque
//!   lies between the vertex and the light: other glass objects let it through as if they were
//!   clear, their own caustics being their volumes). Its volume holds the three exit
//!   points eᵢ and directions dᵢ and, per corner, the flux per unit triangle area entering
//!   there and leaving the object: Fᵢ = Eᵢ · max(0, −ωᵢ·n_tri) · Tᵢ (Eq. 2's L_in cos θ F_t).
//! - **Irradiance** ([`Volume::arrival`]): Eq. 2, L_p = L_in cos θ · F_t · F_p · ρ_d with the
//!   flux ratio F_p = S/S_p, S the triangle's area and S_p "the area of the cross section
//!   between the illumination volume and the object surface". For an arbitrary receiver the
//!   cross-section is taken with the receiver's tangent plane at the point being shaded: the
//!   three exit rays meet that plane in a triangle Q, the point's barycentrics b in Q weight the
//!   corner flux densities, and E = S · Σ bᵢFᵢ / |Q|. Q follows the receiver's position and
//!   orientation, so on curved receivers S_p changes continuously from point to point, and
//!   the corner weights make the light vary within a volume on flat ones too. The volumes of
//!   neighbouring triangles share their edge rays, so on any plane their Q tile it exactly and
//!   the flux that enters the object's triangles is the flux that lands (a test checks it).
//!   A pixel gets the average over its footprint on the receiver (the overlap of Q with the
//!   footprint, clipped exactly), not a point sample: foci are far smaller than a pixel, and
//!   a point sample at each pixel centre measured 8 % of the floor flux off on the sphere.
//!   Ernst et al.'s warped-volume area (the cross-section at a common ray parameter t through
//!   the point, a cubic in t) was tried first: point-sampled, it measured like the receiver's
//!   plane on the sphere (L1 0.22 against 0.23, flux 0.91 both); it does not conserve flux by
//!   construction and costs a cubic per pixel and volume, so the receiver's plane, which does,
//!   was kept. What changed the figures was the footprint average (floor flux against
//!   single-refraction photon tracing through the same sphere 0.966 → 0.979, L1 0.20 → 0.13).
//!
//! - **Reflection** ([`build_reflection_volumes`]): the tables hold what the glass transmits;
//!   the light it reflects at the surface (the paper's §8 leaves it "to be calculated") is a
//!   mirror ray at each lit vertex with the Fresnel reflectance of the smooth normal, so lit
//!   triangles sweep reflection volumes from their vertices with no table, evaluated at the
//!   receivers exactly like the transmitted ones. Under the canonical sphere it is 7 % of the
//!   floor's caustic flux (photons traced through it: 0.937 refract in and out, 0.071 start
//!   with a reflection), so without it no table resolution gets the flux within 5 %.
//!
//! `render::transport` draws the same volumes on the GPU (shaders/transport.wgsl); this module
//! is its reference and the test oracle.

use crate::bake::transport::{TransportTable, Vertex, local_angles, table_vertices, tangent_frame};
use crate::cancel::{Canceled, Stop};
use crate::scene::{Light, Material, World};
use crate::trace::Accel;
use crate::trace::optics::{fresnel_dielectric, reflect};
use glam::{DVec3, Vec3};

/// Most a volume may concentrate light: S / A⊥ ≤ this (a focus has zero cross-section).
pub const MAX_MAGNIFICATION: f32 = 1.0e4;

/// Point lights a line light becomes (§5.1) unless told otherwise.
pub const DEFAULT_LINE_POINTS: u32 = 16;

/// A light as the transport render sees it: directional, or a point (with a spot cone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Source {
    /// `direction`: unit travel direction; `irradiance`: W/m² facing the light.
    Directional { direction: Vec3, irradiance: Vec3 },
    /// `intensity` in W/sr; `spot`: (unit axis, cutoff, beam width) in radians.
    Point {
        position: Vec3,
        intensity: Vec3,
        spot: Option<(Vec3, f32, f32)>,
    },
}

impl Source {
    /// Travel direction and irradiance facing the light at point `p` (None where the light
    /// sends nothing).
    pub fn at(&self, p: Vec3) -> Option<(Vec3, Vec3)> {
        match *self {
            Source::Directional {
                direction,
                irradiance,
            } => Some((direction, irradiance)),
            Source::Point {
                position,
                intensity,
                spot,
            } => {
                let to = p - position;
                let r2 = to.length_squared();
                if r2 < 1e-12 {
                    return None;
                }
                let w = to / r2.sqrt();
                let falloff = match spot {
                    Some((axis, cutoff, beam)) => Light::spot_falloff(w.dot(axis), cutoff, beam),
                    None => 1.0,
                };
                (falloff > 0.0).then(|| (w, intensity * falloff / r2))
            }
        }
    }

    /// Where the light is seen from `p`: the unit direction towards it and its distance.
    pub fn towards(&self, p: Vec3) -> (Vec3, f32) {
        match *self {
            Source::Directional { direction, .. } => (-direction, f32::INFINITY),
            Source::Point { position, .. } => {
                let d = position - p;
                let l = d.length();
                (d / l.max(1e-12), l)
            }
        }
    }
}

/// The delta lights of `lights` as sources: line lights as `line_points` point lights of equal
/// intensity at the centres of equal pieces of the segment; environment lights carry no
/// transport caustics and are left out.
pub fn sources(lights: &[Light], line_points: u32) -> Vec<Source> {
    let mut out = Vec::new();
    for l in lights {
        match *l {
            Light::Directional {
                direction,
                irradiance,
                ..
            } => out.push(Source::Directional {
                direction: direction.normalize(),
                irradiance,
            }),
            Light::Point {
                position,
                intensity,
            } => out.push(Source::Point {
                position,
                intensity,
                spot: None,
            }),
            Light::Spot {
                position,
                direction,
                intensity,
                cutoff,
                beam_width,
            } => out.push(Source::Point {
                position,
                intensity,
                spot: Some((direction.normalize(), cutoff, beam_width)),
            }),
            Light::Line {
                start,
                end,
                intensity,
            } => {
                let n = line_points.max(1);
                for k in 0..n {
                    out.push(Source::Point {
                        position: start.lerp(end, (k as f32 + 0.5) / n as f32),
                        intensity: intensity / n as f32,
                        spot: None,
                    });
                }
            }
            Light::Environment { .. } => {}
        }
    }
    out
}

/// Where light arriving at a vertex leaves the object (object rigid frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exit {
    pub position: Vec3,
    pub direction: Vec3,
    /// RGB: the Fresnel transmittance product times Beer-Lambert over the path.
    pub transmittance: Vec3,
}

/// Spherical linear interpolation of unit vectors (the rotation from `a` to `b`, scaled).
pub fn slerp(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    let c = a.dot(b).clamp(-1.0, 1.0);
    if c > 0.9995 {
        return a.lerp(b, t).normalize_or(a);
    }
    let omega = c.acos();
    let s = omega.sin();
    if s < 1e-6 {
        // Opposite vectors: any great circle; the lerp's direction is as good as another.
        return a.lerp(b, t).normalize_or(a);
    }
    ((a * ((1.0 - t) * omega).sin() + b * (t * omega).sin()) / s).normalize_or(a)
}

/// Mix two exits at fraction `f` from `a` to `b`; an unusable one gives its weight's position
/// and direction to the other and contributes no transmittance.
fn mix(a: Option<Exit>, b: Option<Exit>, f: f32) -> Option<Exit> {
    match (a, b) {
        (Some(a), Some(b)) => Some(Exit {
            position: a.position.lerp(b.position, f),
            direction: slerp(a.direction, b.direction, f),
            transmittance: a.transmittance.lerp(b.transmittance, f),
        }),
        (Some(a), None) => Some(Exit {
            transmittance: a.transmittance * (1.0 - f),
            ..a
        }),
        (None, Some(b)) => Some(Exit {
            transmittance: b.transmittance * f,
            ..b
        }),
        (None, None) => None,
    }
}

/// Which table samples [`lookup_with`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Use {
    /// Light: samples that are self-occluded or trapped carry nothing.
    Light,
    /// Viewing rays (§5.3): every sample, trapped ones with their last hit.
    View,
}

/// The interpolated exit of light travelling along `w` (object rigid frame) into table vertex
/// `v` (`vertex` is its entry of [`table_vertices`]); `None` when the light comes from below
/// the vertex's tangent plane or no nearby sample transmits.
pub fn lookup(table: &TransportTable, v: usize, vertex: &Vertex, w: Vec3) -> Option<Exit> {
    lookup_with(table, v, vertex, w, Use::Light)
}

/// [`lookup`] for light or for viewing rays.
pub fn lookup_with(
    table: &TransportTable,
    v: usize,
    vertex: &Vertex,
    w: Vec3,
    usage: Use,
) -> Option<Exit> {
    lookup_on(table, v, vertex, w, usage, None)
}

/// The light travelling along `w` into table vertex `v`, split by the paths it leaves on:
/// for every distinct path signature among the usable samples of the four nearest sampling
/// directions, the exit interpolated from those samples alone (the others carry nothing, as an
/// occluded sample does in [`lookup`]). The transmittances add up to [`lookup`]'s; positions
/// and directions are never interpolated between samples that left on different paths, which
/// would put the exit somewhere no light leaves (a streak across the receiver). Empty when the
/// light comes from below the tangent plane or no nearby sample transmits.
pub fn lookup_paths(
    table: &TransportTable,
    v: usize,
    vertex: &Vertex,
    w: Vec3,
) -> Vec<(u16, Exit)> {
    let mut paths: Vec<u16> = Vec::with_capacity(4);
    let Some(corners) = corners(table, vertex, w) else {
        return Vec::new();
    };
    for (k, m) in corners {
        let s = table.sample(v, table.params.index(k, m));
        if !(s.occluded || s.trapped) && s.transmittance > 0.0 && !paths.contains(&s.path) {
            paths.push(s.path);
        }
    }
    paths
        .into_iter()
        .filter_map(|p| Some((p, lookup_on(table, v, vertex, w, Use::Light, Some(p))?)))
        .collect()
}

/// The (ring, azimuth) grid cell direction `w` falls in at `vertex`: its four corners (ring k0,
/// azimuths m0 and m1, then ring k0 + 1), `None` at or below the horizon.
fn corners(table: &TransportTable, vertex: &Vertex, w: Vec3) -> Option<[(u32, u32); 4]> {
    let (k0, _, m0, m1, _) = cell(table, vertex, w)?;
    Some([(k0, m0), (k0, m1), (k0 + 1, m0), (k0 + 1, m1)])
}

/// The grid cell of [`corners`] and the fractions across it: (k0, fr, m0, m1, fa).
fn cell(table: &TransportTable, vertex: &Vertex, w: Vec3) -> Option<(u32, f32, u32, u32, f32)> {
    let p = &table.params;
    let frame = tangent_frame(vertex.normal);
    let (phi, theta) = local_angles(frame, w);
    let ring_step = std::f32::consts::FRAC_PI_2 / p.rings as f32;
    let r = phi / ring_step;
    if r.is_nan() || r >= p.rings as f32 {
        return None; // at or below the horizon
    }
    let k0 = r.floor() as u32;
    let fr = r - k0 as f32;
    let a = theta / (std::f32::consts::TAU / p.azimuths as f32);
    let m0 = (a.floor() as u32).min(p.azimuths - 1);
    let fa = (a - m0 as f32).clamp(0.0, 1.0);
    let m1 = (m0 + 1) % p.azimuths;
    Some((k0, fr, m0, m1, fa))
}

/// [`lookup_with`], with only the samples of path signature `path` when given.
fn lookup_on(
    table: &TransportTable,
    v: usize,
    vertex: &Vertex,
    w: Vec3,
    usage: Use,
    path: Option<u16>,
) -> Option<Exit> {
    let p = &table.params;
    let (k0, fr, m0, m1, fa) = cell(table, vertex, w)?;
    let sample = |k: u32, m: u32| -> Option<Exit> {
        let s = table.sample(v, p.index(k, m));
        if usage == Use::Light && (s.occluded || s.trapped) {
            return None;
        }
        if path.is_some_and(|p| p != s.path) {
            return None;
        }
        let beer = if table.absorbing {
            (-vertex.absorption * s.path_length).exp()
        } else {
            Vec3::ONE
        };
        Some(Exit {
            position: s.position,
            direction: s.direction,
            transmittance: s.transmittance * beer,
        })
    };
    let ring = |k: u32| mix(sample(k, m0), sample(k, m1), fa);
    mix(ring(k0), ring(k0 + 1), fr)
}

/// One illumination volume (world space): three exit rays and the flux entering at each
/// corner of its triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Volume {
    pub exits: [Vec3; 3],
    pub dirs: [Vec3; 3],
    /// Fᵢ = Eᵢ · cos θᵢ · Tᵢ per corner (W/m² of triangle area, RGB).
    pub flux_density: [Vec3; 3],
    /// Area S of the object's triangle.
    pub source_area: f32,
    /// How far along its rays the volume reaches (to the edge of the scene's bounds).
    pub length: f32,
}

/// One beam of a volume arriving at a receiver point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arrival {
    /// Unit travel direction.
    pub dir: Vec3,
    /// Irradiance on the receiver (W/m²), cos included.
    pub irradiance: Vec3,
    /// Distance back along the ray to where it left the object.
    pub distance: f32,
}

impl Volume {
    /// Where the three exit rays meet the plane through `p` with unit normal `n`: the volume's
    /// cross-section S_p there (Eq. 2). `None` when a ray runs parallel to or away from the
    /// plane's front, or meets it behind its exit or beyond the volume's length.
    pub fn cross_section(&self, p: DVec3, n: DVec3) -> Option<[DVec3; 3]> {
        let mut q = [DVec3::ZERO; 3];
        for (i, qi) in q.iter_mut().enumerate() {
            let (e, d) = (self.exits[i].as_dvec3(), self.dirs[i].as_dvec3());
            let den = d.dot(n);
            if den >= 0.0 {
                return None;
            }
            let t = (p - e).dot(n) / den;
            if !(0.0..=self.length as f64).contains(&t) {
                return None;
            }
            *qi = e + t * d;
        }
        Some(q)
    }

    /// The beam this volume sends to a receiver point `p` (unit normal `n`): irradiance
    /// E = S · Σ bᵢFᵢ / |S_p| (Eq. 2's F_p = S/S_p, the cos θ and transmittance in Fᵢ), with
    /// S_p the cross-section through p and b the barycentrics of p in it. With `footprint`,
    /// the corners of the pixel's footprint on the receiver (a convex quadrilateral in the same
    /// plane), the result is the average over the footprint: S · Σ bᵢFᵢ · |S_p ∩ footprint| /
    /// (|S_p| · |footprint|) with b at the centroid of the overlap, exact for the piecewise
    /// linear field and free of any singularity at foci (the overlap is never larger than
    /// S_p). Without one, a point sample, its magnification capped at [`MAX_MAGNIFICATION`].
    pub fn arrival(&self, p: Vec3, n: Vec3, footprint: Option<&[Vec3; 4]>) -> Option<Arrival> {
        let (pd, nd) = (p.as_dvec3(), n.as_dvec3());
        let q = self.cross_section(pd, nd)?;
        let (u, v) = (q[1] - q[0], q[2] - q[0]);
        let nn = u.cross(v);
        let nn2 = nn.length_squared();
        if nn2 <= 0.0 {
            return None;
        }
        let area_q = 0.5 * nn2.sqrt();
        let s = self.source_area as f64;
        let (at, weight) = match footprint {
            None => (pd, (s / area_q).min(MAX_MAGNIFICATION as f64)),
            Some(fp) => {
                let (centroid, overlap, area_fp) = clip_overlap(&q, fp, nd)?;
                (centroid, s * overlap / (area_q * area_fp))
            }
        };
        let w = at - q[0];
        let b1 = w.cross(v).dot(nn) / nn2;
        let b2 = u.cross(w).dot(nn) / nn2;
        let b0 = 1.0 - b1 - b2;
        const EDGE: f64 = -1e-6;
        if footprint.is_none() && (b0 < EDGE || b1 < EDGE || b2 < EDGE) {
            return None;
        }
        let (b0, b1, b2) = (b0.max(0.0), b1.max(0.0), b2.max(0.0));
        let bs = b0 + b1 + b2;
        let (b0, b1, b2) = (b0 / bs, b1 / bs, b2 / bs);
        let [e0, e1, e2] = self.exits.map(|v| v.as_dvec3());
        let [d0, d1, d2] = self.dirs.map(|v| v.as_dvec3());
        let dir = (b0 * d0 + b1 * d1 + b2 * d2).normalize_or_zero();
        let f = self.flux_density[0] * b0 as f32
            + self.flux_density[1] * b1 as f32
            + self.flux_density[2] * b2 as f32;
        let exit = b0 * e0 + b1 * e1 + b2 * e2;
        Some(Arrival {
            dir: dir.as_vec3(),
            irradiance: f * weight as f32,
            distance: (at - exit).length() as f32,
        })
    }
}

/// Overlap of triangle `q` and the convex quadrilateral `fp`, both in the plane of unit normal
/// `n`: (centroid of the overlap, its area, the quadrilateral's area), `None` when they do not
/// overlap. Sutherland-Hodgman in the plane's 2D coordinates.
fn clip_overlap(q: &[DVec3; 3], fp: &[Vec3; 4], n: DVec3) -> Option<(DVec3, f64, f64)> {
    let o = q[0];
    let ax = n.any_orthonormal_vector();
    let ay = n.cross(ax);
    let to2 = |p: DVec3| glam::DVec2::new((p - o).dot(ax), (p - o).dot(ay));
    let mut quad = fp.map(|p| to2(p.as_dvec3()));
    let area2 = |poly: &[glam::DVec2]| -> f64 {
        let mut a = 0.0;
        for i in 0..poly.len() {
            let (p, r) = (poly[i], poly[(i + 1) % poly.len()]);
            a += p.perp_dot(r);
        }
        0.5 * a
    };
    let area_fp = area2(&quad);
    if area_fp < 0.0 {
        quad.reverse();
    }
    let area_fp = area_fp.abs();
    if area_fp <= 0.0 {
        return None;
    }
    let mut poly: Vec<glam::DVec2> = q.iter().map(|p| to2(*p)).collect();
    for i in 0..4 {
        let (a, b) = (quad[i], quad[(i + 1) % 4]);
        let edge = b - a;
        let inside = |p: glam::DVec2| edge.perp_dot(p - a) >= 0.0;
        let mut out = Vec::with_capacity(poly.len() + 2);
        for k in 0..poly.len() {
            let (cur, prev) = (poly[k], poly[(k + poly.len() - 1) % poly.len()]);
            let (ci, pi) = (inside(cur), inside(prev));
            if ci != pi {
                let dc = edge.perp_dot(cur - a);
                let dp = edge.perp_dot(prev - a);
                out.push(prev + (cur - prev) * (dp / (dp - dc)));
            }
            if ci {
                out.push(cur);
            }
        }
        poly = out;
        if poly.len() < 3 {
            return None;
        }
    }
    // Area and centroid of the overlap.
    let (mut a, mut c) = (0.0, glam::DVec2::ZERO);
    for i in 0..poly.len() {
        let (p, r) = (poly[i], poly[(i + 1) % poly.len()]);
        let cr = p.perp_dot(r);
        a += cr;
        c += (p + r) * cr;
    }
    let a = 0.5 * a;
    if a.abs() <= 0.0 {
        return None;
    }
    let c = c / (6.0 * a);
    Some((o + ax * c.x + ay * c.y, a.abs(), area_fp))
}

impl From<Canceled> for EvalError {
    fn from(_: Canceled) -> Self {
        EvalError::Canceled
    }
}

/// Errors of [`build_volumes`].
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("no object named {0:?}")]
    UnknownObject(String),
    #[error(
        "transport table does not fit object {object:?}: it was baked for another mesh, \
         material or parameters (table {table:016x}, object {object_hash:016x})"
    )]
    Mismatch {
        object: String,
        table: u64,
        object_hash: u64,
    },
    #[error(
        "the lights sweep more than {limit} illumination volumes over the glass ({light_sources} \
         light sources, line lights counting as their points); use fewer lights (or fewer \
         points per line light) or a coarser glass mesh"
    )]
    TooManyVolumes { limit: usize, light_sources: usize },
    #[error("canceled")]
    Canceled,
}

/// Most illumination volumes one frame may hold (144 bytes each on the GPU: 288 MB).
pub const MAX_VOLUMES: usize = 2_000_000;

/// Refuses more than [`MAX_VOLUMES`] volumes for `sources`.
pub fn check_volume_count(count: usize, sources: &[Source]) -> Result<(), EvalError> {
    if count > MAX_VOLUMES {
        return Err(EvalError::TooManyVolumes {
            limit: MAX_VOLUMES,
            light_sources: sources.len(),
        });
    }
    Ok(())
}

/// A vertex the light reaches: its exit (world space), the light's travel direction (rigid
/// frame), the irradiance facing the light, and how far the exit ray runs before it meets the
/// rest of the scene (None: it leaves).
type LitVertex = (Exit, Vec3, Vec3, Option<f32>);

/// Figures of one frame's volume construction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VolumeStats {
    pub vertices: usize,
    /// (vertex, source) pairs whose light reaches the vertex and transmits.
    pub lit_vertices: usize,
    pub volumes: usize,
    /// Flux entering the lit triangles and leaving the object (W, RGB).
    pub flux: Vec3,
    /// Reflection volumes ([`build_reflection_volumes`]) among `volumes`.
    pub reflection_volumes: usize,
    /// Flux the lit triangles reflect (W, RGB), not part of `flux`.
    pub reflected_flux: Vec3,
    /// Flux entering lit triangles that no volume carries because their corners leave on
    /// different paths and the splitting could not place it (W, RGB), not part of `flux`.
    pub split_flux: Vec3,
}

/// The glass of one object as the volumes see it: its table vertices, their world positions,
/// its triangles in table vertex numbering, and its rigid frame.
struct Glass {
    vertices: Vec<Vertex>,
    world_pos: Vec<Vec3>,
    tris: Vec<[usize; 3]>,
    m: glam::Mat4,
    rot: glam::Quat,
}

impl Glass {
    fn new(world: &World, object: &crate::scene::Object) -> Glass {
        let vertices = table_vertices(world, object);
        let m = object.rigid_transform();
        let (_, rot, _) = object.transform.to_scale_rotation_translation();
        let world_pos = vertices
            .iter()
            .map(|v| m.transform_point3(v.position))
            .collect();
        let mut tris: Vec<[usize; 3]> = Vec::new();
        let mut base = 0usize;
        for part in &object.parts {
            if !matches!(
                world.materials[part.material as usize],
                Material::Dielectric { .. }
            ) {
                continue;
            }
            for idx in &part.mesh.indices {
                tris.push(idx.map(|i| base + i as usize));
            }
            base += part.mesh.positions.len();
        }
        Glass {
            vertices,
            world_pos,
            tris,
            m,
            rot,
        }
    }

    /// Every triangle whose three corners are lit sweeps their rays into volumes (appended
    /// to `out`); returns the flux the volumes carry and the flux left out.
    ///
    /// Where the four nearest samples of all three corners left on one and the same path
    /// ([`lookup_paths`]), the corners' interpolated exits sweep one volume, as the paper
    /// does. Where they did not, interpolating would send light where none goes (the streaks
    /// of a flat bottom or an open tube), so with a `split` tracer the triangle is split: its
    /// corners and the midpoints of its edges are traced through the object exactly, and each
    /// quarter whose corners share a path sweeps a volume; a quarter whose corners do not is
    /// split again, down to [`SPLIT_DEPTH`] levels ([`Split::finest`] places what is left
    /// there). Without a tracer (reflection volumes: one path) the shared paths' volumes are
    /// swept and the rest left out.
    fn sweep(
        &self,
        lit: &[Vec<(u16, LitVertex)>],
        split: Option<&Splitter>,
        bounded: bool,
        bounds: (Vec3, Vec3),
        out: &mut Vec<Volume>,
        stop: &Stop,
    ) -> Result<(Vec3, Vec3), EvalError> {
        use rayon::prelude::*;
        let per_tri: Vec<(Vec<Volume>, Vec3, Vec3)> = self
            .tris
            .par_iter()
            .enumerate()
            .filter_map(|(k, &[a, b, c])| {
                if !stop.go_at(k, PER_CHECK) {
                    return None;
                }
                let (la, lb, lc) = (&lit[a], &lit[b], &lit[c]);
                if la.is_empty() || lb.is_empty() || lc.is_empty() {
                    return None;
                }
                let v = &self.vertices;
                let (ng, area) = facing(
                    [v[a].position, v[b].position, v[c].position],
                    v[a].normal + v[b].normal + v[c].normal,
                )?;
                let mut vols = Vec::new();
                let (flux, lost) = match split {
                    Some(sp) if !one_path([la, lb, lc]) => {
                        let corner = |i: usize| Corner {
                            position: v[i].position,
                            normal: v[i].normal,
                        };
                        sp.emit(
                            [corner(a), corner(b), corner(c)],
                            &v[a],
                            ng,
                            area,
                            bounded,
                            bounds,
                            &mut vols,
                        )
                    }
                    _ => emit_shared([la, lb, lc], ng, area, bounded, bounds, &mut vols),
                };
                Some((vols, flux, lost))
            })
            .collect();
        if stop.stopped() {
            return Err(EvalError::Canceled);
        }
        let (mut flux, mut lost) = (Vec3::ZERO, Vec3::ZERO);
        for (vols, f, l) in per_tri {
            out.extend(vols);
            flux += f;
            lost += l;
        }
        Ok((flux, lost))
    }
}

/// Whether the light of three corners leaves on one and the same path, each corner's on that
/// one alone.
fn one_path(corners: [&[(u16, LitVertex)]; 3]) -> bool {
    let one = |l: &[(u16, LitVertex)]| (l.len() == 1).then(|| l[0].0);
    let [a, b, c] = corners.map(one);
    a.is_some() && a == b && b == c
}

/// The volumes of the paths all three corners share (appended to `out`): (flux carried, flux
/// left out).
fn emit_shared(
    [la, lb, lc]: [&[(u16, LitVertex)]; 3],
    ng: Vec3,
    area: f32,
    bounded: bool,
    bounds: (Vec3, Vec3),
    out: &mut Vec<Volume>,
) -> (Vec3, Vec3) {
    let density = |x: &LitVertex| x.2 * (-x.1.dot(ng)).max(0.0) * x.0.transmittance;
    let entering = |l: &[(u16, LitVertex)]| l.iter().map(|(_, x)| density(x)).sum::<Vec3>();
    let total = (entering(la) + entering(lb) + entering(lc)) / 3.0 * area;
    // Light on the shared paths is placed (whether or not its volume then reaches anything).
    let (mut carried, mut placed) = (Vec3::ZERO, Vec3::ZERO);
    for &(path, xa) in la {
        let on = |l: &[(u16, LitVertex)]| l.iter().find(|x| x.0 == path).map(|x| x.1);
        if let (Some(xb), Some(xc)) = (on(lb), on(lc)) {
            carried += emit([xa, xb, xc], ng, area, bounded, bounds, out);
            placed += (density(&xa) + density(&xb) + density(&xc)) / 3.0 * area;
        }
    }
    (carried, (total - placed).max(Vec3::ZERO))
}

/// How many times [`Glass::sweep`] halves a triangle whose corners leave on different paths
/// (4² = 16 pieces at most).
pub const SPLIT_DEPTH: u32 = 2;

/// A point of a glass triangle in the object's rigid frame: position and unit shading normal.
#[derive(Clone, Copy, Debug)]
struct Corner {
    position: Vec3,
    normal: Vec3,
}

/// Traces light into a glass object exactly, for the triangles [`Glass::sweep`] splits: the
/// object alone in its rigid frame, its smooth patches (for the path signatures), the table's
/// most interactions, and what the frame's source and blockers need.
struct Splitter<'a> {
    accel: &'a Accel,
    patches: &'a [u32],
    max_depth: u32,
    source: &'a Source,
    blockers: Option<&'a Accel>,
    m: glam::Mat4,
    rot: glam::Quat,
    scale: f32,
}

impl Splitter<'_> {
    /// The light arriving at `c` (rigid frame) and where it leaves: (path, lit corner), or
    /// `None` where no light enters or none leaves.
    fn trace(&self, c: Corner, vertex: &Vertex) -> Option<(u16, LitVertex)> {
        let pw = self.m.transform_point3(c.position);
        let (w_world, e) = self.source.at(pw)?;
        let w = self.rot.inverse() * w_world;
        if w.dot(c.normal) >= 0.0 {
            return None;
        }
        let mut rays = 0;
        let s = crate::bake::transport::trace_sample(
            self.accel,
            self.patches,
            c.position,
            c.normal,
            w,
            vertex.ior,
            self.max_depth,
            &mut rays,
        );
        if s.occluded || s.trapped || s.transmittance <= 0.0 {
            return None;
        }
        if let Some(b) = self.blockers {
            let (to, dist) = self.source.towards(pw);
            if b.occluded(pw + to * (1e-4 * self.scale), to, dist) {
                return None;
            }
        }
        let position = self.m.transform_point3(s.position);
        let direction = (self.rot * s.direction).normalize();
        let reach = self
            .blockers
            .and_then(|b| b.intersect(position, direction, f32::INFINITY).map(|h| h.t));
        let transmittance = s.transmittance * (-vertex.absorption * s.path_length).exp();
        let exit = Exit {
            position,
            direction,
            transmittance,
        };
        Some((s.path, (exit, w, e, reach)))
    }

    /// The volumes of triangle `c` (unit normal `ng`, area `area`), the light traced at its
    /// corners and the triangle split where they leave on different paths: (flux carried,
    /// flux left out).
    #[allow(clippy::too_many_arguments)]
    fn emit(
        &self,
        c: [Corner; 3],
        vertex: &Vertex,
        ng: Vec3,
        area: f32,
        bounded: bool,
        bounds: (Vec3, Vec3),
        out: &mut Vec<Volume>,
    ) -> (Vec3, Vec3) {
        let n = 1u32 << SPLIT_DEPTH;
        let mut split = Split {
            tracer: self,
            c,
            centroid: Corner {
                position: (c[0].position + c[1].position + c[2].position) / 3.0,
                normal: (c[0].normal + c[1].normal + c[2].normal).normalize_or(c[0].normal),
            },
            vertex,
            ng,
            area,
            bounded,
            bounds,
            traced: std::collections::HashMap::new(),
        };
        split.split([(n, 0), (0, n), (0, 0)], SPLIT_DEPTH, out)
    }
}

/// One triangle being split ([`Splitter::emit`]). Its points are named by integer barycentric
/// coordinates (i, j) over 2^[`SPLIT_DEPTH`] (the weights of its first and second corners), so
/// that the pieces share the points they have in common and each is traced once.
struct Split<'s, 'a> {
    tracer: &'s Splitter<'a>,
    c: [Corner; 3],
    centroid: Corner,
    vertex: &'s Vertex,
    ng: Vec3,
    /// The whole triangle's area.
    area: f32,
    bounded: bool,
    bounds: (Vec3, Vec3),
    traced: std::collections::HashMap<(u32, u32), Option<(u16, LitVertex)>>,
}

impl Split<'_, '_> {
    /// The point (i, j) of the triangle.
    fn point(&self, (i, j): (u32, u32)) -> Corner {
        let n = (1u32 << SPLIT_DEPTH) as f32;
        let (a, b) = (i as f32 / n, j as f32 / n);
        let w = [a, b, 1.0 - a - b];
        Corner {
            position: (0..3).map(|k| self.c[k].position * w[k]).sum(),
            normal: (0..3)
                .map(|k| self.c[k].normal * w[k])
                .sum::<Vec3>()
                .normalize_or(self.c[0].normal),
        }
    }

    /// The light at point `key`, traced once, from a point a thousandth of the way towards the
    /// triangle's centroid: a corner on a crease or a rim (where the table's own samples
    /// disagree) then enters and leaves through the patches the triangle's inside does, not
    /// through whichever side of an edge the ray happens to graze.
    fn lit(&mut self, key: (u32, u32)) -> Option<(u16, LitVertex)> {
        if let Some(l) = self.traced.get(&key) {
            return *l;
        }
        let p = self.point(key);
        let q = Corner {
            position: p.position.lerp(self.centroid.position, 1e-3),
            normal: p
                .normal
                .lerp(self.centroid.normal, 1e-3)
                .normalize_or(p.normal),
        };
        let l = self.tracer.trace(q, self.vertex);
        self.traced.insert(key, l);
        l
    }

    /// The piece with corners `keys`, `depth` halvings from the finest.
    fn split(&mut self, keys: [(u32, u32); 3], depth: u32, out: &mut Vec<Volume>) -> (Vec3, Vec3) {
        let area = self.area / (1u32 << (2 * (SPLIT_DEPTH - depth))) as f32;
        let lit = keys.map(|k| self.lit(k));
        if lit.iter().all(|l| l.is_none()) {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        if let [Some(a), Some(b), Some(c)] = lit
            && a.0 == b.0
            && b.0 == c.0
        {
            let f = emit(
                [a.1, b.1, c.1],
                self.ng,
                area,
                self.bounded,
                self.bounds,
                out,
            );
            return (f, Vec3::ZERO);
        }
        if depth == 0 {
            return self.finest(keys.map(|k| self.point(k)), lit, area, out);
        }
        let mid = |a: (u32, u32), b: (u32, u32)| ((a.0 + b.0) / 2, (a.1 + b.1) / 2);
        let [k0, k1, k2] = keys;
        let m = [mid(k0, k1), mid(k1, k2), mid(k2, k0)];
        let mut total = (Vec3::ZERO, Vec3::ZERO);
        for piece in [
            [k0, m[0], m[2]],
            [m[0], k1, m[1]],
            [m[2], m[1], k2],
            [m[0], m[1], m[2]],
        ] {
            let (f, l) = self.split(piece, depth - 1, out);
            total.0 += f;
            total.1 += l;
        }
        total
    }

    /// A piece of the finest level (corners `c`, area `area`) whose corners still leave on
    /// different paths (or some not at all): each path of its lit corners gets a volume
    /// carrying the share of the corners on it (a third each), the other corners replaced by
    /// a point on the path, found by tracing from the point three quarters of the way to the
    /// centroid of the path's corners. A path with no such point loses its share (the flux
    /// left out).
    fn finest(
        &self,
        c: [Corner; 3],
        lit: [Option<(u16, LitVertex)>; 3],
        area: f32,
        out: &mut Vec<Volume>,
    ) -> (Vec3, Vec3) {
        let ng = self.ng;
        let density = |x: &LitVertex| x.2 * (-x.1.dot(ng)).max(0.0) * x.0.transmittance;
        let (mut carried, mut lost) = (Vec3::ZERO, Vec3::ZERO);
        let mut done: Vec<u16> = Vec::with_capacity(3);
        for &(path, _) in lit.iter().flatten() {
            if done.contains(&path) {
                continue;
            }
            done.push(path);
            let on: Vec<usize> = (0..3)
                .filter(|&i| lit[i].is_some_and(|l| l.0 == path))
                .collect();
            let share = on.len() as f32 / 3.0;
            let centre = on.iter().map(|&i| c[i].position).sum::<Vec3>() / on.len() as f32;
            let normal = on
                .iter()
                .map(|&i| c[i].normal)
                .sum::<Vec3>()
                .normalize_or(c[on[0]].normal);
            let mut corners = [None; 3];
            for i in 0..3 {
                corners[i] = if on.contains(&i) {
                    lit[i].map(|l| l.1)
                } else {
                    let q = Corner {
                        position: c[i].position.lerp(centre, 0.75),
                        normal: c[i].normal.lerp(normal, 0.75).normalize_or(normal),
                    };
                    self.tracer
                        .trace(q, self.vertex)
                        .filter(|l| l.0 == path)
                        .map(|l| l.1)
                };
            }
            let own = on
                .iter()
                .filter_map(|&i| lit[i].map(|l| density(&l.1)))
                .sum::<Vec3>()
                / 3.0
                * area;
            match corners {
                [Some(a), Some(b), Some(d)] => {
                    let mut scaled = Vec::with_capacity(1);
                    let f = emit([a, b, d], ng, area, self.bounded, self.bounds, &mut scaled);
                    // The volume carries its path's share; its flux follows its corners'.
                    for mut v in scaled {
                        v.flux_density = v.flux_density.map(|x| x * share);
                        out.push(v);
                    }
                    carried += f * share;
                }
                _ => lost += own,
            }
        }
        (carried, lost)
    }
}

/// Unit normal and area of triangle `p`, the normal turned to the side of `outward` (table
/// normals face outwards, a mirroring scale turns them with the positions; the winding may
/// not follow).
fn facing(p: [Vec3; 3], outward: Vec3) -> Option<(Vec3, f32)> {
    let mut ng = (p[1] - p[0]).cross(p[2] - p[0]);
    let area = 0.5 * ng.length();
    if area <= 0.0 {
        return None;
    }
    ng /= 2.0 * area;
    if ng.dot(outward) < 0.0 {
        ng = -ng;
    }
    Some((ng, area))
}

/// The volume swept by the rays of three lit corners of a triangle (unit normal `ng` in the
/// frame of the corners' light directions, area `area`), appended to `out`; returns its flux.
fn emit(
    corners: [LitVertex; 3],
    ng: Vec3,
    area: f32,
    bounded: bool,
    (lo, hi): (Vec3, Vec3),
    out: &mut Vec<Volume>,
) -> Vec3 {
    let scale = lo.abs().max(hi.abs()).max_element().max(1.0);
    let f = corners.map(|l| l.2 * (-l.1.dot(ng)).max(0.0) * l.0.transmittance);
    if f.iter().all(|x| x.max_element() <= 0.0) {
        return Vec3::ZERO;
    }
    let exits = corners.map(|l| l.0.position);
    let dirs = corners.map(|l| l.0.direction);
    // The volume reaches as far as its farthest corner ray meets the scene. When all three
    // miss it (blockers given), nothing wider than the volume can be lit, and it is dropped;
    // without blockers it runs to the edge of the scene's bounds.
    let reach = corners.map(|l| l.3);
    let length = if bounded {
        if reach.iter().all(|r| r.is_none()) {
            return Vec3::ZERO;
        }
        reach
            .iter()
            .zip(exits.iter().zip(&dirs))
            .map(|(r, (e, d))| r.unwrap_or_else(|| box_exit(*e, *d, lo, hi)))
            .fold(0.0f32, f32::max)
    } else {
        exits
            .iter()
            .zip(&dirs)
            .map(|(e, d)| box_exit(*e, *d, lo, hi))
            .fold(0.0f32, f32::max)
    };
    if length <= 0.0 {
        return Vec3::ZERO;
    }
    out.push(Volume {
        exits,
        dirs,
        flux_density: f,
        source_area: area,
        length: length * 1.001 + 1e-4 * scale,
    });
    (f[0] + f[1] + f[2]) / 3.0 * area
}

/// Vertices or triangles of [`build_volumes`] and [`build_reflection_volumes`] between two
/// questions to their `keep_going`.
pub const PER_CHECK: usize = 1024;

/// The illumination volumes of object `object_name` (with its `table`) for `sources`, in world
/// space. `blockers` holds what may shadow the object's vertices from the light (the scene
/// without its caustic objects: other glass is taken as clear); `None` shadows nothing. Stops
/// with [`EvalError::Canceled`] when `keep_going` (asked before each source, every
/// [`PER_CHECK`] vertices and triangles, and right before and after a BVH build) says so.
pub fn build_volumes(
    world: &World,
    object_name: &str,
    table: &TransportTable,
    sources: &[Source],
    blockers: Option<&Accel>,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<(Vec<Volume>, VolumeStats), EvalError> {
    let object = world
        .object(object_name)
        .ok_or_else(|| EvalError::UnknownObject(object_name.to_string()))?;
    let expect = crate::bake::transport::source_hash(world, object, &table.params);
    let glass = Glass::new(world, object);
    if expect != table.source_hash || table.vertex_count as usize != glass.vertices.len() {
        return Err(EvalError::Mismatch {
            object: object_name.to_string(),
            table: table.source_hash,
            object_hash: expect,
        });
    }
    let Glass {
        vertices,
        world_pos,
        m,
        rot,
        ..
    } = &glass;
    let inv_rot = rot.inverse();
    let (lo, hi) = world.bounds();
    let mut stats = VolumeStats {
        vertices: vertices.len(),
        ..Default::default()
    };
    let scale = lo.abs().max(hi.abs()).max_element().max(1.0);
    let mut volumes = Vec::new();
    let own: std::sync::OnceLock<(Accel, Vec<u32>)> = std::sync::OnceLock::new();
    let stop = Stop::new(keep_going);
    for src in sources {
        stop.check()?;
        // Per vertex and path it leaves on: the exit (world space), the light's travel
        // direction (rigid frame) and its irradiance.
        let lit: Vec<Vec<(u16, LitVertex)>> = {
            use rayon::prelude::*;
            (0..vertices.len())
                .into_par_iter()
                .map(|i| {
                    if !stop.go_at(i, PER_CHECK) {
                        return Vec::new();
                    }
                    let pw = world_pos[i];
                    let Some((w_world, e)) = src.at(pw) else {
                        return Vec::new();
                    };
                    let w = inv_rot * w_world;
                    let exits = lookup_paths(table, i, &vertices[i], w);
                    if exits.is_empty() {
                        return Vec::new();
                    }
                    if let Some(b) = blockers {
                        let (to, dist) = src.towards(pw);
                        let o = pw + to * (1e-4 * scale);
                        if b.occluded(o, to, dist) {
                            return Vec::new();
                        }
                    }
                    exits
                        .into_iter()
                        .map(|(path, exit)| {
                            let position = m.transform_point3(exit.position);
                            let direction = (*rot * exit.direction).normalize();
                            // Where the exit ray meets the rest of the scene (None: it leaves).
                            let reach = blockers.and_then(|b| {
                                b.intersect(position, direction, f32::INFINITY).map(|h| h.t)
                            });
                            let exit = Exit {
                                position,
                                direction,
                                transmittance: exit.transmittance,
                            };
                            (path, (exit, w, e, reach))
                        })
                        .collect()
                })
                .collect()
        };
        stop.check()?;
        stats.lit_vertices += lit.iter().filter(|l| !l.is_empty()).count();
        // The object alone, to trace the triangles whose corners leave on different paths:
        // built once, when a frame first needs it.
        let needs_split = glass.tris.iter().any(|&[a, b, c]| {
            let (la, lb, lc) = (&lit[a], &lit[b], &lit[c]);
            !(la.is_empty() || lb.is_empty() || lc.is_empty() || one_path([la, lb, lc]))
        });
        // The BVH build cannot be interrupted: asked right before and after it.
        stop.check()?;
        let splitter = needs_split.then(|| {
            let (accel, patches) = own.get_or_init(|| {
                let local = crate::bake::csl::rigid_frame_world(world, object);
                let accel = crate::bake::csl::bake_accel(&local);
                let patches = crate::bake::transport::smooth_patches(&local.objects[0]);
                (accel, patches)
            });
            Splitter {
                accel,
                patches,
                max_depth: table.params.max_depth,
                source: src,
                blockers,
                m: *m,
                rot: *rot,
                scale,
            }
        });
        stop.check()?;
        let (flux, split) = glass.sweep(
            &lit,
            splitter.as_ref(),
            blockers.is_some(),
            (lo, hi),
            &mut volumes,
            &stop,
        )?;
        stats.flux += flux;
        stats.split_flux += split;
        check_volume_count(volumes.len(), sources)?;
    }
    stats.volumes = volumes.len();
    Ok((volumes, stats))
}

/// The reflection volumes of object `object_name` for `sources` (world space): the light its
/// glass reflects before any enters. The tables hold only what the glass transmits (the
/// paper's §8 leaves reflection "to be calculated"); the reflected part needs no table, since
/// at each vertex it is a mirror ray with the Fresnel reflectance R(θ) of the smooth normal,
/// and a lit triangle sweeps its three mirror rays into an illumination volume exactly like
/// its exit rays (Fᵢ = Eᵢ cos θᵢ Rᵢ, the same Eq. 2 at the receiver). It carries the light the
/// table's (1 − R) at entry leaves out, so the two together conserve the light that falls on
/// the glass. Shadows as for [`build_volumes`]: a vertex is lit when neither the object itself
/// (the tables' self-occlusion flag, here traced) nor `blockers` (the scene without its caustic
/// objects) lies between it and the light; a mirror ray that meets the object again (light
/// reflected into another part of it) is not followed, and its triangles sweep no volume.
/// `keep_going` as for [`build_volumes`].
pub fn build_reflection_volumes(
    world: &World,
    object_name: &str,
    sources: &[Source],
    blockers: Option<&Accel>,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<(Vec<Volume>, VolumeStats), EvalError> {
    let oi = world
        .objects
        .iter()
        .position(|o| o.name == object_name)
        .ok_or_else(|| EvalError::UnknownObject(object_name.to_string()))?;
    let glass = Glass::new(world, &world.objects[oi]);
    let stop = Stop::new(keep_going);
    // The BVH build cannot be interrupted: asked right before and after it.
    stop.check()?;
    let own = Accel::shared_fast(world, |i| i == oi);
    let (lo, hi) = world.bounds();
    let scale = lo.abs().max(hi.abs()).max_element().max(1.0);
    let mut stats = VolumeStats {
        vertices: glass.vertices.len(),
        ..Default::default()
    };
    let inv_rot = glass.rot.inverse();
    let mut volumes = Vec::new();
    for src in sources {
        stop.check()?;
        let lit: Vec<Vec<(u16, LitVertex)>> = {
            use rayon::prelude::*;
            (0..glass.vertices.len())
                .into_par_iter()
                .map(|i| {
                    if !stop.go_at(i, PER_CHECK) {
                        return None;
                    }
                    let vertex = &glass.vertices[i];
                    let pw = glass.world_pos[i];
                    let (w, e) = src.at(pw)?;
                    let n = (glass.rot * vertex.normal).normalize_or_zero();
                    let cos_i = -w.dot(n);
                    if cos_i <= 0.0 {
                        return None;
                    }
                    let o = pw + n * (1e-4 * scale);
                    let (to, dist) = src.towards(pw);
                    if own.occluded(o, to, dist)
                        || blockers.is_some_and(|b| b.occluded(o, to, dist))
                    {
                        return None;
                    }
                    let dir = reflect(w, n);
                    if own.occluded(o, dir, f32::INFINITY) {
                        return None;
                    }
                    let reach =
                        blockers.and_then(|b| b.intersect(o, dir, f32::INFINITY).map(|h| h.t));
                    let exit = Exit {
                        position: pw,
                        direction: dir,
                        transmittance: Vec3::splat(fresnel_dielectric(cos_i, 1.0 / vertex.ior)),
                    };
                    Some((exit, inv_rot * w, e, reach))
                })
                .map(|l: Option<LitVertex>| l.map_or_else(Vec::new, |x| vec![(0, x)]))
                .collect()
        };
        stop.check()?;
        stats.lit_vertices += lit.iter().filter(|l| !l.is_empty()).count();
        stats.reflected_flux += glass
            .sweep(
                &lit,
                None,
                blockers.is_some(),
                (lo, hi),
                &mut volumes,
                &stop,
            )?
            .0;
        check_volume_count(volumes.len(), sources)?;
    }
    stats.volumes = volumes.len();
    stats.reflection_volumes = volumes.len();
    Ok((volumes, stats))
}

/// Distance along o + t·d to where it leaves the box (0 when it never is inside).
fn box_exit(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let inv = d.recip();
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let tmax = t0.max(t1).min_element();
    let tmin = t0.min(t1).max_element().max(0.0);
    if tmax >= tmin && tmax.is_finite() {
        tmax
    } else {
        0.0
    }
}

/// The image-space rectangle (pixels, inclusive-exclusive) a volume can cover: the bounds of
/// its six corners (exits and far ends) projected. Where corners lie behind the eye, the
/// volume (the convex hull of its corners) is cut by a plane just in front of it: the corners
/// in front and the points where the edges between one in front and one behind cross that
/// plane (as the GPU pass does). `None` when it lies off the image or wholly behind the eye.
pub fn screen_bounds(cam: &crate::scene::Camera, v: &Volume) -> Option<[u32; 4]> {
    const NEAR: f32 = 1e-4;
    let (w, h) = (cam.width as f32, cam.height as f32);
    let (_, _, forward) = cam.basis();
    let mut corners = [Vec3::ZERO; 6];
    for i in 0..3 {
        corners[i] = v.exits[i];
        corners[i + 3] = v.exits[i] + v.dirs[i] * v.length;
    }
    let depth = corners.map(|p| (p - cam.eye).dot(forward));
    let mut lo = glam::Vec2::splat(f32::INFINITY);
    let mut hi = glam::Vec2::splat(f32::NEG_INFINITY);
    let mut add = |p: Vec3| {
        if let Some((x, y, _)) = cam.project(p) {
            lo = lo.min(glam::Vec2::new(x, y));
            hi = hi.max(glam::Vec2::new(x, y));
        }
    };
    for i in 0..6 {
        if depth[i] <= NEAR {
            continue;
        }
        add(corners[i]);
        for j in 0..6 {
            if depth[j] <= NEAR {
                let f = (depth[i] - NEAR) / (depth[i] - depth[j]);
                add(corners[i].lerp(corners[j], f));
            }
        }
    }
    if lo.x > hi.x || hi.x < 0.0 || hi.y < 0.0 || lo.x > w || lo.y > h {
        return None;
    }
    Some([
        lo.x.floor().clamp(0.0, w) as u32,
        lo.y.floor().clamp(0.0, h) as u32,
        (hi.x.ceil() + 1.0).clamp(0.0, w) as u32,
        (hi.y.ceil() + 1.0).clamp(0.0, h) as u32,
    ])
}

/// The footprint of pixel (x, y) on the plane through `p` with normal `n`: where its four
/// corner rays meet the plane (None when one misses it).
pub fn footprint(
    cam: &crate::scene::Camera,
    rays: &crate::scene::world::RayGen,
    x: u32,
    y: u32,
    p: Vec3,
    n: Vec3,
) -> Option<[Vec3; 4]> {
    let mut out = [Vec3::ZERO; 4];
    for (k, (dx, dy)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
        let d = rays.dir((x + dx) as f32, (y + dy) as f32);
        let den = d.dot(n);
        if den.abs() < 1e-6 {
            return None;
        }
        let t = (p - cam.eye).dot(n) / den;
        if t <= 0.0 {
            return None;
        }
        out[k] = cam.eye + d * t;
    }
    Some(out)
}

/// The caustics layer of `world`'s camera on the CPU: one receiver point per pixel centre
/// (`accel`: the whole scene), every volume evaluated over its screen rectangle, each arrival
/// shaded with the receiver's BRDF and dropped when `blockers` (the scene without the caustic
/// objects) hides it. The CPU twin of the GPU pass (`render::transport`).
pub fn render_caustics(
    world: &World,
    accel: &Accel,
    blockers: Option<&Accel>,
    volumes: &[Volume],
) -> crate::frame::Frame {
    use rayon::prelude::*;
    let cam = &world.camera;
    let (w, h) = (cam.width, cam.height);
    let rays = cam.rays();
    // G-buffer: the receiver hit of every pixel centre.
    let gbuf: Vec<Option<crate::trace::Hit>> = (0..w * h)
        .into_par_iter()
        .map(|k| {
            let d = rays.dir((k % w) as f32 + 0.5, (k / w) as f32 + 0.5);
            let hit = accel.intersect(cam.eye, d, f32::INFINITY)?;
            let mat = accel.material(&hit);
            (!mat.is_specular() && hit.geo_normal.dot(-d) > 0.0).then_some(hit)
        })
        .collect();
    let bounds: Vec<Option<[u32; 4]>> = volumes.iter().map(|v| screen_bounds(cam, v)).collect();
    let pixels: Vec<Vec3> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut row = vec![Vec3::ZERO; w as usize];
            for (v, b) in volumes.iter().zip(&bounds) {
                let Some([x0, y0, x1, y1]) = *b else { continue };
                if y < y0 || y >= y1 {
                    continue;
                }
                for x in x0..x1 {
                    let Some(hit) = &gbuf[(y * w + x) as usize] else {
                        continue;
                    };
                    let wo = (cam.eye - hit.point).normalize();
                    let fp = footprint(cam, &rays, x, y, hit.point, hit.normal);
                    if let Some(a) = v.arrival(hit.point, hit.normal, fp.as_ref()) {
                        let wi = -a.dir;
                        if let Some(b) = blockers
                            && b.occluded(hit.spawn(wi), wi, a.distance)
                        {
                            continue;
                        }
                        let f = crate::trace::optics::brdf(accel.material(hit), hit.normal, wi, wo);
                        row[x as usize] += f * a.irradiance;
                    }
                }
            }
            row
        })
        .collect();
    crate::frame::Frame {
        width: w,
        height: h,
        pixels,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slerp_keeps_unit_length_and_ends() {
        let a = Vec3::new(1.0, 0.0, 0.0);
        let b = Vec3::new(0.0, 1.0, 0.0);
        assert!((slerp(a, b, 0.0) - a).length() < 1e-6);
        assert!((slerp(a, b, 1.0) - b).length() < 1e-6);
        let m = slerp(a, b, 0.5);
        assert!((m.length() - 1.0).abs() < 1e-6);
        assert!((m - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        // Equal angles for equal steps (a lerp would not).
        let q = slerp(a, b, 0.25);
        assert!((q.dot(a).acos() - std::f32::consts::FRAC_PI_8).abs() < 1e-5);
    }

    /// A prism of parallel rays: the irradiance is the flux density times cos, everywhere in
    /// the beam, and nothing outside it; a beam converging to half its size at the receiver is
    /// four times as bright there; a pixel footprint half inside gets half.
    /// Volumes that reach behind the eye are cut at the plane in front of it, not drawn over
    /// the whole image: the rectangle still holds every pixel of a floor they light (brute
    /// force over the image), and is smaller than the image.
    #[test]
    fn screen_bounds_of_volumes_behind_the_eye_hold_what_they_light() {
        let cam = crate::scene::Camera {
            eye: Vec3::new(0.0, 1.0, 0.0),
            target: Vec3::new(0.0, 0.0, -3.0),
            up: Vec3::Y,
            fov_y: 60.0,
            width: 64,
            height: 48,
        };
        let rays = cam.rays();
        let mut checked = 0;
        for (k, spread) in [(0, 0.05f32), (1, 0.2), (2, 0.5)] {
            // Beams from ahead of the eye, coming back down past it onto the floor and beyond.
            let e = Vec3::new(0.3 * k as f32 - 0.3, 1.5, -4.0);
            let d = Vec3::new(0.1, -0.6, 1.0).normalize();
            let v = Volume {
                exits: [
                    e,
                    e + Vec3::new(spread, 0.0, 0.0),
                    e + Vec3::new(0.0, 0.0, spread),
                ],
                dirs: [d, (d + Vec3::new(0.05, 0.0, 0.0)).normalize(), d],
                flux_density: [Vec3::ONE; 3],
                source_area: 0.5 * spread * spread,
                length: 12.0,
            };
            let behind = (0..3)
                .any(|i| (v.exits[i] + v.dirs[i] * v.length - cam.eye).dot(cam.basis().2) <= 0.0);
            assert!(behind);
            let [x0, y0, x1, y1] = screen_bounds(&cam, &v).expect("in view");
            assert!((x1 - x0) * (y1 - y0) < cam.width * cam.height, "{k}");
            for y in 0..cam.height {
                for x in 0..cam.width {
                    let dir = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
                    if dir.y >= 0.0 {
                        continue;
                    }
                    let p = cam.eye + dir * (cam.eye.y / -dir.y);
                    let fp = footprint(&cam, &rays, x, y, p, Vec3::Y);
                    if v.arrival(p, Vec3::Y, fp.as_ref()).is_some() {
                        checked += 1;
                        assert!(
                            (x0..x1).contains(&x) && (y0..y1).contains(&y),
                            "pixel ({x}, {y}) lit outside {:?}",
                            [x0, y0, x1, y1]
                        );
                    }
                }
            }
        }
        assert!(checked > 20, "{checked}");
    }

    #[test]
    fn volume_irradiance_is_the_flux_ratio() {
        let down = Vec3::NEG_Y;
        let v = Volume {
            exits: [
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
            dirs: [down; 3],
            flux_density: [Vec3::splat(2.0); 3],
            source_area: 0.5,
            length: 10.0,
        };
        let a = v.arrival(Vec3::new(0.2, 0.0, 0.2), Vec3::Y, None).unwrap();
        assert!((a.irradiance - Vec3::splat(2.0)).abs().max_element() < 1e-5);
        assert!((a.distance - 1.0).abs() < 1e-5);
        // Tilted receiver: the cross-section grows by 1/cos.
        let nt = Vec3::new(0.6, 0.8, 0.0);
        let a = v.arrival(Vec3::new(0.2, 0.0, 0.2), nt, None).unwrap();
        assert!((a.irradiance.x - 1.6).abs() < 1e-5, "{a:?}");
        assert!(v.arrival(Vec3::new(0.8, 0.0, 0.8), Vec3::Y, None).is_none());
        assert!(v.arrival(Vec3::new(0.2, 2.0, 0.2), Vec3::Y, None).is_none());
        // Lit from behind: nothing.
        assert!(
            v.arrival(Vec3::new(0.2, 0.0, 0.2), Vec3::NEG_Y, None)
                .is_none()
        );
        // Converging to half size at y = 0.
        let c = Vec3::new(1.0 / 3.0, 0.0, 1.0 / 3.0);
        let mut w = v;
        for i in 0..3 {
            let target = c + (v.exits[i] - Vec3::Y - c) * 0.5;
            w.dirs[i] = (target - v.exits[i]).normalize();
        }
        let a = w.arrival(c, Vec3::Y, None).unwrap();
        assert!((a.irradiance.x / 8.0 - 1.0).abs() < 1e-4, "{a:?}");
        // A footprint straddling the prism's edge x = 0 from z = 0.1 to 0.3: half inside.
        let fp = [
            Vec3::new(-0.1, 0.0, 0.1),
            Vec3::new(0.1, 0.0, 0.1),
            Vec3::new(0.1, 0.0, 0.3),
            Vec3::new(-0.1, 0.0, 0.3),
        ];
        let a = v
            .arrival(Vec3::new(0.0, 0.0, 0.2), Vec3::Y, Some(&fp))
            .unwrap();
        assert!((a.irradiance.x - 1.0).abs() < 1e-5, "{a:?}");
        // A footprint containing the whole converged triangle: its flux over the footprint.
        let big = [
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(-1.0, 0.0, 2.0),
        ];
        let a = w.arrival(c, Vec3::Y, Some(&big)).unwrap();
        assert!((a.irradiance.x - 2.0 * 0.5 / 9.0).abs() < 1e-5, "{a:?}");
    }
}
