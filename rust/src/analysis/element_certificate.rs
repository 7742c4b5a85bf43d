//! Is a sum of element matrices negative semidefinite? A certificate from the elements.
//!
//! Every operator of the crate is a sum of per-element matrices: with the element's edge
//! weights `w_ab` (local order [`Simplex::EDGES`]) and diagonal entries `d_a`, `-L = sum_t
//! K_t` where `K_t` (off-diagonals `-w_ab`, diagonal `-d_a`: for the dual `d_a = -sum_b
//! w_ab`, so that `K_t = sum_ab w_ab (e_a - e_b)(e_a - e_b)^T`; for the primal `d_a` is
//! computed on its own, see [`crate::element_laplacians`]) lives on the element's corners. A sum of
//! positive semidefinite matrices is positive semidefinite, so:
//!
//! * every `K_t` is checked (a Cholesky factorisation of `K_t + tau I` on its corners);
//!   for the primal each `K_t` is the Gram matrix `Vol_t G_t G_t^T` and always passes;
//! * the elements that fail are grown into **groups** of face-neighbouring elements, one
//!   ring at a time, until the group's summed matrix passes (the groups are disjoint: a
//!   group that reaches another absorbs it whole), up to [`MAX_GROUP`] vertices.
//!
//! With each piece `P` satisfying `P + diag(tau)_P >= 0` on its own vertices, and at most
//! `c` pieces at any vertex (`c` is bounded by the largest vertex valence in elements),
//! `sum P + c diag(tau)` is positive semidefinite: the shifts are `tau_v = tol_v / c` for
//! the per-vertex tolerances `tol`. This certifies the sum of the element matrices; the
//! caller accounts for any difference between that sum and a given matrix. The dense work is bounded by [`WORK_PER_ELEMENT`] per element. At the
//! first group that cannot be certified (or when the work runs out) the answer is
//! [`Semidefinite::Undetermined`] (`uncovered: 1`): a failing group does not prove
//! indefiniteness (the elements beyond it may compensate).

use crate::analysis::definite::{check_tolerances, cholesky, Semidefinite, MAX_GROUP};
use crate::error::Result;
use crate::topology::faces::faces;
use crate::topology::group::group_by;
use crate::options::Options;
use crate::element::Simplex;
use rayon::prelude::*;

/// Rings of face neighbours a failing element grows before it is given up.
const RINGS: usize = 6;

/// Dense factorisation work (`size^3 / 3` flops summed over the groups) allowed per
/// element: the certificate costs `O(m)` whatever the mesh (jittered Kuhn duals need 5 to
/// 130 per element); past it the answer is undetermined.
const WORK_PER_ELEMENT: f64 = 50_000.0;

/// Whether `-L = sum_t K_t` is negative semidefinite up to the tolerances `tol` (one per
/// vertex, finite and `>= 0`: whether `-L + diag(tol)` is positive semidefinite), from the
/// element Laplacians `laplacians` (one `(edge weights, diagonal entries)` per element of
/// `cells`, local order [`Simplex::EDGES`], as [`crate::element_laplacians`] returns them)
/// over `n` vertices: [`Semidefinite::ElementCertificate`] or
/// [`Semidefinite::Undetermined`]; [`crate::Error::Shape`] for tolerances of the wrong
/// length or value.
///
/// ```
/// use tetlap::{element_laplacians, negative_semidefinite_by_elements, LaplacianKind, Options, Semidefinite, Tet, TetView};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
/// let cells = [[0, 1, 2, 3], [1, 2, 3, 4]];
/// let mesh = TetView::new(&points, 3, &cells)?;
/// let opts = Options::default();
/// let primal = element_laplacians(&mesh, LaplacianKind::Primal, &opts)?;
/// let answer = negative_semidefinite_by_elements::<Tet>(&cells, 5, &primal, &[1e-12; 5], &opts)?;
/// // every element matrix of the primal is a Gram matrix: no group is needed
/// assert_eq!(answer, Semidefinite::ElementCertificate { groups: 0, largest: 1 });
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn negative_semidefinite_by_elements<S: Simplex>(
    cells: &[S::Cell],
    n: usize,
    laplacians: &[(S::EdgeValues, S::CornerValues)],
    tol: &[f64],
    opts: &Options,
) -> Result<Semidefinite> {
    assert_eq!(cells.len(), laplacians.len(), "one element Laplacian per element");
    check_tolerances(tol, n)?;
    opts.install(|| certify::<S>(cells, n, laplacians, tol, opts))
}

fn certify<S: Simplex>(cells: &[S::Cell], n: usize, weights: &[(S::EdgeValues, S::CornerValues)], tol: &[f64], opts: &Options) -> Result<Semidefinite> {
    let mut valence = vec![0usize; n];
    for cell in cells {
        for &v in cell.as_ref() {
            valence[v as usize] += 1;
        }
    }
    let c = valence.iter().copied().max().unwrap_or(1).max(1) as f64;
    let tau: Vec<f64> = tol.iter().map(|t| t / c).collect();
    let passes = |elements: &[u32], vertices: &[u32]| group_passes::<S>(cells, weights, elements, vertices, &tau);
    let failing: Vec<u32> = (0..cells.len() as u32)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&t| !passes(&[t], &group_vertices::<S>(cells, &[t])))
        .collect();
    opts.cancelled()?;
    if failing.is_empty() {
        return Ok(Semidefinite::ElementCertificate { groups: 0, largest: 1 });
    }
    let neighbours = face_neighbours::<S>(cells, n, opts)?;
    // group id of every element in a group (NONE: a piece of its own)
    const NONE: u32 = u32::MAX;
    let mut owner = vec![NONE; cells.len()];
    let mut members: Vec<Vec<u32>> = Vec::new();
    let (mut work, budget) = (0.0, WORK_PER_ELEMENT * cells.len() as f64);
    for &t in &failing {
        opts.cancelled()?;
        if owner[t as usize] != NONE {
            continue;
        }
        let mut group = vec![t];
        let mut certified = false;
        for _ in 0..RINGS {
            opts.cancelled()?;
            let mut grown = group.clone();
            for &e in &group {
                for &f in neighbours.of(e as usize) {
                    match owner[f as usize] {
                        NONE => grown.push(f),
                        g => grown.append(&mut members[g as usize]),
                    }
                }
            }
            grown.sort_unstable();
            grown.dedup();
            group = grown;
            let vertices = group_vertices::<S>(cells, &group);
            work += (vertices.len() as f64).powi(3) / 3.0;
            if vertices.len() > MAX_GROUP || work > budget {
                break;
            }
            if passes(&group, &vertices) {
                certified = true;
                break;
            }
        }
        if !certified {
            // no certificate for the sum: stop at the first group that has none
            return Ok(Semidefinite::Undetermined { uncovered: 1, residual: 0.0 });
        }
        let id = members.len() as u32;
        for &e in &group {
            owner[e as usize] = id;
        }
        members.push(group);
    }
    let live: Vec<&Vec<u32>> = members.iter().filter(|m| !m.is_empty()).collect();
    let largest = live.iter().map(|m| m.len()).max().unwrap_or(1);
    Ok(Semidefinite::ElementCertificate { groups: live.len(), largest })
}

/// The elements across each face of each element, ascending (an [`crate::Incidence`]
/// over elements).
fn face_neighbours<S: Simplex>(cells: &[S::Cell], n: usize, opts: &Options) -> Result<crate::Incidence> {
    let pairs = faces::<S>(cells, n, opts)?.interior;
    let (offsets, mut items) = group_by(
        cells.len(),
        2 * pairs.len(),
        |r| {
            let p = pairs[r / 2];
            if r % 2 == 0 { (p[0], p[2]) } else { (p[2], p[0]) }
        },
        opts,
    )?;
    for w in offsets.windows(2) {
        items[w[0]..w[1]].sort_unstable();
    }
    Ok(crate::Incidence { offsets, items })
}

/// The sorted vertices of `elements`.
fn group_vertices<S: Simplex>(cells: &[S::Cell], elements: &[u32]) -> Vec<u32> {
    let mut vertices: Vec<u32> = elements.iter().flat_map(|&e| cells[e as usize].as_ref().iter().copied()).collect();
    vertices.sort_unstable();
    vertices.dedup();
    vertices
}

/// Whether the summed element matrices of `elements` plus `diag(tau)` on their sorted
/// `vertices` have a Cholesky factorisation.
fn group_passes<S: Simplex>(
    cells: &[S::Cell],
    weights: &[(S::EdgeValues, S::CornerValues)],
    elements: &[u32],
    vertices: &[u32],
    tau: &[f64],
) -> bool {
    let size = vertices.len();
    let mut a = vec![0.0; size * size];
    for &e in elements {
        let cell = cells[e as usize].as_ref();
        let local: Vec<usize> = cell.iter().map(|v| vertices.binary_search(v).expect("a vertex of the group")).collect();
        let (w, d) = &weights[e as usize];
        for (&(x, y), &w) in S::EDGES.iter().zip(w.as_ref()) {
            let (i, j) = (local[x], local[y]);
            a[i * size + j] -= w;
            a[j * size + i] -= w;
        }
        for (&i, &d) in local.iter().zip(d.as_ref()) {
            a[i * size + i] -= d;
        }
    }
    let shift: Vec<f64> = vertices.iter().map(|&v| tau[v as usize]).collect();
    cholesky(&mut a, size, &shift).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Tet;

    /// The element Laplacian making `K` the 4x4 graph Laplacian with weight `w` on every
    /// edge but edge 0, which gets `w0`.
    fn weights(w0: f64, w: f64) -> ([f64; 6], [f64; 4]) {
        let w = [w0, w, w, w, w, w];
        (w, crate::element::corner_sums::<Tet>(&w))
    }

    #[test]
    fn a_needle_is_certified_with_its_own_diagonal_entries() {
        // the apex's weights are about 0.1 and cancel to its diagonal entry -1.7e-21:
        // minus their rounded sum is no Gram matrix's diagonal, the element's own entry is
        let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.0, 1.0, 0.25, 0.3, 0.2, 1e20];
        let cells = [[0, 1, 2, 3]];
        let opts = Options::default();
        let mesh = crate::TetView::new(&points, 3, &cells).unwrap();
        let primal = crate::element_laplacians(&mesh, crate::LaplacianKind::Primal, &opts).unwrap();
        let tol = primal[0].1.map(|d| 1e-9 * d.abs());
        let answer = negative_semidefinite_by_elements::<Tet>(&cells, 4, &primal, &tol, &opts).unwrap();
        assert_eq!(answer, Semidefinite::ElementCertificate { groups: 0, largest: 1 });
        let summed = [(primal[0].0, crate::element::corner_sums::<Tet>(&primal[0].0))];
        assert!(!group_passes::<Tet>(&cells, &summed, &[0], &[0, 1, 2, 3], &tol));
    }

    #[test]
    fn non_negative_element_weights_need_no_groups() {
        let cells = [[0, 1, 2, 3], [1, 2, 3, 4]];
        let answer = negative_semidefinite_by_elements::<Tet>(&cells, 5, &[weights(1.0, 1.0); 2], &[1e-12; 5], &Options::default());
        assert_eq!(answer.unwrap(), Semidefinite::ElementCertificate { groups: 0, largest: 1 });
    }

    #[test]
    fn a_failing_element_is_covered_by_its_neighbour() {
        // K_0 alone: the edge (1, 2) weight -1.5 with the others 1 is indefinite
        // (x = e_1 - e_2 gives 2 + 2 (-1.5) ... checked by the factorisation); the
        // neighbour's strong weight on the same edge covers it
        let cells = [[1, 2, 0, 3], [1, 2, 3, 4]];
        let w = [weights(-1.5, 1.0), weights(5.0, 1.0)];
        let opts = Options::default();
        assert!(!group_passes::<Tet>(&cells, &w, &[0], &group_vertices::<Tet>(&cells, &[0]), &[1e-12; 5]));
        let answer = negative_semidefinite_by_elements::<Tet>(&cells, 5, &w, &[1e-12; 5], &opts).unwrap();
        assert_eq!(answer, Semidefinite::ElementCertificate { groups: 1, largest: 2 });
    }

    #[test]
    fn an_indefinite_sum_is_never_certified() {
        let cells = [[1, 2, 0, 3], [1, 2, 3, 4]];
        let w = [weights(-5.0, 1.0), weights(1.0, 1.0)];
        let answer = negative_semidefinite_by_elements::<Tet>(&cells, 5, &w, &[1e-12; 5], &Options::default()).unwrap();
        assert_eq!(answer, Semidefinite::Undetermined { uncovered: 1, residual: 0.0 });
    }

    #[test]
    fn a_skipped_element_with_zero_tolerances_passes() {
        // element 1 contributes nothing (skipped as degenerate): vertex 4 has a zero row,
        // and a tolerance relative to its diagonal is zero
        let cells = [[0, 1, 2, 3], [1, 2, 3, 4]];
        let w = [weights(1.0, 1.0), ([0.0; 6], [0.0; 4])];
        let tol = [1e-9, 1e-9, 1e-9, 1e-9, 0.0];
        let answer = negative_semidefinite_by_elements::<Tet>(&cells, 5, &w, &tol, &Options::default()).unwrap();
        assert_eq!(answer, Semidefinite::ElementCertificate { groups: 0, largest: 1 });
    }
}
