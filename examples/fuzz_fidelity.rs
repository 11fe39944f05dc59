//! Fidelity fuzzing: `auto` on random scenes nobody tuned a method on
//! (`caustica::scene::random`), against the reference (`caustica::methods::fuzz`). For each
//! seed it prints the scene, the method `auto` used, relative L1 and flux ratio of the total
//! and of the caustics over the floor (3×3 blur), the self-check's estimate where it ran, and
//! whether the frame passes (total ≤ 0.15 relative L1, flux within 5 %).
//!
//! ```sh
//! cargo run --release --example fuzz_fidelity -- [FIRST_SEED] [SEEDS] [SIZE] [PHOTONS]
//! ```
//! (defaults 0, 40, 128, 4000000; the CI test, `tests/it/fuzz_fidelity.rs`, runs a smaller
//! set at 96².) With `FUZZ_DUMP=folder` it writes both frames of each seed as EXRs there.

use caustica::frame::Component;
use caustica::methods::local::LocalGpu;
use caustica::methods::{ArtifactStore, Env, fuzz};

fn main() -> anyhow::Result<()> {
    let arg = |i: usize, d: u64| -> u64 {
        std::env::args()
            .nth(i)
            .and_then(|a| a.parse().ok())
            .unwrap_or(d)
    };
    let (first, n, size, photons) = (arg(1, 0), arg(2, 40), arg(3, 128) as u32, arg(4, 4_000_000));
    let scenes = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let gpu = LocalGpu::default();
    let store = ArtifactStore::from_env();
    let env = Env {
        progress: &|_, _| {},
        keep_going: &|| true,
        gpu: &gpu,
        store: &store,
    };
    println!("{}", fuzz::Row::HEADER);
    let mut failed = 0;
    for seed in first..first + n {
        let row = fuzz::run(seed, size, photons, &scenes, &env)?;
        eprintln!("seed {seed}: {}", row.frames.notes.join("; "));
        for (stage, d) in &row.frames.timings {
            eprintln!("  {stage} {:.0} ms", d.as_secs_f64() * 1e3);
        }
        if let Some(dir) = std::env::var_os("FUZZ_DUMP") {
            let dir = std::path::Path::new(&dir);
            std::fs::create_dir_all(dir)?;
            let t = &row.truth;
            let layers = [
                ("total", t.total()),
                ("direct", t.direct.clone()),
                ("caustics", t.caustics.clone()),
                ("indirect", t.indirect.clone()),
                ("specular", t.specular.clone()),
            ];
            let named: Vec<_> = layers.iter().map(|(n, f)| (*n, f)).collect();
            std::fs::write(
                dir.join(format!("{seed}-reference.exr")),
                caustica::encode::encode_exr_layers(&named)?,
            )?;
            std::fs::write(
                dir.join(format!("{seed}-auto.exr")),
                caustica::encode::encode_exr_layers(&row.frames.named_first(Component::Total))?,
            )?;
        }
        failed += usize::from(!row.ok());
        println!("{}", row.markdown());
    }
    println!(
        "{failed} of {n} frames outside {} / {} %",
        fuzz::MAX_TOTAL_L1,
        fuzz::MAX_FLUX_OFF * 100.0
    );
    Ok(())
}
