//! The symbolic step: a mesh's unique edges, its CSR pattern, and where every tet's
//! contributions go. It depends on the tets only, so it is computed once and reused.

use crate::error::{Error, Result};
use crate::local::EDGES;
use rayon::prelude::*;

/// Marks a diagonal slot in [`Topology::slot_edge`].
pub const DIAGONAL: u32 = u32::MAX;

/// Where each item of a group lives: group `g` owns `items[offsets[g]..offsets[g+1]]`,
/// in ascending order (that order fixes the summation order of every reduction).
#[derive(Debug, Clone, PartialEq)]
pub struct Incidence {
    /// Group starts, length `groups + 1`.
    pub offsets: Vec<usize>,
    /// Flat ids of the items, ascending within each group.
    pub items: Vec<u32>,
}

impl Incidence {
    /// Items of group `g`.
    #[inline]
    pub fn of(&self, g: usize) -> &[u32] {
        &self.items[self.offsets[g]..self.offsets[g + 1]]
    }
}

/// Edge topology and CSR pattern of a tet mesh.
///
/// Flat ids: tet-edge `6 t + e` (local edge `e` of tet `t`, order of [`EDGES`]) and
/// tet-corner `4 t + c`.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Number of vertices.
    pub n: usize,
    /// Unique edges `(i, j)` with `i < j`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// Edge id of every tet-edge (length `6 m`).
    pub tet_edges: Vec<u32>,
    /// Tet-edges of every edge.
    pub edge_incidence: Incidence,
    /// Tet-corners of every vertex (empty for unreferenced vertices).
    pub vertex_incidence: Incidence,
    /// CSR row starts of the pattern "mesh edges + diagonal" (length `n + 1`).
    pub indptr: Vec<usize>,
    /// CSR column indices, sorted within each row.
    pub indices: Vec<u32>,
    /// Edge id of every CSR slot, or [`DIAGONAL`].
    pub slot_edge: Vec<u32>,
}

impl Topology {
    /// Builds the topology of `tets` over `n` vertices (indices must be `< n`, as a
    /// [`crate::TetMesh`] guarantees).
    pub fn new(tets: &[[u32; 4]], n: usize) -> Result<Self> {
        let m = tets.len();
        if m > (u32::MAX as usize - 1) / 6 {
            return Err(Error::InvalidOption {
                message: format!("{m} tets: at most {} are supported", (u32::MAX - 1) / 6),
            });
        }
        // (edge key, tet-edge id), sorted: equal keys become runs in tet order.
        let mut pairs = vec![(0u64, 0u32); 6 * m];
        pairs.par_chunks_mut(6).zip(tets.par_iter()).enumerate().for_each(|(t, (out, tet))| {
            for (e, &(a, b)) in EDGES.iter().enumerate() {
                let (i, j) = (tet[a].min(tet[b]), tet[a].max(tet[b]));
                out[e] = (((i as u64) << 32) | j as u64, (6 * t + e) as u32);
            }
        });
        pairs.par_sort_unstable();

        let mut edges = Vec::new();
        let mut offsets = Vec::new();
        let mut tet_edges = vec![0u32; 6 * m];
        let mut items = Vec::with_capacity(6 * m);
        for (k, &(key, flat)) in pairs.iter().enumerate() {
            if k == 0 || key != pairs[k - 1].0 {
                offsets.push(k);
                edges.push([(key >> 32) as u32, key as u32]);
            }
            tet_edges[flat as usize] = (edges.len() - 1) as u32;
            items.push(flat);
        }
        offsets.push(pairs.len());
        drop(pairs);
        if edges.len() >= DIAGONAL as usize {
            return Err(Error::InvalidOption { message: "too many edges".into() });
        }

        let vertex_incidence = vertex_incidence(tets, n);
        let (indptr, indices, slot_edge) = pattern(&edges, n);
        Ok(Topology {
            n,
            edges,
            tet_edges,
            edge_incidence: Incidence { offsets, items },
            vertex_incidence,
            indptr,
            indices,
            slot_edge,
        })
    }

    /// Number of tets the topology was built for.
    pub fn n_tets(&self) -> usize {
        self.tet_edges.len() / 6
    }

    /// Whether vertex `i` belongs to no tet.
    pub fn is_unreferenced(&self, i: usize) -> bool {
        self.vertex_incidence.of(i).is_empty()
    }
}

/// Tet-corners per vertex by a counting sort (ascending corner ids within each vertex).
fn vertex_incidence(tets: &[[u32; 4]], n: usize) -> Incidence {
    let mut offsets = vec![0usize; n + 1];
    for &v in tets.iter().flatten() {
        offsets[v as usize + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut cursor = offsets[..n].to_vec();
    let mut items = vec![0u32; 4 * tets.len()];
    for (flat, &v) in tets.iter().flatten().enumerate() {
        items[cursor[v as usize]] = flat as u32;
        cursor[v as usize] += 1;
    }
    Incidence { offsets, items }
}

/// CSR pattern "edges + diagonal" with sorted rows, and the edge behind every slot.
fn pattern(edges: &[[u32; 2]], n: usize) -> (Vec<usize>, Vec<u32>, Vec<u32>) {
    let mut below = vec![0usize; n]; // neighbours j < i
    let mut above = vec![0usize; n]; // neighbours j > i
    for &[i, j] in edges {
        above[i as usize] += 1;
        below[j as usize] += 1;
    }
    let mut indptr = vec![0usize; n + 1];
    for i in 0..n {
        indptr[i + 1] = indptr[i] + below[i] + 1 + above[i];
    }
    let nnz = indptr[n];
    let mut indices = vec![0u32; nnz];
    let mut slot_edge = vec![DIAGONAL; nnz];
    // Edges are sorted by (i, j): row j receives its lower neighbours i in increasing
    // order, row i its upper neighbours j in increasing order.
    let mut lower: Vec<usize> = indptr[..n].to_vec();
    let mut upper: Vec<usize> = (0..n).map(|i| indptr[i] + below[i] + 1).collect();
    for i in 0..n {
        indices[indptr[i] + below[i]] = i as u32;
    }
    for (e, &[i, j]) in edges.iter().enumerate() {
        let (i, j) = (i as usize, j as usize);
        indices[lower[j]] = i as u32;
        slot_edge[lower[j]] = e as u32;
        lower[j] += 1;
        indices[upper[i]] = j as u32;
        slot_edge[upper[i]] = e as u32;
        upper[i] += 1;
    }
    (indptr, indices, slot_edge)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_tets_sharing_a_face() {
        let t = Topology::new(&[[0, 1, 2, 3], [4, 3, 2, 1]], 6).unwrap();
        assert_eq!(t.edges.len(), 9);
        assert_eq!(t.edge_incidence.of(t.tet_edges[3] as usize).len(), 2); // edge (1,2) is shared
        assert!(t.is_unreferenced(5));
        assert_eq!(t.indptr[6] - t.indptr[5], 1); // diagonal only
        for i in 0..6 {
            let row = &t.indices[t.indptr[i]..t.indptr[i + 1]];
            assert!(row.windows(2).all(|w| w[0] < w[1]), "row {i} sorted: {row:?}");
        }
        for (s, &e) in t.slot_edge.iter().enumerate() {
            let row = t.indptr.partition_point(|&p| p <= s) - 1;
            if e == DIAGONAL {
                assert_eq!(t.indices[s] as usize, row);
            } else {
                let [i, j] = t.edges[e as usize];
                assert!([i, j].contains(&(row as u32)) && [i, j].contains(&t.indices[s]));
            }
        }
    }
}
