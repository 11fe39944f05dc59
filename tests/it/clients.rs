//! The generated Python client (`clients/python`: `caustica_client` from openapi-python-client
//! and the thin `caustica` layer) runs its end-to-end script against a real server: upload a
//! GLB and a scene, render PNG and EXR, a csl bake to completion with progress, a canceled bake,
//! lists, a problem raised as an exception. Needs python3 with httpx and attrs (Debian:
//! python3-httpx, python3-attr, python3-dateutil; `.ci/run` installs them).

use crate::support::repo_path;
use crate::support::server::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_python_client_passes_its_end_to_end_script() {
    let spec = std::fs::read(repo_path("api/openapi.yaml")).unwrap();
    let recorded = std::fs::read_to_string(repo_path("clients/python/SPEC_SHA256")).unwrap();
    assert_eq!(
        recorded.trim(),
        caustica::jobs::scenes::sha256_hex(&spec),
        "clients/python was generated from another api/openapi.yaml: run clients/python/generate.sh"
    );
    let srv = Server::start("python-client", |_, _| {}).await;
    let base = srv.base.clone();
    let out = tokio::task::spawn_blocking(move || {
        // Debian's interpreter, where apt installs the client's packages; else the one on PATH.
        let python = if std::path::Path::new("/usr/bin/python3").exists() {
            "/usr/bin/python3"
        } else {
            "python3"
        };
        std::process::Command::new(python)
            .arg(repo_path("clients/python/e2e.py"))
            .arg(base)
            .arg(repo_path("scenes/assets/Box.glb"))
            .arg(repo_path("scenes/glass-sphere-directional.json"))
            .env("PYTHONPATH", repo_path("clients/python"))
            .env("PYTHONDONTWRITEBYTECODE", "1")
            .output()
            .expect("python3 runs (install python3, python3-httpx, python3-attr, python3-dateutil)")
    })
    .await
    .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "the Python end-to-end script failed:\n{text}"
    );
    assert!(text.contains("e2e: all passed"), "{text}");
    // Every answer the client got was checked against the spec.
    assert!(srv.contract.checked() >= 15, "{}", srv.contract.checked());
    srv.stop().await;
}
