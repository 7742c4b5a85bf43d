//! Inputs copied out of NumPy (with the GIL) into the core's types, the one dispatch from
//! a `(m, 4)` or `(m, 3)` array to the generic core, and outputs moved into NumPy
//! without copying.

use crate::errors::{shape_error, to_py};
use crate::options::Request;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use pyo3::Borrowed;
use tetlap::{Coefficient, Coo, Csr, CsrRef, Mass, MeshView, Options, Simplex, Tet, Tri};

/// The elements of a mesh: tets or triangles.
pub enum Cells {
    Tets(Vec<[u32; 4]>),
    Tris(Vec<[u32; 3]>),
}

impl Cells {
    /// Copies `cells`, `(m, 4)` or `(m, 3)` int64, every index checked against `n` on the
    /// threads of `opts`: the one dispatch on the element kind.
    pub fn new(py: Python<'_>, cells: &PyReadonlyArray2<'_, i64>, n: usize, opts: &Options) -> PyResult<Self> {
        let flat = contiguous(py, cells)?;
        let k = cells.shape()[1];
        if k != 3 && k != 4 {
            return Err(shape_error(py, format!("elements must have 3 or 4 columns, got {k}")));
        }
        opts.install(|| {
            Ok(match k {
                4 => Cells::Tets(tetlap::cells_from_i64::<Tet>(flat, n)?),
                _ => Cells::Tris(tetlap::cells_from_i64::<Tri>(flat, n)?),
            })
        })
        .map_err(|e| to_py(py, e))
    }

    /// The number of elements.
    pub fn len(&self) -> usize {
        match self {
            Cells::Tets(c) => c.len(),
            Cells::Tris(c) => c.len(),
        }
    }
}

/// Something to compute on the elements alone (no coordinates), of any kind.
pub trait CellsJob: Send {
    type Output: Send;
    fn run<S: Simplex>(self, cells: &[S::Cell], n: usize, opts: &Options) -> tetlap::Result<Self::Output>;
}

/// Something to compute on a mesh of any element kind.
pub trait Job: Send {
    type Output: Send;
    fn run<S: Simplex>(self, mesh: &MeshView<S>, opts: &Options) -> tetlap::Result<Self::Output>;
}

/// Validated elements over `n` vertices, without coordinates.
pub struct CellsInput {
    pub cells: Cells,
    pub n: usize,
}

impl CellsInput {
    pub fn new(py: Python<'_>, cells: &PyReadonlyArray2<'_, i64>, n: usize, opts: &Options) -> PyResult<Self> {
        Ok(CellsInput { cells: Cells::new(py, cells, n, opts)?, n })
    }

    /// Runs `job` on the elements, whatever their kind.
    pub fn run<J: CellsJob>(&self, job: J, opts: &Options) -> tetlap::Result<J::Output> {
        match &self.cells {
            Cells::Tets(c) => job.run::<Tet>(c, self.n, opts),
            Cells::Tris(c) => job.run::<Tri>(c, self.n, opts),
        }
    }
}

/// The data of a C-contiguous array (the Python layer guarantees it).
pub fn contiguous<'a, T: numpy::Element, D: numpy::ndarray::Dimension>(
    py: Python<'_>,
    a: &'a numpy::PyReadonlyArray<'_, T, D>,
) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| shape_error(py, "internal: arrays must be C-contiguous".into()))
}

/// A coefficient as the Python layer hands it over: a C-contiguous float64 array, `(m,)`
/// scalars, `(m, d, d)` tensors or one `(d, d)` tensor (its values checked by the core).
#[derive(Clone)]
pub enum CoefficientArg {
    Scalar(Vec<f64>),
    Tensor(Vec<f64>),
    Constant(Vec<f64>),
}

impl CoefficientArg {
    /// A copy of `array`, its form read from its number of dimensions.
    pub fn new(py: Python<'_>, array: &PyReadonlyArrayDyn<'_, f64>) -> PyResult<Self> {
        let values = contiguous(py, array)?.to_vec();
        match array.ndim() {
            1 => Ok(CoefficientArg::Scalar(values)),
            3 => Ok(CoefficientArg::Tensor(values)),
            2 => Ok(CoefficientArg::Constant(values)),
            k => Err(shape_error(py, format!("internal: a coefficient has 1, 2 or 3 dimensions, got {k}"))),
        }
    }

    /// The core's view.
    pub fn view(&self) -> Coefficient<'_> {
        match self {
            CoefficientArg::Scalar(v) => Coefficient::Scalar(v),
            CoefficientArg::Tensor(v) => Coefficient::Tensor(v),
            CoefficientArg::Constant(v) => Coefficient::Constant(v),
        }
    }
}

/// The medium of a call, `(coefficient, density)`, either `None`: the Laplacians'
/// coefficient (see [`CoefficientArg`]) and the masses' `(m,)` density, copied (checked by
/// the core with the mesh).
#[derive(Clone, Default)]
pub struct MediumArg {
    pub coefficient: Option<CoefficientArg>,
    pub density: Option<Vec<f64>>,
}

impl<'a, 'py> FromPyObject<'a, 'py> for MediumArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let (coefficient, density): (Option<PyReadonlyArrayDyn<'_, f64>>, Option<PyReadonlyArray1<'_, f64>>) =
            obj.extract().map_err(|_| shape_error(py, "internal: a medium is (coefficient, density)".into()))?;
        let coefficient = coefficient.as_ref().map(|c| CoefficientArg::new(py, c)).transpose()?;
        let density = density.as_ref().map(|d| contiguous(py, d).map(<[f64]>::to_vec)).transpose()?;
        Ok(MediumArg { coefficient, density })
    }
}

/// Owned copies of the points, the validated elements, the optional vertex weights, and
/// the optional medium (set by [`Input::with`]).
pub struct Input {
    pub points: Vec<f64>,
    pub dim: usize,
    pub cells: Cells,
    pub weights: Option<Vec<f64>>,
    pub medium: MediumArg,
}

impl Input {
    /// Copies `points` (n, d) float64, `cells` (m, 4) or (m, 3) int64 (indices checked on
    /// the threads of `opts`) and `weights` (n,) float64.
    pub fn new(
        py: Python<'_>,
        points: &PyReadonlyArray2<'_, f64>,
        cells: &PyReadonlyArray2<'_, i64>,
        weights: Option<&PyReadonlyArray1<'_, f64>>,
        opts: &Options,
    ) -> PyResult<Self> {
        let [n, dim] = [points.shape()[0], points.shape()[1]];
        let cells = Cells::new(py, cells, n, opts)?;
        let points = contiguous(py, points)?.to_vec();
        let weights = weights.map(|w| contiguous(py, w).map(<[f64]>::to_vec)).transpose()?;
        Ok(Input { points, dim, cells, weights, medium: MediumArg::default() })
    }

    /// The same input with a medium (a coefficient and a density; checked by the core
    /// with the mesh).
    pub fn with(mut self, medium: Option<MediumArg>) -> Self {
        self.medium = medium.unwrap_or_default();
        self
    }

    /// The validated mesh of `cells` (this input's), with its vertex weights, coefficient
    /// and density.
    pub fn mesh<'a, S: Simplex>(&'a self, cells: &'a [S::Cell]) -> tetlap::Result<MeshView<'a, S>> {
        let mut mesh = MeshView::new(&self.points, self.dim, cells)?;
        if let Some(w) = &self.weights {
            mesh = mesh.with_vertex_weights(w)?;
        }
        if let Some(c) = &self.medium.coefficient {
            mesh = mesh.with_coefficient(c.view())?;
        }
        if let Some(d) = &self.medium.density {
            mesh = mesh.with_density(d)?;
        }
        Ok(mesh)
    }

    /// The validated tet mesh, or the error for a triangle mesh (what only tets support).
    pub fn tets(&self, what: &str) -> tetlap::Result<MeshView<'_, Tet>> {
        match &self.cells {
            Cells::Tets(c) => self.mesh::<Tet>(c),
            Cells::Tris(_) => Err(tetlap::Error::Shape { what: format!("{what} needs a tet mesh, (m, 4) elements") }),
        }
    }

    /// Runs `job` on the validated mesh, whatever its element kind.
    pub fn run<J: Job>(&self, job: J, opts: &Options) -> tetlap::Result<J::Output> {
        match &self.cells {
            Cells::Tets(c) => job.run(&self.mesh::<Tet>(c)?, opts),
            Cells::Tris(c) => job.run(&self.mesh::<Tri>(c)?, opts),
        }
    }
}

/// A sparse matrix from Python, `(data float64, indices int64, indptr int64)` as SciPy
/// holds them, copied; its shape is checked by the core ([`CsrRef::check_shape`]).
pub struct CsrArg {
    pub indptr: Vec<usize>,
    pub indices: Vec<u32>,
    pub data: Vec<f64>,
}

impl CsrArg {
    /// The matrix as an `n x n` CSR view.
    pub fn view(&self, n: usize) -> CsrRef<'_> {
        CsrRef { n, indptr: &self.indptr, indices: &self.indices, data: &self.data }
    }
}

impl<'a, 'py> FromPyObject<'a, 'py> for CsrArg {
    type Error = PyErr;

    fn extract(obj: Borrowed<'a, 'py, PyAny>) -> PyResult<Self> {
        let py = obj.py();
        let (data, indices, indptr): (PyReadonlyArray1<'_, f64>, PyReadonlyArray1<'_, i64>, PyReadonlyArray1<'_, i64>) =
            obj.extract().map_err(|_| shape_error(py, "internal: a sparse matrix is (data, indices, indptr)".into()))?;
        // negative entries become values no valid matrix has; the core names them
        let indptr = indptr.as_array().iter().map(|&p| usize::try_from(p).unwrap_or(usize::MAX)).collect();
        let indices = indices.as_array().iter().map(|&j| u32::try_from(j).unwrap_or(u32::MAX)).collect();
        Ok(CsrArg { indptr, indices, data: data.as_array().to_vec() })
    }
}

/// What a [`Request`] gives.
pub enum Response {
    Matrix(Csr),
    Mass(Mass),
    Operators(Csr, Mass),
    /// The operators and the elements skipped: `(element, 0)` flat, `(element, 1)` values
    /// beyond the range.
    OperatorsSkipping(Csr, Mass, Vec<[i64; 2]>),
    /// Per-element values, row-major, and the row width.
    PerElement(Vec<f64>, usize),
    Triplets(Coo),
    Edges(Vec<[u32; 2]>, Vec<f64>),
}

impl Job for Request {
    type Output = Response;

    fn run<S: Simplex>(self, mesh: &MeshView<S>, opts: &Options) -> tetlap::Result<Response> {
        Ok(match self {
            Request::Laplacian(kind) => Response::Matrix(tetlap::laplacian(mesh, kind, opts)?),
            Request::Mass(kind) => Response::Mass(tetlap::mass(mesh, kind, opts)?),
            Request::Operators(lap, mass) => {
                let (l, m) = tetlap::operators(mesh, lap, mass, opts)?;
                Response::Operators(l, m)
            }
            Request::OperatorsSkipping(lap, mass) => {
                let (l, m, skipped) = tetlap::operators_skipping(mesh, lap, mass, opts)?;
                let code = |s: tetlap::Skipped| if s == tetlap::Skipped::Degenerate { 0 } else { 1 };
                Response::OperatorsSkipping(l, m, skipped.into_iter().map(|(t, s)| [t as i64, code(s)]).collect())
            }
            Request::Contributions(kind) => {
                let w = tetlap::contributions(mesh, kind, opts)?;
                Response::PerElement(w.iter().flat_map(|v| v.as_ref().iter().copied()).collect(), S::EDGES.len())
            }
            Request::ElementLaplacians(kind) => {
                let l = tetlap::element_laplacians(mesh, kind, opts)?;
                let rows = l.iter().flat_map(|(w, d)| w.as_ref().iter().chain(d.as_ref()).copied()).collect();
                Response::PerElement(rows, S::EDGES.len() + S::CORNERS)
            }
            Request::Triplets(kind) => Response::Triplets(tetlap::triplets(mesh, kind, opts)?),
            Request::EdgeWeights(kind) => {
                let (edges, w) = tetlap::edge_weights(mesh, kind, opts)?;
                Response::Edges(edges, w)
            }
        })
    }
}

impl Response {
    /// The Python value: CSR triples `(data, indices, indptr)`, masses as
    /// `("lumped", diagonal)` or `("csr", triple)`, `(m, k)` arrays, COO triples or
    /// `(edges, weights)`.
    pub fn into_py(self, py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
        Ok(match self {
            Response::Matrix(l) => csr_arrays(py, l)?.into_any(),
            Response::Mass(m) => mass_arrays(py, m)?.into_any(),
            Response::Operators(l, m) => {
                PyTuple::new(py, [csr_arrays(py, l)?.into_any(), mass_arrays(py, m)?.into_any()])?.into_any()
            }
            Response::OperatorsSkipping(l, m, skipped) => {
                let k = skipped.len();
                let skipped = PyArray1::from_iter(py, skipped.into_iter().flatten()).reshape([k, 2])?.into_any();
                PyTuple::new(py, [csr_arrays(py, l)?.into_any(), mass_arrays(py, m)?.into_any(), skipped])?.into_any()
            }
            Response::PerElement(values, width) => {
                let m = values.len() / width;
                PyArray1::from_vec(py, values).reshape([m, width])?.into_any()
            }
            Response::Triplets(coo) => {
                let as_i64 = |v: Vec<u32>| PyArray1::from_iter(py, v.into_iter().map(i64::from)).into_any();
                let vals = PyArray1::from_vec(py, coo.vals).into_any();
                PyTuple::new(py, [as_i64(coo.rows), as_i64(coo.cols), vals])?.into_any()
            }
            Response::Edges(edges, w) => {
                PyTuple::new(py, [table(py, &edges)?, PyArray1::from_vec(py, w).into_any()])?.into_any()
            }
        })
    }
}

/// A `(rows, W)` int64 array.
pub fn table<'py, const W: usize>(py: Python<'py>, rows: &[[u32; W]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<i64> = rows.iter().flat_map(|r| r.map(i64::from)).collect();
    Ok(PyArray1::from_vec(py, flat).reshape([rows.len(), W])?.into_any())
}

/// Row starts as int32 when every offset fits, int64 otherwise.
pub fn indptr_array<'py>(py: Python<'py>, indptr: &[usize]) -> Bound<'py, PyAny> {
    if indptr.last().is_none_or(|&nnz| nnz <= i32::MAX as usize) {
        PyArray1::from_iter(py, indptr.iter().map(|&p| p as i32)).into_any()
    } else {
        PyArray1::from_iter(py, indptr.iter().map(|&p| p as i64)).into_any()
    }
}

/// `(data float64, indices uint32, indptr int32|int64)`, data and indices moved without a
/// copy (the Python side views the uint32 indices, all `< 2^31`, as int32).
pub fn csr_arrays(py: Python<'_>, m: Csr) -> PyResult<Bound<'_, PyTuple>> {
    let indptr = indptr_array(py, &m.indptr);
    PyTuple::new(py, [PyArray1::from_vec(py, m.data).into_any(), PyArray1::from_vec(py, m.indices).into_any(), indptr])
}

/// `("lumped", diagonal)` or `("csr", (data, indices, indptr))`.
fn mass_arrays(py: Python<'_>, m: Mass) -> PyResult<Bound<'_, PyTuple>> {
    match m {
        Mass::Lumped(d) => PyTuple::new(py, ["lumped".into_pyobject(py)?.into_any(), PyArray1::from_vec(py, d).into_any()]),
        Mass::Consistent(c) => PyTuple::new(py, ["csr".into_pyobject(py)?.into_any(), csr_arrays(py, c)?.into_any()]),
    }
}
