//! `tetlap._core.vjp`: the vector-Jacobian product of the operators (`tetlap::vjp`), for
//! `tetlap.derivatives`.
//!
//! Cotangents arrive as tagged tuples, copied out of NumPy before the GIL is released:
//! on `L`, `("elements", (m, 6))`, `("matrix", (data, indices, indptr))` or
//! `("quadratic", (n, k))`; on `M`, `("diagonal", (n,))`, `("matrix", ...)` or
//! `("quadratic", (n, k))`.

use crate::convert::{CsrArg, Input};
use crate::errors::{compute, option_error, shape_error};
use crate::options::{Kind, MassArg, OptionsArg};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString, PyTuple};
use pyo3::Borrowed;
use tetlap::{Columns, Cotangents, LaplacianCotangent, MassCotangent};

/// One cotangent as the Python layer hands it over.
pub enum Cotangent {
    Elements(Vec<[f64; 6]>),
    Matrix(CsrArg),
    Quadratic(Vec<f64>, usize),
    Diagonal(Vec<f64>),
}

impl<'a, 'py> FromPyObject<'a, 'py> for Cotangent {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let bad = || option_error(py, "internal: a cotangent is a (form, arrays) pair".into());
        let (form, payload): (Bound<'py, PyString>, Bound<'py, PyAny>) = obj.extract().map_err(|_| bad())?;
        let internal = |what: &str| shape_error(py, format!("internal: {what} must be a float64 array"));
        Ok(match form.to_str()? {
            "elements" | "quadratic" => {
                let a: PyReadonlyArray2<'_, f64> = payload.extract().map_err(|_| internal("a 2-d cotangent"))?;
                let (values, k) = (a.as_array().iter().copied().collect::<Vec<f64>>(), a.shape()[1]);
                if form.to_str()? == "quadratic" {
                    Cotangent::Quadratic(values, k)
                } else if k == 6 {
                    Cotangent::Elements(values.chunks_exact(6).map(|c| c.try_into().expect("6 values")).collect())
                } else {
                    return Err(shape_error(py, format!("a per-tet cotangent has 6 columns, got {k}")));
                }
            }
            "diagonal" => {
                let a: PyReadonlyArray1<'_, f64> = payload.extract().map_err(|_| internal("a diagonal cotangent"))?;
                Cotangent::Diagonal(a.as_array().to_vec())
            }
            "matrix" => Cotangent::Matrix(payload.extract()?),
            _ => return Err(bad()),
        })
    }
}

/// The cotangents of one product, as the Python layer hands them over: a dict with any of
/// `"laplacian"` and `"mass"`, each an operator's `(kind, cotangent)` pair; a `None`
/// cotangent (or a missing key) is no term, and a cotangent needs its operator's kind.
pub struct CotangentsArg {
    laplacian: Option<(tetlap::LaplacianKind, Cotangent)>,
    mass: Option<(tetlap::MassKind, Cotangent)>,
}

/// The `(kind, cotangent)` pair of `dict[key]`, parsed (the kind even without a cotangent).
fn term<'py, K>(dict: &Bound<'py, PyDict>, key: &str) -> PyResult<(Option<K>, Option<Cotangent>)>
where
    K: for<'a> FromPyObject<'a, 'py, Error = PyErr>,
{
    match dict.get_item(key)? {
        Some(pair) => pair.extract(),
        None => Ok((None, None)),
    }
}

/// A kind with its cotangent, if there is one (a cotangent needs a kind).
fn paired<K>(py: Python<'_>, (kind, cotangent): (Option<K>, Option<Cotangent>), what: &str) -> PyResult<Option<(K, Cotangent)>> {
    match (kind, cotangent) {
        (Some(kind), Some(c)) => Ok(Some((kind, c))),
        (_, None) => Ok(None),
        (None, Some(_)) => Err(option_error(py, format!("a {what} cotangent needs the {what}'s kind"))),
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for CotangentsArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let dict = obj.cast::<PyDict>().map_err(|_| option_error(py, "internal: cotangents must be a dict".into()))?.to_owned();
        let laplacian = paired(py, term::<Kind>(&dict, "laplacian")?, "Laplacian")?;
        let mass = paired(py, term::<MassArg>(&dict, "mass")?, "mass")?;
        Ok(CotangentsArg { laplacian: laplacian.map(|(k, c)| (k.0, c)), mass: mass.map(|(k, c)| (k.0, c)) })
    }
}

/// `(gradient (n, d), weight gradient (n,) or None, value)` of `<dl, L> + <dm, M>`, with
/// `cotangents = {"laplacian": (kind, dl), "mass": (kind, dm)}` (see [`CotangentsArg`]).
#[pyfunction]
#[pyo3(signature = (points, cells, cotangents, *, weights=None, options=None))]
pub fn vjp<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    cotangents: CotangentsArg,
    weights: Option<PyReadonlyArray1<'py, f64>>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, weights.as_ref(), &opts)?;
    let CotangentsArg { laplacian: lap, mass } = cotangents;
    let dim = input.dim;
    let g = compute(py, opts, move |opts| {
        let mesh = input.tets("a derivative")?;
        let n = mesh.n_vertices();
        let form = |what: &str| tetlap::Error::Shape { what: format!("a {what} cotangent cannot take this form") };
        let laplacian = match &lap {
            None => None,
            Some((kind, c)) => Some((*kind, match c {
                Cotangent::Elements(e) => LaplacianCotangent::Elements(e),
                Cotangent::Matrix(s) => LaplacianCotangent::Matrix(s.view(n)),
                Cotangent::Quadratic(v, k) => LaplacianCotangent::Dirichlet(Columns::new(v, *k)),
                Cotangent::Diagonal(_) => return Err(form("Laplacian")),
            })),
        };
        let mass = match &mass {
            None => None,
            Some((kind, c)) => Some((*kind, match c {
                Cotangent::Diagonal(d) => MassCotangent::Diagonal(d),
                Cotangent::Matrix(s) => MassCotangent::Matrix(s.view(n)),
                Cotangent::Quadratic(v, k) => MassCotangent::Quadratic(Columns::new(v, *k)),
                Cotangent::Elements(_) => return Err(form("mass")),
            })),
        };
        tetlap::vjp(&mesh, &Cotangents { laplacian, mass }, opts)
    })?;
    let n = g.points.len() / dim;
    let points = PyArray1::from_vec(py, g.points).reshape([n, dim])?.into_any();
    let weights = match g.weights {
        Some(w) => PyArray1::from_vec(py, w).into_any(),
        None => py.None().into_bound(py),
    };
    PyTuple::new(py, [points, weights, g.value.into_pyobject(py)?.into_any()])
}
