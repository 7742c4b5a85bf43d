//! `tetlap._core`: the thin PyO3 layer over the `tetlap` crate.
//!
//! Every function copies its inputs (so no other Python thread can change them under the
//! computation), validates them in the core, releases the GIL for the computation, catches
//! any panic, and hands the output arrays to NumPy without copying. The public API, with
//! its array-like conversions and SciPy wrapping, is the Python package `tetlap`.

mod convert;
mod errors;
mod mesh;

use pyo3::prelude::*;

#[pymodule]
mod _core {
    use crate::convert::{csr_arrays, rows, Input, RawOptions, Spec};
    use crate::errors::guarded;
    use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
    use pyo3::prelude::*;
    use pyo3::types::PyTuple;
    use tetlap::Mass;

    #[pymodule_export]
    use crate::mesh::PyMesh;

    type Points<'py> = PyReadonlyArray2<'py, f64>;
    type Tets<'py> = PyReadonlyArray2<'py, i64>;
    type Weights<'py> = Option<PyReadonlyArray1<'py, f64>>;

    /// Laplacian as CSR arrays `(data, indices, indptr)`.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, t, options))]
    fn laplacian<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        t: f64,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(Some((kind, t)), None, &options)?;
        let l = guarded(py, move || input.laplacian(spec.lap(), &spec.opts))?;
        csr_arrays(py, l)
    }

    /// Mass matrix as `("lumped", diagonal)` or `("csr", (data, indices, indptr))`.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, options))]
    fn mass<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(None, Some(kind), &options)?;
        let m = guarded(py, move || input.mass(spec.mass(), &spec.opts))?;
        mass_arrays(py, m)
    }

    /// Laplacian and mass in one pass: `(laplacian_csr_arrays, mass_arrays)`.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, t, mass_kind, options))]
    fn operators<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        t: f64,
        mass_kind: &str,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(Some((kind, t)), Some(mass_kind), &options)?;
        let (l, m) = guarded(py, move || input.operators(spec.lap(), spec.mass(), &spec.opts))?;
        PyTuple::new(py, [csr_arrays(py, l)?, mass_arrays(py, m)?])
    }

    /// Per-element edge weights, `(m, 6)` (tets) or `(m, 3)` (triangles) float64.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, t, options))]
    fn tet_contributions<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        t: f64,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(Some((kind, t)), None, &options)?;
        let (w, k) = guarded(py, move || input.contributions(spec.lap(), &spec.opts))?;
        let m = w.len() / k;
        PyArray1::from_vec(py, w).reshape([m, k])
    }

    /// Unsummed triplets `(rows, cols, vals)`, 16 per tet or 9 per triangle.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, t, options))]
    fn triplets<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        t: f64,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(Some((kind, t)), None, &options)?;
        let coo = guarded(py, move || input.triplets(spec.lap(), &spec.opts))?;
        let as_i64 = |v: Vec<u32>| v.into_iter().map(i64::from).collect::<Vec<_>>();
        PyTuple::new(
            py,
            [
                PyArray1::from_vec(py, as_i64(coo.rows)).into_any(),
                PyArray1::from_vec(py, as_i64(coo.cols)).into_any(),
                PyArray1::from_vec(py, coo.vals).into_any(),
            ],
        )
    }

    /// Unique edges `(E, 2)` int64 and their summed weights `(E,)`.
    #[pyfunction]
    #[pyo3(signature = (points, tets, weights, kind, t, options))]
    fn edge_weights<'py>(
        py: Python<'py>,
        points: Points<'py>,
        tets: Tets<'py>,
        weights: Weights<'py>,
        kind: &str,
        t: f64,
        options: RawOptions,
    ) -> PyResult<Bound<'py, PyTuple>> {
        let input = Input::new(py, &points, &tets, weights.as_ref())?;
        let spec = Spec::new(Some((kind, t)), None, &options)?;
        let (edges, w) = guarded(py, move || {
            input.laplacian(spec.lap(), &spec.opts).map(|l| tetlap::upper_triangle(&l))
        })?;
        let edges: Vec<[i64; 2]> = edges.into_iter().map(|e| e.map(i64::from)).collect();
        PyTuple::new(py, [rows(py, edges)?.into_any(), PyArray1::from_vec(py, w).into_any()])
    }

    /// Test hook: a panic inside the guarded region, which must surface as
    /// `tetlap.errors.InternalError` (never as `PanicException`).
    #[pyfunction]
    fn _panic_inside_guard(py: Python<'_>, message: String) -> PyResult<()> {
        guarded(py, move || -> tetlap::Result<()> { panic!("{message}") })
    }

    fn mass_arrays<'py>(py: Python<'py>, m: Mass) -> PyResult<Bound<'py, PyTuple>> {
        match m {
            Mass::Lumped(d) => {
                PyTuple::new(py, ["lumped".into_pyobject(py)?.into_any(), PyArray1::from_vec(py, d).into_any()])
            }
            Mass::Consistent(c) => {
                PyTuple::new(py, ["csr".into_pyobject(py)?.into_any(), csr_arrays(py, c)?.into_any()])
            }
        }
    }
}
