//! `tetlap._core`: the thin PyO3 layer over the `tetlap` crate.
//!
//! Every function copies its inputs (so no other Python thread can change them under the
//! computation), parses its options into the core's types, runs the computation on a
//! worker thread without the GIL (answering Ctrl-C, catching any panic), and hands the
//! output arrays to NumPy without copying. The public API, with its array-like
//! conversions and SciPy wrapping, is the Python package `tetlap`.

mod convert;
mod derivatives;
mod diagnostics;
mod errors;
mod mesh;
mod options;

use pyo3::prelude::*;

#[pymodule]
mod _core {
    use crate::convert::{Input, Request};
    use crate::errors::guarded;
    use crate::options::{BoundaryArg, DegenerateArg, Kind, MassArg, Threads};
    use numpy::{PyReadonlyArray1, PyReadonlyArray2};
    use pyo3::prelude::*;
    use tetlap::{Cancel, Options};

    #[pymodule_export]
    use crate::mesh::PyMesh;

    #[pymodule_export]
    use crate::diagnostics::{
        check_operator, duplicates, edges, element_certificate, faces, negative_semidefinite, non_delaunay, quality,
    };
    #[pymodule_export]
    use crate::derivatives::vjp;

    type Points<'py> = PyReadonlyArray2<'py, f64>;
    type Cells<'py> = PyReadonlyArray2<'py, i64>;
    type Weights<'py> = Option<PyReadonlyArray1<'py, f64>>;

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        crate::errors::init(m.py())?;
        m.add("MAX_THREADS", tetlap::max_threads())?;
        m.add("DELAUNAY_RTOL", tetlap::DELAUNAY_RTOL)?;
        m.add("MAX_GROUP", tetlap::MAX_GROUP)
    }

    /// The core options of one call, with a fresh cancel flag.
    fn options(boundary: BoundaryArg, degenerate: DegenerateArg, threads: Threads) -> Options {
        Options { threads: threads.0, degenerate: degenerate.0, boundary: boundary.0, cancel: Some(Cancel::new()) }
    }

    /// The shared prologue and epilogue: copy the input, compute without the GIL, convert.
    fn compute<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        weights: Weights<'py>,
        opts: Options,
        request: Request,
    ) -> PyResult<Bound<'py, PyAny>> {
        let input = Input::new(py, &points, &cells, weights.as_ref())?;
        let cancel = opts.cancel.clone().expect("set by options()");
        let response = guarded(py, &cancel, move || input.run(request, &opts))?;
        response.into_py(py)
    }

    /// Laplacian as CSR arrays `(data, indices, indptr)`.
    #[pyfunction]
    #[pyo3(signature = (points, cells, kind, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn laplacian<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        kind: Kind,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::Laplacian(kind.0))
    }

    /// Mass matrix as `("lumped", diagonal)` or `("csr", (data, indices, indptr))`.
    #[pyfunction]
    #[pyo3(signature = (points, cells, kind, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn mass<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        kind: MassArg,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::Mass(kind.0))
    }

    /// Laplacian and mass in one pass: `(laplacian_csr_arrays, mass_arrays)`.
    #[pyfunction]
    #[pyo3(signature = (points, cells, laplacian, mass, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn operators<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        laplacian: Kind,
        mass: MassArg,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::Operators(laplacian.0, mass.0))
    }

    /// Per-element edge weights, `(m, 6)` (tets) or `(m, 3)` (triangles) float64.
    #[pyfunction]
    #[pyo3(signature = (points, cells, kind, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn contributions<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        kind: Kind,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::Contributions(kind.0))
    }

    /// Unsummed triplets `(rows, cols, vals)`, 16 per tet or 9 per triangle.
    #[pyfunction]
    #[pyo3(signature = (points, cells, kind, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn triplets<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        kind: Kind,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::Triplets(kind.0))
    }

    /// Unique edges `(E, 2)` int64 and their summed weights `(E,)`.
    #[pyfunction]
    #[pyo3(signature = (points, cells, kind, *, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
    #[allow(clippy::too_many_arguments)]
    fn edge_weights<'py>(
        py: Python<'py>,
        points: Points<'py>,
        cells: Cells<'py>,
        kind: Kind,
        weights: Weights<'py>,
        boundary: BoundaryArg,
        degenerate: DegenerateArg,
        threads: Threads,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = options(boundary, degenerate, threads);
        compute(py, points, cells, weights, opts, Request::EdgeWeights(kind.0))
    }
}
