//! [`Factorization`]: faer's sparse `LL^T` / `LDL^T` behind a small, checked API.

use crate::error::{Error, Result};
use crate::options::Options;
use crate::sparse::CsrRef;
use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LdltRef, LltRef, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::linalg::cholesky::ldlt::factor::LdltError;
use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::FaerError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use std::ops::DerefMut;

/// Which factorization.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// `A = P L L^T P^T`: `A` must be positive definite, else
    /// [`Error::NotPositiveDefinite`] names the row whose pivot failed. Its success proves
    /// that `A` is positive definite (up to the rounding of a backward-stable method).
    Cholesky,
    /// `A = P L D L^T P^T` with diagonal `D`, without pivoting: any symmetric matrix whose
    /// leading pivots (in the ordering) are non-zero, else [`Error::Singular`]. Without
    /// pivoting it is not backward stable for indefinite matrices: check what it solves.
    Ldlt,
}

/// The fill-reducing ordering of the symbolic analysis.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ordering {
    /// faer's approximate minimum degree.
    Amd,
    /// No reordering.
    Identity,
    /// `order[k]` is the row eliminated `k`-th (a permutation of `0..n`), such as a nested
    /// dissection computed by METIS.
    Custom(Vec<u32>),
}

/// The signs of the pivots `D` of an `LDL^T` factorization: by Sylvester's law of inertia,
/// the numbers of negative, zero and positive eigenvalues of the factorized matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inertia {
    /// Negative pivots.
    pub negative: usize,
    /// Zero pivots.
    pub zero: usize,
    /// Positive pivots.
    pub positive: usize,
}

/// The symbolic analysis of a sparse symmetric pattern (fill-reducing ordering,
/// elimination tree, supernodes): the half of a [`Factorization`] that depends on the
/// pattern only. [`Analysis::numeric`] factorizes values on it into a caller's slice, a pure
/// function of its inputs (a caller may run it where it can be abandoned, such as a child
/// process), and [`Factorization::from_parts`] takes the result.
///
/// Only the upper triangle of the CSR input is read (for a symmetric matrix, the lower
/// triangle of its CSC form); the caller checks symmetry.
#[derive(Debug)]
pub struct Analysis {
    method: Method,
    indptr: Vec<usize>,
    indices: Vec<usize>,
    symbolic: SymbolicCholesky<usize>,
}

/// The scratch memory of [`Analysis::numeric`] ([`Analysis::workspace`]), allocated ahead
/// so that the factorization itself allocates nothing large.
pub struct Workspace(MemBuffer);

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Workspace")
    }
}

/// A sparse symmetric factorization of an `n x n` matrix, reusable for many right-hand
/// sides and, through [`Factorization::refactor`], for new values on the same pattern.
///
/// Only the upper triangle of the CSR input is read (for a symmetric matrix, the lower
/// triangle of its CSC form); the caller checks symmetry. The factor's values live in a
/// `V` (a `Vec<f64>` unless the caller gives other storage to
/// [`Factorization::from_parts`], such as memory shared with another process).
///
/// ```
/// use tetlap::solve::{Factorization, Method, Ordering};
/// use tetlap::{CsrRef, Options};
/// // the 1-D Laplacian [[2, -1, 0], [-1, 2, -1], [0, -1, 2]]
/// let (indptr, indices) = ([0, 2, 5, 7], [0, 1, 0, 1, 2, 1, 2]);
/// let data = [2.0, -1.0, -1.0, 2.0, -1.0, -1.0, 2.0];
/// let a = CsrRef { n: 3, indptr: &indptr, indices: &indices, data: &data };
/// let opts = Options::default();
/// let mut f = Factorization::new(a, Method::Cholesky, &Ordering::Amd, &opts)?;
/// let mut x = [1.0, 0.0, 1.0];
/// f.solve(&mut x, &opts)?;
/// assert!(x.iter().all(|v| (v - 1.0).abs() < 1e-14));
/// // the same pattern, new values: 2 A
/// let doubled: Vec<f64> = data.iter().map(|v| 2.0 * v).collect();
/// f.refactor(CsrRef { data: &doubled, ..a }, &opts)?;
/// let mut y = [1.0, 0.0, 1.0];
/// f.solve(&mut y, &opts)?;
/// assert!(y.iter().all(|v| (v - 0.5).abs() < 1e-14));
/// // the same in two steps: the analysis, then the values into storage of the caller's
/// let (analysis, mut values) = f.into_parts();
/// analysis.numeric(&data, &mut values, &mut analysis.workspace()?)?;
/// let f = Factorization::from_parts(analysis, &data, values)?;
/// let mut z = [1.0, 0.0, 1.0];
/// f.solve(&mut z, &opts)?;
/// assert_eq!(z, x);
/// # Ok::<(), tetlap::Error>(())
/// ```
#[derive(Debug)]
pub struct Factorization<V = Vec<f64>> {
    analysis: Analysis,
    values: V,
    /// [`Factorization::smallest_pivot`].
    smallest: (usize, f64),
}

fn faer_error(e: FaerError) -> Error {
    match e {
        FaerError::OutOfMemory => Error::OutOfMemory { what: "the sparse factorization" },
        _ => Error::OutOfMemory { what: "the sparse factorization's indices" },
    }
}

/// A `MemBuffer` of `req`, or [`Error::OutOfMemory`].
fn buffer(req: StackReq) -> Result<MemBuffer> {
    MemBuffer::try_new(req).map_err(|_| Error::OutOfMemory { what: "the factorization's workspace" })
}

impl Analysis {
    /// The symbolic analysis (ordering, elimination tree, supernodes) of the pattern of `a`
    /// (any square CSR layout: [`CsrRef::check_shape`]; its values are not read).
    pub fn new(a: CsrRef<'_>, method: Method, ordering: &Ordering, opts: &Options) -> Result<Self> {
        opts.check()?;
        a.check_shape(a.n, "the matrix to factorize")?;
        let n = a.n;
        let indptr = a.indptr.to_vec();
        let indices: Vec<usize> = a.indices.iter().map(|&j| j as usize).collect();
        let (forward, inverse);
        let ordering = match ordering {
            Ordering::Amd => SymmetricOrdering::Amd,
            // (faer's own Identity ordering reads the pattern as an upper triangle: the
            // identity is passed as a permutation instead)
            Ordering::Identity | Ordering::Custom(_) => {
                forward = match ordering {
                    Ordering::Custom(order) => permutation(order, n)?,
                    _ => (0..n).collect(),
                };
                let mut inv = vec![0usize; n];
                for (k, &i) in forward.iter().enumerate() {
                    inv[i] = k;
                }
                inverse = inv;
                SymmetricOrdering::Custom(PermRef::new_checked(&forward, &inverse, n))
            }
        };
        opts.cancelled()?;
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &indptr, None, &indices);
        let symbolic = factorize_symbolic_cholesky(pattern, Side::Lower, ordering, CholeskySymbolicParams::default())
            .map_err(faer_error)?;
        Ok(Analysis { method, indptr, indices, symbolic })
    }

    /// [`Error::Shape`] unless `a` has the analysed pattern (the same `indptr` and
    /// `indices`) and one value per stored entry.
    pub fn check_pattern(&self, a: CsrRef<'_>) -> Result<()> {
        let same = a.n + 1 == self.indptr.len()
            && a.indptr == self.indptr.as_slice()
            && a.indices.len() == self.indices.len()
            && a.indices.iter().zip(&self.indices).all(|(&a, &b)| a as usize == b);
        if !same {
            return Err(Error::Shape {
                what: "refactor: the matrix has another sparsity pattern than the factorized one \
                       (factorize it anew)"
                    .into(),
            });
        }
        if a.data.len() != self.indices.len() {
            return Err(Error::Shape { what: "refactor: one value per stored entry is needed".into() });
        }
        Ok(())
    }

    /// The number of stored values of the factor `L` (its fill): the length of the
    /// `values` of [`Analysis::numeric`].
    pub fn values_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// The scratch memory of [`Analysis::numeric`].
    pub fn workspace(&self) -> Result<Workspace> {
        let req = match self.method {
            Method::Cholesky => self.symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
            Method::Ldlt => self.symbolic.factorize_numeric_ldlt_scratch::<f64>(Par::Seq, Default::default()),
        };
        buffer(req).map(Workspace)
    }

    /// The numeric factorization of the values `data` (one per stored entry of the analysed
    /// pattern, in its order) into `values` ([`Analysis::values_len`] long, else
    /// [`Error::Shape`]), on one thread, reading nothing but its arguments. Errors:
    /// [`Error::NotPositiveDefinite`] (Cholesky) or [`Error::Singular`] (`LDL^T`) naming
    /// the row of the failed pivot; `values` then holds no usable factor.
    pub fn numeric(&self, data: &[f64], values: &mut [f64], workspace: &mut Workspace) -> Result<()> {
        let n = self.n();
        if data.len() != self.indices.len() || values.len() != self.values_len() {
            return Err(Error::Shape {
                what: format!(
                    "the numeric factorization takes {} values and writes {}, given {} and {}",
                    self.indices.len(),
                    self.values_len(),
                    data.len(),
                    values.len()
                ),
            });
        }
        let a = SparseColMatRef::new(SymbolicSparseColMatRef::new_checked(n, n, &self.indptr, None, &self.indices), data);
        let stack = MemStack::new(&mut workspace.0);
        // faer counts the failed pivot from 1 in the simplicial form; clamped either way
        let row = |index: usize| {
            let k = index.saturating_sub(1).min(n.saturating_sub(1));
            self.symbolic.perm().map_or(k, |p| p.arrays().0[k])
        };
        match self.method {
            Method::Cholesky => self
                .symbolic
                .factorize_numeric_llt(values, a, Side::Lower, LltRegularization::default(), Par::Seq, stack, Default::default())
                .map(|_| ())
                .map_err(|LltError::NonPositivePivot { index }| Error::NotPositiveDefinite { row: row(index) }),
            Method::Ldlt => self
                .symbolic
                .factorize_numeric_ldlt(values, a, Side::Lower, LdltRegularization::default(), Par::Seq, stack, Default::default())
                .map(|_| ())
                .map_err(|LdltError::ZeroPivot { index }| Error::Singular { row: row(index) }),
        }
    }

    /// The matrix order `n`.
    pub fn n(&self) -> usize {
        self.indptr.len() - 1
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.method
    }

    /// Whether faer chose the supernodal (dense blocks) rather than the simplicial form.
    pub fn supernodal(&self) -> bool {
        matches!(self.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }

    /// The pivots of the factor `values`: see [`Factorization::pivots`].
    fn pivots(&self, values: &[f64]) -> Vec<f64> {
        let square = |d: f64| if self.method == Method::Cholesky { d * d } else { d };
        match self.symbolic.raw() {
            // the diagonal entry leads every column of the simplicial factor
            SymbolicCholeskyRaw::Simplicial(s) => {
                s.col_ptr()[..self.n()].iter().map(|&start| square(values[start])).collect()
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                // LL^T and LDL^T share the supernodal layout; the diagonal of each block
                let factor = SupernodalLdltRef::new(s, values);
                (0..s.n_supernodes())
                    .flat_map(|i| {
                        let block = factor.supernode(i).val();
                        (0..block.ncols()).map(move |j| square(block[(j, j)]))
                    })
                    .collect()
            }
        }
    }

    /// [`Factorization::smallest_pivot`] of the factor `values` of `data`: each pivot
    /// against its row's diagonal entry (rows with a zero diagonal left out).
    fn smallest_pivot(&self, data: &[f64], values: &[f64]) -> (usize, f64) {
        let mut diagonal = vec![0.0f64; self.n()];
        for (i, range) in self.indptr.windows(2).enumerate() {
            for (&j, &v) in self.indices[range[0]..range[1]].iter().zip(&data[range[0]..range[1]]) {
                if i == j {
                    diagonal[i] += v;
                }
            }
        }
        let mut smallest = (0, f64::INFINITY);
        for (k, d) in self.pivots(values).into_iter().enumerate() {
            let i = self.symbolic.perm().map_or(k, |p| p.arrays().0[k]);
            let relative = d.abs() / diagonal[i].abs();
            if diagonal[i] != 0.0 && !(relative >= smallest.1) {
                smallest = (i, relative);
            }
        }
        smallest
    }
}

impl Factorization {
    /// The symbolic analysis ([`Analysis::new`]) and the numeric factorization of `a` (any
    /// square CSR layout: [`CsrRef::check_shape`]).
    pub fn new(a: CsrRef<'_>, method: Method, ordering: &Ordering, opts: &Options) -> Result<Self> {
        let analysis = Analysis::new(a, method, ordering, opts)?;
        let mut values = Vec::new();
        values.try_reserve_exact(analysis.values_len()).map_err(|_| Error::OutOfMemory { what: "the factor" })?;
        values.resize(analysis.values_len(), 0.0);
        let mut workspace = analysis.workspace()?;
        opts.cancelled()?;
        analysis.numeric(a.data, &mut values, &mut workspace)?;
        Factorization::from_parts(analysis, a.data, values)
    }
}

impl<V: DerefMut<Target = [f64]>> Factorization<V> {
    /// The factorization of `data` (one value per stored entry of the analysed pattern)
    /// whose factor `values` [`Analysis::numeric`] computed ([`Error::Shape`] if a length
    /// differs). Values computed otherwise make wrong solves, never undefined behaviour.
    pub fn from_parts(analysis: Analysis, data: &[f64], values: V) -> Result<Self> {
        if data.len() != analysis.indices.len() || values.len() != analysis.values_len() {
            return Err(Error::Shape {
                what: format!(
                    "a factorization takes {} values and a factor of {}, given {} and {}",
                    analysis.indices.len(),
                    analysis.values_len(),
                    data.len(),
                    values.len()
                ),
            });
        }
        let smallest = analysis.smallest_pivot(data, &values);
        Ok(Factorization { analysis, values, smallest })
    }

    /// The analysis and the factor's storage, for [`Analysis::numeric`] of new values into
    /// the same storage.
    pub fn into_parts(self) -> (Analysis, V) {
        (self.analysis, self.values)
    }

    /// The factor's stored values (faer's layout), in their storage.
    pub fn values(&self) -> &V {
        &self.values
    }

    /// The symbolic analysis.
    pub fn analysis(&self) -> &Analysis {
        &self.analysis
    }

    /// Factorizes new values of the same pattern (the same `indptr` and `indices`, else
    /// [`Error::Shape`]), reusing the symbolic analysis and the factor's storage. On an
    /// error the factorization keeps no usable values: refactor again before solving.
    pub fn refactor(&mut self, a: CsrRef<'_>, opts: &Options) -> Result<()> {
        opts.check()?;
        self.refactor_with(a, |analysis, values| {
            let mut workspace = analysis.workspace()?;
            opts.cancelled()?;
            analysis.numeric(a.data, values, &mut workspace)
        })
    }

    /// [`Factorization::refactor`] whose numeric step is `numeric(analysis, values)`: the
    /// caller's way to run [`Analysis::numeric`] of `a.data` (elsewhere, or into other
    /// storage, which it may put in place of `values`).
    pub fn refactor_with(&mut self, a: CsrRef<'_>, numeric: impl FnOnce(&Analysis, &mut V) -> Result<()>) -> Result<()> {
        self.analysis.check_pattern(a)?;
        numeric(&self.analysis, &mut self.values)?;
        if self.values.len() != self.analysis.values_len() {
            return Err(Error::Shape {
                what: format!("a factor of {} values was given for {}", self.values.len(), self.analysis.values_len()),
            });
        }
        self.smallest = self.analysis.smallest_pivot(a.data, &self.values);
        Ok(())
    }

    /// `(row, |pivot| / |a_row,row|)` of the pivot that is smallest against its row's
    /// diagonal entry (a ratio invariant under symmetric diagonal scaling; rows with a zero
    /// diagonal are left out, `(0, inf)` if all are). For a positive definite matrix these
    /// ratios are the pivots of the Jacobi-scaled matrix, which lie between its smallest
    /// and largest eigenvalue, so a ratio `r` proves its condition number `>= 1 / r`: a
    /// ratio of a few units in the last place is a matrix singular to working precision.
    pub fn smallest_pivot(&self) -> (usize, f64) {
        self.smallest
    }

    /// Solves `A X = B` in place: `rhs` holds `B`, `n x k` column-major (`k` columns of `n`
    /// values one after the other), and receives `X`.
    pub fn solve(&self, rhs: &mut [f64], opts: &Options) -> Result<()> {
        opts.check()?;
        let n = self.n();
        if n == 0 || rhs.len() % n != 0 {
            return Err(Error::Shape {
                what: format!("the right-hand sides hold {} values, not a multiple of n = {n}", rhs.len()),
            });
        }
        let k = rhs.len() / n;
        let symbolic = &self.analysis.symbolic;
        let mut mem = buffer(symbolic.solve_in_place_scratch::<f64>(k, Par::Seq))?;
        let stack = MemStack::new(&mut mem);
        let rhs = MatMut::from_column_major_slice_mut(rhs, n, k);
        match self.method() {
            Method::Cholesky => {
                LltRef::new(symbolic, &self.values).solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack)
            }
            Method::Ldlt => {
                LdltRef::new(symbolic, &self.values).solve_in_place_with_conj(Conj::No, rhs, Par::Seq, stack)
            }
        }
        Ok(())
    }

    /// The signs of the pivots: for [`Method::Ldlt`] the entries of `D`; a [`Method::Cholesky`]
    /// factorization exists only for positive definite matrices (all `n` positive).
    pub fn inertia(&self) -> Inertia {
        let mut inertia = Inertia { negative: 0, zero: 0, positive: 0 };
        if self.method() == Method::Cholesky {
            inertia.positive = self.n();
            return inertia;
        }
        for d in self.pivots() {
            if d < 0.0 {
                inertia.negative += 1
            } else if d > 0.0 {
                inertia.positive += 1
            } else {
                inertia.zero += 1
            }
        }
        inertia
    }

    /// The pivots in the order of elimination: the entries of `D` for [`Method::Ldlt`], the
    /// squared diagonal of `L` for [`Method::Cholesky`]. A pivot tiny against the matrix's
    /// diagonal shows a matrix singular to working precision: for a positive definite
    /// matrix every pivot lies between its smallest and its largest eigenvalue.
    pub fn pivots(&self) -> Vec<f64> {
        self.analysis.pivots(&self.values)
    }

    /// The matrix order `n`.
    pub fn n(&self) -> usize {
        self.analysis.n()
    }

    /// The method.
    pub fn method(&self) -> Method {
        self.analysis.method()
    }

    /// The stored values of the factor `L` (its fill).
    pub fn factor_entries(&self) -> usize {
        self.values.len()
    }

    /// Whether faer chose the supernodal (dense blocks) rather than the simplicial form.
    pub fn supernodal(&self) -> bool {
        self.analysis.supernodal()
    }
}

/// `order` as `usize` indices after checking it is a permutation of `0..n`.
pub(super) fn permutation(order: &[u32], n: usize) -> Result<Vec<usize>> {
    let mut seen = vec![false; n];
    if order.len() != n {
        return Err(Error::Shape { what: format!("the ordering has {} entries, the matrix {n} rows", order.len()) });
    }
    for (k, &i) in order.iter().enumerate() {
        let i = i as usize;
        if i >= n || seen[i] {
            return Err(Error::Shape { what: format!("the ordering is not a permutation of 0..{n} (entry {k} is {i})") });
        }
        seen[i] = true;
    }
    Ok(order.iter().map(|&i| i as usize).collect())
}
