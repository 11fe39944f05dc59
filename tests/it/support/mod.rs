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

/// A command-line tool from PyPI: the one the environment variable `var` names, else `exe` on
/// the PATH, else `exe` from a virtual environment under `target/` made for it (needs `python3`
/// with `venv`, and PyPI) with `requirement` installed.
pub fn python_tool(var: &str, exe: &str, requirement: &str) -> PathBuf {
    if let Some(p) = std::env::var_os(var) {
        return PathBuf::from(p);
    }
    let on_path = Command::new(exe)
        .arg("--help")
        .output()
        .is_ok_and(|o| o.status.success());
    if on_path {
        return PathBuf::from(exe);
    }
    let venv = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join(format!("venv-{exe}"));
    let path = venv.join("bin").join(exe);
    // One test at a time makes a given environment.
    static MAKING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one = MAKING.lock().unwrap_or_else(|e| e.into_inner());
    if !path.exists() {
        let run = |c: &mut Command| {
            let out = c.output().unwrap_or_else(|e| panic!("{c:?}: {e}"));
            assert!(
                out.status.success(),
                "{c:?} failed (python3 with venv, and PyPI, are needed to install {requirement}): {}",
                String::from_utf8_lossy(&out.stderr)
            );
        };
        run(Command::new("python3").args(["-m", "venv"]).arg(&venv));
        run(Command::new(venv.join("bin/pip")).args(["install", "--quiet", requirement]));
    }
    path
}
