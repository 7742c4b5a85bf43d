//! The outputs: compressed sparse row matrices, masses and unsummed coordinate triplets,
//! and a borrowed CSR matrix for inputs.

use crate::error::{Error, Result};

/// A square `n x n` matrix in compressed sparse row form: sorted column indices per row,
/// no duplicates. Row `i` holds `indices[indptr[i]..indptr[i+1]]` and the matching `data`.
#[derive(Debug, Clone, PartialEq)]
pub struct Csr {
    /// Number of rows and columns.
    pub n: usize,
    /// Row starts, length `n + 1`.
    pub indptr: Vec<usize>,
    /// Column index of every stored entry, sorted within each row.
    pub indices: Vec<u32>,
    /// Value of every stored entry.
    pub data: Vec<f64>,
}

impl Csr {
    /// The strictly upper triangle: edges `(i, j)`, `i < j`, in CSR order, and values.
    pub fn upper_triangle(&self) -> (Vec<[u32; 2]>, Vec<f64>) {
        let l = self;
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

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.data.len()
    }

    /// Entry `(i, j)`, zero when not stored.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let row = self.indptr[i]..self.indptr[i + 1];
        match self.indices[row.clone()].binary_search(&(j as u32)) {
            Ok(k) => self.data[row.start + k],
            Err(_) => 0.0,
        }
    }
}

/// Unsummed coordinate triplets of an `n x n` matrix: entry `k` adds `vals[k]` at
/// `(rows[k], cols[k])`; repeated positions add up.
#[derive(Debug, Clone, PartialEq)]
pub struct Coo {
    /// Number of rows and columns.
    pub n: usize,
    /// Row of every triplet.
    pub rows: Vec<u32>,
    /// Column of every triplet.
    pub cols: Vec<u32>,
    /// Value of every triplet.
    pub vals: Vec<f64>,
}

/// A mass matrix: lumped (a diagonal, one value per vertex) or consistent (sparse).
#[derive(Debug, Clone, PartialEq)]
pub enum Mass {
    /// Diagonal entries, one per vertex (0 for unreferenced vertices).
    Lumped(Vec<f64>),
    /// The consistent P1 mass on the pattern "edges + diagonal".
    Consistent(Csr),
}

/// A borrowed square `n x n` sparse matrix in compressed sparse row form: row `i` holds the
/// columns `indices[indptr[i]..indptr[i + 1]]`, strictly ascending, and their `data`.
/// Any pattern: entries outside the mesh's edges and diagonal meet structural zeros of the
/// operators and do not contribute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsrRef<'a> {
    /// Number of rows and columns (the mesh's vertex count).
    pub n: usize,
    /// Row starts, length `n + 1`, from 0 to `indices.len()`.
    pub indptr: &'a [usize],
    /// Column of every stored entry, strictly ascending within each row.
    pub indices: &'a [u32],
    /// Value of every stored entry.
    pub data: &'a [f64],
}

impl<'a> From<&'a Csr> for CsrRef<'a> {
    fn from(m: &'a Csr) -> Self {
        CsrRef { n: m.n, indptr: &m.indptr, indices: &m.indices, data: &m.data }
    }
}

impl CsrRef<'_> {
    /// Entry `(i, j)`, zero when not stored (a binary search in row `i`).
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (start, end) = (self.indptr[i], self.indptr[i + 1]);
        match self.indices[start..end].binary_search(&(j as u32)) {
            Ok(k) => self.data[start + k],
            Err(_) => 0.0,
        }
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.data.len()
    }

    /// Checks the layout against an `n x n` matrix: row starts from 0 to the entry count,
    /// strictly ascending columns below `n` in every row, one value per column index
    /// ([`Error::Shape`], its message prefixed with `what`).
    pub fn check_shape(&self, n: usize, what: &'static str) -> Result<()> {
        let shape = |detail: String| Err(Error::Shape { what: format!("{what}: {detail}") });
        if self.n != n {
            return shape(format!("a {n} x {n} matrix is needed, got {} x {}", self.n, self.n));
        }
        if self.indptr.len() != n + 1 || self.indptr[0] != 0 {
            return shape(format!("indptr must hold {} row starts from 0", n + 1));
        }
        if self.indices.len() != self.data.len() || self.indptr[n] != self.indices.len() {
            return shape(format!(
                "indptr ends at {}, with {} indices and {} values",
                self.indptr[n],
                self.indices.len(),
                self.data.len()
            ));
        }
        if let Some(i) = self.indptr.windows(2).position(|w| w[0] > w[1]) {
            return shape(format!("indptr decreases at row {i}"));
        }
        let bad_row = crate::threads::position_first(&self.indptr[..n], |i, _| {
            let row = &self.indices[self.indptr[i]..self.indptr[i + 1]];
            row.windows(2).any(|w| w[0] >= w[1]) || row.last().is_some_and(|&j| j as usize >= n)
        })?;
        if let Some(i) = bad_row {
            return shape(format!(
                "the columns of row {i} must be strictly ascending and below {n} \
                 (sum duplicates and sort the indices first)"
            ));
        }
        Ok(())
    }
}
