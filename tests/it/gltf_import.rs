//! glTF import against real files: the malformed corpus in `tests/data/gltf-bad/` (Khronos
//! glTF-Validator and gltf-rs inputs), hostile inputs built here, and the bundled sample
//! assets in `scenes/assets/`.

use crate::support::{files_under, repo_path, scenes};
use caustica::scene::gltf::{GltfError, GltfImport, GltfLimits, import_gltf};
use caustica::scene::{AssetSource, DirSource, Limits, MapSource, Material};
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

fn corpus() -> PathBuf {
    repo_path("tests/data/gltf-bad")
}

fn assets_dir() -> PathBuf {
    repo_path("scenes/assets")
}

/// An asset source that counts what it is asked for (the work an import does on the side).
struct Counting<S> {
    inner: S,
    reads: AtomicUsize,
    bytes: AtomicUsize,
}

impl<S: AssetSource> Counting<S> {
    fn new(inner: S) -> Self {
        Counting {
            inner,
            reads: AtomicUsize::new(0),
            bytes: AtomicUsize::new(0),
        }
    }
}

impl<S: AssetSource> AssetSource for Counting<S> {
    fn read(&self, name: &str, max_bytes: usize) -> Result<Vec<u8>, String> {
        self.reads.fetch_add(1, Ordering::Relaxed);
        let r = self.inner.read(name, max_bytes);
        if let Ok(b) = &r {
            self.bytes.fetch_add(b.len(), Ordering::Relaxed);
        }
        r
    }
}

/// Import a file with its folder as the asset source.
fn import_file(path: &Path) -> Result<GltfImport, GltfError> {
    let bytes = std::fs::read(path).unwrap();
    let dir = DirSource(path.parent().unwrap().to_path_buf());
    import_gltf(&bytes, &GltfLimits::default(), Some(&dir))
}

fn bad(rel: &str) -> Result<GltfImport, GltfError> {
    import_file(&corpus().join(rel))
}

fn err_text(r: Result<GltfImport, GltfError>) -> String {
    match r {
        Ok(i) => panic!("expected an error, got Ok with {} parts", i.parts.len()),
        Err(e) => e.to_string(),
    }
}

fn triangles(i: &GltfImport) -> usize {
    i.parts.iter().map(|(m, _)| m.triangle_count()).sum()
}

#[test]
fn corpus_files_give_ok_or_err_never_panic() {
    let files = files_under(&corpus());
    assert!(
        files.len() >= 50,
        "corpus incomplete: {} files",
        files.len()
    );
    let limits = GltfLimits {
        max_nodes: 1000,
        max_triangles: 100_000,
        max_vertices: 100_000,
        max_texture_side: 1024,
        ..GltfLimits::default()
    };
    let mut gltf_files = 0;
    for f in &files {
        let bytes = std::fs::read(f).unwrap();
        let src = Counting::new(DirSource(f.parent().unwrap().to_path_buf()));
        // Every file goes in, reports and licences included: none may panic.
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            import_gltf(&bytes, &limits, Some(&src))
        }));
        let rel = f.strip_prefix(corpus()).unwrap().display().to_string();
        let r = r.unwrap_or_else(|_| panic!("{rel}: import panicked"));
        // Work bound: a few side reads of small files, bounded output.
        let reads = src.reads.load(Ordering::Relaxed);
        let read_bytes = src.bytes.load(Ordering::Relaxed);
        assert!(
            reads <= 8 && read_bytes <= 1 << 20,
            "{rel}: {reads} reads, {read_bytes} bytes"
        );
        match &r {
            Ok(i) => {
                assert!(triangles(i) <= limits.max_triangles);
                assert!(i.warnings.len() <= 101);
                println!(
                    "{rel}: Ok ({} parts, {} warnings: {:?})",
                    i.parts.len(),
                    i.warnings.len(),
                    i.warnings
                );
            }
            Err(e) => {
                assert!(
                    !matches!(e, GltfError::Panic(_)),
                    "{rel}: the parser panicked: {e}"
                );
                println!("{rel}: Err: {e}");
            }
        }
        if rel.ends_with(".gltf") || rel.ends_with(".glb") {
            gltf_files += 1;
        }
    }
    assert_eq!(gltf_files, 24);
}

#[test]
fn broken_glb_framing_is_an_error_about_glb() {
    for f in [
        "empty_file.glb",
        "zero_length.glb",
        "invalid_magic.glb",
        "truncated_chunk_header.glb",
        "truncated_chunk_data.glb",
        "length_mismatch.glb",
        "chunk_too_big.glb",
        "two_bin_chunks.glb",
        "unaligned_chunk.glb",
    ] {
        let e = err_text(bad(&format!("glTF-Validator/glb/{f}")));
        assert!(e.contains("GLB"), "{f}: {e}");
    }
    let e = err_text(bad("glTF-Validator/glb/two_bin_chunks.glb"));
    assert!(e.contains("first chunk must be JSON"), "{e}");
    let e = err_text(bad("glTF-Validator/glb/unaligned_chunk.glb"));
    assert!(e.contains("multiple of 4") || e.contains("declares"), "{e}");
}

#[test]
fn buffer_errors_name_the_buffer() {
    let e = err_text(bad("glTF-Validator/buffer/non_relative_uri.gltf"));
    assert!(
        e.contains("http://example.com/buffer.bin") && e.contains("buffer 0"),
        "{e}"
    );
    let e = err_text(bad("glTF-Validator/buffer/wrong_bytelength.glb"));
    assert!(e.contains("buffer 0") && e.contains("17"), "{e}");
    let e = err_text(bad("glTF-Validator/buffer_view/invalid_length.gltf"));
    assert!(
        e.contains("bufferView 0") && e.contains("out of bounds"),
        "{e}"
    );
    let e = err_text(bad("glTF-Validator/accessor/unresolved_bufferviews.gltf"));
    assert!(e.contains("accessor 0"), "{e}");
    let e = err_text(bad(
        "glTF-Validator/accessor/invalid_sparse_count_and_stride.gltf",
    ));
    assert!(e.contains("buffer 0"), "{e}");
}

#[test]
fn out_of_bounds_indices_are_refused() {
    let e = err_text(bad("glTF-Validator/mesh_data/index_buffer_oob.gltf"));
    assert!(e.contains("index") && e.contains("out of bounds"), "{e}");
    // The gltf-rs regression input has an accessor whose max has the wrong arity and no
    // asset field; whatever it yields, it must not be a panic.
    let r = bad("gltf-rs/minimal_accessor_invalid.gltf");
    assert!(!matches!(r, Err(GltfError::Panic(_))));
}

#[test]
fn node_loops_terminate_with_an_error() {
    let e = err_text(bad("glTF-Validator/node/node_loop_scene.gltf"));
    assert!(e.contains("loop"), "{e}");
    let e = err_text(bad("glTF-Validator/node/infinite_transform.gltf"));
    assert!(e.contains("finite") || e.contains("JSON"), "{e}");
}

#[test]
fn out_of_range_material_values_are_clamped_with_warnings() {
    let i = bad("glTF-Validator/ext/KHR_materials_ior/out_of_range.gltf").unwrap();
    assert_eq!(i.materials.len(), 2);
    for m in &i.materials {
        assert_eq!(m.ior, 1.0, "{m:?}");
    }
    let ior_warnings = i.warnings.iter().filter(|w| w.contains("ior")).count();
    assert_eq!(ior_warnings, 2, "{:?}", i.warnings);
    assert!(i.warnings[0].contains("material 0"), "{:?}", i.warnings);

    let i = bad("glTF-Validator/ext/KHR_materials_volume/out_of_range.gltf").unwrap();
    let m = &i.materials[0];
    assert_eq!(m.absorption, Vec3::ZERO);
    let w = i.warnings.join("\n");
    assert!(
        w.contains("attenuationColor") && w.contains("clamped"),
        "{w}"
    );
    assert!(w.contains("attenuationDistance"), "{w}");
    assert!(w.contains("thicknessFactor"), "{w}");
}

#[test]
fn other_corpus_files() {
    // A truncated PNG that no material uses: nothing decodes it.
    let i = bad("glTF-Validator/image/png_eos.gltf").unwrap();
    assert!(i.parts.is_empty());
    // A byte order mark is tolerated with a warning.
    let i = bad("glTF-Validator/json/bom.gltf").unwrap();
    assert!(i.warnings[0].contains("byte order mark"));
    let e = err_text(bad("glTF-Validator/json/invalid_syntax.gltf"));
    assert!(e.contains("JSON"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Hostile inputs built here

fn b64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in data.chunks(3) {
        let n = (u32::from(c[0]) << 16)
            | (u32::from(*c.get(1).unwrap_or(&0)) << 8)
            | u32::from(*c.get(2).unwrap_or(&0));
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

fn glb(json: &str, bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut chunks = Vec::new();
    chunks.extend((j.len() as u32).to_le_bytes());
    chunks.extend(b"JSON");
    chunks.extend(&j);
    if let Some(b) = bin {
        let mut b = b.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        chunks.extend((b.len() as u32).to_le_bytes());
        chunks.extend(b"BIN\0");
        chunks.extend(&b);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend((12 + chunks.len() as u32).to_le_bytes());
    out.extend(chunks);
    out
}

/// A unit quad (two triangles) as positions + u16 indices.
fn quad_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
        for x in p {
            b.extend(x.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend(i.to_le_bytes());
    }
    b
}

fn quad_gltf(extra_nodes: &str, scene_nodes: &str, extensions: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"byteLength":60,"uri":"data:application/octet-stream;base64,{}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"}},
                     {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "nodes":[{extra_nodes}],
        "scenes":[{{"nodes":[{scene_nodes}]}}]{extensions}}}"#,
        b64(&quad_bin())
    )
}

#[test]
fn embedded_quad_imports_with_computed_normals() {
    let json = quad_gltf(r#"{"mesh":0,"translation":[0,0,2]}"#, "0", "");
    let i = import_gltf(json.as_bytes(), &GltfLimits::default(), None).unwrap();
    assert_eq!(triangles(&i), 2);
    let (m, mat) = &i.parts[0];
    assert_eq!(
        *mat,
        Material::Diffuse {
            albedo: Vec3::splat(0.8)
        }
    );
    assert!(m.positions.iter().all(|p| p.z == 2.0));
    assert!(m.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    // The same as a GLB with a BIN chunk.
    let json = json.replace(
        &format!(
            r#""uri":"data:application/octet-stream;base64,{}""#,
            b64(&quad_bin())
        ),
        r#""x":0"#,
    );
    let i = import_gltf(&glb(&json, Some(&quad_bin())), &GltfLimits::default(), None).unwrap();
    assert_eq!(triangles(&i), 2);
}

#[test]
fn glb_declaring_4_gib_is_refused_without_allocating() {
    let mut g = glb(r#"{"asset":{"version":"2.0"}}"#, None);
    g[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = err_text(import_gltf(&g, &GltfLimits::default(), None));
    assert!(e.contains("GLB") && e.contains("4294967295"), "{e}");
    // A chunk declaring 4 GiB inside a correctly sized file.
    let mut g = glb(r#"{"asset":{"version":"2.0"}}"#, None);
    g[12..16].copy_from_slice(&(u32::MAX - 3).to_le_bytes());
    let e = err_text(import_gltf(&g, &GltfLimits::default(), None));
    assert!(e.contains("GLB") && e.contains("declares"), "{e}");
    // A buffer declaring 4 GiB.
    let g = glb(
        r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4294967296}]}"#,
        Some(&[0; 4]),
    );
    let e = err_text(import_gltf(&g, &GltfLimits::default(), None));
    assert!(e.contains("limit") && e.contains("buffer 0"), "{e}");
}

#[test]
fn huge_accessor_counts_are_refused() {
    let n = 1u64 << 31;
    // Backed by a buffer view: out of bounds.
    let json =
        quad_gltf(r#"{"mesh":0}"#, "0", "").replace(r#""count":4"#, &format!(r#""count":{n}"#));
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(
        e.contains("accessor 0") && e.contains("out of bounds"),
        "{e}"
    );
    // Without a buffer view (all zeros): refused by the vertex limit before allocating.
    let json = quad_gltf(r#"{"mesh":0}"#, "0", "").replace(
        r#"{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"}"#,
        &format!(r#"{{"componentType":5126,"count":{n},"type":"VEC3"}}"#),
    );
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(e.contains("limit") && e.contains(&n.to_string()), "{e}");
}

#[test]
fn escaping_and_absolute_uris_are_refused() {
    let dir = DirSource(corpus().join("glTF-Validator/buffer"));
    for uri in [
        "../../../etc/passwd",
        "file:///etc/passwd",
        "/etc/passwd",
        "%2e%2e/%2e%2e/etc/passwd",
        "https://example.com/x.bin",
        "bad%zzescape.bin",
    ] {
        let json = format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":4,"uri":"{uri}"}}]}}"#
        );
        let e = err_text(import_gltf(
            json.as_bytes(),
            &GltfLimits::default(),
            Some(&dir),
        ));
        assert!(e.contains(uri) && e.contains("buffer 0"), "{uri}: {e}");
        let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
        assert!(e.contains("buffer 0"), "{uri}: {e}");
    }
    // A relative URI with no asset source is refused too.
    let json = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":4,"uri":"a.bin"}]}"#;
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(e.contains("no asset source"), "{e}");
}

#[test]
fn deep_and_shared_node_graphs_are_capped() {
    let limits = GltfLimits::default();
    let depth = limits.max_depth + 10;
    let mut nodes: Vec<String> = (0..depth - 1)
        .map(|k| format!(r#"{{"children":[{}]}}"#, k + 1))
        .collect();
    nodes.push(r#"{"mesh":0}"#.into());
    let json = quad_gltf(&nodes.join(","), "0", "");
    let e = err_text(import_gltf(json.as_bytes(), &limits, None));
    assert!(
        e.contains("nested") && e.contains(&limits.max_depth.to_string()),
        "{e}"
    );
    let deeper = GltfLimits {
        max_depth: depth,
        ..GltfLimits::default()
    };
    assert_eq!(
        triangles(&import_gltf(json.as_bytes(), &deeper, None).unwrap()),
        2
    );

    // Each node names the next one twice: 2^40 paths if shared children were walked again.
    let mut nodes: Vec<String> = (0..40)
        .map(|k| format!(r#"{{"children":[{0},{0}]}}"#, k + 1))
        .collect();
    nodes.push(r#"{"mesh":0}"#.into());
    let json = quad_gltf(&nodes.join(","), "0", "");
    let e = err_text(import_gltf(json.as_bytes(), &limits, None));
    assert!(e.contains("reached twice"), "{e}");
}

#[test]
fn instancing_counts_against_the_triangle_limit() {
    let nodes: Vec<String> = (0..10)
        .map(|k| format!(r#"{{"mesh":0,"translation":[{k},0,0]}}"#))
        .collect();
    let scene: Vec<String> = (0..10).map(|k| k.to_string()).collect();
    let json = quad_gltf(&nodes.join(","), &scene.join(","), "");
    let limits = GltfLimits {
        max_triangles: 15,
        ..GltfLimits::default()
    };
    let e = err_text(import_gltf(json.as_bytes(), &limits, None));
    assert!(e.contains("instancing"), "{e}");
    assert_eq!(
        triangles(&import_gltf(json.as_bytes(), &GltfLimits::default(), None).unwrap()),
        20
    );
}

#[test]
fn lights_and_cameras_follow_their_nodes() {
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let nodes = format!(
        r#"{{"mesh":0}},
        {{"translation":[0,2,0],"rotation":[{m},0,0,{s}],
          "extensions":{{"KHR_lights_punctual":{{"light":0}}}}}},
        {{"extensions":{{"KHR_lights_punctual":{{"light":1}}}}}},
        {{"translation":[0,0,5],"camera":0}}"#,
        m = -s
    );
    let ext = r#","extensionsUsed":["KHR_lights_punctual"],
        "extensions":{"KHR_lights_punctual":{"lights":[
            {"type":"spot","intensity":683,"color":[1,0.5,0],"spot":{"innerConeAngle":0.2,"outerConeAngle":0.4}},
            {"type":"directional","intensity":1366}]}},
        "cameras":[{"type":"perspective","perspective":{"yfov":0.5,"aspectRatio":1.5,"znear":0.1}}]"#;
    let json = quad_gltf(&nodes, "0,1,2,3", ext);
    let i = import_gltf(json.as_bytes(), &GltfLimits::default(), None).unwrap();
    assert_eq!(i.lights.len(), 2);
    match &i.lights[0] {
        caustica::scene::Light::Spot {
            position,
            direction,
            intensity,
            cutoff,
            beam_width,
        } => {
            assert!((*position - Vec3::new(0., 2., 0.)).length() < 1e-6);
            // Rotated -90° about X: local -Z points down.
            assert!((*direction - Vec3::NEG_Y).length() < 1e-5, "{direction}");
            assert!((*intensity - Vec3::new(1., 0.5, 0.)).length() < 1e-6);
            assert_eq!((*cutoff, *beam_width), (0.4, 0.2));
        }
        l => panic!("{l:?}"),
    }
    match &i.lights[1] {
        caustica::scene::Light::Directional {
            direction,
            irradiance,
            ..
        } => {
            assert_eq!(*direction, Vec3::NEG_Z);
            assert!((*irradiance - Vec3::splat(2.0)).length() < 1e-6);
        }
        l => panic!("{l:?}"),
    }
    let c = &i.cameras[0];
    assert_eq!((c.width, c.height), (384, 256));
    assert!((c.fov_y - 0.5f32.to_degrees()).abs() < 1e-4);
    assert_eq!(c.eye, Vec3::new(0., 0., 5.));
    assert_eq!(c.target, Vec3::new(0., 0., 4.));
    assert_eq!(c.up, Vec3::Y);
}

#[test]
fn strips_and_sparse_accessors() {
    // The quad's vertices drawn as a non-indexed strip, with a sparse accessor moving vertex 0
    // onto vertex 2's value (1, 1, 0): sparse index 0 is the first byte of the index view,
    // the value is read from vertex 2's bytes.
    let json = quad_gltf(r#"{"mesh":0}"#, "0", "")
        .replace(r#""indices":1"#, r#""mode":5"#)
        .replace(
            r#"{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3"}"#,
            r#"{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3",
               "sparse":{"count":1,"indices":{"bufferView":2,"componentType":5121},
                         "values":{"bufferView":3}}}"#,
        )
        .replace(
            r#"{"buffer":0,"byteOffset":48,"byteLength":12}"#,
            r#"{"buffer":0,"byteOffset":48,"byteLength":12},
               {"buffer":0,"byteOffset":48,"byteLength":1},
               {"buffer":0,"byteOffset":24,"byteLength":12}"#,
        );
    let i = import_gltf(json.as_bytes(), &GltfLimits::default(), None).unwrap();
    let m = &i.parts[0].0;
    assert_eq!(m.indices, vec![[0, 1, 2], [1, 3, 2]]);
    assert_eq!(m.positions[0], Vec3::new(1., 1., 0.));
    // Triangle 0 became degenerate: kept, with a warning.
    assert!(
        i.warnings
            .iter()
            .any(|w| w.contains("1 of 2 triangles are degenerate")),
        "{:?}",
        i.warnings
    );
    // A sparse index past the accessor's count is refused.
    let e = err_text(import_gltf(
        json.replace(r#""count":4,"type":"VEC3""#, r#""count":1,"type":"VEC3""#)
            .replace(
                r#""byteOffset":48,"byteLength":1}"#,
                r#""byteOffset":50,"byteLength":1}"#,
            )
            .as_bytes(),
        &GltfLimits::default(),
        None,
    ));
    assert!(e.contains("sparse index 1 is out of bounds"), "{e}");
}

#[test]
fn wrong_accessor_types_are_refused() {
    let base = quad_gltf(r#"{"mesh":0}"#, "0", "");
    let json = base.replace(
        r#""componentType":5126,"count":4,"type":"VEC3""#,
        r#""componentType":5123,"count":4,"type":"VEC3""#,
    );
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(e.contains("POSITION") && e.contains("VEC3 FLOAT"), "{e}");
    let json = base.replace(
        r#""componentType":5123,"count":6,"type":"SCALAR""#,
        r#""componentType":5126,"count":3,"type":"SCALAR""#,
    );
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(e.contains("indices") && e.contains("unsigned"), "{e}");
    let json = base.replace(r#""type":"VEC3"}"#, r#""type":"VEC3","normalized":true}"#);
    let e = err_text(import_gltf(json.as_bytes(), &GltfLimits::default(), None));
    assert!(e.contains("not normalized"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Good assets

fn good(name: &str) -> GltfImport {
    let i = import_file(&assets_dir().join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    for (m, _) in &i.parts {
        assert_eq!(m.normals.len(), m.positions.len(), "{name}");
        for n in &m.normals {
            assert!(
                n.is_finite() && (n.length() - 1.0).abs() < 1e-4,
                "{name}: normal {n}"
            );
        }
        assert!(m.positions.iter().all(|p| p.is_finite()), "{name}");
    }
    i
}

#[test]
fn sample_assets_have_the_documented_triangle_counts() {
    for (name, tris) in [
        ("teapot-glass.glb", 6_320),
        ("GlassVaseFlowers.glb", 14_036),
        ("AttenuationTest.glb", 292),
        ("Box.glb", 12),
        ("Suzanne-glTF/Suzanne.gltf", 3_936),
    ] {
        let i = good(name);
        assert_eq!(triangles(&i), tris, "{name}");
        println!("{name}: {} parts, warnings {:?}", i.parts.len(), i.warnings);
    }
}

#[test]
fn sample_asset_materials() {
    let t = good("teapot-glass.glb");
    for (_, m) in &t.parts {
        match m {
            Material::Dielectric { ior, absorption } => {
                assert_eq!(*ior, 1.5);
                // attenuationColor [0.9, 0.95, 1] over 8.2048 units.
                assert!((absorption.x - 0.9f32.ln().abs() / 8.204807).abs() < 1e-6);
                assert_eq!(absorption.z, 0.0);
            }
            m => panic!("teapot: {m:?}"),
        }
    }

    let v = good("GlassVaseFlowers.glb");
    // The vase's transmission material has no attenuation: clear glass.
    assert!(v.parts.iter().any(|(_, m)| matches!(m, Material::Dielectric { ior, absorption } if *ior == 1.5 && *absorption == Vec3::ZERO)));
    assert!(v.parts.iter().any(|(_, m)| !m.is_specular()));

    let a = good("AttenuationTest.glb");
    let absorbing = a
        .parts
        .iter()
        .filter(|(_, m)| matches!(m, Material::Dielectric { absorption, .. } if absorption.min_element() > 0.0))
        .count();
    assert!(absorbing >= 10, "{absorbing}");
    // attenuationColor [0.1, 0.5, 0.9] at distance 1 → -ln c per unit.
    assert!(a.materials.iter().any(|m| {
        (m.absorption - -Vec3::new(0.1f32.ln(), 0.5f32.ln(), 0.9f32.ln())).length() < 1e-4
    }));

    let b = good("Box.glb");
    for (_, m) in &b.parts {
        assert!(
            matches!(m, Material::Diffuse { .. } | Material::Glossy { .. }),
            "{m:?}"
        );
    }

    // Suzanne's base colour comes from its texture (the factor is 1).
    let s = good("Suzanne-glTF/Suzanne.gltf");
    let base = s.materials[0].base_color;
    assert!(
        base.max_element() < 1.0 && base.min_element() > 0.0,
        "{base}"
    );
    assert!(
        s.warnings.iter().all(|w| !w.contains("texture")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn suzanne_through_an_in_memory_source() {
    let dir = assets_dir().join("Suzanne-glTF");
    let mut files = HashMap::new();
    for f in [
        "Suzanne.bin",
        "Suzanne_BaseColor.png",
        "Suzanne_MetallicRoughness.png",
    ] {
        files.insert(f.to_string(), std::fs::read(dir.join(f)).unwrap());
    }
    let bytes = std::fs::read(dir.join("Suzanne.gltf")).unwrap();
    let i = import_gltf(&bytes, &GltfLimits::default(), Some(&MapSource(files))).unwrap();
    assert_eq!(triangles(&i), 3_936);
    // Without the .bin it is an error naming the buffer and file.
    let e = err_text(import_gltf(
        &bytes,
        &GltfLimits::default(),
        Some(&MapSource::default()),
    ));
    assert!(e.contains("buffer 0") && e.contains("Suzanne.bin"), "{e}");
}

#[test]
fn scene_files_with_gltf_load() {
    let w = scenes::load("glass-teapot");
    let teapot = w.object("teapot").unwrap();
    assert_eq!(teapot.triangle_count(), 6_320);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in &teapot.parts {
        assert!(matches!(
            w.materials[p.material as usize],
            Material::Dielectric { .. }
        ));
        for v in &p.mesh.positions {
            let q = teapot.transform.transform_point3(*v);
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    assert!(
        lo.y.abs() < 0.01 && (hi.y - lo.y - 1.0).abs() < 0.05,
        "teapot bounds {lo} {hi}"
    );
    assert!(lo.x > -4.0 && hi.x < 4.0 && lo.z > -4.0 && hi.z < 4.0);
    assert_eq!((w.camera.width, w.camera.height), (256, 256));

    let w = scenes::load("glass-vase");
    let vase = w.object("vase").unwrap();
    let table = w.object("table").unwrap();
    assert_eq!(vase.triangle_count(), 14_036);
    let table_top = table.parts[0]
        .mesh
        .positions
        .iter()
        .map(|v| table.transform.transform_point3(*v).y)
        .fold(f32::NEG_INFINITY, f32::max);
    let mut vlo = f32::INFINITY;
    for p in &vase.parts {
        for v in &p.mesh.positions {
            vlo = vlo.min(vase.transform.transform_point3(*v).y);
        }
    }
    // The vase stands on the table top.
    assert!(
        (vlo - table_top).abs() < 0.01,
        "vase bottom {vlo}, table top {table_top}"
    );
    assert!(w.lights.iter().any(|l| l.kind() == "spot"));
}

#[test]
fn gltf_in_a_subfolder_finds_its_files() {
    let json = r#"{
        "camera": {"eye": [0, 1, 4], "target": [0, 0, 0]},
        "lights": [{"type": "point", "position": [0, 3, 3], "intensity": 10}],
        "objects": [{"name": "suzanne", "shape": {"type": "gltf", "path": "assets/Suzanne-glTF/Suzanne.gltf"}}]
    }"#;
    let desc = caustica::scene::parse_scene(json.as_bytes()).unwrap();
    let w = caustica::scene::resolve(&desc, &DirSource(repo_path("scenes")), &Limits::default())
        .unwrap();
    assert_eq!(w.triangle_count(), 3_936);
}
