//! `caustica bake csl` and `caustica render --method csl --bake FILE`: the artifact is written,
//! read back and rendered; a corrupted artifact is refused with a message.

use caustica::encode::decode_frame;
use std::process::Command;

fn caustica(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_caustica"))
        .args(args)
        .output()
        .expect("runs")
}

#[test]
fn bake_then_render_with_the_artifact() {
    let dir = std::env::temp_dir().join(format!("caustica-csl-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let set = dir.join("sphere.csl");
    let scene = "scenes/glass-sphere-directional.json";
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
    let f = decode_frame(&std::fs::read(&exr).unwrap()).unwrap();
    assert_eq!((f.width, f.height), (64, 48));
    let peak = f.pixels.iter().map(|p| p.x).fold(0.0f32, f32::max);
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
    let _ = std::fs::remove_dir_all(&dir);
}

/// `caustica bake csl --dynamic` writes a dynamic bake that `render --method csl --bake` turns
/// into the set of the scene's light; a dynamic bake of another object is refused by name.
#[test]
fn dynamic_bake_then_render_with_the_artifact() {
    let dir = std::env::temp_dir().join(format!("caustica-csl-dyn-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let set = dir.join("sphere.csld");
    let scene = "scenes/glass-sphere-directional.json";
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
    let f = decode_frame(&std::fs::read(&exr).unwrap()).unwrap();
    let peak = f.pixels.iter().map(|p| p.x).fold(0.0f32, f32::max);
    assert!(peak > 1.0, "a bright caustic: {peak}");
    // The teapot scene's caustic object is another object.
    let out = render("scenes/glass-teapot.json");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("dynamic bake of another object"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
