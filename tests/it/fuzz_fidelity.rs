//! Fidelity fuzzing in CI: `auto` on random scenes nobody tuned a method on (glass or mirror,
//! a glTF asset or a procedural shape at a random size and rotation on a floor, under a random
//! directional, spot, point or sun-and-sky light, seen by a random camera;
//! `caustica::scene::random`), each against a reference render of it
//! (`caustica::methods::fuzz`). Every frame must be within 0.15 relative L1 of the reference's
//! total over the floor with its flux within 5 % (where `auto` declined its pick and rendered
//! with the reference, that frame too), and say what made it and why. The table is printed
//! (`--nocapture`).
//!
//! Sized for CI: 12 seeds at 96², references of 1 M caustic photons; the larger set is
//! `examples/fuzz_fidelity.rs` (its figures in docs/accuracy.md).

use crate::support::{gpu, repo_path, temp_dir};
use caustica::methods::local::LocalGpu;
use caustica::methods::{ArtifactStore, Env, fuzz};

#[test]
fn auto_is_within_fifteen_percent_of_the_reference_on_random_scenes() {
    gpu::ensure_runtime_dir();
    let gpu = LocalGpu::default();
    let store = ArtifactStore::new(temp_dir("fuzz-fidelity"));
    let env = Env {
        progress: &|_, _| {},
        keep_going: &|| true,
        gpu: &gpu,
        store: &store,
    };
    let scenes = repo_path("scenes");
    let mut table = vec![fuzz::Row::HEADER.to_string()];
    let mut failed = Vec::new();
    for seed in 0..12 {
        let row = fuzz::run(seed, 96, 1 << 20, &scenes, &env).expect("renders");
        table.push(row.markdown());
        // Every frame says what made it and why (the reference too, where auto declined).
        let auto = row.frames.statistics.as_ref().and_then(|s| s.get("auto"));
        assert!(
            auto.and_then(|a| a.get("reason")).is_some(),
            "seed {seed}: no reason recorded for the pick"
        );
        if !row.ok() {
            failed.push(row.drawn.to_string());
        }
    }
    eprintln!("{}", table.join("\n"));
    assert!(failed.is_empty(), "outside 0.15 / 5 %: {failed:?}");
}
