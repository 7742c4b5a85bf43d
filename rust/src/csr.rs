//! The outputs: compressed sparse row matrices, masses and unsummed coordinate triplets.

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
