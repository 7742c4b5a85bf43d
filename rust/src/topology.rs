//! The symbolic step: the CSR pattern "mesh edges + diagonal" and, for every tet around a
//! vertex, where its contributions land in that vertex's row. It depends on the tets
//! only, so it is computed once and reused for every operator and every new geometry.

use crate::error::{Error, Result};
use rayon::prelude::*;

/// The other three corners of corner `c`, ascending.
pub(crate) const OTHERS: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// Items grouped by key: group `g` owns `items[offsets[g]..offsets[g+1]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Incidence {
    /// Group starts, length `groups + 1`.
    pub offsets: Vec<usize>,
    /// The items, ascending within each group.
    pub items: Vec<u32>,
}

impl Incidence {
    /// Items of group `g`.
    #[inline]
    pub fn of(&self, g: usize) -> &[u32] {
        &self.items[self.offsets[g]..self.offsets[g + 1]]
    }
}

/// CSR pattern of a tet mesh and the slot map of its row-wise assembly.
///
/// Row `i` of an operator is assembled from the tets around vertex `i`, in ascending tet
/// order: that order is the same for entry `(i, j)` and entry `(j, i)` and for every thread
/// count, so the result is symmetric and deterministic to the last bit.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Number of vertices.
    pub n: usize,
    /// Tet-corners `4 t + c` around every vertex, ascending (empty for unreferenced ones).
    pub corners: Incidence,
    /// For the tet-corner `corners.items[k]` = `4 t + c` (in row `i`): the positions,
    /// relative to the row start, of the other three corners of `t` in ascending corner
    /// order.
    pub corner_slots: Vec<[u32; 3]>,
    /// CSR row starts (length `n + 1`).
    pub indptr: Vec<usize>,
    /// CSR column indices, sorted within each row: the row's neighbours and itself.
    pub indices: Vec<u32>,
    /// Position of the diagonal within each row.
    pub diagonal: Vec<u32>,
}

/// Splits `data` into consecutive groups of `offsets`, for parallel per-group writes.
pub(crate) fn groups_mut<'a, T>(mut data: &'a mut [T], offsets: &[usize]) -> Vec<&'a mut [T]> {
    let mut groups = Vec::with_capacity(offsets.len().saturating_sub(1));
    for w in offsets.windows(2) {
        let (group, rest) = data.split_at_mut(w[1] - w[0]);
        groups.push(group);
        data = rest;
    }
    groups
}

impl Topology {
    /// Builds the topology of `tets` over `n` vertices (indices must be `< n`, as
    /// [`crate::TetMesh`] guarantees).
    pub fn new(tets: &[[u32; 4]], n: usize) -> Result<Self> {
        if tets.len() > (u32::MAX / 4) as usize {
            return Err(Error::InvalidOption {
                message: format!("{} tets: at most {} are supported", tets.len(), u32::MAX / 4),
            });
        }
        let corners = corner_incidence(tets, n);
        // Row i has at most 1 + 3 * (tets around i) entries: build every row in a buffer of
        // that size, then compact. A row is built by sorting the keys (neighbour, origin),
        // origin = 3 q + o for the o-th other corner of the q-th tet around i (or MAX for the
        // diagonal), so that the slot of every origin falls out of the same pass.
        let bound: Vec<usize> = (0..=n).map(|i| 3 * corners.offsets[i] + i).collect();
        let mut buffer = vec![0u32; bound[n]];
        let mut corner_slots = vec![[0u32; 3]; corners.items.len()];
        let rows: Vec<(usize, u32)> = groups_mut(&mut buffer, &bound)
            .into_par_iter()
            .zip(groups_mut(&mut corner_slots, &corners.offsets))
            .enumerate()
            .map_init(Vec::new, |keys: &mut Vec<u64>, (i, (row, slots))| {
                keys.clear();
                keys.push(((i as u64) << 32) | u32::MAX as u64);
                for (q, &k) in corners.of(i).iter().enumerate() {
                    let (tet, c) = (&tets[k as usize / 4], k as usize % 4);
                    for (o, &corner) in OTHERS[c].iter().enumerate() {
                        keys.push(((tet[corner] as u64) << 32) | (3 * q + o) as u64);
                    }
                }
                keys.sort_unstable();
                let (mut len, mut diagonal) = (0usize, 0u32);
                for &key in keys.iter() {
                    let (j, origin) = ((key >> 32) as u32, key as u32);
                    if len == 0 || row[len - 1] != j {
                        row[len] = j;
                        len += 1;
                    }
                    if origin == u32::MAX {
                        diagonal = (len - 1) as u32;
                    } else {
                        slots[origin as usize / 3][origin as usize % 3] = (len - 1) as u32;
                    }
                }
                (len, diagonal)
            })
            .collect();
        let mut indptr = Vec::with_capacity(n + 1);
        indptr.push(0);
        for &(len, _) in &rows {
            indptr.push(indptr.last().unwrap() + len);
        }
        let mut indices = vec![0u32; indptr[n]];
        groups_mut(&mut indices, &indptr)
            .into_par_iter()
            .enumerate()
            .for_each(|(i, out)| out.copy_from_slice(&buffer[bound[i]..bound[i] + out.len()]));
        let diagonal = rows.into_iter().map(|(_, d)| d).collect();
        Ok(Topology { n, corners, corner_slots, indptr, indices, diagonal })
    }

    /// Number of stored entries of the pattern.
    pub fn nnz(&self) -> usize {
        self.indices.len()
    }

    /// A CSR matrix on this pattern with the given values (the pattern is copied).
    pub fn to_csr(&self, data: Vec<f64>) -> crate::Csr {
        assert_eq!(data.len(), self.nnz(), "one value per stored entry");
        crate::Csr { n: self.n, indptr: self.indptr.clone(), indices: self.indices.clone(), data }
    }

    /// A CSR matrix on this pattern with the given values (the pattern is moved).
    pub fn into_csr(self, data: Vec<f64>) -> crate::Csr {
        assert_eq!(data.len(), self.nnz(), "one value per stored entry");
        crate::Csr { n: self.n, indptr: self.indptr, indices: self.indices, data }
    }

    /// Unique edges `(i, j)`, `i < j`, in CSR order (sorted).
    pub fn edges(&self) -> Vec<[u32; 2]> {
        (0..self.n)
            .flat_map(|i| {
                let row = &self.indices[self.indptr[i]..self.indptr[i + 1]];
                row.iter().filter(move |&&j| j as usize > i).map(move |&j| [i as u32, j])
            })
            .collect()
    }
}

/// Whether each tet has a face that no other tet shares (a boundary face).
pub fn boundary_tets(tets: &[[u32; 4]]) -> Vec<bool> {
    let mut keys: Vec<([u32; 3], u32)> = tets
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, tet)| {
            OTHERS.iter().map(move |f| {
                let mut face = f.map(|c| tet[c]);
                face.sort_unstable();
                (face, t as u32)
            })
        })
        .collect();
    keys.par_sort_unstable();
    let mut boundary = vec![false; tets.len()];
    for (k, &(face, t)) in keys.iter().enumerate() {
        let shared = (k > 0 && keys[k - 1].0 == face) || keys.get(k + 1).is_some_and(|n| n.0 == face);
        if !shared {
            boundary[t as usize] = true;
        }
    }
    boundary
}

/// Tet-corners per vertex by a counting sort (ascending corner ids within each vertex).
fn corner_incidence(tets: &[[u32; 4]], n: usize) -> Incidence {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_tets_sharing_a_face() {
        let t = Topology::new(&[[0, 1, 2, 3], [4, 3, 2, 1]], 6).unwrap();
        assert_eq!(t.edges().len(), 9);
        assert_eq!(t.corners.of(5).len(), 0); // unreferenced
        assert_eq!(t.indptr[6] - t.indptr[5], 1); // diagonal only
        assert_eq!(&t.indices[t.indptr[1]..t.indptr[2]], &[0, 1, 2, 3, 4]);
        for i in 0..6 {
            let row = &t.indices[t.indptr[i]..t.indptr[i + 1]];
            assert!(row.windows(2).all(|w| w[0] < w[1]), "row {i} sorted: {row:?}");
            assert_eq!(row[t.diagonal[i] as usize] as usize, i);
        }
        // vertex 2 is corner 2 of tet 1 = [4, 3, 2, 1]: the others are 4, 3, 1
        let k = t.corners.of(2).iter().position(|&k| k == 4 + 2).unwrap();
        let slots = t.corner_slots[t.corners.offsets[2] + k];
        let row = &t.indices[t.indptr[2]..t.indptr[3]];
        assert_eq!(slots.map(|s| row[s as usize]), [4, 3, 1]);
    }
}
