//! The public one-shot API: validated mesh in, CSR / triplets / per-tet values out.

use crate::assemble::{
    check_kind, corner_mass, laplacian_values, mass_values, per_tet, run, weights,
    weights_and_mass, Elements, LaplacianKind, MassKind, Options,
};
use crate::csr::{Coo, Csr};
use crate::error::Result;
use crate::local::EDGES;
use crate::mesh::TetMesh;
use crate::topology::Topology;
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

/// The mass of `kind` from per-tet corner masses (volumes for [`MassKind::Fem`]).
pub(crate) fn mass_from(topo: &Topology, kind: MassKind, m: &[[f64; 4]]) -> Mass {
    let values = mass_values(topo, kind, m, None, vec![]);
    match kind {
        MassKind::Fem => Mass::Consistent(topo.to_csr(values)),
        _ => Mass::Lumped(values),
    }
}

/// Per-tet pass and topology, side by side.
fn with_topology<T: Send>(
    mesh: &TetMesh,
    pass: impl FnOnce() -> Result<T> + Send,
) -> Result<(T, Topology)> {
    let (values, topo) = rayon::join(pass, || Topology::new(mesh.tets(), mesh.n_vertices()));
    Ok((values?, topo?))
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
        let (w, topo) = with_topology(mesh, || {
            let mut w = vec![[0.0; 6]; mesh.n_tets()];
            per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut w, |t| weights(t, kind)).map(|_| w)
        })?;
        let data = laplacian_values(&topo, &w, None, vec![]);
        Ok(topo.into_csr(data))
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
        let (m, topo) = with_topology(mesh, || {
            let mut m = vec![[0.0; 4]; mesh.n_tets()];
            per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut m, |t| corner_mass(t, kind)).map(|_| m)
        })?;
        Ok(mass_from(&topo, kind, &m))
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
        let (wm, topo) = with_topology(mesh, || {
            let mut wm = vec![([0.0; 6], [0.0; 4]); mesh.n_tets()];
            per_tet(&Elements::new(*mesh, opts), opts.degenerate, &mut wm, |t| weights_and_mass(t, lap, mass))
                .map(|_| wm)
        })?;
        let (w, m): (Vec<[f64; 6]>, Vec<[f64; 4]>) = wm.into_par_iter().unzip();
        let mass = mass_from(&topo, mass, &m);
        let data = laplacian_values(&topo, &w, None, vec![]);
        Ok((topo.into_csr(data), mass))
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
    let m = w.len();
    let (mut rows, mut cols, mut vals) = (vec![0u32; 16 * m], vec![0u32; 16 * m], vec![0.0; 16 * m]);
    run(opts.threads, || {
        rows.par_chunks_mut(16)
            .zip(cols.par_chunks_mut(16))
            .zip(vals.par_chunks_mut(16))
            .zip(mesh.tets().par_iter().zip(w.par_iter()))
            .for_each(|(((r, c), v), (tet, w))| {
                let mut local = [[0.0; 4]; 4];
                for (e, &(a, b)) in EDGES.iter().enumerate() {
                    local[a][b] = w[e];
                    local[b][a] = w[e];
                    local[a][a] -= w[e];
                    local[b][b] -= w[e];
                }
                for a in 0..4 {
                    for b in 0..4 {
                        r[4 * a + b] = tet[a];
                        c[4 * a + b] = tet[b];
                        v[4 * a + b] = local[a][b];
                    }
                }
            })
    })?;
    Ok(Coo { n: mesh.n_vertices(), rows, cols, vals })
}

/// Unique edges `(i, j)`, `i < j`, sorted, with their summed weights `w_ij` (the upper
/// triangle of [`laplacian`]).
pub fn edge_weights(mesh: &TetMesh, kind: LaplacianKind, opts: &Options) -> Result<(Vec<[u32; 2]>, Vec<f64>)> {
    let l = laplacian(mesh, kind, opts)?;
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
    Ok((edges, w))
}
