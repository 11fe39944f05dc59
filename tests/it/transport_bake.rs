//! Light transport tables (Iwasaki et al. 2005 §4, §6): exits through a glass sphere against Snell and
//! Fresnel in closed form, self-occlusion, trapped rays, determinism, quantisation and the
//! artifact format.

use crate::support::quiet;
use crate::support::scenes::parse;
use caustica::bake::transport::table::TableError;
use caustica::bake::transport::{
    TransportParams, TransportTable, bake_transport, local_angles, sampling_direction,
    table_vertices, tangent_frame,
};
use caustica::bake::{BakeError, Progress};
use caustica::scene::World;
use caustica::trace::optics::{fresnel_dielectric, refract};
use glam::Vec3;

/// One object `shape` of material `mat` over a floor, moved and turned (the table is made in
/// the object's rigid frame, so that must not matter).
fn world(shape: &str, mat: &str) -> World {
    parse(&format!(
        r#"{{
        "camera": {{"eye": [0, 3, 3], "target": [0, 0, 0]}},
        "materials": {{"glass": {{"type": "dielectric", "ior": 1.5}},
                      "tinted": {{"type": "dielectric", "ior": 1.5, "absorption": [0.5, 0.1, 2.0]}},
                      "dense": {{"type": "dielectric", "ior": 2.5}},
                      "floor": {{"type": "diffuse", "albedo": 0.5}}}},
        "objects": [
            {{"name": "floor", "shape": {{"type": "plane", "size": [4, 4]}}, "material": "floor"}},
            {{"name": "thing", "shape": {shape}, "material": "{mat}",
             "transform": {{"translation": [0.2, 0.6, -0.1], "rotation_deg": [10, 30, 0]}}}}
        ]}}"#
    ))
}

const SPHERE: &str = r#"{"type": "sphere", "radius": 0.5, "segments": 96}"#;

fn bake(world: &World, params: &TransportParams) -> TransportTable {
    bake_transport(world, "thing", params, &quiet).expect("bakes")
}

/// Small tables for the format and determinism tests.
const SMALL: TransportParams = TransportParams {
    rings: 4,
    azimuths: 8,
    max_depth: 16,
};

/// Through a sphere (centre at the origin of its frame, R = 0.5, n = 1.5): light entering at
/// vertex P along w refracts to d₁ = refract(w, n), crosses the chord to Q = P − 2(P·d₁)d₁,
/// and leaves refracted again; by symmetry both interfaces have the same Fresnel reflectance,
/// so the transmittance is (1 − F)². Every sample of the table is checked (96-segment mesh
/// with smooth normals: exits within 0.3 % of R and 0.01 rad of the closed form, transmittance
/// within 0.006; measured 6.4e-4 m, 3.4e-3, 4.7e-3).
#[test]
fn sphere_exits_match_snell_and_fresnel_in_closed_form() {
    let w = world(SPHERE, "glass");
    let params = TransportParams::paper();
    let table = bake(&w, &params);
    let verts = table_vertices(&w, w.object("thing").unwrap());
    assert_eq!(table.vertex_count as usize, verts.len());
    assert_eq!(table.records.len(), verts.len() * 129);
    assert_eq!(
        table.stats.occluded, 0,
        "a convex object never occludes itself"
    );
    // Only exactly grazing light is trapped: it enters at the critical angle (F = 1, nothing
    // gets in) and meets the far side at the critical angle again.
    let horizon = |j: usize| j > 0 && params.angles(j).0 > 1.57;
    for v in 0..verts.len() {
        for j in 0..params.directions() {
            let s = table.sample(v, j);
            assert!(
                !s.trapped || (horizon(j) && s.transmittance == 0.0),
                "{v} {j} {s:?}"
            );
        }
    }
    let (mut worst_p, mut worst_d, mut worst_t) = (0.0f32, 0.0f32, 0.0f32);
    for (v, vert) in verts.iter().enumerate() {
        let frame = tangent_frame(vert.normal);
        let p = vert.position;
        let n = p.normalize();
        for j in 0..params.directions() {
            let (phi, theta) = params.angles(j);
            if phi > 1.5 {
                continue; // near grazing, F → 1 and the tessellation dominates
            }
            let win = sampling_direction(frame, phi, theta);
            let d1 = refract(win, n, 1.0 / 1.5).unwrap();
            let q = p - 2.0 * p.dot(d1) * d1;
            let d2 = refract(d1, -q.normalize(), 1.5).unwrap();
            let f = fresnel_dielectric((-win.dot(n)).max(0.0), 1.0 / 1.5);
            let s = table.sample(v, j);
            worst_p = worst_p.max((s.position - q).length());
            worst_d = worst_d.max((s.direction - d2).length());
            worst_t = worst_t.max((s.transmittance - (1.0 - f) * (1.0 - f)).abs());
        }
    }
    eprintln!(
        "sphere exits: position {worst_p:.2e} m, direction {worst_d:.2e}, transmittance {worst_t:.2e}"
    );
    assert!(worst_p < 0.003 * 0.5, "position off by {worst_p}");
    assert!(worst_d < 0.01, "direction off by {worst_d}");
    assert!(worst_t < 0.006, "transmittance off by {worst_t}");
    // Quantisation as §6 (12 bytes a sample) and the path's signature: 14 bytes; errors
    // within a step of 16 bits.
    assert_eq!(table.bytes_per_sample(), 14);
    assert!(table.errors.position < 2e-5, "{:?}", table.errors);
    assert!(table.errors.direction < 1e-4, "{:?}", table.errors);
    assert!(
        table.errors.transmittance <= 0.5 / 16383.0 + 1e-7,
        "{:?}",
        table.errors
    );
}

/// §4: a ray from the vertex towards the light that meets the object marks the sample
/// occluded. On a torus the inner side sees the other side of the ring across the hole.
#[test]
fn a_torus_occludes_itself_across_its_hole() {
    let w = world(
        r#"{"type": "torus", "major_radius": 0.5, "minor_radius": 0.15, "segments": 48}"#,
        "glass",
    );
    let table = bake(&w, &SMALL);
    let verts = table_vertices(&w, w.object("thing").unwrap());
    assert!(table.stats.occluded > 0);
    // The innermost vertex on the +x side (nearest the axis, in the ring's plane), light
    // travelling towards it from the far side of the hole (along +x): occluded. The outermost
    // vertex on +x lit from outside (along −x): not.
    let (inner, _) = verts
        .iter()
        .enumerate()
        .filter(|(_, v)| v.position.x > 0.0 && v.position.y.abs() < 0.02)
        .min_by(|a, b| a.1.position.length().total_cmp(&b.1.position.length()))
        .unwrap();
    let (outer, _) = verts
        .iter()
        .enumerate()
        .filter(|(_, v)| v.position.x > 0.0 && v.position.y.abs() < 0.02)
        .max_by(|a, b| a.1.position.length().total_cmp(&b.1.position.length()))
        .unwrap();
    let nearest = |v: usize, light: Vec3| {
        let frame = tangent_frame(verts[v].normal);
        let (phi, theta) = local_angles(frame, light);
        let k = (phi / SMALL.phi(1)).round() as u32;
        let m = (theta / SMALL.theta(1)).round() as u32;
        table.sample(v, SMALL.index(k.min(SMALL.rings), m))
    };
    assert!(nearest(inner, Vec3::X).occluded);
    assert!(!nearest(outer, Vec3::NEG_X).occluded);
}

/// Rays that never leave within `max_depth` interactions are flagged and keep their last hit
/// on the surface (§4: used only to refract viewing rays). In a box of n = 2.5 light entering
/// a face reflects totally off the sides: with one interaction allowed rays from every ring are
/// trapped, with the default only exactly grazing ones (which carry no light).
#[test]
fn trapped_rays_are_flagged_and_keep_their_last_hit() {
    let w = world(r#"{"type": "box", "size": [0.2, 1.0, 0.2]}"#, "dense");
    let full = bake(&w, &SMALL);
    let grazing = |j: usize| j > 0 && SMALL.angles(j).0 > 1.57;
    for v in 0..full.vertex_count as usize {
        for j in 0..SMALL.directions() {
            let s = full.sample(v, j);
            assert!(
                !s.trapped || (grazing(j) && s.transmittance == 0.0),
                "{s:?}"
            );
        }
    }
    let short = bake(
        &w,
        &TransportParams {
            max_depth: 1,
            ..SMALL
        },
    );
    assert!(short.stats.trapped > full.stats.trapped && short.stats.trapped < short.stats.samples);
    assert!(
        (0..short.vertex_count as usize)
            .any(|v| (1..SMALL.directions()).any(|j| !grazing(j) && short.sample(v, j).trapped))
    );
    let half = Vec3::new(0.1, 0.5, 0.1);
    for v in 0..short.vertex_count as usize {
        for j in 0..SMALL.directions() {
            let s = short.sample(v, j);
            if s.trapped {
                // On the box's surface: one coordinate at ±half, the others inside.
                let rel = s.position.abs() / half;
                assert!(
                    rel.max_element() > 0.999 && rel.max_element() < 1.001,
                    "{s:?}"
                );
            }
        }
    }
}

#[test]
fn tables_are_deterministic_across_thread_counts() {
    let w = world(SPHERE, "glass");
    let a = bake(&w, &SMALL).to_bytes();
    for threads in [1, 3] {
        let b = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| bake(&w, &SMALL).to_bytes());
        assert!(a == b, "{threads} threads differ");
    }
    // Moving the object (same rotation, another place, no floor) does not change the table.
    let moved = parse(
        &serde_json::to_string(&{
            let mut v: serde_json::Value = serde_json::from_str(&format!(
                r#"{{"camera": {{"eye": [0, 3, 3], "target": [0, 0, 0]}},
                "materials": {{"glass": {{"type": "dielectric", "ior": 1.5}}}},
                "objects": [{{"name": "thing", "shape": {SPHERE}, "material": "glass"}}]}}"#
            ))
            .unwrap();
            v["objects"][0]["transform"] =
                serde_json::json!({"translation": [3, 1, 2], "rotation_deg": [10, 30, 0]});
            v
        })
        .unwrap(),
    );
    assert!(
        bake(&moved, &SMALL).to_bytes() == a,
        "a moved object has another table"
    );
}

#[test]
fn artifact_round_trips_and_rejects_corruption() {
    for mat in ["glass", "tinted"] {
        let table = bake(&world(SPHERE, mat), &SMALL);
        let bytes = table.to_bytes();
        let back = TransportTable::from_bytes(&bytes).expect("parses");
        assert_eq!(back.records, table.records);
        assert_eq!(back.params, table.params);
        assert_eq!(back.source_hash, table.source_hash);
        assert_eq!(back.to_bytes(), bytes);
        assert_eq!(back.stats.samples, table.stats.samples);
        // A tinted object stores path lengths: 16 bytes a sample, colour recovered.
        let per = if mat == "tinted" { 16 } else { 14 };
        assert_eq!(table.bytes_per_sample(), per);
        assert_eq!(
            bytes.len(),
            84 + table.records.len() * per + 8,
            "header 84, trailer 8"
        );
        // The bake's fit travels with the table.
        assert!(table.fit.is_some());
        assert_eq!(back.fit, table.fit);
        if mat == "tinted" {
            // The scale is the longest path of light that leaves (at least the diameter;
            // light entering near grazing can bounce inside before it leaves).
            assert!(table.max_path >= 0.99, "{}", table.max_path);
            let s = table.sample(0, 0);
            assert!(s.path_length > 0.0 && table.errors.path < 1e-4);
        }
        let mut bad = bytes.clone();
        bad[200] ^= 1;
        assert_eq!(
            TransportTable::from_bytes(&bad).unwrap_err(),
            TableError::Checksum
        );
        assert!(matches!(
            TransportTable::from_bytes(&bytes[..bytes.len() - 3]).unwrap_err(),
            TableError::Truncated { .. }
        ));
        let mut v = bytes.clone();
        v[8] = 9;
        assert_eq!(
            TransportTable::from_bytes(&v).unwrap_err(),
            TableError::UnsupportedVersion(9)
        );
        assert_eq!(
            TransportTable::from_bytes(b"CSLSET\0\0 and more").unwrap_err(),
            TableError::BadMagic
        );
    }
}

/// Every bake checks its table against photons traced through the object
/// (`bake::transport::verify`) and stores the figures with it. The sphere's table follows the
/// photons closely (measured 0.024 at 96 segments); a flat-capped cylinder's, whose light
/// leaves through the caps or the side depending on where and how it enters, does not (0.26,
/// 9 % of its light left out where its paths split): above the renders' bar for a poor fit.
#[test]
fn a_bake_reports_how_well_its_table_fits_fresh_photons() {
    use caustica::methods::transport::POOR_FIT;
    let sphere = bake(&world(SPHERE, "glass"), &TransportParams::paper());
    let cylinder = bake(
        &world(
            r#"{"type": "cylinder", "radius": 0.3, "height": 0.8, "segments": 128}"#,
            "glass",
        ),
        &TransportParams::paper(),
    );
    let (s, c) = (sphere.fit.unwrap(), cylinder.fit.unwrap());
    eprintln!("fit: sphere {s:?}, cylinder {c:?}");
    assert!(s.error < 0.05 && s.split_loss < 0.01, "{s:?}");
    assert!(c.error > POOR_FIT, "{c:?}");
    assert!((0.0..=1.0).contains(&c.split_loss));
}

#[test]
fn bad_requests_are_errors() {
    let w = world(SPHERE, "glass");
    let err = |name: &str, p: &TransportParams| bake_transport(&w, name, p, &quiet).unwrap_err();
    assert!(matches!(err("nope", &SMALL), BakeError::UnknownObject(_)));
    assert!(matches!(err("floor", &SMALL), BakeError::NotRefractive(_)));
    let bad = TransportParams { rings: 0, ..SMALL };
    assert!(matches!(err("thing", &bad), BakeError::InvalidParams(_)));
    // Cancel from the progress callback.
    let r = bake_transport(&w, "thing", &SMALL, &|p: Progress| p.fraction < 0.01);
    assert!(matches!(r, Err(BakeError::Canceled)));
}
