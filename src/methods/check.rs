//! The self-check: how far a frame's caustics are from the truth on *this* scene's receivers,
//! estimated the way the tests measure it. A short run of the reference (its caustic photons
//! only, light tracing splatted to the same camera: `ReferenceParams::caustics_only`) is
//! compared with the frame's `caustics` component over every pixel whose 3×3 neighbourhood
//! sees a receiver, after a 3×3 blur (`reference::compare`): relative L1 and flux ratio, the
//! figures of `caustica compare` against a converged reference. Frames larger than
//! [`CheckParams::side`] are compared at that size (blocks averaged), where the short
//! reference's own noise stays a few per cent.
//!
//! The reference's noise inflates the raw figure; it is estimated from the difference of the
//! run's two halves (two seeds) and taken out in quadrature: `error` = √(raw² − noise²), the
//! estimate of the frame's own error (for Gaussian noise this reads 0 for a perfect frame and
//! 0.85–0.93 of the true error where it is one to two times the noise).

use super::MethodError;
use crate::frame::Frame;
use crate::reference::compare::{compare, downsample, downsample_mask, receivers_mask};
use crate::reference::{self, ReferenceParams};
use crate::scene::{Material, World};
use crate::trace::Accel;
use serde::Serialize;
use std::time::{Duration, Instant};

/// How much the check may spend.
#[derive(Clone, Debug)]
pub struct CheckParams {
    /// Caustic photons of each round of the short reference, split into two halves.
    pub photons: u64,
    /// The longer side of the compared images, pixels: a larger frame is compared in blocks.
    pub side: u32,
    pub seed: u64,
    /// Rounds are added until the short reference's noise is at most this…
    pub noise_target: f32,
    /// …or this much time has passed (a round under way is finished, and the first always is).
    pub time_budget: Duration,
}

impl Default for CheckParams {
    /// Rounds of 1 M photons (about half a second each on 2 cores) until the noise is 0.03 or
    /// 4 s have passed, 256 pixels a side.
    fn default() -> Self {
        CheckParams {
            photons: 1 << 20,
            side: 256,
            seed: 0x5e1f,
            noise_target: 0.03,
            time_budget: Duration::from_secs(4),
        }
    }
}

/// What the check measured.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Check {
    /// The estimated relative L1 of the frame's caustics against the reference on the
    /// receivers, after a 3×3 blur (the error a user would measure): `raw` without the short
    /// reference's noise.
    pub error: f32,
    /// Relative L1 of the frame's caustics against the short reference.
    pub raw: f32,
    /// Caustic flux of the frame over the reference's, on the receivers.
    pub flux: f32,
    /// The short reference's own noise in the same measure (half the relative L1 between its
    /// two halves): an `error` near it is within what the check can see.
    pub noise: f32,
    /// The compared images' size.
    pub width: u32,
    pub height: u32,
    /// Photons the short reference traced.
    pub photons: u64,
    pub seconds: f32,
}

impl Check {
    /// One line for the CLI and the render's notes.
    pub fn sentence(&self) -> String {
        format!(
            "self-check: the caustics are an estimated {:.3} relative L1 from the reference on \
             the receivers (flux {:.3}; {:.3} from a short reference whose own noise is {:.3}; \
             {}×{}, {} photons, {:.1} s)",
            self.error,
            self.flux,
            self.raw,
            self.noise,
            self.width,
            self.height,
            self.photons,
            self.seconds
        )
    }
}

/// Checks `caustics` (at `world`'s camera size) against a short reference of the light of
/// `objects` (None: every glass or mirror object). None when there is nothing to check: no
/// glass or mirror, no light, no receiver the camera sees, or no caustic light on them in the
/// short reference.
pub fn check_caustics(
    world: &World,
    caustics: &Frame,
    objects: Option<&[usize]>,
    p: &CheckParams,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Check>, MethodError> {
    let t = Instant::now();
    if world.lights.is_empty() || world.objects_with(Material::is_specular).is_empty() {
        return Ok(None);
    }
    let mut world = world.clone();
    world.camera.width = caustics.width;
    world.camera.height = caustics.height;
    let accel = Accel::shared_fast(&world, |_| true);
    let mask = receivers_mask(&world, &accel);
    if !mask.iter().any(|m| *m) {
        return Ok(None);
    }
    let half = |seed: u64| -> Result<(Frame, u64), MethodError> {
        let params = ReferenceParams {
            seed,
            photons: (p.photons / 2).max(1),
            spp: 1,
            caustics_only: true,
            caustic_objects: objects.map(<[usize]>::to_vec),
            ..Default::default()
        };
        let (c, stats) = reference::render(&world, &accel, &params, &|_| keep_going())
            .map_err(|_| MethodError::Canceled)?;
        Ok((c.caustics, stats.photons_traced))
    };
    let k = caustics.width.max(caustics.height).div_ceil(p.side.max(1));
    let mask = downsample_mask(&mask, caustics.width, caustics.height, k);
    let frame = downsample(caustics, k);
    // Rounds of two halves (each its own seeds), summed into `a` and `b`, until their
    // difference says the mean is quiet enough.
    let mut a = Frame::new(frame.width, frame.height);
    let mut b = a.clone();
    let (mut photons, mut rounds) = (0u64, 0u32);
    let noise = loop {
        let seed = p.seed.wrapping_add(u64::from(rounds) * 0x9e37_79b9);
        for (sum, seed) in [(&mut a, seed), (&mut b, seed ^ 0x5bd1_e995)] {
            let (f, n) = half(seed)?;
            photons += n;
            for (s, x) in sum.pixels.iter_mut().zip(&downsample(&f, k).pixels) {
                *s += *x;
            }
        }
        rounds += 1;
        let noise = compare(&a, &b, &mask).rel_l1 * 0.5;
        // A NaN noise (no light to compare) stops too.
        if noise.partial_cmp(&p.noise_target) != Some(std::cmp::Ordering::Greater)
            || t.elapsed() >= p.time_budget
        {
            break noise;
        }
    };
    let mut truth = a.clone();
    for (t, x) in truth.pixels.iter_mut().zip(&b.pixels) {
        *t = (*t + *x) * (0.5 / rounds as f32);
    }
    let lit: f32 = truth
        .pixels
        .iter()
        .zip(&mask)
        .filter(|(_, m)| **m)
        .map(|(p, _)| p.element_sum())
        .sum();
    if lit <= 0.0 {
        return Ok(None);
    }
    let measured = compare(&frame, &truth, &mask);
    let raw = measured.rel_l1;
    Ok(Some(Check {
        error: (raw * raw - noise * noise).max(0.0).sqrt(),
        raw,
        flux: measured.flux_ratio,
        noise,
        width: frame.width,
        height: frame.height,
        photons,
        seconds: t.elapsed().as_secs_f32(),
    }))
}

/// The longer side, in pixels, of the frames a bake's check renders on the CPU from the
/// scene's camera.
pub const BAKE_CHECK_SIDE: u32 = 256;

/// `world` with its camera's image made at most [`BAKE_CHECK_SIDE`] a side (the aspect kept
/// to the nearest pixel).
fn small(world: &World) -> World {
    let mut w = world.clone();
    let (cw, ch) = (w.camera.width.max(1), w.camera.height.max(1));
    let s = (BAKE_CHECK_SIDE as f32 / cw.max(ch) as f32).min(1.0);
    w.camera.width = ((cw as f32 * s).round() as u32).max(1);
    w.camera.height = ((ch as f32 * s).round() as u32).max(1);
    w
}

/// The check of a CSL set baked for object `object` of `world` lit by its directional light of
/// `irradiance` (W/m²): the set's caustics evaluated on the CPU at the camera's view of the
/// receivers ([`BAKE_CHECK_SIDE`]), against a short reference of that object's light.
pub fn check_csl_set(
    world: &World,
    object: usize,
    set: &crate::bake::csl::CslSet,
    irradiance: glam::Vec3,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Check>, MethodError> {
    let world = small(world);
    let csls = set.to_world(world.objects[object].rigid_transform());
    let (accel, blockers) = accels(&world, object);
    let frame =
        crate::render::csl::eval::render_caustics(&world, &accel, &blockers, &csls, irradiance, 2);
    check_caustics(
        &world,
        &frame,
        Some(&[object]),
        &CheckParams::default(),
        keep_going,
    )
}

/// The scene's acceleration structure, and one of everything but `object` (what shadows the
/// object's caustics).
fn accels(world: &World, object: usize) -> (std::sync::Arc<Accel>, Accel) {
    let accel = Accel::shared_fast(world, |_| true);
    let blockers = Accel::build_with(world, |i| i != object, obvhs::BvhBuildParams::fast_build());
    (accel, blockers)
}

/// The check of a transport table baked for object `object` of `world`: the illumination
/// volumes of the scene's lights evaluated on the CPU at the camera's view of the receivers
/// ([`BAKE_CHECK_SIDE`]), against a short reference of that object's light. None where the
/// table cannot be evaluated for the scene's lights.
pub fn check_transport_table(
    world: &World,
    object: usize,
    table: &crate::bake::transport::TransportTable,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Option<Check>, MethodError> {
    use crate::render::transport::{TransportLayer, volumes};
    let world = small(world);
    let Ok(layer) = TransportLayer::build_with(
        &world,
        &[(object, table)],
        volumes::DEFAULT_LINE_POINTS,
        keep_going,
    ) else {
        return Ok(None);
    };
    let (accel, blockers) = accels(&world, object);
    let frame = volumes::render_caustics(&world, &accel, Some(&blockers), &layer.volumes);
    check_caustics(
        &world,
        &frame,
        Some(&[object]),
        &CheckParams::default(),
        keep_going,
    )
}
