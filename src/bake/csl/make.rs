//! Stages 3–4 for one bundle: its fit, its rings ([`rings`]) and their intensity images, made
//! CSLs; the *fan* of a bundle's axis; and the loop of stages 2–5 that makes bundles CSLs until
//! they cover the energy ([`Maker::cover`]).
//!
//! **The fan.** A lens's marginal rays leave it steeply, cross its axis close behind it and
//! spread far (a glass sphere lit from above: the rays that enter farther out than 0.85 of its
//! radius cross the axis between its surface and a floor just below it and reach the floor up
//! to several radii out). They lie on the bundle's axis line, but at more than the bundle's
//! angle threshold (60°) from it, or so far off its focus law that its fit dismisses them. Left
//! to the pool, they were gathered into bundles of a mean direction, axes tilted 45–70° from
//! the lens's, each a radially symmetric CSL about the wrong axis: on the sphere lit from 87°
//! they lit a band 0.15–0.34 m from the caustic's centre up to 3.2 times too bright, left the
//! band 0.09–0.14 m at a fifth of its light and drew a dark curved seam through the focus
//! (0.312 relative L1 in the shadow). So after a bundle that carries a share of the energy
//! worth it ([`rings::WORTH`]) is made CSLs, the rays left within the distance threshold of its
//! axis line at up to [`FAN_ANGLE_DEG`] from it are fitted as a bundle of their own on the same
//! axis (the fit finds their light plane and law, [`rings`] their rings): that direction
//! measures 0.073 with as many CSLs (16), and every direction of the sweep is closer.

use super::bundle::{Bundle, Extractor, Thresholds, det_sum};
use super::trace::CausticRay;
use super::{BakeError, BakeStats, Csl, CslParams, TEXEL_SPACINGS, fit, image, rings};
use std::time::Instant;

/// The steepest ray a fan takes, degrees from the axis. Steeper rays would stretch the fan's
/// light plane (a ray at 85° meets a plane a metre before it 11 m from the axis) for light that
/// lands far away.
pub const FAN_ANGLE_DEG: f32 = 85.0;

/// What making a bundle's CSLs needs from the bake.
pub struct Maker<'a> {
    pub rays: &'a [CausticRay],
    pub params: &'a CslParams,
    /// The object's bounding-sphere radius (m): the fit's length scale.
    pub radius: f32,
    /// The fit's plane weight ([`fit::fit_bundle`]'s `w`).
    pub far: f64,
    /// Grid-ray spacing (m).
    pub spacing: f32,
    /// Energy leaving the object (grid-ray units).
    pub total: f64,
    /// [`fit::fit_bundle`]'s `beside`.
    pub spare_cores: bool,
}

impl Maker<'_> {
    /// Stages 2–5 (Liu et al. 2008 §3.1.1): bundles from `ex`'s pool made CSLs until they
    /// cover the target share of the energy, within the bake's bounds on their count and
    /// images' memory; `stats.stopped_by` says which ended it. `report` takes the fraction of
    /// the whole bake done and says whether to go on.
    pub fn cover(
        &self,
        ex: &mut Extractor,
        thresholds: &Thresholds,
        stats: &mut BakeStats,
        report: &dyn Fn(f32) -> bool,
    ) -> Result<Vec<Csl>, BakeError> {
        let (params, total) = (self.params, self.total);
        let mut remaining = total;
        let mut csls = Vec::new();
        let mut attempts = 0u32;
        let mut taken: Option<Vec<u32>> = None;
        stats.stopped_by = "coverage";
        while remaining > (1.0 - params.coverage as f64) * total {
            if csls.len() >= params.max_csls as usize || attempts >= 2 * params.max_csls {
                stats.stopped_by = "count";
                break;
            }
            let image_bytes: u64 = csls.iter().map(|c: &Csl| c.texels.len() as u64 * 8).sum();
            if image_bytes >= params.max_image_bytes {
                stats.stopped_by = "memory";
                break;
            }
            attempts += 1;
            if !report(0.5 + 0.5 * (1.0 - remaining / total.max(1e-30)) as f32) {
                return Err(BakeError::Canceled);
            }
            // The last CSL's rays leave the pool only now, when another bundle is wanted.
            if let Some(kept) = taken.take() {
                let t0 = Instant::now();
                ex.remove(&kept, !self.spare_cores);
                stats.time_bundles += t0.elapsed();
            }
            let Some(cell) = ex.max_cell() else {
                stats.stopped_by = "bundles";
                break;
            };
            let t0 = Instant::now();
            let found = ex.extract(cell, thresholds, self.radius);
            stats.time_bundles += t0.elapsed();
            let Some(b) = found else {
                ex.block(cell);
                stats.rejected_bundles += 1;
                continue;
            };
            let Some(kept) = self.make(&b, stats, &mut csls) else {
                ex.block(cell);
                stats.rejected_bundles += 1;
                continue;
            };
            stats.iterations += b.iterations;
            let energy = self.energy(&kept);
            remaining -= energy;
            if energy < rings::WORTH * total {
                taken = Some(kept);
                continue;
            }
            // The fan of its axis (above), from the rays the bundle left.
            let t0 = Instant::now();
            ex.remove(&kept, !self.spare_cores);
            let fan = fan(ex, &b, thresholds.distance);
            stats.time_bundles += t0.elapsed();
            if let Some(fan) = fan {
                taken = self.make(&fan, stats, &mut csls);
                remaining -= taken.as_deref().map_or(0.0, |k| self.energy(k));
            }
        }
        Ok(csls)
    }

    /// Energy of the rays `idx`.
    pub fn energy(&self, idx: &[u32]) -> f64 {
        det_sum(idx, 0.0, |&i| self.rays[i as usize].weight() as f64)
    }

    /// The largest light-plane radius an image resolves at the texel its rays need
    /// ([`TEXEL_SPACINGS`] grid spacings, in the largest image, centred on the axis): a piece
    /// whose rays reach twice as far gets texels twice as coarse, and is cut into rings
    /// ([`rings::split`]).
    fn fine_reach(&self) -> f64 {
        (0.5 * self.params.image_size as f32 * TEXEL_SPACINGS * self.spacing) as f64
    }

    /// `b` fitted, cut into rings where one law or one image does not do, and made CSLs
    /// (appended to `csls`); its kept rays, ascending. None, and nothing made, when the fit
    /// keeps nothing or less than the bake's smallest CSL's energy.
    pub fn make(&self, b: &Bundle, stats: &mut BakeStats, csls: &mut Vec<Csl>) -> Option<Vec<u32>> {
        let p = self.params;
        let t0 = Instant::now();
        let args = (
            self.radius as f64,
            self.far,
            (p.fit_threshold_deg as f64).to_radians(),
            p.fit_samples as usize,
        );
        let f = fit::fit_bundle(
            self.rays,
            b,
            args.0,
            args.1,
            args.2,
            args.3,
            self.spare_cores,
        );
        stats.time_fit += t0.elapsed();
        stats.dismissed_rays += f.dismissed as u64;
        if f.kept.is_empty() || self.energy(&f.kept) < p.min_csl_energy as f64 * self.total {
            return None;
        }
        // One law per ring of light-plane radius where one law for the bundle misses its rays.
        let t0 = Instant::now();
        let room = (p.max_csls as usize).saturating_sub(csls.len()).max(1);
        let pieces = rings::split(
            self.rays,
            f,
            args,
            (room.min(rings::MAX_PIECES), rings::WORTH * self.total),
            self.fine_reach(),
            self.spare_cores,
        );
        stats.time_fit += t0.elapsed();
        if pieces.len() > 1 {
            stats.dismissed_rays += pieces.iter().map(|p| p.dismissed as u64).sum::<u64>();
        }
        let mut kept = Vec::new();
        for f in pieces {
            let t0 = Instant::now();
            let energy = self.energy(&f.kept);
            csls.push(self.csl(&f));
            stats.time_image += t0.elapsed();
            stats.energy_covered += energy;
            kept.extend_from_slice(&f.kept);
        }
        kept.sort_unstable();
        Some(kept)
    }

    /// The CSL of a fitted piece: its intensity image splatted from its kept rays.
    fn csl(&self, f: &fit::Fit) -> Csl {
        let p = self.params;
        let x_axis = f.axis.any_orthonormal_vector();
        let y_axis = f.axis.cross(x_axis);
        let img = image::splat(
            self.rays,
            &f.kept,
            f.origin,
            f.axis,
            x_axis,
            y_axis,
            p.splat_scale * self.spacing,
            self.spacing * self.spacing,
            TEXEL_SPACINGS * self.spacing,
            p.image_size,
        );
        let (scale, texels) = image::quantise(&img.texels);
        Csl {
            origin: f.origin,
            axis: f.axis,
            x_axis,
            kappa: f.kappa as f32,
            gamma: f.gamma as f32,
            half_extent: img.half,
            size: img.size,
            scale,
            flux: img.flux as f32,
            grain: if scale > 0.0 {
                (img.grain / scale as f64) as f32
            } else {
                0.0
            },
            texels,
        }
    }
}

/// The fan of bundle `b`'s axis line (module docs): the rays left in `ex`'s pool within
/// `distance` of the line at up to [`FAN_ANGLE_DEG`] from it, as a bundle on the same axis;
/// None when there are none.
pub fn fan(ex: &Extractor, b: &Bundle, distance: f32) -> Option<Bundle> {
    let members = ex.around(b.origin, b.axis, distance, FAN_ANGLE_DEG.to_radians().cos());
    (!members.is_empty()).then_some(Bundle {
        origin: b.origin,
        axis: b.axis,
        members,
        iterations: 0,
    })
}
