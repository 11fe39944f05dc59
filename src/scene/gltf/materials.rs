//! glTF materials to ours. The metallic-roughness factors and the `KHR_materials_transmission`,
//! `KHR_materials_ior` and `KHR_materials_volume` extensions are clamped into range, with a
//! warning naming the material, and mapped to a dielectric, mirror, glossy or diffuse
//! [`Material`]. A base colour texture contributes only its mean linear colour, its image
//! decoded once per file within the texture side and buffer limits. The clamping helpers serve
//! lights and cameras too.

use super::container::{read_uri, short, view_bytes};
use super::{Doc, GltfError, State, panic_message};
use crate::scene::image::DecodeRefusal;
use crate::scene::world::Material;
use glam::Vec3;
use gltf::json;
use std::borrow::Cow;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};

/// A glTF material as read (values clamped into range) and the physical material it maps to.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialInfo {
    /// `material 3 'Glass'` (index and name, as used in warnings).
    pub label: String,
    /// Linear base colour: factor × mean of the base colour texture when it decoded.
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    /// `KHR_materials_transmission` factor (0 without the extension).
    pub transmission: f32,
    /// `KHR_materials_ior` (1.5 without the extension), clamped to [1, 4].
    pub ior: f32,
    /// Beer-Lambert coefficient per scene unit from `KHR_materials_volume`.
    pub absorption: Vec3,
    pub resolved: Material,
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Mean linear RGB of texture `t`'s image.
fn texture_mean(
    doc: &Doc,
    st: &mut State,
    t: usize,
    cache: &mut HashMap<usize, Result<Vec3, DecodeRefusal>>,
) -> Result<Vec3, DecodeRefusal> {
    let tex = doc
        .root
        .textures
        .get(t)
        .ok_or_else(|| DecodeRefusal::Skip(format!("texture {t} does not exist")))?;
    let i = tex.source.value();
    if let Some(r) = cache.get(&i) {
        return r.clone();
    }
    let r = image_mean(doc, st, i);
    cache.insert(i, r.clone());
    r
}

fn image_mean(doc: &Doc, st: &mut State, i: usize) -> Result<Vec3, DecodeRefusal> {
    let skip = |e: String| DecodeRefusal::Skip(e);
    let img = doc
        .root
        .images
        .get(i)
        .ok_or_else(|| skip(format!("image {i} does not exist")))?;
    let bytes: Cow<[u8]> = match (&img.buffer_view, &img.uri) {
        (Some(v), _) => Cow::Borrowed(
            view_bytes(doc, v.value())
                .map_err(|e| skip(e.to_string()))?
                .0,
        ),
        (None, Some(uri)) => Cow::Owned(
            read_uri(uri, &format!("image {i}"), st.limits.max_buffer_bytes, st)
                .map_err(|e| skip(e.to_string()))?,
        ),
        (None, None) => return Err(skip(format!("image {i} has neither bufferView nor uri"))),
    };
    let max_side = st.limits.max_texture_side;
    let left = &mut st.image_bytes_left;
    // The decoded image and its 8-bit RGB copy are held at once.
    let (decoded, _held) = catch_unwind(AssertUnwindSafe(|| {
        crate::scene::image::decode_image_budgeted(&bytes, max_side, left, 3)
    }))
    .map_err(|p| skip(format!("image decoder panicked: {}", panic_message(p))))?
    .map_err(|e| match e {
        DecodeRefusal::Skip(m) => skip(format!("image {i}: {m}")),
        busy => busy,
    })?;
    let rgb = decoded.to_rgb8();
    drop(decoded);
    let lut: Vec<f32> = (0..256).map(|v| srgb_to_linear(v as f32 / 255.0)).collect();
    let mut sum = [0f64; 3];
    for p in rgb.pixels() {
        for (s, &c) in sum.iter_mut().zip(&p.0) {
            *s += f64::from(lut[c as usize]);
        }
    }
    let n = (rgb.width() as f64 * rgb.height() as f64).max(1.0);
    Ok(Vec3::new(
        (sum[0] / n) as f32,
        (sum[1] / n) as f32,
        (sum[2] / n) as f32,
    ))
}

/// `v` clamped into [lo, hi] (non-finite: `default`), with a warning when it changed.
pub(super) fn clamp_warn(
    st: &mut State,
    label: &str,
    field: &str,
    v: f32,
    lo: f32,
    hi: f32,
    default: f32,
) -> f32 {
    if !v.is_finite() {
        st.warn(format!(
            "{label}: {field} {v} is not finite; {default} used"
        ));
        return default;
    }
    let c = v.clamp(lo, hi);
    if c != v {
        st.warn(format!(
            "{label}: {field} {v} clamped to {c} (range [{lo}, {hi}])"
        ));
    }
    c
}

pub(super) fn clamp3_warn(
    st: &mut State,
    label: &str,
    field: &str,
    v: [f32; 3],
    lo: f32,
    hi: f32,
    default: f32,
) -> Vec3 {
    let out = v.map(|x| {
        if x.is_finite() {
            x.clamp(lo, hi)
        } else {
            default
        }
    });
    if out != v {
        st.warn(format!(
            "{label}: {field} {v:?} clamped to {out:?} (range [{lo}, {hi}])"
        ));
    }
    Vec3::from(out)
}

fn convert_material(
    doc: &Doc,
    st: &mut State,
    i: usize,
    m: &json::Material,
    cache: &mut HashMap<usize, Result<Vec3, DecodeRefusal>>,
) -> Result<MaterialInfo, GltfError> {
    let label = match &m.name {
        Some(n) => format!("material {i} '{}'", short(n)),
        None => format!("material {i}"),
    };
    let pbr = &m.pbr_metallic_roughness;
    let f = pbr.base_color_factor.0;
    let mut base = clamp3_warn(
        st,
        &label,
        "baseColorFactor",
        [f[0], f[1], f[2]],
        0.0,
        1.0,
        1.0,
    );
    let metallic = clamp_warn(
        st,
        &label,
        "metallicFactor",
        pbr.metallic_factor.0,
        0.0,
        1.0,
        1.0,
    );
    let roughness = clamp_warn(
        st,
        &label,
        "roughnessFactor",
        pbr.roughness_factor.0,
        0.0,
        1.0,
        1.0,
    );
    if let Some(info) = &pbr.base_color_texture {
        match texture_mean(doc, st, info.index.value(), cache) {
            Ok(mean) => base *= mean,
            Err(DecodeRefusal::Skip(e)) => st.warn(format!(
                "{label}: base colour texture not used ({e}); the factor alone is used"
            )),
            Err(DecodeRefusal::Busy(e)) => return Err(GltfError::Busy(format!("{label}: {e}"))),
        }
    }
    let ext = m.extensions.as_ref();
    let transmission = match ext.and_then(|e| e.transmission.as_ref()) {
        Some(t) => {
            if t.transmission_texture.is_some() {
                st.warn(format!("{label}: transmissionTexture ignored"));
            }
            clamp_warn(
                st,
                &label,
                "transmissionFactor",
                t.transmission_factor.0,
                0.0,
                1.0,
                0.0,
            )
        }
        None => 0.0,
    };
    let ior = match ext.and_then(|e| e.ior.as_ref()) {
        Some(x) => clamp_warn(st, &label, "KHR_materials_ior ior", x.ior.0, 1.0, 4.0, 1.5),
        None => 1.5,
    };
    let mut absorption = Vec3::ZERO;
    if let Some(v) = ext.and_then(|e| e.volume.as_ref()) {
        let color = clamp3_warn(
            st,
            &label,
            "KHR_materials_volume attenuationColor",
            v.attenuation_color.0,
            1e-4,
            1.0,
            1.0,
        );
        let d = v.attenuation_distance.0;
        if d.is_nan() || d <= 0.0 {
            st.warn(format!(
                "{label}: KHR_materials_volume attenuationDistance {d} must be > 0; no absorption used"
            ));
        } else if d.is_finite() {
            absorption = Vec3::new(-color.x.ln(), -color.y.ln(), -color.z.ln()) / d;
        }
        if v.thickness_factor.0.is_nan() || v.thickness_factor.0 < 0.0 {
            st.warn(format!(
                "{label}: KHR_materials_volume thicknessFactor {} must be >= 0 (unused here)",
                v.thickness_factor.0
            ));
        }
    }
    let resolved = if transmission >= 0.5 {
        Material::Dielectric { ior, absorption }
    } else if metallic >= 0.9 && roughness <= 0.1 {
        Material::Mirror { reflectance: base }
    } else if roughness < 0.6 {
        Material::Glossy {
            albedo: base * (1.0 - metallic),
            specular: Vec3::splat(0.04).lerp(base, metallic),
            roughness: roughness.max(0.02),
        }
    } else {
        Material::Diffuse {
            albedo: base * (1.0 - metallic),
        }
    };
    Ok(MaterialInfo {
        label,
        base_color: base,
        metallic,
        roughness,
        transmission,
        ior,
        absorption,
        resolved,
    })
}

pub(super) fn convert_materials(doc: &Doc, st: &mut State) -> Result<Vec<MaterialInfo>, GltfError> {
    let mut cache = HashMap::new();
    doc.root
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| convert_material(doc, st, i, m, &mut cache))
        .collect()
}

/// Material of primitives without one.
pub const DEFAULT_MATERIAL: Material = Material::Diffuse {
    albedo: Vec3::splat(0.8),
};
