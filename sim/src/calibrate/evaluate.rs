//! Evaluating a deformation model against tracked real recordings: per-sample errors, the
//! undeformed pin positions, and radial displacement profiles by depth.

use rayon::prelude::*;

use super::model::{Deformation, RigFrame, SampleError, affine_residual, compare, displacements, simulate_pins};
use super::observe::Observations;
use crate::SensorPose;
use crate::contact::{ContactModel, Simulation};
use crate::detect::{match_reference, tip_pixels};
use crate::error::Result;
use crate::pins::PinPose;
use crate::render::PinRenderer;
use crate::scene::{Scene, flat_scene};
use crate::sensor::SensorParams;
use crate::stimulus::Stimulus;

/// Largest distance (px at 420) between a real reference pin and its simulated counterpart.
const MATCH_PX420: f64 = 8.0;
/// Slide step of the simulated recordings (mm).
const STEP_MM: f64 = 1.0;

/// Simulated displacements (px) per sensor pin, `None` where a tip leaves the view.
pub type Field = Vec<Option<[f64; 2]>>;

/// One pin of a profile: radius band, real and simulated radial displacement (px).
type RadialPoint = (usize, f64, f64);

/// A deformation model ready to simulate recordings.
pub struct Simulator {
    /// Its sensor.
    pub sensor: SensorParams,
    model: ContactModel,
    renderer: PinRenderer,
    scene: Scene,
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
        Self::on_scene(base, deformation, cells, obs, flat_scene(surface, deformation.friction)?)
    }

    /// The simulator of `deformation` on `base` for the reference pins of `obs`, pressing into
    /// `scene` (a stimulus other than the flat surface: [`super::edge_scene`]).
    pub fn on_scene(
        base: &SensorParams,
        deformation: &Deformation,
        cells: usize,
        obs: &Observations,
        scene: Scene,
    ) -> Result<Self> {
        let mut sensor = deformation.sensor(base)?;
        sensor.skin.cells_across = cells;
        sensor.validate("calibration")?;
        let model = ContactModel::new(&sensor)?;
        let renderer = PinRenderer::new(&sensor, obs.size)?;
        let radius = MATCH_PX420 * obs.size as f64 / 420.0;
        let reference_to_sim = match_reference(&renderer, &model.layout.poses(), &obs.reference, radius);
        Ok(Self { sensor, model, renderer, scene, reference_to_sim, deformation: deformation.clone() })
    }

    /// Simulated pins of a vertical tap at `pose` (scene frame) from above.
    pub fn tap(&self, pose: SensorPose) -> Result<Vec<PinPose>> {
        let mut sim = Simulation::new(&self.model, &self.scene, &[pose]);
        sim.step(pose)?;
        Ok(sim.pins())
    }

    /// For each real reference pin, its simulated sensor pin.
    pub fn reference_to_sim(&self) -> &[Option<usize>] {
        &self.reference_to_sim
    }

    /// RMS distance (px) between the real reference pins and their simulated undeformed
    /// counterparts, and how many were matched.
    pub fn undeformed_rms(&self, obs: &Observations) -> (f64, usize) {
        let sim = tip_pixels(&self.renderer, &self.model.layout.poses());
        let d2: Vec<f64> = obs
            .reference
            .iter()
            .zip(&self.reference_to_sim)
            .filter_map(|(r, m)| m.and_then(|i| sim[i]).map(|s| (s[0] - r[0]).powi(2) + (s[1] - r[1]).powi(2)))
            .collect();
        let n = d2.len();
        ((d2.iter().sum::<f64>() / n.max(1) as f64).sqrt(), n)
    }

    /// Simulated pins of recording `k` of `obs`.
    pub fn pins(&self, obs: &Observations, k: usize, frame: &RigFrame) -> Result<Vec<PinPose>> {
        simulate_pins(&self.model, &self.scene, frame, &self.deformation, &obs.samples[k].sample, STEP_MM)
    }

    /// Image displacements (px per sensor pin) of `pins` from the undeformed sensor.
    pub fn displacements_of(&self, pins: &[PinPose]) -> Vec<Option<[f64; 2]>> {
        displacements(&self.model, &self.renderer, pins)
    }

    /// Simulated displacements (px per sensor pin) of recording `k` of `obs`.
    pub fn displacements(&self, obs: &Observations, k: usize, frame: &RigFrame) -> Result<Vec<Option<[f64; 2]>>> {
        Ok(self.displacements_of(&self.pins(obs, k, frame)?))
    }

    /// The binary image of `pins` at the observations' size.
    pub fn render(&self, pins: &[PinPose]) -> image::GrayImage {
        self.renderer.render(pins)
    }

    /// Mean image scale at the undeformed pin tips (mm per px): summed 3-D distances between
    /// neighbouring tips over their summed image distances (neighbours: within 1.5 times the
    /// nearest-neighbour distance).
    pub fn mm_per_px(&self) -> f64 {
        let tips = self.model.layout.poses();
        let px = tip_pixels(&self.renderer, &tips);
        let (mut mm, mut img) = (0.0, 0.0);
        for (i, a) in tips.iter().enumerate() {
            let d: Vec<f64> = tips.iter().map(|b| (b.tip - a.tip).norm()).collect();
            let nearest = d.iter().enumerate().filter(|(j, _)| *j != i).map(|(_, v)| *v).fold(f64::INFINITY, f64::min);
            for (j, dj) in d.iter().enumerate() {
                if j != i
                    && *dj <= 1.5 * nearest
                    && let (Some(p), Some(q)) = (px[i], px[j])
                {
                    mm += dj;
                    img += (p[0] - q[0]).hypot(p[1] - q[1]);
                }
            }
        }
        if img > 0.0 { mm / img } else { f64::NAN }
    }

    /// Simulated displacements (px per sensor pin) of the recordings `which` of `obs`.
    pub fn fields(&self, obs: &Observations, which: &[usize], frame: &RigFrame) -> Result<Vec<Field>> {
        which.par_iter().map(|&k| self.displacements(obs, k, frame)).collect()
    }

    /// Error of recording `k` of `obs` given its simulated `field`.
    pub fn error(&self, obs: &Observations, k: usize, field: &[Option<[f64; 2]>]) -> SampleError {
        compare(field, &obs.samples[k].tracking.displacement, &self.reference_to_sim)
    }

    /// The relative error of recording `k` of `obs` left after the best affine map of the
    /// simulated `field` onto the real one (`d_real ~ A d_sim + c`, least squares): the
    /// field's shape rather than a gain, a rotation or a global shift.
    pub fn affine_residual(&self, obs: &Observations, k: usize, field: &[Option<[f64; 2]>]) -> Option<f64> {
        affine_residual(field, &obs.samples[k].tracking.displacement, &self.reference_to_sim)
    }

    /// Errors of the recordings `which` of `obs`.
    pub fn errors(&self, obs: &Observations, which: &[usize], frame: &RigFrame) -> Result<Vec<SampleError>> {
        let fields = self.fields(obs, which, frame)?;
        Ok(which.iter().zip(&fields).map(|(&k, f)| self.error(obs, k, f)).collect())
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
                let pins =
                    simulate_pins(&self.model, &self.scene, &RigFrame::IDENTITY, &self.deformation, &s, STEP_MM)?;
                let sim = self.displacements_of(&pins);
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
