//! The symbolic step: the CSR pattern "mesh edges + diagonal", row by row.
//!
//! Row `i` of every operator is the vertex `i` and its neighbours, its columns sorted by
//! the user's vertex index. A row is built from the element-corners around its vertex (the
//! corner incidence, [`corner_incidence`]): the other corners of those elements, each
//! kept once (a stamp per vertex, no reset), then sorted. Rows are built in the internal
//! order of [`crate::assembly::order`] (the elements around a vertex are close in memory)
//! and written to their place in the user's numbering.
//!
//! * [`row_starts`]: the rows' lengths alone, for a one-shot assembly (which then builds
//!   and fills its rows in place, [`crate::assembly::scatter`]);
//! * [`Topology`]: the pattern with its slot map, kept by [`crate::CachedMesh`];
//! * [`Rows`]: rows on demand, for the checks of [`crate::analysis`].

use crate::assembly::order::Layout;
use crate::assembly::pass::Pool;
use crate::element::Simplex;
use crate::error::Result;
use crate::options::Options;
use crate::topology::group::{group_u32, groups_mut, Incidence};
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

/// Scratch of one worker building rows: a stamp per internal vertex (the number of the
/// last row built that met it), the number of rows built, and the keys of the current row.
pub(crate) struct RowScratch {
    seen: Vec<u32>,
    built: u32,
    keys: Vec<u64>,
}

impl RowScratch {
    /// Scratch for `n` vertices.
    pub fn new(n: usize) -> Self {
        RowScratch { seen: vec![0; n], built: 0, keys: Vec::with_capacity(64) }
    }

    /// The next stamp (wrapping: after 2^32 rows the stamps start again).
    #[inline]
    fn stamp(&mut self) -> u32 {
        self.built = self.built.wrapping_add(1);
        if self.built == 0 {
            self.seen.fill(0);
            self.built = 1;
        }
        self.built
    }

    /// The number of columns of internal row `v` (see [`RowScratch::columns`]).
    #[inline]
    pub fn count<S: Simplex>(&mut self, v: usize, items: &[u32], cells: &[S::Cell]) -> u32 {
        let k = S::CORNERS;
        let stamp = self.stamp();
        self.seen[v] = stamp;
        let mut count = 1;
        for &item in items {
            let (cell, c) = (cells[item as usize / k].as_ref(), item as usize % k);
            for (o, &u) in cell.iter().enumerate() {
                if o != c && self.seen[u as usize] != stamp {
                    self.seen[u as usize] = stamp;
                    count += 1;
                }
            }
        }
        count
    }

    /// The columns of internal row `v` (the element-corners `items` around it, of `cells`
    /// in internal numbering): `v` and its neighbours, each once, sorted by user index
    /// (`vertex_of`), as keys `user << 32 | internal`.
    #[inline]
    pub fn columns<S: Simplex>(&mut self, v: usize, items: &[u32], cells: &[S::Cell], vertex_of: &[u32]) -> &[u64] {
        let k = S::CORNERS;
        let stamp = self.stamp();
        let key = |u: u32| (vertex_of[u as usize] as u64) << 32 | u as u64;
        self.keys.clear();
        self.seen[v] = stamp;
        self.keys.push(key(v as u32));
        for &item in items {
            let (cell, c) = (cells[item as usize / k].as_ref(), item as usize % k);
            for (o, &u) in cell.iter().enumerate() {
                if o != c && self.seen[u as usize] != stamp {
                    self.seen[u as usize] = stamp;
                    self.keys.push(key(u));
                }
            }
        }
        sort_small(&mut self.keys);
        &self.keys
    }
}

/// Sorts a short slice (a row: about 15 entries) by insertion, a longer one by the library.
#[inline]
fn sort_small(keys: &mut [u64]) {
    if keys.len() > 32 {
        keys.sort_unstable();
        return;
    }
    for i in 1..keys.len() {
        let x = keys[i];
        let mut j = i;
        while j > 0 && keys[j - 1] > x {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = x;
    }
}

/// The row starts in the user's order (length `n + 1`) of the pattern of the mesh `cells`
/// (internal numbering) with corner incidence `corners`: one pass that counts the distinct
/// columns of every row (no columns stored).
pub(crate) fn row_starts<S: Simplex>(cells: &[S::Cell], corners: &Incidence, vertex_of: &[u32], opts: &Options) -> Result<Vec<usize>> {
    let n = vertex_of.len();
    let pool = Pool::new();
    let mut length = vec![0u32; n];
    length.par_chunks_mut(ROW_CHUNK).enumerate().try_for_each(|(c, lengths)| {
        opts.cancelled()?;
        pool.with(
            || RowScratch::new(n),
            |scratch| {
                for (k, length) in lengths.iter_mut().enumerate() {
                    let v = c * ROW_CHUNK + k;
                    *length = scratch.count::<S>(v, corners.of(v), cells);
                }
            },
        );
        Ok::<(), crate::Error>(())
    })?;
    let mut by_user = vec![0u32; n];
    for (&u, &len) in vertex_of.iter().zip(&length) {
        by_user[u as usize] = len;
    }
    let mut indptr = Vec::with_capacity(n + 1);
    indptr.push(0);
    for len in by_user {
        indptr.push(indptr.last().expect("starts with 0") + len as usize);
    }
    Ok(indptr)
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
    /// Builds the topology of a mesh in its internal order `layout` (see
    /// [`crate::assembly::order`]) with its corner incidence `corners`.
    pub(crate) fn new<S: Simplex>(layout: &Layout<S>, corners: Incidence, opts: &Options) -> Result<Self> {
        let rows = Rows::<S> { cells: &layout.cells, vertex_of: &layout.vertex_of, corners };
        let indptr = row_starts::<S>(&layout.cells, &rows.corners, &layout.vertex_of, opts)?;
        let (n, k) = (layout.n_vertices(), S::CORNERS - 1);
        let mut indices = vec![0u32; *indptr.last().expect("n + 1 entries")];
        let mut corner_slots = vec![0u32; k * rows.corners.items.len()];
        let mut diagonal = vec![0u32; n];
        {
            let mut user_rows = rows_in_internal_order(&mut indices, &indptr, &layout.vertex_of);
            // the slots of every row, split at the rows' corner ranges
            let offsets: Vec<usize> = rows.corners.offsets.iter().map(|&o| k * o).collect();
            let slot_rows = groups_mut(&mut corner_slots, &offsets);
            let mut work: Vec<_> = user_rows.iter_mut().zip(slot_rows).zip(diagonal.iter_mut()).collect();
            let pool = Pool::new();
            work.par_chunks_mut(ROW_CHUNK).enumerate().try_for_each(|(c, chunk)| {
                opts.cancelled()?;
                pool.with(
                    || (RowScratch::new(n), vec![0u32; n]),
                    |(scratch, position)| {
                        for (r, ((out, slots), diagonal)) in chunk.iter_mut().enumerate() {
                            let v = c * ROW_CHUNK + r;
                            let items = rows.corners.of(v);
                            let keys = scratch.columns::<S>(v, items, &layout.cells, &layout.vertex_of);
                            for (p, (&key, out)) in keys.iter().zip(out.iter_mut()).enumerate() {
                                position[key as u32 as usize] = p as u32;
                                *out = (key >> 32) as u32;
                            }
                            **diagonal = position[v];
                            row_slots::<S>(items, &layout.cells, position, slots);
                        }
                    },
                );
                Ok::<(), crate::Error>(())
            })?;
        }
        let Rows { corners, .. } = rows;
        Ok(Topology { n, corners, corner_slots, diagonal, vertex_of: layout.vertex_of.clone(), indptr, indices })
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

/// The slots of the element-corners `items` of one row: for each, the positions in the row
/// (`position[u]` of internal vertex `u`) of the other corners of its element, ascending
/// corner order.
#[inline]
fn row_slots<S: Simplex>(items: &[u32], cells: &[S::Cell], position: &[u32], slots: &mut [u32]) {
    let k = S::CORNERS;
    let mut out = slots.iter_mut();
    for &item in items {
        let (cell, c) = (cells[item as usize / k].as_ref(), item as usize % k);
        for (o, &u) in cell.iter().enumerate() {
            if o != c {
                *out.next().expect("K - 1 slots per corner") = position[u as usize];
            }
        }
    }
}

/// One row of the pattern as built from the elements around its vertex.
pub(crate) struct Row<'a> {
    /// Columns sorted by the user's vertex index: the vertex and its neighbours.
    pub cols: &'a [u32],
    /// For the q-th element-corner around the vertex, the positions in `cols` of the other
    /// `K - 1` corners of its element (ascending corner order): `slots[(K-1) q ..]`.
    #[allow(dead_code)]
    pub slots: &'a [u32],
    /// Position of the vertex itself in `cols`.
    #[allow(dead_code)]
    pub diagonal: u32,
}

/// Scratch of [`Rows::build`]: row building and positions per vertex, with the row's
/// buffers.
struct Scratch {
    rows: RowScratch,
    position: Vec<u32>,
    cols: Vec<u32>,
    slots: Vec<u32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Option<Scratch>> = const { std::cell::RefCell::new(None) };
}

/// The rows of a mesh's pattern, built on demand from the elements around each vertex.
pub(crate) struct Rows<'a, S: Simplex> {
    cells: &'a [S::Cell],
    vertex_of: &'a [u32],
    pub corners: Incidence,
}

impl<'a, S: Simplex> Rows<'a, S> {
    /// The element-corners around every vertex; `user_cells` are the mesh's elements in the
    /// user's order and numbering.
    pub fn new(layout: &'a Layout<S>, user_cells: &[S::Cell], opts: &Options) -> Result<Self> {
        let corners = corner_incidence::<S>(user_cells, &layout.rank, &layout.internal_of, opts)?;
        Ok(Rows { cells: &layout.cells, vertex_of: &layout.vertex_of, corners })
    }

    /// Internal row `v` with its columns as user indices, sorted (see [`Row`]).
    pub fn build<R>(&self, v: usize, f: impl FnOnce(Row) -> R) -> R {
        let n = self.vertex_of.len();
        SCRATCH.with(|scratch| {
            let mut scratch = scratch.borrow_mut();
            if scratch.as_ref().is_none_or(|s| s.position.len() != n) {
                *scratch = Some(Scratch { rows: RowScratch::new(n), position: vec![0; n], cols: vec![], slots: vec![] });
            }
            let s = scratch.as_mut().expect("made above");
            let items = self.corners.of(v);
            let keys = s.rows.columns::<S>(v, items, self.cells, self.vertex_of);
            s.cols.clear();
            for (p, &key) in keys.iter().enumerate() {
                s.position[key as u32 as usize] = p as u32;
                s.cols.push((key >> 32) as u32);
            }
            s.slots.resize((S::CORNERS - 1) * items.len(), 0);
            row_slots::<S>(items, self.cells, &s.position, &mut s.slots);
            let diagonal = s.position[v];
            f(Row { cols: &s.cols, slots: &s.slots, diagonal })
        })
    }
}

/// Element-corners `K t + c` (internal `t`) per internal vertex, in ascending user element
/// index, from the user's `cells` (`rank[u]`: internal index of user vertex `u`;
/// `internal_of[e]`: internal index of user element `e`).
pub(crate) fn corner_incidence<S: Simplex>(
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
    let (offsets, items) = group_u32(rank.len(), k * cells.len(), corner, opts)?;
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
        let corners = corner_incidence::<Tet>(&user_cells, &layout.rank, &layout.internal_of, &Options::default()).unwrap();
        let t = Topology::new::<Tet>(&layout, corners, &Options::default()).unwrap();
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
        // the rows on demand and their counts are the same
        let rows = Rows::<Tet>::new(&layout, &user_cells, &Options::default()).unwrap();
        let starts = row_starts::<Tet>(&layout.cells, &rows.corners, &layout.vertex_of, &Options::default()).unwrap();
        assert_eq!(starts, t.indptr());
        for v in 0..6 {
            rows.build(v, |r| assert_eq!(r.cols, row(layout.vertex_of[v] as usize)));
        }
    }

    #[test]
    fn short_rows_sort_like_the_library() {
        let mut state = 9u64;
        for len in [0, 1, 2, 15, 32, 33, 100] {
            let mut keys: Vec<u64> = (0..len)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    state >> 40
                })
                .collect();
            let mut expected = keys.clone();
            expected.sort_unstable();
            sort_small(&mut keys);
            assert_eq!(keys, expected);
        }
    }
}
