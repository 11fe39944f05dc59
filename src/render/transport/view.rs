//! Refracting viewing rays through the tables (Iwasaki et al. 2005 §5.3): what the camera sees through a
//! glass object, per table vertex, for the renderer to interpolate across its triangles.

use super::volumes::{EvalError, Source, Use, Volume, lookup_with};
use crate::bake::transport::{TransportTable, table_vertices};
use crate::scene::{Light, World};
use crate::trace::Accel;
use glam::Vec3;

/// What a viewer sees through the object (§5.3), per table vertex: the viewing direction from
/// the eye to the vertex is looked up in the vertex's table like a light direction (every
/// sample counts, trapped ones with their last hit), and the refracted viewing ray that leaves
/// the object is followed into the rest of the scene (`blockers`, the scene without the
/// caustic objects). The radiance it finds there, times the table's transmittance, is the
/// vertex's value (rgb, w = 1; w = 0 where the vertex faces away from the eye): at a receiver,
/// direct light from `sources` (shadowed by everything in `scene`, glass included, as the
/// direct pass does), the caustic light of `volumes` arriving there, and the constant part of
/// the environment's light (diffuse lobe, unshadowed, as the direct pass); where the ray leaves
/// the scene, the environment in its direction. The renderer interpolates the vertex values
/// across the object's triangles, as the paper maps the sliced object images with texture
/// coordinates at the vertices. Stops with [`EvalError::Canceled`] soon after `keep_going`
/// returns false.
#[allow(clippy::too_many_arguments)]
pub fn view_refraction(
    world: &World,
    object_name: &str,
    table: &TransportTable,
    eye: Vec3,
    sources: &[Source],
    volumes: &[Volume],
    blockers: &Accel,
    scene: &Accel,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Vec<[f32; 4]>, EvalError> {
    use rayon::prelude::*;
    let object = world
        .object(object_name)
        .ok_or_else(|| EvalError::UnknownObject(object_name.to_string()))?;
    let vertices = table_vertices(world, object);
    if vertices.len() != table.vertex_count as usize {
        return Err(EvalError::Mismatch {
            object: object_name.to_string(),
            table: table.source_hash,
            object_hash: crate::bake::transport::source_hash(world, object, &table.params),
        });
    }
    let m = object.rigid_transform();
    let (_, rot, _) = object.transform.to_scale_rotation_translation();
    let inv_rot = rot.inverse();
    let (lo, hi) = world.bounds();
    let scale = lo.abs().max(hi.abs()).max_element().max(1.0);
    let eps = 1e-4 * scale;
    let (env_const, env_maps): (Vec3, Vec<(&crate::scene::EnvMap, Vec3)>) = {
        let mut c = Vec3::ZERO;
        let mut maps = Vec::new();
        for l in &world.lights {
            if let Light::Environment { map, radiance } = l {
                match map {
                    Some(mp) => maps.push((mp.as_ref(), *radiance)),
                    None => c += *radiance,
                }
            }
        }
        (c, maps)
    };
    let env = |d: Vec3| {
        env_const
            + env_maps
                .iter()
                .map(|(mp, s)| mp.lookup(d) * *s)
                .sum::<Vec3>()
    };
    // Where each viewing ray goes.
    enum Seen {
        Nothing,
        Sky(Vec3, Vec3),
        Receiver(crate::trace::Hit, Vec3, Vec3),
    }
    let seen: Vec<Seen> = (0..vertices.len())
        .into_par_iter()
        .map(|i| {
            let v = &vertices[i];
            let pw = m.transform_point3(v.position);
            let w = (pw - eye).normalize_or_zero();
            if w.dot(rot * v.normal) >= 0.0 {
                return Seen::Nothing;
            }
            let Some(e) = lookup_with(table, i, v, inv_rot * w, Use::View) else {
                return Seen::Nothing;
            };
            let (o, d) = (
                m.transform_point3(e.position),
                (rot * e.direction).normalize(),
            );
            match blockers.intersect(o + d * eps, d, f32::INFINITY) {
                Some(h) if !blockers.material(&h).is_specular() && h.geo_normal.dot(d) < 0.0 => {
                    Seen::Receiver(h, d, e.transmittance)
                }
                Some(_) => Seen::Nothing,
                None => Seen::Sky(d, e.transmittance),
            }
        })
        .collect();
    // Caustic irradiance at the receiver points: the points in a uniform grid, each volume
    // tested against the points of the cells its bounding box covers.
    let pts: Vec<(usize, Vec3, Vec3)> = seen
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s {
            Seen::Receiver(h, _, _) => Some((i, h.point, h.normal)),
            _ => None,
        })
        .collect();
    let mut caustic = vec![Vec3::ZERO; vertices.len()];
    if !pts.is_empty() && !volumes.is_empty() {
        let (mut plo, mut phi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (_, p, _) in &pts {
            plo = plo.min(*p);
            phi = phi.max(*p);
        }
        // Receivers are surfaces: cells sized for about one point each over the two longest
        // extents (a cube root of the count per axis would put a flat floor's points into a
        // few thick cells, and a long beam's bounds would test most of them).
        let ext = (phi - plo).max(Vec3::splat(1e-6));
        let thin = ext.min_position();
        let mut e = ext.to_array();
        e.sort_by(f32::total_cmp);
        let side = (e[1] * e[2] / pts.len() as f32).sqrt().max(1e-6);
        let flat = e[0] <= 1e-3 * e[1];
        let res = (ext / side)
            .ceil()
            .clamp(Vec3::ONE, Vec3::splat(256.0))
            .as_uvec3();
        let resf = res.as_vec3();
        let cell_of = |p: Vec3| {
            let c = ((p - plo) / ext * resf).floor();
            c.clamp(Vec3::ZERO, resf - Vec3::ONE).as_uvec3()
        };
        let (rx, ry) = (res.x as usize, res.y as usize);
        let idx = |c: glam::UVec3| (c.z as usize * ry + c.y as usize) * rx + c.x as usize;
        let mut start = vec![0usize; rx * ry * res.z as usize + 1];
        for (_, p, _) in &pts {
            start[idx(cell_of(*p)) + 1] += 1;
        }
        for k in 1..start.len() {
            start[k] += start[k - 1];
        }
        let mut fill = start.clone();
        let mut order = vec![0usize; pts.len()];
        for (k, (_, p, _)) in pts.iter().enumerate() {
            let c = idx(cell_of(*p));
            order[fill[c]] = k;
            fill[c] += 1;
        }
        let stop = std::sync::atomic::AtomicBool::new(false);
        let acc = volumes
            .par_iter()
            .enumerate()
            .fold(
                || vec![Vec3::ZERO; pts.len()],
                |mut acc, (k, vol)| {
                    use std::sync::atomic::Ordering::Relaxed;
                    if stop.load(Relaxed) || (k % 1024 == 0 && !keep_going()) {
                        stop.store(true, Relaxed);
                        return acc;
                    }
                    // Bounds of the volume's rays over the points. When the points lie in a
                    // plane (a floor), their receivers' tangent plane is that plane and the
                    // cross-sections are where the rays cross it: a long beam over a floor
                    // covers its landing, not all the cells below its path. Otherwise, its
                    // exits and far ends.
                    let (mut vlo, mut vhi) =
                        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                    for k in 0..3 {
                        let (e, d) = (vol.exits[k], vol.dirs[k]);
                        let (ea, da) = (e[thin], d[thin]);
                        let (t0, t1) = if !flat {
                            (0.0, vol.length)
                        } else if da.abs() < 1e-6 {
                            if ea < plo[thin] || ea > phi[thin] {
                                continue;
                            }
                            (0.0, vol.length)
                        } else {
                            let (a, b) = ((plo[thin] - ea) / da, (phi[thin] - ea) / da);
                            (a.min(b).max(0.0), a.max(b).min(vol.length))
                        };
                        if t0 > t1 {
                            continue;
                        }
                        for q in [e + d * t0, e + d * t1] {
                            vlo = vlo.min(q);
                            vhi = vhi.max(q);
                        }
                    }
                    if vhi.cmplt(plo).any() || vlo.cmpgt(phi).any() {
                        return acc;
                    }
                    let (c0, c1) = (cell_of(vlo), cell_of(vhi));
                    for z in c0.z..=c1.z {
                        for y in c0.y..=c1.y {
                            for x in c0.x..=c1.x {
                                let c = idx(glam::UVec3::new(x, y, z));
                                for &k in &order[start[c]..start[c + 1]] {
                                    let (vi, p, n) = pts[k];
                                    let Some(a) = vol.arrival(p, n, None) else {
                                        continue;
                                    };
                                    let Seen::Receiver(h, d, _) = &seen[vi] else {
                                        continue;
                                    };
                                    let wi = -a.dir;
                                    if blockers.occluded(h.spawn(wi), wi, a.distance) {
                                        continue;
                                    }
                                    let f = crate::trace::optics::brdf(
                                        blockers.material(h),
                                        n,
                                        wi,
                                        -*d,
                                    );
                                    acc[k] += f * a.irradiance;
                                }
                            }
                        }
                    }
                    acc
                },
            )
            .reduce(
                || vec![Vec3::ZERO; pts.len()],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(b) {
                        *x += y;
                    }
                    a
                },
            );
        if stop.into_inner() {
            return Err(EvalError::Canceled);
        }
        for (k, (vi, _, _)) in pts.iter().enumerate() {
            caustic[*vi] = acc[k];
        }
    }
    Ok(seen
        .par_iter()
        .enumerate()
        .map(|(i, s)| match s {
            Seen::Nothing => [0.0; 4],
            Seen::Sky(d, t) => (env(*d) * *t).extend(1.0).to_array(),
            Seen::Receiver(h, d, t) => {
                let mat = blockers.material(h);
                let wo = -*d;
                let mut l = caustic[i];
                for src in sources {
                    let (to, dist) = src.towards(h.point);
                    let Some((_, e)) = src.at(h.point) else {
                        continue;
                    };
                    let f = crate::trace::optics::brdf(mat, h.normal, to, wo);
                    if f == Vec3::ZERO || scene.occluded(h.spawn(to), to, dist) {
                        continue;
                    }
                    l += f * e * h.normal.dot(to).max(0.0);
                }
                if let crate::scene::Material::Diffuse { albedo }
                | crate::scene::Material::Glossy { albedo, .. } = mat
                {
                    l += *albedo * env_const;
                }
                (l * *t).extend(1.0).to_array()
            }
        })
        .collect())
}
