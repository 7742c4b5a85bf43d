//! The public one-shot API: validated mesh in, CSR / triplets / per-tet values out.

use crate::assemble::{
    assemble_rows, check_kind, corner_mass, gather_vertices, per_tet, per_tet_pair, run, weights,
    weights_and_mass, Elements, LaplacianKind, MassKind, Options,
};
use crate::csr::{Coo, Csr};
use crate::error::Result;
use crate::local::EDGES;
use crate::mesh::TetMesh;
use crate::topology::Rows;
use rayon::prelude::*;

/// A mass matrix: lumped (a diagonal, one value per vertex) or consistent (sparse).
#[derive(Debug, Clone, PartialEq)]
pub enum Mass {
    /// Diagonal entries, one per vertex (0 for unreferenced vertices).
    Lumped(Vec<f64>),
    /// The consistent P1 mass on the pattern "edges + diagonal".
    Consistent(Csr),
}

impl Mass {
    /// As a CSR matrix (a lumped mass becomes a diagonal matrix).
    pub fn into_csr(self) -> Csr {
        match self {
            Mass::Lumped(d) => Csr::diagonal(d),
            Mass::Consistent(m) => m,
        }
    }
}

/// Consistent P1 mass of a tet: `Vol / 20` off the diagonal, `Vol / 10` on it.
const FEM_TET: (f64, f64) = (20.0, 10.0);

/// Per-element pass and row layout of `elements` over `n` vertices, side by side.
pub(crate) fn with_rows<'a, T: Send, const K: usize>(
    elements: &'a [[u32; K]],
    n: usize,
    pass: impl FnOnce() -> Result<T> + Send,
) -> Result<(T, Rows<'a, K>)> {
    let (values, rows) = rayon::join(pass, || Rows::new(elements, n));
    Ok((values?, rows?))
}

fn csr<const K: usize>(rows: Rows<K>, indices: Vec<u32>, data: Vec<f64>) -> Csr {
    Csr { n: rows.indptr.len() - 1, indptr: rows.indptr, indices, data }
}

/// One-shot assembly of the requested operators from per-tet values.
pub(crate) fn assemble<const K: usize, const E: usize>(
    rows: Rows<K>,
    w: Option<&[[f64; E]]>,
    mass: Option<(MassKind, &[[f64; K]])>,
    fem_factors: (f64, f64),
) -> (Option<Csr>, Option<Mass>) {
    let fem = mass.and_then(|(kind, m)| (kind == MassKind::Fem).then_some((m, fem_factors)));
    let lumped = mass
        .filter(|(kind, _)| *kind != MassKind::Fem)
        .map(|(_, m)| Mass::Lumped(gather_vertices::<K>(&rows.corners, |t, c| m[t][c])));
    let (indices, lap, fem) = assemble_rows(&rows, w, fem);
    let laplacian = lap.map(|data| Csr {
        n: rows.indptr.len() - 1,
        indptr: rows.indptr.clone(),
        indices: indices.clone(),
        data,
    });
    let mass = lumped.or_else(|| fem.map(|data| Mass::Consistent(csr(rows, indices, data))));
    (laplacian, mass)
}

/// The `n x n` Laplacian: `L[i,j] = w_ij` on edges, `L[i,i] = -sum_j w_ij`; rows sum to
/// zero, the primal is negative semidefinite. Sorted CSR with every mesh edge stored.
///
/// ```
/// use tetlap::{laplacian, LaplacianKind, Options, TetMesh};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = TetMesh::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// let l = laplacian(&mesh, LaplacianKind::Dual, &Options::default()).unwrap();
/// assert_eq!(l.get(0, 0), -0.75);
/// assert_eq!(l.get(0, 1), 0.25);
/// ```
pub fn laplacian(mesh: &TetMesh, kind: LaplacianKind, opts: &Options) -> Result<Csr> {
    check_kind(kind)?;
    run(opts.threads, || {
        let (w, rows) = with_rows(mesh.tets(), mesh.n_vertices(), || {
            let mut w = vec![[0.0; 6]; mesh.n_tets()];
            per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut w, |t| weights(t, kind)).map(|_| w)
        })?;
        Ok(assemble(rows, Some(&w), None, FEM_TET).0.expect("a Laplacian was asked for"))
    })?
}

/// The mass matrix of `kind` (paper Eq. 3, 4/21, or the consistent P1 mass).
///
/// ```
/// use tetlap::{mass, Mass, MassKind, Options, TetMesh};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = TetMesh::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// let Mass::Lumped(m) = mass(&mesh, MassKind::Circumcentric, &Options::default()).unwrap()
/// else { unreachable!() };
/// assert!((m[0] - 1.0 / 8.0).abs() < 1e-15 && (m.iter().sum::<f64>() - 1.0 / 6.0).abs() < 1e-15);
/// ```
pub fn mass(mesh: &TetMesh, kind: MassKind, opts: &Options) -> Result<Mass> {
    run(opts.threads, || {
        let (m, rows) = with_rows(mesh.tets(), mesh.n_vertices(), || {
            let mut m = vec![[0.0; 4]; mesh.n_tets()];
            per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut m, |t| corner_mass(t, kind)).map(|_| m)
        })?;
        Ok(assemble::<4, 6>(rows, None, Some((kind, &m)), FEM_TET).1.expect("a mass was asked for"))
    })?
}

/// Laplacian and mass matrix from one per-tet pass and one topology.
pub fn operators(
    mesh: &TetMesh,
    lap: LaplacianKind,
    mass: MassKind,
    opts: &Options,
) -> Result<(Csr, Mass)> {
    check_kind(lap)?;
    run(opts.threads, || {
        let ((w, m), rows) = with_rows(mesh.tets(), mesh.n_vertices(), || {
            let (mut w, mut m) = (vec![[0.0; 6]; mesh.n_tets()], vec![[0.0; 4]; mesh.n_tets()]);
            per_tet_pair(&Elements::new(*mesh, opts), opts.degenerate, &mut w, &mut m, |t| {
                weights_and_mass(t, lap, mass)
            })
            .map(|_| (w, m))
        })?;
        let (l, m) = assemble(rows, Some(&w), Some((mass, &m)), FEM_TET);
        Ok((l.expect("a Laplacian was asked for"), m.expect("a mass was asked for")))
    })?
}

/// Per-tet edge weights, `(m, 6)` in the local edge order [`crate::local::EDGES`].
pub fn tet_contributions(mesh: &TetMesh, kind: LaplacianKind, opts: &Options) -> Result<Vec<[f64; 6]>> {
    check_kind(kind)?;
    run(opts.threads, || {
        let mut w = vec![[0.0; 6]; mesh.n_tets()];
        per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut w, |t| weights(t, kind)).map(|_| w)
    })?
}

/// Unsummed triplets of the Laplacian: 16 per tet (the tet's local 4 x 4 Laplacian, tet by
/// tet, row-major). Summing repeated positions gives [`laplacian`] up to rounding.
pub fn triplets(mesh: &TetMesh, kind: LaplacianKind, opts: &Options) -> Result<Coo> {
    let w = tet_contributions(mesh, kind, opts)?;
    local_triplets::<4>(mesh.tets(), mesh.n_vertices(), &EDGES, |t| &w[t], opts)
}

/// The local `K x K` Laplacians of all elements as triplets, from per-element weights on
/// the local edges `pairs`.
pub(crate) fn local_triplets<'w, const K: usize>(
    elements: &[[u32; K]],
    n: usize,
    pairs: &[(usize, usize)],
    w: impl Fn(usize) -> &'w [f64] + Sync,
    opts: &Options,
) -> Result<Coo> {
    let m = elements.len();
    let kk = K * K;
    let (mut rows, mut cols, mut vals) = (vec![0u32; kk * m], vec![0u32; kk * m], vec![0.0; kk * m]);
    run(opts.threads, || {
        rows.par_chunks_mut(kk)
            .zip(cols.par_chunks_mut(kk))
            .zip(vals.par_chunks_mut(kk))
            .zip(elements.par_iter())
            .enumerate()
            .for_each(|(t, (((r, c), v), el))| {
                let mut local = [[0.0; K]; K];
                for (&(a, b), &we) in pairs.iter().zip(w(t)) {
                    local[a][b] = we;
                    local[b][a] = we;
                    local[a][a] -= we;
                    local[b][b] -= we;
                }
                for a in 0..K {
                    for b in 0..K {
                        r[K * a + b] = el[a];
                        c[K * a + b] = el[b];
                        v[K * a + b] = local[a][b];
                    }
                }
            })
    })?;
    Ok(Coo { n, rows, cols, vals })
}

/// Unique edges `(i, j)`, `i < j`, sorted, with their summed weights `w_ij` (the upper
/// triangle of [`laplacian`]).
pub fn edge_weights(mesh: &TetMesh, kind: LaplacianKind, opts: &Options) -> Result<(Vec<[u32; 2]>, Vec<f64>)> {
    Ok(upper_triangle(&laplacian(mesh, kind, opts)?))
}

/// The strictly upper triangle of `l`: edges `(i, j)`, `i < j`, in CSR order, and values.
pub fn upper_triangle(l: &Csr) -> (Vec<[u32; 2]>, Vec<f64>) {
    let mut edges = Vec::with_capacity((l.nnz() - l.n) / 2);
    let mut w = Vec::with_capacity(edges.capacity());
    for i in 0..l.n {
        for k in l.indptr[i]..l.indptr[i + 1] {
            if l.indices[k] as usize > i {
                edges.push([i as u32, l.indices[k]]);
                w.push(l.data[k]);
            }
        }
    }
    (edges, w)
}
