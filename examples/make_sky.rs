//! Writes the procedural skies of `scenes/assets/`: `sky.hdr` (a clear-sky gradient over a dark
//! ground) and `sky-sun.hdr` (the same with a small bright sun towards +X at 50° elevation,
//! 4π/8000 sr, 3 W/m² facing it). Run with `cargo run --example make_sky`.
//!
//! Equirectangular, linear Rec.709 RGB, radiance in W/(m²·sr), laid out as Mitsuba 3's `envmap`
//! reads it (design.md §2); the skies are `caustica::scene::random::sky_map`'s. The sky depends
//! on elevation only, so that the RLE of Radiance's format keeps the files small.

use caustica::scene::random::{repository_sun, sky_map};
use image::{Rgb, codecs::hdr::HdrEncoder};

const WIDTH: usize = 512;
const HEIGHT: usize = 256;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets");
    for (name, sun) in [("sky.hdr", None), ("sky-sun.hdr", Some(repository_sun()))] {
        let map = sky_map(sun, WIDTH, HEIGHT);
        let px: Vec<Rgb<f32>> = map.texels.iter().map(|t| Rgb(t.to_array())).collect();
        let path = dir.join(name);
        let file = std::io::BufWriter::new(std::fs::File::create(&path)?);
        HdrEncoder::new(file).encode(&px, WIDTH, HEIGHT)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
