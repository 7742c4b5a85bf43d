//! `tetlap._core.dual_centres`: the centres of the orthogonal dual and its dual edges
//! (`tetlap::dual_centres`), for `tetlap.dual_geometry` and `tetlap.dec`.

use crate::convert::Input;
use crate::errors::compute;
use crate::options::OptionsArg;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// `(points (m, 5, d), barycentric (m, 4), heights (m, 4), areas (m, 4), volumes (m,))`
/// float64: per tet its centre then its four face centres (face `l` opposite corner `l`),
/// the centre's barycentric coordinates, its signed distances from the faces (positive on
/// the tet's side), the faces' areas and the tet's signed volume. Tets only.
#[pyfunction]
#[pyo3(signature = (points, cells, *, weights=None, options=None))]
pub fn dual_centres<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    weights: Option<PyReadonlyArray1<'py, f64>>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, weights.as_ref(), &opts)?;
    let dim = input.dim;
    let tetlap::DualCentres { points, tets } =
        compute(py, opts, move |opts| tetlap::dual_centres(&input.tets("the dual geometry")?, opts))?;
    let m = tets.len();
    let table = |f: fn(&tetlap::TetDual) -> [f64; 4]| -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_iter(py, tets.iter().flat_map(f)).reshape([m, 4])?.into_any())
    };
    PyTuple::new(
        py,
        [
            PyArray1::from_vec(py, points).reshape([m, 5, dim])?.into_any(),
            table(|t| t.barycentric)?,
            table(|t| t.heights)?,
            table(|t| t.areas)?,
            PyArray1::from_iter(py, tets.iter().map(|t| t.volume)).into_any(),
        ],
    )
}
