//! The public one-shot API: a validated mesh in, CSR / triplets / per-element values out.
//! Every function serves tets and triangles alike (generic over [`Simplex`]).

use crate::assembly::scatter::assemble;
use crate::sparse::{Coo, Csr, Mass};
use crate::assembly::pass::{boundary_mask, Elements};
use crate::error::Result;
use crate::assembly::order::Layout;
use crate::mesh::MeshView;
use crate::options::{LaplacianKind, MassKind, Options};
use crate::assembly::pass::values;
use crate::element::Request;
use crate::element::Simplex;
use crate::assembly::pattern::row_starts;
use rayon::prelude::*;
use std::borrow::Cow;

/// One-shot assembly of `request`: the internal order of `mesh`, the corner incidence and
/// the pattern, then the values of the elements and the rows, stripe by stripe
/// ([`assemble`]).
fn one_shot<S: Simplex>(mesh: &MeshView<S>, opts: &Options, request: Request) -> Result<(Option<Csr>, Option<Mass>)> {
    let (mut layout, corners) = Layout::with_corners(mesh, opts)?;
    layout.internal_of = Vec::new(); // not needed any more
    let indptr = row_starts::<S>(&layout.cells, &corners, &layout.vertex_of, opts)?;
    let internal = layout.mesh();
    let boundary = boundary_mask(&internal, opts)?.map(Cow::Owned);
    let elements = Elements::internal(internal, &layout.element_of, boundary);
    assemble(&layout, &elements, &corners, indptr, request, opts)
}

/// The `n x n` Laplacian: `L[i,j] = w_ij` on edges, `L[i,i] = -sum_j w_ij`; rows sum to
/// zero, the primal is negative semidefinite. Sorted CSR with every mesh edge stored.
///
/// ```
/// use tetlap::{laplacian, LaplacianKind, Options, TetView};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// let l = laplacian(&mesh, LaplacianKind::Dual, &Options::default()).unwrap();
/// assert_eq!(l.get(0, 0), -0.75);
/// assert_eq!(l.get(0, 1), 0.25);
/// ```
pub fn laplacian<S: Simplex>(mesh: &MeshView<S>, kind: LaplacianKind, opts: &Options) -> Result<Csr> {
    let kind = kind.check()?;
    super::install::<S, _>(opts, || {
        let (l, _) = one_shot(mesh, opts, Request { laplacian: Some(kind), mass: None })?;
        Ok(l.expect("a Laplacian was asked for"))
    })
}

/// The mass matrix of `kind` (paper Eq. 3, 4/21, or the consistent P1 mass).
///
/// ```
/// use tetlap::{mass, Mass, MassKind, Options, TetView};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// let Mass::Lumped(m) = mass(&mesh, MassKind::Circumcentric, &Options::default()).unwrap()
/// else { unreachable!() };
/// assert!((m[0] - 1.0 / 8.0).abs() < 1e-15 && (m.iter().sum::<f64>() - 1.0 / 6.0).abs() < 1e-15);
/// ```
pub fn mass<S: Simplex>(mesh: &MeshView<S>, kind: MassKind, opts: &Options) -> Result<Mass> {
    super::install::<S, _>(opts, || {
        let (_, m) = one_shot(mesh, opts, Request { laplacian: None, mass: Some(kind) })?;
        Ok(m.expect("a mass was asked for"))
    })
}

/// Laplacian and mass matrix from one per-element pass and one row layout.
///
/// ```
/// use tetlap::{operators, LaplacianKind, Mass, MassKind, Options, TriView};
/// // the unit square as two triangles
/// let points = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
/// let mesh = TriView::new(&points, 2, &[[0, 1, 2], [0, 2, 3]])?;
/// let (l, m) = operators(&mesh, LaplacianKind::Primal, MassKind::Barycentric, &Options::default())?;
/// assert!((l.get(0, 1) - 0.5).abs() < 1e-15 && l.get(0, 2).abs() < 1e-15);
/// let Mass::Lumped(m) = m else { unreachable!() };
/// assert!((m.iter().sum::<f64>() - 1.0).abs() < 1e-15);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn operators<S: Simplex>(
    mesh: &MeshView<S>,
    lap: LaplacianKind,
    mass: MassKind,
    opts: &Options,
) -> Result<(Csr, Mass)> {
    let lap = lap.check()?;
    super::install::<S, _>(opts, || {
        let (l, m) = one_shot(mesh, opts, Request { laplacian: Some(lap), mass: Some(mass) })?;
        Ok((l.expect("a Laplacian was asked for"), m.expect("a mass was asked for")))
    })
}

/// Per-element edge weights in the local edge order [`Simplex::EDGES`] (for tets
/// `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`).
pub fn contributions<S: Simplex>(
    mesh: &MeshView<S>,
    kind: LaplacianKind,
    opts: &Options,
) -> Result<Vec<S::EdgeValues>> {
    let kind = kind.check()?;
    super::install::<S, _>(opts, || {
        let mut w = vec![S::EdgeValues::default(); mesh.n_elements()];
        let request = Request { laplacian: Some(kind), mass: None };
        values(&Elements::new(*mesh, opts)?, opts, request, Some(&mut w), None).map(|_| w)
    })
}

/// Unsummed triplets of the Laplacian: `K^2` per element (its local `K x K` Laplacian,
/// element by element, row-major). Summing repeated positions gives [`laplacian`] up to
/// rounding.
pub fn triplets<S: Simplex>(mesh: &MeshView<S>, kind: LaplacianKind, opts: &Options) -> Result<Coo> {
    let w = contributions(mesh, kind, opts)?;
    let (k, m) = (S::CORNERS, mesh.n_elements());
    let kk = k * k;
    let (mut rows, mut cols, mut vals) = (vec![0u32; kk * m], vec![0u32; kk * m], vec![0.0; kk * m]);
    super::install::<S, _>(opts, || {
        rows.par_chunks_mut(kk)
            .zip(cols.par_chunks_mut(kk))
            .zip(vals.par_chunks_mut(kk))
            .zip(mesh.cells().par_iter().zip(&w))
            .for_each(|(((r, c), v), (cell, w))| {
                let cell = cell.as_ref();
                let mut diag = [0.0; 4];
                for (&(a, b), &we) in S::EDGES.iter().zip(w.as_ref()) {
                    v[k * a + b] = we;
                    v[k * b + a] = we;
                    diag[a] -= we;
                    diag[b] -= we;
                }
                for a in 0..k {
                    v[k * a + a] = diag[a];
                    for b in 0..k {
                        r[k * a + b] = cell[a];
                        c[k * a + b] = cell[b];
                    }
                }
            });
        Ok(())
    })?;
    Ok(Coo { n: mesh.n_vertices(), rows, cols, vals })
}

/// Unique edges `(i, j)`, `i < j`, sorted, with their summed weights `w_ij` (the upper
/// triangle of [`laplacian`]).
pub fn edge_weights<S: Simplex>(
    mesh: &MeshView<S>,
    kind: LaplacianKind,
    opts: &Options,
) -> Result<(Vec<[u32; 2]>, Vec<f64>)> {
    Ok(laplacian(mesh, kind, opts)?.upper_triangle())
}
