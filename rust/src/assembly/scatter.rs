//! The scatter: per-element values summed onto rows and vertices in a fixed order (the
//! elements around a vertex, in the canonical internal order of [`crate::assembly::order`]), so
//! that the output is bitwise identical for any number of threads, for every route
//! (one-shot, cached, updated) and for every numbering of the input.

use crate::sparse::{Csr, Mass};
use crate::error::Result;
use crate::assembly::order::Layout;
use crate::options::{MassKind, Options};
use crate::element::{edge_index, Simplex};
use crate::topology::group::Incidence;
use crate::assembly::pass::{values_by, Elements, FirstFault, Pool, Slots};
use crate::assembly::pattern::{for_each_row, rows_in_internal_order, RowScratch, Topology, ROW_CHUNK};
use crate::element::{Fault, Request};
use rayon::prelude::*;

/// Fills one row of an operator: entry `(i, j)` is the sum, over the elements around `i`
/// in ascending user index (`items`, with the row positions `slots` of their other
/// corners), of `edge(t, e)` for their local edge `e = (i, j)`; the diagonal (at `diag`)
/// is the sum over the same elements of `corner(t, c)`, `c` the local corner of `i`, or
/// without it of minus the edge values just added ([`crate::element::corner_sums`], bit
/// for bit). Every assembly path goes through here (or sums in the same order), hence
/// their bitwise agreement.
#[inline]
fn fill_row<S: Simplex>(
    row: &mut [f64],
    items: &[u32],
    slots: &[u32],
    diag: usize,
    edge: &impl Fn(usize, usize) -> f64,
    corner: Option<&dyn Fn(usize, usize) -> f64>,
) {
    let k = S::CORNERS;
    row.fill(0.0);
    let mut d = 0.0;
    for (&item, slot) in items.iter().zip(slots.chunks_exact(k - 1)) {
        let (t, c) = (item as usize / k, item as usize % k);
        let mut sum = 0.0;
        for (o, &col) in (0..k).filter(|&o| o != c).zip(slot) {
            let x = edge(t, edge_index(k, c, o));
            row[col as usize] += x;
            sum -= x;
        }
        d += corner.map_or(sum, |f| f(t, c));
    }
    row[diag] = d;
}

/// Writes rows `rows` (internal ids; all rows when `None`) of an operator on the
/// topology's pattern into `data` (user order), by [`fill_row`].
fn gather_rows<S: Simplex>(
    topo: &Topology,
    data: &mut [f64],
    rows: Option<&[u32]>,
    opts: &Options,
    edge: impl Fn(usize, usize) -> f64 + Sync,
    corner: Option<&(dyn Fn(usize, usize) -> f64 + Sync)>,
) -> Result<()> {
    let k = S::CORNERS - 1;
    let fill = |v: usize, row: &mut [f64]| {
        let range = topo.corners.offsets[v]..topo.corners.offsets[v + 1];
        let slots = &topo.corner_slots[k * range.start..k * range.end];
        let items = &topo.corners.items[range];
        let corner = corner.map(|f| f as &dyn Fn(usize, usize) -> f64);
        fill_row::<S>(row, items, slots, topo.diagonal[v] as usize, &edge, corner);
    };
    match rows {
        None => {
            let mut rows = rows_in_internal_order(data, topo.indptr(), &topo.vertex_of);
            for_each_row(&mut rows, opts, |v, row| fill(v, row))
        }
        Some(rows) => {
            for &v in rows {
                let u = topo.vertex_of[v as usize] as usize;
                fill(v as usize, &mut data[topo.indptr()[u]..topo.indptr()[u + 1]]);
            }
            Ok(())
        }
    }
}

/// Elements per stripe of a one-shot assembly (the per-element values of a stripe are held
/// at once: 48 bytes per tet for a Laplacian, 32 more for a mass).
const STRIPE_ELEMENTS: usize = 1 << 16;

/// The scratch of one worker filling rows.
struct RowWork {
    rows: RowScratch,
    /// Position in the current row of every internal vertex (stale outside it).
    position: Vec<u32>,
    /// The values of the current row.
    row: Vec<f64>,
}

/// The output rows of some internal rows (user-order slices, listed in internal order).
struct RowsOut<'s, 'a> {
    indices: &'s mut [&'a mut [u32]],
    lap: Option<&'s mut [&'a mut [f64]]>,
    fem: Option<&'s mut [&'a mut [f64]]>,
    lumped: Option<&'s mut [f64]>,
}

impl<'s, 'a> RowsOut<'s, 'a> {
    /// The outputs split at `bounds` (internal rows relative to the first).
    fn split(self, bounds: &[usize]) -> Vec<RowsOut<'s, 'a>> {
        split_at_bounds(self.indices, bounds)
            .into_iter()
            .zip(parts_of(self.lap, bounds))
            .zip(parts_of(self.fem, bounds))
            .zip(parts_of(self.lumped, bounds))
            .map(|(((indices, lap), fem), lumped)| RowsOut { indices, lap, fem, lumped })
            .collect()
    }
}

/// `v` (if any) split at `bounds`, or no part for each.
fn parts_of<'s, T>(v: Option<&'s mut [T]>, bounds: &[usize]) -> Vec<Option<&'s mut [T]>> {
    match v {
        Some(v) => split_at_bounds(v, bounds).into_iter().map(Some).collect(),
        None => (1..bounds.len()).map(|_| None).collect(),
    }
}

/// `v` split at `bounds` (ascending, from 0 to `v.len()`).
fn split_at_bounds<'a, T>(mut v: &'a mut [T], bounds: &[usize]) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(bounds.len().saturating_sub(1));
    for w in bounds.windows(2) {
        let (head, rest) = v.split_at_mut(w[1] - w[0]);
        out.push(head);
        v = rest;
    }
    out
}

/// What a one-shot assembly gives: the Laplacian and the mass asked for, and the faulty
/// elements its policy skipped (user index, ascending).
pub(crate) type Assembled = (Option<Csr>, Option<Mass>, Vec<(usize, Fault)>);

/// One-shot assembly of `request` on the rows starting at `indptr` (user order): the
/// Laplacian from the elements' edge values, the mass from their corner values.
///
/// The internal rows are cut into stripes of about [`STRIPE_ELEMENTS`] elements, one after
/// the other. A stripe computes, in parallel chunks, the values of its elements (those
/// whose first vertex is one of its rows, a contiguous range of the internal order) and of
/// the elements of earlier stripes around its rows ("ghosts"), then builds and fills its
/// rows in parallel chunks, each written once in its place: entry `(i, j)` is the sum over
/// the elements around `i` in ascending user index (the corner incidence) of their value
/// at edge `ij`; the diagonal is the sum, over the same elements, of their diagonal entry
/// at `i` (the Laplacian) or of their FEM diagonal; a lumped mass is the sum of the corner
/// values. Only one stripe's
/// values are held at once. [`gather_rows`] sums the same way: one-shot, cached and
/// updated operators agree bit for bit.
pub(crate) fn assemble<S: Simplex>(
    layout: &Layout<S>,
    elements: &Elements<S>,
    corners: &Incidence,
    indptr: Vec<usize>,
    request: Request,
    opts: &Options,
) -> Result<Assembled> {
    let (n, nnz) = (layout.n_vertices(), *indptr.last().expect("n + 1 entries"));
    let cells = &layout.cells[..];
    let fem_mass = request.mass == Some(MassKind::Fem);
    let mut indices = vec![0u32; nnz];
    let mut lap = request.laplacian.map(|_| vec![0.0; nnz]);
    let mut fem = fem_mass.then(|| vec![0.0; nnz]);
    let mut lumped = request.mass.filter(|_| !fem_mass).map(|_| vec![0.0; n]);
    // stripes: whole row chunks, about STRIPE_ELEMENTS elements each (the first vertex of
    // internal element t is non-decreasing in t)
    let per_stripe = (STRIPE_ELEMENTS * n / cells.len().max(1)).max(1).div_ceil(ROW_CHUNK) * ROW_CHUNK;
    let bounds: Vec<usize> = (0..n).step_by(per_stripe).chain([n]).collect();
    let first = |c: &S::Cell| *c.as_ref().iter().min().expect("corners") as usize;
    let element_bounds: Vec<usize> = bounds.iter().map(|&v| cells.partition_point(|c| first(c) < v)).collect();
    let skipped = {
        let (indptr, vertex_of) = (&indptr, &layout.vertex_of[..]);
        let mut index_rows = rows_in_internal_order(&mut indices, indptr, vertex_of);
        let mut lap_rows = lap.as_deref_mut().map(|d| rows_in_internal_order(d, indptr, vertex_of));
        let mut fem_rows = fem.as_deref_mut().map(|d| rows_in_internal_order(d, indptr, vertex_of));
        let all = RowsOut {
            indices: &mut index_rows,
            lap: lap_rows.as_deref_mut(),
            fem: fem_rows.as_deref_mut(),
            lumped: lumped.as_deref_mut(),
        };
        let mut values = Values::<S> { ghosts: vec![], local_of: vec![0; cells.len()], own: 0..0, w: vec![], d: vec![], m: vec![] };
        let pool = Pool::new();
        let mut first = FirstFault::default();
        for (s, out) in all.split(&bounds).into_iter().enumerate() {
            let (rows, own) = (bounds[s]..bounds[s + 1], element_bounds[s]..element_bounds[s + 1]);
            first.merge(values.compute(elements, corners, rows.clone(), own, request, opts)?);
            fill_rows(layout, corners, &values, rows, out, &pool, opts)?;
        }
        first.check(opts.degenerate)?;
        first.all()
    };
    opts.cancelled()?;
    let laplacian = lap.map(|data| Csr { n, indptr: indptr.clone(), indices: indices.clone(), data });
    let mass = match (lumped, fem) {
        (Some(internal), _) => Some(Mass::Lumped(layout.to_user_vertices(&internal))),
        (_, Some(data)) => Some(Mass::Consistent(Csr { n, indptr, indices, data })),
        _ => None,
    };
    if let Some(l) = &laplacian {
        finite_rows(&l.indptr, &l.data)?;
    }
    match &mass {
        Some(Mass::Lumped(m)) => finite_rows(&(0..=n).collect::<Vec<_>>(), m)?,
        Some(Mass::Consistent(m)) => finite_rows(&m.indptr, &m.data)?,
        None => {}
    }
    Ok((laplacian, mass, skipped))
}

/// The per-element values of one stripe: its own elements (a range of the internal order)
/// then its ghosts.
struct Values<S: Simplex> {
    /// Elements of earlier stripes around the stripe's rows, ascending.
    ghosts: Vec<u32>,
    /// The place of every ghost among the values (stale for other elements).
    local_of: Vec<u32>,
    own: std::ops::Range<usize>,
    w: Vec<S::EdgeValues>,
    /// The Laplacian's diagonal entries, where they are the elements' own
    /// ([`Simplex::own_diagonal`]; else empty).
    d: Vec<S::CornerValues>,
    m: Vec<S::CornerValues>,
}

impl<S: Simplex> Values<S> {
    /// The values `request` asks for of the elements around `rows`, whose own elements are
    /// `own`: the first faulty one.
    fn compute(
        &mut self,
        elements: &Elements<S>,
        corners: &Incidence,
        rows: std::ops::Range<usize>,
        own: std::ops::Range<usize>,
        request: Request,
        opts: &Options,
    ) -> Result<FirstFault> {
        opts.cancelled()?;
        let k = S::CORNERS as u32;
        let items = &corners.items[corners.offsets[rows.start]..corners.offsets[rows.end]];
        self.ghosts.clear();
        self.ghosts.extend(items.iter().map(|&q| q / k).filter(|&t| (t as usize) < own.start));
        self.ghosts.par_sort_unstable();
        self.ghosts.dedup();
        for (i, &g) in self.ghosts.iter().enumerate() {
            self.local_of[g as usize] = (own.len() + i) as u32;
        }
        let count = own.len() + self.ghosts.len();
        let ghosts = &self.ghosts;
        let t_of = |i: usize| if i < own.len() { own.start + i } else { ghosts[i - own.len()] as usize };
        self.w.clear();
        self.d.clear();
        self.m.clear();
        let own_diagonal = request.laplacian.is_some_and(S::own_diagonal);
        if request.laplacian.is_some() {
            self.w.resize(count, Default::default());
        }
        if own_diagonal {
            self.d.resize(count, Default::default());
        }
        if request.mass.is_some() {
            self.m.resize(count, S::CornerValues::default());
        }
        let out = Slots {
            w: request.laplacian.map(|_| &mut self.w[..]),
            d: own_diagonal.then_some(&mut self.d[..]),
            m: request.mass.map(|_| &mut self.m[..]),
        };
        let faults = values_by(elements, opts, count, t_of, request, out)?;
        self.own = own;
        Ok(faults)
    }

    /// Where the values of internal element `t` are.
    #[inline]
    fn local(&self, t: usize) -> usize {
        if t >= self.own.start { t - self.own.start } else { self.local_of[t] as usize }
    }
}

/// Builds and fills the internal `rows` of a stripe (see [`assemble`]) into `out`, in
/// parallel chunks of [`ROW_CHUNK`] rows.
fn fill_rows<S: Simplex>(
    layout: &Layout<S>,
    corners: &Incidence,
    values: &Values<S>,
    rows: std::ops::Range<usize>,
    out: RowsOut,
    pool: &Pool<RowWork>,
    opts: &Options,
) -> Result<()> {
    let n = layout.n_vertices();
    let bounds: Vec<usize> = (0..rows.len()).step_by(ROW_CHUNK).chain([rows.len()]).collect();
    out.split(&bounds).into_par_iter().enumerate().try_for_each(|(c, out)| {
        opts.cancelled()?;
        let first = rows.start + c * ROW_CHUNK;
        let make = || RowWork { rows: RowScratch::new(n), position: vec![0; n], row: vec![] };
        pool.with(make, |work| fill_chunk::<S>(layout, corners, values, first, out, work));
        Ok(())
    })
}

/// [`fill_rows`] for the internal rows from `first` on, one chunk.
fn fill_chunk<S: Simplex>(
    layout: &Layout<S>,
    corners: &Incidence,
    values: &Values<S>,
    first: usize,
    out: RowsOut,
    work: &mut RowWork,
) {
    let k = S::CORNERS;
    let RowWork { rows: builder, position, row } = work;
    let RowsOut { indices, mut lap, mut fem, mut lumped } = out;
    let (w, own, m) = (&values.w, &values.d, &values.m);
    for (r, index_row) in indices.iter_mut().enumerate() {
        let v = first + r;
        // the row's columns, sorted by user index, and where each lands
        let items = corners.of(v);
        let keys = builder.columns::<S>(v, items, &layout.cells, &layout.vertex_of);
        for (p, (&key, index)) in keys.iter().zip(index_row.iter_mut()).enumerate() {
            position[key as u32 as usize] = p as u32;
            *index = (key >> 32) as u32;
        }
        let (len, diag) = (keys.len(), position[v] as usize);
        // each row is summed in a buffer and then written to its place: stores only there
        if let Some(lap) = lap.as_deref_mut() {
            row.clear();
            row.resize(len, 0.0);
            // the diagonal as fill_row sums it
            let mut d = 0.0;
            for &item in items {
                let (t, c) = (item as usize / k, item as usize % k);
                let (cell, local) = (layout.cells[t].as_ref(), values.local(t));
                let value = w[local].as_ref();
                let mut sum = 0.0;
                for (o, &u) in cell.iter().enumerate() {
                    if o != c {
                        let x = value[edge_index(k, c, o)];
                        row[position[u as usize] as usize] += x;
                        sum -= x;
                    }
                }
                d += if own.is_empty() { sum } else { own[local].as_ref()[c] };
            }
            row[diag] = d;
            lap[r].copy_from_slice(row);
        }
        if let Some(fem) = fem.as_deref_mut() {
            row.clear();
            row.resize(len, 0.0);
            for &item in items {
                let (t, c) = (item as usize / k, item as usize % k);
                let value = m[values.local(t)].as_ref()[0] / S::FEM.0;
                for (o, &u) in layout.cells[t].as_ref().iter().enumerate() {
                    if o != c {
                        row[position[u as usize] as usize] += value;
                    }
                }
            }
            // summed as fill_row sums it
            let mut d = 0.0;
            for &q in items {
                d += m[values.local(q as usize / k)].as_ref()[0] / S::FEM.1;
            }
            row[diag] = d;
            fem[r].copy_from_slice(row);
        }
        if let Some(lumped) = lumped.as_deref_mut() {
            lumped[r] = items.iter().map(|&q| m[values.local(q as usize / k)].as_ref()[q as usize % k]).sum();
        }
    }
}

/// Sum over the elements around every internal vertex (ascending user index) of
/// `corner(t, c)`.
fn gather_vertices<S: Simplex>(
    corners: &Incidence,
    corner: impl Fn(usize, usize) -> f64 + Sync,
) -> Vec<f64> {
    let k = S::CORNERS;
    (0..corners.offsets.len() - 1)
        .into_par_iter()
        .map(|v| corners.of(v).iter().map(|&q| corner(q as usize / k, q as usize % k)).sum())
        .collect()
}

/// [`crate::Error::SumOverflow`] for the first row (user order) of `data` (split at
/// `indptr`) with a value that is not finite. Every element's own values are finite by
/// then, so such a value can only be a sum that left the `f64` range.
pub(crate) fn finite_rows(indptr: &[usize], data: &[f64]) -> Result<()> {
    match crate::threads::position_first(data, |_, x| !x.is_finite())? {
        None => Ok(()),
        Some(k) => Err(crate::Error::SumOverflow { vertex: indptr.partition_point(|&p| p <= k) - 1 }),
    }
}

/// Laplacian values on the pattern, for all rows (`rows = None`) or the listed internal
/// ones.
pub(crate) fn laplacian_values<S: Simplex>(
    topo: &Topology,
    w: &[(S::EdgeValues, S::CornerValues)],
    rows: Option<&[u32]>,
    mut data: Vec<f64>,
    opts: &Options,
) -> Result<Vec<f64>> {
    data.resize(topo.nnz(), 0.0);
    let corner = |t: usize, c: usize| w[t].1.as_ref()[c];
    gather_rows::<S>(topo, &mut data, rows, opts, |t, e| w[t].0.as_ref()[e], Some(&corner))?;
    Ok(data)
}

/// Mass values (per user vertex, or CSR data for FEM) for all rows or the listed internal
/// ones.
pub(crate) fn mass_values<S: Simplex>(
    topo: &Topology,
    kind: MassKind,
    m: &[S::CornerValues],
    rows: Option<&[u32]>,
    mut values: Vec<f64>,
    opts: &Options,
) -> Result<Vec<f64>> {
    let k = S::CORNERS;
    let vertex = |v: usize| -> f64 { topo.corners.of(v).iter().map(|&q| m[q as usize / k].as_ref()[q as usize % k]).sum() };
    match (kind, rows) {
        (MassKind::Fem, _) => {
            values.resize(topo.nnz(), 0.0);
            let (off, on) = S::FEM;
            let corner = |t: usize, _| m[t].as_ref()[0] / on;
            gather_rows::<S>(topo, &mut values, rows, opts, |t, _| m[t].as_ref()[0] / off, Some(&corner))?;
        }
        (_, None) => {
            values.resize(topo.n(), 0.0);
            let internal = gather_vertices::<S>(&topo.corners, |t, c| m[t].as_ref()[c]);
            for (&u, x) in topo.vertex_of.iter().zip(internal) {
                values[u as usize] = x;
            }
        }
        (_, Some(rows)) => {
            for &v in rows {
                values[topo.vertex_of[v as usize] as usize] = vertex(v as usize);
            }
        }
    }
    opts.cancelled()?;
    Ok(values)
}
