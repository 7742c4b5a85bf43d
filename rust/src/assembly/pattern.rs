//! The symbolic step: the CSR pattern "mesh edges + diagonal" and, for every element
//! around a vertex, where its contributions land in that vertex's row. It depends on the
//! elements only, so it is computed once and reused for every operator and every new
//! geometry.
//!
//! Rows are built in the internal order of [`crate::assembly::order`] (the elements around a vertex
//! are close in memory) and written to their place in the user's numbering: the columns
//! of a row are sorted by the user's vertex index, as the output needs them.

use crate::error::Result;
use crate::topology::group::{group_by, groups_mut, Incidence};
use crate::assembly::order::Layout;
use crate::options::Options;
use crate::element::Simplex;
use rayon::prelude::*;

/// Rows per work item of the row passes (and per poll of the cancel flag).
pub(crate) const ROW_CHUNK: usize = 512;

/// The user-order rows of `data` (split at `indptr`) listed in internal order.
pub(crate) fn rows_in_internal_order<'a, T>(
    data: &'a mut [T],
    indptr: &[usize],
    vertex_of: &[u32],
) -> Vec<&'a mut [T]> {
    let mut by_user: Vec<Option<&mut [T]>> = groups_mut(data, indptr).into_iter().map(Some).collect();
    vertex_of.iter().map(|&u| by_user[u as usize].take().expect("a permutation")).collect()
}

/// Runs `f(v, item)` for every internal row `v` and its item, in parallel chunks of
/// [`ROW_CHUNK`] rows, polling the cancel flag between chunks.
pub(crate) fn for_each_row<T: Send>(
    items: &mut [T],
    opts: &Options,
    f: impl Fn(usize, &mut T) + Sync,
) -> Result<()> {
    items.par_chunks_mut(ROW_CHUNK).enumerate().try_for_each(|(c, chunk)| {
        opts.cancelled()?;
        for (k, item) in chunk.iter_mut().enumerate() {
            f(c * ROW_CHUNK + k, item);
        }
        Ok(())
    })
}

/// CSR pattern of a mesh and the slot map of its row-wise assembly.
///
/// Row `i` of an operator is assembled from the elements around vertex `i`, in ascending
/// user element index: that order is the same for entry `(i, j)` and entry `(j, i)`, for
/// every thread count and whatever the internal order, so the result is symmetric and
/// deterministic to the last bit.
#[derive(Debug, Clone, PartialEq)]
pub struct Topology {
    n: usize,
    /// Element-corners `K t + c` (internal element ids) around every internal vertex, in
    /// ascending user element index (empty for unreferenced vertices).
    pub(crate) corners: Incidence,
    /// For the element-corner `corners.items[q]` (in internal row `v`): the positions,
    /// relative to the row start, of the other `K - 1` corners of its element (ascending
    /// corner order), at `corner_slots[(K - 1) q..(K - 1) (q + 1)]`.
    pub(crate) corner_slots: Vec<u32>,
    /// Position of the diagonal within each internal row.
    pub(crate) diagonal: Vec<u32>,
    /// Internal vertex -> user vertex (row of the output).
    pub(crate) vertex_of: Vec<u32>,
    indptr: Vec<usize>,
    indices: Vec<u32>,
}

impl Topology {
    /// Builds the topology of a mesh (its user-order `cells`) in its internal order (see
    /// [`crate::assembly::order`]).
    pub(crate) fn new<S: Simplex>(layout: &Layout<S>, cells: &[S::Cell], opts: &Options) -> Result<Self> {
        #[derive(Default)]
        struct Pattern {
            cols: Vec<u32>,
            slots: Vec<u32>,
            diagonal: Vec<u32>,
        }
        let rows = Rows::<S>::new(layout, cells, opts)?;
        let built = rows.build_all(opts, |_, row, out: &mut Pattern| {
            out.cols.extend_from_slice(row.cols);
            out.slots.extend_from_slice(row.slots);
            out.diagonal.push(row.diagonal);
        })?;
        let vertex_of = &layout.vertex_of[..];
        let indices = built.gather(vertex_of, |p| &p.cols);
        // slots and diagonals are per internal corner / row: the chunks in order
        let corner_slots = built.chunks.iter().flat_map(|(p, _)| &p.slots).copied().collect();
        let diagonal = built.chunks.iter().flat_map(|(p, _)| &p.diagonal).copied().collect();
        let Built { indptr, .. } = built;
        let n = vertex_of.len();
        Ok(Topology { n, corners: rows.corners, corner_slots, diagonal, vertex_of: vertex_of.to_vec(), indptr, indices })
    }

    /// Internal vertex -> user vertex (row of the output).
    pub(crate) fn vertex_of(&self) -> &[u32] {
        &self.vertex_of
    }

    /// Number of vertices (rows and columns).
    pub fn n(&self) -> usize {
        self.n
    }

    /// CSR row starts in the user's numbering (length `n + 1`).
    pub fn indptr(&self) -> &[usize] {
        &self.indptr
    }

    /// CSR column indices, sorted within each row: the row's neighbours and itself.
    pub fn indices(&self) -> &[u32] {
        &self.indices
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
    /// Columns sorted by the user's vertex index: the vertex and its neighbours.
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
    vertex_of: &'a [u32],
    pub corners: Incidence,
}

/// Every row of a pattern built once ([`Rows::build_all`]): the user-order row starts and,
/// per chunk of [`ROW_CHUNK`] internal rows, its buffers and row lengths.
pub(crate) struct Built<B> {
    pub indptr: Vec<usize>,
    pub chunks: Vec<(B, Vec<u32>)>,
}

impl<B: Sync> Built<B> {
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        *self.indptr.last().expect("n + 1 entries")
    }

    /// One per-entry array of the rows in the user's order: `part(buffers)` is a chunk's
    /// rows of it, concatenated in internal order.
    pub fn gather<T: Copy + Default + Send + Sync>(&self, vertex_of: &[u32], part: impl Fn(&B) -> &Vec<T> + Sync) -> Vec<T> {
        let mut out = vec![T::default(); self.nnz()];
        let mut rows = rows_in_internal_order(&mut out, &self.indptr, vertex_of);
        rows.par_chunks_mut(ROW_CHUNK).zip(&self.chunks).for_each(|(rows, (buffers, lengths))| {
            let mut from = part(buffers).as_slice();
            for (row, &len) in rows.iter_mut().zip(lengths) {
                let (head, rest) = from.split_at(len as usize);
                row.copy_from_slice(head);
                from = rest;
            }
        });
        out
    }
}

impl<'a, S: Simplex> Rows<'a, S> {
    /// The element-corners around every vertex; `user_cells` are the mesh's elements in the
    /// user's order and numbering.
    pub fn new(layout: &'a Layout<S>, user_cells: &[S::Cell], opts: &Options) -> Result<Self> {
        let corners = corner_incidence::<S>(user_cells, &layout.rank, &layout.internal_of, opts)?;
        Ok(Rows { cells: &layout.cells, vertex_of: &layout.vertex_of, corners })
    }

    /// Builds every internal row once ([`Rows::build`]), in parallel chunks of
    /// [`ROW_CHUNK`] rows: `fill(v, row, buffers)` appends what row `v` contributes to its
    /// chunk's buffers. The row starts in the user's order follow from the lengths, and
    /// [`Built::gather`] moves per-entry arrays there: one build and one copy, instead of a
    /// counting pass and a second build.
    pub fn build_all<B: Default + Send>(&self, opts: &Options, fill: impl Fn(usize, Row, &mut B) + Sync) -> Result<Built<B>> {
        let n = self.vertex_of.len();
        let chunks: Vec<(B, Vec<u32>)> = (0..n.div_ceil(ROW_CHUNK))
            .into_par_iter()
            .map(|c| {
                opts.cancelled()?;
                let mut buffers = B::default();
                let lengths = (c * ROW_CHUNK..n.min((c + 1) * ROW_CHUNK))
                    .map(|v| {
                        self.build(v, |row| {
                            let len = row.cols.len() as u32;
                            fill(v, row, &mut buffers);
                            len
                        })
                    })
                    .collect();
                Ok((buffers, lengths))
            })
            .collect::<Result<_>>()?;
        let mut by_user = vec![0u32; n];
        for (&u, &len) in self.vertex_of.iter().zip(chunks.iter().flat_map(|(_, l)| l)) {
            by_user[u as usize] = len;
        }
        let mut indptr = Vec::with_capacity(n + 1);
        indptr.push(0);
        for len in by_user {
            indptr.push(indptr.last().expect("starts with 0") + len as usize);
        }
        Ok(Built { indptr, chunks })
    }

    /// Internal row `v` in order of first appearance: columns (internal ids) and the slots
    /// of every corner item.
    fn build_unsorted<R>(&self, v: usize, f: impl FnOnce(&[u32], &[u32]) -> R) -> R {
        SCRATCH.with(|scratch| {
            let s = &mut *scratch.borrow_mut();
            let n = self.corners.offsets.len() - 1;
            if s.position.len() < n {
                s.position.resize(n, u32::MAX);
            }
            s.cols.clear();
            s.slots.clear();
            s.position[v] = 0;
            s.cols.push(v as u32);
            let k = S::CORNERS;
            for &item in self.corners.of(v) {
                let (cell, c) = (self.cells[item as usize / k].as_ref(), item as usize % k);
                for o in (0..k).filter(|&o| o != c) {
                    let u = cell[o] as usize;
                    if s.position[u] == u32::MAX {
                        s.position[u] = s.cols.len() as u32;
                        s.cols.push(u as u32);
                    }
                    s.slots.push(s.position[u]);
                }
            }
            for &u in &s.cols {
                s.position[u as usize] = u32::MAX;
            }
            f(&s.cols, &s.slots)
        })
    }

    /// Internal row `v` with its columns as user indices, sorted (see [`Row`]).
    pub fn build<R>(&self, v: usize, f: impl FnOnce(Row) -> R) -> R {
        self.build_unsorted(v, |_, _| ());
        SCRATCH.with(|scratch| {
            let s = &mut *scratch.borrow_mut();
            s.order.clear();
            s.order.extend(s.cols.iter().enumerate().map(|(k, &u)| (self.vertex_of[u as usize], k as u32)));
            s.order.sort_unstable();
            s.rank.resize(s.cols.len(), 0);
            for (pos, &(user, first)) in s.order.iter().enumerate() {
                s.rank[first as usize] = pos as u32;
                s.cols[pos] = user;
            }
            for slot in s.slots.iter_mut() {
                *slot = s.rank[*slot as usize];
            }
            let diagonal = s.rank[0];
            f(Row { cols: &s.cols, slots: &s.slots, diagonal })
        })
    }
}

/// Element-corners `K t + c` (internal `t`) per internal vertex, in ascending user element
/// index, from the user's `cells` (`rank[u]`: internal index of user vertex `u`;
/// `internal_of[e]`: internal index of user element `e`).
fn corner_incidence<S: Simplex>(
    cells: &[S::Cell],
    rank: &[u32],
    internal_of: &[u32],
    opts: &Options,
) -> Result<Incidence> {
    let k = S::CORNERS;
    let corner = |r: usize| {
        let (e, c) = (r / k, r % k);
        let item = k as u32 * internal_of[e] + c as u32;
        (rank[cells[e].as_ref()[c] as usize], item)
    };
    let (offsets, items) = group_by(rank.len(), k * cells.len(), corner, opts)?;
    Ok(Incidence { offsets, items })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Tet;

    #[test]
    fn two_tets_sharing_a_face() {
        // internal numbering = user numbering reversed, elements in user order
        let vertex_of: Vec<u32> = (0..6).rev().collect();
        let user_cells = [[0u32, 1, 2, 3], [4, 3, 2, 1]];
        let cells: Vec<[u32; 4]> = user_cells.iter().map(|c| c.map(|u| 5 - u)).collect();
        let layout = Layout::<Tet> {
            rank: vertex_of.clone(),
            vertex_of,
            element_of: vec![0, 1],
            internal_of: vec![0, 1],
            cells,
            points: vec![0.0; 18],
            weights: None,
            dim: 3,
        };
        let t = Topology::new::<Tet>(&layout, &user_cells, &Options::default()).unwrap();
        assert_eq!(t.edges().len(), 9);
        let row = |i: usize| &t.indices()[t.indptr()[i]..t.indptr()[i + 1]];
        assert_eq!(row(5), &[5]); // unreferenced: diagonal only
        assert_eq!(row(1), &[0, 1, 2, 3, 4]);
        for i in 0..6 {
            assert!(row(i).windows(2).all(|w| w[0] < w[1]), "row {i} sorted: {:?}", row(i));
            let v = 5 - i; // internal row of user vertex i
            assert_eq!(row(i)[t.diagonal[v] as usize] as usize, i);
        }
        // user vertex 2 (internal 3) is corner 2 of the second tet: the others are 4, 3, 1
        let v = 3;
        let q = t.corners.of(v).iter().position(|&item| item == 4 + 2).unwrap();
        let q = t.corners.offsets[v] + q;
        let slots = &t.corner_slots[3 * q..3 * q + 3];
        assert_eq!(slots.iter().map(|&s| row(2)[s as usize]).collect::<Vec<_>>(), [4, 3, 1]);
    }
}
