//! The public one-shot API: a validated mesh in, CSR / triplets / per-element values out.
//! Every function serves tets and triangles alike (generic over [`Simplex`]).

use crate::assembly::scatter::{assemble, Assembled};
use crate::sparse::{Coo, Csr, Mass};
use crate::assembly::pass::{boundary_mask, Elements};
use crate::error::Result;
use crate::assembly::order::Layout;
use crate::mesh::MeshView;
use crate::options::{LaplacianKind, MassKind, Options};
use crate::assembly::pass::{values, Slots};
use crate::element::{Fault, Request};
use crate::element::Simplex;
use crate::assembly::pattern::row_starts;
use rayon::prelude::*;
use std::borrow::Cow;

/// Why [`Degenerate::Skip`](crate::Degenerate::Skip) dropped an element's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Skipped {
    /// Zero volume: its corners are affinely dependent (exactly).
    Degenerate,
    /// Its values leave the normal `f64` range (see [`crate::element::ACCURACY`]'s rule).
    OutOfRange,
}

/// The elements a [`Degenerate`](crate::Degenerate) policy skipped: user index,
/// ascending, and why.
pub type Skips = Vec<(usize, Skipped)>;

/// The Laplacian and mass of `lap` and `mass` (as [`operators`]) with the elements the
/// options' [`Degenerate`](crate::Degenerate) policy dropped (user index, ascending, with
/// why): none under `Raise` (it fails instead), every element whose Laplacian or mass
/// values were left out under `Skip`. The operators are those of the mesh without them.
///
/// ```
/// use tetlap::{operators_skipping, Degenerate, LaplacianKind, MassKind, Options, Skipped, TetView};
/// // a tet and a flat one
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0];
/// let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3], [0, 1, 2, 4]]).unwrap();
/// let opts = Options { degenerate: Degenerate::Skip, ..Options::default() };
/// let (_, _, skipped) = operators_skipping(&mesh, LaplacianKind::Primal, MassKind::Barycentric, &opts).unwrap();
/// assert_eq!(skipped, vec![(1, Skipped::Degenerate)]);
/// ```
pub fn operators_skipping<S: Simplex>(
    mesh: &MeshView<S>,
    lap: LaplacianKind,
    mass: MassKind,
    opts: &Options,
) -> Result<(Csr, Mass, Skips)> {
    let lap = lap.check()?;
    super::install::<S, _>(opts, || {
        let (l, m, skipped) = one_shot(mesh, opts, Request { laplacian: Some(lap), mass: Some(mass) })?;
        let why = |f: Fault| if f == Fault::Degenerate { Skipped::Degenerate } else { Skipped::OutOfRange };
        let skipped = skipped.into_iter().map(|(t, f)| (t, why(f))).collect();
        Ok((l.expect("a Laplacian was asked for"), m.expect("a mass was asked for"), skipped))
    })
}

/// One-shot assembly of `request`: the internal order of `mesh`, the corner incidence and
/// the pattern, then the values of the elements and the rows, stripe by stripe
/// ([`assemble`]); with the elements the policy skipped.
fn one_shot<S: Simplex>(mesh: &MeshView<S>, opts: &Options, request: Request) -> Result<Assembled> {
    let (mut layout, corners) = Layout::with_corners(mesh, opts)?;
    layout.internal_of = Vec::new(); // not needed any more
    let indptr = row_starts::<S>(&layout.cells, &corners, &layout.vertex_of, opts)?;
    let internal = layout.mesh();
    let boundary = boundary_mask(&internal, opts)?.map(Cow::Owned);
    let elements = Elements::internal(internal, &layout.element_of, boundary).with(mesh.coefficient(), mesh.density());
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
        let (l, _, _) = one_shot(mesh, opts, Request { laplacian: Some(kind), mass: None })?;
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
        let (_, m, _) = one_shot(mesh, opts, Request { laplacian: None, mass: Some(kind) })?;
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
        let (l, m, _) = one_shot(mesh, opts, Request { laplacian: Some(lap), mass: Some(mass) })?;
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
        values(&Elements::new(*mesh, opts)?, opts, request, Slots { w: Some(&mut w), d: None, m: None }).map(|_| w)
    })
}

/// Per-element edge weights (as [`contributions`]) and diagonal entries: each element's
/// own `L_aa` at its corners, which for the primal is `-Vol |grad lambda_a|^2` computed on
/// its own (accurate relative to itself, where minus the sum of the corner's rounded
/// weights can cancel to nothing: a needle) and for the dual minus that sum.
pub fn element_laplacians<S: Simplex>(
    mesh: &MeshView<S>,
    kind: LaplacianKind,
    opts: &Options,
) -> Result<Vec<(S::EdgeValues, S::CornerValues)>> {
    let kind = kind.check()?;
    super::install::<S, _>(opts, || {
        let (mut w, mut d) = (vec![Default::default(); mesh.n_elements()], vec![Default::default(); mesh.n_elements()]);
        let request = Request { laplacian: Some(kind), mass: None };
        values(&Elements::new(*mesh, opts)?, opts, request, Slots { w: Some(&mut w), d: Some(&mut d), m: None })?;
        Ok(w.into_iter().zip(d).collect())
    })
}

/// Unsummed triplets of the Laplacian: `K^2` per element (its local `K x K` Laplacian,
/// element by element, row-major, with the element's diagonal entries of
/// [`element_laplacians`]). Summing repeated positions gives [`laplacian`] up to rounding.
pub fn triplets<S: Simplex>(mesh: &MeshView<S>, kind: LaplacianKind, opts: &Options) -> Result<Coo> {
    let w = element_laplacians(mesh, kind, opts)?;
    let (k, m) = (S::CORNERS, mesh.n_elements());
    let kk = k * k;
    let (mut rows, mut cols, mut vals) = (vec![0u32; kk * m], vec![0u32; kk * m], vec![0.0; kk * m]);
    super::install::<S, _>(opts, || {
        rows.par_chunks_mut(kk)
            .zip(cols.par_chunks_mut(kk))
            .zip(vals.par_chunks_mut(kk))
            .zip(mesh.cells().par_iter().zip(&w))
            .for_each(|(((r, c), v), (cell, (w, diag)))| {
                let cell = cell.as_ref();
                for (&(a, b), &we) in S::EDGES.iter().zip(w.as_ref()) {
                    v[k * a + b] = we;
                    v[k * b + a] = we;
                }
                for a in 0..k {
                    v[k * a + a] = diag.as_ref()[a];
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
