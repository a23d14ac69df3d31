//! `Contact`: the sensor pressed and slid over a scene, with stick/slip history.

use std::collections::HashMap;

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use tacsim_sim::contact::{ContactModel, Simulation, StepReport, contact_disk_grid};
use tacsim_sim::{PinRenderer, Scene, SensorPath, SensorPose};

use crate::scene::PyScene;
use crate::sensor::{PySensor, image_array};
use crate::sim_err;

/// What a [`Simulation`] borrows: the contact model and the scene.
struct Owner {
    model: ContactModel,
    scene: Scene,
    /// Contact grid half-depth: every untilted contact up to this indentation (mm) fits.
    max_depth_mm: f64,
}

self_cell::self_cell!(
    /// A simulation together with the model and scene it borrows.
    struct Cell {
        owner: Owner,
        #[covariant]
        dependent: Simulation,
    }
);

fn fresh(owner: Owner) -> Cell {
    Cell::new(owner, |o| Simulation::with_grid(&o.model, &o.scene, Some(contact_disk_grid(&o.model, o.max_depth_mm))))
}

/// A sensor over a scene with contact history: `press`, `slide_to`, `lift`; then the image,
/// pins, pressure and force of the last step.
#[pyclass(name = "Contact", module = "tacsim._tacsim")]
pub struct PyContact {
    cell: Cell,
    sensor: PySensor,
    renderers: HashMap<u32, PinRenderer>,
    pose: Option<SensorPose>,
}

/// A pose from `(x_mm, y_mm, depth_mm, yaw_deg[, rx_deg, ry_deg])`, checked for this sensor.
fn sensor_pose(pose: &[f64], sensor: &PySensor) -> PyResult<SensorPose> {
    let p = SensorPose::from_values(pose).map_err(PyValueError::new_err)?;
    p.validate("pose", sensor.params.dome.outer_radius_mm).map_err(sim_err)?;
    Ok(p)
}

impl PyContact {
    /// Steps through `poses` (without the GIL); the last report.
    fn run(&mut self, py: Python<'_>, poses: Vec<SensorPose>) -> PyResult<()> {
        py.detach(|| self.steps(&poses)).map_err(sim_err)
    }

    /// The sub-poses of a slide from the current pose to `pose` (checked).
    fn slide_poses(&self, pose: &[f64], step_mm: f64, step_deg: f64) -> PyResult<Vec<SensorPose>> {
        // Checked before any step, so that a bad target leaves the contact as it was.
        let target = sensor_pose(pose, &self.sensor)?;
        let start = self.pose.ok_or_else(|| PyValueError::new_err("slide_to needs a press first"))?;
        if !(step_mm.is_finite() && (0.01..=10.0).contains(&step_mm)) {
            return Err(PyValueError::new_err(format!("step_mm must be in [0.01, 10] mm, got {step_mm}")));
        }
        if !(step_deg.is_finite() && (0.01..=45.0).contains(&step_deg)) {
            return Err(PyValueError::new_err(format!("step_deg must be in [0.01, 45] deg, got {step_deg}")));
        }
        let path = SensorPath::slide_between(start, target, step_mm, step_deg).map_err(sim_err)?;
        // The path's own bound caps its steps (`MAX_PATH_STEPS`).
        Ok(path.steps.iter().skip(1).map(|s| s.pose).collect())
    }

    /// Steps through `poses` (the GIL held by the caller or not).
    fn steps(&mut self, poses: &[SensorPose]) -> Result<(), tacsim_sim::SimError> {
        for p in poses {
            self.cell.with_dependent_mut(|_, sim| sim.step(*p).map(|_| ()))?;
        }
        self.pose = poses.last().copied().or(self.pose);
        Ok(())
    }

    /// The binary image at `size` (px).
    fn render(&mut self, size: Option<u32>) -> PyResult<image::GrayImage> {
        let pins = self.cell.borrow_dependent().pins();
        Ok(self.renderer(size)?.render(&pins))
    }

    fn report(&self) -> StepReport {
        self.cell.borrow_dependent().report().clone()
    }

    fn renderer(&mut self, size: Option<u32>) -> PyResult<&PinRenderer> {
        let size = size.unwrap_or(self.sensor.params.camera.image_size);
        if !self.renderers.contains_key(&size) {
            let r = self.sensor.renderer(Some(size))?;
            self.renderers.insert(size, r);
        }
        self.renderers.get(&size).ok_or_else(|| PyValueError::new_err("renderer"))
    }
}

#[pymethods]
impl PyContact {
    /// The sensor over `scene`; contact is solved on a square grid of `cells` cells across
    /// (default: the sensor's `skin.cells_across`) centred on the apex, holding every untilted
    /// contact up to `max_depth_mm` of indentation (side `2.2 sqrt(2 R max_depth_mm)`, `R` the
    /// dome radius; deeper contact is cut at its border): set it near the deepest press, as
    /// the cells grow with it.
    #[new]
    #[pyo3(signature = (sensor, scene, max_depth_mm = 5.0, cells = None))]
    fn new(sensor: &PySensor, scene: &PyScene, max_depth_mm: f64, cells: Option<usize>) -> PyResult<Self> {
        let half = 0.5 * sensor.params.dome.outer_radius_mm;
        if !(max_depth_mm > 0.0 && max_depth_mm <= half) {
            return Err(PyValueError::new_err(format!(
                "max_depth_mm must be in (0, {half}] (half the dome radius), got {max_depth_mm}"
            )));
        }
        let mut params = sensor.params.clone();
        if let Some(n) = cells {
            if !(5..=129).contains(&n) {
                return Err(PyValueError::new_err(format!("cells must be in [5, 129], got {n}")));
            }
            params.skin.cells_across = n;
        }
        let owner =
            Owner { model: ContactModel::new(&params).map_err(crate::sim_err)?, scene: scene.build()?, max_depth_mm };
        Ok(Self { cell: fresh(owner), sensor: sensor.clone(), renderers: HashMap::new(), pose: None })
    }

    /// Lifts off (the history is cleared) and presses straight onto `pose`
    /// `(x_mm, y_mm, depth_mm, yaw_deg[, rx_deg, ry_deg])`; depth below the highest top face.
    fn press(&mut self, py: Python<'_>, pose: Vec<f64>) -> PyResult<()> {
        let p = sensor_pose(&pose, &self.sensor)?;
        self.lift();
        self.run(py, vec![p])
    }

    /// Slides from the current pose to `pose` in straight steps of at most `step_mm`
    /// laterally and `step_deg` of yaw, keeping the stick/slip history (press first).
    #[pyo3(signature = (pose, step_mm = 0.25, step_deg = 5.0))]
    fn slide_to(&mut self, py: Python<'_>, pose: Vec<f64>, step_mm: f64, step_deg: f64) -> PyResult<()> {
        let poses = self.slide_poses(&pose, step_mm, step_deg)?;
        self.run(py, poses)
    }

    /// Lifts the sensor off: no contact, no history.
    fn lift(&mut self) {
        self.cell.with_dependent_mut(|_, sim| sim.lift());
        self.pose = None;
    }

    /// The current pose `(x_mm, y_mm, depth_mm, yaw_deg, rx_deg, ry_deg)`, `None` when lifted.
    #[getter]
    fn pose(&self) -> Option<(f64, f64, f64, f64, f64, f64)> {
        self.pose.map(|p| (p.x_mm, p.y_mm, p.depth_mm, p.yaw_deg, p.rx_deg, p.ry_deg))
    }

    /// Whether the skin touches a stimulus.
    #[getter]
    fn in_contact(&self) -> bool {
        self.report().in_contact
    }

    /// Total force on the skin in the sensor frame (N): shear `x`, `y`, normal (pressing).
    #[getter]
    fn force_n<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.report().force_n.to_vec())
    }

    /// Cells in contact and cells slipping at the last step.
    #[getter]
    fn contact_cells(&self) -> (usize, usize) {
        let r = self.report();
        (r.contact_cells, r.slip_cells)
    }

    /// The binary pin image `uint8 (size, size)`, 0 or 255 (default size: the camera's).
    #[pyo3(signature = (size = None))]
    fn image<'py>(&mut self, py: Python<'py>, size: Option<u32>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        let img = self.render(size)?;
        image_array(py, img)
    }

    /// Pin tip centres in the image, `float (n, 2)`: `u` right, `v` down (px at `size`);
    /// pins the camera cannot see are `nan`.
    #[pyo3(signature = (size = None))]
    fn pins_px<'py>(&mut self, py: Python<'py>, size: Option<u32>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pins = self.cell.borrow_dependent().pins();
        let r = self.renderer(size)?;
        let tip = r.layout().tip_radius_mm;
        let mut out = Vec::with_capacity(2 * pins.len());
        for p in &pins {
            match r.camera().project_disc(&p.tip, &p.axis, tip) {
                Some(d) => out.extend([d.u, d.v]),
                None => out.extend([f64::NAN, f64::NAN]),
            }
        }
        PyArray1::from_vec(py, out).reshape([pins.len(), 2])
    }

    /// Pin tip centres in the sensor frame, `float (n, 3)` (mm).
    fn pins_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let pins = self.cell.borrow_dependent().pins();
        let flat: Vec<f64> = pins.iter().flat_map(|p| [p.tip.x, p.tip.y, p.tip.z]).collect();
        PyArray1::from_vec(py, flat).reshape([pins.len(), 3])
    }

    /// The contact pressure field `float (ny, nx)` (MPa) on the contact grid, with the
    /// grid's cell side (mm); rows along sensor `y`, columns along `x`, centred on the apex.
    fn pressure<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyArray2<f64>>, f64)> {
        let sim = self.cell.borrow_dependent();
        let (nx, ny, cell) = sim.grid().map_or((0, 0, 0.0), |g| (g.nx, g.ny, g.cell_mm));
        let p = sim.pressure().to_vec();
        Ok((PyArray1::from_vec(py, p).reshape([ny, nx])?, cell))
    }

    fn __repr__(&self) -> String {
        format!("Contact(sensor={:?}, pose={:?})", self.sensor.params.name, self.pose())
    }
}

/// Slides each contact to its pose (as `Contact.slide_to`, same steps) on all cores, without
/// the GIL; then returns their images `uint8 (n, size, size)`. The contacts must be distinct.
/// Each contact's result is what `slide_to` and `image` give it alone, whatever the threads.
#[pyfunction]
#[pyo3(signature = (contacts, poses, step_mm = 0.25, step_deg = 5.0, size = None))]
pub fn slide_many<'py>(
    py: Python<'py>,
    mut contacts: Vec<PyRefMut<'py, PyContact>>,
    poses: Vec<Vec<f64>>,
    step_mm: f64,
    step_deg: f64,
    size: Option<u32>,
) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
    if contacts.len() != poses.len() {
        return Err(PyValueError::new_err(format!("{} contacts but {} poses", contacts.len(), poses.len())));
    }
    let side = size.unwrap_or_else(|| contacts.first().map_or(128, |c| c.sensor.params.camera.image_size));
    let mut plans = Vec::with_capacity(contacts.len());
    for (c, p) in contacts.iter_mut().zip(&poses) {
        plans.push(c.slide_poses(p, step_mm, step_deg)?);
        c.renderer(Some(side))?;
    }
    let mut targets: Vec<&mut PyContact> = contacts.iter_mut().map(|c| &mut **c).collect();
    let images = py
        .detach(|| {
            targets
                .par_iter_mut()
                .zip(&plans)
                .map(|(c, plan)| {
                    c.steps(plan).map_err(|e| e.to_string())?;
                    let pins = c.cell.borrow_dependent().pins();
                    // Made above for every contact, with the GIL.
                    let r = c.renderers.get(&side).ok_or_else(|| format!("no renderer at {side} px"))?;
                    Ok(r.render(&pins).into_raw())
                })
                .collect::<Result<Vec<_>, String>>()
        })
        .map_err(PyValueError::new_err)?;
    let n = images.len();
    PyArray1::from_vec(py, images.concat()).reshape([n, side as usize, side as usize])
}
