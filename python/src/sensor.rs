//! `Sensor`: a TacTip's parameters (a built-in preset or a sensor TOML file).

use numpy::{PyArray2, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use tacsim_sim::{PRESETS, PinRenderer, SensorParams};

use crate::sim_err;

/// A TacTip sensor: dome, skin, pins, camera (`Sensor.load()`).
#[pyclass(name = "Sensor", module = "tacsim._tacsim", frozen)]
#[derive(Clone)]
pub struct PySensor {
    pub(crate) params: SensorParams,
}

impl PySensor {
    /// The renderer at `size` px (default: the camera's image size).
    pub(crate) fn renderer(&self, size: Option<u32>) -> PyResult<PinRenderer> {
        // A dataset recipe's range (`image_size`), narrower than the renderer's own.
        let size = size.unwrap_or(self.params.camera.image_size);
        if !(16..=2048).contains(&size) {
            return Err(PyValueError::new_err(format!("size must be in [16, 2048] px, got {size}")));
        }
        PinRenderer::new(&self.params, size).map_err(sim_err)
    }
}

/// A greyscale image as a `uint8` numpy array `(height, width)`.
pub(crate) fn image_array<'py>(py: Python<'py>, img: image::GrayImage) -> PyResult<Bound<'py, PyArray2<u8>>> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    numpy::PyArray1::from_vec(py, img.into_raw()).reshape([h, w])
}

#[pymethods]
impl PySensor {
    /// A sensor from a built-in preset name or a sensor TOML file (default: the built-in
    /// TacTip calibrated on the lab's flat-surface recordings, with its finite-element dome:
    /// `tactip-331-dome`; `tactip-331-calibrated` is the same TacTip over a half-space).
    #[staticmethod]
    #[pyo3(signature = (name_or_path = None))]
    fn load(name_or_path: Option<&str>) -> PyResult<Self> {
        let params = match name_or_path {
            None => SensorParams::default(),
            Some(arg) => SensorParams::file_or_preset(arg, None).map_err(sim_err)?,
        };
        Ok(Self { params })
    }

    /// The built-in preset names.
    #[staticmethod]
    fn presets() -> Vec<String> {
        presets()
    }

    /// The sensor's name.
    #[getter]
    fn name(&self) -> String {
        self.params.name.clone()
    }

    /// Number of pins.
    #[getter]
    fn pin_count(&self) -> usize {
        self.params.pin_count()
    }

    /// The camera's image size (px).
    #[getter]
    fn image_size(&self) -> u32 {
        self.params.camera.image_size
    }

    /// Outer radius of the dome (mm).
    #[getter]
    fn dome_radius_mm(&self) -> f64 {
        self.params.dome.outer_radius_mm
    }

    /// The sensor as TOML (the format of `sim/presets/*.toml`).
    fn to_toml(&self) -> String {
        self.params.to_toml()
    }

    /// The undeformed binary image, `uint8 (size, size)`, 0 or 255.
    #[pyo3(signature = (size = None))]
    fn undeformed_image<'py>(&self, py: Python<'py>, size: Option<u32>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        image_array(py, self.renderer(size)?.render_undeformed())
    }

    fn __repr__(&self) -> String {
        format!("Sensor(name={:?}, pins={}, image_size={})", self.params.name, self.pin_count(), self.image_size())
    }
}

fn presets() -> Vec<String> {
    PRESETS.iter().map(|(n, _)| (*n).to_owned()).collect()
}
