//! `tetlap._core.Factor`: the core's sparse factorization (`tetlap::solve`), for
//! `tetlap.solve.factorize`.

use crate::convert::CsrArg;
use crate::errors::{compute, option_error, solve_error};
use crate::options::OptionsArg;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::ops::{Deref, DerefMut};
use std::sync::RwLock;
use tetlap::solve::{Analysis, Factorization, LuFactors, Method, Ordering};
use tetlap::{Error, Options};

/// From this many stored values of the factor on (about the 4M of a 60k-tet cube), the
/// numeric factorization runs in a child process (where fork is available): below it, the
/// factorization ends within about 0.25 s, soon enough for Ctrl-C, and the fork with its
/// shared memory (0.05 to 0.15 s) would cost as much (BENCHMARKS.md, "Ctrl-C during a
/// factorization").
pub const CHILD_MIN_VALUES: usize = 4_000_000;

/// A sparse symmetric factorization (`"cholesky"`: `LL^T`, `"ldlt"`: `LDL^T` without
/// pivoting) of an `n x n` matrix given as CSR arrays `(data, indices, indptr)`, with
/// `ordering` the elimination order (int64 permutation of `0..n`) or None for AMD. Only the
/// upper triangle is read. Every call runs without the GIL and answers Ctrl-C within
/// 0.1 s: on Linux a large numeric factorization (`child=None`: from `FACTOR_CHILD_MIN`
/// stored values of the factor; True or False force it) runs in a forked child process,
/// killed on Ctrl-C, so that nothing runs on after the KeyboardInterrupt; elsewhere it runs
/// in this process, and Ctrl-C waits for it. A refactor that failed or was interrupted
/// leaves no usable factor: `solve`, `inertia` and `smallest_pivot` then raise SolveError
/// until a refactor succeeds.
#[pyclass(module = "tetlap._core", name = "Factor", frozen)]
pub struct PyFactor {
    inner: RwLock<Inner>,
}

struct Inner {
    factor: Factorization<Storage>,
    /// The last refactor failed or was interrupted: the values are not a factor.
    stale: bool,
}

/// Where the factor's values live: this process's heap, or memory shared with the child
/// process that computes them.
enum Storage {
    Heap(Vec<f64>),
    #[cfg(target_os = "linux")]
    Shared(crate::child::Shared),
}

impl Deref for Storage {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        match self {
            Storage::Heap(v) => v,
            #[cfg(target_os = "linux")]
            Storage::Shared(s) => s,
        }
    }
}

impl DerefMut for Storage {
    fn deref_mut(&mut self) -> &mut [f64] {
        match self {
            Storage::Heap(v) => v,
            #[cfg(target_os = "linux")]
            Storage::Shared(s) => s,
        }
    }
}

impl Storage {
    /// Zeroed storage for `analysis`'s factor: shared with a child process when `child`.
    fn new(analysis: &Analysis, child: bool) -> tetlap::Result<Storage> {
        #[cfg(target_os = "linux")]
        if child {
            return crate::child::Shared::new(analysis.values_len()).map(Storage::Shared);
        }
        let _ = child;
        let mut values = Vec::new();
        values.try_reserve_exact(analysis.values_len()).map_err(|_| Error::OutOfMemory { what: "the factor" })?;
        values.resize(analysis.values_len(), 0.0);
        Ok(Storage::Heap(values))
    }

    fn shared(&self) -> bool {
        !matches!(self, Storage::Heap(_))
    }
}

/// Whether the numeric factorization of `analysis` runs in a child process: as asked, or
/// by its size; never where fork is not available.
fn use_child(analysis: &Analysis, child: Option<bool>) -> bool {
    cfg!(target_os = "linux") && child.unwrap_or(analysis.values_len() >= CHILD_MIN_VALUES)
}

/// The numeric factorization of `data` into `values` (replaced by storage of the kind that
/// `child` needs if it is of the other kind), in a child process when `child`.
fn numeric(analysis: &Analysis, data: &[f64], values: &mut Storage, child: bool, opts: &Options) -> tetlap::Result<()> {
    if values.shared() != child {
        *values = Storage::new(analysis, child)?;
    }
    let mut workspace = analysis.workspace()?;
    opts.cancelled()?;
    match values {
        #[cfg(target_os = "linux")]
        Storage::Shared(shared) => {
            crate::child::run(shared, || opts.is_cancelled(), |out| analysis.numeric(data, out, &mut workspace))
        }
        _ => analysis.numeric(data, values, &mut workspace),
    }
}

fn method(name: &str, py: Python<'_>) -> PyResult<Method> {
    match name {
        "cholesky" => Ok(Method::Cholesky),
        "ldlt" => Ok(Method::Ldlt),
        _ => Err(option_error(py, format!("method must be \"cholesky\" or \"ldlt\", got {name:?}"))),
    }
}

impl PyFactor {
    /// The factorization for reading, or SolveError if its last refactor did not succeed.
    fn ready(&self, py: Python<'_>) -> PyResult<std::sync::RwLockReadGuard<'_, Inner>> {
        let inner = self.inner.read().unwrap_or_else(|e| e.into_inner());
        if inner.stale {
            return Err(solve_error(
                py,
                "the last refactor of this factorization failed or was interrupted: it holds no \
                 factor until a refactor succeeds"
                    .into(),
            ));
        }
        Ok(inner)
    }
}

#[pymethods]
impl PyFactor {
    #[new]
    #[pyo3(signature = (n, matrix, method_name, ordering=None, *, options=None, child=None))]
    fn new(
        py: Python<'_>,
        n: usize,
        matrix: CsrArg,
        method_name: &str,
        ordering: Option<PyReadonlyArray1<'_, i64>>,
        options: Option<OptionsArg>,
        child: Option<bool>,
    ) -> PyResult<Self> {
        let method = method(method_name, py)?;
        let ordering = match ordering {
            None => Ordering::Amd,
            Some(order) => Ordering::Custom(
                order.as_array().iter().map(|&i| u32::try_from(i).unwrap_or(u32::MAX)).collect(),
            ),
        };
        let factor = compute(py, OptionsArg::options(options), move |opts| {
            let a = matrix.view(n);
            let analysis = Analysis::new(a, method, &ordering, opts)?;
            let child = use_child(&analysis, child);
            let mut values = Storage::new(&analysis, child)?;
            numeric(&analysis, a.data, &mut values, child, opts)?;
            Factorization::from_parts(analysis, a.data, values)
        })?;
        Ok(PyFactor { inner: RwLock::new(Inner { factor, stale: false }) })
    }

    /// New values on the factorized pattern (the symbolic analysis and the factor's memory
    /// are reused).
    #[pyo3(signature = (n, matrix, *, options=None, child=None))]
    fn refactor(&self, py: Python<'_>, n: usize, matrix: CsrArg, options: Option<OptionsArg>, child: Option<bool>) -> PyResult<()> {
        compute(py, OptionsArg::options(options), move |opts| {
            let mut inner = self.inner.write().unwrap_or_else(|e| e.into_inner());
            let a = matrix.view(n);
            inner.factor.analysis().check_pattern(a)?;
            inner.stale = true;
            inner.factor.refactor_with(a, |analysis, values| {
                numeric(analysis, a.data, values, use_child(analysis, child), opts)
            })?;
            inner.stale = false;
            Ok(())
        })
    }

    /// `X` for `A X = B`, with `B` and `X` as `(k, n)` arrays (one right-hand side per row).
    #[pyo3(signature = (rhs, *, options=None))]
    fn solve<'py>(&self, py: Python<'py>, rhs: PyReadonlyArray2<'py, f64>, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        drop(self.ready(py)?);
        let shape = [rhs.shape()[0], rhs.shape()[1]];
        let mut x: Vec<f64> = rhs.as_array().iter().copied().collect();
        let x = compute(py, OptionsArg::options(options), move |opts| {
            self.inner.read().unwrap_or_else(|e| e.into_inner()).factor.solve(&mut x, opts).map(|_| x)
        })?;
        PyArray1::from_vec(py, x).reshape(shape)
    }

    /// `(negative, zero, positive)` pivots (Sylvester's law of inertia).
    fn inertia(&self, py: Python<'_>) -> PyResult<(usize, usize, usize)> {
        let i = self.ready(py)?.factor.inertia();
        Ok((i.negative, i.zero, i.positive))
    }

    /// `(row, |pivot| / |a_row,row|)` of the smallest pivot against its diagonal entry.
    fn smallest_pivot(&self, py: Python<'_>) -> PyResult<(usize, f64)> {
        Ok(self.ready(py)?.factor.smallest_pivot())
    }

    /// The matrix order.
    #[getter]
    fn n(&self) -> usize {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).factor.n()
    }

    /// The stored values of the factor (its fill).
    #[getter]
    fn factor_entries(&self) -> usize {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).factor.factor_entries()
    }

    /// Whether the supernodal (dense blocks) form was chosen.
    #[getter]
    fn supernodal(&self) -> bool {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).factor.supernodal()
    }

    /// Whether the factor's values were computed in a child process (and live in memory
    /// shared with it).
    #[getter]
    fn in_child(&self) -> bool {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).factor.values().shared()
    }
}

/// The factors `Pr A Pc = L U` of a sparse LU made elsewhere (SciPy's SuperLU), for solves:
/// `l` and `u` as CSC arrays `(data, indices, indptr)` with sorted indices (`L` unit lower
/// triangular with its diagonal stored, `U` upper triangular), `perm_r` and `perm_c` as
/// SuperLU gives them. The arrays are copied; every solve runs without the GIL.
#[pyclass(module = "tetlap._core", name = "LU", frozen)]
pub struct PyLu {
    inner: LuFactors,
}

/// A sparse matrix as `(data, indices, indptr)`.
type Arrays<'py> = (Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>);

#[pymethods]
impl PyLu {
    #[new]
    fn new(py: Python<'_>, n: usize, l: CsrArg, u: CsrArg, perm_r: PyReadonlyArray1<'_, i64>, perm_c: PyReadonlyArray1<'_, i64>) -> PyResult<Self> {
        let order = |p: &PyReadonlyArray1<'_, i64>| -> Vec<u32> {
            p.as_array().iter().map(|&i| u32::try_from(i).unwrap_or(u32::MAX)).collect()
        };
        let (rows, columns) = (order(&perm_r), order(&perm_c));
        let inner = compute(py, Options::default(), move |_| LuFactors::new(l.view(n), u.view(n), &rows, &columns))?;
        Ok(PyLu { inner })
    }

    /// `X` for `A X = B`, with `B` and `X` as `(k, n)` arrays (one right-hand side per row).
    #[pyo3(signature = (rhs, *, options=None))]
    fn solve<'py>(&self, py: Python<'py>, rhs: PyReadonlyArray2<'py, f64>, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let shape = [rhs.shape()[0], rhs.shape()[1]];
        let mut x: Vec<f64> = rhs.as_array().iter().copied().collect();
        let x = compute(py, OptionsArg::options(options), move |opts| self.inner.solve(&mut x, opts).map(|_| x))?;
        PyArray1::from_vec(py, x).reshape(shape)
    }

    /// `U` (`upper=True`) or `L` as CSC arrays `(data, indices, indptr)` (a copy).
    fn factor<'py>(&self, py: Python<'py>, upper: bool) -> Arrays<'py> {
        let (indptr, indices, data) = self.inner.factors()[usize::from(upper)];
        let int = |v: &[usize]| v.iter().map(|&i| i as i64).collect::<Vec<_>>().into_pyarray(py);
        (data.to_vec().into_pyarray(py), int(indices), int(indptr))
    }

    /// The matrix order.
    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }
}
