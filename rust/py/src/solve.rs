//! `tetlap._core.Factor`: the core's sparse factorization (`tetlap::solve`), for
//! `tetlap.solve.factorize`.

use crate::convert::CsrArg;
use crate::errors::{compute, option_error};
use crate::options::OptionsArg;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::RwLock;
use tetlap::solve::{Factorization, Method, Ordering};

/// A sparse symmetric factorization (`"cholesky"`: `LL^T`, `"ldlt"`: `LDL^T` without
/// pivoting) of an `n x n` matrix given as CSR arrays `(data, indices, indptr)`, with
/// `ordering` the elimination order (int64 permutation of `0..n`) or None for AMD. Only the
/// upper triangle is read. Every call runs without the GIL and answers Ctrl-C between its
/// phases.
#[pyclass(module = "tetlap._core", name = "Factor", frozen)]
pub struct PyFactor {
    inner: RwLock<Factorization>,
}

fn method(name: &str, py: Python<'_>) -> PyResult<Method> {
    match name {
        "cholesky" => Ok(Method::Cholesky),
        "ldlt" => Ok(Method::Ldlt),
        _ => Err(option_error(py, format!("method must be \"cholesky\" or \"ldlt\", got {name:?}"))),
    }
}

#[pymethods]
impl PyFactor {
    #[new]
    #[pyo3(signature = (n, matrix, method_name, ordering=None, *, options=None))]
    fn new(
        py: Python<'_>,
        n: usize,
        matrix: CsrArg,
        method_name: &str,
        ordering: Option<PyReadonlyArray1<'_, i64>>,
        options: Option<OptionsArg>,
    ) -> PyResult<Self> {
        let method = method(method_name, py)?;
        let ordering = match ordering {
            None => Ordering::Amd,
            Some(order) => Ordering::Custom(
                order.as_array().iter().map(|&i| u32::try_from(i).unwrap_or(u32::MAX)).collect(),
            ),
        };
        let f = compute(py, OptionsArg::options(options), move |opts| {
            Factorization::new(matrix.view(n), method, &ordering, opts)
        })?;
        Ok(PyFactor { inner: RwLock::new(f) })
    }

    /// New values on the factorized pattern (the symbolic analysis is reused).
    #[pyo3(signature = (n, matrix, *, options=None))]
    fn refactor(&self, py: Python<'_>, n: usize, matrix: CsrArg, options: Option<OptionsArg>) -> PyResult<()> {
        compute(py, OptionsArg::options(options), move |opts| {
            self.inner.write().unwrap_or_else(|e| e.into_inner()).refactor(matrix.view(n), opts)
        })
    }

    /// `X` for `A X = B`, with `B` and `X` as `(k, n)` arrays (one right-hand side per row).
    #[pyo3(signature = (rhs, *, options=None))]
    fn solve<'py>(&self, py: Python<'py>, rhs: PyReadonlyArray2<'py, f64>, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let shape = [rhs.shape()[0], rhs.shape()[1]];
        let mut x: Vec<f64> = rhs.as_array().iter().copied().collect();
        let x = compute(py, OptionsArg::options(options), move |opts| {
            self.inner.read().unwrap_or_else(|e| e.into_inner()).solve(&mut x, opts).map(|_| x)
        })?;
        PyArray1::from_vec(py, x).reshape(shape)
    }

    /// `(negative, zero, positive)` pivots (Sylvester's law of inertia).
    fn inertia(&self) -> (usize, usize, usize) {
        let i = self.inner.read().unwrap_or_else(|e| e.into_inner()).inertia();
        (i.negative, i.zero, i.positive)
    }

    /// `(row, |pivot| / |a_row,row|)` of the smallest pivot against its diagonal entry.
    fn smallest_pivot(&self) -> (usize, f64) {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).smallest_pivot()
    }

    /// The matrix order.
    #[getter]
    fn n(&self) -> usize {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).n()
    }

    /// The stored values of the factor (its fill).
    #[getter]
    fn factor_entries(&self) -> usize {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).factor_entries()
    }

    /// Whether the supernodal (dense blocks) form was chosen.
    #[getter]
    fn supernodal(&self) -> bool {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).supernodal()
    }
}
