//! Output encoding: PNG (exposure, tone map, sRGB 8-bit) and EXR (linear float RGB, optionally
//! one layer per component); also reading those outputs back into a [`Frame`].

use crate::frame::Frame;
use glam::Vec3;
use std::io::Cursor;

/// Tone mapping applied before the sRGB transfer in PNG output.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum ToneMap {
    /// Clamp to [0, 1].
    Clamp,
    /// Narkowicz's ACES filmic fit.
    #[default]
    Aces,
    /// x / (1 + x).
    Reinhard,
}

/// PNG settings: radiance × 2^exposure, then the tone map, then sRGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PngSettings {
    pub exposure: f32,
    pub tone_map: ToneMap,
}

impl Default for PngSettings {
    fn default() -> Self {
        PngSettings {
            exposure: 0.0,
            tone_map: ToneMap::Clamp,
        }
    }
}

pub fn tone_map(x: f32, t: ToneMap) -> f32 {
    let x = x.max(0.0);
    match t {
        ToneMap::Clamp => x.min(1.0),
        ToneMap::Reinhard => x / (1.0 + x),
        ToneMap::Aces => ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0),
    }
}

pub fn linear_to_srgb(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

#[derive(Debug, thiserror::Error)]
pub enum EncodeError {
    #[error("image encoding failed: {0}")]
    Image(#[from] image::ImageError),
    #[error("layers differ in size or there are none")]
    LayerSize,
    #[error("EXR encoding failed: {0}")]
    Exr(String),
    #[error("APNG encoding failed: {0}")]
    Apng(String),
}

/// The 8-bit sRGB bytes (RGB) of a frame, tone-mapped as `s` says.
pub fn srgb8(f: &Frame, s: PngSettings) -> Vec<u8> {
    let k = 2f32.powf(s.exposure);
    let mut buf = Vec::with_capacity(f.pixels.len() * 3);
    for p in &f.pixels {
        for c in p.to_array() {
            let v = linear_to_srgb(tone_map(c * k, s.tone_map));
            buf.push((v * 255.0 + 0.5).clamp(0.0, 255.0) as u8);
        }
    }
    buf
}

/// An animated PNG (APNG) of `frames`, each the [`srgb8`] bytes of a `width` × `height`
/// frame, shown `fps` frames a second and looping.
pub fn encode_apng(
    frames: &[Vec<u8>],
    (width, height): (u32, u32),
    fps: f32,
) -> Result<Vec<u8>, EncodeError> {
    let size = width as usize * height as usize * 3;
    if frames.is_empty() || frames.iter().any(|f| f.len() != size) {
        return Err(EncodeError::LayerSize);
    }
    let err = |e: png::EncodingError| EncodeError::Apng(e.to_string());
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_animated(frames.len() as u32, 0).map_err(err)?;
        // The delay 1/fps s as 1000/(1000·fps): fps to a thousandth, up to 65.
        let den = (fps * 1000.0).round().clamp(1.0, 65535.0) as u16;
        enc.set_frame_delay(1000, den).map_err(err)?;
        let mut w = enc.write_header().map_err(err)?;
        for f in frames {
            w.write_image_data(f).map_err(err)?;
        }
        w.finish().map_err(err)?;
    }
    Ok(out)
}

/// 8-bit sRGB PNG bytes.
pub fn encode_png(f: &Frame, s: PngSettings) -> Result<Vec<u8>, EncodeError> {
    let buf = srgb8(f, s);
    let img = image::RgbImage::from_raw(f.width, f.height, buf).expect("buffer size matches");
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)?;
    Ok(out.into_inner())
}

/// Linear float RGB EXR bytes.
pub fn encode_exr(f: &Frame) -> Result<Vec<u8>, EncodeError> {
    let buf: Vec<f32> = f.pixels.iter().flat_map(|p| p.to_array()).collect();
    let img = image::Rgb32FImage::from_raw(f.width, f.height, buf).expect("buffer size matches");
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::OpenExr)?;
    Ok(out.into_inner())
}

/// One EXR file with one linear RGB layer per named frame (layer names such as `direct`,
/// `caustics`; channels `NAME.R`, `NAME.G`, `NAME.B`), ZIP-compressed.
pub fn encode_exr_layers(layers: &[(&str, &Frame)]) -> Result<Vec<u8>, EncodeError> {
    use exr::prelude::*;
    let Some((_, first)) = layers.first() else {
        return Err(EncodeError::LayerSize);
    };
    let size = Vec2(first.width as usize, first.height as usize);
    if layers
        .iter()
        .any(|(_, f)| (f.width, f.height) != (first.width, first.height))
    {
        return Err(EncodeError::LayerSize);
    }
    let list: Vec<_> = layers
        .iter()
        .map(|(name, f)| {
            let w = f.width as usize;
            Layer::new(
                size,
                LayerAttributes::named(*name),
                Encoding::SMALL_LOSSLESS,
                SpecificChannels::rgb(move |p: Vec2<usize>| {
                    let c = f.pixels[p.1 * w + p.0];
                    (c.x, c.y, c.z)
                }),
            )
        })
        .collect();
    let image = Image::from_layers(
        ImageAttributes::new(IntegerBounds::from_dimensions(size)),
        list,
    );
    let mut out = Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut out)
        .map_err(|e| EncodeError::Exr(e.to_string()))?;
    Ok(out.into_inner())
}

/// Read a float image (EXR or PNG) back into a [`Frame`]; PNG is taken as sRGB.
pub fn decode_frame(bytes: &[u8]) -> Result<Frame, String> {
    let img = crate::scene::image::decode_image_limited(bytes, 16384)?;
    let srgb = !matches!(
        img,
        image::DynamicImage::ImageRgb32F(_) | image::DynamicImage::ImageRgba32F(_)
    );
    let rgb = img.to_rgb32f();
    let (width, height) = rgb.dimensions();
    let lin = |c: f32| {
        if !srgb {
            c
        } else if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    Ok(Frame {
        width,
        height,
        pixels: rgb
            .pixels()
            .map(|p| Vec3::new(lin(p.0[0]), lin(p.0[1]), lin(p.0[2])))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_round_trips_linear_values() {
        let mut f = Frame::new(3, 2);
        f.pixels[4] = Vec3::new(0.25, 7.5, 1e-3);
        let back = decode_frame(&encode_exr(&f).unwrap()).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert!((back.at(1, 1) - f.at(1, 1)).abs().max_element() < 1e-6);
    }

    #[test]
    fn exr_layers_read_back_by_name() {
        use exr::prelude::*;
        let mut a = Frame::new(5, 3);
        let mut b = Frame::new(5, 3);
        a.pixels[7] = Vec3::new(1.0, 2.0, 3.0);
        b.pixels[2] = Vec3::splat(0.5);
        let bytes = encode_exr_layers(&[("direct", &a), ("caustics", &b)]).unwrap();
        let img = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(Cursor::new(bytes))
            .unwrap();
        let names: Vec<String> = img
            .layer_data
            .iter()
            .map(|l| l.attributes.layer_name.as_ref().unwrap().to_string())
            .collect();
        assert_eq!(names, ["direct", "caustics"]);
        let direct = &img.layer_data[0].channel_data.list;
        // Channels are sorted by name: B, G, R.
        assert_eq!(direct[2].sample_data.value_by_flat_index(7).to_f32(), 1.0);
        assert_eq!(direct[0].sample_data.value_by_flat_index(7).to_f32(), 3.0);
    }

    #[test]
    fn png_is_srgb_encoded() {
        let mut f = Frame::new(1, 1);
        f.pixels[0] = Vec3::splat(0.5);
        let back = decode_frame(&encode_png(&f, PngSettings::default()).unwrap()).unwrap();
        assert!(
            (back.pixels[0].x - 0.5).abs() < 0.01,
            "{:?}",
            back.pixels[0]
        );
        let img = image::load_from_memory(&encode_png(&f, PngSettings::default()).unwrap())
            .unwrap()
            .to_rgb8();
        assert_eq!(img.get_pixel(0, 0).0[0], 188); // sRGB(0.5) = 0.7354
    }
}
