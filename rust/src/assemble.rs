//! The scatter: per-element values summed onto rows and vertices in a fixed order (the
//! elements around a vertex, ascending), so that the output is bitwise identical for any
//! number of threads and for every route (one-shot, cached, updated).

use crate::csr::{Csr, Mass};
use crate::options::{MassKind, Options};
use crate::simplex::{edge_index, Simplex};
use crate::topology::{groups_mut, Incidence, Rows, Topology};
use rayon::prelude::*;

/// Fills one row of an operator: entry `(i, j)` is the sum, over the elements around `i`
/// in ascending order (`items`, with the row positions `slots` of their other corners), of
/// `edge(t, e)` for their local edge `e = (i, j)`; the diagonal (at `diag`) is
/// `diagonal(s)` with `s` the row's off-diagonal sum in column order. Every assembly path
/// goes through here, hence their bitwise agreement.
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

/// Writes rows `rows` (all rows when `None`) of an operator on the topology's pattern into
/// `data`, by [`fill_row`] with `diagonal(i, off-diagonal sum)`.
fn gather_rows<S: Simplex>(
    topo: &Topology,
    data: &mut [f64],
    rows: Option<&[u32]>,
    edge: impl Fn(usize, usize) -> f64 + Sync,
    diagonal: impl Fn(usize, f64) -> f64 + Sync,
) {
    let k = S::CORNERS - 1;
    let fill = |i: usize, row: &mut [f64]| {
        let range = topo.corners.offsets[i]..topo.corners.offsets[i + 1];
        let slots = &topo.corner_slots[k * range.start..k * range.end];
        let items = &topo.corners.items[range];
        fill_row::<S>(row, items, slots, topo.diagonal[i] as usize, &edge, |s| diagonal(i, s));
    };
    match rows {
        None => groups_mut(data, &topo.indptr)
            .into_par_iter()
            .enumerate()
            .for_each(|(i, row)| fill(i, row)),
        Some(rows) => {
            for &i in rows {
                let i = i as usize;
                fill(i, &mut data[topo.indptr[i]..topo.indptr[i + 1]]);
            }
        }
    }
}

/// The rows of `data` if present, else one `None` per row.
fn optional_rows<'a>(data: &'a mut Option<Vec<f64>>, indptr: &[usize]) -> Vec<Option<&'a mut [f64]>> {
    match data {
        Some(d) => groups_mut(d, indptr).into_iter().map(Some).collect(),
        None => (0..indptr.len() - 1).map(|_| None).collect(),
    }
}

/// One-shot assembly without storing the slot map: every row is built from its elements
/// and filled at once. Returns the column indices and, if asked, the Laplacian's values
/// (from per-element weights) and the consistent mass's values (from per-element measures
/// in slot 0 of `vol`).
fn assemble_rows<S: Simplex>(
    rows: &Rows<S>,
    w: Option<&[S::EdgeValues]>,
    vol: Option<&[S::CornerValues]>,
) -> (Vec<u32>, Option<Vec<f64>>, Option<Vec<f64>>) {
    let (k, (off, on)) = (S::CORNERS, S::FEM);
    let nnz = rows.nnz();
    let mut indices = vec![0u32; nnz];
    let mut lap = w.map(|_| vec![0.0; nnz]);
    let mut fem = vol.map(|_| vec![0.0; nnz]);
    let (lap_rows, fem_rows) = (optional_rows(&mut lap, &rows.indptr), optional_rows(&mut fem, &rows.indptr));
    groups_mut(&mut indices, &rows.indptr)
        .into_par_iter()
        .zip(lap_rows)
        .zip(fem_rows)
        .enumerate()
        .for_each(|(i, ((cols, lap_row), fem_row))| {
            let items = rows.corners.of(i);
            rows.build(i, |row| {
                cols.copy_from_slice(row.cols);
                let diag = row.diagonal as usize;
                if let (Some(out), Some(w)) = (lap_row, w) {
                    fill_row::<S>(out, items, row.slots, diag, &|t, e| w[t].as_ref()[e], |s| -s);
                }
                if let (Some(out), Some(vol)) = (fem_row, vol) {
                    let d: f64 = items.iter().map(|&q| vol[q as usize / k].as_ref()[0] / on).sum();
                    fill_row::<S>(out, items, row.slots, diag, &|t, _| vol[t].as_ref()[0] / off, |_| d);
                }
            })
        });
    (indices, lap, fem)
}

/// Sum over the elements around every vertex (ascending) of `corner(t, c)`.
fn gather_vertices<S: Simplex>(corners: &Incidence, corner: impl Fn(usize, usize) -> f64 + Sync) -> Vec<f64> {
    let k = S::CORNERS;
    (0..corners.offsets.len() - 1)
        .into_par_iter()
        .map(|i| corners.of(i).iter().map(|&q| corner(q as usize / k, q as usize % k)).sum())
        .collect()
}

/// One-shot assembly of the requested operators from per-element values: the Laplacian
/// from edge weights `w`, the mass of `kind` from corner masses `m`.
pub(crate) fn assemble<S: Simplex>(
    rows: Rows<S>,
    w: Option<&[S::EdgeValues]>,
    mass: Option<(MassKind, &[S::CornerValues])>,
) -> (Option<Csr>, Option<Mass>) {
    let fem = mass.and_then(|(kind, m)| (kind == MassKind::Fem).then_some(m));
    let lumped = mass
        .filter(|(kind, _)| *kind != MassKind::Fem)
        .map(|(_, m)| Mass::Lumped(gather_vertices::<S>(&rows.corners, |t, c| m[t].as_ref()[c])));
    let (indices, lap, fem) = assemble_rows(&rows, w, fem);
    let n = rows.indptr.len() - 1;
    let laplacian = lap.map(|data| Csr { n, indptr: rows.indptr.clone(), indices: indices.clone(), data });
    let mass = lumped.or_else(|| {
        fem.map(|data| Mass::Consistent(Csr { n, indptr: rows.indptr, indices, data }))
    });
    (laplacian, mass)
}

/// Laplacian values on the pattern, for all rows (`rows = None`) or the listed ones.
pub(crate) fn laplacian_values<S: Simplex>(
    topo: &Topology,
    w: &[S::EdgeValues],
    rows: Option<&[u32]>,
    mut data: Vec<f64>,
) -> Vec<f64> {
    data.resize(topo.nnz(), 0.0);
    gather_rows::<S>(topo, &mut data, rows, |t, e| w[t].as_ref()[e], |_, sum| -sum);
    data
}

/// Mass values (per vertex, or CSR data for FEM) for all rows or the listed ones.
pub(crate) fn mass_values<S: Simplex>(
    topo: &Topology,
    kind: MassKind,
    m: &[S::CornerValues],
    rows: Option<&[u32]>,
    mut values: Vec<f64>,
) -> Vec<f64> {
    let k = S::CORNERS;
    let (off, on) = S::FEM;
    let vertex = |i: usize, f: &dyn Fn(usize, usize) -> f64| -> f64 {
        topo.corners.of(i).iter().map(|&q| f(q as usize / k, q as usize % k)).sum()
    };
    match (kind, rows) {
        (MassKind::Fem, _) => {
            values.resize(topo.nnz(), 0.0);
            let diagonal = |i: usize, _| vertex(i, &|t, _| m[t].as_ref()[0] / on);
            gather_rows::<S>(topo, &mut values, rows, |t, _| m[t].as_ref()[0] / off, diagonal);
            values
        }
        (_, None) => gather_vertices::<S>(&topo.corners, |t, c| m[t].as_ref()[c]),
        (_, Some(rows)) => {
            for &i in rows {
                values[i as usize] = vertex(i as usize, &|t, c| m[t].as_ref()[c]);
            }
            values
        }
    }
}

/// Runs `f` with the options' threads, after checking them for meshes of `S`.
pub(crate) fn with_threads<S: Simplex, R: Send>(
    opts: &Options,
    f: impl FnOnce() -> crate::Result<R> + Send,
) -> crate::Result<R> {
    opts.check::<S>()?;
    crate::parallel::run(opts.threads, f)?
}
