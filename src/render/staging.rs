//! The buffers a frame's layers are read back through.

use crate::frame::Frame;
use glam::Vec3;

/// The buffers the layers a frame reads back (direct, specular, caustics) are copied into at
/// the end of its command buffer, rows padded to 256 bytes: kept per image size with the
/// targets (up to [`KEEP_STAGING_BYTES`]), so that a frame allocates no staging memory and
/// waits for the device once.
pub(super) struct Staging {
    pub(super) width: u32,
    pub(super) height: u32,
    /// Bytes a row takes in the buffers.
    pub(super) padded: u64,
    pub(super) buffers: [wgpu::Buffer; 3],
}

/// Staging buffers up to this size (the three together) are kept for the next frame; larger
/// ones (past about 2.8 megapixels) are freed after their frame, so that one large render does
/// not leave a service holding their memory.
pub(super) const KEEP_STAGING_BYTES: u64 = 128 << 20;

impl Staging {
    pub(super) fn bytes(&self) -> u64 {
        self.buffers.iter().map(|b| b.size()).sum()
    }

    pub(super) fn new(device: &wgpu::Device, width: u32, height: u32) -> Staging {
        let padded =
            (u64::from(width) * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64);
        let buffer = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: padded * u64::from(height),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        };
        Staging {
            width,
            height,
            padded,
            buffers: [
                buffer("direct readback"),
                buffer("specular readback"),
                buffer("caustics readback"),
            ],
        }
    }

    /// Copies `texture` (Rgba32Float, this size) into buffer `k`.
    pub(super) fn copy(&self, enc: &mut wgpu::CommandEncoder, k: usize, texture: &wgpu::Texture) {
        crate::gpu::encode_texture_copy(enc, texture, &self.buffers[k], self.padded as u32);
    }

    /// The frame in a buffer's mapped `bytes`, and how many of its pixels have an alpha above
    /// 1.5 (the direct pass leaves 1 in every pixel; each pinhole draw whose loop over points
    /// was ended early adds 1; the transport gather flags the pixels whose list overflowed).
    pub(super) fn frame(&self, bytes: &[u8]) -> (Frame, usize) {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut pixels = Vec::with_capacity(w * h);
        let mut flagged = 0;
        for y in 0..h {
            let start = y * self.padded as usize;
            let row: &[f32] = bytemuck::cast_slice(&bytes[start..start + w * 16]);
            for p in row.chunks_exact(4) {
                flagged += usize::from(p[3] > 1.5);
                pixels.push(Vec3::new(p[0], p[1], p[2]));
            }
        }
        let frame = Frame {
            width: self.width,
            height: self.height,
            pixels,
        };
        (frame, flagged)
    }
}
