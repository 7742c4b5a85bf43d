//! `tetlap._core.gradients`: the P1 gradients of every element (`tetlap::gradients`), for
//! `tetlap.gradient`.

use crate::convert::{Input, Job};
use crate::errors::compute;
use crate::options::OptionsArg;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use tetlap::{MeshView, Options, Simplex};

struct Gradients;

impl Job for Gradients {
    type Output = (Vec<f64>, Vec<f64>, usize);

    fn run<S: Simplex>(self, mesh: &MeshView<S>, opts: &Options) -> tetlap::Result<Self::Output> {
        let (g, vol) = tetlap::gradients(mesh, opts)?;
        Ok((g, vol, S::CORNERS))
    }
}

/// `(g, vol)`: the gradients of the barycentric coordinates, `(m, K, d)` float64 (`K` = 4
/// for tets, 3 for triangles), and the unsigned element measures, `(m,)`.
#[pyfunction]
#[pyo3(signature = (points, cells, *, options=None))]
pub fn gradients<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    let dim = input.dim;
    let (g, vol, k) = compute(py, opts, move |opts| input.run(Gradients, opts))?;
    let m = vol.len();
    PyTuple::new(py, [PyArray1::from_vec(py, g).reshape([m, k, dim])?.into_any(), PyArray1::from_vec(py, vol).into_any()])
}
