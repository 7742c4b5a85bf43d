//! Mesh diagnostics and operator checks of the core for `tetlap.diagnostics` and
//! `tetlap.check`.

use crate::convert::{contiguous, CellsInput, CellsJob, Input};
use crate::errors::{guarded, shape_error};
use crate::options::Threads;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tetlap::{Cancel, Csr, Options, Semidefinite, Simplex};

fn options(threads: Threads) -> (Options, Cancel) {
    let cancel = Cancel::new();
    (Options { threads: threads.0, cancel: Some(cancel.clone()), ..Default::default() }, cancel)
}

/// A `(rows, W)` int64 array.
fn table<'py, const W: usize>(py: Python<'py>, rows: &[[u32; W]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = rows.iter().flat_map(|r| r.map(i64::from)).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([rows.len(), W])?.into_any())
}

struct FacesJob;

impl CellsJob for FacesJob {
    type Output = tetlap::Faces;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<tetlap::Faces> {
        tetlap::faces::<S>(cells, n, opts)
    }
}

struct DuplicatesJob;

impl CellsJob for DuplicatesJob {
    type Output = Vec<bool>;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<Vec<bool>> {
        tetlap::duplicate_elements::<S>(cells, n, opts)
    }
}

struct EdgesJob;

impl CellsJob for EdgesJob {
    type Output = Vec<[u32; 2]>;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<Vec<[u32; 2]>> {
        tetlap::edges::<S>(cells, n, opts)
    }
}

/// `(boundary (f, 2), interior (g, 4), nonmanifold (k, 3))` int64: boundary faces as
/// `[element, opposite corner]`, pairs of elements across interior faces as `[element,
/// corner, element, corner]`, non-manifold faces as sorted vertex triples (-1 unused).
#[pyfunction]
#[pyo3(signature = (cells, n, *, threads=Default::default()))]
pub fn faces<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, threads: Threads) -> PyResult<Bound<'py, PyTuple>> {
    let input = CellsInput::new(py, &cells, n)?;
    let (opts, cancel) = options(threads);
    let f = guarded(py, &cancel, move || input.run(FacesJob, &opts))?;
    let nonmanifold: Vec<i64> = f.nonmanifold.iter().flat_map(|r| r.map(|v| if v == u32::MAX { -1 } else { v as i64 })).collect();
    let nonmanifold = PyArray1::from_vec(py, nonmanifold).reshape([f.nonmanifold.len(), 3])?.into_any();
    PyTuple::new(py, [table(py, &f.boundary)?, table(py, &f.interior)?, nonmanifold])
}

/// The element certificate of [`tetlap::negative_semidefinite_by_elements`] for edge
/// weights given row-major, one row of `S::EDGES.len()` per element.
struct ElementCertificateJob {
    weights: Vec<f64>,
    tol: f64,
}

impl CellsJob for ElementCertificateJob {
    type Output = Semidefinite;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<Semidefinite> {
        let weights: Vec<S::EdgeValues> = self
            .weights
            .chunks_exact(S::EDGES.len())
            .map(|row| {
                let mut w = S::EdgeValues::default();
                w.as_mut().copy_from_slice(row);
                w
            })
            .collect();
        tetlap::negative_semidefinite_by_elements::<S>(cells, n, &weights, self.tol, opts)
    }
}

/// `(verdict, name, details)` of the element certificate: `-L = sum_t K_t` with the
/// element edge weights `weights` (m, 6) for tets or (m, 3) for triangles, local edge order
/// lexicographic. `verdict` is True ("element certificate", details `groups`, `largest`)
/// or None ("undetermined", details `uncovered`).
#[pyfunction]
#[pyo3(signature = (cells, n, weights, tol, *, threads=Default::default()))]
pub fn element_certificate<'py>(
    py: Python<'py>,
    cells: PyReadonlyArray2<'py, i64>,
    n: usize,
    weights: PyReadonlyArray2<'py, f64>,
    tol: f64,
    threads: Threads,
) -> PyResult<Bound<'py, PyTuple>> {
    let input = CellsInput::new(py, &cells, n)?;
    let edges = if cells.shape()[1] == 4 { 6 } else { 3 };
    if weights.shape() != [cells.shape()[0], edges] {
        return Err(shape_error(py, format!("weights must have shape ({}, {edges}), got {:?}", cells.shape()[0], weights.shape())));
    }
    let job = ElementCertificateJob { weights: contiguous(py, &weights)?.to_vec(), tol };
    let (opts, cancel) = options(threads);
    let answer = guarded(py, &cancel, move || input.run(job, &opts))?;
    verdict(py, answer)
}

/// `(m,)` bool: the element repeats the vertex set of an element with a lower index.
#[pyfunction]
#[pyo3(signature = (cells, n, *, threads=Default::default()))]
pub fn duplicates<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, threads: Threads) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let input = CellsInput::new(py, &cells, n)?;
    let (opts, cancel) = options(threads);
    let d = guarded(py, &cancel, move || input.run(DuplicatesJob, &opts))?;
    Ok(PyArray1::from_vec(py, d))
}

/// `(E, 2)` int64: the unique edges `i < j`, sorted.
#[pyfunction]
#[pyo3(signature = (cells, n, *, threads=Default::default()))]
pub fn edges<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, threads: Threads) -> PyResult<Bound<'py, PyAny>> {
    let input = CellsInput::new(py, &cells, n)?;
    let (opts, cancel) = options(threads);
    let e = guarded(py, &cancel, move || input.run(EdgesJob, &opts))?;
    table(py, &e)
}

/// `(volume (m,), dihedral (m, 6) degrees, well_centered (m,) bool)` of a tet mesh.
#[pyfunction]
#[pyo3(signature = (points, cells, *, threads=Default::default()))]
pub fn quality<'py>(py: Python<'py>, points: PyReadonlyArray2<'py, f64>, cells: PyReadonlyArray2<'py, i64>, threads: Threads) -> PyResult<Bound<'py, PyTuple>> {
    let input = Input::new(py, &points, &cells, None)?;
    let (opts, cancel) = options(threads);
    let q = guarded(py, &cancel, move || tetlap::quality(&input.tets()?, &opts))?;
    let volume: Vec<f64> = q.iter().map(|t| t.volume).collect();
    let dihedral: Vec<f64> = q.iter().flat_map(|t| t.dihedral).collect();
    let well: Vec<bool> = q.iter().map(|t| t.well_centered).collect();
    PyTuple::new(
        py,
        [
            PyArray1::from_vec(py, volume).into_any(),
            PyArray1::from_vec(py, dihedral).reshape([q.len(), 6])?.into_any(),
            PyArray1::from_vec(py, well).into_any(),
        ],
    )
}

/// `(f,)` bool: for every interior face `[t1, c1, t2, c2]`, the vertex of `t2` opposite
/// the face lies strictly inside the circumsphere of `t1` (R^3).
#[pyfunction]
#[pyo3(signature = (points, cells, interior, rtol, *, threads=Default::default()))]
pub fn non_delaunay<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    interior: PyReadonlyArray2<'py, i64>,
    rtol: f64,
    threads: Threads,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let input = Input::new(py, &points, &cells, None)?;
    if input.dim != 3 {
        return Err(shape_error(py, format!("the Delaunay test needs points in R^3, got d = {}", input.dim)));
    }
    let m = match &input.cells {
        crate::convert::Cells::Tets(c) => c.len() as i64,
        crate::convert::Cells::Tris(_) => return Err(shape_error(py, "the Delaunay test needs tets".into())),
    };
    if interior.shape()[1] != 4 {
        return Err(shape_error(py, "interior faces must have 4 columns".into()));
    }
    let flat = contiguous(py, &interior)?;
    let bad = flat.chunks_exact(4).any(|f| !(0..m).contains(&f[0]) || !(0..m).contains(&f[2]) || !(0..4).contains(&f[1]) || !(0..4).contains(&f[3]));
    if bad {
        return Err(shape_error(py, "interior faces must hold [element, corner, element, corner] of this mesh".into()));
    }
    let faces: Vec<[u32; 4]> = flat.chunks_exact(4).map(|f| [f[0] as u32, f[1] as u32, f[2] as u32, f[3] as u32]).collect();
    let (opts, cancel) = options(threads);
    let flags = guarded(py, &cancel, move || tetlap::non_delaunay_faces(&input.tets()?, &faces, rtol, &opts))?;
    Ok(PyArray1::from_vec(py, flags))
}

/// A sorted, square CSR matrix of the core from SciPy's arrays (checked).
fn csr(py: Python<'_>, n: usize, data: &PyReadonlyArray1<'_, f64>, indices: &PyReadonlyArray1<'_, i64>, indptr: &PyReadonlyArray1<'_, i64>) -> PyResult<Csr> {
    let (data, indices, indptr) = (contiguous(py, data)?, contiguous(py, indices)?, contiguous(py, indptr)?);
    let ok = indptr.len() == n + 1
        && indptr[0] == 0
        && indptr.windows(2).all(|w| w[0] <= w[1])
        && indptr[n] as usize == data.len()
        && indices.len() == data.len()
        && indices.iter().all(|&j| (0..n as i64).contains(&j));
    if !ok {
        return Err(shape_error(py, format!("not a valid {n} x {n} CSR matrix")));
    }
    Ok(Csr {
        n,
        indptr: indptr.iter().map(|&p| p as usize).collect(),
        indices: indices.iter().map(|&j| j as u32).collect(),
        data: data.to_vec(),
    })
}

/// The Table-1 checks of an operator (sorted CSR `data, indices, indptr`) on a mesh, as a
/// dict (see `tetlap::OperatorCheck`).
#[pyfunction]
#[pyo3(signature = (points, cells, data, indices, indptr, boundary, negative_tol, *, threads=Default::default()))]
#[allow(clippy::too_many_arguments)]
pub fn check_operator<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    data: PyReadonlyArray1<'py, f64>,
    indices: PyReadonlyArray1<'py, i64>,
    indptr: PyReadonlyArray1<'py, i64>,
    boundary: PyReadonlyArray1<'py, bool>,
    negative_tol: f64,
    threads: Threads,
) -> PyResult<Bound<'py, PyDict>> {
    let input = Input::new(py, &points, &cells, None)?;
    let n = points.shape()[0];
    let l = csr(py, n, &data, &indices, &indptr)?;
    let boundary = contiguous(py, &boundary)?.to_vec();
    let (opts, cancel) = options(threads);
    let c = guarded(py, &cancel, move || input.run(CheckJob { l, boundary, negative_tol }, &opts))?;
    let d = PyDict::new(py);
    d.set_item("finite", c.finite)?;
    d.set_item("scale", c.scale)?;
    d.set_item("symmetry_error", c.symmetry_error)?;
    d.set_item("max_row_sum", c.max_row_sum)?;
    d.set_item("local", c.local)?;
    d.set_item("n_edges", c.n_edges)?;
    d.set_item("n_negative", c.n_negative)?;
    d.set_item("min_weight", c.min_weight)?;
    d.set_item("n_edges_inner", c.n_edges_inner)?;
    d.set_item("n_negative_inner", c.n_negative_inner)?;
    d.set_item("linear_precision", c.linear_precision)?;
    Ok(d)
}

struct CheckJob {
    l: Csr,
    boundary: Vec<bool>,
    negative_tol: f64,
}

impl crate::convert::Job for CheckJob {
    type Output = tetlap::OperatorCheck;
    fn run<S: Simplex>(self, mesh: &tetlap::MeshView<S>, opts: &Options) -> tetlap::Result<tetlap::OperatorCheck> {
        tetlap::check_operator(&self.l, mesh, &self.boundary, self.negative_tol, opts)
    }
}

/// Whether the symmetric `n x n` matrix `L` (sorted CSR) is negative semidefinite up to
/// `tol`: `(answer True | False | None, certificate name, details dict)`.
#[pyfunction]
#[pyo3(signature = (n, data, indices, indptr, tol, *, threads=Default::default()))]
pub fn negative_semidefinite<'py>(
    py: Python<'py>,
    n: usize,
    data: PyReadonlyArray1<'py, f64>,
    indices: PyReadonlyArray1<'py, i64>,
    indptr: PyReadonlyArray1<'py, i64>,
    tol: f64,
    threads: Threads,
) -> PyResult<Bound<'py, PyTuple>> {
    let l = csr(py, n, &data, &indices, &indptr)?;
    let (opts, cancel) = options(threads);
    let answer = guarded(py, &cancel, move || tetlap::negative_semidefinite(&l, tol, &opts))?;
    verdict(py, answer)
}

/// `(verdict, name, details)` of a [`Semidefinite`] answer: True, False or None, a short
/// name and a dict of the certificate's numbers.
fn verdict(py: Python<'_>, answer: Semidefinite) -> PyResult<Bound<'_, PyTuple>> {
    let details = PyDict::new(py);
    let (verdict, name): (Option<bool>, &str) = match answer {
        Semidefinite::NonNegativeWeights => (Some(true), "non-negative weights"),
        Semidefinite::LocalCertificate { groups, largest } => {
            details.set_item("groups", groups)?;
            details.set_item("largest", largest)?;
            (Some(true), "local certificate")
        }
        Semidefinite::ElementCertificate { groups, largest } => {
            details.set_item("groups", groups)?;
            details.set_item("largest", largest)?;
            (Some(true), "element certificate")
        }
        Semidefinite::Indefinite { rayleigh, support, vertex } => {
            details.set_item("rayleigh", rayleigh)?;
            details.set_item("support", support)?;
            details.set_item("vertex", vertex)?;
            (Some(false), "indefinite")
        }
        Semidefinite::Undetermined { uncovered, residual } => {
            details.set_item("uncovered", uncovered)?;
            details.set_item("residual", residual)?;
            (None, "undetermined")
        }
    };
    PyTuple::new(py, [verdict.into_pyobject(py)?.into_any(), name.into_pyobject(py)?.into_any(), details.into_any()])
}
