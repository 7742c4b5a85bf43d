//! `tetlap._core.Mesh`: the cached-topology mesh of the core, for `tetlap.Mesh`.
//!
//! The mesh sits behind a read-write lock: any number of Python threads may read cached
//! operators at once; a computation (a first request, an update) takes the lock
//! exclusively, so an update concurrent with reads is serialised with them (each reader
//! sees the mesh before or after the update, never in between). Locks are only taken on
//! the worker thread, without the GIL, so they cannot deadlock with it.

use crate::convert::{contiguous, indptr_array, Cells, Input, MediumArg};
use crate::errors::{compute, guarded, shape_error};
use crate::options::{Kind, MassArg, OptionsArg};
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard};
use tetlap::{CachedMesh, Cancel, Change, Tet, Tri};

/// The cached mesh of either element kind.
enum AnyMesh {
    Tets(CachedMesh<Tet>),
    Tris(CachedMesh<Tri>),
}

/// `$body` with `$mesh` bound to the cached mesh, whatever its element kind.
macro_rules! with_mesh {
    ($any:expr, $mesh:ident => $body:expr) => {
        match $any {
            AnyMesh::Tets($mesh) => $body,
            AnyMesh::Tris($mesh) => $body,
        }
    };
}

/// A mesh with its topology computed once (see `tetlap.Mesh`).
#[pyclass(module = "tetlap._core", name = "Mesh", frozen)]
pub struct PyMesh {
    inner: RwLock<AnyMesh>,
    dim: usize,
}

impl PyMesh {
    fn read(&self) -> RwLockReadGuard<'_, AnyMesh> {
        self.inner.read().unwrap_or_else(|e| e.into_inner())
    }

    fn write(&self) -> RwLockWriteGuard<'_, AnyMesh> {
        self.inner.write().unwrap_or_else(|e| e.into_inner())
    }

    /// A cached value from the read lock, else computed under the write lock; with this
    /// call's cancel flag.
    fn values(
        &self,
        py: Python<'_>,
        cached: impl Fn(&AnyMesh) -> Option<Vec<f64>> + Send + Sync,
        compute: impl FnOnce(&mut AnyMesh) -> tetlap::Result<Vec<f64>> + Send,
    ) -> PyResult<Vec<f64>> {
        if let Some(values) = py.detach(|| cached(&self.read())) {
            return Ok(values);
        }
        let cancel = Cancel::new();
        guarded(py, &cancel, || {
            let mut mesh = self.write();
            if let Some(values) = cached(&mesh) {
                return Ok(values); // computed by another thread meanwhile
            }
            with_mesh!(&mut *mesh, m => m.set_cancel(Some(cancel.clone())));
            let result = compute(&mut mesh);
            with_mesh!(&mut *mesh, m => m.set_cancel(None));
            result
        })
    }
}

#[pymethods]
impl PyMesh {
    #[new]
    #[pyo3(signature = (points, cells, *, weights=None, medium=None, options=None))]
    fn new(
        py: Python<'_>,
        points: PyReadonlyArray2<'_, f64>,
        cells: PyReadonlyArray2<'_, i64>,
        weights: Option<PyReadonlyArray1<'_, f64>>,
        medium: Option<MediumArg>,
        options: Option<OptionsArg>,
    ) -> PyResult<Self> {
        let opts = OptionsArg::options(options);
        let Input { points, dim, cells, weights, medium } = Input::new(py, &points, &cells, weights.as_ref(), &opts)?.with(medium);
        let inner = compute(py, opts, move |opts| {
            let opts = opts.clone();
            let change = |m: &mut AnyMesh| -> tetlap::Result<()> {
                let change = Change {
                    coefficient: medium.coefficient.as_ref().map(|c| Some(c.view())),
                    density: medium.density.as_deref().map(Some),
                    ..Change::default()
                };
                with_mesh!(m, m => m.change(change)).map(drop)
            };
            let mut mesh = match cells {
                Cells::Tets(c) => AnyMesh::Tets(CachedMesh::with_vertex_weights(points, dim, c, weights, opts)?),
                Cells::Tris(c) => AnyMesh::Tris(CachedMesh::with_vertex_weights(points, dim, c, weights, opts)?),
            };
            change(&mut mesh)?;
            with_mesh!(&mut mesh, m => m.set_cancel(None));
            Ok(mesh)
        })?;
        Ok(PyMesh { inner: RwLock::new(inner), dim })
    }

    /// `(indices uint32, indptr int32|int64)` of the CSR pattern.
    fn pattern<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let (indices, indptr) = py.detach(|| {
            with_mesh!(&*self.read(), m => (m.topology().indices().to_vec(), m.topology().indptr().to_vec()))
        });
        PyTuple::new(py, [PyArray1::from_vec(py, indices).into_any(), indptr_array(py, &indptr)])
    }

    /// CSR data (a copy) of the Laplacian.
    fn laplacian<'py>(&self, py: Python<'py>, kind: Kind) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let kind = kind.0;
        let values = self.values(
            py,
            |mesh| with_mesh!(mesh, m => m.cached_laplacian_values(kind).map(<[f64]>::to_vec)),
            |mesh| with_mesh!(mesh, m => m.laplacian_values(kind).map(<[f64]>::to_vec)),
        )?;
        Ok(PyArray1::from_vec(py, values))
    }

    /// Values (a copy) of the mass: per vertex, or CSR data for "fem".
    fn mass<'py>(&self, py: Python<'py>, kind: MassArg) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let kind = kind.0;
        let values = self.values(
            py,
            |mesh| with_mesh!(mesh, m => m.cached_mass_values(kind).map(<[f64]>::to_vec)),
            |mesh| with_mesh!(mesh, m => m.mass_values(kind).map(<[f64]>::to_vec)),
        )?;
        Ok(PyArray1::from_vec(py, values))
    }

    /// Moves the vertices and sets a new medium (coefficient, density), each `None` kept,
    /// at once; returns `(moved_vertices, recomputed_elements, recomputed_rows)`.
    #[pyo3(signature = (points=None, *, medium=None))]
    fn update(
        &self,
        py: Python<'_>,
        points: Option<PyReadonlyArray2<'_, f64>>,
        medium: Option<MediumArg>,
    ) -> PyResult<(usize, usize, usize)> {
        if let Some(points) = &points {
            if points.shape()[1] != self.dim {
                let message = format!("the new points must have {} columns, got {}", self.dim, points.shape()[1]);
                return Err(shape_error(py, message));
            }
        }
        let new = points.as_ref().map(|p| contiguous(py, p).map(<[f64]>::to_vec)).transpose()?;
        let MediumArg { coefficient, density } = medium.unwrap_or_default();
        let cancel = Cancel::new();
        let u = guarded(py, &cancel, || {
            let mut mesh = self.write();
            let change = Change {
                points: new.as_deref(),
                coefficient: coefficient.as_ref().map(|c| Some(c.view())),
                density: density.as_deref().map(Some),
            };
            with_mesh!(&mut *mesh, m => {
                m.set_cancel(Some(cancel.clone()));
                let result = m.change(change);
                m.set_cancel(None);
                result
            })
        })?;
        Ok((u.moved_vertices, u.recomputed_elements, u.recomputed_rows))
    }

    /// The current coordinates (a copy), `(n, d)`.
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let points = py.detach(|| with_mesh!(&*self.read(), m => m.points()));
        let n = points.len() / self.dim;
        PyArray1::from_vec(py, points).reshape([n, self.dim])
    }

    /// The elements (a copy), `(m, 4)` or `(m, 3)` int64.
    fn cells<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let (flat, k): (Vec<i64>, usize) = py.detach(|| match &*self.read() {
            AnyMesh::Tets(m) => (m.cells().iter().flat_map(|c| c.map(i64::from)).collect(), 4),
            AnyMesh::Tris(m) => (m.cells().iter().flat_map(|c| c.map(i64::from)).collect(), 3),
        });
        let m = flat.len() / k;
        PyArray1::from_vec(py, flat).reshape([m, k])
    }
}
