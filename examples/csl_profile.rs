//! Where a static CSL set puts the light of the glass sphere on the floor, against the bake's own
//! rays: for one direction of the glass sweep (`reference::sweep`, seed 56), the rays leaving
//! the sphere are traced to the floor and summed in rings around the caustic's centre (the
//! point under the sphere's centre along the light), and the CSLs' irradiance is integrated
//! over the same rings (256 azimuths × 8 radii a ring). Prints each CSL and, per ring, the flux
//! of the rays, of the CSLs and the ratio, with the four CSLs that give the ring the most. No
//! noise and no camera: what differs is the CSL model's and the bake's. From the repository
//! root:
//!
//!     cargo run --release --example csl_profile -- [DIRECTION] [GRID]
//!
//! (defaults: direction 15, 87.1° above the horizon, and the paper's 1280² grid).

use caustica::bake::csl::{CslParams, bake_accel, bake_csl, rigid_frame_world, trace};
use caustica::reference::sweep;
use glam::Vec3;

/// Rings of this width (m), this many.
const WIDTH: f32 = 0.01;
const RINGS: usize = 60;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let index: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(15);
    let grid: u32 = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(1280);
    let base = caustica::scene::load_scene_file(
        "scenes/glass-sphere-directional.json".as_ref(),
        &Default::default(),
    )?;
    let case = sweep::directions(index + 1, 56)[index];
    let light = case.direction.normalize();
    let world = sweep::lit_from(&base, "glass", light, 128);
    let oi = world.object_index("glass").ok_or("no glass object")?;
    let params = CslParams {
        grid,
        ..CslParams::paper()
    };
    let object = &world.objects[oi];
    let local_light = object.to_rigid_frame(light);
    let set = bake_csl(&world, "glass", local_light, &params, &|_| true)?;
    let place = object.rigid_transform();
    let csls = set.to_world(place);

    // The bake's rays, traced again in the object's rigid frame as the bake traces them.
    let accel = bake_accel(&rigid_frame_world(&world, object));
    let (u, v) = local_light.any_orthonormal_pair();
    let ray_grid = trace::RayGrid {
        light: local_light,
        u,
        v,
        centre: set.centre,
        radius: set.radius,
        n: grid,
    };
    let (rays, _) = trace::trace_grid(&accel, &ray_grid, &params, &|_| true).ok_or("canceled")?;
    let area = (ray_grid.spacing() as f64).powi(2);
    let centre = place.transform_point3(set.centre);
    let hit = centre + light * (centre.y / -light.y);
    let mut from_rays = vec![0f64; RINGS];
    for r in &rays {
        let o = place.transform_point3(r.origin);
        let d = place.transform_vector3(r.dir);
        if d.y >= 0.0 {
            continue;
        }
        let k = ((o + d * (o.y / -d.y) - hit).length() / WIDTH) as usize;
        if k < RINGS {
            from_rays[k] += r.weight() as f64 * area;
        }
    }

    let (azimuths, radii) = (256, 8);
    let mut from_csls = vec![vec![0f64; csls.len()]; RINGS];
    for (k, ring) in from_csls.iter_mut().enumerate() {
        for j in 0..radii {
            let rho = (k as f32 + (j as f32 + 0.5) / radii as f32) * WIDTH;
            let element = std::f32::consts::TAU * rho * WIDTH / (azimuths * radii) as f32;
            for a in 0..azimuths {
                let phi = (a as f32 + 0.5) / azimuths as f32 * std::f32::consts::TAU;
                let p = hit + Vec3::new(rho * phi.cos(), 0.0, rho * phi.sin());
                for (c, csl) in csls.iter().enumerate() {
                    let e = csl.irradiance(p, Vec3::Y).element_sum() / 3.0;
                    ring[c] += (e * element) as f64;
                }
            }
        }
    }

    println!(
        "direction {index}: {:.1}° above the horizon, {} CSLs, {} rays",
        case.elevation_deg,
        csls.len(),
        rays.len()
    );
    for (c, csl) in csls.iter().enumerate() {
        println!(
            "csl {c}: flux {:.4}, axis {:.2}° from the light, light plane {:.3} m above the floor, \
             kappa {:.3} gamma {:.3}, half extent {:.3} m",
            csl.flux,
            csl.axis.angle_between(light).to_degrees(),
            csl.origin.y,
            csl.kappa,
            csl.gamma,
            csl.half_extent
        );
    }
    for (k, ring) in from_csls.iter().enumerate() {
        let total: f64 = ring.iter().sum();
        let mut most: Vec<(usize, f64)> = ring.iter().copied().enumerate().collect();
        most.sort_by(|a, b| b.1.total_cmp(&a.1));
        let most: Vec<String> = most
            .iter()
            .take(4)
            .filter(|m| m.1 > 0.0)
            .map(|(c, e)| format!("{c}: {e:.2e}"))
            .collect();
        println!(
            "{:.2}–{:.2} m: rays {:.3e}, CSLs {:.3e}, ratio {:.2} ({})",
            k as f32 * WIDTH,
            (k + 1) as f32 * WIDTH,
            from_rays[k],
            total,
            total / from_rays[k].max(1e-30),
            most.join(", ")
        );
    }
    Ok(())
}
