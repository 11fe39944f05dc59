//! Images the tests read: frames from EXR files, the stored references under `tests/data/`, and
//! the measure of a frame several modules take.

use caustica::encode::decode_frame;
use caustica::frame::Frame;
use std::path::Path;

/// The frame in an image file (EXR, or whatever [`decode_frame`] reads).
pub fn read_frame(path: impl AsRef<Path>) -> Frame {
    let path = path.as_ref();
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    decode_frame(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A stored render of our `reference` method, `tests/data/reference/{name}` (how they were made:
/// the README beside them).
pub fn stored_reference(name: &str) -> Frame {
    read_frame(super::repo_path("tests/data/reference").join(name))
}

/// A stored Mitsuba 3 render, `tests/data/mitsuba/{name}` (how they were made: the README beside
/// them).
pub fn mitsuba(name: &str) -> Frame {
    read_frame(super::repo_path("tests/data/mitsuba").join(name))
}

/// The largest first (red) channel value of a frame, 0 for a black one.
pub fn peak(f: &Frame) -> f32 {
    f.pixels.iter().map(|p| p.x).fold(0.0f32, f32::max)
}
