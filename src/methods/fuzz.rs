//! Fidelity fuzzing: `auto` on a random scene nobody tuned a method on
//! (`crate::scene::random`), against a `reference` render of it. The CI test
//! (`tests/it/fuzz_fidelity.rs`) runs a fixed seed set at 96², the example
//! (`examples/fuzz_fidelity.rs`) a larger one; both print [`Row::markdown`]'s table.

use super::{Env, Frames, Method, MethodArgs, MethodError};
use crate::frame::Component;
use crate::reference::{self, ReferenceParams, compare};
use crate::scene::random::{Drawn, random_scene};
use crate::trace::Accel;
use std::path::Path;
use std::time::Instant;

/// The pass mark: total light over the floor within this relative L1 (3×3 blur) of the
/// reference…
pub const MAX_TOTAL_L1: f32 = 0.15;
/// …and its flux within this fraction.
pub const MAX_FLUX_OFF: f32 = 0.05;

/// One scene's outcome.
#[derive(Clone, Debug)]
pub struct Row {
    pub drawn: Drawn,
    /// The method that made the frame (`auto`'s pick, or the reference it fell back to).
    pub used: Method,
    /// Seconds `auto` took.
    pub seconds: f64,
    pub total: compare::Comparison,
    pub caustics: compare::Comparison,
    /// The self-check's estimate, where it ran.
    pub check: Option<f32>,
    /// Both frames, for a look (`FUZZ_DUMP`); `auto`'s with its warnings.
    pub frames: Frames,
    pub truth: reference::Components,
}

impl Row {
    /// Whether the frame passes: within [`MAX_TOTAL_L1`] and [`MAX_FLUX_OFF`] of the
    /// reference.
    pub fn ok(&self) -> bool {
        self.total.rel_l1 <= MAX_TOTAL_L1 && (self.total.flux_ratio - 1.0).abs() <= MAX_FLUX_OFF
    }

    pub const HEADER: &'static str = "| seed | scene | auto used | s | total L1 / flux | \
        caustics L1 / flux | self-check | ok |\n| --- | --- | --- | --- | --- | --- | --- | --- |";

    /// The row of the table (and a row per warning).
    pub fn markdown(&self) -> String {
        let check = self.check.map_or("-".to_string(), |e| format!("{e:.3}"));
        let mut s = format!(
            "| {} | {} of {} under {} | {} | {:.1} | {:.3} / {:.3} | {:.3} / {:.3} | {check} | {} |",
            self.drawn.seed,
            self.drawn.shape,
            self.drawn.material,
            self.drawn.light,
            self.used,
            self.seconds,
            self.total.rel_l1,
            self.total.flux_ratio,
            self.caustics.rel_l1,
            self.caustics.flux_ratio,
            if self.ok() { "yes" } else { "**no**" }
        );
        for w in &self.frames.warnings {
            s.push_str(&format!("\n|  | warning: {w} | | | | | | |"));
        }
        s
    }
}

/// Renders random scene `seed` at `size`² with `auto` and with the reference (`photons`
/// caustic photons, 8 samples a pixel) and compares them over the floor. `scenes` is the
/// repository's `scenes/` folder.
pub fn run(
    seed: u64,
    size: u32,
    photons: u64,
    scenes: &Path,
    env: &Env,
) -> Result<Row, MethodError> {
    let (world, drawn) = random_scene(seed, scenes, size)
        .map_err(|e| MethodError::Render(format!("random scene {seed}: {e}")))?;
    let accel = Accel::build(&world);
    let rp = ReferenceParams {
        photons,
        spp: 8,
        seed: 1000 + seed,
        ..Default::default()
    };
    let (truth, _) = reference::render(&world, &accel, &rp, &|_| (env.keep_going)())
        .map_err(|e| MethodError::Render(format!("reference of random scene {seed}: {e}")))?;
    let t = Instant::now();
    let plan = Method::Auto.imp().plan(&world, &MethodArgs::default())?;
    let frames = super::render(plan.as_ref(), &world, env, None)?;
    let seconds = t.elapsed().as_secs_f64();
    let mask = compare::object_mask(&world, &accel, "floor");
    let total = compare::compare(frames.get(Component::Total), &truth.total(), &mask);
    let caustics = compare::compare(frames.get(Component::Caustics), &truth.caustics, &mask);
    let check = frames
        .statistics
        .as_ref()
        .and_then(|s| s.get("check"))
        .and_then(|c| c.get("error"))
        .and_then(|e| e.as_f64())
        .map(|e| e as f32);
    Ok(Row {
        drawn,
        used: frames.made_by.unwrap_or(plan.method()),
        seconds,
        total,
        caustics,
        check,
        frames,
        truth,
    })
}
