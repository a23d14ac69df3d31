//! Fitting the deformation model to tracked real recordings.
//!
//! The recordings are split once, by a hash of their image names, into a training 80% and a
//! held-out 20% that the fit never sees ([`RecordingSplit`]). On the training part the label frame is
//! found from the data ([`super::frame::best_frame`]), then for each candidate elastic model
//! Nelder-Mead minimises the mean relative error (mean over recordings of mean per-pin
//! displacement error over mean real displacement) over the model's parameters
//! ([`Deformation`]: depth offset, friction, tilt pivot, the rig's depth compliance and tilt
//! relaxation under load, pin length, camera distance, the skin's Poisson's ratio, and for the layered models the base depth and the gel's modulus
//! ratio). The search runs on every
//! `search_stride`-th training recording; the best model is then polished on all of them and
//! the frame found again with the fitted response.

use image::GrayImage;

use super::dome::{DomePoint, search_dome};
use super::evaluate::Simulator;
use super::frame::{FrameFit, ImageMap, best_frame, shift_samples};
use super::model::{Deformation, RigFrame, SampleError};
use super::observe::Observations;
use super::reference::Reference;
use crate::calibrate::rings::fit_camera_at;
use crate::error::{Result, SimError};
use crate::fit::nelder_mead;
use crate::sensor::{SensorParams, SkinModel};
use crate::stimulus::Stimulus;

/// The training and held-out recordings (indices into [`Observations::samples`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingSplit {
    /// Recordings the fit uses (about 80%).
    pub train: Vec<usize>,
    /// Recordings it never sees (about 20%).
    pub held_out: Vec<usize>,
}

impl RecordingSplit {
    /// Holds out the recordings of [`tacsim_data::LabSample::is_held_out`].
    pub fn of(obs: &Observations) -> Self {
        let (mut train, mut held_out) = (Vec::new(), Vec::new());
        for (k, o) in obs.samples.iter().enumerate() {
            if o.sample.is_held_out() { held_out.push(k) } else { train.push(k) }
        }
        Self { train, held_out }
    }
}

/// Settings of [`calibrate`].
#[derive(Clone, Debug, PartialEq)]
pub struct FitOptions {
    /// Contact grid cells across the footprint (odd).
    pub cells: usize,
    /// The model search uses every this-many-th training recording.
    pub search_stride: usize,
    /// Objective evaluations per candidate model in the search.
    pub search_evaluations: usize,
    /// Objective evaluations of the polish on all training recordings.
    pub polish_evaluations: usize,
    /// Candidate elastic models.
    pub models: Vec<SkinModel>,
    /// Fit the rig alone (depth offset, friction, the pivot's height and its offset off the
    /// axis, depth compliance, tilt relaxation, play in tilt: one search from each of
    /// [`RIG_PLAY_STARTS_DEG`]), the sensor held as given: its own elastic model, pins, camera
    /// and skin.
    pub rig_only: bool,
    /// Fit the finite-element dome with the rig: at most this many domes of the
    /// sensor's (gel ratio, skin thickness, base depth; `super::dome`), each scored by the
    /// rig fitted on it ([`FitOptions::dome_evaluations`] on the search recordings), the best
    /// polished as `rig_only` is; 0: no dome search.
    pub dome_points: usize,
    /// Rig evaluations per dome of the dome search.
    pub dome_evaluations: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            cells: 17,
            search_stride: 2,
            search_evaluations: 160,
            polish_evaluations: 80,
            models: vec![SkinModel::HalfSpace, SkinModel::Layer, SkinModel::SkinOnGel],
            rig_only: false,
            dome_points: 0,
            dome_evaluations: 60,
        }
    }
}

/// One candidate model's search result.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Candidate {
    /// The model's fitted parameters.
    pub deformation: Deformation,
    /// Mean relative error on the search recordings.
    pub relative_error: f64,
    /// Objective evaluations spent.
    pub evaluations: usize,
}

/// The outcome of [`calibrate`].
#[derive(Clone, Debug)]
pub struct Calibration {
    /// The fitted sensor (camera refitted at the fitted distance).
    pub sensor: SensorParams,
    /// The fitted parameters.
    pub deformation: Deformation,
    /// The label frame.
    pub frame: FrameFit,
    /// Every candidate model's search result.
    pub candidates: Vec<Candidate>,
    /// Mean relative error on all training recordings after the polish.
    pub train_relative_error: f64,
}

/// The data and fixed settings a fit simulates with.
pub struct Problem<'a> {
    /// The recordings' folder.
    pub folder: &'a tacsim_data::LabFolder,
    /// The sensor before the fit.
    pub base: &'a SensorParams,
    /// The real undeformed reference (the camera is refitted on it; every image is cut as it).
    pub reference: &'a Reference,
    /// The tracked recordings.
    pub obs: &'a Observations,
    /// The stimulus whose flat top face the recordings pressed.
    pub surface: &'a Stimulus,
    /// Contact grid cells across the footprint.
    pub cells: usize,
}

impl Problem<'_> {
    /// Path of recording `k`'s image.
    pub fn folder_image(&self, k: usize) -> std::path::PathBuf {
        self.folder.image_path(&self.obs.samples[k].sample)
    }

    /// The simulator of `d`, the camera refitted at its distance.
    pub fn simulator(&self, d: &Deformation) -> Result<Simulator> {
        let base = self.camera_at(d.camera_distance_mm)?;
        Simulator::new(&base, d, self.cells, self.obs, self.surface)
    }

    /// The base sensor with its camera refitted on the reference at `distance_mm`.
    pub fn camera_at(&self, distance_mm: f64) -> Result<SensorParams> {
        fit_camera_at(self.base, &self.reference.image, &self.reference.describe(), Some(distance_mm))
    }

    /// Recording `k`'s image, cut as the reference.
    pub fn real_image(&self, k: usize) -> Result<GrayImage> {
        self.reference.read(&self.folder_image(k))
    }

    /// Mean relative error of `d` under `frame` over the recordings `which`.
    pub fn relative_error(&self, d: &Deformation, frame: &RigFrame, which: &[usize]) -> Result<f64> {
        let errs = self.simulator(d)?.errors(self.obs, which, frame)?;
        Ok(mean(errs.iter().map(SampleError::relative)))
    }

    /// The label frame of the recordings `which` under the response of `d`.
    pub fn frame(&self, d: &Deformation, which: &[usize]) -> Result<FrameFit> {
        let identity = self.simulator(d)?.errors(self.obs, which, &RigFrame::IDENTITY)?;
        let [real, sim] = shift_samples(which.iter().map(|&k| &self.obs.samples[k].sample), &identity);
        let too_few = || SimError::Analysis {
            source_name: self.reference.describe(),
            reason: format!("{} recordings are too few to find the label frame: record at least 8", which.len()),
        };
        let sim_map = ImageMap::fit(&sim).ok_or_else(too_few)?;
        best_frame(&real, &sim_map).ok_or_else(too_few)
    }
}

/// Mean of `v` (0 when empty).
fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { 0.0 } else { s / n as f64 }
}

/// Which parameters a search moves ([`encode`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Coordinates {
    /// The rig and the sensor's elastic parameters (the full fit).
    Full,
    /// The rig alone: depth offset, friction, pivot height, the pivot's offset `x`, `y`,
    /// depth compliance and tilt relaxation (the dome search's rig on each dome).
    Rig,
    /// The rig alone and its play in tilt (`--rig-only`).
    RigAndPlay,
}

/// The parameters a model fits, in the search's coordinates (friction and the gel ratio on a
/// log scale), with the search's first steps. What `coords` leaves out is held at `d`'s.
fn encode(d: &Deformation, coords: Coordinates) -> (Vec<f64>, Vec<f64>) {
    if coords != Coordinates::Full {
        let mut p = vec![
            d.depth_offset_mm,
            d.friction.ln(),
            d.pivot_mm,
            d.pivot_offset_mm[0],
            d.pivot_offset_mm[1],
            d.depth_compliance,
            d.tilt_relaxation_per_mm,
        ];
        let mut step = vec![0.4, 0.5, 5.0, 1.0, 1.0, 0.05, 0.04];
        if coords == Coordinates::RigAndPlay {
            p.push(d.tilt_play_deg);
            step.push(1.0);
        }
        return (p, step);
    }
    let mut p = vec![
        d.depth_offset_mm,
        d.friction.ln(),
        d.pivot_mm,
        d.pin_length_mm,
        d.camera_distance_mm,
        d.poisson,
        d.depth_compliance,
        d.tilt_relaxation_per_mm,
    ];
    let mut step = vec![0.4, 0.5, 5.0, 0.5, 8.0, -0.1, 0.05, 0.04];
    if d.model != SkinModel::HalfSpace {
        p.push(d.base_depth_mm);
        step.push(3.0);
    }
    if d.model == SkinModel::SkinOnGel {
        p.push(d.gel_ratio.ln());
        step.push(1.0);
    }
    (p, step)
}

/// The most play in tilt a fit tries (deg): a quarter of the surface recordings' largest tilts.
pub const MAX_TILT_PLAY_DEG: f64 = 6.0;

/// The plays in tilt (deg) the rig alone is searched from, one search each
/// ([`calibrate`] with [`FitOptions::rig_only`]).
pub const RIG_PLAY_STARTS_DEG: [f64; 3] = [0.0, 2.0, 4.0];

/// Inverse of [`encode`] on `start`; `None` outside the physical bounds: depth offset
/// -2..1.5 mm, friction 0.02..2, pivot 0..40 mm, its offset within 10 mm of the axis, depth
/// compliance 0..0.3 mm^-0.5, tilt relaxation 0..0.15 per mm, the play in tilt 0..6 deg
/// ([`MAX_TILT_PLAY_DEG`]), and in the full fit pin length
/// 0.5..3 mm, camera 4..80 mm, skin Poisson's ratio 0.3..0.5, base depth 3..25 mm, gel ratio
/// 0.003..1. Fitting the rig alone, the sensor's own parameters are held, not bounded: a
/// sensor with 3.1 mm pins had every evaluation refused, and the fit reported its start.
fn decode(start: &Deformation, p: &[f64], coords: Coordinates) -> Option<Deformation> {
    let mut d = start.clone();
    if coords == Coordinates::Full {
        decode_full(&mut d, p);
    } else {
        d.depth_offset_mm = p[0];
        d.friction = p[1].exp();
        d.pivot_mm = p[2];
        d.pivot_offset_mm = [p[3], p[4]];
        d.depth_compliance = p[5];
        d.tilt_relaxation_per_mm = p[6];
        if coords == Coordinates::RigAndPlay {
            d.tilt_play_deg = p[7];
        }
    }
    let within = |v: f64, lo: f64, hi: f64| v.is_finite() && (lo..=hi).contains(&v);
    let rig = within(d.depth_offset_mm, -2.0, 1.5)
        && within(d.friction, 0.02, 2.0)
        && within(d.pivot_mm, 0.0, 40.0)
        && within(d.pivot_offset_mm[0].hypot(d.pivot_offset_mm[1]), 0.0, 10.0)
        && within(d.depth_compliance, 0.0, 0.3)
        && within(d.tilt_relaxation_per_mm, 0.0, 0.15)
        && within(d.tilt_play_deg, 0.0, MAX_TILT_PLAY_DEG);
    if coords != Coordinates::Full {
        return rig.then_some(d);
    }
    (rig && within(d.pin_length_mm, 0.5, 3.0)
        && within(d.camera_distance_mm, 4.0, 80.0)
        && within(d.poisson, 0.3, 0.5)
        && within(d.base_depth_mm, 3.0, 25.0)
        && within(d.gel_ratio, 0.003, 1.0))
    .then_some(d)
}

/// The full fit's parameters `p` ([`encode`]) into `d`.
fn decode_full(d: &mut Deformation, p: &[f64]) {
    d.depth_offset_mm = p[0];
    d.friction = p[1].exp();
    d.pivot_mm = p[2];
    d.pin_length_mm = p[3];
    d.camera_distance_mm = p[4];
    d.poisson = p[5];
    d.depth_compliance = p[6];
    d.tilt_relaxation_per_mm = p[7];
    let mut i = 8;
    if d.model != SkinModel::HalfSpace {
        d.base_depth_mm = p[i];
        i += 1;
    }
    if d.model == SkinModel::SkinOnGel {
        d.gel_ratio = p[i].exp();
    }
}

/// Minimises the mean relative error over `which` from `start`, at most `evaluations` times.
fn minimise(
    problem: &Problem,
    start: &Deformation,
    frame: &RigFrame,
    which: &[usize],
    evaluations: usize,
    coords: Coordinates,
    progress: &dyn Fn(&str),
) -> Candidate {
    let (p0, step) = encode(start, coords);
    let mut best = f64::INFINITY;
    let min = nelder_mead(&p0, &step, 1e-3, evaluations, |p| {
        let Some(d) = decode(start, p, coords) else { return f64::INFINITY };
        let v = problem.relative_error(&d, frame, which).unwrap_or(f64::INFINITY);
        if v < best {
            best = v;
            progress(&format!("{:?}: relative error {v:.3} at {d:?}", d.model));
        }
        v
    });
    let deformation = decode(start, &min.params, coords).unwrap_or_else(|| start.clone());
    Candidate { deformation, relative_error: min.value, evaluations: min.evaluations }
}

/// The start of every model's search: the sensor's own parameters, friction 0.3, the robot
/// tilting about the dome centre, no depth offset; layered models 10 mm deep, the gel a tenth
/// as stiff as the skin.
pub fn start(base: &SensorParams, model: SkinModel) -> Deformation {
    let mut d = Deformation::of(base, 0.3);
    d.model = model;
    d.pivot_mm = base.dome.outer_radius_mm;
    if model != SkinModel::HalfSpace {
        d.base_depth_mm = 10.0;
        d.gel_ratio = 0.1;
    }
    d
}

/// Fits the deformation model to the training recordings of `split` (see the module docs);
/// `progress` hears of every improvement.
pub fn calibrate(
    problem: &Problem,
    split: &RecordingSplit,
    opts: &FitOptions,
    progress: &dyn Fn(&str),
) -> Result<Calibration> {
    if opts.models.is_empty() {
        return Err(SimError::invalid("calibration", "models", "name at least one candidate elastic model"));
    }
    let search: Vec<usize> = split.train.iter().copied().step_by(opts.search_stride.max(1)).collect();
    // The rig alone: the sensor's own model and parameters, the robot tilting about the dome
    // centre to start with.
    let rig = Deformation { pivot_mm: problem.base.dome.outer_radius_mm, ..Deformation::of(problem.base, 0.3) };
    let domes = opts.dome_points > 0;
    let rig_only = opts.rig_only || domes;
    // The models searched: the sensor's own with the rig alone, none besides the domes.
    let models = match (domes, rig_only) {
        (true, _) => Vec::new(),
        (false, true) => vec![problem.base.skin.model],
        (false, false) => opts.models.clone(),
    };
    let start_of = |model| if rig_only { rig.clone() } else { start(problem.base, model) };
    let first = if domes { DomePoint::of(problem.base).on(problem.base, &rig) } else { start_of(models[0]) };
    let frame = problem.frame(&first, &split.train)?;
    progress(&format!(
        "label frame: rotation {:.0} deg{}{}, shift residual {:.2} px",
        frame.rotation_deg,
        if frame.mirrored { " mirrored" } else { "" },
        if frame.frame.tilt_sign < 0.0 { ", tilts reversed" } else { "" },
        frame.rms_px
    ));
    let mut candidates = Vec::new();
    if domes {
        // The first dome's rig is fitted as `rig_only` fits it, each later dome's from the best
        // dome's rig so far, in fewer evaluations.
        let tried = search_dome(
            problem.base,
            opts.dome_points,
            &mut |point, best: Option<&Candidate>| {
                let from = point.on(problem.base, best.map_or(&rig, |c| &c.deformation));
                let evaluations = if best.is_some() { opts.dome_evaluations } else { opts.search_evaluations };
                let c = minimise(problem, &from, &frame.frame, &search, evaluations, Coordinates::Rig, progress);
                Ok((c.relative_error, c))
            },
            progress,
        )?;
        candidates = tried.trials.into_iter().map(|t| t.fitted).collect();
    }
    // The rig alone searches from each of a few plays in tilt: the play trades against the
    // tilt's relaxation, along a valley one simplex from no play does not leave.
    let (coords, plays): (_, &[f64]) = match (rig_only, domes) {
        (false, _) => (Coordinates::Full, &[0.0]),
        (true, true) => (Coordinates::Rig, &[0.0]),
        (true, false) => (Coordinates::RigAndPlay, &RIG_PLAY_STARTS_DEG),
    };
    for &model in &models {
        for &play in plays {
            let from = Deformation { tilt_play_deg: play, ..start_of(model) };
            let c = minimise(problem, &from, &frame.frame, &search, opts.search_evaluations, coords, progress);
            progress(&format!(
                "{model:?} from {play} deg of play: relative error {:.3} after {} evaluations",
                c.relative_error, c.evaluations
            ));
            candidates.push(c);
        }
    }
    let best = candidates.iter().min_by(|a, b| a.relative_error.total_cmp(&b.relative_error)).expect("one model");
    // A search none of whose evaluations succeeded would report its start as a fit.
    if !best.relative_error.is_finite() {
        return Err(SimError::Analysis {
            source_name: problem.reference.describe(),
            reason: format!(
                "no evaluation of the fit succeeded ({} tried per model): the sensor's parameters may lie outside the fit's bounds (see `decode` in sim/src/calibrate/fitting.rs)",
                opts.search_evaluations
            ),
        });
    }
    let frame = problem.frame(&best.deformation, &split.train)?;
    let polished =
        minimise(problem, &best.deformation, &frame.frame, &split.train, opts.polish_evaluations, coords, progress);
    let sensor = polished.deformation.sensor(&problem.camera_at(polished.deformation.camera_distance_mm)?)?;
    Ok(Calibration {
        sensor,
        deformation: polished.deformation,
        frame,
        candidates,
        train_relative_error: polished.relative_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_round_trip_through_the_search_coordinates_and_bounds_hold() {
        let base = SensorParams::half_space();
        for model in [SkinModel::HalfSpace, SkinModel::Layer, SkinModel::SkinOnGel] {
            let d = start(&base, model);
            let (p, step) = encode(&d, Coordinates::Full);
            assert_eq!(p.len(), step.len());
            let back = decode(&d, &p, Coordinates::Full).expect("in bounds");
            assert!((back.friction - d.friction).abs() < 1e-12 && back.pivot_mm == d.pivot_mm, "{back:?}");
            let mut bad = p.clone();
            bad[3] = 3.5;
            assert!(decode(&d, &bad, Coordinates::Full).is_none(), "a 3.5 mm pin leaves no skin");
        }
        // The rig alone: its parameters round-trip, the sensor's stay, and the pivot stays
        // within 10 mm of the axis.
        let mut d = start(&base, SkinModel::HalfSpace);
        d.pivot_offset_mm = [0.5, -1.25];
        d.tilt_play_deg = 2.0;
        let (p, step) = encode(&d, Coordinates::RigAndPlay);
        assert_eq!((p.len(), step.len()), (8, 8));
        assert_eq!(decode(&d, &p, Coordinates::RigAndPlay), Some(d.clone()));
        let mut far = p.clone();
        far[3] = 11.0;
        assert!(decode(&d, &far, Coordinates::RigAndPlay).is_none(), "a pivot 11 mm off the axis");
        for play in [-0.1, MAX_TILT_PLAY_DEG + 0.1] {
            let mut loose = p.clone();
            loose[7] = play;
            assert!(decode(&d, &loose, Coordinates::RigAndPlay).is_none(), "{play} deg of play");
        }
        // The dome search's rig and the full fit hold the play where it starts.
        for coords in [Coordinates::Rig, Coordinates::Full] {
            let (p, step) = encode(&d, coords);
            assert_eq!(p.len(), step.len());
            assert_eq!(decode(&d, &p, coords).map(|b| b.tilt_play_deg), Some(2.0), "{coords:?}");
        }
        // What broke: the held sensor was bounded as the full fit bounds it, so a sensor with
        // 3.1 mm pins (a 0.4 mm skin at the calibrated tips) refused every rig evaluation.
        let mut long_pins = d.clone();
        long_pins.pin_length_mm = 3.1;
        let (p, _) = encode(&long_pins, Coordinates::RigAndPlay);
        assert_eq!(decode(&long_pins, &p, Coordinates::RigAndPlay), Some(long_pins.clone()));
        let full = encode(&long_pins, Coordinates::Full).0;
        assert!(decode(&long_pins, &full, Coordinates::Full).is_none(), "the full fit bounds it");
    }
}
