//! The clients generated from the spec run their end-to-end scripts against a real server:
//! upload a GLB and a scene, render PNG and EXR, a csl bake to completion with progress, a
//! canceled bake, lists, a problem raised as an exception. Every answer they get is checked
//! against the spec too.
//!
//! - Python (`clients/python`: `caustica_client` from openapi-python-client and the thin
//!   `caustica` layer) needs python3 with httpx and attrs (Debian: python3-httpx, python3-attr,
//!   python3-dateutil).
//! - TypeScript (`clients/typescript`: types from openapi-typescript and a thin fetch layer) is
//!   compiled with tsc and run with node (Debian: nodejs, node-typescript).
//!
//! `.ci/run` installs those packages.

use crate::support::server::*;
use crate::support::{Cleanup, repo_path, temp_dir};

/// Fails when `client` was generated from another `api/openapi.yaml` than the committed one.
fn assert_current(client: &str) {
    let spec = std::fs::read(repo_path("api/openapi.yaml")).unwrap();
    let recorded =
        std::fs::read_to_string(repo_path(format!("clients/{client}/SPEC_SHA256"))).unwrap();
    assert_eq!(
        recorded.trim(),
        caustica::jobs::scenes::sha256_hex(&spec),
        "clients/{client} was generated from another api/openapi.yaml: run \
         clients/{client}/generate.sh"
    );
}

/// Runs `cmd`, panicking with its output unless it succeeds and says "e2e: all passed".
async fn run_e2e(mut cmd: std::process::Command, what: &'static str) {
    let out = tokio::task::spawn_blocking(move || cmd.output())
        .await
        .unwrap()
        .unwrap_or_else(|e| panic!("{what} does not start ({e}): see this file's header"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{what} failed:\n{text}");
    assert!(text.contains("e2e: all passed"), "{text}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_python_client_passes_its_end_to_end_script() {
    assert_current("python");
    let srv = Server::start("python-client", |_, _| {}).await;
    // Debian's interpreter, where apt installs the client's packages; else the one on PATH.
    let python = if std::path::Path::new("/usr/bin/python3").exists() {
        "/usr/bin/python3"
    } else {
        "python3"
    };
    let mut cmd = std::process::Command::new(python);
    cmd.arg(repo_path("clients/python/e2e.py"))
        .arg(&srv.base)
        .arg(repo_path("scenes/assets/Box.glb"))
        .arg(repo_path("scenes/glass-sphere-directional.json"))
        .env("PYTHONPATH", repo_path("clients/python"))
        .env("PYTHONDONTWRITEBYTECODE", "1");
    run_e2e(cmd, "the Python end-to-end script").await;
    // Every answer the client got was checked against the spec.
    assert!(srv.contract.checked() >= 15, "{}", srv.contract.checked());
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_typescript_client_compiles_and_passes_its_end_to_end_script() {
    assert_current("typescript");
    // Compiled against the generated types: a spec change that breaks the layer fails here.
    let out = temp_dir("ts-client");
    let _cleanup = Cleanup(out.clone());
    let dir = repo_path("clients/typescript");
    let tsc = tokio::task::spawn_blocking({
        let out = out.clone();
        move || {
            std::process::Command::new("tsc")
                .arg("-p")
                .arg(&dir)
                .arg("--outDir")
                .arg(&out)
                .output()
        }
    })
    .await
    .unwrap()
    .expect("tsc runs (Debian: node-typescript)");
    assert!(
        tsc.status.success(),
        "tsc:\n{}{}",
        String::from_utf8_lossy(&tsc.stdout),
        String::from_utf8_lossy(&tsc.stderr)
    );
    std::fs::write(out.join("package.json"), r#"{"type": "module"}"#).unwrap();
    let srv = Server::start("ts-client", |_, _| {}).await;
    let mut cmd = std::process::Command::new("node");
    cmd.arg(out.join("e2e.js"))
        .arg(&srv.base)
        .arg(repo_path("scenes/assets/Box.glb"))
        .arg(repo_path("scenes/glass-sphere-directional.json"));
    run_e2e(cmd, "the TypeScript end-to-end script").await;
    assert!(srv.contract.checked() >= 15, "{}", srv.contract.checked());
    srv.stop().await;
}
