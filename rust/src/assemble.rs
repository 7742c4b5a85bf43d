//! Drivers: the parallel per-tet pass (each tet writes its own slot) and the reductions
//! onto edges, rows and vertices in a fixed order, so that the output is bitwise identical
//! for any number of threads.

use crate::csr::Csr;
use crate::error::{Error, Result};
use crate::geometry::{local_tet, LocalTet};
use crate::local;
use crate::mesh::TetMesh;
use crate::topology::{Topology, DIAGONAL};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Which Laplacian (paper Sec. 4-5, 9).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaplacianKind {
    /// P1 FEM / cotan weights (Eq. 7): always negative semidefinite.
    Primal,
    /// Circumcentric dual / DEC weights (Eq. 19-20): non-negative on Delaunay interiors.
    Dual,
    /// `(1 - t) primal + t dual`, `t` in `[0, 1]` (Sec. 9).
    Affine(f64),
}

/// Which mass matrix (paper Eq. 3, 4/21, consistent P1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MassKind {
    /// `Vol / 4` per tet corner, diagonal.
    Barycentric,
    /// Signed dual-cell volumes `Vol(*i)`, diagonal; negative on some non-Delaunay meshes.
    Circumcentric,
    /// Consistent P1 mass `Vol (1 + delta_ab) / 20`, on the edge pattern.
    Fem,
}

/// What to do with a tet of zero volume (or one so flat that its contribution overflows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Degenerate {
    /// Fail with [`Error::Degenerate`] / [`Error::NonFiniteResult`] naming the first such tet.
    #[default]
    Raise,
    /// Give such tets zero weights and zero mass (their edges stay in the pattern).
    Skip,
}

/// Options common to every assembly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Options {
    /// Worker threads; `None` uses rayon's global pool (all cores). Results do not depend
    /// on it.
    pub threads: Option<usize>,
    /// Policy for degenerate tets.
    pub degenerate: Degenerate,
}

/// One tet's requested contributions: six edge weights and four corner masses (for
/// [`MassKind::Fem`], `mass[0]` holds the tet's volume).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct TetValues {
    pub weights: [f64; 6],
    pub mass: [f64; 4],
}

/// Why one tet could not be evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fault {
    ZeroVolume,
    NonFinite,
}

/// Validates the affine parameter.
pub(crate) fn check_kind(kind: LaplacianKind) -> Result<()> {
    match kind {
        LaplacianKind::Affine(t) if !(0.0..=1.0).contains(&t) => Err(Error::InvalidOption {
            message: format!("the affine parameter t must lie in [0, 1], got {t}"),
        }),
        _ => Ok(()),
    }
}

fn evaluate(
    t: &LocalTet,
    lap: Option<LaplacianKind>,
    mass: Option<MassKind>,
) -> std::result::Result<TetValues, Fault> {
    if local::is_degenerate(t) {
        return Err(Fault::ZeroVolume);
    }
    let needs_dual = matches!(lap, Some(LaplacianKind::Dual | LaplacianKind::Affine(_)))
        || mass == Some(MassKind::Circumcentric);
    let dual = needs_dual.then(|| local::dual(t));
    let weights = match lap {
        None => [0.0; 6],
        Some(LaplacianKind::Primal) => local::primal_weights(t),
        Some(LaplacianKind::Dual) => dual.unwrap().weights,
        Some(LaplacianKind::Affine(s)) => {
            let (p, d) = (local::primal_weights(t), dual.unwrap().weights);
            std::array::from_fn(|e| (1.0 - s) * p[e] + s * d[e])
        }
    };
    let mass = match mass {
        None => [0.0; 4],
        Some(MassKind::Barycentric) => local::barycentric_mass(t),
        Some(MassKind::Circumcentric) => dual.unwrap().cell_volumes,
        Some(MassKind::Fem) => [local::volume(t), 0.0, 0.0, 0.0],
    };
    if weights.iter().chain(&mass).all(|v| v.is_finite()) {
        Ok(TetValues { weights, mass })
    } else {
        Err(Fault::NonFinite)
    }
}

/// Runs `f` on `threads` workers (a pool of its own) or on rayon's global pool.
pub(crate) fn run<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(Error::InvalidOption { message: "threads must be at least 1".into() }),
        Some(k) => rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .build()
            .map(|pool| pool.install(f))
            .map_err(|e| Error::InvalidOption { message: format!("thread pool: {e}") }),
    }
}

/// The parallel per-tet pass: every tet's values in its own slot.
pub(crate) fn tet_values(
    mesh: &TetMesh,
    lap: Option<LaplacianKind>,
    mass: Option<MassKind>,
    degenerate: Degenerate,
) -> Result<Vec<TetValues>> {
    if let Some(kind) = lap {
        check_kind(kind)?;
    }
    let d = mesh.dim();
    let scratch_len = if d > 3 { 3 * d } else { 0 };
    let corners = |t: usize| mesh.tets()[t].map(|v| mesh.point(v));
    let first_fault = AtomicUsize::new(usize::MAX);
    let mut out = vec![TetValues::default(); mesh.n_tets()];
    out.par_iter_mut().enumerate().for_each_init(
        || vec![0.0; scratch_len],
        |scratch, (t, slot)| match evaluate(&local_tet(corners(t), scratch), lap, mass) {
            Ok(v) => *slot = v,
            Err(_) => {
                first_fault.fetch_min(t, Ordering::Relaxed);
            }
        },
    );
    let t = first_fault.into_inner();
    if t == usize::MAX || degenerate == Degenerate::Skip {
        return Ok(out);
    }
    let mut scratch = vec![0.0; scratch_len];
    Err(match evaluate(&local_tet(corners(t), &mut scratch), lap, mass) {
        Err(Fault::ZeroVolume) => Error::Degenerate { element: t },
        _ => Error::NonFiniteResult { element: t },
    })
}

/// Sum over every edge of its tet-edge values, in ascending tet order.
pub(crate) fn edge_sums(topo: &Topology, value: impl Fn(usize) -> f64 + Sync) -> Vec<f64> {
    (0..topo.edges.len())
        .into_par_iter()
        .map(|e| topo.edge_incidence.of(e).iter().map(|&k| value(k as usize)).sum())
        .collect()
}

/// Sum over every vertex of its tet-corner values, in ascending tet order.
pub(crate) fn vertex_sums(topo: &Topology, value: impl Fn(usize) -> f64 + Sync) -> Vec<f64> {
    (0..topo.n)
        .into_par_iter()
        .map(|i| topo.vertex_incidence.of(i).iter().map(|&k| value(k as usize)).sum())
        .collect()
}

/// Splits `data` into the rows of `indptr`, for parallel per-row writes.
fn rows_mut<'a>(mut data: &'a mut [f64], indptr: &[usize]) -> Vec<&'a mut [f64]> {
    let mut rows = Vec::with_capacity(indptr.len().saturating_sub(1));
    for w in indptr.windows(2) {
        let (row, rest) = data.split_at_mut(w[1] - w[0]);
        rows.push(row);
        data = rest;
    }
    rows
}

/// CSR matrix on the topology's pattern: off-diagonal slots get `edge_value[e]`, the
/// diagonal gets `diagonal(i, off_diagonal_row_sum)` (sums in column order).
pub(crate) fn on_pattern(
    topo: &Topology,
    edge_value: &[f64],
    diagonal: impl Fn(usize, f64) -> f64 + Sync,
) -> Csr {
    let mut data = vec![0.0; topo.indices.len()];
    rows_mut(&mut data, &topo.indptr).into_par_iter().enumerate().for_each(|(i, row)| {
        let slots = &topo.slot_edge[topo.indptr[i]..topo.indptr[i + 1]];
        let mut sum = 0.0;
        let mut diag = 0;
        for (k, (&e, out)) in slots.iter().zip(row.iter_mut()).enumerate() {
            if e == DIAGONAL {
                diag = k;
            } else {
                *out = edge_value[e as usize];
                sum += *out;
            }
        }
        row[diag] = diagonal(i, sum);
    });
    Csr { n: topo.n, indptr: topo.indptr.clone(), indices: topo.indices.clone(), data }
}

/// The Laplacian from per-tet weights: `L[i,j] = w_ij`, `L[i,i] = -sum_j w_ij`.
pub(crate) fn laplacian_from(topo: &Topology, values: &[TetValues]) -> Csr {
    let w = edge_sums(topo, |k| values[k / 6].weights[k % 6]);
    on_pattern(topo, &w, |_, sum| -sum)
}

/// Lumped mass per vertex from per-tet corner masses.
pub(crate) fn lumped_from(topo: &Topology, values: &[TetValues]) -> Vec<f64> {
    vertex_sums(topo, |k| values[k / 4].mass[k % 4])
}

/// Consistent P1 mass from per-tet volumes (`values[t].mass[0]`).
pub(crate) fn fem_from(topo: &Topology, values: &[TetValues]) -> Csr {
    let off = edge_sums(topo, |k| values[k / 6].mass[0] / 20.0);
    let diag = vertex_sums(topo, |k| values[k / 4].mass[0] / 10.0);
    on_pattern(topo, &off, |i, _| diag[i])
}
