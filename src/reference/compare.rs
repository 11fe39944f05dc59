//! Image comparison as the quality figures are stated: a 3×3 box blur, then relative L1 and
//! total flux over a mask of pixels (e.g. the receiver seen directly by the camera).

use crate::frame::Frame;
use crate::scene::World;
use crate::trace::Accel;
use glam::Vec3;

/// 3×3 box blur (edge pixels average their in-image neighbours).
pub fn blur3(f: &Frame) -> Frame {
    let (w, h) = (f.width as i64, f.height as i64);
    let mut out = Frame::new(f.width, f.height);
    for y in 0..h {
        for x in 0..w {
            let mut s = Vec3::ZERO;
            let mut n = 0.0;
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx >= 0 && yy >= 0 && xx < w && yy < h {
                        s += f.pixels[(yy * w + xx) as usize];
                        n += 1.0;
                    }
                }
            }
            out.pixels[(y * w + x) as usize] = s / n;
        }
    }
    out
}

/// Pixels whose whole 3×3 neighbourhood sees object `name` directly through the pixel centre
/// (so that a blur never mixes in other surfaces).
pub fn object_mask(world: &World, accel: &Accel, name: &str) -> Vec<bool> {
    let oi = world.objects.iter().position(|o| o.name == name);
    neighbourhoods(world, accel, |hit| Some(hit.object as usize) == oi)
}

/// Pixels of [`object_mask`]`(receiver)` whose whole 3×3 neighbourhood lies in the shadow that
/// object `occluder` casts for light travelling along `light_dir`: the receiver's point, seen
/// through the pixel centre, cannot see the light past the occluder. There a directional
/// light's direct component is zero, so a particle tracer's whole image (Mitsuba 3's `ptracer`)
/// is the caustic alone.
pub fn shadow_mask(
    world: &World,
    accel: &Accel,
    receiver: &str,
    occluder: &str,
    light_dir: Vec3,
) -> Vec<bool> {
    let index = |name: &str| world.objects.iter().position(|o| o.name == name);
    let (ri, oi) = (index(receiver), index(occluder));
    let to_light = -light_dir.normalize();
    neighbourhoods(world, accel, |hit| {
        Some(hit.object as usize) == ri
            && accel
                .intersect(hit.point + hit.geo_normal * 1e-4, to_light, f32::INFINITY)
                .is_some_and(|s| Some(s.object as usize) == oi)
    })
}

/// Pixels whose whole 3×3 neighbourhood sees a receiver directly: a surface that is not glass
/// or mirror (every object's, not one's).
pub fn receivers_mask(world: &World, accel: &Accel) -> Vec<bool> {
    neighbourhoods(world, accel, |hit| !accel.material(hit).is_specular())
}

/// `f` averaged over blocks of `k` × `k` pixels (the blocks at the right and bottom edges over
/// the pixels they hold): the image a camera with `k` times larger pixels would see.
pub fn downsample(f: &Frame, k: u32) -> Frame {
    let k = k.max(1);
    let (w, h) = (f.width.div_ceil(k), f.height.div_ceil(k));
    let mut out = Frame::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let mut s = Vec3::ZERO;
            let mut n = 0u32;
            for yy in y * k..((y + 1) * k).min(f.height) {
                for xx in x * k..((x + 1) * k).min(f.width) {
                    s += f.pixels[(yy * f.width + xx) as usize];
                    n += 1;
                }
            }
            out.pixels[(y * w + x) as usize] = s / n.max(1) as f32;
        }
    }
    out
}

/// The mask of [`downsample`]`(_, k)`'s pixels whose whole block is in `mask` (of a `width` ×
/// `height` image).
pub fn downsample_mask(mask: &[bool], width: u32, height: u32, k: u32) -> Vec<bool> {
    let k = k.max(1);
    let (w, h) = (width.div_ceil(k), height.div_ceil(k));
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            (y * k..((y + 1) * k).min(height)).all(|yy| {
                (x * k..((x + 1) * k).min(width)).all(|xx| mask[(yy * width + xx) as usize])
            })
        })
        .collect()
}

/// Pixels whose whole 3×3 neighbourhood passes `test` on what the camera ray through the pixel
/// centre hits first (a pixel that sees nothing fails).
fn neighbourhoods(
    world: &World,
    accel: &Accel,
    test: impl Fn(&crate::trace::Hit) -> bool + Sync,
) -> Vec<bool> {
    use rayon::prelude::*;
    let cam = &world.camera;
    let (w, h) = (cam.width as i64, cam.height as i64);
    let pass: Vec<bool> = (0..w * h)
        .into_par_iter()
        .map(|i| (i % w, i / w))
        .map(|(x, y)| {
            let d = cam.ray_dir(x as f32 + 0.5, y as f32 + 0.5);
            accel
                .intersect(cam.eye, d, f32::INFINITY)
                .is_some_and(|hit| test(&hit))
        })
        .collect();
    (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0 && yy >= 0 && xx < w && yy < h && pass[(yy * w + xx) as usize]
                })
            })
        })
        .collect()
}

/// Figures of one comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Σ|a−b| / Σ|b| over masked pixels and channels, after a 3×3 blur of both.
    pub rel_l1: f32,
    /// Σa / Σb over masked pixels (total flux ratio).
    pub flux_ratio: f32,
    pub pixels: usize,
}

/// Compare `a` against the reference `b` on `mask`.
pub fn compare(a: &Frame, b: &Frame, mask: &[bool]) -> Comparison {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "image sizes differ"
    );
    let (ab, bb) = (blur3(a), blur3(b));
    let (mut diff, mut base, mut sa, mut sb) = (0f64, 0f64, 0f64, 0f64);
    let mut pixels = 0;
    for ((x, y), _) in ab
        .pixels
        .iter()
        .zip(&bb.pixels)
        .zip(mask)
        .filter(|(_, m)| **m)
    {
        pixels += 1;
        let (x, y) = (*x, *y);
        diff += f64::from((x - y).abs().element_sum());
        base += f64::from(y.abs().element_sum());
        sa += f64::from(x.element_sum());
        sb += f64::from(y.element_sum());
    }
    Comparison {
        rel_l1: (diff / base.max(1e-30)) as f32,
        flux_ratio: (sa / sb.max(1e-30)) as f32,
        pixels,
    }
}

/// `a` against the reference `b` over the pixels of object `name` as `world`'s camera sees
/// them at the frames' size: the figures `caustica compare` and `POST /v1/compare` give.
pub fn compare_on(mut world: World, name: &str, a: &Frame, b: &Frame) -> Comparison {
    world.camera.width = b.width;
    world.camera.height = b.height;
    let accel = Accel::build(&world);
    let mask = object_mask(&world, &accel, name);
    compare(a, b, &mask)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_compare_perfectly() {
        let mut f = Frame::new(4, 4);
        f.pixels[5] = Vec3::ONE;
        let c = compare(&f, &f, &[true; 16]);
        assert_eq!(c.rel_l1, 0.0);
        assert!((c.flux_ratio - 1.0).abs() < 1e-6);
        let mut g = f.clone();
        g.scale(1.1);
        let c = compare(&g, &f, &[true; 16]);
        assert!((c.rel_l1 - 0.1).abs() < 1e-5 && (c.flux_ratio - 1.1).abs() < 1e-5);
    }
}
