//! Where the caustic light of a scene goes, from a few light paths: for each light and each
//! glass or mirror object, photons aimed at the object (as the reference aims them) are
//! followed through its specular bounces to the first other surface, and connected to the
//! camera there. It tells a frame whose caustics are black *why*: the light misses the object,
//! nothing receives the light that leaves it, or the camera sees none of the surfaces it lands
//! on. Milliseconds on a scene's shared BVH; deterministic for a seed.

use super::{Population, connect_to_camera, emit, intersect, object_sphere};
use crate::sampling::Pcg;
use crate::scene::{EnvSampler, Material, World};
use crate::trace::Accel;
use crate::trace::optics::sample_specular;

/// Photons aimed at each (light, object) pair.
pub const PROBE_PHOTONS: u32 = 2048;

/// What became of the photons one light aimed at one glass or mirror object.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Reach {
    pub light: usize,
    pub object: usize,
    /// Photons aimed at the object's bounding sphere.
    pub aimed: u32,
    /// Of those, photons whose first hit is a glass or mirror surface of the object.
    pub hit: u32,
    /// Of those, photons that then land on a surface that is not glass or mirror (after their
    /// specular bounces): the caustic's receivers.
    pub landed: u32,
    /// Of those, photons landing where the camera sees them (in the image, unoccluded, on the
    /// side the camera looks at).
    pub seen: u32,
    /// The objects they landed on, by index, most photons first.
    pub receivers: Vec<usize>,
}

/// The reach of every (light, glass or mirror object) pair of `world`.
pub fn probe(world: &World, accel: &Accel, photons: u32, seed: u64) -> Vec<Reach> {
    let env = EnvSampler::for_lights(world);
    let pixel_area = world.camera.pixel_area();
    let mut out = Vec::new();
    for (li, _) in world.lights.iter().enumerate() {
        for oi in world.objects_with(Material::is_specular) {
            let (centre, radius) = object_sphere(world, oi);
            let pop = Population {
                light: li,
                target: Some(oi as u32),
                centre,
                radius,
                count: u64::from(photons),
            };
            let mut rng = Pcg::new(seed, ((li as u64) << 32) | oi as u64);
            let mut r = Reach {
                light: li,
                object: oi,
                ..Default::default()
            };
            let mut on: Vec<(usize, u32)> = Vec::new();
            for _ in 0..photons {
                let Some((mut o, mut d, mut flux)) = emit(world, &env, &pop, &mut rng) else {
                    continue;
                };
                r.aimed += 1;
                for depth in 0..16 {
                    let Some(hit) = intersect(world, accel, o, d) else {
                        break;
                    };
                    let mat = accel.material(&hit);
                    if depth == 0 {
                        if hit.object as usize != oi || !mat.is_specular() {
                            break;
                        }
                        r.hit += 1;
                    }
                    if mat.is_specular() {
                        let Some(b) = sample_specular(&hit, d, mat, rng.f32()) else {
                            break;
                        };
                        flux *= b.weight;
                        o = hit.spawn(b.dir);
                        d = b.dir;
                        continue;
                    }
                    r.landed += 1;
                    match on.iter_mut().find(|(o, _)| *o == hit.object as usize) {
                        Some((_, n)) => *n += 1,
                        None => on.push((hit.object as usize, 1)),
                    }
                    if connect_to_camera(world, accel, &hit, mat, -d, flux, pixel_area).is_some() {
                        r.seen += 1;
                    }
                    break;
                }
            }
            on.sort_by_key(|o| std::cmp::Reverse(o.1));
            r.receivers = on.into_iter().map(|(o, _)| o).collect();
            out.push(r);
        }
    }
    out
}

/// Why no receiver the camera sees gets caustic light, one sentence for each glass or mirror
/// object (naming the cause and what to do), or nothing when some does (or the scene has no
/// glass or mirror, or no light).
pub fn black_caustics(world: &World, reach: &[Reach]) -> Vec<String> {
    if reach.is_empty() || reach.iter().any(|r| r.seen > 0) {
        return Vec::new();
    }
    let mut objects: Vec<usize> = reach.iter().map(|r| r.object).collect();
    objects.sort_unstable();
    objects.dedup();
    objects
        .into_iter()
        .map(|oi| {
            let name = &world.objects[oi].name;
            let of: Vec<&Reach> = reach.iter().filter(|r| r.object == oi).collect();
            let hit: u32 = of.iter().map(|r| r.hit).sum();
            let landed: u32 = of.iter().map(|r| r.landed).sum();
            if hit == 0 {
                format!(
                    "no light reaches `{name}` (every photon aimed at it from the scene's \
                     lights was blocked or missed it): move or turn a light towards it"
                )
            } else if landed == 0 {
                format!(
                    "no surface receives the light that passes through `{name}`: add a floor, \
                     or use \"ground\": true"
                )
            } else {
                let on: Vec<&str> = of
                    .iter()
                    .flat_map(|r| r.receivers.iter())
                    .map(|&o| world.objects[o].name.as_str())
                    .collect();
                let mut names: Vec<&str> = Vec::new();
                for n in on {
                    if !names.contains(&n) {
                        names.push(n);
                    }
                }
                format!(
                    "the camera sees none of the light that passes through `{name}` (it lands \
                     on {}): turn the camera towards where it falls, or move the light",
                    names
                        .iter()
                        .map(|n| format!("`{n}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        })
        .collect()
}
