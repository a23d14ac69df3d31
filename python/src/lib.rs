//! `tacsim._tacsim`: the simulator from Python (pyo3). `Sensor` loads a
//! preset, `Scene` places stimuli, `Contact` presses
//! and slides the sensor over them with stick/slip history and returns images, pins, the
//! pressure field and the force as numpy arrays; `Dataset` reads a
//! generated dataset. The package `tacsim` (python/tacsim) re-exports them with docstrings and
//! type stubs. Units: mm, deg, N, MPa; frames as in the Rust crates (sensor frame: `z` along
//! the sensor's axis into the stimulus, image `u` right and `v` down in px).

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;

mod contact;
mod dataset;
mod generate;
mod scene;
mod sensor;

/// A simulator error as a Python exception: `OSError` for files that cannot be read or
/// written, `ValueError` for everything else (bad values, names, formats), with the Rust
/// message (file, field, value, range).
pub(crate) fn sim_err(e: tacsim_sim::SimError) -> PyErr {
    match e {
        tacsim_sim::SimError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// A dataset error as a Python exception (see [`sim_err`]).
pub(crate) fn data_err(e: tacsim_data::DataError) -> PyErr {
    match e {
        tacsim_data::DataError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// The extension module.
#[pymodule]
fn _tacsim(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<sensor::PySensor>()?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<contact::PyContact>()?;
    m.add_class::<dataset::PyDataset>()?;
    m.add_function(wrap_pyfunction!(scene::shapes, m)?)?;
    m.add_function(wrap_pyfunction!(contact::slide_many, m)?)?;
    m.add_function(wrap_pyfunction!(generate::generate, m)?)?;
    m.add_function(wrap_pyfunction!(generate::merge, m)?)?;
    m.add_function(wrap_pyfunction!(generate::plan, m)?)?;
    Ok(())
}
