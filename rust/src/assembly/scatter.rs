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
use crate::assembly::pattern::{for_each_row, rows_in_internal_order, Rows, Topology};
use rayon::prelude::*;

/// Fills one row of an operator: entry `(i, j)` is the sum, over the elements around `i`
/// in ascending user index (`items`, with the row positions `slots` of their other
/// corners), of `edge(t, e)` for their local edge `e = (i, j)`; the diagonal (at `diag`)
/// is `diagonal(s)` with `s` the row's off-diagonal sum in column order. Every assembly
/// path goes through here, hence their bitwise agreement.
#[inline]
fn fill_row<S: Simplex>(
    row: &mut [f64],
    items: &[u32],
    slots: &[u32],
    diag: usize,
    edge: &impl Fn(usize, usize) -> f64,
    diagonal: impl FnOnce(f64) -> f64,
) {
    let k = S::CORNERS;
    row.fill(0.0);
    for (&corner, slot) in items.iter().zip(slots.chunks_exact(k - 1)) {
        let (t, c) = (corner as usize / k, corner as usize % k);
        for (o, &col) in (0..k).filter(|&o| o != c).zip(slot) {
            row[col as usize] += edge(t, edge_index(k, c, o));
        }
    }
    let sum: f64 = row.iter().sum();
    row[diag] = diagonal(sum);
}

/// The FEM diagonal of internal row `v`: `measure / on` summed over its elements.
fn fem_diagonal<S: Simplex>(items: &[u32], vol: &[S::CornerValues]) -> f64 {
    let k = S::CORNERS;
    items.iter().map(|&q| vol[q as usize / k].as_ref()[0] / S::FEM.1).sum()
}

/// Writes rows `rows` (internal ids; all rows when `None`) of an operator on the
/// topology's pattern into `data` (user order), by [`fill_row`] with
/// `diagonal(v, sum of the row's contributions)`.
fn gather_rows<S: Simplex>(
    topo: &Topology,
    data: &mut [f64],
    rows: Option<&[u32]>,
    opts: &Options,
    edge: impl Fn(usize, usize) -> f64 + Sync,
    diagonal: impl Fn(usize, f64) -> f64 + Sync,
) -> Result<()> {
    let k = S::CORNERS - 1;
    let fill = |v: usize, row: &mut [f64]| {
        let range = topo.corners.offsets[v]..topo.corners.offsets[v + 1];
        let slots = &topo.corner_slots[k * range.start..k * range.end];
        let items = &topo.corners.items[range];
        fill_row::<S>(row, items, slots, topo.diagonal[v] as usize, &edge, |s| diagonal(v, s));
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

/// One-shot assembly: every row is built once, its values filled at once into its chunk's
/// buffers, then moved to the user's order. Returns the row starts, the column indices
/// and, if asked, the Laplacian's values (from per-element weights) and the consistent
/// mass's values (from per-element measures in slot 0 of `vol`).
#[allow(clippy::type_complexity)]
fn assemble_rows<S: Simplex>(
    rows: &Rows<S>,
    vertex_of: &[u32],
    w: Option<&[S::EdgeValues]>,
    vol: Option<&[S::CornerValues]>,
    opts: &Options,
) -> Result<(Vec<usize>, Vec<u32>, Option<Vec<f64>>, Option<Vec<f64>>)> {
    #[derive(Default)]
    struct Values {
        cols: Vec<u32>,
        lap: Vec<f64>,
        fem: Vec<f64>,
    }
    /// `values` grown by one row of `len` zeros: the new row.
    fn new_row(values: &mut Vec<f64>, len: usize) -> &mut [f64] {
        let start = values.len();
        values.resize(start + len, 0.0);
        &mut values[start..]
    }
    let off = S::FEM.0;
    let built = rows.build_all(opts, |v, row, out: &mut Values| {
        let items = rows.corners.of(v);
        let diag = row.diagonal as usize;
        out.cols.extend_from_slice(row.cols);
        if let Some(w) = w {
            let values = new_row(&mut out.lap, row.cols.len());
            fill_row::<S>(values, items, row.slots, diag, &|t, e| w[t].as_ref()[e], |s| -s);
        }
        if let Some(vol) = vol {
            let d = fem_diagonal::<S>(items, vol);
            let values = new_row(&mut out.fem, row.cols.len());
            fill_row::<S>(values, items, row.slots, diag, &|t, _| vol[t].as_ref()[0] / off, |_| d);
        }
    })?;
    opts.cancelled()?;
    let indices = built.gather(vertex_of, |b| &b.cols);
    let lap = w.map(|_| built.gather(vertex_of, |b| &b.lap));
    let fem = vol.map(|_| built.gather(vertex_of, |b| &b.fem));
    Ok((built.indptr, indices, lap, fem))
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

/// One-shot assembly of the requested operators from per-element values in internal
/// order: the Laplacian from edge weights `w`, the mass of `kind` from corner masses `m`.
pub(crate) fn assemble<S: Simplex>(
    layout: &Layout<S>,
    rows: Rows<S>,
    w: Option<&[S::EdgeValues]>,
    mass: Option<(MassKind, &[S::CornerValues])>,
    opts: &Options,
) -> Result<(Option<Csr>, Option<Mass>)> {
    let fem = mass.and_then(|(kind, m)| (kind == MassKind::Fem).then_some(m));
    let lumped = mass.filter(|(kind, _)| *kind != MassKind::Fem).map(|(_, m)| {
        let internal = gather_vertices::<S>(&rows.corners, |t, c| m[t].as_ref()[c]);
        Mass::Lumped(layout.to_user_vertices(&internal))
    });
    let (indptr, indices, lap, fem) = assemble_rows(&rows, &layout.vertex_of, w, fem, opts)?;
    let n = layout.n_vertices();
    let laplacian = lap.map(|data| Csr { n, indptr: indptr.clone(), indices: indices.clone(), data });
    let mass = lumped.or_else(|| fem.map(|data| Mass::Consistent(Csr { n, indptr, indices, data })));
    if let Some(l) = &laplacian {
        finite_rows(&l.indptr, &l.data)?;
    }
    match &mass {
        Some(Mass::Lumped(m)) => finite_rows(&(0..=n).collect::<Vec<_>>(), m)?,
        Some(Mass::Consistent(m)) => finite_rows(&m.indptr, &m.data)?,
        None => {}
    }
    Ok((laplacian, mass))
}

/// [`crate::Error::SumOverflow`] for the first row (user order) of `data` (split at
/// `indptr`) with a value that is not finite. Every element's own values are finite by
/// then, so such a value can only be a sum that left the `f64` range.
pub(crate) fn finite_rows(indptr: &[usize], data: &[f64]) -> Result<()> {
    match crate::threads::position_first(data, |_, x| !x.is_finite()) {
        None => Ok(()),
        Some(k) => Err(crate::Error::SumOverflow { vertex: indptr.partition_point(|&p| p <= k) - 1 }),
    }
}

/// Laplacian values on the pattern, for all rows (`rows = None`) or the listed internal
/// ones.
pub(crate) fn laplacian_values<S: Simplex>(
    topo: &Topology,
    w: &[S::EdgeValues],
    rows: Option<&[u32]>,
    mut data: Vec<f64>,
    opts: &Options,
) -> Result<Vec<f64>> {
    data.resize(topo.nnz(), 0.0);
    gather_rows::<S>(topo, &mut data, rows, opts, |t, e| w[t].as_ref()[e], |_, sum| -sum)?;
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
            let diagonal = |v: usize, _| fem_diagonal::<S>(topo.corners.of(v), m);
            let off = S::FEM.0;
            gather_rows::<S>(topo, &mut values, rows, opts, |t, _| m[t].as_ref()[0] / off, diagonal)?;
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
