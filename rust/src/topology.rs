//! The symbolic step: the CSR pattern "mesh edges + diagonal" and, for every element
//! around a vertex, where its contributions land in that vertex's row. It depends on the
//! elements only, so it is computed once and reused for every operator and every new
//! geometry.

use crate::error::Result;
use crate::mesh::max_elements;
use crate::simplex::Simplex;
use rayon::prelude::*;

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

/// CSR pattern of a mesh and the slot map of its row-wise assembly.
///
/// Row `i` of an operator is assembled from the elements around vertex `i`, in ascending
/// element order: that order is the same for entry `(i, j)` and entry `(j, i)` and for
/// every thread count, so the result is symmetric and deterministic to the last bit.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    /// Number of vertices.
    pub n: usize,
    /// Corners per element (`K`: 4 for tets, 3 for triangles).
    pub corners_per_element: usize,
    /// Element-corners `K t + c` around every vertex, ascending (empty for unreferenced
    /// vertices).
    pub corners: Incidence,
    /// For the element-corner `corners.items[q]` = `K t + c` (in row `i`): the positions,
    /// relative to the row start, of the other `K - 1` corners of `t` in ascending corner
    /// order, at `corner_slots[(K - 1) q..(K - 1) (q + 1)]`.
    pub corner_slots: Vec<u32>,
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
    /// Builds the topology of `cells` over `n` vertices (indices must be `< n`, as
    /// [`crate::Mesh`] guarantees).
    pub fn new<S: Simplex>(cells: &[S::Cell], n: usize) -> Result<Self> {
        let rows = Rows::<S>::new(cells, n)?;
        let k = S::CORNERS - 1;
        let mut indices = vec![0u32; rows.nnz()];
        let mut corner_slots = vec![0u32; k * rows.corners.items.len()];
        let mut diagonal = vec![0u32; n];
        let slot_offsets: Vec<usize> = rows.corners.offsets.iter().map(|o| k * o).collect();
        groups_mut(&mut indices, &rows.indptr)
            .into_par_iter()
            .zip(groups_mut(&mut corner_slots, &slot_offsets))
            .zip(diagonal.par_iter_mut())
            .enumerate()
            .for_each(|(i, ((cols, slots), diag))| {
                rows.build(i, |row| {
                    cols.copy_from_slice(row.cols);
                    slots.copy_from_slice(row.slots);
                    *diag = row.diagonal;
                })
            });
        let Rows { corners, indptr, .. } = rows;
        Ok(Topology { n, corners_per_element: S::CORNERS, corners, corner_slots, indptr, indices, diagonal })
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

/// One row of the pattern as built from the elements around its vertex.
pub(crate) struct Row<'a> {
    /// Sorted columns: the vertex and its neighbours.
    pub cols: &'a [u32],
    /// For the q-th element-corner around the vertex, the positions in `cols` of the other
    /// `K - 1` corners of its element (ascending corner order): `slots[(K-1) q ..]`.
    pub slots: &'a [u32],
    /// Position of the vertex itself in `cols`.
    pub diagonal: u32,
}

/// Scratch of one worker thread: a position per vertex (`u32::MAX` when unused, and
/// restored to that after every row) and small buffers.
#[derive(Default)]
struct Scratch {
    position: Vec<u32>,
    cols: Vec<u32>,
    slots: Vec<u32>,
    order: Vec<(u32, u32)>,
    rank: Vec<u32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// The rows of a mesh's pattern, built on demand from the elements around each vertex.
pub(crate) struct Rows<'a, S: Simplex> {
    cells: &'a [S::Cell],
    pub corners: Incidence,
    pub indptr: Vec<usize>,
}

impl<'a, S: Simplex> Rows<'a, S> {
    /// Counts every row (a first pass that deduplicates neighbours with the per-thread
    /// position array) and lays out `indptr`.
    pub fn new(cells: &'a [S::Cell], n: usize) -> Result<Self> {
        debug_assert!(cells.len() <= max_elements::<S>(), "checked by Mesh::new");
        let corners = corner_incidence::<S>(cells, n);
        let mut rows = Rows { cells, corners, indptr: Vec::new() };
        let lengths: Vec<usize> =
            (0..n).into_par_iter().map(|i| rows.build_unsorted(i, |cols, _| cols.len())).collect();
        let mut indptr = Vec::with_capacity(n + 1);
        indptr.push(0);
        for len in lengths {
            indptr.push(indptr.last().unwrap() + len);
        }
        rows.indptr = indptr;
        Ok(rows)
    }

    pub fn nnz(&self) -> usize {
        *self.indptr.last().unwrap()
    }

    /// Row `i` in order of first appearance: columns and the slots of every corner item.
    fn build_unsorted<R>(&self, i: usize, f: impl FnOnce(&[u32], &[u32]) -> R) -> R {
        SCRATCH.with(|scratch| {
            let s = &mut *scratch.borrow_mut();
            let n = self.corners.offsets.len() - 1;
            if s.position.len() < n {
                s.position.resize(n, u32::MAX);
            }
            s.cols.clear();
            s.slots.clear();
            s.position[i] = 0;
            s.cols.push(i as u32);
            let k = S::CORNERS;
            for &item in self.corners.of(i) {
                let (cell, c) = (self.cells[item as usize / k].as_ref(), item as usize % k);
                for o in (0..k).filter(|&o| o != c) {
                    let v = cell[o] as usize;
                    if s.position[v] == u32::MAX {
                        s.position[v] = s.cols.len() as u32;
                        s.cols.push(v as u32);
                    }
                    s.slots.push(s.position[v]);
                }
            }
            for &v in &s.cols {
                s.position[v as usize] = u32::MAX;
            }
            f(&s.cols, &s.slots)
        })
    }

    /// Row `i` with sorted columns (see [`Row`]).
    pub fn build<R>(&self, i: usize, f: impl FnOnce(Row) -> R) -> R {
        self.build_unsorted(i, |_, _| ());
        SCRATCH.with(|scratch| {
            let s = &mut *scratch.borrow_mut();
            s.order.clear();
            s.order.extend(s.cols.iter().enumerate().map(|(k, &v)| (v, k as u32)));
            s.order.sort_unstable();
            s.rank.resize(s.cols.len(), 0);
            for (pos, &(v, first)) in s.order.iter().enumerate() {
                s.rank[first as usize] = pos as u32;
                s.cols[pos] = v;
            }
            for slot in s.slots.iter_mut() {
                *slot = s.rank[*slot as usize];
            }
            let diagonal = s.rank[0];
            f(Row { cols: &s.cols, slots: &s.slots, diagonal })
        })
    }
}

/// Whether each element has a face (a tet's triangle, a triangle's edge) that no other
/// element shares: a boundary face.
pub fn boundary_elements<S: Simplex>(cells: &[S::Cell]) -> Vec<bool> {
    let k = S::CORNERS;
    let mut keys: Vec<([u32; 3], u32)> = cells
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, cell)| {
            let cell = cell.as_ref();
            (0..k).map(move |opposite| {
                // the face opposite `opposite`, sorted, padded with u32::MAX
                let mut face = [u32::MAX; 3];
                for (slot, c) in (0..k).filter(|&c| c != opposite).enumerate() {
                    face[slot] = cell[c];
                }
                face.sort_unstable();
                (face, t as u32)
            })
        })
        .collect();
    keys.par_sort_unstable();
    let mut boundary = vec![false; cells.len()];
    for (k, &(face, t)) in keys.iter().enumerate() {
        let shared = (k > 0 && keys[k - 1].0 == face) || keys.get(k + 1).is_some_and(|n| n.0 == face);
        if !shared {
            boundary[t as usize] = true;
        }
    }
    boundary
}

/// Element-corners per vertex (ascending corner ids within each vertex), by a counting
/// sort parallel over vertex ranges: every worker scans all corners and keeps its own range.
pub(crate) fn corner_incidence<S: Simplex>(cells: &[S::Cell], n: usize) -> Incidence {
    // every corner's vertex, in element-corner order `K t + c`
    let corners = || cells.iter().flat_map(|c| c.as_ref().iter().copied());
    let parts = (rayon::current_num_threads() * 2).clamp(1, n.max(1));
    let bounds: Vec<usize> = (0..=parts).map(|p| p * n / parts).collect();
    let mut counts = vec![0usize; n];
    groups_mut(&mut counts, &bounds).into_par_iter().enumerate().for_each(|(p, counts)| {
        let lo = bounds[p];
        for v in corners() {
            if let Some(c) = (v as usize).checked_sub(lo).and_then(|k| counts.get_mut(k)) {
                *c += 1;
            }
        }
    });
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    for c in counts {
        offsets.push(offsets.last().unwrap() + c);
    }
    let mut items = vec![0u32; cells.len() * S::CORNERS];
    let item_bounds: Vec<usize> = bounds.iter().map(|&b| offsets[b]).collect();
    groups_mut(&mut items, &item_bounds).into_par_iter().enumerate().for_each(|(p, out)| {
        let (lo, hi) = (bounds[p], bounds[p + 1]);
        let mut cursor: Vec<usize> = (lo..hi).map(|i| offsets[i] - offsets[lo]).collect();
        for (flat, v) in corners().enumerate() {
            let v = v as usize;
            if (lo..hi).contains(&v) {
                out[cursor[v - lo]] = flat as u32;
                cursor[v - lo] += 1;
            }
        }
    });
    Incidence { offsets, items }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simplex::{Tet, Tri};

    #[test]
    fn boundary_elements_of_tets_and_triangles() {
        // two tets sharing the face (1, 2, 3): every tet has boundary faces
        assert_eq!(boundary_elements::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]]), [true, true]);
        // a fan of 4 triangles around vertex 0: each has an edge on the rim
        let fan = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]];
        assert_eq!(boundary_elements::<Tri>(&fan), [true; 4]);
        // a closed tetrahedron surface: no boundary
        let closed = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
        assert_eq!(boundary_elements::<Tri>(&closed), [false; 4]);
    }

    #[test]
    fn two_tets_sharing_a_face() {
        let t = Topology::new::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]], 6).unwrap();
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
        let q = t.corners.offsets[2] + k;
        let slots = &t.corner_slots[3 * q..3 * q + 3];
        let row = &t.indices[t.indptr[2]..t.indptr[3]];
        assert_eq!(slots.iter().map(|&s| row[s as usize]).collect::<Vec<_>>(), [4, 3, 1]);
    }
}
