//! Mesh diagnostics and operator checks of the core, for `tetlap.diagnostics` and
//! `tetlap.check`.

use crate::convert::{contiguous, table, CellsInput, CellsJob, CsrArg, Input, Job};
use crate::errors::{compute, shape_error};
use crate::options::OptionsArg;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use tetlap::{MeshView, Options, Semidefinite, Simplex};

/// A computation on the elements alone: `faces`, `duplicates`, `edges`.
macro_rules! cells_job {
    ($name:ident, $output:ty, |$cells:ident, $n:ident, $opts:ident| $body:expr) => {
        struct $name;
        impl CellsJob for $name {
            type Output = $output;
            fn run<S: Simplex>(self, $cells: &[S::Cell], $n: usize, $opts: &Options) -> tetlap::Result<$output> {
                $body
            }
        }
    };
}

cells_job!(FacesJob, tetlap::Faces, |cells, n, opts| tetlap::faces::<S>(cells, n, opts));
cells_job!(DuplicatesJob, Vec<bool>, |cells, n, opts| tetlap::duplicate_elements::<S>(cells, n, opts));
cells_job!(EdgesJob, Vec<[u32; 2]>, |cells, n, opts| tetlap::edges::<S>(cells, n, opts));

/// `(boundary (f, 2), interior (g, 4), nonmanifold (k, 3))` int64: boundary faces as
/// `[element, opposite corner]`, pairs of elements across interior faces as `[element,
/// corner, element, corner]`, non-manifold faces as sorted vertex triples (-1 unused).
#[pyfunction]
#[pyo3(signature = (cells, n, *, options=None))]
pub fn faces<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = CellsInput::new(py, &cells, n, &opts)?;
    let f = compute(py, opts, move |opts| input.run(FacesJob, opts))?;
    let nonmanifold: Vec<i64> = f.nonmanifold.iter().flat_map(|r| r.map(|v| if v == u32::MAX { -1 } else { v as i64 })).collect();
    let nonmanifold = PyArray1::from_vec(py, nonmanifold).reshape([f.nonmanifold.len(), 3])?.into_any();
    PyTuple::new(py, [table(py, &f.boundary)?, table(py, &f.interior)?, nonmanifold])
}

/// `(m,)` bool: the element repeats the vertex set of an element with a lower index.
#[pyfunction]
#[pyo3(signature = (cells, n, *, options=None))]
pub fn duplicates<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let opts = OptionsArg::options(options);
    let input = CellsInput::new(py, &cells, n, &opts)?;
    Ok(PyArray1::from_vec(py, compute(py, opts, move |opts| input.run(DuplicatesJob, opts))?))
}

/// `(E, 2)` int64: the unique edges `i < j`, sorted.
#[pyfunction]
#[pyo3(signature = (cells, n, *, options=None))]
pub fn edges<'py>(py: Python<'py>, cells: PyReadonlyArray2<'py, i64>, n: usize, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyAny>> {
    let opts = OptionsArg::options(options);
    let input = CellsInput::new(py, &cells, n, &opts)?;
    table(py, &compute(py, opts, move |opts| input.run(EdgesJob, opts))?)
}

/// The element certificate of [`tetlap::negative_semidefinite_by_elements`] for element
/// Laplacians given row-major, one row per element: its `S::EDGES.len()` edge weights, then
/// (when `diagonal`) its `S::CORNERS` diagonal entries, else minus the weights' sums.
struct ElementCertificateJob {
    rows: Vec<f64>,
    diagonal: bool,
    tol: Vec<f64>,
}

impl CellsJob for ElementCertificateJob {
    type Output = Semidefinite;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<Semidefinite> {
        let (e, k) = (S::EDGES.len(), S::CORNERS);
        let laplacians: Vec<(S::EdgeValues, S::CornerValues)> = self
            .rows
            .chunks_exact(if self.diagonal { e + k } else { e })
            .map(|row| {
                let mut w = S::EdgeValues::default();
                w.as_mut().copy_from_slice(&row[..e]);
                let d = if self.diagonal {
                    let mut d = S::CornerValues::default();
                    d.as_mut().copy_from_slice(&row[e..]);
                    d
                } else {
                    tetlap::element::corner_sums::<S>(&w)
                };
                (w, d)
            })
            .collect();
        tetlap::negative_semidefinite_by_elements::<S>(cells, n, &laplacians, &self.tol, opts)
    }
}

/// `(verdict, name, details)` of the element certificate: `-L = sum_t K_t` with the
/// element Laplacians `weights`: (m, 6) edge weights for tets or (m, 3) for triangles,
/// local edge order lexicographic (the diagonal minus their sums), or (m, 10) / (m, 6)
/// with the element's diagonal entries after them; up to the per-vertex tolerances `tol`
/// (n,). `verdict` is True ("element certificate", details `groups`, `largest`) or None
/// ("undetermined", details `uncovered`).
#[pyfunction]
#[pyo3(signature = (cells, n, weights, tol, *, options=None))]
pub fn element_certificate<'py>(
    py: Python<'py>,
    cells: PyReadonlyArray2<'py, i64>,
    n: usize,
    weights: PyReadonlyArray2<'py, f64>,
    tol: PyReadonlyArray1<'py, f64>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = CellsInput::new(py, &cells, n, &opts)?;
    let (edges, corners) = if cells.shape()[1] == 4 { (6, 4) } else { (3, 3) };
    let m = input.cells.len();
    if weights.shape() != [m, edges] && weights.shape() != [m, edges + corners] {
        let shapes = format!("({m}, {edges}) or ({m}, {})", edges + corners);
        return Err(shape_error(py, format!("weights must have shape {shapes}, got {:?}", weights.shape())));
    }
    let diagonal = weights.shape()[1] == edges + corners;
    let job = ElementCertificateJob { rows: contiguous(py, &weights)?.to_vec(), diagonal, tol: contiguous(py, &tol)?.to_vec() };
    verdict(py, compute(py, opts, move |opts| input.run(job, opts))?)
}

/// `(volume (m,), dihedral (m, 6) degrees, well_centered (m,) bool, orientation (m,) int8)`
/// of a tet mesh (the orientation exact where the volume underflows).
#[pyfunction]
#[pyo3(signature = (points, cells, *, options=None))]
pub fn quality<'py>(py: Python<'py>, points: PyReadonlyArray2<'py, f64>, cells: PyReadonlyArray2<'py, i64>, options: Option<OptionsArg>) -> PyResult<Bound<'py, PyTuple>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    let q = compute(py, opts, move |opts| tetlap::quality(&input.tets("the quality report")?, opts))?;
    let volume: Vec<f64> = q.iter().map(|t| t.volume).collect();
    let dihedral: Vec<f64> = q.iter().flat_map(|t| t.dihedral).collect();
    let well: Vec<bool> = q.iter().map(|t| t.well_centered).collect();
    let orientation: Vec<i8> = q.iter().map(|t| t.orientation).collect();
    PyTuple::new(
        py,
        [
            PyArray1::from_vec(py, volume).into_any(),
            PyArray1::from_vec(py, dihedral).reshape([q.len(), 6])?.into_any(),
            PyArray1::from_vec(py, well).into_any(),
            PyArray1::from_vec(py, orientation).into_any(),
        ],
    )
}

/// `(f,)` bool: for every interior face `[t1, c1, t2, c2]`, the vertex of `t2` opposite
/// the face lies strictly inside the circumsphere of `t1` (R^3).
#[pyfunction]
#[pyo3(signature = (points, cells, interior, rtol, *, options=None))]
pub fn non_delaunay<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    interior: PyReadonlyArray2<'py, i64>,
    rtol: f64,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    if interior.shape()[1] != 4 {
        return Err(shape_error(py, "interior faces must have 4 columns".into()));
    }
    // out-of-range entries become values no mesh has; the core names the face
    let faces: Vec<[u32; 4]> =
        contiguous(py, &interior)?.chunks_exact(4).map(|f| std::array::from_fn(|k| u32::try_from(f[k]).unwrap_or(u32::MAX))).collect();
    let flags = compute(py, opts, move |opts| {
        tetlap::non_delaunay_faces(&input.tets("the Delaunay test")?, &faces, rtol, opts)
    })?;
    Ok(PyArray1::from_vec(py, flags))
}

/// [`tetlap::check_operator`] of one operator on a mesh.
struct CheckJob {
    l: CsrArg,
    boundary: Vec<bool>,
    negative_tol: f64,
}

impl Job for CheckJob {
    type Output = tetlap::OperatorCheck;
    fn run<S: Simplex>(self, mesh: &MeshView<S>, opts: &Options) -> tetlap::Result<tetlap::OperatorCheck> {
        tetlap::check_operator(self.l.view(mesh.n_vertices()), mesh, &self.boundary, self.negative_tol, opts)
    }
}

/// The Table-1 checks of an operator `l = (data, indices, indptr)` (sorted CSR) on a mesh,
/// as a dict (see `tetlap::OperatorCheck`).
#[pyfunction]
#[pyo3(signature = (points, cells, l, boundary, negative_tol, *, options=None))]
pub fn check_operator<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    cells: PyReadonlyArray2<'py, i64>,
    l: CsrArg,
    boundary: PyReadonlyArray1<'py, bool>,
    negative_tol: f64,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyDict>> {
    let opts = OptionsArg::options(options);
    let input = Input::new(py, &points, &cells, None, &opts)?;
    let job = CheckJob { l, boundary: contiguous(py, &boundary)?.to_vec(), negative_tol };
    let c = compute(py, opts, move |opts| input.run(job, opts))?;
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

/// Whether the symmetric `n x n` matrix `l = (data, indices, indptr)` (sorted CSR) is
/// negative semidefinite up to the per-vertex tolerances `tol` (n,): `(answer True | False
/// | None, certificate name, details dict)`.
#[pyfunction]
#[pyo3(signature = (n, l, tol, *, options=None))]
pub fn negative_semidefinite<'py>(
    py: Python<'py>,
    n: usize,
    l: CsrArg,
    tol: PyReadonlyArray1<'py, f64>,
    options: Option<OptionsArg>,
) -> PyResult<Bound<'py, PyTuple>> {
    let tol = contiguous(py, &tol)?.to_vec();
    let answer = compute(py, OptionsArg::options(options), move |opts| tetlap::negative_semidefinite(l.view(n), &tol, opts))?;
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
