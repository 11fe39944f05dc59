//! The opt-in ground plane (`"ground": true` in a scene or a render request, `--ground` in the
//! CLI): a diffuse floor under a scene's objects, so that a glass or mirror object uploaded on
//! its own (a lone GLB) has a surface to cast its shadow and caustic on.

use super::world::{Material, Object, Part, World};
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// The ground's albedo (the canonical scenes' floors).
pub const GROUND_ALBEDO: f32 = 0.6;
/// The ground's side, in bounding-sphere radii of the objects: wide enough for the shadow and
/// caustic of a light 15° above the horizon (about 3.7 object heights long) on every side.
const SIDE_RADII: f32 = 16.0;

/// Adds a square diffuse plane (albedo [`GROUND_ALBEDO`], named `ground`, or `ground-2`… when
/// that name is taken) under the objects' bounds, touching their lowest point, centred under
/// them. A world without objects, or with the plane already (the scene's `ground` and the
/// request's both), is left as it is.
pub fn add_ground(world: &mut World) {
    if world.objects.is_empty() || world.has_ground {
        return;
    }
    world.has_ground = true;
    let (lo, hi) = world.bounds();
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let side = SIDE_RADII * radius;
    let centre = Vec3::new((lo.x + hi.x) * 0.5, lo.y, (lo.z + hi.z) * 0.5);
    let mut name = "ground".to_string();
    let mut k = 1;
    while world.objects.iter().any(|o| o.name == name) {
        k += 1;
        name = format!("ground-{k}");
    }
    world.materials.push(Material::Diffuse {
        albedo: Vec3::splat(GROUND_ALBEDO),
    });
    world.objects.push(Object {
        name,
        parts: vec![Part {
            mesh: Arc::new(super::shapes::plane(side, side)),
            material: (world.materials.len() - 1) as u32,
        }],
        transform: Mat4::from_translation(centre),
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ground_lies_under_the_objects_and_takes_a_free_name() {
        let mut w = crate::scene::load_scene_json(
            br#"{"camera": {"eye": [0, 2, 2], "target": [0, 0, 0]},
                 "materials": {"g": {"type": "dielectric", "ior": 1.5}},
                 "objects": [{"name": "ground", "shape": {"type": "sphere", "radius": 0.5},
                              "material": "g", "transform": {"translation": [1, 2, 0]}}]}"#,
        )
        .unwrap();
        add_ground(&mut w);
        let g = w.objects.last().unwrap();
        assert_eq!(g.name, "ground-2");
        let (lo, hi) = crate::scene::world::objects_extent(&w.objects[1..]);
        // Touching the sphere's lowest point, centred under it, 16 radii wide.
        assert!(
            (lo.y - 1.5).abs() < 1e-3 && (hi.y - 1.5).abs() < 1e-3,
            "{lo} {hi}"
        );
        assert!(((lo.x + hi.x) * 0.5 - 1.0).abs() < 1e-3);
        assert!(
            (hi.x - lo.x - 16.0 * 0.5 * 3f32.sqrt()).abs() < 0.1,
            "{lo} {hi}"
        );
        assert!(matches!(
            w.materials[g.parts[0].material as usize],
            Material::Diffuse { .. }
        ));
        // Asked again (a scene's `ground` and a request's): still one plane.
        add_ground(&mut w);
        assert_eq!(w.objects.len(), 2);
    }
}
