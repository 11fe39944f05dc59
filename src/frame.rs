//! What a frame is made of: [`Frame`] images, one per [`Component`]. Every method returns the
//! same components, in linear radiance W/(m²·sr), so that any of them can be compared pixel
//! for pixel with the reference.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// A linear-RGB float image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

impl Frame {
    pub fn new(width: u32, height: u32) -> Self {
        Frame {
            width,
            height,
            pixels: vec![Vec3::ZERO; (width * height) as usize],
        }
    }

    pub fn at(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Sum of two frames of the same size.
    pub fn add(&self, o: &Frame) -> Frame {
        assert_eq!((self.width, self.height), (o.width, o.height));
        Frame {
            width: self.width,
            height: self.height,
            pixels: self
                .pixels
                .iter()
                .zip(&o.pixels)
                .map(|(a, b)| *a + *b)
                .collect(),
        }
    }

    /// Adds `o` (same size) to this frame, pixel by pixel: [`Frame::add`] without a new image.
    pub fn add_assign(&mut self, o: &Frame) {
        assert_eq!((self.width, self.height), (o.width, o.height));
        for (a, b) in self.pixels.iter_mut().zip(&o.pixels) {
            *a += *b;
        }
    }

    pub fn scale(&mut self, s: f32) {
        for p in &mut self.pixels {
            *p *= s;
        }
    }
}

/// One component of a frame (Jensen's path notation: L light, S specular, D diffuse, E eye).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    clap::ValueEnum,
    Default,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Component {
    /// The sum of the others.
    #[default]
    Total,
    /// Light → receiver → camera (L D E); specular objects cast shadows.
    Direct,
    /// Light through glass or off mirrors onto the first diffuse receiver (L S+ D E).
    Caustics,
    /// What the camera sees in glass and mirrors (… S+ E).
    Specular,
    /// Every other path of two or more bounces: diffuse interreflection, and light a diffuse
    /// surface sends through glass (L D S+ D E).
    Indirect,
    /// Light scattered towards the camera by a participating medium (L … V E), other than
    /// `volume_caustics`.
    Volume,
    /// Light that went through glass or off mirrors and then scattered once in the medium
    /// towards the camera (L S+ V E): the volumetric caustic.
    #[value(name = "volume_caustics", alias = "volume-caustics")]
    VolumeCaustics,
}

impl Component {
    /// Every component, `total` first: the order of a frame's layers.
    pub const ALL: [Component; 7] = [
        Component::Total,
        Component::Direct,
        Component::Caustics,
        Component::Specular,
        Component::Indirect,
        Component::Volume,
        Component::VolumeCaustics,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Component::Total => "total",
            Component::Direct => "direct",
            Component::Caustics => "caustics",
            Component::Specular => "specular",
            Component::Indirect => "indirect",
            Component::Volume => "volume",
            Component::VolumeCaustics => "volume_caustics",
        }
    }
}

impl std::fmt::Display for Component {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
