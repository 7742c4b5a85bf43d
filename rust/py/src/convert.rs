//! Inputs copied out of NumPy (with the GIL), outputs moved into NumPy without copying.

use crate::errors::to_py;
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use tetlap::{Boundary, Coo, Csr, Degenerate, LaplacianKind, Mass, MassKind, Options, TetMesh, TriMesh};

/// The elements of a mesh: tets or triangles.
pub enum Cells {
    Tets(Vec<[u32; 4]>),
    Tris(Vec<[u32; 3]>),
}

/// Owned copies of the points, the validated `u32` elements and the optional weights.
pub struct Input {
    pub points: Vec<f64>,
    pub dim: usize,
    pub cells: Cells,
    pub weights: Option<Vec<f64>>,
}

impl Input {
    pub fn new(
        py: Python<'_>,
        points: &PyReadonlyArray2<'_, f64>,
        cells: &PyReadonlyArray2<'_, i64>,
        weights: Option<&PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<Self> {
        let [n, dim] = [points.shape()[0], points.shape()[1]];
        // The Python layer hands over C-contiguous arrays: plain slice copies.
        let points = contiguous(points)?.to_vec();
        let flat = contiguous(cells)?;
        let cells = match cells.shape()[1] {
            4 => Cells::Tets(tetlap::elements_from_i64::<4>(flat, n).map_err(|e| to_py(py, e))?),
            3 => Cells::Tris(tetlap::elements_from_i64::<3>(flat, n).map_err(|e| to_py(py, e))?),
            k => return Err(PyValueError::new_err(format!("elements must have 3 or 4 columns, got {k}"))),
        };
        let weights = weights.map(|w| w.as_slice().map(|w| w.to_vec())).transpose().map_err(|_| {
            PyValueError::new_err("weights must be C-contiguous")
        })?;
        Ok(Input { points, dim, cells, weights })
    }

    /// The tets, or an error for a triangle mesh (what only tets support).
    pub fn tets(self) -> PyResult<(Vec<f64>, usize, Vec<[u32; 4]>, Option<Vec<f64>>)> {
        match self.cells {
            Cells::Tets(t) => Ok((self.points, self.dim, t, self.weights)),
            Cells::Tris(_) => Err(PyValueError::new_err("this needs a tet mesh, (m, 4) elements")),
        }
    }

    fn tet_mesh<'a>(&'a self, tets: &'a [[u32; 4]]) -> tetlap::Result<TetMesh<'a>> {
        let mesh = TetMesh::new(&self.points, self.dim, tets)?;
        match &self.weights {
            Some(w) => mesh.with_weights(w),
            None => Ok(mesh),
        }
    }

    fn tri_mesh<'a>(&'a self, tris: &'a [[u32; 3]]) -> tetlap::Result<TriMesh<'a>> {
        if self.weights.is_some() {
            return Err(tetlap::Error::InvalidOption {
                message: "vertex weights are supported for tet meshes only".into(),
            });
        }
        TriMesh::new(&self.points, self.dim, tris)
    }

    pub fn laplacian(&self, lap: LaplacianKind, opts: &Options) -> tetlap::Result<Csr> {
        match &self.cells {
            Cells::Tets(t) => tetlap::laplacian(&self.tet_mesh(t)?, lap, opts),
            Cells::Tris(t) => tetlap::tri_laplacian(&self.tri_mesh(t)?, lap, opts),
        }
    }

    pub fn mass(&self, kind: MassKind, opts: &Options) -> tetlap::Result<Mass> {
        match &self.cells {
            Cells::Tets(t) => tetlap::mass(&self.tet_mesh(t)?, kind, opts),
            Cells::Tris(t) => tetlap::tri_mass(&self.tri_mesh(t)?, kind, opts),
        }
    }

    pub fn operators(&self, lap: LaplacianKind, kind: MassKind, opts: &Options) -> tetlap::Result<(Csr, Mass)> {
        match &self.cells {
            Cells::Tets(t) => tetlap::operators(&self.tet_mesh(t)?, lap, kind, opts),
            Cells::Tris(t) => tetlap::tri_operators(&self.tri_mesh(t)?, lap, kind, opts),
        }
    }

    /// Per-element weights, flat, and the number of local edges (6 or 3).
    pub fn contributions(&self, lap: LaplacianKind, opts: &Options) -> tetlap::Result<(Vec<f64>, usize)> {
        Ok(match &self.cells {
            Cells::Tets(t) => (tetlap::tet_contributions(&self.tet_mesh(t)?, lap, opts)?.into_flattened(), 6),
            Cells::Tris(t) => (tetlap::tri_contributions(&self.tri_mesh(t)?, lap, opts)?.into_flattened(), 3),
        })
    }

    pub fn triplets(&self, lap: LaplacianKind, opts: &Options) -> tetlap::Result<Coo> {
        match &self.cells {
            Cells::Tets(t) => tetlap::triplets(&self.tet_mesh(t)?, lap, opts),
            Cells::Tris(t) => tetlap::tri_triplets(&self.tri_mesh(t)?, lap, opts),
        }
    }
}

/// The options tuple of the Python layer: `(threads, degenerate, boundary)`.
#[derive(FromPyObject)]
pub struct RawOptions(Option<usize>, String, String);

impl Default for RawOptions {
    fn default() -> Self {
        RawOptions(None, "raise".into(), "circumcentric".into())
    }
}

/// The data of a C-contiguous array (the Python layer guarantees it).
fn contiguous<'a, T: numpy::Element>(a: &'a PyReadonlyArray2<'_, T>) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| PyValueError::new_err("internal: arrays must be C-contiguous"))
}

/// Parsed operator kinds and options.
pub struct Spec {
    lap: Option<LaplacianKind>,
    mass: Option<MassKind>,
    pub opts: Options,
}

impl Spec {
    pub fn new(lap: Option<(&str, f64)>, mass: Option<&str>, raw: &RawOptions) -> PyResult<Self> {
        let RawOptions(threads, degenerate, boundary) = raw;
        let lap = lap
            .map(|(kind, t)| match kind {
                "primal" => Ok(LaplacianKind::Primal),
                "dual" => Ok(LaplacianKind::Dual),
                "affine" => Ok(LaplacianKind::Affine(t)),
                _ => Err(PyValueError::new_err(format!("unknown Laplacian kind {kind:?}"))),
            })
            .transpose()?;
        let mass = mass
            .map(|kind| match kind {
                "barycentric" => Ok(MassKind::Barycentric),
                "circumcentric" => Ok(MassKind::Circumcentric),
                "fem" => Ok(MassKind::Fem),
                _ => Err(PyValueError::new_err(format!("unknown mass kind {kind:?}"))),
            })
            .transpose()?;
        let degenerate = match degenerate.as_str() {
            "raise" => Degenerate::Raise,
            "skip" => Degenerate::Skip,
            _ => return Err(PyValueError::new_err(format!("unknown degenerate policy {degenerate:?}"))),
        };
        let boundary = match boundary.as_str() {
            "circumcentric" => Boundary::Circumcentric,
            "barycentric" => Boundary::Barycentric,
            _ => return Err(PyValueError::new_err(format!("unknown boundary treatment {boundary:?}"))),
        };
        Ok(Spec { lap, mass, opts: Options { threads: *threads, degenerate, boundary } })
    }

    pub fn lap(&self) -> LaplacianKind {
        self.lap.expect("a Laplacian kind was parsed")
    }

    pub fn mass(&self) -> MassKind {
        self.mass.expect("a mass kind was parsed")
    }
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
pub fn csr_arrays<'py>(py: Python<'py>, m: Csr) -> PyResult<Bound<'py, PyTuple>> {
    let indptr = indptr_array(py, &m.indptr);
    PyTuple::new(
        py,
        [
            PyArray1::from_vec(py, m.data).into_any(),
            PyArray1::from_vec(py, m.indices).into_any(),
            indptr,
        ],
    )
}

/// A `(rows, K)` array from fixed-size rows, moved without copying the values twice.
pub fn rows<'py, T: numpy::Element + Copy, const K: usize>(
    py: Python<'py>,
    v: Vec<[T; K]>,
) -> PyResult<Bound<'py, PyArray2<T>>> {
    let m = v.len();
    let flat: Vec<T> = v.into_iter().flatten().collect();
    PyArray1::from_vec(py, flat).reshape([m, K])
}
