//! The properties of Table 1 that can be read off an operator and its mesh in one pass:
//! finiteness, symmetry, zero row sums, locality, the signs of the edge weights and linear
//! precision. `O(nnz log degree)`, parallel over rows. (Semidefiniteness is
//! [`crate::negative_semidefinite`].)

use crate::sparse::CsrRef;
use crate::error::{Error, Result};
use crate::assembly::order::Layout;
use crate::mesh::MeshView;
use crate::options::Options;
use crate::element::Simplex;
use crate::assembly::pattern::{for_each_row, Rows};

/// What [`check_operator`] measured.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OperatorCheck {
    /// No stored entry is NaN or infinite.
    pub finite: bool,
    /// `max |L_ij|` over stored entries.
    pub scale: f64,
    /// `max |L_ij - L_ji|`.
    pub symmetry_error: f64,
    /// `max_i |sum_j L_ij|`.
    pub max_row_sum: f64,
    /// Every stored entry lies on the mesh's pattern (its edges and the diagonal).
    pub local: bool,
    /// Mesh edges.
    pub n_edges: usize,
    /// Edges with `L_ij < -negative_tol * max|L_ij|` (over edges).
    pub n_negative: usize,
    /// The smallest edge weight (0 for an edge without a stored entry).
    pub min_weight: f64,
    /// Edges whose endpoints are not both on the boundary.
    pub n_edges_inner: usize,
    /// Negative weights among those.
    pub n_negative_inner: usize,
    /// `max_i |(L (X - c))_i|` over interior vertices, relative to `max|L| * diameter`: `X`
    /// the positions in a frame centred on the mesh (`c` the centre of the bounding box of
    /// the vertices in cells, `diameter` its diagonal), for a mesh as wide as its cells
    /// (tets in R^3, triangles in R^2) with interior vertices (`None` otherwise). The
    /// centred frame makes the number independent of where the mesh lies: in the frame of
    /// the origin it would add `c` times each row's sum, rounding of the row-sum check's
    /// own business, which at an offset of `1e6` exceeds the tolerance of a perfect
    /// operator.
    pub linear_precision: Option<f64>,
}

/// Per-row partial results, reduced in row order.
#[derive(Default)]
struct RowCheck {
    finite: bool,
    scale: f64,
    asymmetry: f64,
    row_sum: f64,
    local: bool,
    edges: usize,
    min_weight: f64,
    inner: usize,
    residual: Option<f64>,
    /// The edge weights of the row (`j > i`) and whether each is inner.
    weights: Vec<(f64, bool)>,
}

/// Checks `l` (square `n x n`, sorted CSR, any values) against the mesh: see
/// [`OperatorCheck`]. `boundary[i]` marks the vertices on a boundary face; `negative_tol`
/// is relative to the largest edge weight.
pub fn check_operator<'a, S: Simplex>(
    l: impl Into<CsrRef<'a>>,
    mesh: &MeshView<S>,
    boundary: &[bool],
    negative_tol: f64,
    opts: &Options,
) -> Result<OperatorCheck> {
    let (l, n) = (l.into(), mesh.n_vertices());
    l.check_shape(n, "the operator")?;
    if boundary.len() != n {
        return Err(Error::Shape { what: format!("the boundary flags hold {} values, the mesh has {n} vertices", boundary.len()) });
    }
    opts.install(|| {
        let layout = Layout::new(mesh, opts)?;
        let rows = Rows::<S>::new(&layout, mesh.cells(), opts)?;
        let stored = |i: usize| (&l.indices[l.indptr[i]..l.indptr[i + 1]], &l.data[l.indptr[i]..l.indptr[i + 1]]);
        let get = |i: usize, j: u32| {
            let (cols, vals) = stored(i);
            cols.binary_search(&j).map_or(0.0, |k| vals[k])
        };
        let interior = |i: usize| !boundary[i] && !rows.corners.of(layout.rank[i] as usize).is_empty();
        let d = mesh.dim();
        let geometric = d == S::MIN_DIM;
        let (centre, diameter) = bounding_box(mesh);
        let mut checks: Vec<RowCheck> = (0..n).map(|_| RowCheck::default()).collect();
        for_each_row(&mut checks, opts, |v, out| {
            let i = layout.vertex_of[v] as usize;
            let (cols, vals) = stored(i);
            out.finite = vals.iter().all(|x| x.is_finite());
            out.scale = vals.iter().fold(0.0, |m, x| m.max(x.abs()));
            out.row_sum = vals.iter().sum::<f64>().abs();
            out.asymmetry = cols.iter().zip(vals).fold(0.0, |m, (&j, &x)| m.max((x - get(j as usize, i as u32)).abs()));
            out.min_weight = f64::INFINITY;
            rows.build(v, |row| {
                out.local = cols.iter().all(|c| row.cols.binary_search(c).is_ok());
                for &j in row.cols.iter().filter(|&&j| j as usize > i) {
                    let w = get(i, j);
                    let inner = !(boundary[i] && boundary[j as usize]);
                    out.edges += 1;
                    out.inner += inner as usize;
                    out.min_weight = out.min_weight.min(w);
                    out.weights.push((w, inner));
                }
            });
            if geometric && interior(i) {
                let x = |j: usize| &mesh.points()[d * j..d * j + d];
                let mut r = [0.0; 3];
                for (&j, &a) in cols.iter().zip(vals) {
                    for ((rc, xc), cc) in r.iter_mut().zip(x(j as usize)).zip(&centre) {
                        *rc += a * (xc - cc);
                    }
                }
                out.residual = Some(r.iter().fold(0.0, |m, c| m.max(c.abs())));
            }
        })?;
        let mut total = OperatorCheck { finite: true, local: true, min_weight: f64::INFINITY, ..Default::default() };
        let mut residual: Option<f64> = None;
        for c in &checks {
            total.finite &= c.finite;
            total.local &= c.local;
            total.scale = total.scale.max(c.scale);
            total.symmetry_error = total.symmetry_error.max(c.asymmetry);
            total.max_row_sum = total.max_row_sum.max(c.row_sum);
            total.n_edges += c.edges;
            total.n_edges_inner += c.inner;
            total.min_weight = total.min_weight.min(c.min_weight);
            residual = match (residual, c.residual) {
                (Some(a), Some(b)) => Some(a.max(b)),
                (a, b) => a.or(b),
            };
        }
        if total.n_edges == 0 {
            total.min_weight = 0.0;
        }
        let weight_scale = checks.iter().flat_map(|c| &c.weights).fold(0.0f64, |m, (w, _)| m.max(w.abs()));
        for (w, inner) in checks.iter().flat_map(|c| &c.weights) {
            if *w < -negative_tol * weight_scale {
                total.n_negative += 1;
                total.n_negative_inner += *inner as usize;
            }
        }
        if let Some(r) = residual {
            let scale = if total.scale > 0.0 { total.scale } else { 1.0 };
            total.linear_precision = Some(r / (scale * diameter));
        }
        Ok(total)
    })
}

/// The centre and the length of the diagonal of the bounding box of the vertices of
/// `mesh`'s cells (a vertex in no cell takes no part), computed without overflow; the
/// centre has `mesh.dim()` coordinates (at most 3 are read).
fn bounding_box<S: Simplex>(mesh: &MeshView<S>) -> ([f64; 3], f64) {
    let d = mesh.dim().min(3);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let points = mesh.points();
    for &v in mesh.cells().iter().flat_map(|c| c.as_ref()) {
        let p = &points[mesh.dim() * v as usize..][..d];
        for a in 0..d {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let mut centre = [0.0; 3];
    for a in 0..d {
        centre[a] = lo[a] / 2.0 + hi[a] / 2.0;
    }
    let extent = |a: usize| (hi[a] - lo[a]).max(0.0);
    let largest = (0..d).map(extent).fold(0.0, f64::max);
    if largest == 0.0 || !largest.is_finite() {
        return (centre, largest);
    }
    (centre, largest * (0..d).map(|a| (extent(a) / largest).powi(2)).sum::<f64>().sqrt())
}
