//! Procedural meshes, centred at the origin, outward smooth normals, counter-clockwise front faces.

use super::world::Mesh;
use glam::Vec3;
use std::f32::consts::{PI, TAU};

/// Rectangle in the y=0 plane facing +Y with extents `sx` (x) by `sz` (z).
pub fn plane(sx: f32, sz: f32) -> Mesh {
    let (hx, hz) = (sx * 0.5, sz * 0.5);
    Mesh {
        positions: vec![
            Vec3::new(-hx, 0.0, -hz),
            Vec3::new(-hx, 0.0, hz),
            Vec3::new(hx, 0.0, hz),
            Vec3::new(hx, 0.0, -hz),
        ],
        normals: vec![Vec3::Y; 4],
        indices: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// UV sphere: `segments` around the equator, `segments / 2` rings, smooth normals.
pub fn sphere(radius: f32, segments: u32) -> Mesh {
    let seg = segments.max(3);
    let rings = (seg / 2).max(2);
    let mut m = Mesh::default();
    for i in 0..=rings {
        let theta = PI * i as f32 / rings as f32;
        for j in 0..=seg {
            let phi = TAU * j as f32 / seg as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            m.positions.push(n * radius);
            m.normals.push(n);
        }
    }
    let row = seg + 1;
    for i in 0..rings {
        for j in 0..seg {
            let a = i * row + j;
            let b = a + row;
            if i != 0 {
                m.indices.push([a, b, a + 1]);
            }
            if i != rings - 1 {
                m.indices.push([a + 1, b, b + 1]);
            }
        }
    }
    m
}

/// Axis-aligned box with full extents `size`, flat normals (24 vertices).
pub fn cuboid(size: Vec3) -> Mesh {
    let h = size * 0.5;
    let mut m = Mesh::default();
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (Vec3::NEG_X, Vec3::Y, Vec3::NEG_Z),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (Vec3::NEG_Y, Vec3::NEG_Z, Vec3::X),
        (Vec3::Z, Vec3::Y, Vec3::NEG_X),
        (Vec3::NEG_Z, Vec3::Y, Vec3::X),
    ];
    for (n, u, v) in faces {
        // u × v must equal n for counter-clockwise winding seen from outside.
        let (u, v) = if u.cross(v).dot(n) > 0.0 {
            (u, v)
        } else {
            (v, u)
        };
        let base = m.positions.len() as u32;
        for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            m.positions.push((n + u * a + v * b) * h);
            m.normals.push(n);
        }
        m.indices.push([base, base + 1, base + 2]);
        m.indices.push([base, base + 2, base + 3]);
    }
    m
}

/// Torus around the Y axis.
pub fn torus(major: f32, minor: f32, segments: u32) -> Mesh {
    let seg = segments.max(3);
    let minor_seg = (seg / 2).max(3);
    let mut m = Mesh::default();
    for i in 0..=seg {
        let phi = TAU * i as f32 / seg as f32;
        let c = Vec3::new(phi.cos(), 0.0, -phi.sin());
        for j in 0..=minor_seg {
            let th = TAU * j as f32 / minor_seg as f32;
            let n = c * th.cos() + Vec3::Y * th.sin();
            m.positions.push(c * major + n * minor);
            m.normals.push(n);
        }
    }
    let row = minor_seg + 1;
    for i in 0..seg {
        for j in 0..minor_seg {
            let a = i * row + j;
            let b = a + row;
            m.indices.push([a, b, a + 1]);
            m.indices.push([a + 1, b, b + 1]);
        }
    }
    m
}

/// Capped cylinder along Y from -height/2 to height/2; sides smooth, caps flat.
pub fn cylinder(radius: f32, height: f32, segments: u32) -> Mesh {
    let seg = segments.max(3);
    let hh = height * 0.5;
    let mut m = Mesh::default();
    for j in 0..=seg {
        let phi = TAU * j as f32 / seg as f32;
        let n = Vec3::new(phi.cos(), 0.0, -phi.sin());
        m.positions.push(n * radius - Vec3::Y * hh);
        m.normals.push(n);
        m.positions.push(n * radius + Vec3::Y * hh);
        m.normals.push(n);
    }
    for j in 0..seg {
        let a = 2 * j;
        m.indices.push([a, a + 2, a + 1]);
        m.indices.push([a + 1, a + 2, a + 3]);
    }
    for (y, n) in [(hh, Vec3::Y), (-hh, Vec3::NEG_Y)] {
        let centre = m.positions.len() as u32;
        m.positions.push(Vec3::Y * y);
        m.normals.push(n);
        for j in 0..=seg {
            let phi = TAU * j as f32 / seg as f32;
            m.positions
                .push(Vec3::new(phi.cos() * radius, y, -phi.sin() * radius));
            m.normals.push(n);
        }
        for j in 0..seg {
            let (a, b) = (centre + 1 + j, centre + 2 + j);
            if n.y > 0.0 {
                m.indices.push([centre, a, b]);
            } else {
                m.indices.push([centre, b, a]);
            }
        }
    }
    m
}

/// A paraboloid dish y = r²/(4f) around the local Y axis, r ≤ `radius`, open at the rim: its
/// focus is at (0, f, 0); normals face the concave side (+Y at the vertex).
pub fn paraboloid(focal: f32, radius: f32, segments: u32) -> Mesh {
    let seg = segments.max(3);
    let rings = (seg / 2).max(2);
    let mut m = Mesh::default();
    let at = |r: f32, phi: f32| {
        let p = Vec3::new(r * phi.cos(), r * r / (4.0 * focal), -r * phi.sin());
        let n = Vec3::new(-p.x / (2.0 * focal), 1.0, -p.z / (2.0 * focal)).normalize();
        (p, n)
    };
    m.positions.push(Vec3::ZERO);
    m.normals.push(Vec3::Y);
    for i in 1..=rings {
        let r = radius * i as f32 / rings as f32;
        for j in 0..seg {
            let (p, n) = at(r, TAU * j as f32 / seg as f32);
            m.positions.push(p);
            m.normals.push(n);
        }
    }
    let v = |i: u32, j: u32| {
        if i == 0 {
            0
        } else {
            1 + (i - 1) * seg + j % seg
        }
    };
    for i in 0..rings {
        for j in 0..seg {
            let (a, b) = (v(i, j), v(i, j + 1));
            let (c, d) = (v(i + 1, j), v(i + 1, j + 1));
            if i > 0 {
                m.indices.push([a, c, b]);
            }
            m.indices.push([b, c, d]);
        }
    }
    // Wind every face towards its normals' side.
    for t in &mut m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let n = t.map(|i| m.normals[i as usize]);
        if (b - a).cross(c - a).dot(n[0] + n[1] + n[2]) < 0.0 {
            t.swap(1, 2);
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_paraboloid_reflects_light_along_its_axis_into_its_focus() {
        let f = 0.4;
        let m = paraboloid(f, 0.8, 48);
        for (p, n) in m.positions.iter().zip(&m.normals).skip(1) {
            let d = crate::trace::optics::reflect(Vec3::NEG_Y, *n);
            // The reflected ray passes (0, f, 0).
            let t = (Vec3::new(0.0, f, 0.0) - *p).dot(d);
            let miss = (*p + d * t - Vec3::new(0.0, f, 0.0)).length();
            assert!(miss < 1e-4, "{p}: misses the focus by {miss}");
        }
    }

    /// Every face's geometric normal agrees with its vertex normals (outward, CCW winding).
    fn check_winding(m: &Mesh) {
        for t in &m.indices {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let g = (b - a).cross(c - a);
            if g.length() < 1e-9 {
                continue;
            }
            let n = t.map(|i| m.normals[i as usize]).iter().sum::<Vec3>();
            assert!(g.dot(n) > 0.0, "face {t:?} winds against its normals");
        }
    }

    #[test]
    fn shapes_wind_outward() {
        for m in [
            plane(2.0, 3.0),
            sphere(0.5, 32),
            cuboid(Vec3::new(1.0, 2.0, 3.0)),
            torus(1.0, 0.25, 24),
            cylinder(0.5, 1.0, 24),
            paraboloid(0.4, 0.8, 24),
        ] {
            check_winding(&m);
        }
    }

    #[test]
    fn sphere_vertices_on_radius() {
        let m = sphere(0.5, 64);
        assert!(m.positions.iter().all(|p| (p.length() - 0.5).abs() < 1e-5));
        assert_eq!(m.triangle_count(), 64 * 32 * 2 - 2 * 64);
    }
}
