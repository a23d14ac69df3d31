//! Evaluating a deformation model against tracked real recordings: per-sample errors, the
//! undeformed pin positions, and radial displacement profiles by depth.

use rayon::prelude::*;

use super::model::{Deformation, LabelFrame, SampleError, compare, flat_scene, match_reference, simulate};
use super::observe::Observations;
use crate::contact::engine::ContactModel;
use crate::error::Result;
use crate::render::PinRenderer;
use crate::sensor::SensorParams;
use crate::stimulus::Stimulus;

/// Largest distance (px at 420) between a real reference pin and its simulated counterpart.
const MATCH_PX420: f64 = 8.0;
/// Slide step of the simulated recordings (mm).
const STEP_MM: f64 = 1.0;

/// One pin of a profile: radius band, real and simulated radial displacement (px).
type RadialPoint = (usize, f64, f64);

/// A deformation model ready to simulate recordings.
pub struct Simulator {
    /// Its sensor.
    pub sensor: SensorParams,
    model: ContactModel,
    renderer: PinRenderer,
    scene: crate::scene::Scene,
    reference_to_sim: Vec<Option<usize>>,
    deformation: Deformation,
}

impl Simulator {
    /// The simulator of `deformation` on `base` (with `cells` across the contact grid) for the
    /// reference pins of `obs`; `surface` provides the flat top face.
    pub fn new(
        base: &SensorParams,
        deformation: &Deformation,
        cells: usize,
        obs: &Observations,
        surface: &Stimulus,
    ) -> Result<Self> {
        let mut sensor = deformation.sensor(base)?;
        sensor.skin.cells_across = cells;
        sensor.validate("calibration")?;
        let model = ContactModel::new(&sensor);
        let renderer = PinRenderer::new(&sensor, obs.size)?;
        let radius = MATCH_PX420 * obs.size as f64 / 420.0;
        let reference_to_sim = match_reference(&renderer, &model.layout.poses(), &obs.reference, radius);
        let scene = flat_scene(surface, deformation.friction)?;
        Ok(Self { sensor, model, renderer, scene, reference_to_sim, deformation: deformation.clone() })
    }

    /// RMS distance (px) between the real reference pins and their simulated undeformed
    /// counterparts, and how many were matched.
    pub fn undeformed_rms(&self, obs: &Observations) -> (f64, usize) {
        let sim: Vec<Option<[f64; 2]>> =
            self.model.layout.poses().iter().map(|p| self.renderer.camera().project(&p.tip)).collect();
        let d2: Vec<f64> = obs
            .reference
            .iter()
            .zip(&self.reference_to_sim)
            .filter_map(|(r, m)| m.and_then(|i| sim[i]).map(|s| (s[0] - r[0]).powi(2) + (s[1] - r[1]).powi(2)))
            .collect();
        let n = d2.len();
        ((d2.iter().sum::<f64>() / n.max(1) as f64).sqrt(), n)
    }

    /// Simulated displacements (px per sensor pin) of recording `k` of `obs`.
    pub fn displacements(&self, obs: &Observations, k: usize, frame: &LabelFrame) -> Result<Vec<Option<[f64; 2]>>> {
        simulate(
            &self.model,
            &self.scene,
            &self.renderer,
            frame,
            self.deformation.depth_offset_mm,
            &obs.samples[k].sample,
            STEP_MM,
        )
    }

    /// Errors of the recordings `which` of `obs`.
    pub fn errors(&self, obs: &Observations, which: &[usize], frame: &LabelFrame) -> Result<Vec<SampleError>> {
        which
            .par_iter()
            .map(|&k| {
                let sim = self.displacements(obs, k, frame)?;
                Ok(compare(&sim, &obs.samples[k].tracking.displacement, &self.reference_to_sim))
            })
            .collect()
    }

    /// Mean radial displacement (px, outward from the image centre) of real and simulated
    /// pins, for untilted taps at the depths of the recordings with tilt under `max_tilt_deg`:
    /// `[depth band 1-2, 2-3, 3-4, 4-5 mm][radius band 0-25%, ..., 75-100% of the half
    /// image] = (real, sim, pins)`.
    pub fn radial_profiles(&self, obs: &Observations, max_tilt_deg: f64) -> Result<[[(f64, f64, usize); 4]; 4]> {
        let centre = 0.5 * obs.size as f64;
        let band_px = centre / 4.0;
        let low: Vec<usize> = (0..obs.samples.len())
            .filter(|&k| obs.samples[k].sample.pose[3].abs().max(obs.samples[k].sample.pose[4].abs()) < max_tilt_deg)
            .collect();
        let rows = low
            .par_iter()
            .map(|&k| -> Result<(usize, Vec<RadialPoint>)> {
                let o = &obs.samples[k];
                let mut s = o.sample.clone();
                s.shear = [0.0; 6];
                s.pose[3] = 0.0;
                s.pose[4] = 0.0;
                let sim = simulate(
                    &self.model,
                    &self.scene,
                    &self.renderer,
                    &LabelFrame::IDENTITY,
                    self.deformation.depth_offset_mm,
                    &s,
                    STEP_MM,
                )?;
                let band = (o.sample.pose[2] - 1.0).floor().clamp(0.0, 3.0) as usize;
                let mut v = Vec::new();
                for ((r, real), m) in obs.reference.iter().zip(&o.tracking.displacement).zip(&self.reference_to_sim) {
                    if let (Some(real), Some(Some(simd))) = (real, m.map(|i| sim[i])) {
                        let (x, y) = (r[0] - centre, r[1] - centre);
                        let rad = x.hypot(y);
                        if rad < 1.0 {
                            continue;
                        }
                        let (ux, uy) = (x / rad, y / rad);
                        v.push((
                            ((rad / band_px) as usize).min(3),
                            real[0] * ux + real[1] * uy,
                            simd[0] * ux + simd[1] * uy,
                        ));
                    }
                }
                Ok((band, v))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut acc = [[(0.0, 0.0, 0usize); 4]; 4];
        for (band, v) in rows {
            for (rb, re, si) in v {
                let a = &mut acc[band][rb];
                a.0 += re;
                a.1 += si;
                a.2 += 1;
            }
        }
        Ok(acc.map(|row| row.map(|(re, si, n)| (re / n.max(1) as f64, si / n.max(1) as f64, n))))
    }
}
