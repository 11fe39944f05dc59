//! The scene graph. The nodes of the default scene (or scene 0, or every parentless node) are
//! walked iteratively with a depth cap, a node cap and a visited set, so loops and nodes with
//! two parents end with an error rather than a hang; node transforms come from a matrix or TRS.
//! Mesh instances are counted against the triangle and vertex caps after instancing, and
//! cameras and `KHR_lights_punctual` lights are converted at their nodes' world transforms.

use super::materials::{DEFAULT_MATERIAL, MaterialInfo, clamp_warn, clamp3_warn};
use super::mesh::decode_mesh;
use super::{Doc, GltfError, GltfImport, State, invalid};
use crate::scene::world::{Camera, Light};
use glam::{Mat4, Quat, Vec3};
use gltf::json;
use json::validation::Checked;

/// Luminous efficacy used to turn glTF's photometric light units into radiometric ones:
/// 683 lm/W (the definition of the candela at 555 nm). glTF point and spot intensities are in
/// candela (lm/sr) and become W/sr; directional intensities are in lux (lm/m²) and become W/m².
pub const LUMENS_PER_WATT: f32 = 683.0;

fn node_matrix(i: usize, node: &json::Node, st: &mut State) -> Result<Mat4, GltfError> {
    if let Some(m) = node.matrix {
        if m.iter().any(|x| !x.is_finite()) {
            return Err(invalid(format!("node {i}: matrix is not finite")));
        }
        if node.translation.is_some() || node.rotation.is_some() || node.scale.is_some() {
            st.warn(format!("node {i}: has both matrix and TRS; TRS ignored"));
        }
        return Ok(Mat4::from_cols_array(&m));
    }
    let t = node.translation.unwrap_or([0.0; 3]);
    let r = node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
    let s = node.scale.unwrap_or([1.0; 3]);
    if t.iter().chain(&r).chain(&s).any(|x| !x.is_finite()) {
        return Err(invalid(format!(
            "node {i}: translation, rotation or scale is not finite"
        )));
    }
    let q = Quat::from_array(r);
    let len = q.length();
    let q = if len < 1e-6 {
        st.warn(format!("node {i}: zero rotation quaternion; identity used"));
        Quat::IDENTITY
    } else {
        if (len - 1.0).abs() > 1e-3 {
            st.warn(format!(
                "node {i}: rotation quaternion of length {len} normalised"
            ));
        }
        q / len
    };
    Ok(Mat4::from_scale_rotation_translation(
        Vec3::from(s),
        q,
        Vec3::from(t),
    ))
}

fn convert_light(
    doc: &Doc,
    st: &mut State,
    node: usize,
    li: usize,
    world: Mat4,
) -> Result<Option<Light>, GltfError> {
    use json::extensions::scene::khr_lights_punctual::Type as LightType;
    let light = doc
        .root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .and_then(|l| l.lights.get(li))
        .ok_or_else(|| {
            invalid(format!(
                "node {node}: KHR_lights_punctual light {li} does not exist"
            ))
        })?;
    let label = format!("light {li} (node {node})");
    let ty = match &light.type_ {
        Checked::Valid(t) => *t,
        Checked::Invalid => {
            st.warn(format!("{label}: unknown type; skipped"));
            return Ok(None);
        }
    };
    let color = clamp3_warn(st, &label, "color", light.color, 0.0, f32::MAX, 1.0);
    let intensity = clamp_warn(st, &label, "intensity", light.intensity, 0.0, f32::MAX, 1.0);
    // Photometric (cd or lx) to radiometric (W/sr or W/m²).
    let radiometric = color * intensity / LUMENS_PER_WATT;
    let position = world.transform_point3(Vec3::ZERO);
    let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    if !position.is_finite() || (ty != LightType::Point && direction == Vec3::ZERO) {
        st.warn(format!("{label}: degenerate node transform; skipped"));
        return Ok(None);
    }
    if light.range.is_some() {
        st.warn(format!(
            "{label}: range ignored (inverse-square falloff is used)"
        ));
    }
    Ok(Some(match ty {
        LightType::Directional => Light::Directional {
            direction,
            irradiance: radiometric,
            angular_radius: 0.0,
        },
        LightType::Point => Light::Point {
            position,
            intensity: radiometric,
        },
        LightType::Spot => {
            let (inner, outer) = match &light.spot {
                Some(s) => (s.inner_cone_angle, s.outer_cone_angle),
                None => {
                    st.warn(format!("{label}: spot without cone angles; 0 and π/4 used"));
                    (0.0, std::f32::consts::FRAC_PI_4)
                }
            };
            let half_pi = std::f32::consts::FRAC_PI_2;
            let outer = clamp_warn(
                st,
                &label,
                "outerConeAngle",
                outer,
                1e-3,
                half_pi,
                std::f32::consts::FRAC_PI_4,
            );
            let inner = clamp_warn(st, &label, "innerConeAngle", inner, 0.0, outer, 0.0);
            Light::Spot {
                position,
                direction,
                intensity: radiometric,
                cutoff: outer,
                beam_width: inner,
            }
        }
    }))
}

fn convert_camera(
    doc: &Doc,
    st: &mut State,
    node: usize,
    ci: usize,
    world: Mat4,
) -> Result<Option<Camera>, GltfError> {
    let cam = doc
        .root
        .cameras
        .get(ci)
        .ok_or_else(|| invalid(format!("node {node}: camera {ci} does not exist")))?;
    let label = format!("camera {ci} (node {node})");
    let Some(p) = &cam.perspective else {
        st.warn(format!("{label}: not perspective; skipped"));
        return Ok(None);
    };
    let fov_y = clamp_warn(
        st,
        &label,
        "yfov (degrees)",
        p.yfov.to_degrees(),
        1.0,
        178.0,
        40.0,
    );
    let height = 256u32;
    let width = match p.aspect_ratio {
        Some(a) if a.is_finite() && a > 0.0 => (256.0 * a).round().clamp(1.0, 8192.0) as u32,
        Some(a) => {
            st.warn(format!("{label}: aspectRatio {a} ignored"));
            256
        }
        None => 256,
    };
    let eye = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    if !eye.is_finite()
        || forward == Vec3::ZERO
        || up == Vec3::ZERO
        || forward.cross(up).length() < 1e-4
    {
        st.warn(format!("{label}: degenerate node transform; skipped"));
        return Ok(None);
    }
    Ok(Some(Camera {
        eye,
        target: eye + forward,
        up,
        fov_y,
        width,
        height,
    }))
}

/// Root nodes of the default scene, scene 0, or every parentless node.
fn scene_roots(root: &json::Root) -> Result<Vec<usize>, GltfError> {
    if let Some(s) = root.scene {
        let scene = root
            .scenes
            .get(s.value())
            .ok_or_else(|| invalid(format!("default scene {} does not exist", s.value())))?;
        return Ok(scene.nodes.iter().map(|n| n.value()).collect());
    }
    if let Some(scene) = root.scenes.first() {
        return Ok(scene.nodes.iter().map(|n| n.value()).collect());
    }
    let mut has_parent = vec![false; root.nodes.len()];
    for n in &root.nodes {
        for c in n.children.iter().flatten() {
            if let Some(h) = has_parent.get_mut(c.value()) {
                *h = true;
            }
        }
    }
    Ok((0..root.nodes.len()).filter(|&i| !has_parent[i]).collect())
}

pub(super) fn walk_scene(
    doc: &Doc,
    materials: &[MaterialInfo],
    st: &mut State,
) -> Result<GltfImport, GltfError> {
    let root = doc.root;
    let limits = st.limits;
    let mut out = GltfImport::default();
    let mut visited = vec![false; root.nodes.len()];
    let mut visits = 0usize;
    let mut stack: Vec<(usize, Mat4, usize)> = scene_roots(root)?
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY, 1))
        .collect();
    // Every mesh is decoded (and so checked) once, used or not; instances share it.
    let meshes = (0..root.meshes.len())
        .map(|m| decode_mesh(doc, st, m))
        .collect::<Result<Vec<_>, _>>()?;
    let (mut triangles, mut vertices) = (0usize, 0usize);
    while let Some((ni, parent, depth)) = stack.pop() {
        let node = root
            .nodes
            .get(ni)
            .ok_or_else(|| invalid(format!("node {ni} does not exist")))?;
        if visited[ni] {
            return Err(invalid(format!(
                "node {ni} is reached twice: the node hierarchy has a loop or a node with two parents"
            )));
        }
        visited[ni] = true;
        visits += 1;
        if visits > limits.max_nodes {
            return Err(GltfError::Limit(format!(
                "more than {} nodes visited",
                limits.max_nodes
            )));
        }
        if depth > limits.max_depth {
            return Err(GltfError::Limit(format!(
                "node {ni} is nested {depth} deep, the limit is {}",
                limits.max_depth
            )));
        }
        let world = parent * node_matrix(ni, node, st)?;
        if !world.is_finite() {
            return Err(invalid(format!("node {ni}: world transform is not finite")));
        }
        if let Some(m) = node.mesh {
            let m = m.value();
            let prims = meshes
                .get(m)
                .ok_or_else(|| invalid(format!("node {ni}: mesh {m} does not exist")))?;
            let det = world.determinant();
            if !prims.is_empty() && (!det.is_finite() || det.abs() < 1e-20) {
                st.warn(format!(
                    "node {ni}: singular transform; its mesh {m} is skipped"
                ));
            } else {
                for prim in prims.iter() {
                    triangles += prim.mesh.triangle_count();
                    vertices += prim.mesh.positions.len();
                    if triangles > limits.max_triangles {
                        return Err(GltfError::Limit(format!(
                            "more than {} triangles after instancing (at node {ni})",
                            limits.max_triangles
                        )));
                    }
                    if vertices > limits.max_vertices {
                        return Err(GltfError::Limit(format!(
                            "more than {} vertices after instancing (at node {ni})",
                            limits.max_vertices
                        )));
                    }
                    let mesh = if world == Mat4::IDENTITY {
                        prim.mesh.clone()
                    } else {
                        prim.mesh.transformed(world)
                    };
                    if mesh.positions.iter().any(|p| !p.is_finite()) {
                        return Err(invalid(format!(
                            "node {ni}: transformed positions of mesh {m} are not finite"
                        )));
                    }
                    let material = prim
                        .material
                        .and_then(|k| materials.get(k))
                        .map_or(DEFAULT_MATERIAL, |mi| mi.resolved);
                    out.parts.push((mesh, material));
                }
            }
        }
        if let Some(c) = node.camera
            && let Some(cam) = convert_camera(doc, st, ni, c.value(), world)?
        {
            out.cameras.push(cam);
        }
        if let Some(l) = node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            && let Some(light) = convert_light(doc, st, ni, l.light.value(), world)?
        {
            out.lights.push(light);
        }
        if node.skin.is_some() {
            st.warn(format!("node {ni}: skin ignored"));
        }
        for c in node.children.iter().flatten().rev() {
            stack.push((c.value(), world, depth + 1));
        }
    }
    Ok(out)
}
