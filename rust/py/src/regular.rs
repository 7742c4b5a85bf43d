//! `tetlap._core.regular_conditions`, `regular_search` and `regular_masses`: the per-face
//! and per-tet work of `tetlap.regular` (`tetlap::analysis::regular`).
//!
//! The face conditions go to Python as arrays and come back as `rows = (vertices (c, 5)
//! int64, g0 (c,), coefficients (c, 5))`, with `targets = (floor (c,), aim (c,), lo (n,),
//! hi (n,))`; a budget is `(iterations, seconds or None)`, an optional wall-clock limit.

use crate::convert::{contiguous, table, Input};
use crate::errors::{compute, shape_error};
use crate::options::OptionsArg;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use pyo3::Borrowed;
use std::time::{Duration, Instant};
use tetlap::analysis::regular::{self, Budget, MassTargets, Rows, Stop, Targets};
use tetlap::Tet;

/// Rows `(vertices (c, 5) int64, g0 (c,), coefficients (c, 5))`, copied.
pub struct RowsArg {
    vertices: Vec<[u32; 5]>,
    g0: Vec<f64>,
    coefficients: Vec<[f64; 5]>,
}

impl RowsArg {
    fn rows(&self) -> Rows<'_> {
        Rows { vertices: &self.vertices, g0: &self.g0, coefficients: &self.coefficients }
    }
}

/// `(c, 5)` rows of a 2-d array.
fn fives<T: numpy::Element + Copy, U>(py: Python<'_>, a: &PyReadonlyArray2<'_, T>, what: &str, f: impl Fn(T) -> U) -> PyResult<Vec<[U; 5]>> {
    if a.shape()[1] != 5 {
        return Err(shape_error(py, format!("internal: {what} must have 5 columns")));
    }
    Ok(contiguous(py, a)?.chunks_exact(5).map(|r| std::array::from_fn(|k| f(r[k]))).collect())
}

impl<'a, 'py> FromPyObject<'a, 'py> for RowsArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let (vertices, g0, coefficients): (PyReadonlyArray2<'_, i64>, PyReadonlyArray1<'_, f64>, PyReadonlyArray2<'_, f64>) =
            obj.extract().map_err(|_| shape_error(py, "internal: rows are (vertices, g0, coefficients)".into()))?;
        Ok(RowsArg {
            // out-of-range variables become values no problem has; the core names the row
            vertices: fives(py, &vertices, "vertices", |j| u32::try_from(j).unwrap_or(u32::MAX))?,
            g0: contiguous(py, &g0)?.to_vec(),
            coefficients: fives(py, &coefficients, "coefficients", |a| a)?,
        })
    }
}

/// Targets `(floor (c,), aim (c,), lo (n,), hi (n,))`, copied.
pub struct TargetsArg([Vec<f64>; 4]);

impl TargetsArg {
    fn targets(&self) -> Targets<'_> {
        let [floor, aim, lo, hi] = &self.0;
        Targets { floor, aim, lo, hi }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for TargetsArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let arrays: [PyReadonlyArray1<'_, f64>; 4] =
            obj.extract().map_err(|_| shape_error(py, "internal: targets are (floor, aim, lo, hi)".into()))?;
        let mut out: [Vec<f64>; 4] = Default::default();
        for (slot, a) in out.iter_mut().zip(&arrays) {
            *slot = contiguous(py, a)?.to_vec();
        }
        Ok(TargetsArg(out))
    }
}

/// A work budget `(iterations, seconds or None)`: iterations, and an optional wall-clock
/// limit that starts when the computation does.
pub struct BudgetArg {
    iterations: usize,
    seconds: Option<f64>,
}

impl BudgetArg {
    fn start(&self) -> Budget {
        let deadline = self.seconds.map(|s| Instant::now() + Duration::from_secs_f64(s.clamp(0.0, 1e9)));
        Budget { iterations: self.iterations, deadline }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for BudgetArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let (iterations, seconds) = obj.extract().map_err(|_: PyErr| {
            shape_error(obj.py(), "internal: a budget is (iterations >= 0, seconds or None)".into())
        })?;
        Ok(BudgetArg { iterations, seconds })
    }
}

/// The mass step's problem `(rows, targets, masses)`, `masses = (plain (n,), floor, scale
/// (n,))`, copied.
pub struct MassProblemArg {
    rows: RowsArg,
    targets: TargetsArg,
    plain: Vec<f64>,
    floor: f64,
    scale: Vec<f64>,
}

impl<'a, 'py> FromPyObject<'a, 'py> for MassProblemArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        type Masses<'p> = (PyReadonlyArray1<'p, f64>, f64, PyReadonlyArray1<'p, f64>);
        let (rows, targets, (plain, floor, scale)): (RowsArg, TargetsArg, Masses<'py>) = obj.extract()?;
        Ok(MassProblemArg { rows, targets, plain: contiguous(py, &plain)?.to_vec(), floor, scale: contiguous(py, &scale)?.to_vec() })
    }
}

fn stop_name(stop: Stop) -> &'static str {
    match stop {
        Stop::Done => "done",
        Stop::Stalled => "stalled",
        Stop::Iterations => "iterations",
        Stop::Deadline => "deadline",
    }
}

/// The conditions of a tet mesh in R^3 and its face table, as a dict: `interior` (f, 4),
/// `boundary` (b, 2), `nonmanifold` (k, 3) (-1 unused) int64 (see `faces`); `vertices`
/// (c, 5) int64, `g0` (c,), `coefficients` (c, 5), `face` (c,) int64; `folded` (f,) bool;
/// `flat` (k,) int64 (faces with an exactly flat tet), `beyond_range` (k,) int64 (faces with
/// a value beyond the float64 range).
#[pyfunction]
#[pyo3(signature = (points, cells, *, options=None))]
pub fn regular_conditions<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    let (faces, c) = compute(py, opts, move |opts| {
        let mesh = input.tets("regular weights")?;
        let faces = tetlap::faces::<Tet>(mesh.cells(), mesh.n_vertices(), opts)?;
        let c = regular::conditions(&mesh, &faces.interior, opts)?;
        Ok((faces, c))
    })?;
    let d = PyDict::new(py);
    d.set_item("interior", table(py, &faces.interior)?)?;
    d.set_item("boundary", table(py, &faces.boundary)?)?;
    let nonmanifold: Vec<[u32; 3]> = faces.nonmanifold;
    let flat: Vec<i64> = nonmanifold.iter().flat_map(|r| r.map(|v| if v == u32::MAX { -1 } else { v as i64 })).collect();
    d.set_item("nonmanifold", PyArray1::from_vec(py, flat).reshape([nonmanifold.len(), 3])?)?;
    d.set_item("vertices", table(py, &c.vertices)?)?;
    d.set_item("g0", PyArray1::from_vec(py, c.g0))?;
    let rows = c.coefficients.len();
    d.set_item("coefficients", PyArray1::from_vec(py, c.coefficients.concat()).reshape([rows, 5])?)?;
    d.set_item("face", PyArray1::from_iter(py, c.face.iter().map(|&f| f as i64)))?;
    d.set_item("folded", PyArray1::from_vec(py, c.folded))?;
    d.set_item("flat", PyArray1::from_iter(py, c.flat.iter().map(|&f| f as i64)))?;
    d.set_item("beyond_range", PyArray1::from_iter(py, c.beyond_range.iter().map(|&f| f as i64)))?;
    Ok(d)
}

/// The sign of every interior face view's lifted determinant for `weights` (n,) or None
/// ([`regular::lifted_signs`]): (2 f,) int8, the views from the first tets, then from the
/// second; 0 where float64 cannot tell.
#[pyfunction]
#[pyo3(signature = (points, cells, interior, weights=None, *, options=None))]
pub fn regular_signs<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    interior: PyReadonlyArray2<'py, i64>,
    weights: Option<PyReadonlyArray1<'py, f64>>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyArray1<i8>>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    if interior.shape()[1] != 4 {
        return Err(shape_error(py, "internal: the face table has 4 columns".into()));
    }
    let interior: Vec<[u32; 4]> =
        contiguous(py, &interior)?.chunks_exact(4).map(|r| std::array::from_fn(|k| u32::try_from(r[k]).unwrap_or(u32::MAX))).collect();
    let weights = weights.map(|w| contiguous(py, &w).map(<[f64]>::to_vec)).transpose()?;
    let signs = compute(py, opts, move |opts| {
        let mesh = input.tets("regular weights")?;
        regular::lifted_signs(&mesh, &interior, weights.as_deref(), opts)
    })?;
    Ok(PyArray1::from_vec(py, signs))
}

/// One search ([`regular::search`]) from `u` (n,) within `budget = (iterations, seconds or
/// None)`: `(u, stop, iterations, short_rows int64, short_y)`, `stop` one of "done",
/// "stalled", "iterations", "deadline".
#[pyfunction]
#[pyo3(signature = (rows, targets, u, budget, *, options=None))]
pub fn regular_search<'py>(
    py: Python<'py>,
    rows: RowsArg,
    targets: TargetsArg,
    u: PyReadonlyArray1<'py, f64>,
    budget: BudgetArg,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let mut u = contiguous(py, &u)?.to_vec();
    let (u, out) = compute(py, OptionsArg::options(options), move |opts| {
        let out = regular::search(rows.rows(), &targets.targets(), &mut u, &mut budget.start(), opts)?;
        Ok((u, out))
    })?;
    let (short, y): (Vec<i64>, Vec<f64>) = out.short.iter().map(|&(r, y)| (r as i64, y)).unzip();
    PyTuple::new(
        py,
        [
            PyArray1::from_vec(py, u).into_any(),
            stop_name(out.stop).into_pyobject(py)?.into_any(),
            out.iterations.into_pyobject(py)?.into_any(),
            PyArray1::from_vec(py, short).into_any(),
            PyArray1::from_vec(py, y).into_any(),
        ],
    )
}

/// The mass step ([`regular::keep_masses`]) from `u` (n,), with `problem = (rows, targets,
/// masses)` ([`MassProblemArg`]) and `budget = (iterations, seconds or None)`: `(u,
/// {"rounds", "iterations", "kept", "lost", "deficit"})`.
#[pyfunction]
#[pyo3(signature = (points, cells, problem, u, budget, *, options=None))]
pub fn regular_masses<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    problem: MassProblemArg,
    u: PyReadonlyArray1<'py, f64>,
    budget: BudgetArg,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    let mut u = contiguous(py, &u)?.to_vec();
    let (u, out) = compute(py, opts, move |opts| {
        let mesh = input.tets("regular weights")?;
        let p = &problem;
        let masses = MassTargets { plain: &p.plain, floor: p.floor, scale: &p.scale };
        let out = regular::keep_masses(&mesh, p.rows.rows(), &p.targets.targets(), &masses, &mut u, &mut budget.start(), opts)?;
        Ok((u, out))
    })?;
    let d = PyDict::new(py);
    d.set_item("rounds", out.rounds)?;
    d.set_item("iterations", out.iterations)?;
    d.set_item("kept", out.kept)?;
    d.set_item("lost", out.lost)?;
    d.set_item("deficit", out.deficit)?;
    PyTuple::new(py, [PyArray1::from_vec(py, u).into_any(), d.into_any()])
}
