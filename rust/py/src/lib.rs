//! `tetlap._core`: the thin PyO3 layer over the `tetlap` crate.
//!
//! Every function copies its inputs (so no other Python thread can change them under the
//! computation), parses its options into the core's types ([`options`]), runs the
//! computation on a worker thread without the GIL (answering Ctrl-C, catching any panic:
//! [`errors::compute`]), and hands the output arrays to NumPy without copying. The public
//! API, with its array-like conversions and SciPy wrapping, is the Python package `tetlap`.

mod analysis;
#[cfg(target_os = "linux")]
mod child;
mod convert;
mod derivatives;
mod dual;
mod errors;
mod gradient;
mod mesh;
mod options;
mod regular;
mod solve;

use pyo3::prelude::*;

#[pymodule]
mod _core {
    use crate::convert::{Input, MediumArg};
    use crate::errors::compute;
    use crate::options::{OptionsArg, Request};
    use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn};
    use pyo3::prelude::*;

    #[pymodule_export]
    use crate::mesh::PyMesh;
    #[pymodule_export]
    use crate::analysis::{
        check_operator, duplicates, edges, element_certificate, faces, negative_semidefinite, non_delaunay, quality,
    };
    #[pymodule_export]
    use crate::derivatives::vjp;
    #[pymodule_export]
    use crate::dual::dual_centres;
    #[pymodule_export]
    use crate::gradient::gradients;
    #[pymodule_export]
    use crate::regular::{regular_conditions, regular_masses, regular_search, regular_signs};
    #[pymodule_export]
    use crate::solve::{PyFactor, PyLu};

    #[pymodule_init]
    fn init(m: &Bound<'_, PyModule>) -> PyResult<()> {
        crate::errors::init(m.py())?;
        m.add("MAX_THREADS", tetlap::max_threads())?;
        m.add("DELAUNAY_RTOL", tetlap::DELAUNAY_RTOL)?;
        m.add("MAX_GROUP", tetlap::MAX_GROUP)?;
        m.add("FACTOR_CHILD_MIN", crate::solve::CHILD_MIN_VALUES)
    }

    /// One pass of the one-shot API: `request` is `("laplacian", kind)` (CSR arrays
    /// `(data, indices, indptr)`), `("mass", kind)` (`("lumped", diagonal)` or
    /// `("csr", arrays)`), `("operators", kind, mass_kind)` (both),
    /// `("operators_skipping", kind, mass_kind)` (both and the `(k, 2)` int64 skipped
    /// elements: `[element, 0]` flat, `[element, 1]` beyond the range), `("contributions",
    /// kind)` (`(m, 6)` or `(m, 3)`), `("element_laplacians", kind)` (`(m, 10)` or `(m, 6)`:
    /// the weights, then the element's diagonal entries), `("triplets", kind)` (`(rows, cols,
    /// vals)`) or `("edge_weights", kind)` (`(edges (E, 2), weights (E,))`).
    ///
    /// `medium`: `(coefficient, density)`, the Laplacians' `(m,)` scalars, `(m, d, d)`
    /// tensors or `(d, d)` tensor and the masses' `(m,)` factors, either `None` (checked by
    /// the core).
    #[pyfunction]
    #[pyo3(signature = (points, cells, request, *, weights=None, medium=None, options=None))]
    fn assemble<'py>(
        py: Python<'py>,
        points: PyReadonlyArray2<'py, f64>,
        cells: PyReadonlyArray2<'py, i64>,
        request: Request,
        weights: Option<PyReadonlyArray1<'py, f64>>,
        medium: Option<MediumArg>,
        options: Option<OptionsArg>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let opts = OptionsArg::options(options);
        let input = Input::new(py, &points, &cells, weights.as_ref(), &opts)?.with(medium);
        compute(py, opts, move |opts| input.run(request, opts))?.into_py(py)
    }

    /// Checks a coefficient (`density=False`: `(m,)` scalars, `(m, d, d)` tensors or one
    /// `(d, d)` tensor) or a density (`(m,)`) for `m` elements of `corners` corners (4:
    /// tets, 3: triangles) in `dim`-space: `None`, or the error naming the element (with
    /// `vertices=True`, values given per vertex, named `values`: the error names the vertex).
    #[pyfunction]
    #[pyo3(signature = (values, m, corners, dim, *, density=false, vertices=false))]
    fn check_coefficient(
        py: Python<'_>,
        values: PyReadonlyArrayDyn<'_, f64>,
        m: usize,
        corners: usize,
        dim: usize,
        density: bool,
        vertices: bool,
    ) -> PyResult<()> {
        use crate::convert::CoefficientArg;
        let arg = CoefficientArg::new(py, &values)?;
        let run = || -> tetlap::Result<()> {
            match (density, corners, &arg) {
                (true, 4, CoefficientArg::Scalar(d)) => tetlap::check_density::<tetlap::Tet>(d, m),
                (true, _, CoefficientArg::Scalar(d)) => tetlap::check_density::<tetlap::Tri>(d, m),
                (true, ..) => Err(tetlap::Error::Shape { what: "internal: a density is (m,)".into() }),
                (false, 4, c) => tetlap::check_coefficient::<tetlap::Tet>(c.view(), m, dim),
                (false, _, c) => tetlap::check_coefficient::<tetlap::Tri>(c.view(), m, dim),
            }
        };
        let opts = tetlap::Options::default();
        match py.detach(|| opts.install(run)) {
            Err(tetlap::Error::Coefficient { element, density, problem, .. }) if vertices => {
                Err(crate::errors::coefficient_error(py, element, ("values", "vertex", "vertex"), density, problem))
            }
            result => result.map_err(|e| crate::errors::to_py(py, e)),
        }
    }

    /// Checks the options before any work (what every call does first): `None` or an
    /// `OptionError` naming the bad value.
    #[pyfunction]
    fn check_options(options: Option<OptionsArg>) -> PyResult<()> {
        Python::attach(|py| OptionsArg::options(options).check().map_err(|e| crate::errors::to_py(py, e)))
    }
}
