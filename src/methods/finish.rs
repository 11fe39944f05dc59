//! What every render adds to its method's frames (`render`): non-finite pixels mended and
//! named, a warning naming why where the caustics are black, and the self-check
//! ([`super::check`]) where it is asked for or the method's default.

use super::{Env, Frames, Method, MethodError, RenderPlan, caustic_objects, check};
use crate::frame::{Component, Frame};
use crate::scene::World;
use std::time::Instant;

/// A self-check ([`check`]) above this relative L1 makes the render warn: the frame is further
/// from the reference than `auto` accepts (docs/accuracy.md).
pub const POOR_CHECK: f32 = 0.10;

/// The frames of `plan` for `world`, with what every render adds to them: where the frame's
/// caustics are black, a warning naming why (`reference::probe`: the light misses the glass or
/// mirror, nothing receives it, or the camera sees none of it); and the self-check ([`check`])
/// where `check` asks for it (None: the method's default, [`MethodInfo::check`]) unless the
/// plan ran it already (`auto`).
pub fn render(
    plan: &dyn RenderPlan,
    world: &World,
    env: &Env,
    check: Option<bool>,
) -> Result<Frames, MethodError> {
    let mut frames = plan.frames(world, env)?;
    let method = frames.made_by.unwrap_or(plan.method());
    let mut mended = Vec::new();
    for (c, f) in &mut frames.layers {
        let bad = f.pixels.iter().filter(|p| !p.is_finite()).count();
        if bad > 0 && *c != Component::Total {
            f.pixels
                .iter_mut()
                .filter(|p| !p.is_finite())
                .for_each(|p| *p = glam::Vec3::ZERO);
            mended.push(format!(
                "{bad} pixels of the {} layer were not finite and are black: a fault of method \
                 {method}, please report it",
                c.name()
            ));
        }
    }
    if !mended.is_empty() {
        for w in mended {
            frames.warn(w);
        }
        // The total again, from the mended layers.
        let (w, h) = (frames.layers[0].1.width, frames.layers[0].1.height);
        let total = frames
            .layers
            .iter()
            .filter(|(c, _)| *c != Component::Total)
            .fold(Frame::new(w, h), |t, (_, f)| t.add(f));
        if let Some((_, t)) = frames
            .layers
            .iter_mut()
            .find(|(c, _)| *c == Component::Total)
        {
            *t = total;
        }
    }
    if matches!(method, Method::Direct) {
        return Ok(frames);
    }
    let sum = |c: Component| -> f64 {
        frames
            .get(c)
            .pixels
            .iter()
            .map(|p| f64::from(p.element_sum()))
            .sum()
    };
    let caustic = sum(Component::Caustics) + sum(Component::VolumeCaustics);
    if caustic <= 1e-6 * sum(Component::Total) && !caustic_objects(world).is_empty() {
        let accel = crate::trace::Accel::shared_fast(world, |_| true);
        let reach = crate::reference::probe::probe(
            world,
            &accel,
            crate::reference::probe::PROBE_PHOTONS,
            1,
        );
        let why = crate::reference::probe::black_caustics(world, &reach);
        if why.is_empty() {
            frames.warn(format!(
                "method {method} made no caustic light, although light that passes through the \
                 glass or mirrors lands where the camera sees it: render with method photons or \
                 reference"
            ));
        }
        for w in why {
            frames.warn(w);
        }
    }
    let wanted = check.unwrap_or(method.info().check) && method != Method::Reference;
    let done = frames
        .statistics
        .as_ref()
        .is_some_and(|s| s.get("check").is_some());
    if wanted && !done {
        let c = self_check(world, &mut frames, env)?;
        note_check(&mut frames, c.as_ref());
    }
    Ok(frames)
}

/// The self-check of a frame's caustics against a short reference on the receivers
/// ([`check::check_caustics`] with its default parameters), its time among the timings.
pub fn self_check(
    world: &World,
    frames: &mut Frames,
    env: &Env,
) -> Result<Option<check::Check>, MethodError> {
    let t = Instant::now();
    (env.progress)(0.99, "check");
    let c = check::check_caustics(
        world,
        frames.get(Component::Caustics),
        None,
        &check::CheckParams::default(),
        env.keep_going,
    )?;
    frames.timings.push(("check".into(), t.elapsed()));
    Ok(c)
}

/// Records a self-check in `frames` (its statistics' `check`, a note, and a warning when it is
/// over [`POOR_CHECK`]).
pub fn note_check(frames: &mut Frames, c: Option<&check::Check>) {
    frames.record(
        "check",
        serde_json::to_value(c).expect("a check serialises"),
    );
    match c {
        Some(c) if c.error > POOR_CHECK => {
            frames.warn(format!(
                "the caustics are {:.2} relative L1 from a short reference on the receivers \
                 (over {POOR_CHECK}): render with method auto or reference",
                c.error
            ));
            frames.notes.push(c.sentence());
        }
        Some(c) => frames.notes.push(c.sentence()),
        None => frames
            .notes
            .push("self-check: no caustic light on the receivers to check".into()),
    }
}
