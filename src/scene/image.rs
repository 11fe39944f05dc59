//! Bounded image decoding for scene inputs: glTF textures and environment maps arrive as
//! untrusted bytes, so they are decoded here with explicit limits on size and allocation
//! (`encode` reads our own outputs back through the same function).

use std::io::Cursor;

/// Decode PNG/EXR/HDR bytes with explicit limits on size and allocation.
pub fn decode_image_limited(bytes: &[u8], max_side: u32) -> Result<image::DynamicImage, String> {
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| e.to_string())?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side);
    limits.max_image_height = Some(max_side);
    limits.max_alloc = Some(u64::from(max_side) * u64::from(max_side) * 16 + (1 << 20));
    reader.limits(limits);
    reader.decode().map_err(|e| e.to_string())
}
