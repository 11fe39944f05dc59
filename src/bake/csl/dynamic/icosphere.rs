//! The light directions of a dynamic bake: the vertices of a subdivided icosahedron, its faces
//! and edges, and the face a light direction passes through with its barycentric weights.

use glam::{Mat3, Vec3};
use std::collections::{BTreeSet, HashMap};

/// The light directions of a dynamic bake: a regularly subdivided icosahedron on the unit
/// sphere (0 subdivisions: 12 directions; 1: 42; 2: 162, the paper's; 3: 642).
#[derive(Clone, Debug, PartialEq)]
pub struct Icosphere {
    pub vertices: Vec<Vec3>,
    /// Counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

impl Icosphere {
    pub fn new(subdivisions: u32) -> Icosphere {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut vertices: Vec<Vec3> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|v| Vec3::from_array(*v).normalize())
        .collect();
        let mut faces: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
            let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
                    vertices.len() as u32 - 1
                })
            };
            let mut next = Vec::with_capacity(faces.len() * 4);
            for &[a, b, c] in &faces {
                let ab = midpoint(a, b, &mut vertices);
                let bc = midpoint(b, c, &mut vertices);
                let ca = midpoint(c, a, &mut vertices);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            faces = next;
        }
        Icosphere { vertices, faces }
    }

    /// Every edge once, as (lower, higher) vertex index, in ascending order.
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let set: BTreeSet<[u32; 2]> = self
            .faces
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        set.into_iter().collect()
    }

    /// The face the ray from the centre along `dir` passes through, and the barycentric
    /// coordinates (summing to 1) of the point where it meets the face's plane.
    pub fn locate(&self, dir: Vec3) -> (usize, [f32; 3]) {
        let d = dir.normalize();
        let mut best = (0usize, [1.0, 0.0, 0.0], f32::NEG_INFINITY);
        for (fi, f) in self.faces.iter().enumerate() {
            let m = Mat3::from_cols(
                self.vertices[f[0] as usize],
                self.vertices[f[1] as usize],
                self.vertices[f[2] as usize],
            );
            let l = m.inverse() * d;
            let s = l.element_sum();
            if s <= 0.0 {
                continue;
            }
            let w = l / s;
            let min = w.min_element();
            if min > best.2 {
                best = (fi, w.to_array(), min);
            }
            if min >= 0.0 {
                break;
            }
        }
        // Rounding leaves weights of a few 1e-8 at a corner or on an edge: snapped to zero, so
        // that a corner's direction gives exactly its own set.
        let w = Vec3::from_array(best.1);
        let w = Vec3::select(w.cmplt(Vec3::splat(1e-6)), Vec3::ZERO, w);
        (best.0, (w / w.element_sum()).to_array())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts_orientation_and_edges() {
        for (sub, v, f, e) in [(0, 12, 20, 30), (1, 42, 80, 120), (2, 162, 320, 480)] {
            let ico = Icosphere::new(sub);
            assert_eq!(
                (ico.vertices.len(), ico.faces.len(), ico.edges().len()),
                (v, f, e)
            );
            assert!(ico.vertices.iter().all(|v| (v.length() - 1.0).abs() < 1e-6));
            let mut uses: HashMap<[u32; 2], u32> = HashMap::new();
            for &[a, b, c] in &ico.faces {
                let (a, b, c) = (
                    ico.vertices[a as usize],
                    ico.vertices[b as usize],
                    ico.vertices[c as usize],
                );
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0, "outward");
            }
            for &[a, b, c] in &ico.faces {
                for [p, q] in [[a, b], [b, c], [c, a]] {
                    *uses.entry([p.min(q), p.max(q)]).or_default() += 1;
                }
            }
            assert!(
                uses.values().all(|&n| n == 2),
                "every edge between two faces"
            );
        }
    }

    #[test]
    fn locate_gives_weights_that_rebuild_the_direction() {
        let ico = Icosphere::new(2);
        let mut seed = 7u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let d = Vec3::new(rnd(), rnd(), rnd()).normalize();
            let (fi, w) = ico.locate(d);
            assert!(w.iter().all(|&x| x >= 0.0));
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
            let f = ico.faces[fi];
            let back = (0..3)
                .map(|k| ico.vertices[f[k] as usize] * w[k])
                .fold(Vec3::ZERO, |a, b| a + b)
                .normalize();
            assert!(back.dot(d) > 1.0 - 1e-6, "{d} {back}");
        }
        // A vertex is found with weight 1 on it.
        let (fi, w) = ico.locate(ico.vertices[17]);
        let k = ico.faces[fi].iter().position(|&v| v == 17).unwrap();
        assert!((w[k] - 1.0).abs() < 1e-5, "{w:?}");
    }
}
