//! Is a Laplacian negative semidefinite? Certificates that cost `O(size of the mesh)`.
//!
//! Write `A = -L = sum_{edges ij} w_ij (e_i - e_j)(e_i - e_j)^T + diag(r)` with the weights
//! `w_ij = L_ij` and the row residuals `r_i = -sum_j L_ij` (zero up to rounding for a
//! Laplacian). `L` is negative semidefinite up to the tolerances `tol` (one per vertex)
//! when `A + diag(tol)` is positive semidefinite; with one tolerance `t` for every vertex
//! that is `lambda_min(A) >= -t`. Per-vertex tolerances (such as a fraction of each row's
//! diagonal) make the answer independent of the scale of any other part of the mesh.
//!
//! * **Non-negative weights**: `A` is a weighted graph Laplacian plus a diagonal, so
//!   `A + diag(tol)` is positive semidefinite when every `r_i + tol_i >= 0` (Weyl).
//! * **Local certificate**: every negative weight is put in a small group (edges sharing a
//!   vertex group together), with the positive weights of the edges among the group's
//!   vertices and their neighbours split evenly between the groups that contain them. `A`
//!   is the sum of the groups' matrices and of what is left (non-negative weights: PSD), so
//!   if every group matrix `A_C` satisfies `A_C + diag(tau_C) > 0` (a Cholesky
//!   factorisation succeeds) with `sum_C tau_C(v) <= tol_v + min(r_v, 0)` at every vertex
//!   `v`, then `A + diag(tol)` is positive semidefinite.
//! * **Indefinite**: when a group cannot be certified, the principal submatrix of
//!   `A + diag(tol)` on its vertices is factored: a negative pivot gives a vector `x`
//!   supported there with `x^T A x < -x^T diag(tol) x` (checked directly from the
//!   entries), so `A + diag(tol)` is not positive semidefinite (interlacing).
//! * Otherwise every group that failed merges with all groups overlapping it and grows by
//!   a ring of neighbours, and the whole certificate is tried again (at most six rounds,
//!   groups of at most [`MAX_GROUP`] vertices): what remains is reported as undetermined,
//!   never guessed.

use crate::sparse::CsrRef;
use crate::error::{Error, Result};
use crate::options::Options;
use rayon::prelude::*;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::atomic::{AtomicU32, Ordering};

/// The largest group (vertices) whose dense matrix is factored.
pub const MAX_GROUP: usize = 600;

/// Negative weights per initial group.
const GROUP_EDGES: usize = 12;

/// The answer to "is `L` negative semidefinite (up to the tolerances `tol`)?", with its
/// certificate.
#[derive(Debug, Clone, PartialEq)]
pub enum Semidefinite {
    /// Every off-diagonal weight is non-negative and every row residual `r_i >= -tol_i`.
    NonNegativeWeights,
    /// Every negative weight is covered by the positive weights around it: `groups`
    /// groups of at most `largest` vertices, whose shifts sum to at most `tol_v` at
    /// every vertex `v`.
    LocalCertificate {
        /// Number of groups.
        groups: usize,
        /// Vertices of the largest group.
        largest: usize,
    },
    /// Every element matrix `K_t` is positive semidefinite (up to a shift), except in
    /// `groups` groups of face-neighbouring elements (at most `largest` each) whose sums
    /// are: see [`crate::negative_semidefinite_by_elements`].
    ElementCertificate {
        /// Number of groups of elements.
        groups: usize,
        /// Elements in the largest group (1 when no group was needed).
        largest: usize,
    },
    /// Not semidefinite: a vector `x` supported on `support` vertices around vertex
    /// `vertex` has `x^T (-L) x < -x^T diag(tol) x`; `rayleigh = x^T (-L) x / x^T x`.
    Indefinite {
        /// The Rayleigh quotient of `-L` at the witness (an upper bound on its smallest
        /// eigenvalue).
        rayleigh: f64,
        /// Vertices in the witness's support.
        support: usize,
        /// A vertex of the support (one endpoint of a negative weight).
        vertex: u32,
    },
    /// No certificate either way: `uncovered` negative weights could not be covered by
    /// groups of up to [`MAX_GROUP`] vertices, or a row's residual exceeds its tolerance.
    Undetermined {
        /// Negative weights left uncovered.
        uncovered: usize,
        /// The largest row residual `max(0, -min_i r_i)`.
        residual: f64,
    },
}

/// A group of negative weights and the vertices of its matrix.
#[derive(Debug, Clone)]
struct Group {
    /// CSR positions `(i, k)` of its negative weights (`i < indices[k]`).
    edges: Vec<(usize, usize)>,
    /// Rings of neighbours around the endpoints.
    ring: usize,
}

/// The sorted vertex set of `group`: its endpoints and `ring` rings of neighbours.
fn vertices(l: &CsrRef, group: &Group) -> Vec<u32> {
    let mut set: BTreeSet<u32> = BTreeSet::new();
    for &(i, k) in &group.edges {
        set.insert(i as u32);
        set.insert(l.indices[k]);
    }
    for _ in 0..group.ring {
        let frontier: Vec<u32> = set.iter().copied().collect();
        for v in frontier {
            let v = v as usize;
            set.extend(&l.indices[l.indptr[v]..l.indptr[v + 1]]);
            if set.len() > MAX_GROUP {
                break;
            }
        }
    }
    set.into_iter().collect()
}

/// In-place Cholesky of the dense symmetric `n x n` matrix `a` (row-major) plus
/// `diag(shift)`: `Err(k)` at the first pivot `k` that is negative, or zero with a non-zero
/// entry below it. A zero pivot over a zero column (an exactly zero row and column, such
/// as those of a vertex whose elements were all skipped, with a zero tolerance) is
/// semidefinite and passes, its column of the factor zero. The lower factor overwrites `a`.
pub(crate) fn cholesky(a: &mut [f64], n: usize, shift: &[f64]) -> std::result::Result<(), usize> {
    for j in 0..n {
        let mut d = a[j * n + j] + shift[j];
        for p in 0..j {
            d -= a[j * n + p] * a[j * n + p];
        }
        if d == 0.0 {
            for i in j + 1..n {
                let mut s = a[i * n + j];
                for p in 0..j {
                    s -= a[i * n + p] * a[j * n + p];
                }
                if s != 0.0 {
                    return Err(j);
                }
                a[i * n + j] = 0.0;
            }
            a[j * n + j] = 0.0;
            continue;
        }
        if !(d > 0.0) {
            return Err(j);
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for p in 0..j {
                s -= a[i * n + p] * a[j * n + p];
            }
            a[i * n + j] = s / d;
        }
    }
    Ok(())
}

/// The entry `L[i, j]`, zero if not stored.
fn entry(l: &CsrRef, i: usize, j: u32) -> f64 {
    let row = l.indptr[i]..l.indptr[i + 1];
    l.indices[row.clone()].binary_search(&j).map_or(0.0, |k| l.data[row.start + k])
}

/// A witness of indefiniteness on the vertex set `s`: the principal submatrix of
/// `A + diag(tol)` (`A = -L`) is factored; at a failing pivot `k` the vector
/// `x = L_k^{-T} e_k` has `x^T (A + diag(tol)) x <= 0`. Returns the Rayleigh quotient of
/// `A` at `x` if `x^T A x < -x^T diag(tol) x`, both computed from the entries again.
fn witness(l: &CsrRef, s: &[u32], tol: &[f64]) -> Option<f64> {
    let n = s.len();
    let mut a = vec![0.0; n * n];
    for (p, &i) in s.iter().enumerate() {
        for (q, &j) in s.iter().enumerate() {
            a[p * n + q] = -entry(l, i as usize, j);
        }
    }
    let original = a.clone();
    let shift: Vec<f64> = s.iter().map(|&i| tol[i as usize]).collect();
    let k = cholesky(&mut a, n, &shift).err()?;
    // x_{0..k} solves L_k^T x = -l_k (the row k of the factor left of the diagonal), x_k = 1
    let mut x = vec![0.0; k + 1];
    x[k] = 1.0;
    for p in (0..k).rev() {
        let mut v = -a[k * n + p];
        for q in p + 1..k {
            v -= a[q * n + p] * x[q];
        }
        // a zero pivot has a zero column (see `cholesky`): any x_p solves its row
        x[p] = if a[p * n + p] == 0.0 { 0.0 } else { v / a[p * n + p] };
    }
    let (mut num, mut den, mut allowed) = (0.0, 0.0, 0.0);
    for p in 0..=k {
        den += x[p] * x[p];
        allowed += shift[p] * x[p] * x[p];
        for q in 0..=k {
            num += x[p] * original[p * n + q] * x[q];
        }
    }
    (num < -allowed).then_some(num / den)
}

/// Whether `l` (square, symmetric, sorted CSR: a [`crate::Csr`] or a [`CsrRef`]) is
/// negative semidefinite up to the tolerances `tol` (one per row, finite and `>= 0`):
/// whether `-L + diag(tol)` is positive semidefinite, with the certificate or witness of
/// [`Semidefinite`]. [`Error::Shape`] for tolerances of the wrong length or value.
///
/// ```
/// use tetlap::{laplacian, negative_semidefinite, LaplacianKind, Options, Semidefinite, TetView};
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3]])?;
/// let opts = Options::default();
/// // the primal of the corner tet has weights 1/6 and 0: a graph Laplacian
/// let primal = laplacian(&mesh, LaplacianKind::Primal, &opts)?;
/// let tol = [1e-12; 4]; // one per vertex
/// assert_eq!(negative_semidefinite(&primal, &tol, &opts)?, Semidefinite::NonNegativeWeights);
/// // its dual has negative weights on the slanted face, covered by the positive ones
/// let dual = laplacian(&mesh, LaplacianKind::Dual, &opts)?;
/// let certified = negative_semidefinite(&dual, &tol, &opts)?;
/// assert!(matches!(certified, Semidefinite::LocalCertificate { groups: 1, .. }));
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn negative_semidefinite<'a>(l: impl Into<CsrRef<'a>>, tol: &[f64], opts: &Options) -> Result<Semidefinite> {
    let l = l.into();
    l.check_shape(l.n, "the operator")?;
    check_tolerances(tol, l.n)?;
    opts.install(|| certify(&l, tol, opts))
}

/// [`Error::Shape`] unless `tol` holds one finite, non-negative tolerance per vertex.
pub(crate) fn check_tolerances(tol: &[f64], n: usize) -> Result<()> {
    if tol.len() != n {
        return Err(Error::Shape { what: format!("the tolerances hold {} values, one per vertex of {n}", tol.len()) });
    }
    match tol.iter().position(|t| !(t.is_finite() && *t >= 0.0)) {
        Some(i) => Err(Error::Shape { what: format!("the tolerance of vertex {i} is {}: tolerances are finite and >= 0", tol[i]) }),
        None => Ok(()),
    }
}

fn certify(l: &CsrRef, tol: &[f64], opts: &Options) -> Result<Semidefinite> {
    let n = l.n;
    let row = |i: usize| l.indptr[i]..l.indptr[i + 1];
    // what a negative row residual r_i = -sum_j L_ij takes from its vertex's tolerance
    let deficit: Vec<f64> = (0..n).into_par_iter().map(|i| l.data[row(i)].iter().sum::<f64>().max(0.0)).collect();
    let residual = deficit.iter().fold(0.0, |m: f64, &d| m.max(d));
    let negative: Vec<(usize, usize)> = (0..n)
        .into_par_iter()
        .flat_map_iter(|i| row(i).filter(move |&k| l.indices[k] as usize > i && l.data[k] < 0.0).map(move |k| (i, k)))
        .collect();
    opts.cancelled()?;
    if deficit.iter().zip(tol).any(|(d, t)| d > t) {
        return Ok(Semidefinite::Undetermined { uncovered: negative.len(), residual });
    }
    if negative.is_empty() {
        return Ok(Semidefinite::NonNegativeWeights);
    }
    let budget: Vec<f64> = tol.iter().zip(&deficit).map(|(t, d)| t - d).collect();
    let mut groups = initial_groups(l, &negative);
    for round in 0..ROUNDS {
        opts.cancelled()?;
        let sets: Vec<Vec<u32>> = groups.par_iter().map(|g| vertices(l, g)).collect();
        // how many groups hold each positive weight (both endpoints in the group)
        let count: Vec<AtomicU32> = (0..l.nnz()).map(|_| AtomicU32::new(0)).collect();
        sets.par_iter().for_each(|s| {
            for_each_positive(l, s, |k, _, _| {
                count[k].fetch_add(1, Ordering::Relaxed);
            })
        });
        let count: Vec<u32> = count.into_iter().map(AtomicU32::into_inner).collect();
        let share = |k: usize| l.data[k] / count[k] as f64;
        // each group may take its share of every vertex's budget (a vertex may lie in all)
        let shift = |v: u32| budget[v as usize] / groups.len() as f64;
        let passed: Vec<bool> = groups
            .par_iter()
            .zip(&sets)
            .map(|(g, s)| !opts.is_cancelled() && s.len() <= MAX_GROUP && covered(l, g, s, &share, &shift))
            .collect();
        opts.cancelled()?;
        let failing: Vec<usize> = (0..groups.len()).filter(|&g| !passed[g]).collect();
        if failing.is_empty() {
            let largest = sets.iter().map(Vec::len).max().unwrap_or(0);
            return Ok(Semidefinite::LocalCertificate { groups: groups.len(), largest });
        }
        // a failing group: is the principal submatrix on its vertices indefinite?
        let found = failing.par_iter().find_map_first(|&g| {
            let s = &sets[g];
            if s.len() > MAX_GROUP {
                return None;
            }
            witness(l, s, tol).map(|rayleigh| Semidefinite::Indefinite {
                rayleigh,
                support: s.len(),
                vertex: groups[g].edges[0].0 as u32,
            })
        });
        if let Some(indefinite) = found {
            return Ok(indefinite);
        }
        if round + 1 == ROUNDS || failing.iter().all(|&g| sets[g].len() > MAX_GROUP) {
            let uncovered = failing.iter().map(|&g| groups[g].edges.len()).sum();
            return Ok(Semidefinite::Undetermined { uncovered, residual });
        }
        groups = merge_failing(l.n, groups, &sets, &failing);
    }
    unreachable!("the last round returns")
}

/// Rounds of growing the groups that could not be certified.
const ROUNDS: usize = 6;

/// `f(k, i, j)` for every positive weight at CSR position `k` between two vertices `i < j`
/// of the sorted set `s`.
fn for_each_positive(l: &CsrRef, s: &[u32], mut f: impl FnMut(usize, u32, u32)) {
    for &i in s {
        let iu = i as usize;
        for k in l.indptr[iu]..l.indptr[iu + 1] {
            let j = l.indices[k];
            if j > i && l.data[k] > 0.0 && s.binary_search(&j).is_ok() {
                f(k, i, j);
            }
        }
    }
}

/// Whether the matrix of `group` on the vertex set `s` plus `diag(shift(v))` is positive
/// definite: its negative weights in full, the positive weights among `s` by their
/// `share(k)`.
fn covered(l: &CsrRef, group: &Group, s: &[u32], share: &(impl Fn(usize) -> f64 + Sync), shift: &(impl Fn(u32) -> f64 + Sync)) -> bool {
    let n = s.len();
    let at = |v: u32| s.binary_search(&v).expect("in the set");
    let mut a = vec![0.0; n * n];
    let mut add = |i: usize, j: usize, w: f64| {
        a[i * n + i] += w;
        a[j * n + j] += w;
        a[i * n + j] -= w;
        a[j * n + i] -= w;
    };
    for &(i, k) in &group.edges {
        add(at(i as u32), at(l.indices[k]), l.data[k]);
    }
    for_each_positive(l, s, |k, i, j| add(at(i), at(j), share(k)));
    let shift: Vec<f64> = s.iter().map(|&v| shift(v)).collect();
    cholesky(&mut a, n, &shift).is_ok()
}

/// Negative weights grouped: those sharing a vertex together (connected components of
/// the graph of negative edges), split into pieces of at most [`GROUP_EDGES`] edges in
/// breadth-first order. Deterministic.
fn initial_groups(l: &CsrRef, negative: &[(usize, usize)]) -> Vec<Group> {
    let mut by_vertex: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (e, &(i, k)) in negative.iter().enumerate() {
        by_vertex.entry(i as u32).or_default().push(e);
        by_vertex.entry(l.indices[k]).or_default().push(e);
    }
    let mut seen = vec![false; negative.len()];
    let mut groups = Vec::new();
    for start in 0..negative.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut queue = std::collections::VecDeque::from([start]);
        let mut current = Vec::new();
        while let Some(e) = queue.pop_front() {
            current.push(negative[e]);
            if current.len() == GROUP_EDGES {
                groups.push(Group { edges: std::mem::take(&mut current), ring: 1 });
            }
            let (i, k) = negative[e];
            for v in [i as u32, l.indices[k]] {
                for &f in &by_vertex[&v] {
                    if !seen[f] {
                        seen[f] = true;
                        queue.push_back(f);
                    }
                }
            }
        }
        if !current.is_empty() {
            groups.push(Group { edges: current, ring: 1 });
        }
    }
    groups
}

/// The groups after a round: every failing group merged with all groups whose vertex
/// sets overlap its own (union-find), one ring wider; the others as they were.
fn merge_failing(n: usize, groups: Vec<Group>, sets: &[Vec<u32>], failing: &[usize]) -> Vec<Group> {
    let mut parent: Vec<usize> = (0..groups.len()).collect();
    fn find(parent: &mut [usize], mut g: usize) -> usize {
        while parent[g] != g {
            parent[g] = parent[parent[g]];
            g = parent[g];
        }
        g
    }
    let mut holders: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (g, s) in sets.iter().enumerate() {
        for &v in s {
            holders[v as usize].push(g as u32);
        }
    }
    let mut grows = vec![false; groups.len()];
    for &f in failing {
        grows[f] = true;
        for &v in &sets[f] {
            for &h in &holders[v as usize] {
                let (a, b) = (find(&mut parent, f), find(&mut parent, h as usize));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut merged: BTreeMap<usize, (Group, bool)> = BTreeMap::new();
    for (g, group) in groups.into_iter().enumerate() {
        let root = find(&mut parent, g);
        match merged.get_mut(&root) {
            Some((m, grow)) => {
                m.edges.extend(group.edges);
                m.ring = m.ring.max(group.ring);
                *grow |= grows[g];
            }
            None => {
                merged.insert(root, (group, grows[g]));
            }
        }
    }
    merged
        .into_values()
        .map(|(mut g, grow)| {
            g.ring += grow as usize;
            g
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::Csr;

    /// The Laplacian of a weighted graph on `n` vertices.
    fn graph(n: usize, edges: &[(u32, u32, f64)]) -> Csr {
        let mut rows: Vec<BTreeMap<u32, f64>> = vec![BTreeMap::new(); n];
        for &(i, j, w) in edges {
            *rows[i as usize].entry(j).or_default() += w;
            *rows[j as usize].entry(i).or_default() += w;
            *rows[i as usize].entry(i).or_default() -= w;
            *rows[j as usize].entry(j).or_default() -= w;
        }
        let mut csr = Csr { n, indptr: vec![0], indices: vec![], data: vec![] };
        for r in rows {
            for (j, v) in r {
                csr.indices.push(j);
                csr.data.push(v);
            }
            csr.indptr.push(csr.indices.len());
        }
        csr
    }

    #[test]
    fn a_small_negative_weight_inside_a_strong_cycle_is_covered() {
        // a ring of 8 vertices with unit weights and one chord of weight -0.1
        let mut edges: Vec<(u32, u32, f64)> = (0..8).map(|i| (i, (i + 1) % 8, 1.0)).collect();
        edges.push((0, 4, -0.1));
        let opts = Options::default();
        let answer = negative_semidefinite(&graph(8, &edges), &[1e-12; 8], &opts).unwrap();
        assert!(matches!(answer, Semidefinite::LocalCertificate { .. }), "{answer:?}");
    }

    #[test]
    fn a_large_negative_weight_is_a_witnessed_indefiniteness() {
        let mut edges: Vec<(u32, u32, f64)> = (0..8).map(|i| (i, (i + 1) % 8, 1.0)).collect();
        edges.push((0, 4, -5.0)); // effective resistance 2 between 0 and 4: 5 * 2 > 1
        let answer = negative_semidefinite(&graph(8, &edges), &[1e-12; 8], &Options::default()).unwrap();
        let Semidefinite::Indefinite { rayleigh, .. } = answer else { panic!("{answer:?}") };
        assert!(rayleigh < -1e-3);
    }

    #[test]
    fn non_negative_weights_need_no_factorisation() {
        let edges = [(0, 1, 1.0), (1, 2, 0.0), (2, 0, 3.0)];
        let answer = negative_semidefinite(&graph(3, &edges), &[1e-12; 3], &Options::default()).unwrap();
        assert_eq!(answer, Semidefinite::NonNegativeWeights);
    }

    #[test]
    fn rows_that_do_not_sum_to_zero_are_not_guessed() {
        let mut l = graph(3, &[(0, 1, 1.0), (1, 2, -0.1)]);
        l.data[0] += 1.0; // L[0, 0] grows: a positive row sum, -L has a negative residual
        let answer = negative_semidefinite(&l, &[1e-12; 3], &Options::default()).unwrap();
        assert!(matches!(answer, Semidefinite::Undetermined { .. }), "{answer:?}");
    }

    /// Two components: the 8-ring with a chord of `chord` and a triangle of weight `big`.
    fn ring_and_triangle(chord: f64, big: f64) -> Csr {
        let mut edges: Vec<(u32, u32, f64)> = (0..8).map(|i| (i, (i + 1) % 8, 1.0)).collect();
        edges.push((0, 4, chord));
        edges.extend([(8, 9, big), (9, 10, big), (10, 8, big)]);
        graph(11, &edges)
    }

    /// `rtol` times each row's diagonal: the tolerances of `tetlap.check`.
    fn row_tolerances(l: &Csr, rtol: f64) -> Vec<f64> {
        (0..l.n).map(|i| rtol * entry(&CsrRef::from(l), i, i as u32).abs()).collect()
    }

    #[test]
    fn tolerances_per_row_do_not_let_a_large_component_hide_a_small_one() {
        // the ring with chord -0.6 is indefinite (effective resistance 2 between 0 and 4:
        // 0.6 * 2 > 1), which a tolerance at the triangle's scale hides
        let l = ring_and_triangle(-0.6, 1e12);
        let uniform = vec![1e-9 * 2e12; 11]; // 1e-9 max|L|: the triangle's scale
        let answer = negative_semidefinite(&l, &uniform, &Options::default()).unwrap();
        assert!(!matches!(answer, Semidefinite::Indefinite { .. }), "{answer:?}");
        let answer = negative_semidefinite(&l, &row_tolerances(&l, 1e-9), &Options::default()).unwrap();
        assert!(matches!(answer, Semidefinite::Indefinite { rayleigh, vertex, .. } if rayleigh < 0.0 && vertex < 8), "{answer:?}");
        // the covered ring (chord -0.1) is certified whatever the triangle's scale
        for big in [1e-12, 1.0, 1e12] {
            let l = ring_and_triangle(-0.1, big);
            let answer = negative_semidefinite(&l, &row_tolerances(&l, 1e-9), &Options::default()).unwrap();
            assert!(matches!(answer, Semidefinite::LocalCertificate { .. }), "{big}: {answer:?}");
        }
    }

    #[test]
    fn a_zero_row_and_column_is_semidefinite_with_a_zero_shift() {
        let mut a = vec![2.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 2.0];
        assert_eq!(cholesky(&mut a, 3, &[0.0; 3]), Ok(()));
        // a zero pivot with an entry below it is not
        let mut a = vec![0.0, 1.0, 1.0, 2.0];
        assert_eq!(cholesky(&mut a, 2, &[0.0; 2]), Err(0));
    }

    #[test]
    fn tolerances_are_one_finite_non_negative_value_per_vertex() {
        let l = graph(3, &[(0, 1, 1.0), (1, 2, 1.0)]);
        for tol in [vec![1e-12; 2], vec![1e-12, -1e-12, 0.0], vec![f64::NAN, 0.0, 0.0]] {
            let err = negative_semidefinite(&l, &tol, &Options::default()).unwrap_err();
            assert!(matches!(err, Error::Shape { .. }), "{err:?}");
        }
    }
}
