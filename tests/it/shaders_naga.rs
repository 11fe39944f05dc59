//! Every WGSL file under shaders/ (and the tests' own, under tests/it/support/) parses and
//! validates with naga, after the same `#include` expansion the renderer does (reading the
//! included files from shaders/ on disk).

use crate::support::repo_path;
use caustica::render::shaders::{FILES, expand_includes};
use std::path::PathBuf;

fn shader_dir() -> PathBuf {
    repo_path("shaders")
}

fn validate(name: &str, src: &str) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(src).map_err(|e| e.emit_to_string(src))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .map_err(|e| format!("{name}: {}", e.emit_to_string(src)))?;
    Ok(())
}

#[test]
fn every_wgsl_file_validates() {
    let dir = shader_dir();
    let lookup = |n: &str| std::fs::read_to_string(dir.join(n)).ok();
    let wgsl_in = |dir: PathBuf| {
        let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "wgsl"))
            .collect();
        paths.sort();
        paths
    };
    let renderer = wgsl_in(dir.clone());
    assert!(renderer.len() >= 3, "expected shaders, found {renderer:?}");
    let tests = wgsl_in(repo_path("tests/it/support"));
    assert!(!tests.is_empty(), "the tests' compute shader");
    let mut failures = Vec::new();
    for path in renderer.iter().chain(&tests) {
        let name = &path.display().to_string();
        let raw = std::fs::read_to_string(path).unwrap();
        assert!(
            raw.trim_start().starts_with("//"),
            "{name} must start with a comment paragraph of intent"
        );
        match expand_includes(&raw, &lookup).and_then(|src| validate(name, &src)) {
            Ok(()) => {}
            Err(e) => failures.push(format!("{name}: {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn embedded_shaders_match_the_files() {
    let dir = shader_dir();
    for (name, text) in FILES {
        let disk = std::fs::read_to_string(dir.join(name)).unwrap();
        assert_eq!(&disk, text, "{name}");
    }
    let count = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".wgsl")
        })
        .count();
    assert_eq!(
        count,
        FILES.len(),
        "every shader file is embedded in render::shaders::FILES"
    );
}

/// The transport shader a device without `SHADER_EARLY_DEPTH_TEST` gets validates without that
/// capability, and no longer forces the test; with the feature it is the file as written.
#[test]
fn the_transport_shader_without_early_depth_tests_validates_without_them() {
    use caustica::render::transport::select_source;
    let without = select_source(wgpu::Features::empty());
    assert!(!without.contains("early_depth_test"));
    let module = naga::front::wgsl::parse_str(&without).map_err(|e| e.emit_to_string(&without));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all() - naga::valid::Capabilities::EARLY_DEPTH_TEST,
    )
    .validate(&module.unwrap())
    .unwrap();
    let with = select_source(wgpu::Features::SHADER_EARLY_DEPTH_TEST);
    assert!(with.contains("@early_depth_test(force)"));
    assert_eq!(with, caustica::render::shaders::source("transport.wgsl"));
}
