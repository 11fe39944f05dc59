//! WGSL sources, embedded at build time, and the textual `#include "file"` expansion the
//! passes use for shared code (`shaders/*.inc.wgsl`). A test runs the same expansion on the
//! files on disk before validating them with naga; [`wgsl_layout`] gives naga's layout of a
//! WGSL struct, against which every Rust struct mirrored in WGSL is checked (the tests below).

/// Every file under `shaders/`, by file name.
pub const FILES: &[(&str, &str)] = &[
    (
        "common.inc.wgsl",
        include_str!("../../shaders/common.inc.wgsl"),
    ),
    ("shadow.wgsl", include_str!("../../shaders/shadow.wgsl")),
    ("direct.wgsl", include_str!("../../shaders/direct.wgsl")),
    ("csl.inc.wgsl", include_str!("../../shaders/csl.inc.wgsl")),
    ("csl.wgsl", include_str!("../../shaders/csl.wgsl")),
    ("gbuffer.wgsl", include_str!("../../shaders/gbuffer.wgsl")),
    ("pinhole.wgsl", include_str!("../../shaders/pinhole.wgsl")),
    ("water.wgsl", include_str!("../../shaders/water.wgsl")),
    ("beams.wgsl", include_str!("../../shaders/beams.wgsl")),
    ("hull.inc.wgsl", include_str!("../../shaders/hull.inc.wgsl")),
    (
        "shadow_lookup.inc.wgsl",
        include_str!("../../shaders/shadow_lookup.inc.wgsl"),
    ),
    ("fog.wgsl", include_str!("../../shaders/fog.wgsl")),
    (
        "water.inc.wgsl",
        include_str!("../../shaders/water.inc.wgsl"),
    ),
    (
        "water_map.wgsl",
        include_str!("../../shaders/water_map.wgsl"),
    ),
    (
        "transport.wgsl",
        include_str!("../../shaders/transport.wgsl"),
    ),
    (
        "occlusion.inc.wgsl",
        include_str!("../../shaders/occlusion.inc.wgsl"),
    ),
    ("photons.wgsl", include_str!("../../shaders/photons.wgsl")),
    (
        "photon_splat.wgsl",
        include_str!("../../shaders/photon_splat.wgsl"),
    ),
];

/// Replaces each line `#include "name"` with the text `lookup(name)` returns, recursively
/// (depth-limited); an unknown name is an error.
pub fn expand_includes(
    src: &str,
    lookup: &dyn Fn(&str) -> Option<String>,
) -> Result<String, String> {
    fn go(
        src: &str,
        lookup: &dyn Fn(&str) -> Option<String>,
        depth: u32,
        out: &mut String,
    ) -> Result<(), String> {
        if depth > 8 {
            return Err("#include nested too deeply".into());
        }
        for line in src.lines() {
            let t = line.trim();
            if let Some(rest) = t.strip_prefix("#include") {
                let name = rest.trim().trim_matches('"');
                let text = lookup(name)
                    .ok_or_else(|| format!("#include {name:?}: no such shader file"))?;
                go(&text, lookup, depth + 1, out)?;
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        Ok(())
    }
    let mut out = String::new();
    go(src, lookup, 0, &mut out)?;
    Ok(out)
}

/// The embedded shader `name` with its includes expanded.
pub fn source(name: &str) -> String {
    let lookup = |n: &str| {
        FILES
            .iter()
            .find(|(f, _)| *f == n)
            .map(|(_, s)| s.to_string())
    };
    let src = lookup(name).unwrap_or_else(|| panic!("no embedded shader {name}"));
    expand_includes(&src, &lookup).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// naga's layout of WGSL struct `name` as shader `file` declares it (includes expanded): its
/// size and each member's (name, offset), in bytes.
pub fn wgsl_layout(file: &str, name: &str) -> Result<(u32, Vec<(String, u32)>), String> {
    let src = source(file);
    let module = naga::front::wgsl::parse_str(&src).map_err(|e| e.emit_to_string(&src))?;
    let mut layouter = naga::proc::Layouter::default();
    layouter
        .update(module.to_ctx())
        .map_err(|e| format!("{file}: {e}"))?;
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, t)| t.name.as_deref() == Some(name))
        .ok_or_else(|| format!("{file} declares no struct {name}"))?;
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        return Err(format!("{name} of {file} is not a struct"));
    };
    let members = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
        .collect();
    Ok((layouter[handle].size, members))
}

#[cfg(test)]
mod tests {
    use super::wgsl_layout;
    use std::mem::{offset_of, size_of};

    /// The Rust mirror of WGSL struct `name` (`size` bytes, `offsets` of the WGSL members in
    /// declaration order) has naga's layout.
    fn mirror(file: &str, name: &str, size: usize, offsets: &[(&str, usize)]) {
        let (wsize, members) = wgsl_layout(file, name).unwrap();
        let wgsl: Vec<(&str, usize)> = members
            .iter()
            .map(|(n, o)| (n.as_str(), *o as usize))
            .collect();
        assert_eq!(wgsl, offsets, "{name} of {file}: member offsets");
        assert_eq!(wsize as usize, size, "{name} of {file}: size");
    }

    #[test]
    fn structs_mirrored_in_rust_have_the_wgsl_layout() {
        use crate::render::blockers::{GpuBvhNode, GpuTriangle};
        use crate::render::csl::GpuCsl;
        use crate::render::direct::Globals as G;
        use crate::render::lights::GpuLight as L;
        use crate::render::scene::GpuMaterial as M;
        use crate::render::transport::GpuVolume as V;
        mirror(
            "direct.wgsl",
            "Globals",
            size_of::<G>(),
            &[
                ("view_proj", offset_of!(G, view_proj)),
                ("inv_view_proj", offset_of!(G, inv_view_proj)),
                ("eye", offset_of!(G, eye)),
                ("env_radiance", offset_of!(G, env_radiance)),
                ("env_map_scale", offset_of!(G, env_map_scale)),
                ("counts", offset_of!(G, counts)),
                ("viewport", offset_of!(G, viewport)),
                ("sh", offset_of!(G, sh)),
                ("csl_irradiance", offset_of!(G, csl_irradiance)),
                ("medium_to_local", offset_of!(G, medium_to_local)),
                ("medium_half", offset_of!(G, medium_half)),
                ("medium_sigma_t", offset_of!(G, medium_sigma_t)),
                ("medium_sigma_s", offset_of!(G, medium_sigma_s)),
                ("sky", offset_of!(G, sky)),
            ],
        );
        mirror(
            "direct.wgsl",
            "Light",
            size_of::<L>(),
            &[
                ("kind", offset_of!(L, kind)),
                ("first_layer", offset_of!(L, first_layer)),
                ("n_layers", offset_of!(L, n_layers)),
                ("ortho", offset_of!(L, ortho)),
                ("position", offset_of!(L, position)),
                ("direction", offset_of!(L, direction)),
                ("intensity", offset_of!(L, intensity)),
                ("params", offset_of!(L, params)),
                ("mats", offset_of!(L, mats)),
            ],
        );
        mirror(
            "direct.wgsl",
            "Material",
            size_of::<M>(),
            &[
                ("kind", offset_of!(M, kind)),
                ("roughness", offset_of!(M, roughness)),
                ("ior", offset_of!(M, ior)),
                ("_pad", offset_of!(M, _pad)),
                ("albedo", offset_of!(M, albedo)),
                ("specular", offset_of!(M, specular)),
            ],
        );
        mirror(
            "csl.wgsl",
            "Csl",
            size_of::<GpuCsl>(),
            &[
                ("origin", offset_of!(GpuCsl, origin)),
                ("kappa", offset_of!(GpuCsl, kappa)),
                ("axis", offset_of!(GpuCsl, axis)),
                ("gamma", offset_of!(GpuCsl, gamma)),
                ("x_axis", offset_of!(GpuCsl, x_axis)),
                ("half_extent", offset_of!(GpuCsl, half_extent)),
                ("y_axis", offset_of!(GpuCsl, y_axis)),
                ("scale", offset_of!(GpuCsl, scale)),
                ("size", offset_of!(GpuCsl, size)),
                ("texel_offset", offset_of!(GpuCsl, texel_offset)),
                ("pad0", offset_of!(GpuCsl, pad)),
                ("pad1", offset_of!(GpuCsl, pad) + 4),
            ],
        );
        mirror(
            "csl.wgsl",
            "BvhNode",
            size_of::<GpuBvhNode>(),
            &[
                ("lo", offset_of!(GpuBvhNode, lo)),
                ("first", offset_of!(GpuBvhNode, first)),
                ("hi", offset_of!(GpuBvhNode, hi)),
                ("count", offset_of!(GpuBvhNode, count)),
            ],
        );
        mirror(
            "csl.wgsl",
            "BlockerTri",
            size_of::<GpuTriangle>(),
            &[
                ("v0", offset_of!(GpuTriangle, v0)),
                ("e1", offset_of!(GpuTriangle, e1)),
                ("e2", offset_of!(GpuTriangle, e2)),
            ],
        );
        let (e, d, f) = (offset_of!(V, e), offset_of!(V, d), offset_of!(V, f));
        mirror(
            "transport.wgsl",
            "Volume",
            size_of::<V>(),
            &[
                ("e0", e),
                ("e1", e + 16),
                ("e2", e + 32),
                ("d0", d),
                ("d1", d + 16),
                ("d2", d + 32),
                ("f0", f),
                ("f1", f + 16),
                ("f2", f + 32),
            ],
        );
    }

    #[test]
    fn pinhole_structs_have_the_wgsl_layout() {
        use crate::render::pinhole::{GpuCluster, GpuPinhole, GpuSample, GpuSampleLight};
        mirror(
            "pinhole.wgsl",
            "Sample",
            size_of::<GpuSample>(),
            &[
                ("position", offset_of!(GpuSample, position)),
                ("normal", offset_of!(GpuSample, normal)),
                ("dir1", offset_of!(GpuSample, dir1)),
                ("dir2", offset_of!(GpuSample, dir2)),
                ("reflectance", offset_of!(GpuSample, reflectance)),
            ],
        );
        mirror(
            "pinhole.wgsl",
            "SampleLight",
            size_of::<GpuSampleLight>(),
            &[
                ("dir", offset_of!(GpuSampleLight, dir)),
                ("irradiance", offset_of!(GpuSampleLight, irradiance)),
            ],
        );
        mirror(
            "pinhole.wgsl",
            "Cluster",
            size_of::<GpuCluster>(),
            &[
                ("centre", offset_of!(GpuCluster, centre)),
                ("range", offset_of!(GpuCluster, range)),
                ("area", offset_of!(GpuCluster, area)),
            ],
        );
        mirror(
            "pinhole.wgsl",
            "Pinhole",
            size_of::<GpuPinhole>(),
            &[
                ("counts", offset_of!(GpuPinhole, counts)),
                ("env", offset_of!(GpuPinhole, env)),
                ("env_scale", offset_of!(GpuPinhole, env_scale)),
                ("env_size", offset_of!(GpuPinhole, env_size)),
                ("draw", offset_of!(GpuPinhole, draw)),
            ],
        );
    }

    #[test]
    fn the_water_uniform_has_the_wgsl_layout() {
        use crate::render::water::gpu::GpuWater;
        mirror(
            "water.wgsl",
            "Water",
            size_of::<GpuWater>(),
            &[
                ("centre", offset_of!(GpuWater, centre)),
                ("size", offset_of!(GpuWater, size)),
                ("absorption", offset_of!(GpuWater, absorption)),
                ("article", offset_of!(GpuWater, article)),
                ("counts", offset_of!(GpuWater, counts)),
                ("sun", offset_of!(GpuWater, sun)),
                ("beam", offset_of!(GpuWater, beam)),
                ("up", offset_of!(GpuWater, up)),
                ("map", offset_of!(GpuWater, map)),
                ("grid", offset_of!(GpuWater, grid)),
                ("sun_e", offset_of!(GpuWater, sun_e)),
                ("splat", offset_of!(GpuWater, splat)),
            ],
        );
    }

    #[test]
    fn the_beams_structs_have_the_wgsl_layout() {
        use crate::render::beams::GpuBeam as B;
        use crate::render::beams::gpu::GpuBeamsParams as P;
        mirror(
            "beams.wgsl",
            "Beam",
            size_of::<B>(),
            &[
                ("origin", offset_of!(B, origin)),
                ("ax", offset_of!(B, ax)),
                ("ay", offset_of!(B, ay)),
                ("az", offset_of!(B, az)),
                ("k", offset_of!(B, k)),
                ("d01", offset_of!(B, d01)),
                ("d2", offset_of!(B, d2)),
                ("abc", offset_of!(B, abc)),
                ("rho", offset_of!(B, rho)),
                ("cap", offset_of!(B, cap)),
            ],
        );
        mirror(
            "beams.wgsl",
            "Params",
            size_of::<P>(),
            &[
                ("counts", offset_of!(P, counts)),
                ("misc", offset_of!(P, misc)),
            ],
        );
    }

    #[test]
    fn the_photons_structs_have_the_wgsl_layout() {
        use crate::render::photons::{
            GpuEnvDir as E, GpuPhotonFrame as F, GpuPopulation as P, GpuTriNormals as N,
            RECORD_BYTES,
        };
        mirror(
            "photons.wgsl",
            "PhotonFrame",
            size_of::<F>(),
            &[
                ("counts", offset_of!(F, counts)),
                ("footprint", offset_of!(F, footprint)),
                ("eye", offset_of!(F, eye)),
            ],
        );
        mirror(
            "photons.wgsl",
            "Population",
            size_of::<P>(),
            &[
                ("ids", offset_of!(P, ids)),
                ("position", offset_of!(P, position)),
                ("direction", offset_of!(P, direction)),
                ("end", offset_of!(P, end)),
                ("intensity", offset_of!(P, intensity)),
                ("spot", offset_of!(P, spot)),
                ("target_sphere", offset_of!(P, target_sphere)),
            ],
        );
        mirror(
            "photons.wgsl",
            "TriNormals",
            size_of::<N>(),
            &[
                ("n0", offset_of!(N, n0)),
                ("n1", offset_of!(N, n1)),
                ("n2", offset_of!(N, n2)),
            ],
        );
        mirror(
            "photons.wgsl",
            "EnvDir",
            size_of::<E>(),
            &[
                ("dir", offset_of!(E, dir)),
                ("weight", offset_of!(E, weight)),
            ],
        );
        // The stored photon, written by the trace and read by the splat, is 64 bytes in both.
        for file in ["photons.wgsl", "photon_splat.wgsl"] {
            let (size, _) = wgsl_layout(file, "PhotonRecord").unwrap();
            assert_eq!(u64::from(size), RECORD_BYTES, "{file}");
        }
    }

    #[test]
    fn a_layout_that_differs_is_caught() {
        // A mirror with its albedo one vec4 late, and one a vec4 short, are refused.
        let m = [("kind", 0), ("roughness", 4), ("ior", 8), ("_pad", 12)];
        let late = [&m[..], &[("albedo", 32), ("specular", 48)]].concat();
        assert!(std::panic::catch_unwind(|| mirror("direct.wgsl", "Material", 64, &late)).is_err());
        let right = [&m[..], &[("albedo", 16), ("specular", 32)]].concat();
        assert!(
            std::panic::catch_unwind(|| mirror("direct.wgsl", "Material", 32, &right)).is_err()
        );
        mirror("direct.wgsl", "Material", 48, &right);
        assert!(wgsl_layout("direct.wgsl", "NoSuchStruct").is_err());
    }
}
