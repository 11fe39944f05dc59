//! Mesh primitives to triangles in the mesh's local frame. Triangle lists, strips and fans are
//! triangulated (points and lines have no surface and are skipped with a warning); positions
//! must be finite, indices in bounds and not every triangle degenerate; normals are read when
//! they are usable and recomputed otherwise. Each mesh is decoded once and its primitives are
//! shared by the nodes that instance it.

use super::accessors::{read_indices, read_vec3};
use super::{Doc, GltfError, State, invalid};
use crate::scene::world::Mesh;
use glam::Vec3;
use gltf::json;
use json::mesh::{Mode, Semantic};
use json::validation::Checked;

/// One decoded primitive in the mesh's local frame.
pub(super) struct Prim {
    pub(super) mesh: Mesh,
    pub(super) material: Option<usize>,
}

fn triangulate(mode: Mode, idx: &[u32], what: &str, st: &mut State) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => {
            if !idx.len().is_multiple_of(3) {
                st.warn(format!(
                    "{what}: {} indices is not a multiple of 3; the last {} ignored",
                    idx.len(),
                    idx.len() % 3
                ));
            }
            idx.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect()
        }
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i], idx[i + 2], idx[i + 1]]
                }
            })
            // Repeated indices stitch strips together; they are not triangles.
            .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
            .collect(),
        Mode::TriangleFan => (0..idx.len().saturating_sub(2))
            .map(|i| [idx[i + 1], idx[i + 2], idx[0]])
            .collect(),
        _ => Vec::new(),
    }
}

fn decode_primitive(
    doc: &Doc,
    st: &mut State,
    m: usize,
    p: usize,
    prim: &json::mesh::Primitive,
) -> Result<Option<Prim>, GltfError> {
    let what = format!("mesh {m} primitive {p}");
    let mode = match &prim.mode {
        Checked::Valid(md) => *md,
        Checked::Invalid => {
            st.warn(format!("{what}: unknown mode; skipped"));
            return Ok(None);
        }
    };
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        st.warn(format!("{what}: mode {mode:?} has no surface; skipped"));
        return Ok(None);
    }
    if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
        st.warn(format!("{what}: morph targets ignored"));
    }
    if let Some(mat) = prim.material
        && mat.value() >= doc.root.materials.len()
    {
        return Err(invalid(format!(
            "{what}: material {} does not exist",
            mat.value()
        )));
    }
    let Some(pos) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) else {
        st.warn(format!("{what}: no POSITION attribute; skipped"));
        return Ok(None);
    };
    let positions = read_vec3(doc, st, pos.value(), &format!("{what} POSITION"))?;
    if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
        return Err(invalid(format!(
            "{what}: POSITION of vertex {k} is not finite"
        )));
    }
    let n = positions.len();
    let idx: Vec<u32> = match prim.indices {
        Some(i) => {
            let idx = read_indices(doc, st, i.value(), &format!("{what} indices"))?;
            if let Some(k) = idx.iter().position(|&x| x as usize >= n) {
                return Err(invalid(format!(
                    "{what}: index value {} at position {k} is out of bounds: the primitive has {n} vertices",
                    idx[k]
                )));
            }
            idx
        }
        None => (0..n as u32).collect(),
    };
    let tris = triangulate(mode, &idx, &what, st);
    drop(idx);
    if tris.is_empty() {
        st.warn(format!("{what}: no triangles; skipped"));
        return Ok(None);
    }
    let degenerate = tris
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            (b - a).cross(c - a).length_squared() == 0.0
        })
        .count();
    if degenerate == tris.len() {
        return Err(invalid(format!(
            "{what}: all {} triangles are degenerate (zero area)",
            tris.len()
        )));
    }
    if degenerate > 0 {
        st.warn(format!(
            "{what}: {degenerate} of {} triangles are degenerate (zero area)",
            tris.len()
        ));
    }
    let normals = match prim.attributes.get(&Checked::Valid(Semantic::Normals)) {
        Some(acc) => {
            let nr = read_vec3(doc, st, acc.value(), &format!("{what} NORMAL"))?;
            if nr.len() != n {
                return Err(invalid(format!(
                    "{what}: NORMAL has {} entries but POSITION has {n}",
                    nr.len()
                )));
            }
            if nr
                .iter()
                .all(|v| v.is_finite() && v.length_squared() > 1e-12)
            {
                Some(nr.into_iter().map(Vec3::normalize).collect())
            } else {
                st.warn(format!(
                    "{what}: NORMAL has zero or non-finite vectors; normals recomputed"
                ));
                None
            }
        }
        None => None,
    };
    let mut mesh = Mesh {
        positions,
        normals: normals.clone().unwrap_or_default(),
        indices: tris,
    };
    if normals.is_none() {
        mesh.compute_normals();
    }
    Ok(Some(Prim {
        mesh,
        material: prim.material.map(|i| i.value()),
    }))
}

pub(super) fn decode_mesh(doc: &Doc, st: &mut State, m: usize) -> Result<Vec<Prim>, GltfError> {
    let mesh = doc
        .root
        .meshes
        .get(m)
        .ok_or_else(|| invalid(format!("mesh {m} does not exist")))?;
    let mut out = Vec::new();
    for (p, prim) in mesh.primitives.iter().enumerate() {
        if let Some(d) = decode_primitive(doc, st, m, p, prim)? {
            out.push(d);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::gltf::GltfLimits;

    #[test]
    fn strips_and_fans() {
        let mut st = State {
            limits: &GltfLimits::default(),
            assets: None,
            warnings: vec![],
            suppressed: 0,
            decoded: 0,
            image_bytes_left: 0,
        };
        let strip = triangulate(Mode::TriangleStrip, &[0, 1, 2, 3], "t", &mut st);
        assert_eq!(strip, vec![[0, 1, 2], [1, 3, 2]]);
        let fan = triangulate(Mode::TriangleFan, &[0, 1, 2, 3], "t", &mut st);
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
    }
}
