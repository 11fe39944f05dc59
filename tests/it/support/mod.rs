//! What several test modules share: the server harness, the GPU context, the repository's
//! scenes and stored images, temporary directories, and the `caustica` binary.

use caustica::bake::Progress;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

pub mod contract;
pub mod csl_points;
pub mod gpu;
pub mod images;
pub mod pg;
pub mod scenes;
pub mod server;

/// `rel`, a path relative to the repository's root, wherever the tests run from.
pub fn repo_path(rel: impl AsRef<Path>) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A fresh, empty directory under the system temp dir, its name unique in this process and
/// across processes.
pub fn temp_dir(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "caustica-{name}-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::SeqCst)
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Removes its directory when dropped (also when the test fails).
pub struct Cleanup(pub PathBuf);

impl Drop for Cleanup {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Every file under `dir`, depth first, each directory's entries in sorted order.
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, &mut out);
    out
}

/// The `caustica` binary cargo built for these tests, as a command to add arguments to.
pub fn caustica_command() -> Command {
    Command::new(env!("CARGO_BIN_EXE_caustica"))
}

/// Runs `caustica ARGS` to completion.
pub fn caustica(args: &[&str]) -> Output {
    caustica_command().args(args).output().expect("runs")
}

/// A bake progress callback that never cancels.
pub fn quiet(_: Progress) -> bool {
    true
}
