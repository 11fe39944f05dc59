//! Lights as the direct pass reads them: delta lights with their shadow map layers and
//! matrices (directional: orthographic fitted to the scene bounds; spot: perspective, or a cube
//! when the cone is too wide; point: six faces; line: `LINE_SAMPLES` shadowed point lights), and
//! the environment as SH irradiance plus at most one bound map, its suns as shadowed directional
//! lights and the rest's visibility from its median-cut directions' shadow maps ([`super::sky`]).

use crate::scene::{EnvMap, Light, World};
use bytemuck::{Pod, Zeroable};
use glam::camera::rh::proj::directx as proj;
use glam::camera::rh::view::look_at_mat4 as look_at;
use glam::{Mat4, Vec3, Vec4};
use std::sync::Arc;

/// Point samples a line light is split into (each carries intensity / N).
pub const LINE_SAMPLES: usize = 8;
/// Side of each shadow map of the environment's sky directions: each carries 1/64 of the
/// sky's light, so a coarse map's edges blur into the others'.
pub const SKY_SHADOW_RESOLUTION: u32 = 512;
/// Spots with a cutoff above this use a cube of shadow maps instead of one perspective map.
const MAX_SPOT_PERSPECTIVE_CUTOFF: f32 = 75.0 * std::f32::consts::PI / 180.0;
/// Field of view of a cube face: a little over 90° so that the 3×3 PCF kernel stays inside.
const CUBE_FACE_TAN: f32 = 1.05;

pub const KIND_DIRECTIONAL: u32 = 0;
pub const KIND_POINT: u32 = 1;
pub const KIND_SPOT: u32 = 2;

/// `Light` of `common.inc.wgsl` (its layout is checked against naga's in `render::shaders`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuLight {
    pub kind: u32,
    pub first_layer: u32,
    pub n_layers: u32,
    pub ortho: u32,
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub intensity: [f32; 4],
    /// cutoff, beam width (radians), shadow texel size, unused.
    pub params: [f32; 4],
    pub mats: [[f32; 16]; 6],
}

/// One layer of the shadow map array to render.
#[derive(Clone, Copy, Debug)]
pub struct ShadowLayer {
    pub view_proj: Mat4,
    /// False when the scene bounds lie outside this layer's frustum: cleared, not drawn.
    pub visible: bool,
}

/// The environment lights folded together.
#[derive(Clone, Debug, Default)]
pub struct EnvSetup {
    /// Sum of the constant environment radiances.
    pub constant: Vec3,
    /// The map bound for specular lookups, with its scale.
    pub map: Option<(Arc<EnvMap>, Vec3)>,
    /// Irradiance SH coefficients (cosine-convolved), constant and all maps included.
    pub sh: [Vec3; 9],
    /// Environment maps beyond the first: in the irradiance, not in reflections.
    pub extra_maps: usize,
}

#[derive(Clone, Debug, Default)]
pub struct LightPlan {
    /// The lights the pass shades with (the scene's delta lights, then the environment's
    /// suns), followed by the environment's sky directions (`sky`).
    pub lights: Vec<GpuLight>,
    pub layers: Vec<ShadowLayer>,
    /// The sky directions' shadow maps, [`SKY_SHADOW_RESOLUTION`]² each, in an array of their
    /// own (their lights' `first_layer` indexes it).
    pub sky_layers: Vec<ShadowLayer>,
    pub env: EnvSetup,
    /// The entries of `lights` that are the environment's sky directions (their `intensity.x`
    /// the direction's weight): they light nothing themselves, their shadow maps tell how much
    /// of the environment's SH irradiance reaches a point. Empty without an environment.
    pub sky: std::ops::Range<u32>,
}

fn v4(v: Vec3) -> [f32; 4] {
    [v.x, v.y, v.z, 0.0]
}

/// The eight corners of the box [lo, hi].
pub(super) fn corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Whether an axis-aligned box can intersect the clip volume of `vp` (conservative: false only
/// when all corners lie outside one clip plane).
fn box_visible(vp: Mat4, lo: Vec3, hi: Vec3) -> bool {
    let c: Vec<Vec4> = corners(lo, hi).iter().map(|p| vp * p.extend(1.0)).collect();
    let planes: [fn(Vec4) -> bool; 6] = [
        |c| c.x < -c.w,
        |c| c.x > c.w,
        |c| c.y < -c.w,
        |c| c.y > c.w,
        |c| c.z < 0.0,
        |c| c.z > c.w,
    ];
    !planes.iter().any(|out| c.iter().all(|p| out(*p)))
}

fn up_for(d: Vec3) -> Vec3 {
    if d.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

/// Near and far planes for a perspective shadow map from `pos` covering the scene box.
fn near_far(pos: Vec3, lo: Vec3, hi: Vec3) -> (f32, f32) {
    let far = corners(lo, hi)
        .iter()
        .map(|c| c.distance(pos))
        .fold(0.0f32, f32::max)
        * 1.01
        + 1e-3;
    ((far * 1e-3).max(1e-4), far)
}

impl LightPlan {
    pub fn new(world: &World, shadow_res: u32) -> LightPlan {
        let mut plan = LightPlan::default();
        let (lo, hi) = world.bounds();
        let res = shadow_res as f32;
        let mut sky = Vec::new();
        for light in &world.lights {
            match light {
                Light::Directional {
                    direction,
                    irradiance,
                    ..
                } => plan.push_directional(
                    direction.normalize_or(Vec3::NEG_Y),
                    *irradiance,
                    (lo, hi),
                    res,
                    false,
                ),
                Light::Point {
                    position,
                    intensity,
                } => plan.push_point(*position, *intensity, lo, hi, res),
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cutoff,
                    beam_width,
                } => {
                    let axis = direction.normalize_or(Vec3::NEG_Y);
                    if *cutoff > MAX_SPOT_PERSPECTIVE_CUTOFF {
                        plan.push_point(*position, *intensity, lo, hi, res);
                    } else {
                        let (near, far) = near_far(*position, lo, hi);
                        let half = (*cutoff + 2f32.to_radians()).min(80f32.to_radians());
                        let proj = proj::perspective(2.0 * half, 1.0, near, far);
                        let view = look_at(*position, *position + axis, up_for(axis));
                        let vp = proj * view;
                        let mut g = GpuLight::zeroed();
                        g.first_layer = plan.layers.len() as u32;
                        g.n_layers = 1;
                        g.mats[0] = vp.to_cols_array();
                        g.params[2] = 2.0 * half.tan() / res;
                        plan.layers.push(ShadowLayer {
                            view_proj: vp,
                            visible: box_visible(vp, lo, hi),
                        });
                        g.position = v4(*position);
                        g.intensity = v4(*intensity);
                        plan.lights.push(g);
                    }
                    let g = plan.lights.last_mut().expect("just pushed");
                    g.kind = KIND_SPOT;
                    g.direction = v4(axis);
                    g.params[0] = *cutoff;
                    g.params[1] = *beam_width;
                }
                Light::Line {
                    start,
                    end,
                    intensity,
                } => {
                    let n = LINE_SAMPLES;
                    for i in 0..n {
                        let p = start.lerp(*end, (i as f32 + 0.5) / n as f32);
                        plan.push_point(p, *intensity / n as f32, lo, hi, res);
                    }
                }
                Light::Environment { map, radiance } => match map {
                    None => plan.env.constant += *radiance,
                    Some(m) => {
                        let lit = super::sky::lighting(m);
                        for (acc, c) in plan.env.sh.iter_mut().zip(lit.sh) {
                            *acc += c * *radiance;
                        }
                        for sun in &lit.suns {
                            plan.push_directional(
                                -sun.towards,
                                sun.irradiance * *radiance,
                                (lo, hi),
                                res,
                                false,
                            );
                        }
                        if plan.env.map.is_none() {
                            plan.env.map = Some((m.clone(), *radiance));
                            sky = lit.sky.clone();
                        } else {
                            plan.env.extra_maps += 1;
                        }
                    }
                },
            }
        }
        // A constant radiance L gives irradiance πL on any normal: c00·Y00 = πL.
        plan.env.sh[0] += plan.env.constant * (std::f32::consts::PI / SH_Y00);
        // The sky's directions: the first map's regions, or, for constant environments only,
        // directions spread evenly.
        if sky.is_empty() && plan.env.constant.max_element() > 0.0 {
            sky = super::sky::uniform_directions(super::sky::SKY_DIRECTIONS);
        }
        let first = plan.lights.len() as u32;
        let sky_res = SKY_SHADOW_RESOLUTION as f32;
        for d in &sky {
            plan.push_directional(-d.towards, Vec3::splat(d.weight), (lo, hi), sky_res, true);
        }
        plan.sky = first..plan.lights.len() as u32;
        plan
    }

    /// A directional light travelling along `d` (unit) with an orthographic shadow map of `res`
    /// texels a side fitted to the scene box, in the sky's array where `sky`.
    fn push_directional(
        &mut self,
        d: Vec3,
        irradiance: Vec3,
        (lo, hi): (Vec3, Vec3),
        res: f32,
        sky: bool,
    ) {
        let c = (lo + hi) * 0.5;
        let r = ((hi - lo).length() * 0.5).max(1e-3);
        let view = look_at(c - d * 2.0 * r, c, up_for(d));
        let (mut vlo, mut vhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in corners(lo, hi) {
            let q = view.transform_point3(p);
            vlo = vlo.min(q);
            vhi = vhi.max(q);
        }
        let ext = (vhi.x - vlo.x).max(vhi.y - vlo.y).max(1e-3);
        let m = ext * 0.02;
        let mz = (vhi.z - vlo.z) * 0.01 + 1e-3;
        let proj = proj::orthographic(
            vlo.x - m,
            vhi.x + m,
            vlo.y - m,
            vhi.y + m,
            -vhi.z - mz,
            -vlo.z + mz,
        );
        let vp = proj * view;
        let layers = if sky {
            &mut self.sky_layers
        } else {
            &mut self.layers
        };
        let mut g = GpuLight::zeroed();
        g.kind = KIND_DIRECTIONAL;
        g.first_layer = layers.len() as u32;
        g.n_layers = 1;
        g.ortho = 1;
        g.direction = v4(d);
        g.intensity = v4(irradiance);
        g.params = [0.0, 0.0, (ext + 2.0 * m) / res, 0.0];
        g.mats[0] = vp.to_cols_array();
        layers.push(ShadowLayer {
            view_proj: vp,
            visible: true,
        });
        self.lights.push(g);
    }

    fn push_point(&mut self, pos: Vec3, intensity: Vec3, lo: Vec3, hi: Vec3, res: f32) {
        let (near, far) = near_far(pos, lo, hi);
        let proj = proj::perspective(2.0 * CUBE_FACE_TAN.atan(), 1.0, near, far);
        let mut g = GpuLight::zeroed();
        g.kind = KIND_POINT;
        g.first_layer = self.layers.len() as u32;
        g.n_layers = 6;
        g.position = v4(pos);
        g.intensity = v4(intensity);
        g.params[2] = 2.0 * CUBE_FACE_TAN / res;
        let axes = [
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::Z,
            Vec3::NEG_Z,
        ];
        for (f, a) in axes.iter().enumerate() {
            let vp = proj * look_at(pos, pos + *a, up_for(*a));
            g.mats[f] = vp.to_cols_array();
            self.layers.push(ShadowLayer {
                view_proj: vp,
                visible: box_visible(vp, lo, hi),
            });
        }
        self.lights.push(g);
    }
}

const SH_Y00: f32 = 0.282095;

/// Irradiance SH of an equirectangular map (per unit scale): radiance projected on the first
/// nine real SH functions, each band multiplied by the cosine lobe's Â_l (π, 2π/3, π/4).
pub fn sh_project(m: &EnvMap) -> [Vec3; 9] {
    use std::f32::consts::PI;
    let mut c = [Vec3::ZERO; 9];
    let (w, h) = (m.width as usize, m.height as usize);
    let rows = h.max(2) - 1;
    for y in 0..h {
        let dw = super::sky::texel_solid_angle(y, w, h);
        for x in 0..w {
            let d = EnvMap::direction((x as f32 + 0.5) / w as f32, y as f32 / rows as f32);
            let l = m.texels[y * w + x] * dw;
            let basis = sh_basis(d);
            for (ci, b) in c.iter_mut().zip(basis) {
                *ci += l * b;
            }
        }
    }
    let a = [PI, 2.0 * PI / 3.0, PI / 4.0];
    for (i, ci) in c.iter_mut().enumerate() {
        *ci *= a[if i == 0 {
            0
        } else if i < 4 {
            1
        } else {
            2
        }];
    }
    c
}

/// The real SH basis in the order `common.inc.wgsl` evaluates it.
pub fn sh_basis(n: Vec3) -> [f32; 9] {
    [
        SH_Y00,
        0.488603 * n.y,
        0.488603 * n.z,
        0.488603 * n.x,
        1.092548 * n.x * n.y,
        1.092548 * n.y * n.z,
        0.315392 * (3.0 * n.z * n.z - 1.0),
        1.092548 * n.x * n.z,
        0.546274 * (n.x * n.x - n.y * n.y),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_map_irradiance_is_pi_l() {
        let m = EnvMap {
            width: 64,
            height: 32,
            texels: vec![Vec3::splat(2.0); 64 * 32],
        };
        let sh = sh_project(&m);
        for n in [Vec3::Y, Vec3::X, Vec3::new(0.3, -0.8, 0.5).normalize()] {
            let e: Vec3 = sh.iter().zip(sh_basis(n)).map(|(c, b)| *c * b).sum();
            assert!((e.x - 2.0 * std::f32::consts::PI).abs() < 0.02, "{e}");
        }
    }

    #[test]
    fn cube_faces_cover_all_directions() {
        let mut plan = LightPlan::default();
        plan.push_point(
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::splat(-1.0),
            Vec3::splat(1.0),
            2048.0,
        );
        let m: Vec<Mat4> = plan.lights[0]
            .mats
            .iter()
            .map(Mat4::from_cols_array)
            .collect();
        for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.2, 0.3, -0.9)] {
            let a = d.abs();
            let face = if a.x >= a.y && a.x >= a.z {
                if d.x > 0.0 { 0 } else { 1 }
            } else if a.y >= a.z {
                if d.y > 0.0 { 2 } else { 3 }
            } else if d.z > 0.0 {
                4
            } else {
                5
            };
            let c = m[face] * (d * 0.5).extend(1.0);
            let ndc = c.truncate() / c.w;
            assert!(
                c.w > 0.0
                    && ndc.x.abs() <= 1.0
                    && ndc.y.abs() <= 1.0
                    && (0.0..=1.0).contains(&ndc.z)
            );
        }
    }
}
