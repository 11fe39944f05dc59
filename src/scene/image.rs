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

/// Bytes that decoded images may hold at once in the whole process (uploads and renders
/// resolving scenes together); a decode waits for room, up to [`DECODE_WAIT`].
pub const PROCESS_DECODE_BYTES: u64 = 384 << 20;
/// Longest a decode waits for room in [`PROCESS_DECODE_BYTES`] before it gives up (busy).
pub const DECODE_WAIT: std::time::Duration = std::time::Duration::from_secs(30);

static DECODING: std::sync::Mutex<u64> = std::sync::Mutex::new(0);
static DECODED: std::sync::Condvar = std::sync::Condvar::new();

/// Room for `bytes` in the process's decode budget, given back when dropped.
pub struct Reservation(u64);

impl Reservation {
    /// Waits up to `wait` for `bytes` of room; None when it does not come (or `bytes` is more
    /// than the whole budget).
    pub fn take(bytes: u64, wait: std::time::Duration) -> Option<Reservation> {
        if bytes > PROCESS_DECODE_BYTES {
            return None;
        }
        let deadline = std::time::Instant::now() + wait;
        let mut used = DECODING.lock().unwrap_or_else(|e| e.into_inner());
        while *used + bytes > PROCESS_DECODE_BYTES {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            if left.is_zero() {
                return None;
            }
            used = DECODED
                .wait_timeout(used, left)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
        *used += bytes;
        Some(Reservation(bytes))
    }
}

impl Drop for Reservation {
    fn drop(&mut self) {
        let mut used = DECODING.lock().unwrap_or_else(|e| e.into_inner());
        *used -= self.0;
        DECODED.notify_all();
    }
}

/// Why a budgeted decode did not happen.
#[derive(Clone, Debug, PartialEq)]
pub enum DecodeRefusal {
    /// The image is bad or past a limit of its own (the caller warns and goes on without it).
    Skip(String),
    /// The process's decode budget stayed full for [`DECODE_WAIT`] (the caller answers busy).
    Busy(String),
}

/// Decodes an image as [`decode_image_limited`] does, within budgets: its decoded bytes plus
/// `extra_per_pixel` bytes a pixel (a working copy) are taken from `scene_left` (past it: not
/// decoded) and held in the process's budget for as long as the returned reservation lives.
pub fn decode_image_budgeted(
    bytes: &[u8],
    max_side: u32,
    scene_left: &mut u64,
    extra_per_pixel: u64,
) -> Result<(image::DynamicImage, Reservation), DecodeRefusal> {
    use image::ImageDecoder;
    let skip = |e: image::ImageError| DecodeRefusal::Skip(e.to_string());
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| DecodeRefusal::Skip(e.to_string()))?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(max_side);
    limits.max_image_height = Some(max_side);
    limits.max_alloc = Some(u64::from(max_side) * u64::from(max_side) * 16 + (1 << 20));
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(skip)?;
    let (w, h) = decoder.dimensions();
    let need = decoder
        .total_bytes()
        .saturating_add(u64::from(w) * u64::from(h) * extra_per_pixel);
    if need > *scene_left {
        return Err(DecodeRefusal::Skip(format!(
            "{w}×{h} needs {} MiB decoded, past the {} MiB left of the scene's image budget",
            need >> 20,
            *scene_left >> 20
        )));
    }
    let held = Reservation::take(need, DECODE_WAIT).ok_or_else(|| {
        DecodeRefusal::Busy(format!(
            "the server is decoding other images ({} MiB at most at once) and had no room \
             for this one ({} MiB) within {} s",
            PROCESS_DECODE_BYTES >> 20,
            need >> 20,
            DECODE_WAIT.as_secs()
        ))
    })?;
    *scene_left -= need;
    let img = image::DynamicImage::from_decoder(decoder).map_err(skip)?;
    Ok((img, held))
}
