//! Drivers: the parallel per-tet pass (each tet writes its own slot) and the reductions
//! onto edges, rows and vertices in a fixed order, so that the output is bitwise identical
//! for any number of threads.

use crate::error::{Error, Result};
use crate::geometry::{local_tet, LocalTet};
use crate::local;
use crate::mesh::TetMesh;
use crate::topology::{boundary_tets, groups_mut, Incidence, Rows, Topology};
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Which Laplacian (paper Sec. 4-5, 9).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaplacianKind {
    /// P1 FEM / cotan weights (Eq. 7): always negative semidefinite.
    Primal,
    /// Circumcentric dual / DEC weights (Eq. 19-20): non-negative on Delaunay interiors.
    Dual,
    /// `(1 - t) primal + t dual`, `t` in `[0, 1]` (Sec. 9).
    Affine(f64),
}

/// Which mass matrix (paper Eq. 3, 4/21, consistent P1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MassKind {
    /// `Vol / 4` per tet corner, diagonal.
    Barycentric,
    /// Signed dual-cell volumes `Vol(*i)`, diagonal; negative on some non-Delaunay meshes.
    Circumcentric,
    /// Consistent P1 mass `Vol (1 + delta_ab) / 20`, on the edge pattern.
    Fem,
}

/// What to do with a tet of zero volume (or one so flat that its contribution overflows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Degenerate {
    /// Fail with [`Error::Degenerate`] / [`Error::NonFiniteResult`] naming the first such tet.
    #[default]
    Raise,
    /// Give such tets zero weights and zero mass (their edges stay in the pattern).
    Skip,
}

/// Dual vertices of tets with a boundary face (paper Sec. 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Boundary {
    /// Plain per-tet assembly: dual cells at the boundary are closed by the face
    /// circumcenters. Linear precision at every interior vertex; boundary weights and
    /// masses may be negative.
    #[default]
    Circumcentric,
    /// In tets with a boundary face, a tet or face circumcenter outside its simplex is
    /// replaced by the centroid: positive masses and weights there, at the cost of linear
    /// precision at the vertices of those tets.
    Barycentric,
}

/// Options common to every assembly.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Options {
    /// Worker threads; `None` uses rayon's global pool (all cores). Results do not depend
    /// on it.
    pub threads: Option<usize>,
    /// Policy for degenerate tets.
    pub degenerate: Degenerate,
    /// Boundary treatment of the dual Laplacian and the circumcentric mass.
    pub boundary: Boundary,
}

/// One tet could not be evaluated (zero volume, or a non-finite value; see
/// [`Elements::fault_error`] for which).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Fault;

/// Validates the affine parameter.
pub(crate) fn check_kind(kind: LaplacianKind) -> Result<()> {
    match kind {
        LaplacianKind::Affine(t) if !(0.0..=1.0).contains(&t) => Err(Error::InvalidOption {
            message: format!("the affine parameter t must lie in [0, 1], got {t}"),
        }),
        _ => Ok(()),
    }
}

/// Runs `f` on `threads` workers (a pool of its own) or on rayon's global pool.
pub(crate) fn run<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    match threads {
        None => Ok(f()),
        Some(0) => Err(Error::InvalidOption { message: "threads must be at least 1".into() }),
        Some(k) => rayon::ThreadPoolBuilder::new()
            .num_threads(k)
            .build()
            .map(|pool| pool.install(f))
            .map_err(|e| Error::InvalidOption { message: format!("thread pool: {e}") }),
    }
}

/// Where the per-element pass gets its elements from (tets or triangles).
pub(crate) trait Source: Sync {
    /// One element as its kernels see it.
    type Item;
    /// Element `t` (`scratch` holds `scratch_len()` values for immersed frames).
    fn get(&self, t: usize, scratch: &mut [f64]) -> Self::Item;
    /// Scratch length for [`Source::get`].
    fn scratch_len(&self) -> usize;
    /// The error for element `t`, known to fail: zero measure or a non-finite value.
    fn fault_error(&self, t: usize) -> Error;
}

/// Which tets get the barycentric boundary fix, if the options ask for it.
pub(crate) fn boundary_mask(mesh: &TetMesh, opts: &Options) -> Option<Vec<bool>> {
    (opts.boundary == Boundary::Barycentric).then(|| boundary_tets(mesh.tets()))
}

/// One tet as the kernels see it: its local frame, its vertex weights (scaled like the
/// frame, squared) if the dual is weighted, and whether the boundary fix applies to it.
pub(crate) struct Element {
    pub frame: LocalTet,
    pub weights: Option<[f64; 4]>,
    pub fix_boundary: bool,
    /// The dual, computed once however many operators ask for it.
    dual: std::cell::OnceCell<local::Dual>,
}

impl Element {
    fn dual(&self) -> local::Dual {
        *self.dual.get_or_init(|| {
            if self.weights.is_none() && !self.fix_boundary {
                return local::dual(&self.frame);
            }
            let centers = local::Centers::weighted(&self.frame, self.weights.unwrap_or([0.0; 4]));
            let centers =
                if self.fix_boundary { centers.clamp_to_centroids(&self.frame) } else { centers };
            local::dual_from_centers(&self.frame, &centers)
        })
    }
}

/// The tets of a mesh as [`Element`]s, with the boundary mask the options ask for.
pub(crate) struct Elements<'a> {
    mesh: TetMesh<'a>,
    boundary: Option<Cow<'a, [bool]>>,
}

impl<'a> Elements<'a> {
    pub fn new(mesh: TetMesh<'a>, opts: &Options) -> Self {
        Elements { mesh, boundary: boundary_mask(&mesh, opts).map(Cow::Owned) }
    }

    /// Elements with a boundary mask computed before (see [`boundary_mask`]).
    pub fn with_mask(mesh: TetMesh<'a>, boundary: Option<&'a [bool]>) -> Self {
        Elements { mesh, boundary: boundary.map(Cow::Borrowed) }
    }

}

impl Source for Elements<'_> {
    type Item = Element;

    fn get(&self, t: usize, scratch: &mut [f64]) -> Element {
        let mesh = &self.mesh;
        let tet = mesh.tets()[t];
        let frame = local_tet(tet.map(|v| mesh.point(v)), scratch);
        let s2 = frame.scale * frame.scale;
        let weights = mesh.weights().map(|w| tet.map(|v| (w[v as usize] - w[tet[0] as usize]) / s2));
        let fix_boundary = self.boundary.as_ref().is_some_and(|b| b[t]);
        Element { frame, weights, fix_boundary, dual: Default::default() }
    }

    fn fault_error(&self, t: usize) -> Error {
        let el = self.get(t, &mut vec![0.0; self.scratch_len()]);
        if local::is_degenerate(&el.frame) {
            Error::Degenerate { element: t }
        } else {
            Error::NonFiniteResult { element: t }
        }
    }

    fn scratch_len(&self) -> usize {
        if self.mesh.dim() > 3 { 3 * self.mesh.dim() } else { 0 }
    }
}

fn finite<const K: usize>(v: [f64; K]) -> std::result::Result<[f64; K], Fault> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(Fault)
    }
}

/// The six weights of one tet for `kind`.
pub(crate) fn weights(el: &Element, kind: LaplacianKind) -> std::result::Result<[f64; 6], Fault> {
    let t = &el.frame;
    if local::is_degenerate(t) {
        return Err(Fault);
    }
    finite(match kind {
        LaplacianKind::Primal => local::primal_weights(t),
        LaplacianKind::Dual => el.dual().weights,
        LaplacianKind::Affine(s) => {
            let (p, d) = (local::primal_weights(t), el.dual().weights);
            std::array::from_fn(|e| (1.0 - s) * p[e] + s * d[e])
        }
    })
}

/// The four corner masses of one tet for a lumped `kind`; for [`MassKind::Fem`] the tet's
/// volume in every slot.
pub(crate) fn corner_mass(el: &Element, kind: MassKind) -> std::result::Result<[f64; 4], Fault> {
    let t = &el.frame;
    if local::is_degenerate(t) {
        return Err(Fault);
    }
    finite(match kind {
        MassKind::Barycentric => local::barycentric_mass(t),
        MassKind::Circumcentric => el.dual().cell_volumes,
        MassKind::Fem => [local::volume(t); 4],
    })
}

/// Weights and corner masses of one tet (the dual, if both need it, is computed once).
pub(crate) fn weights_and_mass(
    el: &Element,
    lap: LaplacianKind,
    mass: MassKind,
) -> std::result::Result<([f64; 6], [f64; 4]), Fault> {
    Ok((weights(el, lap)?, corner_mass(el, mass)?))
}

/// The parallel per-tet pass: `f` of every tet, handed to `store` with the tet's own
/// output slot (`slots` yields one per tet, in order).
///
/// A tet for which `f` fails gets `T::default()` under [`Degenerate::Skip`]; under
/// [`Degenerate::Raise`] the first such tet (lowest index, whatever the scheduling) is
/// reported.
fn pass<Src: Source, T: Default, S: Send>(
    elements: &Src,
    degenerate: Degenerate,
    slots: impl IndexedParallelIterator<Item = S>,
    f: impl Fn(&Src::Item) -> std::result::Result<T, Fault> + Sync,
    store: impl Fn(S, T) + Sync,
) -> Result<()> {
    let first_fault = AtomicUsize::new(usize::MAX);
    slots.enumerate().for_each_init(
        || vec![0.0; elements.scratch_len()],
        |scratch, (t, slot)| match f(&elements.get(t, scratch)) {
            Ok(v) => store(slot, v),
            Err(_) => {
                store(slot, T::default());
                first_fault.fetch_min(t, Ordering::Relaxed);
            }
        },
    );
    fault_to_error(elements, degenerate, first_fault.into_inner())
}

/// [`pass`] into one output slot per tet.
pub(crate) fn per_tet<Src: Source, T: Copy + Default + Send + Sync>(
    elements: &Src,
    degenerate: Degenerate,
    out: &mut [T],
    f: impl Fn(&Src::Item) -> std::result::Result<T, Fault> + Sync,
) -> Result<()> {
    pass(elements, degenerate, out.par_iter_mut(), f, |slot, v| *slot = v)
}

/// [`pass`] into two output slots per tet (weights and corner masses in one pass).
pub(crate) fn per_tet_pair<Src, A, B>(
    elements: &Src,
    degenerate: Degenerate,
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(&Src::Item) -> std::result::Result<(A, B), Fault> + Sync,
) -> Result<()>
where
    Src: Source,
    A: Copy + Default + Send + Sync,
    B: Copy + Default + Send + Sync,
{
    let slots = a.par_iter_mut().zip(b.par_iter_mut());
    pass(elements, degenerate, slots, f, |(x, y), (u, v)| {
        *x = u;
        *y = v;
    })
}

/// [`per_tet`] for the listed tets only: their values, in the order of `tets`.
pub(crate) fn per_tet_subset<T: Copy + Default + Send + Sync>(
    elements: &Elements,
    degenerate: Degenerate,
    tets: &[u32],
    f: impl Fn(&Element) -> std::result::Result<T, Fault> + Sync,
) -> Result<Vec<T>> {
    let results: Vec<_> = tets
        .par_iter()
        .map_init(|| vec![0.0; elements.scratch_len()], |scratch, &t| {
            f(&elements.get(t as usize, scratch))
        })
        .collect();
    let first = tets.iter().zip(&results).filter(|(_, r)| r.is_err()).map(|(&t, _)| t as usize).min();
    fault_to_error(elements, degenerate, first.unwrap_or(usize::MAX))?;
    Ok(results.into_iter().map(|r| r.unwrap_or_default()).collect())
}

/// The error for the first failing tet `t` (`usize::MAX`: none) under the policy.
fn fault_to_error(elements: &impl Source, degenerate: Degenerate, t: usize) -> Result<()> {
    if t == usize::MAX || degenerate == Degenerate::Skip {
        return Ok(());
    }
    Err(elements.fault_error(t))
}

/// Local edge index of corners `(a, b)`, `a != b`, of a `K`-corner simplex: edges in
/// lexicographic order, `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)` for a tet.
#[inline]
const fn edge_index<const K: usize>(a: usize, b: usize) -> usize {
    let (a, b) = if a < b { (a, b) } else { (b, a) };
    a * (2 * K - a - 1) / 2 + (b - a - 1)
}


/// Fills one row of an operator: entry `(i, j)` is the sum, over the tets around `i` in
/// ascending order (`items`, with the row positions `slots` of their other corners), of
/// `edge(t, e)` for their local edge `e = (i, j)`; the diagonal (at `diag`) is
/// `diagonal(s)` with `s` the row's off-diagonal sum in column order. Every assembly path
/// (one-shot, cached, update) goes through here, hence their bitwise agreement.
#[inline]
fn fill_row<const K: usize>(
    row: &mut [f64],
    items: &[u32],
    slots: &[u32],
    diag: usize,
    edge: &impl Fn(usize, usize) -> f64,
    diagonal: impl FnOnce(f64) -> f64,
) {
    row.fill(0.0);
    for (&corner, slot) in items.iter().zip(slots.chunks_exact(K - 1)) {
        let (t, c) = (corner as usize / K, corner as usize % K);
        for (o, &k) in (0..K).filter(|&o| o != c).zip(slot) {
            row[k as usize] += edge(t, edge_index::<K>(c, o));
        }
    }
    let sum: f64 = row.iter().sum();
    row[diag] = diagonal(sum);
}

/// Writes rows `rows` (all rows when `None`) of an operator on the topology's pattern into
/// `data`, by [`fill_row`] with `diagonal(i, off-diagonal sum)`.
pub(crate) fn gather_rows(
    topo: &Topology,
    data: &mut [f64],
    rows: Option<&[u32]>,
    edge: impl Fn(usize, usize) -> f64 + Sync,
    diagonal: impl Fn(usize, f64) -> f64 + Sync,
) {
    let fill = |i: usize, row: &mut [f64]| {
        let range = topo.corners.offsets[i]..topo.corners.offsets[i + 1];
        let items = &topo.corners.items[range.clone()];
        let slots = topo.corner_slots[range].as_flattened();
        fill_row::<4>(row, items, slots, topo.diagonal[i] as usize, &edge, |s| diagonal(i, s));
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
/// (from per-element weights, `E` per element) and the consistent mass's values (from
/// per-element measures in `vol[t][0]`: `vol / fem.0` off the diagonal, the sum of
/// `vol / fem.1` on it).
pub(crate) fn assemble_rows<const K: usize, const E: usize>(
    rows: &Rows<K>,
    w: Option<&[[f64; E]]>,
    vol: Option<(&[[f64; K]], (f64, f64))>,
) -> (Vec<u32>, Option<Vec<f64>>, Option<Vec<f64>>) {
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
                    fill_row::<K>(out, items, row.slots, diag, &|t, e| w[t][e], |s| -s);
                }
                if let (Some(out), Some((vol, (off, on)))) = (fem_row, vol) {
                    let d: f64 = items.iter().map(|&k| vol[k as usize / K][0] / on).sum();
                    fill_row::<K>(out, items, row.slots, diag, &|t, _| vol[t][0] / off, |_| d);
                }
            })
        });
    (indices, lap, fem)
}

/// Sum over the elements (`K` corners) around every vertex (ascending) of `corner(t, c)`.
pub(crate) fn gather_vertices<const K: usize>(
    corners: &Incidence,
    corner: impl Fn(usize, usize) -> f64 + Sync,
) -> Vec<f64> {
    (0..corners.offsets.len() - 1)
        .into_par_iter()
        .map(|i| corners.of(i).iter().map(|&k| corner(k as usize / K, k as usize % K)).sum())
        .collect()
}

/// Laplacian values on the pattern, for all rows (`rows = None`) or the listed ones.
pub(crate) fn laplacian_values(topo: &Topology, w: &[[f64; 6]], rows: Option<&[u32]>, mut data: Vec<f64>) -> Vec<f64> {
    data.resize(topo.nnz(), 0.0);
    gather_rows(topo, &mut data, rows, |t, e| w[t][e], |_, sum| -sum);
    data
}

/// Mass values (per vertex, or CSR data for FEM) for all rows or the listed ones.
pub(crate) fn mass_values(
    topo: &Topology,
    kind: MassKind,
    m: &[[f64; 4]],
    rows: Option<&[u32]>,
    mut values: Vec<f64>,
) -> Vec<f64> {
    let vertex = |i: usize, f: &dyn Fn(usize, usize) -> f64| -> f64 {
        topo.corners.of(i).iter().map(|&k| f(k as usize / 4, k as usize % 4)).sum()
    };
    match (kind, rows) {
        (MassKind::Fem, _) => {
            values.resize(topo.nnz(), 0.0);
            let diagonal = |i: usize, _| vertex(i, &|t, _| m[t][0] / 10.0);
            gather_rows(topo, &mut values, rows, |t, _| m[t][0] / 20.0, diagonal);
            values
        }
        (_, None) => gather_vertices::<4>(&topo.corners, |t, c| m[t][c]),
        (_, Some(rows)) => {
            for &i in rows {
                values[i as usize] = vertex(i as usize, &|t, c| m[t][c]);
            }
            values
        }
    }
}
