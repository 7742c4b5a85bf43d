//! [`LuFactors`]: solves with the sparse factors `P_r A P_c = L U` made elsewhere.

use super::factor::permutation;
use crate::error::{Error, Result};
use crate::options::Options;
use crate::sparse::CsrRef;
use faer::sparse::linalg::triangular_solve::{solve_unit_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};

/// The factors of a sparse LU factorization `P_r A P_c = L U` of an `n x n` matrix, made
/// elsewhere (such as SciPy's SuperLU, run where it can be abandoned), for solves: `L` unit
/// lower triangular, `U` upper triangular with a non-zero diagonal, and the row and column
/// permutations as SuperLU gives them (`P_r` moves row `i` of `A` to row `rows[i]`, `P_c`
/// column `j` to column `columns[j]`).
///
/// ```
/// use tetlap::solve::LuFactors;
/// use tetlap::{CsrRef, Options};
/// // A = [[0, 2], [4, 1]]: swap the rows, then L = I, U = [[4, 1], [0, 2]]
/// let l = CsrRef { n: 2, indptr: &[0, 1, 2], indices: &[0, 1], data: &[1.0, 1.0] };
/// // U by columns: column 0 holds (0, 4); column 1 holds (0, 1) and (1, 2)
/// let u = CsrRef { n: 2, indptr: &[0, 1, 3], indices: &[0, 0, 1], data: &[4.0, 1.0, 2.0] };
/// let f = LuFactors::new(l, u, &[1, 0], &[0, 1])?;
/// let mut x = [4.0, 10.0]; // b = A (2, 2)
/// f.solve(&mut x, &Options::default())?;
/// assert_eq!(x, [2.0, 2.0]);
/// # Ok::<(), tetlap::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct LuFactors {
    l: Csc,
    u: Csc,
    rows: Vec<usize>,
    columns: Vec<usize>,
}

/// A square matrix stored by columns.
#[derive(Debug, Clone)]
struct Csc {
    indptr: Vec<usize>,
    indices: Vec<usize>,
    data: Vec<f64>,
}

impl Csc {
    /// `m` (its columns given as the rows of a CSR layout) checked, with its diagonal the
    /// first (`lower`) or the last stored entry of every column and nothing on the other
    /// side of it.
    fn new(m: CsrRef<'_>, n: usize, lower: bool, what: &'static str) -> Result<Csc> {
        m.check_shape(n, what)?;
        for j in 0..n {
            let column = &m.indices[m.indptr[j]..m.indptr[j + 1]];
            let diagonal = if lower { column.first() } else { column.last() };
            if diagonal != Some(&(j as u32)) {
                let side = if lower { "lower" } else { "upper" };
                return Err(Error::Shape {
                    what: format!("{what}: column {j} must hold its diagonal entry and only entries of the {side} triangle"),
                });
            }
        }
        Ok(Csc { indptr: m.indptr.to_vec(), indices: m.indices.iter().map(|&i| i as usize).collect(), data: m.data.to_vec() })
    }

    fn view(&self) -> SparseColMatRef<'_, usize, f64> {
        let n = self.indptr.len() - 1;
        SparseColMatRef::new(SymbolicSparseColMatRef::new_checked(n, n, &self.indptr, None, &self.indices), &self.data)
    }
}

impl LuFactors {
    /// The factors checked ([`Error::Shape`] naming the first fault): `l` and `u` are
    /// `n x n` and given by columns, as the CSR arrays of their transposes (strictly
    /// ascending indices in every column); every column of `l` starts with its diagonal
    /// entry (read as 1), every column of `u` ends with its; `rows` and `columns` are
    /// permutations of `0..n`.
    pub fn new(l: CsrRef<'_>, u: CsrRef<'_>, rows: &[u32], columns: &[u32]) -> Result<Self> {
        let n = l.n;
        Ok(LuFactors {
            l: Csc::new(l, n, true, "the factor L")?,
            u: Csc::new(u, n, false, "the factor U")?,
            rows: permutation(rows, n)?,
            columns: permutation(columns, n)?,
        })
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
        let mut work = vec![0.0; n];
        for b in rhs.chunks_exact_mut(n) {
            // P_r b, then L U z = P_r b, then x = P_c z
            for (i, &r) in self.rows.iter().enumerate() {
                work[r] = b[i];
            }
            let z = MatMut::from_column_major_slice_mut(&mut work, n, 1);
            solve_unit_lower_triangular_in_place(self.l.view(), Conj::No, z, Par::Seq);
            let z = MatMut::from_column_major_slice_mut(&mut work, n, 1);
            solve_upper_triangular_in_place(self.u.view(), Conj::No, z, Par::Seq);
            for (x, &c) in b.iter_mut().zip(&self.columns) {
                *x = work[c];
            }
            opts.cancelled()?;
        }
        Ok(())
    }

    /// The matrix order `n`.
    pub fn n(&self) -> usize {
        self.rows.len()
    }

    /// `L` and `U`, each by columns as `(indptr, indices, data)` (the CSR arrays of its
    /// transpose).
    pub fn factors(&self) -> [(&[usize], &[usize], &[f64]); 2] {
        [&self.l, &self.u].map(|m| (m.indptr.as_slice(), m.indices.as_slice(), m.data.as_slice()))
    }
}
