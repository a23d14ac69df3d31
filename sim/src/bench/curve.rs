//! Run time against error: the grid (cells across the footprint) against the Hertz and
//! Cattaneo errors and the pins' error against a fine reference grid, and the slide step
//! against the pins' error against fine steps.

use rayon::prelude::*;

use super::rates::{captured, ms_single};
use super::report::CurvePoint;
use crate::contact::{ContactModel, PIN_SUBSQUARES, Simulation, validate};
use crate::error::Result;
use crate::{PinPose, PinRenderer, Scene, SensorParams, SensorPath, SensorPose};

/// Cells across the footprint of the reference taps for the grid rows' pin error.
const PIN_REFERENCE_CELLS: usize = 65;

/// Run time against error over the grid: per grid size, one thread's ms per tap (solve, pins,
/// render), the Hertz and Cattaneo errors of `tacsim validate` at that grid, and the largest
/// pin error of the taps (`taps` on the disk's top, `rim` across its edge) against the same
/// taps on the fine reference grid.
pub(super) fn grid_curve(
    sensor: &SensorParams,
    scene: &Scene,
    renderer: &PinRenderer,
    taps: &[(SensorPose, [f64; 2])],
    rim: &[(SensorPose, [f64; 2])],
    single: &rayon::ThreadPool,
) -> Result<Vec<CurvePoint>> {
    let at_grid = |cells: usize, subsquares: usize| -> Result<ContactModel> {
        let mut s = sensor.clone();
        s.skin.cells_across = cells;
        let mut model = ContactModel::new(&s)?;
        model.pin_subsquares = subsquares;
        Ok(model)
    };
    let tap_pins = |m: &ContactModel, pose: SensorPose, exact: bool| -> Result<Vec<_>> {
        let mut sim = Simulation::new(m, scene, &[pose]);
        sim.step(pose)?;
        Ok(if exact { sim.pins_exact() } else { sim.pins() })
    };
    // Pin reference: the same taps on a fine grid, every cell on every pin, with the same
    // pin product (sub-squares near the pins, or one point force per cell).
    let reference = |subsquares: usize, poses: &[(SensorPose, [f64; 2])]| -> Result<Vec<Vec<PinPose>>> {
        let mut fine = at_grid(PIN_REFERENCE_CELLS, subsquares)?;
        fine.edge_subcells = crate::DEFAULT_EDGE_SUBCELLS;
        poses.par_iter().map(|(p, _)| tap_pins(&fine, *p, true)).collect()
    };
    let largest_error =
        |m: &ContactModel, poses: &[(SensorPose, [f64; 2])], reference: &[Vec<PinPose>]| -> Result<f64> {
            let mut err = 0.0f64;
            for ((p, _), r) in poses.iter().zip(reference) {
                for (a, b) in tap_pins(m, *p, false)?.iter().zip(r) {
                    err = err.max((a.tip - b.tip).norm());
                }
            }
            Ok(err)
        };
    let products = [PIN_SUBSQUARES, 1];
    let references: Vec<_> =
        products.iter().map(|&s| Ok((reference(s, taps)?, reference(s, rim)?))).collect::<Result<_>>()?;
    let mut curve = Vec::new();
    for cells in [9usize, 13, 17, 25, 33] {
        // One model per pin product; the first (the default) is also timed.
        let [a, b] = products.map(|s| at_grid(cells, s));
        let models = [a?, b?];
        let m = &models[0];
        // The errors first: their taps, flat and across the rim, build the model's kept
        // tables, so the time is a warm model's, as the rates' ([`Rates`]).
        let mut errors = [[0.0; 2]; 2];
        for ((e, m), (flat, edge)) in errors.iter_mut().zip(&models).zip(&references) {
            *e = [largest_error(m, taps, flat)?, largest_error(m, rim, edge)?];
        }
        let ms =
            single.install(|| ms_single(taps.len(), |i| captured(m, scene, &SensorPath::tap(taps[i].0), renderer)))?;
        curve.push(CurvePoint {
            knob: "grid",
            value: cells as f64,
            ms_per_sample: ms,
            hertz_force_rel_err: Some(validate::hertz(cells)?.force_rel_err.abs()),
            cattaneo_shift_rel_err: Some(validate::cattaneo_with(cells, 0.0)?.shift_rel_err.abs()),
            pin_err_mm: Some(errors[0][0]),
            edge_pin_err_mm: Some(errors[0][1]),
            point_force_pin_err_mm: Some(errors[1]),
        });
    }
    Ok(curve)
}

/// Run time against error over the slide step: per step (mm), one thread's ms per slide and
/// the largest pin error at the slide's end against 0.025 mm steps.
pub(super) fn step_curve(
    model: &ContactModel,
    scene: &Scene,
    renderer: &PinRenderer,
    slides: &[(SensorPose, [f64; 2])],
    single: &rayon::ThreadPool,
) -> Result<Vec<CurvePoint>> {
    let reference: Vec<_> =
        slides.iter().map(|(p, f)| SensorPath::slide(*p, *f, 0.025)?.run(model, scene)).collect::<Result<_, _>>()?;
    let mut curve = Vec::new();
    for step in [2.5, 1.0, 0.5, 0.25, 0.1] {
        let mut err = 0.0f64;
        let ms = single.install(|| {
            ms_single(slides.len(), |i| {
                let (p, f) = slides[i];
                let frames = captured(model, scene, &SensorPath::slide(p, f, step)?, renderer)?;
                for (a, b) in frames[0].pins.iter().zip(&reference[i][0].pins) {
                    err = err.max((a.tip - b.tip).norm());
                }
                Ok(())
            })
        })?;
        curve.push(CurvePoint {
            knob: "step",
            value: step,
            ms_per_sample: ms,
            hertz_force_rel_err: None,
            cattaneo_shift_rel_err: None,
            pin_err_mm: Some(err),
            edge_pin_err_mm: None,
            point_force_pin_err_mm: None,
        });
    }
    Ok(curve)
}
