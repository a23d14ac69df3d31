//! `Dataset`: a dataset `tacsim generate` wrote, as numpy arrays.

use std::path::Path;

use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use tacsim_data::Subset;
use tacsim_data::{Dataset, Kind, Row, Split};

use crate::data_err;

/// Images `uint8 (n, size, size)`.
type Images<'py> = Bound<'py, PyArray3<u8>>;
/// Labels `float (n, 12)`.
type Labels<'py> = Bound<'py, PyArray2<f64>>;

/// The label columns, in order (`targets.csv` names; mm and deg).
const LABELS: [&str; 12] = [
    "pose_x", "pose_y", "pose_z", "pose_Rx", "pose_Ry", "pose_Rz", "shear_x", "shear_y", "shear_z", "shear_Rx",
    "shear_Ry", "shear_Rz",
];

fn labels(r: &Row) -> [f64; 12] {
    let (p, s) = (r.pose(), r.shear());
    [p[0], p[1], p[2], p[3], p[4], p[5], s[0], s[1], s[2], s[3], s[4], s[5]]
}

/// The value named `name` among `choices`, else a `ValueError` listing them.
fn choice<T: Copy>(what: &str, name: &str, choices: &[(&str, T)]) -> PyResult<T> {
    choices.iter().find(|(n, _)| *n == name).map(|(_, v)| *v).ok_or_else(|| {
        let names: Vec<&str> = choices.iter().map(|(n, _)| *n).collect();
        PyValueError::new_err(format!("{what} must be {}, got {name:?}", names.join(", ")))
    })
}

fn split(name: &str) -> PyResult<Split> {
    choice("split", name, &[("train", Split::Train), ("val", Split::Val), ("test", Split::Test)])
}

fn subset(name: &str) -> PyResult<Subset> {
    choice("subset", name, &[("all", Subset::All), ("paired", Subset::Paired), ("unpaired", Subset::Unpaired)])
}

fn kind(name: &str) -> PyResult<Kind> {
    choice("kind", name, &[("tap", Kind::Tap), ("slide", Kind::Slide)])
}

/// A generated dataset (`targets.csv`, `meta.json`, `images/`).
#[pyclass(name = "Dataset", module = "tacsim._tacsim", frozen)]
pub struct PyDataset {
    data: Dataset,
}

impl PyDataset {
    /// Images of rows `rows` as `uint8 (n, size, size)`, read in parallel without the GIL.
    fn images<'py>(&self, py: Python<'py>, rows: &[usize]) -> PyResult<Images<'py>> {
        let side = self.data.meta.image_size as usize;
        let data = &self.data;
        let pixels = py
            .detach(|| {
                rows.par_iter()
                    .map(|&i| data.image(&data.rows[i]).map(image::GrayImage::into_raw))
                    .collect::<Result<Vec<_>, _>>()
            })
            .map_err(data_err)?;
        PyArray1::from_vec(py, pixels.concat()).reshape([rows.len(), side, side])
    }

    fn label_array<'py>(&self, py: Python<'py>, rows: &[usize]) -> PyResult<Labels<'py>> {
        let flat: Vec<f64> = rows.iter().flat_map(|&i| labels(&self.data.rows[i])).collect();
        PyArray1::from_vec(py, flat).reshape([rows.len(), LABELS.len()])
    }
}

#[pymethods]
impl PyDataset {
    /// Opens the dataset in `dir` (its labels checked; images read on demand).
    #[new]
    fn new(dir: &str) -> PyResult<Self> {
        Ok(Self { data: Dataset::open(Path::new(dir)).map_err(data_err)? })
    }

    /// Samples in the dataset.
    fn __len__(&self) -> usize {
        self.data.rows.len()
    }

    /// The label columns of `labels` arrays, in order (mm, deg).
    #[getter]
    fn columns(&self) -> Vec<&'static str> {
        LABELS.to_vec()
    }

    /// Image side (px).
    #[getter]
    fn image_size(&self) -> u32 {
        self.data.meta.image_size
    }

    /// `(images uint8 (n, size, size), labels float (n, 12))` of the `kind` samples
    /// (`tap` or `slide`) of `split` (`train`, `val`, `test`) and `subset` (`all`,
    /// `paired`, `unpaired`), in file order.
    #[pyo3(signature = (split_name = "train", kind_name = "tap", subset_name = "all"))]
    fn samples<'py>(
        &self,
        py: Python<'py>,
        split_name: &str,
        kind_name: &str,
        subset_name: &str,
    ) -> PyResult<(Images<'py>, Labels<'py>)> {
        let rows = self.data.indices(split(split_name)?, subset(subset_name)?, kind(kind_name)?);
        Ok((self.images(py, &rows)?, self.label_array(py, &rows)?))
    }

    /// True pairs of `split`: `(taps uint8 (n, s, s), slides uint8 (n, s, s), tap labels,
    /// slide labels)`, each slide with the tap of its pose nearest its depth.
    #[pyo3(signature = (split_name = "train", subset_name = "all"))]
    fn true_pairs<'py>(
        &self,
        py: Python<'py>,
        split_name: &str,
        subset_name: &str,
    ) -> PyResult<(Images<'py>, Images<'py>, Labels<'py>, Labels<'py>)> {
        let pairs = self.data.true_pairs(split(split_name)?, subset(subset_name)?);
        let (taps, slides): (Vec<usize>, Vec<usize>) = pairs.into_iter().unzip();
        Ok((
            self.images(py, &taps)?,
            self.images(py, &slides)?,
            self.label_array(py, &taps)?,
            self.label_array(py, &slides)?,
        ))
    }

    /// The undeformed reference image, `uint8 (size, size)`.
    fn reference<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<u8>>> {
        crate::sensor::image_array(py, self.data.reference().map_err(data_err)?)
    }

    fn __repr__(&self) -> String {
        format!("Dataset({:?}, samples={})", self.data.dir.display().to_string(), self.data.rows.len())
    }
}
