//! Triangle meshes (in R^2 or immersed in R^d): the cotan Laplacian, where the primal and
//! the circumcentric dual coincide (paper Sec. 4.3), and its masses.

use crate::assemble::{check_kind, per_tet, per_tet_pair, run, Fault, LaplacianKind, MassKind, Options, Source};
use crate::csr::{Coo, Csr};
use crate::error::{Error, Result};
use crate::geometry::{local_tri, LocalTri};
use crate::local::{cotan_weights, tri_area, tri_dual, tri_is_degenerate, TRI_EDGES};
use crate::mesh::TriMesh;
use crate::operators::{assemble, with_rows, Mass};

/// Consistent P1 mass of a triangle: `A / 12` off the diagonal, `A / 6` on it.
const FEM_TRI: (f64, f64) = (12.0, 6.0);

impl Source for TriMesh<'_> {
    type Item = LocalTri;

    fn get(&self, t: usize, _: &mut [f64]) -> LocalTri {
        local_tri(self.triangles()[t].map(|v| self.point(v)))
    }

    fn scratch_len(&self) -> usize {
        0
    }

    fn fault_error(&self, t: usize) -> Error {
        if tri_is_degenerate(&self.get(t, &mut [])) {
            Error::Degenerate { element: t }
        } else {
            Error::NonFiniteResult { element: t }
        }
    }
}

fn finite<const K: usize>(v: [f64; K]) -> std::result::Result<[f64; K], Fault> {
    if v.iter().all(|x| x.is_finite()) { Ok(v) } else { Err(Fault) }
}

/// The three weights of one triangle (local order `(0,1), (0,2), (1,2)`).
fn weights(t: &LocalTri, kind: LaplacianKind) -> std::result::Result<[f64; 3], Fault> {
    if tri_is_degenerate(t) {
        return Err(Fault);
    }
    finite(match kind {
        LaplacianKind::Primal => cotan_weights(t),
        LaplacianKind::Dual => tri_dual(t).0,
        LaplacianKind::Affine(s) => {
            let (p, d) = (cotan_weights(t), tri_dual(t).0);
            std::array::from_fn(|e| (1.0 - s) * p[e] + s * d[e])
        }
    })
}

/// The corner masses of one triangle (the area in every slot for [`MassKind::Fem`]).
fn corner_mass(t: &LocalTri, kind: MassKind) -> std::result::Result<[f64; 3], Fault> {
    if tri_is_degenerate(t) {
        return Err(Fault);
    }
    finite(match kind {
        MassKind::Barycentric => [tri_area(t) / 3.0; 3],
        MassKind::Circumcentric => tri_dual(t).1,
        MassKind::Fem => [tri_area(t); 3],
    })
}

/// The cotan Laplacian of a triangle mesh: `L[i,j] = (cot a + cot b) / 2`,
/// `L[i,i] = -sum_j L[i,j]`. `kind` may be primal or dual (equal up to rounding) or affine.
///
/// ```
/// use tetlap::{tri_laplacian, LaplacianKind, Options, TriMesh};
/// let points = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
/// let mesh = TriMesh::new(&points, 2, &[[0, 1, 2]])?;
/// let l = tri_laplacian(&mesh, LaplacianKind::Primal, &Options::default())?;
/// assert!((l.get(0, 1) - 0.5).abs() < 1e-15 && l.get(1, 2).abs() < 1e-15);
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn tri_laplacian(mesh: &TriMesh, kind: LaplacianKind, opts: &Options) -> Result<Csr> {
    check_kind(kind)?;
    run(opts.threads, || {
        let (w, rows) = with_rows(mesh.triangles(), mesh.n_vertices(), || {
            let mut w = vec![[0.0; 3]; mesh.n_triangles()];
            per_tet(mesh, opts.degenerate, &mut w, |t| weights(t, kind)).map(|_| w)
        })?;
        Ok(assemble::<3, 3>(rows, Some(&w), None, FEM_TRI).0.expect("a Laplacian was asked for"))
    })?
}

/// Mass of a triangle mesh: barycentric (Eq. 2, `A / 3`), circumcentric (signed Voronoi
/// areas) or consistent P1 (`A (1 + delta) / 12`).
pub fn tri_mass(mesh: &TriMesh, kind: MassKind, opts: &Options) -> Result<Mass> {
    run(opts.threads, || {
        let (m, rows) = with_rows(mesh.triangles(), mesh.n_vertices(), || {
            let mut m = vec![[0.0; 3]; mesh.n_triangles()];
            per_tet(mesh, opts.degenerate, &mut m, |t| corner_mass(t, kind)).map(|_| m)
        })?;
        Ok(assemble::<3, 3>(rows, None, Some((kind, &m)), FEM_TRI).1.expect("a mass was asked for"))
    })?
}

/// Laplacian and mass of a triangle mesh in one pass.
pub fn tri_operators(mesh: &TriMesh, lap: LaplacianKind, mass: MassKind, opts: &Options) -> Result<(Csr, Mass)> {
    check_kind(lap)?;
    run(opts.threads, || {
        let ((w, m), rows) = with_rows(mesh.triangles(), mesh.n_vertices(), || {
            let (mut w, mut m) = (vec![[0.0; 3]; mesh.n_triangles()], vec![[0.0; 3]; mesh.n_triangles()]);
            per_tet_pair(mesh, opts.degenerate, &mut w, &mut m, |t| Ok((weights(t, lap)?, corner_mass(t, mass)?)))
                .map(|_| (w, m))
        })?;
        let (l, m) = assemble(rows, Some(&w), Some((mass, &m)), FEM_TRI);
        Ok((l.expect("a Laplacian was asked for"), m.expect("a mass was asked for")))
    })?
}

/// Per-triangle weights, `(m, 3)` in the local edge order `(0,1), (0,2), (1,2)`.
pub fn tri_contributions(mesh: &TriMesh, kind: LaplacianKind, opts: &Options) -> Result<Vec<[f64; 3]>> {
    check_kind(kind)?;
    run(opts.threads, || {
        let mut w = vec![[0.0; 3]; mesh.n_triangles()];
        per_tet(mesh, opts.degenerate, &mut w, |t| weights(t, kind)).map(|_| w)
    })?
}

/// Unsummed triplets: 9 per triangle (its local 3 x 3 Laplacian, row-major).
pub fn tri_triplets(mesh: &TriMesh, kind: LaplacianKind, opts: &Options) -> Result<Coo> {
    let w = tri_contributions(mesh, kind, opts)?;
    let pairs: Vec<(usize, usize)> = TRI_EDGES.iter().map(|&(a, b, _)| (a, b)).collect();
    crate::operators::local_triplets::<3>(mesh.triangles(), mesh.n_vertices(), &pairs, |t| &w[t], opts)
}
