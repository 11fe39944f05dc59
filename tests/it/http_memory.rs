//! Memory under hostile uploads (issue: hardening): GLBs of a few megabytes whose
//! textures would decode to gigabytes, uploaded eight at a time to `caustica serve` running
//! under an address-space limit (`ulimit -v`). Each upload is answered (201 with warnings, or
//! 503 busy), `/healthz` answers throughout, and the process is alive at the end.

use crate::support::server::*;
use crate::support::{Cleanup, temp_dir};
use std::time::{Duration, Instant};

/// A PNG of `side`² RGBA pixels of one colour, written row by row (never held whole).
fn flat_png(side: u32) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, side, side);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut w = enc.write_header().unwrap();
        let mut s = w.stream_writer().unwrap();
        let row: Vec<u8> = [200u8, 120, 40, 255].repeat(side as usize);
        for _ in 0..side {
            std::io::Write::write_all(&mut s, &row).unwrap();
        }
        s.finish().unwrap();
    }
    out
}

/// A GLB with one triangle and four materials, each with its own base colour image: one
/// 8192² and three 4096² (about 1.2 GB decoded, with their RGB copies).
fn hostile_glb() -> Vec<u8> {
    let big = flat_png(8192);
    let small = flat_png(4096);
    let mut bin: Vec<u8> = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    let mut views = vec![serde_json::json!({"buffer": 0, "byteOffset": 0, "byteLength": 36})];
    let mut images = Vec::new();
    for png in [&big, &small, &small, &small] {
        let off = bin.len();
        bin.extend_from_slice(png);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        images.push(serde_json::json!({"bufferView": views.len(), "mimeType": "image/png"}));
        views.push(serde_json::json!({"buffer": 0, "byteOffset": off, "byteLength": png.len()}));
    }
    let json = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
        "images": images,
        "textures": (0..4).map(|i| serde_json::json!({"source": i})).collect::<Vec<_>>(),
        "materials": (0..4).map(|i| serde_json::json!({
            "pbrMetallicRoughness": {"baseColorTexture": {"index": i}}
        })).collect::<Vec<_>>(),
    });
    let mut js = serde_json::to_vec(&json).unwrap();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let total = 12 + 8 + js.len() + 8 + bin.len();
    let mut glb = Vec::with_capacity(total);
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(js.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&js);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    glb
}

fn vm_hwm_mib(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb >> 10)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn hostile_texture_uploads_in_parallel_do_not_kill_a_memory_limited_server() {
    let glb = hostile_glb();
    assert!(glb.len() < 4 << 20, "{} bytes", glb.len());
    let dir = temp_dir("memory");
    let _cleanup = Cleanup(dir.clone());
    // 3 GiB of address space: the idle server maps ~1.4 GiB (threads, the GPU driver); the
    // images of one of these uploads alone would take ~1.2 GiB more, eight at once ~10 GiB.
    let (child, base) = serve_under("ulimit -v 3145728", &dir);
    let pid = child.0.id();
    let c = client();
    let mut uploads = Vec::new();
    for _ in 0..8 {
        let (c, url, body) = (c.clone(), format!("{base}/v1/scenes"), glb.clone());
        uploads.push(tokio::spawn(async move {
            let r = c
                .post(url)
                .header("content-type", "model/gltf-binary")
                .body(body)
                .send()
                .await
                .expect("the server answers the upload");
            let status = r.status().as_u16();
            (status, r.json::<serde_json::Value>().await.unwrap())
        }));
    }
    let mut worst = Duration::ZERO;
    while uploads.iter().any(|u| !u.is_finished()) {
        let t = Instant::now();
        let (s, v) = get_json(&c, &format!("{base}/healthz")).await;
        worst = worst.max(t.elapsed());
        assert_eq!((s, &v["status"]), (200, &"ok".into()));
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    for u in uploads {
        let (status, v) = u.await.unwrap();
        match status {
            201 => {
                let w = v["warnings"].to_string();
                assert!(w.contains("image budget"), "{v}");
            }
            503 => assert!(v["detail"].as_str().unwrap().contains("decoding"), "{v}"),
            s => panic!("{s}: {v}"),
        }
    }
    let mut child = child;
    assert!(child.0.try_wait().unwrap().is_none(), "the server died");
    eprintln!(
        "8 hostile uploads: peak resident {} MiB, worst /healthz {worst:?}",
        vm_hwm_mib(pid).unwrap_or(0)
    );
    sigterm(&child.0);
    assert!(child.0.wait().unwrap().success());
}
