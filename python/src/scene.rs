//! `Scene`: stimuli placed in the world (built-in shapes or OBJ files).

use std::path::Path;
use std::sync::Arc;

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use tacsim_sim::stimulus::{Contour, Mesh, ShapeEntry, Stimulus};
use tacsim_sim::{ObjectPose, Scene};

use crate::sim_err;

/// Stimuli placed in the world: `Scene("square")`, `Scene(obj_path="part.obj")`, `.add(...)`.
#[pyclass(name = "Scene", module = "tacsim._tacsim")]
#[derive(Clone, Default)]
pub struct PyScene {
    pub(crate) objects: Vec<(Arc<Stimulus>, ObjectPose)>,
}

impl PyScene {
    /// Stimulus `i` and its pose.
    fn object(&self, i: usize) -> PyResult<&(Arc<Stimulus>, ObjectPose)> {
        self.objects
            .get(i)
            .ok_or_else(|| PyValueError::new_err(format!("no stimulus {i}: the scene holds {}", self.objects.len())))
    }

    /// The simulator's scene of these objects.
    pub(crate) fn build(&self) -> PyResult<Scene> {
        let mut scene = Scene::new();
        for (stimulus, pose) in &self.objects {
            scene.add(stimulus.clone(), *pose).map_err(sim_err)?;
        }
        Ok(scene)
    }
}

/// `(x_mm, y_mm, yaw_deg)` as an object pose on the table (top face at the object's height).
fn object_pose(pose: (f64, f64, f64)) -> PyResult<ObjectPose> {
    let (x, y, yaw) = pose;
    if !(x.is_finite() && y.is_finite() && yaw.is_finite()) || x.abs() > 1e4 || y.abs() > 1e4 {
        return Err(PyValueError::new_err(format!(
            "pose must be finite (x_mm, y_mm, yaw_deg) with |x|, |y| <= 10000 mm, got {pose:?}"
        )));
    }
    Ok(ObjectPose { position_mm: [x, y, 0.0], yaw_deg: yaw })
}

/// The stimulus `shape` (built-in name) or the OBJ file `obj_path` (friction `friction`,
/// default: the catalogue's, 0.5 for a file).
fn stimulus(shape: Option<&str>, obj_path: Option<&str>, friction: Option<f64>) -> PyResult<Arc<Stimulus>> {
    let loaded = match (shape, obj_path) {
        (Some(name), None) => tacsim_sim::builtin_catalogue().and_then(|c| c.get(name)).map_err(sim_err)?,
        (None, Some(path)) => obj_stimulus(Path::new(path))?,
        _ => return Err(PyValueError::new_err("give exactly one of shape (a built-in name) and obj_path")),
    };
    if let Some(f) = friction
        && !(f.is_finite() && (0.0..=tacsim_sim::stimulus::MAX_FRICTION).contains(&f))
    {
        return Err(PyValueError::new_err(format!(
            "friction must be in [0, {}], got {f}",
            tacsim_sim::stimulus::MAX_FRICTION
        )));
    }
    Ok(loaded.with_friction(friction))
}

/// The stimulus of an OBJ file: named after the file, friction 0.5, its top-face contour
/// from the mesh (as a catalogue entry's).
fn obj_stimulus(path: &Path) -> PyResult<Arc<Stimulus>> {
    let text = std::fs::read_to_string(path).map_err(|e| sim_err(tacsim_sim::SimError::io(path, "read", e)))?;
    let shown = path.display().to_string();
    let mesh = Mesh::from_obj_str(&text, &shown).map_err(sim_err)?;
    let contour = Contour::from_mesh(&mesh, &shown).map_err(sim_err)?;
    let entry = ShapeEntry {
        name: path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into()),
        file: shown.clone(),
        material: "user".into(),
        friction: 0.5,
        description: shown,
        contact_mm: None,
        edge_radius_mm: 0.0,
    };
    Ok(Arc::new(Stimulus { entry, mesh, contour }))
}

#[pymethods]
impl PyScene {
    /// A scene with one stimulus (or none): a built-in `shape` or an `obj_path`, placed at
    /// `pose` `(x_mm, y_mm, yaw_deg)`, with `friction` overriding its own.
    #[new]
    #[pyo3(signature = (shape = None, obj_path = None, pose = (0.0, 0.0, 0.0), friction = None))]
    fn new(
        shape: Option<&str>,
        obj_path: Option<&str>,
        pose: (f64, f64, f64),
        friction: Option<f64>,
    ) -> PyResult<Self> {
        let mut s = Self::default();
        if shape.is_some() || obj_path.is_some() {
            s.add(shape, obj_path, pose, friction)?;
        }
        Ok(s)
    }

    /// Adds a stimulus (as the constructor).
    #[pyo3(signature = (shape = None, obj_path = None, pose = (0.0, 0.0, 0.0), friction = None))]
    fn add(
        &mut self,
        shape: Option<&str>,
        obj_path: Option<&str>,
        pose: (f64, f64, f64),
        friction: Option<f64>,
    ) -> PyResult<()> {
        let stimulus = stimulus(shape, obj_path, friction)?;
        self.objects.push((stimulus, object_pose(pose)?));
        Ok(())
    }

    /// The stimuli's names, in order.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.objects.iter().map(|(s, _)| s.name().to_owned()).collect()
    }

    /// The stimulus `i`'s contact point from the catalogue (mm, object frame), if any.
    fn contact_mm(&self, i: usize) -> PyResult<Option<(f64, f64)>> {
        let (s, _) = self.object(i)?;
        Ok(s.entry.contact_mm.map(|[x, y]| (x, y)))
    }

    /// The edge of stimulus `i` nearest the world point `(x_mm, y_mm)`: `(signed distance (mm,
    /// negative inside the material), nearest point (x_mm, y_mm), unit tangent (material on
    /// its left))`.
    #[pyo3(signature = (x_mm, y_mm, i = 0))]
    #[allow(clippy::type_complexity)]
    fn edge(&self, x_mm: f64, y_mm: f64, i: usize) -> PyResult<(f64, (f64, f64), (f64, f64))> {
        let (stimulus, pose) = self.object(i)?;
        let p = pose.to_object([x_mm, y_mm, 0.0]);
        let e = stimulus.contour.nearest([p[0], p[1]]);
        let w = pose.to_world([e.point[0], e.point[1], 0.0]);
        let t = pose.rotate_to_world(e.tangent);
        Ok((e.signed_distance_mm, (w[0], w[1]), (t[0], t[1])))
    }

    /// The top-face contour of stimulus `i` in the world: its closed loops, each `float (n, 2)`
    /// (mm, counter-clockwise around the material, no repeated closing vertex).
    #[pyo3(signature = (i = 0))]
    fn contour<'py>(&self, py: Python<'py>, i: usize) -> PyResult<Vec<Bound<'py, PyArray2<f64>>>> {
        let (stimulus, pose) = self.object(i)?;
        stimulus
            .contour
            .loops
            .iter()
            .map(|l| {
                let flat: Vec<f64> = l
                    .iter()
                    .flat_map(|p| {
                        let w = pose.to_world([p[0], p[1], 0.0]);
                        [w[0], w[1]]
                    })
                    .collect();
                PyArray1::from_vec(py, flat).reshape([l.len(), 2])
            })
            .collect()
    }

    fn __repr__(&self) -> String {
        format!("Scene({:?})", self.names())
    }
}

/// The built-in stimuli's names.
#[pyfunction]
pub fn shapes() -> PyResult<Vec<String>> {
    Ok(tacsim_sim::builtin_catalogue().map_err(sim_err)?.names())
}
