//! A table's fit: how well the caustic it predicts matches photons traced through the object.
//!
//! For each of [`DIRECTIONS`] (directional light, the object's rigid frame), the table's
//! illumination volumes (`render::transport::volumes`, the render's own construction, with its
//! splitting of triangles whose corners leave on different paths) are evaluated over the cells of
//! a plane across the light, two radii past the object's centre, each cell averaged exactly over
//! its area; photons from a regular grid across the light are traced through the object by the
//! bake's own rules ([`super::trace_sample`]: Fresnel, total internal reflection, absorption)
//! and binned on the same cells. The fit error is the relative L1 of the two after a 3 × 3
//! blur, Σ|model − photons| / Σ photons, the worst over the directions: 0 is a perfect fit, and
//! light the volumes leave out counts. Only the transmitted light is compared: the reflected
//! light needs no table.

use super::{TransportTable, smooth_patches, table::Fit, trace_sample};
use crate::bake::BakeError;
use crate::bake::plane::{FitPlane, relative_l1};
use crate::cancel::{Canceled, KeepGoing, Stop};
use crate::render::transport::volumes::{EvalError, Source, build_volumes};
use crate::scene::{Material, World};
use crate::trace::Accel;
use glam::Vec3;
use rayon::prelude::*;

/// Light directions (travel, the object's rigid frame) a bake checks its table for: straight
/// down and two slanting ones.
pub const DIRECTIONS: [Vec3; 3] = [
    Vec3::new(0.0, -1.0, 0.0),
    Vec3::new(0.6, -0.8, 0.0),
    Vec3::new(-0.3, -0.8, 0.52),
];

/// Photon rays per side of the grid across the light.
pub const GRID: usize = 256;

/// Cells per side of the plane the caustics are compared on, which spans six radii.
pub const CELLS: usize = 32;

/// The fit of `table`, baked for object `object_name` of `world` ([`TransportTable::fit`]);
/// `None` when the object is missing, or when no photon leaves it (nothing to compare).
pub fn verify(world: &World, object_name: &str, table: &TransportTable) -> Option<Fit> {
    verify_with(world, object_name, table, &|| true).expect("never asked to stop")
}

/// [`verify`] that asks `keep_going` as it goes: right before and after the BVH build, before
/// each direction, within the volumes' construction, per chunk of 64 volumes as they are laid
/// on the plane and per row of the photon grid; Err(Canceled) once it says stop.
pub fn verify_with(
    world: &World,
    object_name: &str,
    table: &TransportTable,
    keep_going: KeepGoing,
) -> Result<Option<Fit>, BakeError> {
    let stop = Stop::new(keep_going);
    let Some(object) = world.object(object_name) else {
        return Ok(None);
    };
    let mut local = crate::bake::csl::rigid_frame_world(world, object);
    stop.check()?;
    let accel = crate::bake::csl::bake_accel(&local);
    stop.check()?;
    let patches = smooth_patches(&local.objects[0]);
    let (lo, hi) = local.bounds();
    // The volumes reach as far as the scene's bounds: a far triangle (never traced) takes
    // them past the plane.
    let far = 10.0 * ((hi - lo).length() + lo.abs().max(hi.abs()).max_element()).max(1e-3);
    local.objects.push(crate::scene::Object {
        name: format!("{}#verify", object.name),
        parts: vec![crate::scene::Part {
            mesh: std::sync::Arc::new(crate::scene::Mesh {
                positions: vec![
                    Vec3::splat(-far),
                    Vec3::new(far, -far, far),
                    Vec3::splat(far),
                ],
                normals: vec![Vec3::Y; 3],
                indices: vec![[0, 1, 2]],
            }),
            material: local.objects[0].parts[0].material,
        }],
        transform: glam::Mat4::IDENTITY,
    });
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo) * 0.5).length().max(1e-6);
    let mut worst: Option<Fit> = None;
    for dir in DIRECTIONS {
        stop.check()?;
        let light = dir.normalize();
        let Some(fit) = verify_direction(
            &local, table, &accel, &patches, light, centre, radius, &stop,
        )?
        else {
            continue;
        };
        worst = Some(match worst {
            None => fit,
            Some(w) => Fit {
                error: w.error.max(fit.error),
                split_loss: w.split_loss.max(fit.split_loss),
            },
        });
    }
    Ok(worst)
}

/// The fit for one light direction; Err(Canceled) once `stop` says so.
#[allow(clippy::too_many_arguments)]
fn verify_direction(
    local: &World,
    table: &TransportTable,
    accel: &Accel,
    patches: &[u32],
    light: Vec3,
    centre: Vec3,
    radius: f32,
    stop: &Stop,
) -> Result<Option<Fit>, Canceled> {
    let name = &local.objects[0].name;
    let source = Source::Directional {
        direction: light,
        irradiance: Vec3::ONE,
    };
    let (volumes, stats) = match build_volumes(local, name, table, &[source], None, &|| stop.go()) {
        Ok(v) => v,
        Err(EvalError::Canceled) => return Err(Canceled),
        Err(_) => return Ok(None),
    };
    stop.check()?;
    let plane = FitPlane::new(light, centre, radius, CELLS);
    let m = CELLS;
    let at = |i: f32, j: f32| plane.at(i, j);
    // The model: every volume over the cells its cross-section covers (the far triangle of
    // `verify` takes them past the plane).
    let n = -light;
    // Fixed chunks summed in order: the same figures on any number of threads (the fit is
    // part of the table's bytes).
    let model = sum_in_order(
        volumes.par_chunks(64).map(|chunk| {
            let mut acc = vec![0f64; m * m];
            if !stop.go() {
                return acc;
            }
            for vol in chunk {
                let Some(q) = vol.cross_section(plane.p0.as_dvec3(), n.as_dvec3()) else {
                    continue;
                };
                let (mut a0, mut a1) = (f32::INFINITY, f32::NEG_INFINITY);
                let (mut b0, mut b1) = (f32::INFINITY, f32::NEG_INFINITY);
                for p in q {
                    let (a, b) = plane.coords(p.as_vec3());
                    (a0, a1, b0, b1) = (a0.min(a), a1.max(a), b0.min(b), b1.max(b));
                }
                let clamp = |x: f32| x.clamp(0.0, m as f32) as usize;
                for j in clamp(b0.floor())..clamp(b1.floor() + 1.0) {
                    for i in clamp(a0.floor())..clamp(a1.floor() + 1.0) {
                        let (fi, fj) = (i as f32, j as f32);
                        let fp = [
                            at(fi, fj),
                            at(fi + 1.0, fj),
                            at(fi + 1.0, fj + 1.0),
                            at(fi, fj + 1.0),
                        ];
                        if let Some(a) = vol.arrival(at(fi + 0.5, fj + 0.5), n, Some(&fp)) {
                            acc[j * m + i] += f64::from(a.irradiance.element_sum()) / 3.0;
                        }
                    }
                }
            }
            acc
        }),
        m,
    );
    stop.checked()?;
    // The photons: a grid across the light over the object's bounding sphere, each carrying
    // the flux of its spacing², traced in by the bake's rules.
    let g = GRID;
    let spacing = 2.0 * radius / g as f32;
    let start = centre - light * (2.0 * radius);
    let photons = sum_in_order(
        (0..g).into_par_iter().map(|row| {
            let mut acc = vec![0f64; m * m];
            if !stop.go() {
                return acc;
            }
            for col in 0..g {
                let (i, j) = (col as f32 + 0.5, row as f32 + 0.5);
                let o =
                    start + plane.u * (-radius + i * spacing) + plane.v * (-radius + j * spacing);
                let Some(hit) = accel.intersect(o, light, f32::INFINITY) else {
                    continue;
                };
                let Material::Dielectric { ior, absorption } = *accel.material(&hit) else {
                    continue;
                };
                if !hit.front_face {
                    continue;
                }
                let mut rays = 0;
                let s = trace_sample(
                    accel,
                    patches,
                    hit.point,
                    hit.normal,
                    light,
                    ior,
                    table.params.max_depth,
                    &mut rays,
                );
                if s.trapped || s.transmittance <= 0.0 {
                    continue;
                }
                if let Some(k) = plane.cell_of(s.position, s.direction) {
                    let beer = (-absorption * s.path_length).exp().element_sum() / 3.0;
                    acc[k] += f64::from(s.transmittance * beer * spacing * spacing);
                }
            }
            acc
        }),
        m,
    );
    stop.checked()?;
    let area = plane.cell_area();
    let photons: Vec<f64> = photons.iter().map(|e| e / area).collect();
    let Some(error) = relative_l1(&model, &photons, m) else {
        return Ok(None);
    };
    let entering = (stats.flux + stats.split_flux).element_sum();
    Ok(Some(Fit {
        error: error as f32,
        split_loss: if entering > 0.0 {
            stats.split_flux.element_sum() / entering
        } else {
            0.0
        },
    }))
}

/// The images of `parts` added in their order (deterministic whatever the threads).
fn sum_in_order(parts: impl IndexedParallelIterator<Item = Vec<f64>>, m: usize) -> Vec<f64> {
    let parts: Vec<Vec<f64>> = parts.collect();
    let mut out = vec![0f64; m * m];
    for p in parts {
        out.iter_mut().zip(p).for_each(|(x, y)| *x += y);
    }
    out
}
