//! What the examples share (`tap_solves`, `slide_solves`, `edge_place`): their arguments, the
//! bench's scene, the contact model at a grid and a hash of a state's tractions.

use tacsim_sim::contact::{ContactModel, Simulation};
use tacsim_sim::{ObjectPose, Scene, SensorParams};

/// Argument `i` (from 0) as a whole number, `default` where it is absent.
pub fn whole(args: &[String], i: usize, default: usize) -> Result<usize, String> {
    args.get(i)
        .map_or(Ok(default), |s| s.parse().map_err(|_| format!("argument {}: `{s}` is not a whole number", i + 1)))
}

/// Argument `i`, a dome mesh: `CELLS`, `CELLSxREFINEMENT` or `CELLSxREFINEMENT+GEL_SHELLS`
/// (`skin.dome_cells`, `skin.dome_skin_refinement`, `skin.dome_refined_gel_shells`; `CELLS`
/// alone is one lattice for skin and gel, `CELLSx1+0`); absent, `default`.
pub fn dome_mesh(args: &[String], i: usize, default: (usize, usize, usize)) -> Result<(usize, usize, usize), String> {
    let Some(a) = args.get(i).filter(|a| *a != "-") else { return Ok(default) };
    let (c, rest) = a.split_once('x').unwrap_or((a, "1"));
    let (r, g) = rest.split_once('+').unwrap_or((rest, "0"));
    let bad = || format!("argument {}: `{a}` is not CELLS, CELLSxREFINEMENT or CELLSxREFINEMENT+GEL_SHELLS", i + 1);
    Ok((c.parse().map_err(|_| bad())?, r.parse().map_err(|_| bad())?, g.parse().map_err(|_| bad())?))
}

/// The bench's scene: the built-in `disk` (100 mm across) at the origin.
pub fn disk_scene() -> Result<Scene, Box<dyn std::error::Error>> {
    let catalogue = tacsim_sim::builtin_catalogue()?;
    let mut scene = Scene::new();
    scene.add(catalogue.get("disk")?, ObjectPose::default())?;
    Ok(scene)
}

/// The calibrated default sensor's contact model at `cells` cells across the footprint.
pub fn model_at(cells: usize) -> Result<ContactModel, Box<dyn std::error::Error>> {
    let mut sensor = SensorParams::half_space();
    sensor.skin.cells_across = cells;
    sensor.validate("CELLS")?;
    Ok(ContactModel::new(&sensor)?)
}

/// A hash of the bits of the pressure and the shear tractions of `sim`'s state: the same bits
/// on every grid cell, the same hash (for telling a change that keeps the results' bits).
pub fn tractions_hash(sim: &Simulation<'_>) -> u64 {
    let (qx, qy) = sim.shear();
    sim.pressure().iter().chain(qx).chain(qy).fold(0u64, |h, v| h.rotate_left(5) ^ v.to_bits())
}
