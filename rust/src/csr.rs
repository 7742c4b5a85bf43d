//! Compressed sparse row matrices and unsummed coordinate triplets.

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
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.data.len()
    }

    /// The diagonal matrix with `diag` on its diagonal.
    pub fn diagonal(diag: Vec<f64>) -> Csr {
        let n = diag.len();
        Csr { n, indptr: (0..=n).collect(), indices: (0..n as u32).collect(), data: diag }
    }

    /// Entry `(i, j)`, zero when not stored.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let row = self.indptr[i]..self.indptr[i + 1];
        match self.indices[row.clone()].binary_search(&(j as u32)) {
            Ok(k) => self.data[row.start + k],
            Err(_) => 0.0,
        }
    }

    /// `y = A x`.
    pub fn matvec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| {
                let row = self.indptr[i]..self.indptr[i + 1];
                self.indices[row.clone()]
                    .iter()
                    .zip(&self.data[row])
                    .map(|(&j, &a)| a * x[j as usize])
                    .sum()
            })
            .collect()
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
