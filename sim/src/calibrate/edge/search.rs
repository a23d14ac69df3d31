//! The edge fit's search (`tacsim calibrate --edge SHAPE`): a lab's taps on a straight edge
//! (labelled lateral offset, depth and yaw) against the same taps simulated on a catalogue
//! stimulus's edge. The label map (which side of the edge is positive, where yaw 0 points,
//! where depth 0 is) is fitted on the fitting 80% ([`super::fit_labels`]), and candidate
//! roundings of the edge, skin patches of the pins, dome slopes and gap profiles are compared
//! on the held-out 20%'s per-pin error ([`super::tap_errors`]). The rest of the sensor is held as
//! given: its camera and framing come from `--camera-only`, its deformation from the surface
//! fit. The command line writes the report ([`EdgeReport`], [`EdgeReport::markdown`]) and the
//! preset ([`EdgeReport::sensor`]).

use std::sync::Arc;

use serde::Serialize;

use super::{EdgeLabels, Signs, edge_scene, fit_labels, pooled_error, start_labels, tap_errors};
use crate::calibrate::{Deformation, DomePoint, Observations, RecordingSplit, Simulator, search_dome};
use crate::error::{Result, SimError};
use crate::sensor::SensorParams;
use crate::stimulus::{Catalogue, Stimulus, off_the_edge};

/// One candidate model of the taps: `None` keeps the sensor's own value.
#[derive(Clone, Copy, Debug)]
pub struct Candidate {
    /// Rounding of the stimulus's edge (mm).
    pub edge_radius_mm: f64,
    /// The pins' skin patch (mm, `pins.patch_radius_mm`).
    pub patch_radius_mm: Option<f64>,
    /// Factor on the dome's slope (`skin.dome_slope`).
    pub dome_slope: Option<f64>,
    /// The gap profile's radius as a fraction of the dome's outer radius
    /// (`skin.gap_radius_mm`; 0: the dome's own).
    pub gap_profile: Option<f64>,
}

const fn candidate(
    edge_radius_mm: f64,
    patch_radius_mm: Option<f64>,
    dome_slope: Option<f64>,
    gap_profile: Option<f64>,
) -> Candidate {
    Candidate { edge_radius_mm, patch_radius_mm, dome_slope, gap_profile }
}

/// The candidates, one change at a time from the sensor as given: rounding of the edge (the
/// stimulus), the pins' skin patch, the dome's slope and the gap profile (the sensor).
pub const CANDIDATES: [Candidate; 14] = [
    candidate(0.0, None, None, None),
    candidate(1.0, None, None, None),
    candidate(2.0, None, None, None),
    candidate(4.0, None, None, None),
    candidate(0.0, Some(0.0), None, None),
    candidate(0.0, Some(0.75), None, None),
    candidate(0.0, Some(1.5), None, None),
    candidate(0.0, Some(2.5), None, None),
    candidate(0.0, None, Some(0.0), None),
    candidate(0.0, None, Some(1.0), None),
    candidate(0.0, None, Some(2.0), None),
    candidate(0.0, None, None, Some(0.0)),
    candidate(0.0, None, None, Some(0.75)),
    candidate(0.0, None, None, Some(0.5)),
];

/// Contact grid cells across the edge fit's taps: the built-in `edge-2d` recipe's, whose
/// simulated taps the fitted preset goes on to make (read from the recipe, so that the two
/// cannot drift apart).
pub fn grid_cells() -> Result<usize> {
    let (recipe, source) = crate::dataset::Recipe::builtin("edge-2d")?;
    recipe.cells_across.ok_or_else(|| SimError::invalid(&source, "cells_across", "is not set; the edge fit needs it"))
}

/// The label map is fitted on one fitting tap in this many (the search runs the taps about
/// 80 times per candidate).
const FIT_STRIDE: usize = 3;

/// The catalogue stimulus `shape` and the edge point `contact` (object frame, mm; default:
/// the catalogue's contact point), checked: the point must lie on the edge.
pub fn edge_stimulus(
    catalogue: &Catalogue,
    shape: &str,
    contact: Option<[f64; 2]>,
) -> Result<(Arc<Stimulus>, [f64; 2])> {
    let stimulus = catalogue.get(shape)?;
    let flag = |source: String, reason: String| SimError::Analysis { source_name: source, reason };
    let Some(c) = contact.or(stimulus.entry.contact_mm) else {
        return Err(flag(
            "--edge-contact".into(),
            format!(
                "shape `{shape}` has no contact point in the catalogue: give one on its edge with --edge-contact X,Y (mm)"
            ),
        ));
    };
    if stimulus.contour.loops.is_empty() {
        return Err(flag(format!("--edge {shape}"), "the shape has no top-face contour, so no edge to tap".into()));
    }
    if let Some(reason) = off_the_edge(&stimulus.contour, c, shape) {
        return Err(flag(format!("--edge-contact {:?},{:?}", c[0], c[1]), reason));
    }
    Ok((stimulus, c))
}

/// One edge fit's inputs.
pub struct EdgeFit<'a> {
    /// The stimulus the taps are on.
    pub stimulus: Arc<Stimulus>,
    /// The edge point the lateral offsets are measured from (object frame, mm).
    pub contact: [f64; 2],
    /// The tracked taps.
    pub obs: &'a Observations,
    /// Fitting and held-out taps.
    pub split: &'a RecordingSplit,
    /// The sensor (held).
    pub base: &'a SensorParams,
    /// The sensor as given only (its label map and held-out error), no other candidate.
    pub quick: bool,
    /// Instead of the candidates: the finite-element dome searched over at most this many
    /// domes ([`crate::calibrate::search_dome`]), each scored by its label map's error on the
    /// fitting taps (the first map fitted in full, each later one refined from the best so
    /// far); 0: the candidates.
    pub dome_points: usize,
    /// The lab folder, for the report and errors.
    pub real: &'a str,
    /// The command line, for the report.
    pub command: &'a str,
    /// Progress messages.
    pub progress: &'a dyn Fn(&str),
}

/// One candidate's result.
#[derive(Clone, Debug, Serialize)]
pub struct EdgeCandidate {
    /// Rounding of the edge (mm).
    pub edge_radius_mm: f64,
    /// The pins' skin patch (mm).
    pub patch_radius_mm: f64,
    /// Factor on the dome's slope.
    pub dome_slope: f64,
    /// The gap profile's radius (mm; 0: the dome's own, `skin.gap_radius_mm`).
    pub gap_radius_mm: f64,
    /// The label map fitted on the fitting taps.
    pub labels: EdgeLabels,
    /// Pooled relative per-pin error on the taps the map was fitted on.
    pub fit_error: f64,
    /// Pooled relative per-pin error on the held-out taps.
    pub held_out_error: f64,
    /// Held-out error by depth label quarter (shallowest first).
    pub held_out_by_depth: Vec<f64>,
    /// The finite-element dome of a dome search's candidate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dome: Option<DomePoint>,
}

/// The report of an edge fit (`report.json`).
#[derive(Clone, Debug, Serialize)]
pub struct EdgeReport {
    /// The command that made it.
    pub command: String,
    /// The lab folder.
    pub real: String,
    /// The stimulus.
    pub shape: String,
    /// Taps the label map was fitted on (one fitting tap in `FIT_STRIDE`).
    pub fitted: usize,
    /// Held-out taps.
    pub held_out: usize,
    /// The candidates, in [`CANDIDATES`] order (those the sensor as given already is once).
    pub candidates: Vec<EdgeCandidate>,
    /// Index of the candidate with the lowest held-out error (of a dome search: the lowest
    /// error on the fitting taps, which the search went by).
    pub best: usize,
}

/// Runs the edge fit: every candidate (the first alone with `quick`), its label map fitted and
/// its held-out error.
pub fn fit_edge(job: &EdgeFit) -> Result<EdgeReport> {
    let (stimulus, contact) = (&job.stimulus, job.contact);
    if job.split.train.len() < 3 * FIT_STRIDE || job.split.held_out.len() < 4 {
        return Err(SimError::Analysis {
            source_name: job.real.to_owned(),
            reason: format!(
                "{} fitting and {} held-out taps: record at least 20 taps",
                job.split.train.len(),
                job.split.held_out.len()
            ),
        });
    }
    let fit_taps: Vec<usize> = job.split.train.iter().copied().step_by(FIT_STRIDE).collect();
    let cells = grid_cells()?;
    let mut by_depth = job.split.held_out.clone();
    by_depth.sort_by(|&a, &b| job.obs.samples[a].sample.pose[2].total_cmp(&job.obs.samples[b].sample.pose[2]));
    if job.dome_points > 0 {
        return fit_dome(job, &fit_taps, &by_depth, cells);
    }
    let mut candidates: Vec<EdgeCandidate> = Vec::new();
    let tried = if job.quick { &CANDIDATES[..1] } else { &CANDIDATES[..] };
    for &c in tried {
        let mut sensor = job.base.clone();
        sensor.pins.patch_radius_mm = c.patch_radius_mm.unwrap_or(sensor.pins.patch_radius_mm);
        sensor.skin.dome_slope = c.dome_slope.unwrap_or(sensor.skin.dome_slope);
        sensor.skin.gap_radius_mm =
            c.gap_profile.map_or(sensor.skin.gap_radius_mm, |f| f * sensor.dome.outer_radius_mm);
        let (r, a, g, p) =
            (c.edge_radius_mm, sensor.pins.patch_radius_mm, sensor.skin.dome_slope, sensor.skin.gap_radius_mm);
        // A candidate the sensor as given already is (its own patch, slope and profile) runs once.
        if candidates
            .iter()
            .any(|c| c.edge_radius_mm == r && c.patch_radius_mm == a && c.dome_slope == g && c.gap_radius_mm == p)
        {
            continue;
        }
        let profile = if p > 0.0 { format!("{p} mm") } else { "the dome's".to_owned() };
        (job.progress)(&format!(
            "edge rounding {r} mm, skin patch {a} mm, dome slope {g}, gap profile {profile}: fitting the label map on \
             {} taps",
            fit_taps.len()
        ));
        let (scene, frame) = edge_scene(stimulus.with_edge_radius(Some(r)), contact)?;
        let deformation = Deformation::of(&sensor, stimulus.entry.friction);
        let sim = Simulator::on_scene(&sensor, &deformation, cells, job.obs, scene)?;
        let start = start_labels(job.obs, &job.split.train);
        let (labels, fit_error) =
            fit_labels(&sim, &frame, job.obs, &fit_taps, start, Signs::Every).map_err(|e| SimError::Analysis {
                source_name: job.real.to_owned(),
                reason: format!(
                    "fitting the label map with the edge rounded to {r} mm, skin patch {a} mm, dome slope {g}, gap \
                     profile {profile}: {e}"
                ),
            })?;
        let (held_out_error, held_out_by_depth) = held_out(&sim, &frame, &labels, job.obs, &by_depth)?;
        candidates.push(EdgeCandidate {
            edge_radius_mm: r,
            patch_radius_mm: a,
            dome_slope: g,
            gap_radius_mm: p,
            labels,
            fit_error,
            held_out_error,
            held_out_by_depth,
            dome: None,
        });
    }
    let best = (0..candidates.len())
        .min_by(|&a, &b| candidates[a].held_out_error.total_cmp(&candidates[b].held_out_error))
        .unwrap_or(0);
    Ok(report(job, fit_taps.len(), candidates, best))
}

/// The report of `candidates` of `job`, `best` the winner's index.
fn report(job: &EdgeFit, fitted: usize, candidates: Vec<EdgeCandidate>, best: usize) -> EdgeReport {
    EdgeReport {
        command: job.command.to_owned(),
        real: job.real.to_owned(),
        shape: job.stimulus.name().to_owned(),
        fitted,
        held_out: job.split.held_out.len(),
        candidates,
        best,
    }
}

/// The pooled per-pin error of the taps `by_depth` (sorted by depth label) and its four depth
/// quarters' (shallowest first).
fn held_out(
    sim: &Simulator,
    frame: &crate::dataset::LabelFrame,
    labels: &EdgeLabels,
    obs: &Observations,
    by_depth: &[usize],
) -> Result<(f64, Vec<f64>)> {
    let held = tap_errors(sim, frame, labels, obs, by_depth)?;
    let quarter = held.len().div_ceil(4);
    Ok((pooled_error(&held), held.chunks(quarter).map(pooled_error).collect()))
}

/// The dome search of [`EdgeFit::dome_points`] on the sharp edge, the sensor's skin patch,
/// dome slope and gap profile held: each dome's label map fitted on `fit_taps` and its
/// held-out error taken on the same simulator, the winner by the fitting taps' error.
fn fit_dome(job: &EdgeFit, fit_taps: &[usize], by_depth: &[usize], cells: usize) -> Result<EdgeReport> {
    let (stimulus, contact) = (&job.stimulus, job.contact);
    let start = start_labels(job.obs, &job.split.train);
    let search = search_dome(
        job.base,
        job.dome_points,
        &mut |point, best: Option<&EdgeCandidate>| {
            let dome = format!(
                "gel / skin {:.4}, skin {:.2} mm, base {:.1} mm",
                point.gel_ratio, point.skin_thickness_mm, point.base_depth_mm
            );
            (job.progress)(&format!("dome: {dome}: fitting the label map on {} taps", fit_taps.len()));
            let sensor = point.sensor(job.base)?;
            let (scene, frame) = edge_scene(stimulus.with_edge_radius(Some(0.0)), contact)?;
            let sim = Simulator::on_scene(
                &sensor,
                &Deformation::of(&sensor, stimulus.entry.friction),
                cells,
                job.obs,
                scene,
            )?;
            let fitted = match best {
                None => fit_labels(&sim, &frame, job.obs, fit_taps, start, Signs::Every),
                Some(b) => fit_labels(&sim, &frame, job.obs, fit_taps, b.labels, Signs::Kept),
            };
            let (labels, fit_error) = fitted.map_err(|e| SimError::Analysis {
                source_name: job.real.to_owned(),
                reason: format!("fitting the label map on the dome of {dome}: {e}"),
            })?;
            let (held_out_error, held_out_by_depth) = held_out(&sim, &frame, &labels, job.obs, by_depth)?;
            let candidate = EdgeCandidate {
                edge_radius_mm: 0.0,
                patch_radius_mm: sensor.pins.patch_radius_mm,
                dome_slope: sensor.skin.dome_slope,
                gap_radius_mm: sensor.skin.gap_radius_mm,
                labels,
                fit_error,
                held_out_error,
                held_out_by_depth,
                dome: Some(*point),
            };
            Ok((fit_error, candidate))
        },
        job.progress,
    )?;
    let candidates = search.trials.into_iter().map(|t| t.fitted).collect();
    Ok(report(job, fit_taps.len(), candidates, search.best))
}

impl EdgeReport {
    /// The best candidate.
    pub fn winner(&self) -> &EdgeCandidate {
        &self.candidates[self.best]
    }

    /// `base` with the best candidate's skin patch, dome slope and gap profile (and
    /// finite-element dome, from a dome search): the preset the fit writes.
    pub fn sensor(&self, base: &SensorParams) -> Result<SensorParams> {
        let b = self.winner();
        let mut sensor = match &b.dome {
            Some(point) => point.sensor(base)?,
            None => base.clone(),
        };
        sensor.pins.patch_radius_mm = b.patch_radius_mm;
        sensor.skin.dome_slope = b.dome_slope;
        sensor.skin.gap_radius_mm = b.gap_radius_mm;
        Ok(sensor)
    }

    /// `report.md`: the candidates' table, the edge frame, the depth map for a recipe.
    pub fn markdown(&self) -> String {
        let domes = self.candidates.iter().any(|c| c.dome.is_some());
        let mut md = format!(
            "# Edge taps against the simulator\n\nMade by `{}` from `{}`: taps on the edge of `{}`, the label map \
             fitted on {} of the fitting taps, the error on the {} held-out taps (pooled mean per-pin displacement \
             error over mean real displacement, the surface fit's measure).\n\n\
             |{} edge rounding (mm) | skin patch (mm) | dome slope | gap profile (mm) | fitted on | held out | held out by depth quarter \
             (shallow to deep) | lateral: sign, edge at (mm) | yaw: sign, offset (deg) | depth offset (mm) | rig yield \
             (mm^-0.5) |\n|{}---|---|---|---|---|---|---|---|---|---|---|\n",
            self.command,
            self.real,
            self.shape,
            self.fitted,
            self.held_out,
            if domes { " dome: gel / skin, skin (mm), base (mm) |" } else { "" },
            if domes { "---|" } else { "" }
        );
        for (i, c) in self.candidates.iter().enumerate() {
            let l = &c.labels;
            let quarters: Vec<String> = c.held_out_by_depth.iter().map(|e| format!("{e:.3}")).collect();
            let dome = c.dome.map_or(String::new(), |d| {
                format!(" {:.4}, {:.2}, {:.1} |", d.gel_ratio, d.skin_thickness_mm, d.base_depth_mm)
            });
            md += &format!(
                "|{dome} {} | {} | {} | {}{} | {:.3} | {:.3} | {} | {:+}, {:.2} | {:+}, {:.1} | {:.2} | {:.3} |\n",
                c.edge_radius_mm,
                c.patch_radius_mm,
                c.dome_slope,
                if c.gap_radius_mm > 0.0 { c.gap_radius_mm.to_string() } else { "0 (dome's)".to_owned() },
                if i == self.best { " (best)" } else { "" },
                c.fit_error,
                c.held_out_error,
                quarters.join(" / "),
                l.lateral_sign,
                l.lateral_offset_mm,
                l.yaw_sign,
                l.yaw_offset_deg,
                l.depth_offset_mm,
                l.depth_compliance
            );
        }
        md += "\nEdge frame: x across the edge, positive off the material, `x = sign (lateral - edge)`; yaw from the \
               edge's tangent, `yaw = sign yaw_label + offset`; indentation `= c - yield c^1.5`, `c = depth label + \
               depth offset` (the rig gives way under load). A recipe takes the rounding as `[[shapes]] \
               edge_radius_mm`; the preset written is the sensor with the best candidate's skin patch \
               (`pins.patch_radius_mm`), dome slope (`skin.dome_slope`) and gap profile (`skin.gap_radius_mm`, 0: \
               the dome's own).\n";
        if domes {
            md += "\nA dome search (`--dome`): each candidate is a finite-element dome (`skin.model = \"dome\"`; the \
                   gel's modulus over the skin's, the skin's thickness with the pins' tips kept, the base's depth), its \
                   label map fitted on the fitting taps, the best chosen by that error (the held-out taps only \
                   score it); the preset written carries its dome.\n";
        }
        let b = &self.winner().labels;
        md += &format!(
            "\nA recipe whose labels are the lab's depths replays the best candidate's depth map with:\n\n```toml\n\
             [rig]\ndepth_offset_mm = {:.3}\ndepth_compliance = {:.4}\n```\n",
            b.depth_offset_mm, b.depth_compliance
        );
        md
    }
}
