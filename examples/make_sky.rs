//! Writes the procedural skies of `scenes/assets/`: `sky.hdr` (a clear-sky gradient over a dark
//! ground) and `sky-sun.hdr` (the same with a small bright sun). Run with
//! `cargo run --example make_sky`.
//!
//! Equirectangular, linear Rec.709 RGB, radiance in W/(m²·sr), laid out as Mitsuba 3's `envmap`
//! reads it (design.md §2): column i is centred on u = (i + 0.5)/W, row j on v = j/(H − 1)
//! (rows 0 and H − 1 at the poles), and (u, v) is the direction
//! (sin 2πu · sin πv, cos πv, −cos 2πu · sin πv) towards the light: u = 0 at −Z, u = 1/4 at +X.
//! The sky depends on elevation only, so that the RLE of Radiance's format keeps the files small.

use image::{Rgb, codecs::hdr::HdrEncoder};
use std::f64::consts::PI;

const WIDTH: usize = 512;
const HEIGHT: usize = 256;
/// Sun: towards +X at 50° elevation, angular radius 1.28° (4π/8000 sr), 3 W/m² facing it.
const SUN_ELEVATION_DEG: f64 = 50.0;
const SUN_AZIMUTH_U: f64 = 0.25;
const SUN_SOLID_ANGLE: f64 = 4.0 * PI / 8000.0;
const SUN_IRRADIANCE: f64 = 3.0;
const SUN_COLOUR: [f64; 3] = [1.0, 0.95, 0.86];

fn dir(u: f64, v: f64) -> [f64; 3] {
    let (st, ct) = (PI * v).sin_cos();
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    [sp * st, ct, -cp * st]
}

fn mix(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t)
}

/// Sky radiance by elevation (radians): blue at the zenith, paler and brighter at the horizon,
/// a dim dark-grey ground below it (blended over the first 3° below the horizon).
fn sky(elevation: f64) -> [f64; 3] {
    let zenith = [0.10, 0.18, 0.40];
    let horizon = [0.45, 0.50, 0.55];
    let ground = [0.05, 0.05, 0.05];
    if elevation >= 0.0 {
        let t = (1.0 - elevation / (0.5 * PI)).powf(3.0);
        mix(zenith, horizon, t)
    } else {
        let t = (-elevation / 3f64.to_radians()).min(1.0);
        mix(horizon, ground, t * t * (3.0 - 2.0 * t))
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let e = SUN_ELEVATION_DEG.to_radians();
    let sun = dir(SUN_AZIMUTH_U, 0.5 - e / PI);
    let cos_radius = 1.0 - SUN_SOLID_ANGLE / (2.0 * PI);
    let sun_radiance = SUN_IRRADIANCE / SUN_SOLID_ANGLE;
    let (w, h) = (WIDTH as f64, HEIGHT as f64);
    let mut sky_px = Vec::with_capacity(WIDTH * HEIGHT);
    let mut sun_px = Vec::with_capacity(WIDTH * HEIGHT);
    // Each texel is the sun's radiance × the fraction of its footprint's solid angle the disc
    // covers (16 × 16 sub-samples weighted by sin θ), so the disc's power survives sampling.
    const SUB: usize = 16;
    for j in 0..HEIGHT {
        let v = j as f64 / (h - 1.0);
        let base = sky(0.5 * PI - PI * v);
        for i in 0..WIDTH {
            let u = (i as f64 + 0.5) / w;
            let (mut covered, mut total) = (0.0, 0.0);
            for a in 0..SUB {
                for b in 0..SUB {
                    let su = u + ((a as f64 + 0.5) / SUB as f64 - 0.5) / w;
                    let sv = v + ((b as f64 + 0.5) / SUB as f64 - 0.5) / (h - 1.0);
                    if !(0.0..=1.0).contains(&sv) {
                        continue;
                    }
                    let d = dir(su, sv);
                    let weight = (PI * sv).sin();
                    total += weight;
                    if d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2] >= cos_radius {
                        covered += weight;
                    }
                }
            }
            let f = if total > 0.0 { covered / total } else { 0.0 };
            let with_sun = mix(base, SUN_COLOUR.map(|c| c * sun_radiance), f);
            sky_px.push(Rgb(base.map(|c| c as f32)));
            sun_px.push(Rgb(with_sun.map(|c| c as f32)));
        }
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets");
    for (name, px) in [("sky.hdr", &sky_px), ("sky-sun.hdr", &sun_px)] {
        let path = dir.join(name);
        let file = std::io::BufWriter::new(std::fs::File::create(&path)?);
        HdrEncoder::new(file).encode(px, WIDTH, HEIGHT)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
