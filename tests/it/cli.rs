//! The command line contract: `caustica render SCENE --method M --out FILE` writes an image of
//! the asked size in the format of the extension, with the right numbers in it.

use crate::support::images::read_frame;
use crate::support::{Cleanup, caustica, caustica_command, scenes, temp_dir};

#[test]
fn render_writes_exr_and_png_of_the_asked_size() {
    let dir = temp_dir("cli");
    let _cleanup = Cleanup(dir.clone());
    let exr = dir.join("sphere.exr");
    let scene = scenes::path("glass-sphere-directional");
    let out = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--method",
        "reference",
        "--width",
        "64",
        "--height",
        "48",
        "--photons",
        "20000",
        "--spp",
        "1",
        "--component",
        "direct",
        "--out",
        exr.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("photons") && stderr.contains("camera"),
        "timings: {stderr}"
    );
    // Without a terminal, progress comes as plain lines (method: stage, per cent, time).
    assert!(
        stderr
            .lines()
            .any(|l| l.starts_with("reference: ") && l.contains("% (")),
        "progress lines: {stderr}"
    );
    let f = read_frame(&exr);
    assert_eq!((f.width, f.height), (64, 48));
    // Lit floor far from the sphere: ρ/π·E·cosθ = 0.6/π·3·1.2/√2.44.
    let expect = 0.6 / std::f32::consts::PI * 3.0 * 1.2 / 2.44f32.sqrt();
    let v = f.at(2, 45).x;
    assert!((v / expect - 1.0).abs() < 0.01, "{v} vs {expect}");

    let png = dir.join("sphere.png");
    let out = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--method",
        "direct",
        "--width",
        "33",
        "--height",
        "17",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (33, 17));
    // sRGB of 0.44 (clamp tone map) is 176.
    let p = img.get_pixel(1, 15).0[0];
    assert!((174..=178).contains(&p), "{p}");
}

#[test]
fn bad_inputs_fail_with_a_message_naming_the_problem() {
    let out = caustica(&["render", "no-such.json", "--out", "x.png"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no-such.json"));
    let dir = temp_dir("cli-bad");
    let _cleanup = Cleanup(dir.clone());
    let scene = dir.join("bad.json");
    std::fs::write(
        &scene,
        r#"{"camera": {"eye": [0,1,1], "target": [0,0,0]},
            "materials": {"m": {"type": "diffuse", "albedo": 2}},
            "objects": []}"#,
    )
    .unwrap();
    let out = caustica(&["render", scene.to_str().unwrap(), "--out", "x.png"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("materials.m.albedo"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = caustica(&[
        "render",
        scenes::path("glass-sphere-point").to_str().unwrap(),
        "--out",
        dir.join("x.tiff").to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains(".png or .exr"));

    // An --out that cannot be written is refused before the render starts (a render that ran
    // would print its progress lines: stderr is no terminal here), and a user's error prints
    // no backtrace even when asked for them.
    let scene = scenes::path("glass-sphere-directional");
    let out = caustica_command()
        .env("RUST_BACKTRACE", "1")
        .args([
            "render",
            scene.to_str().unwrap(),
            "--method",
            "reference",
            "--photons",
            "1000000000",
            "--out",
            dir.join("missing").join("x.exr").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("does not exist") && stderr.contains("missing"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("reference:"),
        "the render started: {stderr}"
    );
    assert!(!stderr.to_lowercase().contains("backtrace"), "{stderr}");
    assert!(stderr.starts_with("error: "), "{stderr}");

    // compare takes linear EXRs only.
    let png = dir.join("a.png");
    std::fs::write(&png, b"\x89PNG\r\n\x1a\n").unwrap();
    let out = caustica(&[
        "compare",
        png.to_str().unwrap(),
        png.to_str().unwrap(),
        "--scene",
        scene.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("not an OpenEXR image") && stderr.contains("a.png"),
        "{stderr}"
    );
}

/// Without `--method`, `auto` picks from the scene and says which and why; a method's flag
/// given to another method, and a bad value, are refused naming the flag.
#[test]
fn auto_is_the_default_and_flags_are_checked_by_the_methods_parser() {
    let dir = temp_dir("cli-auto");
    let _cleanup = Cleanup(dir.clone());
    // The canonical scene with its sphere painted diffuse: nothing casts caustics.
    let mut scene: serde_json::Value =
        serde_json::from_str(&scenes::text("glass-sphere-directional")).unwrap();
    scene["materials"]["glass"] = serde_json::json!({"type": "diffuse", "albedo": 0.5});
    let path = dir.join("matte.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let (a, d) = (out("auto.exr"), out("direct.exr"));
    let size = ["--width", "24", "--height", "16"];
    let r = caustica(&[&["render", path.to_str().unwrap(), "--out", &a], &size[..]].concat());
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{stderr}");
    assert!(
        stderr.contains("method direct (no object has a glass or mirror part"),
        "{stderr}"
    );
    let r = caustica(
        &[
            &[
                "render",
                path.to_str().unwrap(),
                "--method",
                "direct",
                "--out",
                &d,
            ],
            &size[..],
        ]
        .concat(),
    );
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert_eq!(read_frame(&a), read_frame(&d));
    // `--bake` is for csl and transport only; `--photons 0` is out of range.
    for (args, want) in [
        (
            vec!["--method", "reference", "--bake", "x.csl"],
            "--bake: only with method csl, transport",
        ),
        (
            vec!["--method", "reference", "--photons", "0"],
            "--photons: must lie in 1..=1e9",
        ),
    ] {
        let r = caustica(&[&["render", path.to_str().unwrap(), "--out", &a], &args[..]].concat());
        assert!(!r.status.success());
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(stderr.contains(want), "{stderr}");
    }
}

/// `render --repeat N` renders N frames on one renderer and prints each stage's median over the
/// N-1 after the warm-up, with the adapter; the image is still written, with the same numbers.
#[test]
fn repeat_prints_the_medians_of_the_frames_after_a_warm_up() {
    let dir = temp_dir("cli-repeat");
    let _cleanup = Cleanup(dir.clone());
    let png = dir.join("sphere.png");
    let scene = scenes::path("glass-sphere-directional");
    let out = caustica(&[
        "render",
        scene.to_str().unwrap(),
        "--method",
        "direct",
        "--width",
        "33",
        "--height",
        "17",
        "--repeat",
        "3",
        "--out",
        png.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let head = stdout
        .lines()
        .find(|l| l.starts_with("repeat method="))
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(
        head.contains("method=direct size=33x17 adapter=\""),
        "{head}"
    );
    assert!(head.ends_with("frames=2"), "{head}");
    let stages: Vec<(&str, f64)> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("repeat stage="))
        .map(|l| {
            let (name, ms) = l.split_once(" median_ms=").expect("name and median");
            (name, ms.parse().expect("a number"))
        })
        .collect();
    let frame = stages
        .iter()
        .find(|(n, _)| *n == "frame")
        .expect("a frame line");
    assert!(frame.1 > 0.0, "{stdout}");
    // The frame's own stages, each within the whole frame.
    assert!(stages.len() >= 2, "{stdout}");
    assert!(
        stages.iter().all(|(_, ms)| *ms <= frame.1 + 1e-3),
        "{stdout}"
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (33, 17));
    let p = img.get_pixel(1, 15).0[0];
    assert!((174..=178).contains(&p), "{p}");
    // Not with a sequence.
    let pool = scenes::path("pool-noon");
    let out = caustica(&[
        "render",
        pool.to_str().unwrap(),
        "--repeat",
        "2",
        "--frames",
        "2",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--repeat"));
}
