//! The plane the bakes' fit checks compare their model with fresh photons on
//! (`bake::csl::verify`, `bake::transport::verify::verify`): across the light, two radii past
//! the object's centre, six radii wide, in m × m cells; and the figure they report, the
//! relative L1 of the model against the photons after a 3 × 3 blur of both.

use glam::Vec3;

/// The comparison plane of a fit check.
#[derive(Clone, Copy, Debug)]
pub struct FitPlane {
    /// Unit travel direction of the light (the plane's normal faces back along it).
    pub light: Vec3,
    /// The plane's centre.
    pub p0: Vec3,
    /// Unit axes in the plane.
    pub u: Vec3,
    pub v: Vec3,
    /// Half its width.
    pub half: f32,
    /// Cells per side.
    pub m: usize,
}

impl FitPlane {
    /// The plane across `light` (unit) two radii past `centre`, for an object of bounding
    /// radius `radius`, in `m` × `m` cells.
    pub fn new(light: Vec3, centre: Vec3, radius: f32, m: usize) -> FitPlane {
        let (u, v) = light.any_orthonormal_pair();
        FitPlane {
            light,
            p0: centre + light * (2.0 * radius),
            u,
            v,
            half: 3.0 * radius,
            m,
        }
    }

    /// Width of a cell.
    pub fn cell(&self) -> f32 {
        2.0 * self.half / self.m as f32
    }

    /// The point at cell coordinates (i, j) (cell (0, 0) spans [0, 1)²).
    pub fn at(&self, i: f32, j: f32) -> Vec3 {
        let cell = self.cell();
        self.p0 + self.u * (-self.half + i * cell) + self.v * (-self.half + j * cell)
    }

    /// Cell coordinates of a point of the plane.
    pub fn coords(&self, p: Vec3) -> (f32, f32) {
        let q = p - self.p0;
        let cell = self.cell();
        (
            (q.dot(self.u) + self.half) / cell,
            (q.dot(self.v) + self.half) / cell,
        )
    }

    /// The cell (index into an m × m image) where the ray from `origin` along `dir` crosses
    /// the plane going with the light; `None` when it does not or crosses outside.
    pub fn cell_of(&self, origin: Vec3, dir: Vec3) -> Option<usize> {
        let c = dir.dot(self.light);
        if c <= 1e-4 {
            return None;
        }
        let t = (self.p0 - origin).dot(self.light) / c;
        if t <= 0.0 {
            return None;
        }
        let (a, b) = self.coords(origin + dir * t);
        let m = self.m;
        (a >= 0.0 && b >= 0.0 && (a as usize) < m && (b as usize) < m)
            .then(|| b as usize * m + a as usize)
    }

    /// Area of a cell.
    pub fn cell_area(&self) -> f64 {
        f64::from(self.cell()).powi(2)
    }
}

/// Σ|model − photons| / Σ photons after a 3 × 3 box blur of both (m × m images, clamped at
/// the edges); `None` when the photons carry nothing.
pub fn relative_l1(model: &[f64], photons: &[f64], m: usize) -> Option<f64> {
    let (bm, bp) = (blur(model, m), blur(photons, m));
    let total: f64 = bp.iter().sum();
    (total > 0.0).then(|| bm.iter().zip(&bp).map(|(a, b)| (a - b).abs()).sum::<f64>() / total)
}

/// 3 × 3 box blur of an m × m image, clamped at the edges.
fn blur(img: &[f64], m: usize) -> Vec<f64> {
    (0..m * m)
        .map(|k| {
            let (i, j) = ((k % m) as i64, (k / m) as i64);
            let mut s = 0.0;
            for dj in -1..=1 {
                for di in -1..=1 {
                    let x = (i + di).clamp(0, m as i64 - 1) as usize;
                    let y = (j + dj).clamp(0, m as i64 - 1) as usize;
                    s += img[y * m + x];
                }
            }
            s / 9.0
        })
        .collect()
}
