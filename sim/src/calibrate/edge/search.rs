//! The edge fit's search (`tacsim calibrate --edge SHAPE`): a lab's taps on a straight edge
//! (labelled lateral offset, depth and yaw) against the same taps simulated on a catalogue
//! stimulus's edge. The label map (which side of the edge is positive, where yaw 0 points,
//! where depth 0 is) is fitted on the fitting 80% ([`super::fit_labels`]), and candidate
//! roundings of the edge, skin patches of the pins and dome slopes are compared on the
//! held-out 20%'s per-pin error ([`super::tap_errors`]). The rest of the sensor is held as
//! given: its camera and framing come from `--camera-only`, its deformation from the surface
//! fit. The command line writes the report ([`EdgeReport`], [`EdgeReport::markdown`]) and the
//! preset ([`EdgeReport::sensor`]).

use std::sync::Arc;

use serde::Serialize;

use super::{EdgeLabels, edge_scene, fit_labels, pooled_error, start_labels, tap_errors};
use crate::calibrate::{Deformation, Observations, RecordingSplit, Simulator};
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
}

const fn candidate(edge_radius_mm: f64, patch_radius_mm: Option<f64>, dome_slope: Option<f64>) -> Candidate {
    Candidate { edge_radius_mm, patch_radius_mm, dome_slope }
}

/// The candidates, one change at a time from the sensor as given: rounding of the edge (the
/// stimulus), the pins' skin patch and the dome's slope (the sensor).
pub const CANDIDATES: [Candidate; 11] = [
    candidate(0.0, None, None),
    candidate(1.0, None, None),
    candidate(2.0, None, None),
    candidate(4.0, None, None),
    candidate(0.0, Some(0.0), None),
    candidate(0.0, Some(0.75), None),
    candidate(0.0, Some(1.5), None),
    candidate(0.0, Some(2.5), None),
    candidate(0.0, None, Some(0.0)),
    candidate(0.0, None, Some(1.0)),
    candidate(0.0, None, Some(2.0)),
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
    /// The label map fitted on the fitting taps.
    pub labels: EdgeLabels,
    /// Pooled relative per-pin error on the taps the map was fitted on.
    pub fit_error: f64,
    /// Pooled relative per-pin error on the held-out taps.
    pub held_out_error: f64,
    /// Held-out error by depth label quarter (shallowest first).
    pub held_out_by_depth: Vec<f64>,
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
    /// Index of the candidate with the lowest held-out error.
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
    let mut candidates: Vec<EdgeCandidate> = Vec::new();
    let tried = if job.quick { &CANDIDATES[..1] } else { &CANDIDATES[..] };
    for &c in tried {
        let mut sensor = job.base.clone();
        sensor.pins.patch_radius_mm = c.patch_radius_mm.unwrap_or(sensor.pins.patch_radius_mm);
        sensor.skin.dome_slope = c.dome_slope.unwrap_or(sensor.skin.dome_slope);
        let (r, a, g) = (c.edge_radius_mm, sensor.pins.patch_radius_mm, sensor.skin.dome_slope);
        // A candidate the sensor as given already is (its own patch and slope) runs once.
        if candidates.iter().any(|c| c.edge_radius_mm == r && c.patch_radius_mm == a && c.dome_slope == g) {
            continue;
        }
        (job.progress)(&format!(
            "edge rounding {r} mm, skin patch {a} mm, dome slope {g}: fitting the label map on {} taps",
            fit_taps.len()
        ));
        let (scene, frame) = edge_scene(stimulus.with_edge_radius(Some(r)), contact)?;
        let deformation = Deformation::of(&sensor, stimulus.entry.friction);
        let sim = Simulator::on_scene(&sensor, &deformation, cells, job.obs, scene)?;
        let start = start_labels(job.obs, &job.split.train);
        let (labels, fit_error) =
            fit_labels(&sim, &frame, job.obs, &fit_taps, start).map_err(|e| SimError::Analysis {
                source_name: job.real.to_owned(),
                reason: format!(
                    "fitting the label map with the edge rounded to {r} mm, skin patch {a} mm, dome slope {g}: {e}"
                ),
            })?;
        let held = tap_errors(&sim, &frame, &labels, job.obs, &by_depth)?;
        let quarter = held.len().div_ceil(4);
        let held_out_by_depth = held.chunks(quarter).map(pooled_error).collect();
        candidates.push(EdgeCandidate {
            edge_radius_mm: r,
            patch_radius_mm: a,
            dome_slope: g,
            labels,
            fit_error,
            held_out_error: pooled_error(&held),
            held_out_by_depth,
        });
    }
    let best = (0..candidates.len())
        .min_by(|&a, &b| candidates[a].held_out_error.total_cmp(&candidates[b].held_out_error))
        .unwrap_or(0);
    Ok(EdgeReport {
        command: job.command.to_owned(),
        real: job.real.to_owned(),
        shape: stimulus.name().to_owned(),
        fitted: fit_taps.len(),
        held_out: job.split.held_out.len(),
        candidates,
        best,
    })
}

impl EdgeReport {
    /// The best candidate.
    pub fn winner(&self) -> &EdgeCandidate {
        &self.candidates[self.best]
    }

    /// `base` with the best candidate's skin patch and dome slope: the preset the fit writes.
    pub fn sensor(&self, base: &SensorParams) -> SensorParams {
        let b = self.winner();
        let mut sensor = base.clone();
        sensor.pins.patch_radius_mm = b.patch_radius_mm;
        sensor.skin.dome_slope = b.dome_slope;
        sensor
    }

    /// `report.md`: the candidates' table, the edge frame, the depth map for a recipe.
    pub fn markdown(&self) -> String {
        let mut md = format!(
            "# Edge taps against the simulator\n\nMade by `{}` from `{}`: taps on the edge of `{}`, the label map \
             fitted on {} of the fitting taps, the error on the {} held-out taps (pooled mean per-pin displacement \
             error over mean real displacement, the surface fit's measure).\n\n\
             | edge rounding (mm) | skin patch (mm) | dome slope | fitted on | held out | held out by depth quarter \
             (shallow to deep) | lateral: sign, edge at (mm) | yaw: sign, offset (deg) | depth offset (mm) | rig yield \
             (mm^-0.5) |\n|---|---|---|---|---|---|---|---|---|---|\n",
            self.command, self.real, self.shape, self.fitted, self.held_out
        );
        for (i, c) in self.candidates.iter().enumerate() {
            let l = &c.labels;
            let quarters: Vec<String> = c.held_out_by_depth.iter().map(|e| format!("{e:.3}")).collect();
            md += &format!(
                "| {} | {} | {}{} | {:.3} | {:.3} | {} | {:+}, {:.2} | {:+}, {:.1} | {:.2} | {:.3} |\n",
                c.edge_radius_mm,
                c.patch_radius_mm,
                c.dome_slope,
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
               (`pins.patch_radius_mm`) and dome slope (`skin.dome_slope`).\n";
        let b = &self.winner().labels;
        md += &format!(
            "\nA recipe whose labels are the lab's depths replays the best candidate's depth map with:\n\n```toml\n\
             [rig]\ndepth_offset_mm = {:.3}\ndepth_compliance = {:.4}\n```\n",
            b.depth_offset_mm, b.depth_compliance
        );
        md
    }
}
