//! Procedural water: a wave height field over a rectangle, the water body below it (a medium
//! that absorbs), and a floor at a depth. Used by the reference (the surface as a refracting
//! boundary, the body as an absorbing medium) and by method `water`.
//!
//! Two wave presets:
//! - `article`: the wave function of Sánchez-Crespo (2003), in the article's units (x, y in
//!   [0, 1] across the rectangle, heights in units of its x side):
//!   z = 2·A·d·Σᵢ −fᵢ cos(t·S + x·y·W/fᵢ), fᵢ = F/2ⁱ, d = √(x² + y²), with its analytic gradient
//!   (the article's printed gradient drops its second term; this one is complete).
//! - `physical`: a sum of directional sine waves with wavelengths and amplitudes in metres,
//!   travelling at the deep-water phase speed √(gλ/2π) unless given one.

use super::world::Mesh;
use glam::{Vec2, Vec3};
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::f32::consts::TAU;

/// Standard gravity, m/s², for the deep-water dispersion relation ω² = g·k.
const GRAVITY: f32 = 9.81;

/// The wave preset of a water surface.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, JsonSchema)]
#[serde(tag = "preset", rename_all = "snake_case", deny_unknown_fields)]
pub enum WavesDesc {
    /// The article's wave function (defaults: its constants OCTAVES 5, VTXSIZE 0.01,
    /// WAVESIZE 10, FACTOR 1, SPEED 2).
    Article {
        #[serde(default = "default_octaves")]
        octaves: u32,
        /// VTXSIZE: amplitude, in units of the rectangle's x side.
        #[serde(default = "default_vtxsize")]
        amplitude: f32,
        /// WAVESIZE: frequency.
        #[serde(default = "default_wavesize")]
        frequency: f32,
        /// FACTOR: the first octave's weight; each next octave halves it and doubles its
        /// frequency.
        #[serde(default = "one")]
        factor: f32,
        /// SPEED: phase advance per second, radians.
        #[serde(default = "default_speed")]
        speed: f32,
    },
    /// Directional sine waves, lengths in metres (default: a five-wave swell, steepness
    /// a·k ≈ 0.04 each).
    Physical {
        #[serde(default = "default_waves")]
        waves: Vec<WaveDesc>,
    },
}

impl Default for WavesDesc {
    fn default() -> Self {
        WavesDesc::Article {
            octaves: default_octaves(),
            amplitude: default_vtxsize(),
            frequency: default_wavesize(),
            factor: 1.0,
            speed: default_speed(),
        }
    }
}

/// One sine wave: h = amplitude · sin(k·(x, z)·dir − ω·t + phase).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WaveDesc {
    /// Metres, > 0.
    pub wavelength: f32,
    /// Metres, ≥ 0.
    pub amplitude: f32,
    /// Heading in degrees in the horizontal plane: 0 travels along +X, 90 along +Z.
    #[serde(default)]
    pub heading: f32,
    /// Radians.
    #[serde(default)]
    pub phase: f32,
    /// Phase speed in m/s (default: deep water, √(gλ/2π)).
    #[serde(default)]
    pub speed: Option<f32>,
}

fn default_octaves() -> u32 {
    5
}
fn default_vtxsize() -> f32 {
    0.01
}
fn default_wavesize() -> f32 {
    10.0
}
fn default_speed() -> f32 {
    2.0
}
fn one() -> f32 {
    1.0
}

/// A default swell: five waves from 1.6 m to 0.21 m.
pub fn default_waves() -> Vec<WaveDesc> {
    [
        (1.6, 0.012, 0.0),
        (0.9, 0.007, 35.0),
        (0.55, 0.004, -50.0),
        (0.33, 0.0022, 80.0),
        (0.21, 0.0012, 15.0),
    ]
    .into_iter()
    .enumerate()
    .map(|(i, (wavelength, amplitude, heading))| WaveDesc {
        wavelength,
        amplitude,
        heading,
        phase: i as f32 * 1.3,
        speed: None,
    })
    .collect()
}

/// Transmission per metre of sea water in the article (77–80 %), as absorption coefficients
/// per metre (R, G, B).
pub fn default_absorption() -> [f32; 3] {
    [-(0.77f32.ln()), -(0.785f32.ln()), -(0.80f32.ln())]
}

/// The largest |time| in seconds a water surface takes (phases stay exact: they are reduced
/// modulo 2π in f64 before the f32 wave sums).
pub const MAX_TIME: f32 = 1e6;

/// (rate · t) modulo 2π, worked out in f64 so that a late time keeps its precision.
pub fn phase_at(rate: f32, t: f32) -> f32 {
    (f64::from(rate) * f64::from(t)).rem_euclid(std::f64::consts::TAU) as f32
}

/// The most waves a physical preset may have, octaves an article preset.
pub const MAX_WAVES: usize = 64;
pub const MAX_OCTAVES: u32 = 16;

/// One resolved sine wave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wave {
    /// Wave vector, rad/m.
    pub k: Vec2,
    pub amplitude: f32,
    /// Angular frequency, rad/s.
    pub omega: f32,
    pub phase: f32,
}

/// The resolved wave function.
#[derive(Clone, Debug, PartialEq)]
pub enum Waves {
    Article {
        octaves: u32,
        amplitude: f32,
        frequency: f32,
        factor: f32,
        speed: f32,
    },
    Physical(Vec<Wave>),
}

impl Waves {
    /// Checks `d` (fields named under `path`) and resolves it.
    pub fn resolve(d: &WavesDesc, path: &str) -> Result<Waves, (String, String)> {
        let bad = |f: &str, m: &str| Err((format!("{path}.{f}"), m.to_string()));
        match *d {
            WavesDesc::Article {
                octaves,
                amplitude,
                frequency,
                factor,
                speed,
            } => {
                if !(1..=MAX_OCTAVES).contains(&octaves) {
                    return bad("octaves", &format!("must lie in 1..={MAX_OCTAVES}"));
                }
                if !(amplitude.is_finite() && (0.0..=0.1).contains(&amplitude)) {
                    return bad("amplitude", "must lie in 0..=0.1");
                }
                if !(frequency.is_finite() && frequency > 0.0 && frequency <= 1000.0) {
                    return bad("frequency", "must lie in (0, 1000]");
                }
                if !(factor.is_finite() && factor > 0.0 && factor <= 100.0) {
                    return bad("factor", "must lie in (0, 100]");
                }
                if !speed.is_finite() || speed.abs() > 1000.0 {
                    return bad("speed", "must be a finite number of radians per second");
                }
                Ok(Waves::Article {
                    octaves,
                    amplitude,
                    frequency,
                    factor,
                    speed,
                })
            }
            WavesDesc::Physical { ref waves } => {
                if waves.is_empty() || waves.len() > MAX_WAVES {
                    return bad("waves", &format!("must hold 1..={MAX_WAVES} waves"));
                }
                let mut out = Vec::new();
                for (i, w) in waves.iter().enumerate() {
                    let f = |n: &str| format!("waves[{i}].{n}");
                    if !(w.wavelength.is_finite() && w.wavelength > 0.0) {
                        return bad(&f("wavelength"), "must be a finite number of metres > 0");
                    }
                    if !(w.amplitude.is_finite() && w.amplitude >= 0.0) {
                        return bad(&f("amplitude"), "must be a finite number of metres ≥ 0");
                    }
                    let k = TAU / w.wavelength;
                    if w.amplitude * k > 0.5 {
                        return bad(
                            &f("amplitude"),
                            "is too steep for its wavelength (amplitude × 2π/wavelength must \
                             be ≤ 0.5)",
                        );
                    }
                    if !w.heading.is_finite() || !w.phase.is_finite() {
                        return bad(&f("heading"), "heading and phase must be finite");
                    }
                    let speed = match w.speed {
                        Some(s) if !(s.is_finite() && s.abs() <= 1000.0) => {
                            return bad(&f("speed"), "must lie in -1000..=1000 m/s");
                        }
                        Some(s) => s,
                        None => (GRAVITY / k).sqrt(),
                    };
                    let h = w.heading.to_radians();
                    out.push(Wave {
                        k: Vec2::new(h.cos(), h.sin()) * k,
                        amplitude: w.amplitude,
                        omega: k * speed,
                        phase: w.phase,
                    });
                }
                Ok(Waves::Physical(out))
            }
        }
    }

    pub fn preset(&self) -> &'static str {
        match self {
            Waves::Article { .. } => "article",
            Waves::Physical(_) => "physical",
        }
    }
}

/// The water surface at one time: a height field over a rectangle centred on `centre`
/// (world space, mean height `centre.y`), `size` = [x extent, z extent].
#[derive(Clone, Debug, PartialEq)]
pub struct WaterSurface {
    pub centre: Vec3,
    pub size: Vec2,
    /// Changing the waves' count or rates needs [`Self::set_time`] again.
    pub waves: Waves,
    time: f32,
    /// Per wave (one for the article's), its rate × time modulo 2π: the time's share of each
    /// phase, reduced once in f64 ([`phase_at`]).
    phases: Vec<f32>,
}

impl WaterSurface {
    pub fn new(centre: Vec3, size: Vec2, waves: Waves, time: f32) -> WaterSurface {
        let mut s = WaterSurface {
            centre,
            size,
            waves,
            time,
            phases: Vec::new(),
        };
        s.set_time(time);
        s
    }

    /// Seconds.
    pub fn time(&self) -> f32 {
        self.time
    }

    /// Moves the waves to time `t` (seconds).
    pub fn set_time(&mut self, t: f32) {
        self.time = t;
        self.phases = match &self.waves {
            Waves::Article { speed, .. } => vec![phase_at(*speed, t)],
            Waves::Physical(ws) => ws.iter().map(|w| phase_at(w.omega, t)).collect(),
        };
    }

    /// Whether the horizontal position (x, z) lies over the rectangle.
    pub fn contains(&self, x: f32, z: f32) -> bool {
        let l = Vec2::new(x - self.centre.x, z - self.centre.z).abs();
        l.x <= self.size.x * 0.5 && l.y <= self.size.y * 0.5
    }

    /// Height above the mean and its gradient (∂h/∂x, ∂h/∂z) at world (x, z).
    pub fn height_gradient(&self, x: f32, z: f32) -> (f32, Vec2) {
        let (lx, lz) = (x - self.centre.x, z - self.centre.z);
        match &self.waves {
            Waves::Article {
                octaves,
                amplitude,
                frequency,
                factor,
                ..
            } => {
                // The article's coordinates: x, y in [0, 1] across the rectangle, heights in
                // units of the x side.
                let s = self.size;
                let (u, v) = (lx / s.x + 0.5, lz / s.y + 0.5);
                let d = (u * u + v * v).sqrt();
                let (mut c, mut sn) = (0.0f32, 0.0f32);
                let mut f = *factor;
                let ts = self.phases[0];
                for _ in 0..*octaves {
                    let ph = ts + u * v * frequency / f;
                    c -= f * ph.cos();
                    sn += ph.sin();
                    f *= 0.5;
                }
                // z = 2A·d·C with C = Σ −fᵢ cos φᵢ; ∂C/∂u = Σ sin φᵢ · v·W, ∂C/∂v = Σ sin φᵢ · u·W.
                let z = 2.0 * amplitude * d * c;
                let (du, dv) = if d > 0.0 { (u / d, v / d) } else { (0.0, 0.0) };
                let zu = 2.0 * amplitude * (du * c + d * sn * v * frequency);
                let zv = 2.0 * amplitude * (dv * c + d * sn * u * frequency);
                // h = s.x·z(u, v): ∂h/∂x = s.x·zu/s.x, ∂h/∂z = s.x·zv/s.y.
                (z * s.x, Vec2::new(zu, zv * s.x / s.y))
            }
            Waves::Physical(waves) => {
                let p = Vec2::new(lx, lz);
                let mut h = 0.0;
                let mut g = Vec2::ZERO;
                for (w, wt) in waves.iter().zip(&self.phases) {
                    let ph = w.k.dot(p) - wt + w.phase;
                    h += w.amplitude * ph.sin();
                    g += w.k * (w.amplitude * ph.cos());
                }
                (h, g)
            }
        }
    }

    /// World height of the surface at (x, z).
    pub fn height(&self, x: f32, z: f32) -> f32 {
        self.centre.y + self.height_gradient(x, z).0
    }

    /// Unit upward normal at (x, z), from the analytic gradient.
    pub fn normal(&self, x: f32, z: f32) -> Vec3 {
        let g = self.height_gradient(x, z).1;
        Vec3::new(-g.x, 1.0, -g.y).normalize()
    }

    /// Unit upward normal at (x, z) from central finite differences of the height with step
    /// `h` (the article's original per-vertex method).
    pub fn normal_finite_differences(&self, x: f32, z: f32, h: f32) -> Vec3 {
        let dx = (self.height(x + h, z) - self.height(x - h, z)) / (2.0 * h);
        let dz = (self.height(x, z + h) - self.height(x, z - h)) / (2.0 * h);
        Vec3::new(-dx, 1.0, -dz).normalize()
    }

    /// A bound on |height − mean| over the rectangle.
    pub fn amplitude_bound(&self) -> f32 {
        match &self.waves {
            Waves::Article {
                octaves,
                amplitude,
                factor,
                ..
            } => {
                let sum: f32 = (0..*octaves).map(|i| factor / 2f32.powi(i as i32)).sum();
                2.0 * amplitude * std::f32::consts::SQRT_2 * sum * self.size.x
            }
            Waves::Physical(w) => w.iter().map(|w| w.amplitude).sum(),
        }
    }

    /// The shortest horizontal length over which the surface changes (the shortest wavelength),
    /// metres: what a tessellation or a march along the surface must resolve.
    pub fn feature_length(&self) -> f32 {
        match &self.waves {
            Waves::Article {
                octaves,
                frequency,
                factor,
                ..
            } => {
                // Phase x·y·W/f: at most W/f_min per unit of x or y.
                let f_min = factor / 2f32.powi(*octaves as i32 - 1);
                TAU * f_min / frequency * self.size.min_element()
            }
            Waves::Physical(w) => w
                .iter()
                .filter(|w| w.amplitude > 0.0)
                .map(|w| TAU / w.k.length())
                .fold(f32::INFINITY, f32::min)
                .min(self.size.min_element()),
        }
    }

    /// The first crossing of the ray o + t·d (t in (0, t_max)) with the surface over the
    /// rectangle: marched in steps of a sixteenth of the feature length inside the slab the
    /// waves stay in, then refined by bisection.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec3)> {
        let a = self.amplitude_bound() + 1e-4;
        let (y0, y1) = (self.centre.y - a, self.centre.y + a);
        // The ray's interval inside the slab.
        let (mut t0, mut t1) = if d.y.abs() < 1e-9 {
            if o.y < y0 || o.y > y1 {
                return None;
            }
            (0.0, t_max)
        } else {
            let (ta, tb) = ((y0 - o.y) / d.y, (y1 - o.y) / d.y);
            (ta.min(tb), ta.max(tb))
        };
        t0 = t0.max(1e-6);
        t1 = t1.min(t_max);
        // And inside the rectangle's x and z slabs.
        for (o, d, c, h) in [
            (o.x, d.x, self.centre.x, self.size.x * 0.5),
            (o.z, d.z, self.centre.z, self.size.y * 0.5),
        ] {
            if d.abs() < 1e-12 {
                if (o - c).abs() > h {
                    return None;
                }
            } else {
                let (ta, tb) = ((c - h - o) / d, (c + h - o) / d);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t0 >= t1 {
            return None;
        }
        let f = |t: f32| {
            let p = o + d * t;
            p.y - self.height(p.x, p.z)
        };
        let horiz = Vec2::new(d.x, d.z).length().max(1e-6);
        let step = (self.feature_length() / 16.0 / horiz).max((t1 - t0) / 65536.0);
        let mut ta = t0;
        let mut fa = f(ta);
        while ta < t1 {
            let tb = (ta + step).min(t1);
            let fb = f(tb);
            if fa.signum() != fb.signum() {
                // Regula falsi (Illinois) inside the bracket: a few steps reach 1e-7 m.
                let (mut lo, mut hi, mut flo, mut fhi) = (ta, tb, fa, fb);
                let mut t = 0.5 * (lo + hi);
                let mut side = 0;
                for _ in 0..24 {
                    t = (lo * fhi - hi * flo) / (fhi - flo);
                    if !(t > lo && t < hi) {
                        t = 0.5 * (lo + hi);
                    }
                    let ft = f(t);
                    if ft.abs() < 1e-7 || hi - lo < 1e-7 {
                        break;
                    }
                    if ft.signum() == flo.signum() {
                        lo = t;
                        flo = ft;
                        if side == -1 {
                            fhi *= 0.5;
                        }
                        side = -1;
                    } else {
                        hi = t;
                        fhi = ft;
                        if side == 1 {
                            flo *= 0.5;
                        }
                        side = 1;
                    }
                }
                let p = o + d * t;
                if self.contains(p.x, p.z) {
                    return Some((t, p));
                }
            }
            ta = tb;
            fa = fb;
        }
        None
    }

    /// The surface as a grid of `n` × `n` quads over the rectangle, in the frame centred on
    /// `centre`, normals from the analytic gradient, front faces up.
    pub fn mesh(&self, n: u32) -> Mesh {
        let n = n.max(1);
        let mut m = Mesh::default();
        for j in 0..=n {
            for i in 0..=n {
                let lx = (i as f32 / n as f32 - 0.5) * self.size.x;
                let lz = (j as f32 / n as f32 - 0.5) * self.size.y;
                let (x, z) = (lx + self.centre.x, lz + self.centre.z);
                m.positions
                    .push(Vec3::new(lx, self.height_gradient(x, z).0, lz));
                m.normals.push(self.normal(x, z));
            }
        }
        let row = n + 1;
        for j in 0..n {
            for i in 0..n {
                let a = j * row + i;
                // Counter-clockwise seen from +Y (x right, z towards the viewer).
                m.indices.push([a, a + row, a + 1]);
                m.indices.push([a + 1, a + row, a + row + 1]);
            }
        }
        m
    }
}

/// A water body: the surface, the medium below it down to `depth`, its index and absorption.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterBody {
    /// The surface's object in [`super::World::objects`].
    pub object: usize,
    pub surface: WaterSurface,
    /// Metres below the mean surface the body reaches (its floor, if it has one).
    pub depth: f32,
    pub ior: f32,
    /// Beer-Lambert coefficient per metre.
    pub absorption: Vec3,
    /// The floor's object, when the water has one.
    pub floor: Option<usize>,
    /// Quads per side of the surface's tessellation.
    pub resolution: u32,
}

impl WaterBody {
    /// Whether `p` lies in the water: over the rectangle, under the surface, above the bottom.
    pub fn contains(&self, p: Vec3) -> bool {
        let s = &self.surface;
        s.contains(p.x, p.z) && p.y > s.centre.y - self.depth - 1e-3 && p.y < s.height(p.x, p.z)
    }

    /// The part of the straight segment a → b inside the body's box (the rectangle, from the
    /// bottom up to the highest crest), as fractions of the segment; None if it misses the box.
    pub fn clip(&self, a: Vec3, b: Vec3) -> Option<(f32, f32)> {
        let s = &self.surface;
        let (bottom, top) = (-self.depth - 1e-3, s.amplitude_bound());
        let centre = s.centre + Vec3::Y * (0.5 * (bottom + top));
        let half = Vec3::new(0.5 * s.size.x, 0.5 * (top - bottom), 0.5 * s.size.y);
        super::medium::box_interval(a - centre, b - a, half, 1.0)
    }

    /// Transmittance of the straight segment a → b, which crosses no surface: Beer-Lambert over
    /// the length of it that lies in the water. The segment may enter or leave the body through
    /// its open sides (the rectangle's edges under the surface: light the sides let in travels
    /// straight, as the reference traces it), so it is clipped to the body's box first; the
    /// clipped part crosses no surface, so it lies wholly in the water or wholly above it
    /// (judged at its midpoint).
    pub fn transmittance(&self, a: Vec3, b: Vec3) -> Vec3 {
        if self.absorption == Vec3::ZERO {
            return Vec3::ONE;
        }
        let Some((t0, t1)) = self.clip(a, b) else {
            return Vec3::ONE;
        };
        let d = b - a;
        if !self.contains(a + d * (0.5 * (t0 + t1))) {
            return Vec3::ONE;
        }
        (-self.absorption * (d.length() * (t1 - t0))).exp()
    }
}

/// Sets every water surface of `world` to time `t` (seconds, finite): the surfaces' meshes
/// are made again, nothing else changes.
pub fn set_time(world: &mut super::World, t: f32) {
    for w in &mut world.water {
        w.surface.set_time(t);
        if let Some(part) = world
            .objects
            .get_mut(w.object)
            .and_then(|o| o.parts.first_mut())
        {
            part.mesh = std::sync::Arc::new(w.surface.mesh(w.resolution));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn surface(waves: WavesDesc, time: f32) -> WaterSurface {
        WaterSurface::new(
            Vec3::new(0.3, -0.2, 0.1),
            Vec2::new(4.0, 3.0),
            Waves::resolve(&waves, "waves").unwrap(),
            time,
        )
    }

    #[test]
    fn analytic_gradients_match_finite_differences() {
        let presets = [
            WavesDesc::default(),
            WavesDesc::Physical {
                waves: default_waves(),
            },
        ];
        for p in presets {
            let s = surface(p.clone(), 1.7);
            let mut worst = 0.0f32;
            for k in 0..200 {
                let x = -1.6 + (k as f32 * 0.618).fract() * 3.6;
                let z = -1.3 + (k as f32 * 0.414).fract() * 2.8;
                let g = s.height_gradient(x, z).1;
                let h = 1e-3;
                let fd = Vec2::new(
                    (s.height(x + h, z) - s.height(x - h, z)) / (2.0 * h),
                    (s.height(x, z + h) - s.height(x, z - h)) / (2.0 * h),
                );
                worst = worst.max((g - fd).length() / (1.0 + g.length()));
            }
            assert!(worst < 5e-3, "{p:?}: gradient off by {worst}");
        }
    }

    #[test]
    fn article_preset_is_the_articles_function() {
        // The Cg listing at x = 0.3, y = 0.6 (article units), t = 0.5.
        let (x, y, t) = (0.3f32, 0.6f32, 0.5f32);
        let mut z = 0.0;
        let mut f = 1.0f32;
        for _ in 0..5 {
            z -= f * (t * 2.0 + (1.0 / f) * x * y * 10.0).cos();
            f /= 2.0;
        }
        let want = 2.0 * 0.01 * (x * x + y * y).sqrt() * z;
        let s = surface(WavesDesc::default(), t);
        let wx = s.centre.x + (x - 0.5) * s.size.x;
        let wz = s.centre.z + (y - 0.5) * s.size.y;
        let got = s.height_gradient(wx, wz).0 / s.size.x;
        assert!((got - want).abs() < 1e-6, "{got} vs {want}");
    }

    #[test]
    fn rays_find_the_surface() {
        let s = surface(
            WavesDesc::Physical {
                waves: default_waves(),
            },
            0.4,
        );
        for k in 0..50 {
            let o = Vec3::new(-1.0 + k as f32 * 0.04, 2.0, 0.5);
            let d = Vec3::new(0.3, -1.0, 0.2).normalize();
            let (t, p) = s.intersect(o, d, 100.0).expect("hits");
            assert!((p.y - s.height(p.x, p.z)).abs() < 1e-4);
            assert!((o + d * t - p).length() < 1e-4);
        }
        // Outside the rectangle: no hit.
        assert!(
            s.intersect(Vec3::new(9.0, 2.0, 0.0), -Vec3::Y, 100.0)
                .is_none()
        );
    }

    #[test]
    fn bad_waves_name_their_field() {
        for (w, field) in [
            (
                WavesDesc::Physical {
                    waves: vec![WaveDesc {
                        wavelength: 0.0,
                        amplitude: 0.1,
                        heading: 0.0,
                        phase: 0.0,
                        speed: None,
                    }],
                },
                "w.waves[0].wavelength",
            ),
            (WavesDesc::Physical { waves: vec![] }, "w.waves"),
            (
                WavesDesc::Article {
                    octaves: 0,
                    amplitude: 0.01,
                    frequency: 10.0,
                    factor: 1.0,
                    speed: 2.0,
                },
                "w.octaves",
            ),
        ] {
            assert_eq!(Waves::resolve(&w, "w").unwrap_err().0, field);
        }
    }
}
