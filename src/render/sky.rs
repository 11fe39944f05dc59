//! The environment as the direct pass lights with it, so that objects under a sky stand on
//! their shadows:
//!
//! - its **suns**: compact regions far brighter than the map's mean radiance (a sun disc, a
//!   studio lamp) are taken out of the map and lit as directional lights with shadow maps
//!   ([`super::lights`]), their irradiance the power the region carries above its surroundings;
//! - the **rest** stays SH irradiance (as before), multiplied by a visibility term: the rest is
//!   split into [`SKY_DIRECTIONS`] regions of equal power by median cut (Debevec 2005, "A
//!   Median Cut Algorithm for Light Probe Sampling"), each region's centre gets a shadow map,
//!   and a receiver point sees the fraction of the regions' power (weighted by its cosine) that
//!   its shadow maps let through (`direct.wgsl`'s `sky_visibility`).
//!
//! Reflections and the caustics methods still see the whole map; only the direct pass's
//! diffuse lighting is split. A map is analysed once and kept while the scene holds it.

use crate::scene::EnvMap;
use glam::Vec3;
use std::f32::consts::PI;
use std::sync::{Arc, Mutex, Weak};

/// A texel brighter than this many times the map's mean radiance may belong to a sun (the
/// procedural sun of `scenes/assets/sky-sun.hdr` is ~4,500 times its map's mean, the brightest
/// sky there ~1.3 times).
const SUN_RATIO: f32 = 20.0;
/// A bright region wider than this (sr) stays with the sky, whose directions shadow it: 0.05 sr
/// is a disc of 7.2° radius.
const MAX_SUN_SOLID_ANGLE: f32 = 0.05;
/// A bright region carrying less than this fraction of the map's power stays with the sky.
const MIN_SUN_POWER: f32 = 0.01;
/// At most this many suns a map (the brightest).
const MAX_SUNS: usize = 4;
/// Directions the rest of the environment is split into, a power of two: the sky's occlusion
/// under an object moves in steps of 1/64 of its light (with 16, the overlapping shadows of
/// the directions showed as rings on the floor under a mirror ring).
pub const SKY_DIRECTIONS: usize = 32;

const LUMINANCE: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// A compact bright region of a map, lit as a directional light.
#[derive(Clone, Debug, PartialEq)]
pub struct Sun {
    /// Unit direction towards it (its power-weighted centre).
    pub towards: Vec3,
    /// Irradiance on a surface facing it, W/m² per channel, per unit of the light's scale.
    pub irradiance: Vec3,
    /// The region's solid angle, sr.
    pub solid_angle: f32,
}

/// A region of the rest of the environment, as the sky visibility term weighs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyDirection {
    /// Unit direction towards the region's power-weighted centre.
    pub towards: Vec3,
    /// The region's power (luminance × solid angle, per unit scale).
    pub weight: f32,
}

/// What the direct pass takes of one map.
#[derive(Clone, Debug)]
pub struct EnvLighting {
    pub suns: Vec<Sun>,
    /// The irradiance SH (cosine-convolved) of the map without its suns, per unit scale.
    pub sh: [Vec3; 9],
    /// The rest's median-cut regions (empty when it is black).
    pub sky: Vec<SkyDirection>,
}

/// The analysis of `map`, made once while the map is alive (frames of the same scene share it).
pub fn lighting(map: &Arc<EnvMap>) -> Arc<EnvLighting> {
    static MADE: Mutex<Vec<(Weak<EnvMap>, Arc<EnvLighting>)>> = Mutex::new(Vec::new());
    let mut made = MADE.lock().unwrap_or_else(|e| e.into_inner());
    made.retain(|(m, _)| m.strong_count() > 0);
    if let Some((_, l)) = made
        .iter()
        .find(|(m, _)| std::ptr::eq(m.as_ptr(), Arc::as_ptr(map)))
    {
        return l.clone();
    }
    let l = Arc::new(analyse(map));
    made.push((Arc::downgrade(map), l.clone()));
    l
}

/// Splits `map` into its suns, the SH of the rest and the rest's directions.
pub fn analyse(map: &EnvMap) -> EnvLighting {
    let (suns, rest) = split_suns(map);
    EnvLighting {
        suns,
        sh: super::lights::sh_project(&rest),
        sky: median_cut(&rest, SKY_DIRECTIONS),
    }
}

/// Solid angle of a texel of row `y` of a `w`×`h` map: the band of half a row either side of
/// its centre v = y/(h − 1), clamped to the poles, over 1/w of the turn.
pub fn texel_solid_angle(y: usize, w: usize, h: usize) -> f32 {
    let rows = h.max(2) - 1;
    let band = |t: f32| (PI * t.clamp(0.0, rows as f32) / rows as f32).cos();
    (2.0 * PI / w as f32) * (band(y as f32 - 0.5) - band(y as f32 + 0.5))
}

/// The direction towards texel (x, y)'s centre.
fn texel_direction(x: usize, y: usize, w: usize, h: usize) -> Vec3 {
    EnvMap::direction(
        (x as f32 + 0.5) / w as f32,
        y as f32 / (h.max(2) - 1) as f32,
    )
}

/// The map's suns, and the map without them: each sun's texels take the mean of the texels
/// around the region, and the sun the light above that.
fn split_suns(map: &EnvMap) -> (Vec<Sun>, EnvMap) {
    let (w, h) = (map.width as usize, map.height as usize);
    let mut rest = map.clone();
    if w == 0 || h == 0 {
        return (Vec::new(), rest);
    }
    let omega: Vec<f32> = (0..h).map(|y| texel_solid_angle(y, w, h)).collect();
    let lum = |i: usize| map.texels[i].dot(LUMINANCE).max(0.0);
    let power: f64 = (0..w * h).map(|i| f64::from(lum(i) * omega[i / w])).sum();
    if !(power > 0.0 && power.is_finite()) {
        return (Vec::new(), rest);
    }
    let threshold = SUN_RATIO * (power / (4.0 * std::f64::consts::PI)) as f32;
    let bright: Vec<bool> = (0..w * h).map(|i| lum(i) > threshold).collect();
    // Connected regions of bright texels (8-neighbours, wrapping around in u).
    let neighbours = |i: usize| {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        (-1..=1i64)
            .flat_map(move |dy| (-1..=1i64).map(move |dx| (dx, dy)))
            .filter(|&d| d != (0, 0))
            .filter_map(move |(dx, dy)| {
                let yy = y + dy;
                (0..h as i64)
                    .contains(&yy)
                    .then(|| yy as usize * w + (x + dx).rem_euclid(w as i64) as usize)
            })
    };
    let mut region = vec![usize::MAX; w * h];
    let mut regions: Vec<Vec<usize>> = Vec::new();
    for start in 0..w * h {
        if !bright[start] || region[start] != usize::MAX {
            continue;
        }
        let id = regions.len();
        let mut texels = vec![start];
        region[start] = id;
        let mut next = 0;
        while next < texels.len() {
            let i = texels[next];
            next += 1;
            for j in neighbours(i) {
                if bright[j] && region[j] == usize::MAX {
                    region[j] = id;
                    texels.push(j);
                }
            }
        }
        regions.push(texels);
    }
    let mut suns: Vec<(f64, Sun, Vec<usize>, Vec3)> = Vec::new();
    for texels in regions {
        let solid_angle: f32 = texels.iter().map(|&i| omega[i / w]).sum();
        if solid_angle > MAX_SUN_SOLID_ANGLE {
            continue;
        }
        // The surroundings: texels next to the region that are not bright.
        let mut ring = std::collections::HashSet::new();
        for &i in &texels {
            ring.extend(neighbours(i).filter(|&j| !bright[j]));
        }
        let background = if ring.is_empty() {
            Vec3::ZERO
        } else {
            ring.iter().map(|&j| map.texels[j]).sum::<Vec3>() / ring.len() as f32
        };
        let mut irradiance = Vec3::ZERO;
        let mut centre = Vec3::ZERO;
        for &i in &texels {
            let above = (map.texels[i] - background).max(Vec3::ZERO) * omega[i / w];
            irradiance += above;
            centre += texel_direction(i % w, i / w, w, h) * above.dot(LUMINANCE);
        }
        let p = f64::from(irradiance.dot(LUMINANCE));
        if p < f64::from(MIN_SUN_POWER) * power || centre.length_squared() == 0.0 {
            continue;
        }
        suns.push((
            p,
            Sun {
                towards: centre.normalize(),
                irradiance,
                solid_angle,
            },
            texels,
            background,
        ));
    }
    suns.sort_by(|a, b| b.0.total_cmp(&a.0));
    suns.truncate(MAX_SUNS);
    for (_, _, texels, background) in &suns {
        for &i in texels {
            rest.texels[i] = map.texels[i].min(*background);
        }
    }
    (suns.into_iter().map(|(_, s, _, _)| s).collect(), rest)
}

/// `n` (a power of two) regions of equal power by median cut, each as its power-weighted
/// centre direction and its power; regions without power are left out.
fn median_cut(map: &EnvMap, n: usize) -> Vec<SkyDirection> {
    let (w, h) = (map.width as usize, map.height as usize);
    if w == 0 || h == 0 {
        return Vec::new();
    }
    let energy: Vec<f64> = (0..w * h)
        .map(|i| f64::from(map.texels[i].dot(LUMINANCE).max(0.0) * texel_solid_angle(i / w, w, h)))
        .collect();
    // Summed-area table, (h + 1) × (w + 1).
    let mut sat = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += energy[y * w + x];
            sat[(y + 1) * (w + 1) + x + 1] = sat[y * (w + 1) + x + 1] + row;
        }
    }
    let sum = |x0: usize, x1: usize, y0: usize, y1: usize| {
        sat[y1 * (w + 1) + x1] - sat[y0 * (w + 1) + x1] - sat[y1 * (w + 1) + x0]
            + sat[y0 * (w + 1) + x0]
    };
    let rows = (h.max(2) - 1) as f32;
    let mut boxes = vec![(0, w, 0, h)];
    while boxes.len() < n {
        let before = boxes.len();
        let mut next = Vec::with_capacity(before * 2);
        for (x0, x1, y0, y1) in boxes {
            // Cut across the longer side, measured as an angle on the sphere.
            let mid_sin = (PI * (y0 + y1) as f32 * 0.5 / rows).sin().max(1e-3);
            let across_u = (x1 - x0) as f32 * 2.0 * PI / w as f32 * mid_sin;
            let across_v = (y1 - y0) as f32 * PI / rows;
            let half = 0.5 * sum(x0, x1, y0, y1);
            if x1 - x0 > 1 && (across_u >= across_v || y1 - y0 < 2) {
                let x = (x0 + 1..x1)
                    .find(|&x| sum(x0, x, y0, y1) >= half)
                    .unwrap_or(x1 - 1);
                next.extend([(x0, x, y0, y1), (x, x1, y0, y1)]);
            } else if y1 - y0 > 1 {
                let y = (y0 + 1..y1)
                    .find(|&y| sum(x0, x1, y0, y) >= half)
                    .unwrap_or(y1 - 1);
                next.extend([(x0, x1, y0, y), (x0, x1, y, y1)]);
            } else {
                next.push((x0, x1, y0, y1));
            }
        }
        boxes = next;
        if boxes.len() == before {
            break; // every box is one texel
        }
    }
    boxes
        .into_iter()
        .filter_map(|(x0, x1, y0, y1)| {
            let mut centre = glam::DVec3::ZERO;
            let mut weight = 0.0f64;
            for y in y0..y1 {
                for x in x0..x1 {
                    let e = energy[y * w + x];
                    centre += texel_direction(x, y, w, h).as_dvec3() * e;
                    weight += e;
                }
            }
            (weight > 0.0 && centre.length_squared() > 0.0).then(|| SkyDirection {
                towards: centre.normalize().as_vec3(),
                weight: weight as f32,
            })
        })
        .collect()
}

/// `n` directions spread evenly over the sphere (a Fibonacci lattice), of equal weight: the
/// regions of a constant environment.
pub fn uniform_directions(n: usize) -> Vec<SkyDirection> {
    let golden = PI * (3.0 - 5f32.sqrt());
    (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden * i as f32;
            SkyDirection {
                towards: Vec3::new(r * phi.cos(), y, r * phi.sin()),
                weight: 1.0,
            }
        })
        .collect()
}
