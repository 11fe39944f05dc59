//! `caustica bake csl` and `caustica render --method csl --bake FILE`: the artifact is written,
//! read back and rendered; a corrupted artifact is refused with a message.

use crate::support::images::{self, read_frame};
use crate::support::{Cleanup, caustica, scenes, temp_dir};

#[test]
fn bake_then_render_with_the_artifact() {
    let dir = temp_dir("csl-cli");
    let _cleanup = Cleanup(dir.clone());
    let set = dir.join("sphere.csl");
    let scene = scenes::path("glass-sphere-directional");
    let scene = scene.to_str().unwrap();
    let out = caustica(&[
        "bake",
        "csl",
        scene,
        "--object",
        "glass",
        "--grid",
        "96",
        "--out",
        set.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("CSLs covering"), "{err}");
    let exr = dir.join("caustics.exr");
    let render = |bake: &std::path::Path| {
        caustica(&[
            "render",
            scene,
            "--method",
            "csl",
            "--bake",
            bake.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--component",
            "caustics",
            "--out",
            exr.to_str().unwrap(),
        ])
    };
    let out = render(&set);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let f = read_frame(&exr);
    assert_eq!((f.width, f.height), (64, 48));
    let peak = images::peak(&f);
    assert!(peak > 1.0, "a bright caustic: {peak}");

    let mut bytes = std::fs::read(&set).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    let bad = dir.join("bad.csl");
    std::fs::write(&bad, bytes).unwrap();
    let out = render(&bad);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("checksum"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `caustica bake csl --dynamic` writes a dynamic bake that `render --method csl --bake` turns
/// into the set of the scene's light; a dynamic bake of another object is refused by name.
#[test]
fn dynamic_bake_then_render_with_the_artifact() {
    let dir = temp_dir("csl-dyn-cli");
    let _cleanup = Cleanup(dir.clone());
    let set = dir.join("sphere.csld");
    let scene = scenes::path("glass-sphere-directional");
    let scene = scene.to_str().unwrap();
    let out = caustica(&[
        "bake",
        "csl",
        scene,
        "--dynamic",
        "--subdivisions",
        "0",
        "--grid",
        "64",
        "--track-grid",
        "16",
        "--steps",
        "2",
        "--out",
        set.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("12 directions") && err.contains("30 edges"),
        "{err}"
    );
    let exr = dir.join("caustics.exr");
    let render = |s: &str| {
        caustica(&[
            "render",
            s,
            "--method",
            "csl",
            "--bake",
            set.to_str().unwrap(),
            "--width",
            "64",
            "--height",
            "48",
            "--component",
            "caustics",
            "--out",
            exr.to_str().unwrap(),
        ])
    };
    let out = render(scene);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("csl interpolate"), "{err}");
    let f = read_frame(&exr);
    let peak = images::peak(&f);
    assert!(peak > 1.0, "a bright caustic: {peak}");
    // The teapot scene's caustic object is another object.
    let out = render(scenes::path("glass-teapot").to_str().unwrap());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("dynamic bake of another object"), "{err}");
}
