//! `tetlap._core.vjp`: the vector-Jacobian product of the operators (`tetlap::vjp`), for
//! `tetlap.derivatives`.
//!
//! Cotangents arrive as tagged tuples, copied out of NumPy before the GIL is released:
//! on `L`, `("elements", (m, 6))`, `("matrix", (indptr, indices, data))` or
//! `("quadratic", (n, k))`; on `M`, `("diagonal", (n,))`, `("matrix", ...)` or
//! `("quadratic", (n, k))`.

use crate::convert::{Cells, Input};
use crate::errors::{guarded, option_error, shape_error};
use crate::options::{BoundaryArg, DegenerateArg, Kind, MassArg, Threads};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyString, PyTuple};
use pyo3::Borrowed;
use tetlap::{
    Cancel, Columns, Cotangents, CsrRef, LaplacianCotangent, MassCotangent, Options,
};

/// An owned sparse cotangent (CSR, checked in the core).
pub struct Sparse {
    indptr: Vec<usize>,
    indices: Vec<u32>,
    data: Vec<f64>,
}

/// One cotangent as the Python layer hands it over.
pub enum Cotangent {
    Elements(Vec<[f64; 6]>),
    Matrix(Sparse),
    Quadratic(Vec<f64>, usize),
    Diagonal(Vec<f64>),
}

fn copy1(py: Python<'_>, a: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let a: PyReadonlyArray1<'_, f64> =
        a.extract().map_err(|_| shape_error(py, format!("internal: {what} must be a 1-d float64 array")))?;
    Ok(a.as_array().iter().copied().collect())
}

fn copy2(py: Python<'_>, a: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<f64>, usize)> {
    let a: PyReadonlyArray2<'_, f64> =
        a.extract().map_err(|_| shape_error(py, format!("internal: {what} must be a 2-d float64 array")))?;
    let k = a.shape()[1];
    Ok((a.as_array().iter().copied().collect(), k))
}

fn indices(py: Python<'_>, a: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<i64>> {
    let a: PyReadonlyArray1<'_, i64> =
        a.extract().map_err(|_| shape_error(py, format!("internal: {what} must be a 1-d int64 array")))?;
    Ok(a.as_array().iter().copied().collect())
}

impl<'a, 'py> FromPyObject<'a, 'py> for Cotangent {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let bad = || option_error(py, "internal: a cotangent is a (form, arrays) pair".into());
        let pair = obj.cast::<PyTuple>().map_err(|_| bad())?;
        if pair.len() != 2 {
            return Err(bad());
        }
        let form = pair.get_item(0)?;
        let form = form.cast::<PyString>().map_err(|_| bad())?.to_str()?.to_owned();
        let payload = pair.get_item(1)?;
        Ok(match form.as_str() {
            "elements" => {
                let (v, k) = copy2(py, &payload, "a per-tet cotangent")?;
                if k != 6 {
                    return Err(shape_error(py, format!("a per-tet cotangent has 6 columns, got {k}")));
                }
                Cotangent::Elements(v.chunks_exact(6).map(|c| c.try_into().expect("6 values")).collect())
            }
            "quadratic" => {
                let (v, k) = copy2(py, &payload, "f")?;
                Cotangent::Quadratic(v, k)
            }
            "diagonal" => Cotangent::Diagonal(copy1(py, &payload, "a diagonal cotangent")?),
            "matrix" => {
                let triple = payload.cast::<PyTuple>().map_err(|_| bad())?;
                if triple.len() != 3 {
                    return Err(bad());
                }
                let indptr = indices(py, &triple.get_item(0)?, "indptr")?;
                let cols = indices(py, &triple.get_item(1)?, "indices")?;
                let data = copy1(py, &triple.get_item(2)?, "data")?;
                let negative = || shape_error(py, "a sparse cotangent has a negative index".into());
                let indptr = indptr.into_iter().map(|p| usize::try_from(p).map_err(|_| negative())).collect::<PyResult<_>>()?;
                let indices = cols
                    .into_iter()
                    .map(|j| {
                        u32::try_from(j).map_err(|_| {
                            shape_error(py, format!("a sparse cotangent has a column index {j} out of range"))
                        })
                    })
                    .collect::<PyResult<_>>()?;
                Cotangent::Matrix(Sparse { indptr, indices, data })
            }
            _ => return Err(bad()),
        })
    }
}

fn csr(s: &Sparse, n: usize) -> CsrRef<'_> {
    CsrRef { n, indptr: &s.indptr, indices: &s.indices, data: &s.data }
}

/// `(gradient (n, d), weight gradient (n,) or None, value)` of `<dl, L> + <dm, M>`.
#[pyfunction]
#[pyo3(signature = (points, cells, laplacian, mass, *, dl=None, dm=None, weights=None, boundary=Default::default(), degenerate=Default::default(), threads=Default::default()))]
#[allow(clippy::too_many_arguments)]
pub fn vjp<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    laplacian: Option<Kind>,
    mass: Option<MassArg>,
    dl: Option<Cotangent>,
    dm: Option<Cotangent>,
    weights: Option<PyReadonlyArray1<'py, f64>>,
    boundary: BoundaryArg,
    degenerate: DegenerateArg,
    threads: Threads,
) -> PyResult<Bound<'py, PyTuple>> {
    let input = Input::new(py, &points, &cells, weights.as_ref())?;
    let only_tets = "derivatives are available for tet meshes, (m, 4) cells, only";
    if !matches!(input.cells, Cells::Tets(_)) {
        return Err(shape_error(py, only_tets.into()));
    }
    let lap = match (laplacian, dl) {
        (Some(kind), Some(c)) => Some((kind.0, c)),
        (None, None) | (Some(_), None) => None,
        (None, Some(_)) => return Err(option_error(py, "a Laplacian cotangent needs the Laplacian's kind".into())),
    };
    let mass = match (mass, dm) {
        (Some(kind), Some(c)) => Some((kind.0, c)),
        (None, None) | (Some(_), None) => None,
        (None, Some(_)) => return Err(option_error(py, "a mass cotangent needs the mass kind".into())),
    };
    let cancel = Cancel::new();
    let opts = Options { threads: threads.0, degenerate: degenerate.0, boundary: boundary.0, cancel: Some(cancel.clone()) };
    let dim = input.dim;
    let g = guarded(py, &cancel, move || {
        let Cells::Tets(tets) = &input.cells else {
            return Err(tetlap::Error::Shape { what: only_tets.into() });
        };
        let mesh = input.mesh::<tetlap::Tet>(tets)?;
        let n = mesh.n_vertices();
        let laplacian = match &lap {
            None => None,
            Some((kind, c)) => Some((*kind, match c {
                Cotangent::Elements(e) => LaplacianCotangent::Elements(e),
                Cotangent::Matrix(s) => LaplacianCotangent::Matrix(csr(s, n)),
                Cotangent::Quadratic(v, k) => LaplacianCotangent::Dirichlet(Columns::new(v, *k)),
                Cotangent::Diagonal(_) => {
                    return Err(tetlap::Error::Shape { what: "a Laplacian cotangent cannot be a diagonal".into() })
                }
            })),
        };
        let mass = match &mass {
            None => None,
            Some((kind, c)) => Some((*kind, match c {
                Cotangent::Diagonal(d) => MassCotangent::Diagonal(d),
                Cotangent::Matrix(s) => MassCotangent::Matrix(csr(s, n)),
                Cotangent::Quadratic(v, k) => MassCotangent::Quadratic(Columns::new(v, *k)),
                Cotangent::Elements(_) => {
                    return Err(tetlap::Error::Shape { what: "a mass cotangent cannot be per tet".into() })
                }
            })),
        };
        tetlap::vjp(&mesh, &Cotangents { laplacian, mass }, &opts)
    })?;
    let n = g.points.len() / dim;
    let points = PyArray1::from_vec(py, g.points).reshape([n, dim])?.into_any();
    let weights = match g.weights {
        Some(w) => PyArray1::from_vec(py, w).into_any(),
        None => py.None().into_bound(py),
    };
    PyTuple::new(py, [points, weights, g.value.into_pyobject(py)?.into_any()])
}
