//! Writes one object of a scene, as our loader resolves it (world space: transform applied,
//! smooth vertex normals), to a binary little-endian PLY that Mitsuba 3's `ply` shape reads.
//! Used by `tests/data/mitsuba/mirror_ring_env.py` to give Mitsuba our exact mesh:
//!
//!     cargo run --example export_ply -- scenes/mirror-ring-env.json ring ring.ply

use std::io::Write;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, scene, object, out] = args.as_slice() else {
        return Err("usage: export_ply SCENE.json OBJECT OUT.ply".into());
    };
    let world = caustica::scene::load_scene_file(scene.as_ref(), &Default::default())?;
    let o = world
        .object(object)
        .ok_or_else(|| format!("no object {object}"))?;
    let (mut pos, mut nrm, mut tris) = (Vec::new(), Vec::new(), Vec::new());
    for p in &o.parts {
        let m = p.mesh.transformed(o.transform);
        let base = pos.len() as u32;
        pos.extend(m.positions);
        nrm.extend(m.normals);
        tris.extend(m.indices.iter().map(|t| t.map(|i| i + base)));
    }
    let mut f = std::io::BufWriter::new(std::fs::File::create(out)?);
    write!(
        f,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        pos.len(),
        tris.len()
    )?;
    for (p, n) in pos.iter().zip(&nrm) {
        for v in [p.x, p.y, p.z, n.x, n.y, n.z] {
            f.write_all(&v.to_le_bytes())?;
        }
    }
    for t in &tris {
        f.write_all(&[3u8])?;
        for i in t {
            f.write_all(&(*i as i32).to_le_bytes())?;
        }
    }
    println!(
        "{}: {} vertices, {} triangles -> {out}",
        o.name,
        pos.len(),
        tris.len()
    );
    Ok(())
}
