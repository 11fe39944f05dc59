//! The self-check (`methods::check`) reads the error `compare` measures against a converged
//! reference: frames off from the stored reference of the glass sphere's caustics by known
//! amounts (the reference itself, 0.6 of its light, moved 5 pixels, a light too bright at the
//! focus) are each estimated within 2× of their measured relative L1 on the receivers, at the
//! scene's 256².

use crate::support::{images, scenes};
use caustica::frame::Frame;
use caustica::methods::check::{CheckParams, check_caustics};
use caustica::reference::compare;
use caustica::trace::Accel;
use glam::Vec3;

fn moved(f: &Frame, dx: u32) -> Frame {
    let mut out = Frame::new(f.width, f.height);
    for y in 0..f.height {
        for x in dx..f.width {
            out.pixels[(y * f.width + x) as usize] = f.pixels[(y * f.width + x - dx) as usize];
        }
    }
    out
}

#[test]
fn the_self_check_is_within_twice_the_measured_error() {
    let world = scenes::load("glass-sphere-directional");
    let truth = images::stored_reference("glass-sphere-directional.caustics.64M.exr");
    let mask = compare::receivers_mask(&world, &Accel::build(&world));
    let peak = images::peak(&truth);
    let mut scaled = truth.clone();
    scaled.pixels.iter_mut().for_each(|p| *p *= 0.6);
    let mut focus = truth.clone();
    focus
        .pixels
        .iter_mut()
        .filter(|p| p.x > 0.2 * peak)
        .for_each(|p| *p *= Vec3::splat(3.0));
    for (what, frame) in [
        ("the reference", truth.clone()),
        ("0.6 of its light", scaled),
        ("moved 5 pixels", moved(&truth, 5)),
        ("3× at the focus", focus),
    ] {
        let measured = compare::compare(&frame, &truth, &mask).rel_l1;
        let c = check_caustics(&world, &frame, None, &CheckParams::default(), &|| true)
            .expect("checks")
            .expect("caustic light on the receivers");
        eprintln!("{what}: measured {measured:.3}, self-check {c:?}");
        // Below the short reference's noise a check cannot tell: there it reads at most that.
        let floor = 2.0 * c.noise.max(0.01);
        assert!(
            c.error <= (2.0 * measured).max(floor) && measured <= (2.0 * c.error).max(floor),
            "{what}: measured {measured}, self-check {}",
            c.error
        );
    }
}
