//! `tetlap._core.Mesh`: the cached-topology mesh of the core, for `tetlap.Mesh`.

use crate::convert::{indptr_array, Input, RawOptions, Spec};
use crate::errors::guarded;
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// A mesh with its topology computed once (see `tetlap.Mesh`).
#[pyclass(module = "tetlap._core", name = "Mesh")]
pub struct PyMesh {
    inner: tetlap::Mesh,
}

#[pymethods]
impl PyMesh {
    #[new]
    #[pyo3(signature = (points, tets, weights, options))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        tets: PyReadonlyArray2<'_, i64>,
        weights: Option<PyReadonlyArray1<'_, f64>>,
        options: RawOptions,
    ) -> PyResult<Self> {
        let (points, dim, tets, weights) = Input::new(py, &points, &tets, weights.as_ref())?.tets()?;
        let opts = Spec::new(None, None, &options)?.opts;
        let inner =
            guarded(py, move || tetlap::Mesh::with_weights(points, dim, tets, weights, opts))?;
        Ok(PyMesh { inner })
    }

    /// `(indices uint32, indptr int32|int64)` of the CSR pattern.
    fn pattern<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let topo = self.inner.topology();
        PyTuple::new(
            py,
            [PyArray1::from_slice(py, &topo.indices).into_any(), indptr_array(py, &topo.indptr)],
        )
    }

    /// CSR data (a copy) of the Laplacian.
    fn laplacian<'py>(&mut self, py: Python<'py>, kind: &str, t: f64) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let lap = Spec::new(Some((kind, t)), None, &RawOptions::default())?.lap();
        let inner = &mut self.inner;
        let values = guarded(py, move || inner.laplacian_values(lap).map(|v| v.to_vec()))?;
        Ok(PyArray1::from_vec(py, values))
    }

    /// Values (a copy) of the mass: per vertex, or CSR data for "fem".
    fn mass<'py>(&mut self, py: Python<'py>, kind: &str) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let mass = Spec::new(None, Some(kind), &RawOptions::default())?.mass();
        let inner = &mut self.inner;
        let values = guarded(py, move || inner.mass_values(mass).map(|v| v.to_vec()))?;
        Ok(PyArray1::from_vec(py, values))
    }

    /// Moves the vertices; returns `(moved_vertices, recomputed_tets, recomputed_rows)`.
    ///
    /// The comparison with the current coordinates reads `points` in place, with the GIL
    /// held (one pass, no copy); only the moved vertices' coordinates are copied, and the
    /// recomputation runs without the GIL.
    fn update(&mut self, py: Python<'_>, points: PyReadonlyArray2<'_, f64>) -> PyResult<(usize, usize, usize)> {
        let dim = self.inner.dim();
        let shape_error = |message: String| crate::errors::to_py(py, tetlap::Error::Shape { message });
        if points.shape()[1] != dim {
            return Err(shape_error(format!("the new points must have {dim} columns, got {}", points.shape()[1])));
        }
        let new = points
            .as_slice()
            .map_err(|_| PyValueError::new_err("internal: arrays must be C-contiguous"))?;
        let moved = self.inner.moved_vertices(new).map_err(|e| crate::errors::to_py(py, e))?;
        let coords: Vec<f64> =
            moved.iter().flat_map(|&v| &new[v as usize * dim..(v as usize + 1) * dim]).copied().collect();
        let inner = &mut self.inner;
        let u = guarded(py, move || inner.move_vertices(&moved, &coords))?;
        Ok((u.moved_vertices, u.recomputed_tets, u.recomputed_rows))
    }

    /// The current coordinates (a copy), `(n, d)`.
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let dim = self.inner.dim();
        PyArray1::from_slice(py, self.inner.points()).reshape([self.inner.points().len() / dim, dim])
    }

    /// The tets (a copy), `(m, 4)` int64.
    fn tets<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let tets: Vec<[i64; 4]> = self.inner.tets().iter().map(|t| t.map(i64::from)).collect();
        crate::convert::rows(py, tets)
    }
}
