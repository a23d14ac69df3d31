//! The contact engine: a sensor moving through poses over a scene, carrying contact state
//! (pressures, shear tractions) from step to step, and the pins that follow.
//!
//! One step: initial gap from scene ray casts on the grid (fixed for the whole path, see
//! [`super::geometry::footprint`]), the cells a sharp edge cuts made the covered part's
//! ([`super::geometry::cut`], found in `geometry/edge.rs`) -> normal solve (warm-started) -> tangential solve with the rigid slip
//! increment of each cell since the previous step -> (alternate with the normal solve while
//! the two are coupled) -> pins on demand. What a step does not need is skipped: no contact
//! means no solve and the cached undeformed pins; zero friction, or a step without tangential
//! motion on an uncoupled material, means no tangential solve; pins and images only when asked.
//!
//! A path is solved in its [`ContactFrame`] (the sensor frame turned about the dome centre to
//! face the press): grid, gaps, tractions and slip live in that frame, pins are turned back
//! into the sensor frame.

use std::sync::{Arc, OnceLock};

use nalgebra::Vector3;

use super::body::PinKernel;
use super::body::operator::Operator;
use super::geometry::cut::{Cut, CutCoupling};
use super::geometry::edge::cut_cells;
use super::geometry::footprint::Footprint;
use super::geometry::frame::ContactFrame;
use super::geometry::gap::{DomeCells, dome_slope, gaps_below, hits_at, rigid_slip};
use super::geometry::grid::Grid;
use super::geometry::refine::{self, Refinement};
use super::model::ContactModel;
use super::pins::motion::{CellForces, PinLoad, displaced_pins, moved_pin, near_field_motions};
use super::pose::SensorPose;
use super::solve::coupled::{ContactState, Coupled, StepReport};
use crate::error::{Result, SimError};
use crate::pins::{PinLayout, PinPose};
use crate::scene::Scene;

/// A sensor moving over a scene with contact history: the state of a path's contact, moved
/// on by [`Simulation::step`].
///
/// ```
/// use tacsim_sim::contact::{ContactModel, Simulation};
/// use tacsim_sim::{ObjectPose, Scene, SensorParams, SensorPose, builtin_catalogue};
///
/// let sensor = SensorParams::default();
/// let model = ContactModel::new(&sensor)?;
/// let mut scene = Scene::new();
/// scene.add(builtin_catalogue()?.get("disk")?, ObjectPose::default())?;
/// // A 1.5 mm tap on the disk's flat top, then a 1 mm slide along x at that depth.
/// let poses: Vec<SensorPose> = (0..=4).map(|k| SensorPose::new(20.0 + 0.25 * k as f64, 0.0, 1.5, 0.0)).collect();
/// let mut sim = Simulation::new(&model, &scene, &poses);
/// for pose in &poses {
///     let report = sim.step(*pose)?;
///     assert!(report.in_contact && report.force_n[2] > 0.0 && report.dissipation_nmm >= 0.0);
/// }
/// // Friction on the skin opposes its motion over the disk (+x, the sensor's x at yaw 0).
/// assert!(sim.report().force_n[0] < 0.0);
/// let pins = sim.pins(); // every pin's tip and axis, sensor frame (mm)
/// assert_eq!(pins.len(), 331);
/// # Ok::<(), tacsim_sim::SimError>(())
/// ```
#[derive(Debug)]
pub struct Simulation<'a> {
    model: &'a ContactModel,
    scene: &'a Scene,
    frame: ContactFrame,
    /// The pins in `frame` (the model's layout when it is the sensor frame).
    layout: Arc<PinLayout>,
    op: Option<Operator>,
    /// The dome over the grid's cells.
    dome: DomeCells,
    /// The contact state carried from step to step and what its solves reuse.
    contact: ContactState,
    /// Friction coefficient of the stimulus under each cell at the last step.
    friction: Vec<f64>,
    /// The cells a sharp edge cuts at this step ([`super::geometry::cut`]), a grid field; empty
    /// without the option.
    cuts: Vec<Option<Cut>>,
    /// Their own compliance and their coupling to the cells next to them, as the step's
    /// solves take them, found with them once a step; `None` without a cut.
    cut_coupling: Option<CutCoupling>,
    /// The sub-cells along the step's loaded cut cells, for the pins ([`super::geometry::refine`]);
    /// `None` inside without one. Only the pins use them, so they are found on the first call
    /// after a step that needs them ([`Simulation::refinement`]): a path's steps before the
    /// one it captures never do (issue 31: on a `paper` shard, 324 of 524 refinements).
    refinement: OnceLock<Option<Refinement>>,
    /// The dome's slope `dh/dx, dh/dy` per cell times `skin.dome_slope` (none at 0).
    slope: Option<(Vec<f64>, Vec<f64>)>,
    pose: Option<SensorPose>,
    report: StepReport,
}

impl<'a> Simulation<'a> {
    /// A simulation whose grid covers the footprints of `poses` (all poses the path will visit;
    /// poses outside them are solved on the same grid, with contact cut at its border), in the
    /// path's [`ContactFrame`].
    pub fn new(model: &'a ContactModel, scene: &'a Scene, poses: &[SensorPose]) -> Self {
        Self::on_footprint(model, scene, Footprint::of_path(model, scene, poses))
    }

    /// A simulation on a footprint already found for its path ([`Footprint::of_path`] of the
    /// same model, scene and poses: the same simulation as [`Simulation::new`]'s, without
    /// probing the scene again).
    pub fn on_footprint(model: &'a ContactModel, scene: &'a Scene, footprint: Footprint) -> Self {
        Self::in_frame(model, scene, footprint.grid, footprint.frame)
    }

    /// A simulation on a given contact grid (sensor frame), for paths not known in advance
    /// (closed-loop exploration): `contact_disk_grid` covers every contact up to a depth.
    /// `None`: nothing can touch.
    pub fn with_grid(model: &'a ContactModel, scene: &'a Scene, grid: Option<Grid>) -> Self {
        Self::in_frame(model, scene, grid, ContactFrame::SENSOR)
    }

    fn in_frame(model: &'a ContactModel, scene: &'a Scene, grid: Option<Grid>, frame: ContactFrame) -> Self {
        let op = grid.map(|g| model.operator(g));
        let n = op.as_ref().map_or(0, |o| o.grid().len());
        let layout =
            if frame.is_sensor() { model.layout.clone() } else { Arc::new(frame.layout_to_contact(&model.layout)) };
        let factor = model.sensor.skin.dome_slope;
        let slope = op.as_ref().filter(|_| factor > 0.0).map(|o| dome_slope(o.grid(), model.dome_radius(), factor));
        let dome = op.as_ref().map(|o| DomeCells::new(model, &frame, o.grid())).unwrap_or_default();
        Self {
            model,
            scene,
            frame,
            layout,
            op,
            dome,
            contact: ContactState::new(n, model),
            friction: vec![0.0; n],
            cuts: Vec::new(),
            cut_coupling: None,
            refinement: OnceLock::from(None),
            slope,
            pose: None,
            report: StepReport::default(),
        }
    }

    /// Lifts the sensor off: no contact and no history, as [`Simulation::new`] left it (the
    /// grid is kept).
    pub fn lift(&mut self) {
        self.contact.lift();
        self.friction.fill(0.0);
        self.cuts.fill(None);
        self.cut_coupling = None;
        self.refinement = OnceLock::from(None);
        self.pose = None;
        self.report = StepReport::default();
    }

    /// The frame the grid, tractions and gaps are in.
    pub fn frame(&self) -> &ContactFrame {
        &self.frame
    }

    /// The contact grid (in [`Simulation::frame`]), `None` when no pose of the path touches
    /// anything.
    pub fn grid(&self) -> Option<&Grid> {
        self.op.as_ref().map(|o| o.grid())
    }

    /// Contact pressure per grid cell (MPa).
    pub fn pressure(&self) -> &[f64] {
        &self.contact.pressure
    }

    /// Shear traction on the skin per grid cell (MPa), `x` and `y`.
    pub fn shear(&self) -> (&[f64], &[f64]) {
        (&self.contact.qx, &self.contact.qy)
    }

    /// Gap after deformation per grid cell (mm), `+inf` where nothing can touch.
    pub fn gap(&self) -> &[f64] {
        &self.contact.gap
    }

    /// How many cells along a sharp edge (and, on a body with a skin, along the contact's own
    /// edge) the last step solved again at sub-cells for the pins (`refine.rs`; 0 where none).
    pub fn refined_cells(&self) -> usize {
        self.refinement().map_or(0, Refinement::len)
    }

    /// Friction coefficient of the stimulus under each grid cell at the last step.
    pub fn friction(&self) -> &[f64] {
        &self.friction
    }

    /// Normal and tangential `MatrixCache` counts: matrices built and reused.
    pub fn matrix_counts(&self) -> [[usize; 2]; 2] {
        self.contact.matrix_counts()
    }

    /// The last step's report.
    pub fn report(&self) -> &StepReport {
        &self.report
    }

    /// Moves the sensor to `pose` and solves the contact there, given the history so far.
    ///
    /// The stages, each a named step: the initial gap and friction under the pose
    /// (`initial_gap`; lift-off when nothing overlaps), the skin's rigid slip over the
    /// stimulus since the previous pose (`rigid_slip`), the coupled solve
    /// (`solve_coupled`: normal, then tangential, alternated until the tractions settle
    /// for a coupled material), and the report turned into the sensor frame
    /// (`finish_report`). The cells along a sharp edge solved again at sub-cells for the pins
    /// (`refine`, `refine.rs`) are left for the first call that needs them
    /// ([`Simulation::pins`], [`Simulation::refined_cells`]).
    pub fn step(&mut self, pose: SensorPose) -> Result<&StepReport> {
        pose.validate("trajectory", self.model.dome_radius())?;
        let previous = self.pose.replace(pose);
        let Some(op) = self.op.take() else {
            self.report = StepReport::default();
            return Ok(&self.report);
        };
        let solved = self.solve_at(&op, pose, previous);
        self.op = Some(op);
        self.report = solved?;
        Ok(&self.report)
    }

    /// [`Self::step`]'s stages on the path's operator `op`.
    fn solve_at(&mut self, op: &Operator, pose: SensorPose, previous: Option<SensorPose>) -> Result<StepReport> {
        let mut hits = gaps_below(self.model, self.scene, &pose, &self.frame, &self.dome, f64::INFINITY);
        self.cuts = cut_cells((self.model, self.scene, &self.frame), &self.dome, op.grid(), &pose, &mut hits);
        let (g0, mu): (Vec<f64>, Vec<f64>) = hits.iter().map(|h| (h.gap, h.friction)).unzip();
        self.cut_coupling = CutCoupling::of_field(op, &self.cuts, &g0, super::geometry::cut::STRIPS);
        self.refinement = OnceLock::from(None);
        self.friction.clone_from(&mu);
        self.contact.gap.clone_from(&g0);
        if g0.iter().all(|g| *g >= 0.0) {
            // Lift-off: no contact, no solve, no tractions.
            self.contact.lift_off();
            return Ok(StepReport::default());
        }
        let had_contact = self.contact.pressure.iter().any(|p| *p > 0.0);
        let slip = match previous {
            Some(previous) if had_contact => {
                rigid_slip(self.model, self.scene, &self.frame, &self.dome, (&pose, &previous))
            }
            // A new contact has no slip yet.
            _ => (vec![0.0; g0.len()], vec![0.0; g0.len()]),
        };
        let coupled = Coupled { model: self.model, op, cut: self.cut_coupling.as_ref(), slope: self.slope.as_ref() };
        let mut report = self.contact.solve_coupled(&coupled, &g0, &mu, slip)?;
        report.indentation_mm = -g0.iter().fold(0.0f64, |m, g| m.min(*g));
        self.finish_report(&mut report)?;
        // Solved: the sub-cells are found when the pins first need them.
        self.refinement = OnceLock::new();
        Ok(report)
    }

    /// The step's sub-cells along its loaded cut cells ([`super::geometry::refine`]), found on the first
    /// call after the step: the state they are found from (the step's pose, tractions and
    /// cuts) stands until the next step or [`Simulation::lift`], which set them again.
    fn refinement(&self) -> Option<&Refinement> {
        self.refinement
            .get_or_init(|| {
                let (op, pose) = (self.op.as_ref()?, self.pose?);
                self.refine(op.grid(), &pose)
            })
            .as_ref()
    }

    /// The sub-cells along the loaded cut cells and, on a body with a skin
    /// ([`super::body::ElasticBody::refines_contact_edge`]), along the contact's own edge
    /// ([`super::geometry::refine`]), their initial gaps from rays at their centres as the
    /// cells' own.
    fn refine(&self, grid: &Grid, pose: &SensorPose) -> Option<Refinement> {
        let contact_edge = self.model.body.refines_contact_edge();
        if (self.cuts.is_empty() && !contact_edge) || self.model.edge_subcells < 2 {
            return None;
        }
        let scale_free = self.model.body.scale_free();
        // The fine grids keep their own operators (`FineGrids`), not among the paths' grids'.
        let fine =
            || self.model.fine_grids.get(grid, self.model.edge_subcells, scale_free, |g| self.model.body.operator(g));
        let coarse = refine::Coarse {
            grid,
            pressure: &self.contact.pressure,
            qx: &self.contact.qx,
            qy: &self.contact.qy,
            cuts: &self.cuts,
            contact_edge,
            profile: self.model.edge_profile,
        };
        let gaps = |points: &[[f64; 2]]| {
            hits_at(self.model, self.scene, &self.frame, pose, points.iter().map(|c| (*c, true)))
                .iter()
                .map(|h| h.gap)
                .collect()
        };
        refine::refine(fine, &coarse, gaps, &self.model.normal)
    }

    /// The report's force turned into the sensor frame, its contact cells counted; an error
    /// when a solve left a non-finite traction.
    fn finish_report(&self, report: &mut StepReport) -> Result<()> {
        report.contact_force_n = report.force_n;
        if !self.frame.is_sensor() {
            // The force on the skin, (fx, fy, -pressing), turned into the sensor frame.
            let f = self.frame.to_sensor(Vector3::new(report.force_n[0], report.force_n[1], -report.force_n[2]));
            report.force_n = [f.x, f.y, -f.z];
        }
        report.contact_cells = self.contact.pressure.iter().filter(|p| **p > 0.0).count();
        if report.contact_cells == 0 {
            report.in_contact = false;
        }
        if !self.contact.pressure.iter().chain(&self.contact.qx).chain(&self.contact.qy).all(|v| v.is_finite()) {
            return Err(SimError::NoConvergence { solver: "contact", iterations: 0, residual: f64::NAN });
        }
        Ok(())
    }

    /// Pin poses (sensor frame) for the current state: the undeformed layout without contact.
    /// Far cells act on a pin in blocks (see `pins/motion.rs`).
    pub fn pins(&self) -> Vec<PinPose> {
        self.pins_with(false)
    }

    /// [`Simulation::pins`] summing every cell for every pin (the reference for the blocks).
    pub fn pins_exact(&self) -> Vec<PinPose> {
        self.pins_with(true)
    }

    fn pins_with(&self, exact: bool) -> Vec<PinPose> {
        // The dome: its far field from the finite-element table, its near field from the
        // layers' tables (`DomeContact::pin_kernel`).
        if let (Some(dome), PinKernel::Layered(near_field)) =
            (self.model.body.far_field(), self.model.body.pin_kernel())
        {
            let Some(forces) = self.cell_forces() else { return self.undeformed_pins() };
            let near = near_field_motions(&self.layout, near_field, &forces, exact);
            let points = (0..forces.f.len()).map(|k| ([forces.x[k], forces.y[k]], forces.f[k]));
            let far = dome.far_motions(&self.model.layout, &self.frame, points);
            let poses = (self.layout.pins.iter().zip(near).zip(far))
                .map(|((pin, a), b)| moved_pin(pin, &[(a.0 + b.0, a.1 + b.1)]))
                .collect();
            return self.frame.pins_to_sensor(poses);
        }
        match self.pin_load() {
            Some(load) => self.frame.pins_to_sensor(displaced_pins(
                load.layout,
                &load.kernel,
                load.dome_radius_mm,
                &load.forces,
                exact,
            )),
            None => self.undeformed_pins(),
        }
    }

    /// The loaded cells' point forces in the grid's frame, `None` where no cell is loaded.
    fn cell_forces(&self) -> Option<CellForces> {
        let op = self.op.as_ref()?;
        let forces = CellForces::new(
            op.grid(),
            (&self.contact.pressure, &self.contact.qx, &self.contact.qy),
            (!self.cuts.is_empty()).then_some(self.cuts.as_slice()),
            self.refinement(),
            self.model.pin_subsquares,
        );
        (!forces.is_empty()).then_some(forces)
    }

    /// Whether the pins come from the finite-element dome (a table product on the CPU, not the
    /// GPU's kernel sums).
    #[cfg(feature = "wgpu")]
    pub(crate) fn has_dome(&self) -> bool {
        self.model.body.far_field().is_some()
    }

    /// What the pins depend on in the current state (the grid's frame), `None` where no cell
    /// is loaded (the pins are the undeformed layout's) and for the dome, whose pins are not
    /// the kernels' sums (ask [`Simulation::pins`]).
    pub(crate) fn pin_load(&self) -> Option<PinLoad<'_>> {
        let forces = self.cell_forces()?;
        if self.model.body.far_field().is_some() {
            return None;
        }
        let kernel = self.model.body.pin_kernel();
        Some(PinLoad { layout: &self.layout, kernel, dome_radius_mm: self.model.dome_radius(), forces })
    }

    /// The undeformed pins (sensor frame), exactly: an unloaded state's, without the frame's
    /// round trip.
    pub(crate) fn undeformed_pins(&self) -> Vec<PinPose> {
        self.model.layout.poses()
    }
}

#[cfg(test)]
mod tests {
    use crate::contact::geometry::cut::EdgeProfile;
    use crate::contact::geometry::footprint::contact_disk_grid;
    use crate::sensor::{SensorParams, SkinModel};

    use super::*;
    use crate::scene::ObjectPose;

    /// A scene of the built-in stimulus `name` at the origin.
    fn scene_of(name: &str) -> Scene {
        let catalogue = crate::builtin_catalogue().expect("shapes");
        let mut scene = Scene::new();
        scene.add(catalogue.get(name).expect("a built-in"), ObjectPose::default()).expect("placed");
        scene
    }

    /// The default (calibrated) sensor's contact at `cells` across the footprint.
    fn default_model(cells: usize) -> ContactModel {
        let mut sensor = SensorParams::half_space();
        sensor.skin.cells_across = cells;
        ContactModel::new(&sensor).expect("contact model")
    }

    /// The bench's worst taps across the disk's rim (its edge at `x = 50` mm), worst first.
    fn worst_rim_taps() -> [SensorPose; 3] {
        [
            SensorPose::new(50.212111996651636, 1.9034683064035818, 4.112017682582, -104.13378902911502),
            SensorPose::new(47.34907172405703, -4.448277587450935, 3.8926758544961624, 97.68117019787599),
            SensorPose::new(52.59794120780816, -1.0569866164366326, 2.922351496197967, -111.97804110201162),
        ]
    }

    /// The largest distance between corresponding pin tips (mm).
    fn largest_tip_difference(a: &[PinPose], b: &[PinPose]) -> f64 {
        a.iter().zip(b).map(|(p, q)| (p.tip - q.tip).norm()).fold(0.0, f64::max)
    }

    /// Regression (issue 31): a cell was in or out of contact by the gap at its centre, so as
    /// a stimulus's sharp edge crossed a cell the contact's edge moved by a whole cell at
    /// once, and the force and the pins next to it jumped. With the cut cells
    /// (`cut.rs`) they follow the edge smoothly: taps across the disk's rim on a
    /// fixed 13-cell grid (cells 1.5 mm), the edge swept by 0.1 mm across 2 mm, no change of
    /// the force or of the centre pin's tip is over 5 times the median change (2.9 and 2.7
    /// times; without the cuts both stand still for most steps and then jump, the force by
    /// 1.5 N at once: millions of times the median).
    #[test]
    fn an_edge_moves_the_contact_smoothly_across_a_cell() {
        let scene = scene_of("disk");
        let mut sensor = SensorParams::half_space();
        sensor.skin.cells_across = 13;
        sensor.skin.cut_edges = true;
        let model = ContactModel::new(&sensor).expect("contact model");
        let grid = contact_disk_grid(&model, 2.0);
        let (mut force, mut tip) = (Vec::new(), Vec::new());
        for i in 0..=20 {
            let pose = SensorPose::new(49.0 + 0.1 * i as f64, 0.3, 2.0, 0.0);
            let mut sim = Simulation::with_grid(&model, &scene, Some(grid));
            force.push(sim.step(pose).expect("solved").force_n[2]);
            tip.push(sim.pins()[0].tip);
        }
        let steadiness = |changes: Vec<f64>| {
            let mut sorted = changes.clone();
            sorted.sort_by(f64::total_cmp);
            changes.iter().fold(0.0f64, |m, c| m.max(*c)) / sorted[sorted.len() / 2]
        };
        let force_ratio = steadiness(force.windows(2).map(|w| (w[1] - w[0]).abs()).collect());
        let tip_ratio = steadiness(tip.windows(2).map(|w| (w[1] - w[0]).norm()).collect());
        assert!(force_ratio < 5.0 && tip_ratio < 5.0, "force {force_ratio}, tip {tip_ratio}");
    }

    /// Regression (issue 31): on this tap across the disk's rim at 65 cells (the bench's rim
    /// tap 20, the pin reference) the tangential solver's heavy ball cycled with the objective
    /// going up and down, 20,000 iterations at a residual of 1.45, until a momentum step that
    /// raised the objective was taken back.
    #[test]
    fn a_momentum_step_that_goes_uphill_is_taken_back() {
        let pose = SensorPose::new(52.12806085741059, -1.300799758941109, 1.6897821803044915, -153.1759169415759);
        let model = default_model(65);
        let scene = scene_of("disk");
        let mut sim = Simulation::new(&model, &scene, &[pose]);
        let report = sim.step(pose).expect("converged");
        assert!(report.tangential_iterations < 200, "{} tangential iterations", report.tangential_iterations);
    }

    /// Where the pin error across a sharp edge comes from, on the bench's worst taps across the
    /// disk's rim (13 cells against 65 = 5 x 13 on the same footprint, neither with sub-cells
    /// along the edge): 65 cells' tractions summed onto the 13 cells and placed as 13 cells
    /// place them (evenly, and with the cut cells' edge profile), then placed as 65 cells do
    /// inside the cut cells (and their neighbours) only; last, 13 and 17 cells solved with
    /// 0-5 sub-cells a side along the edge ([`super::geometry::refine`]) against the default 65 cells.
    /// A diagnostic, not a check: `cargo test --release -p tacsim-sim --lib
    /// edge_pin_error_budget -- --ignored --nocapture` (`docs/experiments/contact.md`, "The edge's
    /// profile in the pins" and "Sub-cells along an edge").
    #[test]
    #[ignore = "diagnostic: prints the edge error budget"]
    fn edge_pin_error_budget() {
        let scene = scene_of("disk");
        let (mut coarse_model, mut fine_model) = (default_model(13), default_model(65));
        // The budget of the coarse placement: no sub-cells on either grid (the last figure's
        // are the tests' own, against 65 cells with them).
        (coarse_model.edge_subcells, fine_model.edge_subcells) = (0, 0);
        for pose in worst_rim_taps() {
            // 13 and 17 cells with 3, 4 and 5 sub-cells a side along the edge (and none),
            // against the default 65 cells (with them).
            let refined: Vec<String> = [13, 17]
                .iter()
                .flat_map(|&cells| {
                    [0, 2, 3, 4, 5].map(|r| format!("{cells} cells {r}x{r} {:.3}", rim_tap_error(pose, cells, r)))
                })
                .collect();
            let mut coarse = Simulation::new(&coarse_model, &scene, &[pose]);
            coarse.step(pose).expect("solved");
            let mut fine = Simulation::new(&fine_model, &scene, &[pose]);
            fine.step(pose).expect("solved");
            let (gc, gf) = (*coarse.grid().expect("grid"), *fine.grid().expect("grid"));
            assert!(
                gf.nx == 5 * gc.nx && (gf.cell_mm * 5.0 - gc.cell_mm).abs() < 1e-12 && gf.centre_mm == gc.centre_mm
            );
            let reference = fine.pins_exact();
            let err = |pins: Vec<PinPose>| largest_tip_difference(&pins, &reference);
            let coarse_of = |k: usize| {
                let (i, j) = gf.column_row(k);
                (j / 5) * gc.nx + i / 5
            };
            let solved = err(coarse.pins());
            // The fine tractions summed onto the coarse cells.
            let mut summed = [vec![0.0; gc.len()], vec![0.0; gc.len()], vec![0.0; gc.len()]];
            for k in 0..gf.len() {
                let kc = coarse_of(k);
                summed[0][kc] += fine.contact.pressure[k] / 25.0;
                summed[1][kc] += fine.contact.qx[k] / 25.0;
                summed[2][kc] += fine.contact.qy[k] / 25.0;
            }
            let cuts = std::mem::take(&mut coarse.cuts);
            [coarse.contact.pressure, coarse.contact.qx, coarse.contact.qy] = summed.clone();
            let even = err(coarse.pins());
            coarse.cuts = cuts.clone();
            let profiled = err(coarse.pins());
            // The fine tractions kept inside the cut cells (and their neighbours), summed and
            // spread evenly elsewhere.
            let cut = |i: usize, j: usize| cuts[j * gc.nx + i].is_some();
            let beside = |kc: usize| {
                let (i, j) = gc.column_row(kc);
                (i.saturating_sub(1)..(i + 2).min(gc.nx))
                    .any(|a| (j.saturating_sub(1)..(j + 2).min(gc.ny)).any(|b| cut(a, b)))
            };
            let (kept_p, kept_qx, kept_qy, kept_cuts) =
                (fine.contact.pressure.clone(), fine.contact.qx.clone(), fine.contact.qy.clone(), fine.cuts.clone());
            let mut spread_outside = |keep: &dyn Fn(usize) -> bool| {
                fine.cuts.clone_from(&kept_cuts);
                for k in 0..gf.len() {
                    let kc = coarse_of(k);
                    if keep(kc) {
                        (fine.contact.pressure[k], fine.contact.qx[k], fine.contact.qy[k]) =
                            (kept_p[k], kept_qx[k], kept_qy[k]);
                    } else {
                        (fine.contact.pressure[k], fine.contact.qx[k], fine.contact.qy[k]) =
                            (summed[0][kc], summed[1][kc], summed[2][kc]);
                        if let Some(c) = fine.cuts.get_mut(k) {
                            *c = None;
                        }
                    }
                }
                err(fine.pins_exact())
            };
            let fine_in_cuts = spread_outside(&|kc| cuts[kc].is_some());
            let fine_beside = spread_outside(&beside);
            eprintln!(
                "tap {pose:?}: largest pin error against 65 cells (mm): 13 cells solved {solved:.3}; 65 cells' \
                 tractions on 13 cells, spread evenly {even:.3}, with the edge profile {profiled:.3}, as 65 \
                 cells spread them inside the cut cells {fine_in_cuts:.3}, inside the cut cells and their \
                 neighbours {fine_beside:.3}; solved with sub-cells along the edge (`ContactModel::edge_subcells`): {}",
                refined.join(", ")
            );
        }
    }

    /// Regression: across a sharp edge, the pins of 13 cells were 0.46 mm off 65 cells' on
    /// this tap (the bench's worst across the disk's rim), nearly all from a cut cell's force
    /// spread evenly over its covered part; with the edge's singular profile
    /// (`pins::motion::edge_profile`) 0.30 mm.
    #[test]
    fn a_cut_cells_force_leans_to_the_edge_for_the_pins() {
        let err = rim_tap_error(worst_rim_taps()[0], 13, 0);
        assert!(err < 0.31, "largest pin error {err} mm");
    }

    /// Regression (issue 31): a cut cell acted on the cells next to it from its centre, as a
    /// whole cell, and half of the pins' error across an edge at 13 cells was the solve's: on
    /// the bench's worst tap across the disk's rim the pins were 0.302 mm off 65 cells where
    /// 65 cells' own forces, summed onto the 13 and placed with the edge's profile, give
    /// 0.151. With the covered parts' coupling ([`super::super::geometry::cut::CutCoupling`]) 0.174,
    /// and on the two next taps 0.109 and 0.057 (0.122 and 0.071 before; 0.141 / 0.077 /
    /// 0.032 with the gap at the load point since, the next test).
    #[test]
    fn a_cut_cell_acts_on_its_neighbours_from_its_covered_part() {
        assert_worst_rim_taps_within(0, [0.19, 0.12, 0.065]);
    }

    /// Regression (issue 31): a cut cell's gap was taken at its covered part's centroid, half
    /// the covered width in from the edge, while its load (the edge's profile) acts a third of
    /// it in, where the pins see it and its coupling takes its displacement: on the bench's
    /// three worst taps across the disk's rim 13 cells were 0.174 / 0.109 / 0.057 mm off 65
    /// cells; with the gap where the load acts 0.141 / 0.077 / 0.032. (These three tests run
    /// without sub-cells along the edge, which they precede; the reference is the default 65
    /// cells, which have them since.)
    #[test]
    fn a_cut_cells_gap_is_taken_where_its_load_acts() {
        assert_worst_rim_taps_within(0, [0.155, 0.09, 0.045]);
    }

    /// Regression (issue 31): with the solve's forces about right, a cut cell's force and its
    /// neighbours' still acted as one profile across the edge and as even squares; the dome's
    /// pressure rises several-fold across a 13-cell cell towards the contact's centre and the
    /// edge runs at a slant through it, so on the bench's three worst taps across the disk's
    /// rim the pins were 0.137 / 0.077 / 0.032 mm off 65 cells. With the cells along the edge
    /// solved again at 3 x 3 sub-cells (`refine.rs`) 0.056 / 0.030 / 0.023.
    #[test]
    fn the_cells_along_an_edge_are_solved_again_at_sub_cells_for_the_pins() {
        assert_worst_rim_taps_within(crate::DEFAULT_EDGE_SUBCELLS, [0.06, 0.034, 0.026]);
    }

    /// Regression (issue 31, found by the edge quick fit, `tacsim calibrate --edge square
    /// --quick` on the edge recordings): on this tap the sub-cells' normal solve (five
    /// sub-cells, four of them cut, 0.019 N) did not converge in 2,000 iterations, and the step,
    /// and the whole fit, failed; then it fell back to the coarse placement. Its conjugate
    /// gradient swapped two contact sets for ever (one sub-cell loaded, two others taking
    /// turns); with damped steps after a stall it converges, and the step refines.
    #[test]
    fn a_sub_cell_solve_that_swapped_two_contact_sets_converges() {
        let catalogue = crate::builtin_catalogue().expect("shapes");
        let mut scene = Scene::new();
        scene.add(catalogue.get("square").expect("a built-in"), ObjectPose::default()).expect("placed");
        let mut sensor = SensorParams::preset("tactip-331-edge2d").expect("preset");
        sensor.skin.cells_across = 13;
        let model = ContactModel::new(&sensor).expect("contact model");
        let pose = SensorPose::new(39.068618820809355, 0.0, 0.7219355606675195, 30.843697719879216);
        let mut sim = Simulation::new(&model, &scene, &[pose]);
        sim.step(pose).expect("the step solves");
        let loaded_cut = sim.cuts.iter().zip(&sim.contact.pressure).any(|(c, p)| c.is_some() && *p > 0.0);
        assert!(loaded_cut, "the tap must load a cut cell");
        assert!(sim.refined_cells() > 0, "{:?}", sim.grid());
        assert!(sim.pins().iter().all(|p| p.tip.iter().all(|v| v.is_finite())));
    }

    /// The sub-cells carry their cells' force, normal and shear (the solve's report and every
    /// cell not refined are the coarse solution's), on a slide across the disk's rim.
    #[test]
    fn sub_cells_carry_their_cells_force() {
        let scene = scene_of("disk");
        let model = default_model(13);
        let poses: Vec<SensorPose> = (0..4).map(|i| SensorPose::new(48.5 + 0.4 * i as f64, 0.7, 2.5, 20.0)).collect();
        let mut sim = Simulation::new(&model, &scene, &poses);
        let mut refined_steps = 0;
        for pose in poses {
            sim.step(pose).expect("solved");
            let Some(refined) = sim.refinement().cloned() else { continue };
            refined_steps += 1;
            let area = sim.grid().expect("grid").cell_area_mm2();
            let (mut cells, mut subs) = ([0.0; 3], [0.0; 3]);
            let mut shear = false;
            for k in 0..sim.contact.pressure.len() {
                let Some(range) = refined.of(k) else { continue };
                for (c, v) in cells.iter_mut().zip([sim.contact.qx[k], sim.contact.qy[k], sim.contact.pressure[k]]) {
                    *c += v * area;
                }
                shear |= sim.contact.qx[k] != 0.0;
                for s in range {
                    for (c, v) in subs.iter_mut().zip(refined.f[s]) {
                        *c += v;
                    }
                }
            }
            assert!(shear, "the slide must shear the refined cells");
            for (c, s) in cells.iter().zip(&subs) {
                assert!((c - s).abs() <= 1e-9 * cells[2], "{cells:?} vs {subs:?}");
            }
        }
        assert!(refined_steps >= 2, "the slide must cross the edge: {refined_steps} steps refined");
    }

    /// The sub-cells are found only when the pins ask for them (a path's steps before its
    /// captured one do not), from the step's own state: a slide across the disk's rim whose
    /// pins are asked for at its last step only lands them on the same bits as one asked at
    /// every step, and a lift leaves none to find.
    #[test]
    fn sub_cells_are_found_when_the_pins_ask_for_them() {
        let scene = scene_of("disk");
        let model = default_model(13);
        let poses: Vec<SensorPose> = (0..4).map(|i| SensorPose::new(48.5 + 0.4 * i as f64, 0.7, 2.5, 20.0)).collect();
        let (mut every, mut last) = (Simulation::new(&model, &scene, &poses), Simulation::new(&model, &scene, &poses));
        let mut asked = Vec::new();
        for pose in &poses {
            every.step(*pose).expect("solved");
            last.step(*pose).expect("solved");
            assert_eq!(every.refinement.get(), None, "nothing found before the pins ask");
            asked = every.pins();
            assert!(every.refinement.get().is_some());
            assert_eq!(last.refinement.get(), None);
        }
        assert!(every.refined_cells() > 0, "the slide must end across the edge");
        let bits = |pins: &[PinPose]| -> Vec<u64> {
            pins.iter().flat_map(|p| p.tip.iter().chain(p.axis.iter()).map(|v| v.to_bits())).collect()
        };
        assert_eq!(bits(&last.pins()), bits(&asked));
        last.lift();
        assert_eq!(last.refinement.get(), Some(&None));
        assert_eq!(last.refined_cells(), 0);
    }

    /// Regression (issue 85): on a body with a skin the pressure stays nearly flat out to the
    /// contact's edge and drops to zero within a cell, so the coarse grid moved the edge in
    /// steps of a cell and the pins under it turned with the step: on the bench's worst flat
    /// tap for the layer body (4.5 mm deep) its pins on 17 cells were 0.123 mm off 49 cells'
    /// (both every cell on every pin). With the contact's edge solved again at sub-cells
    /// (`refine.rs`, `Coarse::contact_edge`) 0.024 mm; a half-space has no such edge to refine.
    #[test]
    fn a_skin_bodys_pins_see_where_the_contacts_edge_lies_in_a_cell() {
        let scene = scene_of("disk");
        let pose = SensorPose::new(-7.776575308315564, 9.177743360236832, 4.482424269147743, -34.85223108884202);
        let pins = |skin: SkinModel, cells: usize, subcells: usize| {
            let mut sensor = SensorParams::half_space();
            (sensor.skin.model, sensor.skin.cells_across) = (skin, cells);
            let mut model = ContactModel::new(&sensor).expect("contact model");
            model.edge_subcells = subcells;
            let mut sim = Simulation::new(&model, &scene, &[pose]);
            sim.step(pose).expect("solved");
            (sim.pins_exact(), sim.refined_cells())
        };
        let (reference, _) = pins(SkinModel::Layer, 49, crate::DEFAULT_EDGE_SUBCELLS);
        let (plain, none) = pins(SkinModel::Layer, 17, 0);
        let (refined, cells) = pins(SkinModel::Layer, 17, crate::DEFAULT_EDGE_SUBCELLS);
        assert_eq!(none, 0);
        assert!(cells > 0, "the contact's edge must be refined");
        let (before, after) =
            (largest_tip_difference(&plain, &reference), largest_tip_difference(&refined, &reference));
        assert!(before > 0.1 && after < 0.03, "17 cells against 49: {before} mm plain, {after} mm refined");
        assert_eq!(pins(SkinModel::HalfSpace, 17, crate::DEFAULT_EDGE_SUBCELLS).1, 0, "a flat tap on a half-space");
    }

    /// Regression (issue 85): on a skin over a gel a stimulus's sharp edge loads the skin as a
    /// line load, gathered within a fraction of its thickness, but each cut cell took a
    /// half-space's singular profile and put its force a third of its covered width in; the
    /// pins under the edge turned with where the grid put that load: on one of the bench's
    /// worst taps across the disk's rim (4.9 mm deep, the calibrated half-space preset's 0.66 mm
    /// skin) 17 cells were 0.311 mm off 49 cells' (every cell on every pin). With the skin's
    /// profile ([`EdgeProfile::of_skin`]) 0.176 mm.
    #[test]
    fn a_skins_load_along_a_sharp_edge_gathers_at_the_edge() {
        let scene = scene_of("disk");
        // The bench's rim tap 30 of 40 (`tacsim_sim::bench::rim_samples`).
        let pose = SensorPose::new(50.93734347195456, 2.4020248331089347, 4.880514260115042, -8.187009015325515);
        let pins = |cells: usize, profile: Option<EdgeProfile>| {
            let mut sensor = SensorParams::half_space();
            (sensor.skin.model, sensor.skin.cells_across) = (SkinModel::SkinOnGel, cells);
            let mut model = ContactModel::new(&sensor).expect("contact model");
            if let Some(p) = profile {
                model.edge_profile = p;
            }
            let mut sim = Simulation::new(&model, &scene, &[pose]);
            sim.step(pose).expect("solved");
            sim.pins_exact()
        };
        let singular = Some(EdgeProfile::SINGULAR);
        let before = largest_tip_difference(&pins(17, singular), &pins(49, singular));
        let after = largest_tip_difference(&pins(17, None), &pins(49, None));
        assert!(before > 0.25 && after < 0.2, "17 cells against 49: {before} mm singular, {after} mm the skin's");
    }

    /// The sensor's `skin.edge_subcells` sets the model's sub-cells: none refine with 0, and
    /// a tap across the disk's rim refines its cells along the edge with the default.
    #[test]
    fn the_sensors_edge_subcells_set_the_models() {
        let scene = scene_of("disk");
        let pose = worst_rim_taps()[0];
        let refined = |subcells: usize| {
            let mut sensor = SensorParams::half_space();
            (sensor.skin.cells_across, sensor.skin.edge_subcells) = (13, subcells);
            let model = ContactModel::new(&sensor).expect("contact model");
            assert_eq!(model.edge_subcells, subcells);
            let mut sim = Simulation::new(&model, &scene, &[pose]);
            sim.step(pose).expect("solved");
            sim.refined_cells()
        };
        assert_eq!(refined(0), 0);
        assert!(refined(crate::DEFAULT_EDGE_SUBCELLS) > 0);
    }

    /// Each of [`worst_rim_taps`] on 13 cells with `subcells` sub-cells along the edge within
    /// its bound (mm) of 65 cells.
    fn assert_worst_rim_taps_within(subcells: usize, bounds: [f64; 3]) {
        for (pose, bound) in worst_rim_taps().into_iter().zip(bounds) {
            let err = rim_tap_error(pose, 13, subcells);
            assert!(err < bound, "{pose:?}: largest pin error {err} mm");
        }
    }

    /// The largest pin error (mm) of a tap on the disk solved on `cells` cells with
    /// `subcells` sub-cells along the edge ([`ContactModel::edge_subcells`]), against 65
    /// cells' exact pins (the default model's).
    fn rim_tap_error(pose: SensorPose, cells: usize, subcells: usize) -> f64 {
        let scene = scene_of("disk");
        let pins = |model: &ContactModel, exact: bool| {
            let mut sim = Simulation::new(model, &scene, &[pose]);
            sim.step(pose).expect("solved");
            assert!(sim.cuts.iter().any(Option::is_some), "the tap must cut cells");
            if exact { sim.pins_exact() } else { sim.pins() }
        };
        let mut model = default_model(cells);
        model.edge_subcells = subcells;
        largest_tip_difference(&pins(&model, false), &pins(&default_model(65), true))
    }

    /// Regression (issue 31): a whole sub-cell right behind a sharp edge took its force at
    /// its centre, however little the cut sub-cell beyond it covered, and with the edge along
    /// the grid the pins' error peaked where the edge crossed a sub-cell just past its side.
    /// A tap across the disk's rim, yaw 0 (the rim along the grid's `y`), 3.4 mm deep, on 17
    /// cells shifted to put the rim at 0.4 and 0.7 of its cell: its largest pin error against
    /// 65 cells (exact pins both) was 0.043 and 0.063 mm, now 0.020 and 0.023
    /// (`cut::behind_edge_mm`; the same sweep at every tenth:
    /// `cargo run --release -p tacsim-sim --example edge_place -- sweep 3.4 50 17`).
    #[test]
    fn a_whole_sub_cell_behind_the_edge_takes_its_force_where_the_profile_puts_it() {
        let scene = scene_of("disk");
        let pose = SensorPose::new(50.0, 0.3, 3.4, 0.0);
        let pins = |model: &ContactModel, rim_at: Option<f64>| {
            let mut footprint = Footprint::of_path(model, &scene, &[pose]);
            if let (Some(f), Some(g)) = (rim_at, footprint.grid.as_mut()) {
                // The rim at sensor `x = 0` at yaw 0: at `f` of its cell.
                let t = (0.0 - (g.centre_mm[0] - 0.5 * g.nx as f64 * g.cell_mm)) / g.cell_mm;
                g.centre_mm[0] += ((t - t.floor() - f + 0.5).rem_euclid(1.0) - 0.5) * g.cell_mm;
            }
            let mut sim = Simulation::on_footprint(model, &scene, footprint);
            sim.step(pose).expect("solved");
            sim.pins_exact()
        };
        let reference = pins(&default_model(65), None);
        let coarse = default_model(17);
        for f in [0.4, 0.7] {
            let err = largest_tip_difference(&pins(&coarse, Some(f)), &reference);
            assert!(err < 0.03, "rim at {f} of its cell: largest pin error {err} mm");
        }
    }

    /// Regression (issue 31, found by `contact_stress`'s proptest once cut cells became the
    /// default): the normal solve stopped on the cells' relative pressure change, and a cut
    /// cell's extra compliance (up to `1 / sqrt(phi)` times a whole cell's) turned the same
    /// change into a larger gap: a loaded sliver was left 5.0e-5 mm open against the stress
    /// test's 3.5e-5 (1e-4 of the 0.34 mm indentation). The change now counts each cell's own
    /// compliance, and every loaded cell closes within the same bound as the whole cells.
    #[test]
    fn cut_cells_close_their_gaps_as_whole_cells_do() {
        let scene = scene_of("spiral-2");
        let mut sensor = SensorParams::half_space();
        (sensor.skin.cells_across, sensor.skin.poisson, sensor.skin.model) = (11, 0.5, crate::SkinModel::Layer);
        let model = ContactModel::new(&sensor).expect("contact model");
        // The proptest's case: a touch-down on the second spiral, tilted, then a slide and
        // two presses.
        let start = SensorPose {
            rx_deg: -2.392364488704872,
            ry_deg: -10.58115502725998,
            ..SensorPose::new(13.391918450474307, -1.1280546752355975, 0.3361847328200847, -63.15251688985311)
        };
        let slid =
            SensorPose { x_mm: start.x_mm - 0.47357201494022066, y_mm: start.y_mm - 0.1635167333462892, ..start };
        let deeper = SensorPose { depth_mm: slid.depth_mm + 0.16673933286325188, ..slid };
        let turned = SensorPose {
            depth_mm: deeper.depth_mm + 0.16007199304821182,
            yaw_deg: slid.yaw_deg - 4.716625474581112,
            ..slid
        };
        // The path's footprint sets the grid.
        let mut sim = Simulation::new(&model, &scene, &[start, slid, deeper, turned]);
        sim.step(start).expect("solved");
        assert!(sim.cuts.iter().any(Option::is_some), "the pose must cut cells");
        let (p, g) = (sim.pressure(), sim.gap());
        let pmax = p.iter().fold(0.0f64, |m, v| m.max(*v));
        let tol = 1e-4 * start.depth_mm;
        for k in (0..p.len()).filter(|&k| p[k] > 1e-6 * pmax) {
            assert!(g[k].abs() <= tol, "cell {k}: p {} MPa, gap {} mm", p[k], g[k]);
        }
    }
}
