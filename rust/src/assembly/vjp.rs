//! Derivatives of the operators with respect to the mesh: vector-Jacobian products.
//!
//! Every operator of the crate is a sum of per-tet terms, so the gradient of a scalar
//! `phi(L, M)` with respect to the points (and vertex weights) is a sum of small per-tet
//! vector-Jacobian products ([`crate::element::tet::derivatives`]). [`vjp`] takes the cotangents
//! `dphi/dL` and `dphi/dM` in one of the forms below and returns
//!
//! ```text
//! d/dx  <dL, L(x)> + <dM, M(x)>        (<A, B> = sum_ij A_ij B_ij)
//! ```
//!
//! with respect to the points (`n x dim`) and, for a weighted dual, the vertex weights.
//! It also returns the pairing `<dL, L> + <dM, M>` itself, which for the quadratic
//! cotangents ([`LaplacianCotangent::Dirichlet`], [`MassCotangent::Quadratic`]) is the
//! energy `-f^T L f + f^T M f` (the operators are linear in their per-tet values).
//!
//! # How
//! One parallel pass over the tets: each gathers its cotangents (per local edge, corner and
//! volume), runs one [`Vjp`] for every kernel the request
//! needs (a primal, a dual with its cell volumes, a volume: shared normals, one pull-back)
//! and writes its four corner gradients (and four weight gradients) into its own slot. A
//! tet whose values take the precise path of the accuracy rule (it is not well shaped:
//! a sliver, a needle) takes it for its gradient too: forward derivatives through the
//! same closed forms in double-double with error bounds, else in exact arithmetic
//! (`crate::element::tet::derivatives::precise`), each tet's gradient within the
//! documented accuracy of its largest component.
//! Then every vertex sums the slots of its tet corners in ascending order (the corner
//! incidence of the assembly): the result is bitwise identical for any thread count.
//! Degenerate tets follow [`crate::Degenerate`] (an error naming the first, or a zero
//! gradient, consistent with their zero contribution under `Skip`); the cancel flag is
//! polled between chunks of tets.
//!
//! # Limits
//! Tets only (in R^3 or immersed in R^d). The barycentric boundary treatment
//! ([`crate::Boundary::Barycentric`]) switches dual vertices to centroids, a piecewise
//! construction the kernels do not differentiate: asking for a derivative of the dual or
//! the circumcentric mass under it is [`Error::NotDifferentiable`].
//!
//! # Example
//! ```
//! use tetlap::{vjp, Columns, Cotangents, LaplacianCotangent, LaplacianKind, Options, TetView};
//! // two tets sharing the face (1, 2, 3)
//! let mut points = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
//! let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
//! let f = [0.0, 1.0, 2.0, -1.0, 0.5]; // one column
//! let energy = |points: &[f64]| -> f64 {
//!     let mesh = TetView::new(points, 3, &tets).unwrap();
//!     let cot = Cotangents {
//!         laplacian: Some((LaplacianKind::Dual, LaplacianCotangent::Dirichlet(Columns::new(&f, 1)))),
//!         mass: None,
//!     };
//!     vjp(&mesh, &cot, &Options::default()).unwrap().value
//! };
//! let mesh = TetView::new(&points, 3, &tets)?;
//! let cot = Cotangents {
//!     laplacian: Some((LaplacianKind::Dual, LaplacianCotangent::Dirichlet(Columns::new(&f, 1)))),
//!     mass: None,
//! };
//! let g = vjp(&mesh, &cot, &Options::default())?;
//! // E = -f^T L f, against the assembled L
//! let l = tetlap::laplacian(&mesh, LaplacianKind::Dual, &Options::default())?;
//! let lf: f64 = (0..5).map(|i| f[i] * (0..5).map(|j| l.get(i, j) * f[j]).sum::<f64>()).sum();
//! assert!((g.value + lf).abs() < 1e-12);
//! // dE/dz of vertex 4, against a central difference
//! let h = 1e-6;
//! points[14] += h;
//! let up = energy(&points);
//! points[14] -= 2.0 * h;
//! let down = energy(&points);
//! assert!((g.points[14] - (up - down) / (2.0 * h)).abs() < 1e-7);
//! # Ok::<(), tetlap::Error>(())
//! ```

use crate::sparse::CsrRef;
use crate::assembly::pass::Elements;
use crate::error::{Error, Result};
use crate::element::tet::derivatives::precise::{precise_gradient, Pairing};
use crate::element::tet::derivatives::{to_ambient, Vjp};
use crate::element::tet::EDGES;
use crate::mesh::TetView;
use crate::options::{Boundary, LaplacianKind, MassKind, Options};
use crate::assembly::pass::{chunked, CHUNK};
use crate::element::{Element, Fault, Simplex, Tet};
use crate::topology::group::{group_u32, Incidence};
use rayon::prelude::*;

/// A real `n x k` array, row-major: one row per vertex (`k = 1` for a scalar function).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Columns<'a> {
    /// `n * columns` values, row-major.
    pub values: &'a [f64],
    /// Number of columns `k` (0 gives a zero energy).
    pub columns: usize,
}

impl<'a> Columns<'a> {
    /// `values` as rows of `columns` values.
    pub fn new(values: &'a [f64], columns: usize) -> Self {
        Columns { values, columns }
    }

    #[inline]
    fn row(&self, i: usize) -> &'a [f64] {
        &self.values[i * self.columns..(i + 1) * self.columns]
    }

    fn check(&self, n: usize, what: &'static str) -> Result<()> {
        if self.values.len() != n * self.columns {
            return Err(Error::Shape {
                what: format!(
                    "{what} must hold {n} rows (one per vertex) of {} values, got {} values",
                    self.columns,
                    self.values.len()
                ),
            });
        }
        check_finite(self.values, what)
    }
}

/// The cotangent on the Laplacian `L` of the kind given alongside in [`Cotangents`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaplacianCotangent<'a> {
    /// On every tet's own six weights (local edge order, as [`crate::contributions`]
    /// returns them), one `[f64; 6]` per tet.
    Elements(&'a [[f64; 6]]),
    /// On the entries of `L` (any sparse pattern). With `L[i, j] = L[j, i] = w_ij` and
    /// `L[i, i] = -sum_j w_ij`, edge `ij` gets `dL[i, j] + dL[j, i] - dL[i, i] - dL[j, j]`;
    /// an upper-triangular `dL` is a cotangent on the summed edge weights of
    /// [`crate::edge_weights`].
    Matrix(CsrRef<'a>),
    /// The Dirichlet energy `E = -sum_c f_c^T L f_c = sum_edges w_ij |f_i - f_j|^2` of the
    /// columns `f_c` (every edge gets `|f_i - f_j|^2`).
    Dirichlet(Columns<'a>),
}

/// The cotangent on the mass matrix `M` of the kind given alongside in [`Cotangents`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MassCotangent<'a> {
    /// On the diagonal entries `M[i, i]`, one per vertex (for the lumped kinds, all of `M`).
    Diagonal(&'a [f64]),
    /// On the entries of `M` (any sparse pattern; for the lumped kinds only the diagonal
    /// counts).
    Matrix(CsrRef<'a>),
    /// The quadratic form `sum_c f_c^T M f_c` of the columns `f_c`.
    Quadratic(Columns<'a>),
}

/// What to differentiate: `<dL, L> + <dM, M>` for the operators of the given kinds; either
/// part may be absent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cotangents<'a> {
    /// The Laplacian's kind and its cotangent.
    pub laplacian: Option<(LaplacianKind, LaplacianCotangent<'a>)>,
    /// The mass matrix's kind and its cotangent.
    pub mass: Option<(MassKind, MassCotangent<'a>)>,
}

/// The result of [`vjp`].
#[derive(Debug, Clone, PartialEq)]
pub struct MeshGradient {
    /// `d phi / d points`, `n x dim` row-major like the points (zero rows for unreferenced
    /// vertices). For an immersed mesh it lies in the tets' own 3-spaces.
    pub points: Vec<f64>,
    /// `d phi / d weights`, one per vertex, when the mesh has vertex weights (zero unless the
    /// dual or the circumcentric mass is differentiated).
    pub weights: Option<Vec<f64>>,
    /// The pairing `phi = <dL, L> + <dM, M>` (the energy for the quadratic cotangents), summed
    /// in a fixed order.
    pub value: f64,
}

fn check_finite(values: &[f64], what: &'static str) -> Result<()> {
    match crate::threads::position_first(values, |_, x| !x.is_finite())? {
        Some(index) => Err(Error::NonFiniteCotangent { what, index, value: values[index] }),
        None => Ok(()),
    }
}

/// What every tet needs, resolved once for the mesh.
struct Plan<'a> {
    laplacian: Option<(LaplacianKind, LaplacianCotangent<'a>)>,
    mass: Option<(MassKind, MassCotangent<'a>)>,
    /// Diagonals of the `Matrix` cotangents, one per vertex.
    l_diagonal: Vec<f64>,
    m_diagonal: Vec<f64>,
    /// Whether the dual kernel runs (a dual or affine Laplacian, a circumcentric mass).
    dual: bool,
}

fn diagonal(m: &CsrRef<'_>) -> Vec<f64> {
    (0..m.n).into_par_iter().map(|i| m.get(i, i)).collect()
}

impl<'a> Plan<'a> {
    fn new(mesh: &TetView, cot: &Cotangents<'a>, opts: &Options) -> Result<Self> {
        let (n, m) = (mesh.n_vertices(), mesh.n_elements());
        let laplacian = match cot.laplacian {
            Some((kind, c)) => Some((kind.check()?, c)),
            None => None,
        };
        match laplacian {
            Some((_, LaplacianCotangent::Elements(e))) => {
                if e.len() != m {
                    return Err(Error::Shape {
                        what: format!(
                            "the per-tet Laplacian cotangent must hold one row of 6 per tet ({m}), \
                             got {} rows",
                            e.len()
                        ),
                    });
                }
                check_finite(e.as_flattened(), "the per-tet Laplacian cotangent")?;
            }
            Some((_, LaplacianCotangent::Matrix(c))) => {
                c.check_shape(n, "the Laplacian cotangent")?;
                check_finite(c.data, "the Laplacian cotangent")?
            },
            Some((_, LaplacianCotangent::Dirichlet(f))) => f.check(n, "the Dirichlet energy's f")?,
            None => {}
        }
        match cot.mass {
            Some((_, MassCotangent::Diagonal(d))) => {
                if d.len() != n {
                    return Err(Error::Shape {
                        what: format!(
                            "the mass cotangent's diagonal must hold one value per vertex ({n}), \
                             got {}",
                            d.len()
                        ),
                    });
                }
                check_finite(d, "the mass cotangent")?;
            }
            Some((_, MassCotangent::Matrix(c))) => {
                c.check_shape(n, "the mass cotangent")?;
                check_finite(c.data, "the mass cotangent")?
            },
            Some((_, MassCotangent::Quadratic(f))) => f.check(n, "the quadratic form's f")?,
            None => {}
        }
        if cot.mass.is_some_and(|(k, _)| k == MassKind::Mixed) {
            return Err(Error::NotDifferentiable {
                what: "the mixed mass (its moves of centres into their simplices are piecewise)",
            });
        }
        let dual = laplacian.is_some_and(|(k, _)| k != LaplacianKind::Primal)
            || cot.mass.is_some_and(|(k, _)| k == MassKind::Circumcentric);
        if dual && opts.boundary == Boundary::Barycentric {
            return Err(Error::NotDifferentiable {
                what: "the dual Laplacian and the circumcentric mass under \
                       Boundary::Barycentric (its switch of dual vertices to centroids is \
                       piecewise); use Boundary::Circumcentric",
            });
        }
        let l_diagonal = match laplacian {
            Some((_, LaplacianCotangent::Matrix(c))) => diagonal(&c),
            _ => Vec::new(),
        };
        let m_diagonal = match cot.mass {
            Some((_, MassCotangent::Matrix(c))) => diagonal(&c),
            _ => Vec::new(),
        };
        Ok(Plan { laplacian, mass: cot.mass, l_diagonal, m_diagonal, dual })
    }

    /// The cotangents of tet `t` on its six weights.
    #[inline]
    fn edge_cotangent(&self, t: usize, cell: &[u32; 4]) -> [f64; 6] {
        let v = cell.map(|v| v as usize);
        match self.laplacian {
            None => [0.0; 6],
            Some((_, LaplacianCotangent::Elements(e))) => e[t],
            Some((_, LaplacianCotangent::Matrix(c))) => EDGES.map(|(a, b)| {
                let (i, j) = (v[a], v[b]);
                c.get(i, j) + c.get(j, i) - self.l_diagonal[i] - self.l_diagonal[j]
            }),
            Some((_, LaplacianCotangent::Dirichlet(f))) => {
                EDGES.map(|(a, b)| f.row(v[a]).iter().zip(f.row(v[b])).map(|(x, y)| (x - y) * (x - y)).sum())
            }
        }
    }

    /// The cotangents of tet `t` on its four corner masses (lumped kinds) and on its volume
    /// (the barycentric and FEM masses are multiples of it).
    #[inline]
    fn mass_cotangent(&self, cell: &[u32; 4]) -> ([f64; 4], f64) {
        let v = cell.map(|v| v as usize);
        let Some((kind, cot)) = self.mass else { return ([0.0; 4], 0.0) };
        let square = |f: &Columns, i: usize| f.row(i).iter().map(|x| x * x).sum::<f64>();
        if kind == MassKind::Fem {
            // M_ab = Vol (1 + delta_ab) / 20 on the tet's 4 x 4 block
            let (off, on) = Tet::FEM;
            let dv = match cot {
                MassCotangent::Diagonal(d) => v.iter().map(|&i| d[i]).sum::<f64>() / on,
                MassCotangent::Matrix(c) => {
                    let mut off_sum = 0.0;
                    for (a, &i) in v.iter().enumerate() {
                        for (b, &j) in v.iter().enumerate() {
                            if a != b {
                                off_sum += c.get(i, j);
                            }
                        }
                    }
                    v.iter().map(|&i| self.m_diagonal[i]).sum::<f64>() / on + off_sum / off
                }
                MassCotangent::Quadratic(f) => {
                    // f^T M_t f = Vol ((sum_a f_a)^2 + sum_a f_a^2) / 20, per column
                    let mut s = 0.0;
                    for col in 0..f.columns {
                        let x = v.map(|i| f.values[i * f.columns + col]);
                        let sum: f64 = x.iter().sum();
                        s += sum * sum + x.iter().map(|y| y * y).sum::<f64>();
                    }
                    s / off
                }
            };
            return ([0.0; 4], dv);
        }
        let dm = match cot {
            MassCotangent::Diagonal(d) => v.map(|i| d[i]),
            MassCotangent::Matrix(_) => v.map(|i| self.m_diagonal[i]),
            MassCotangent::Quadratic(f) => v.map(|i| square(&f, i)),
        };
        match kind {
            MassKind::Barycentric => ([0.0; 4], dm.iter().sum::<f64>() / 4.0),
            _ => (dm, 0.0),
        }
    }
}

/// Values per tet slot: `4 dim` corner gradients, then 4 weight gradients if the mesh is
/// weighted, then the tet's pairing.
struct SlotLayout {
    dim: usize,
    weighted: bool,
    stride: usize,
}

impl SlotLayout {
    fn new(dim: usize, weighted: bool) -> Self {
        SlotLayout { dim, weighted, stride: 4 * dim + if weighted { 4 } else { 0 } + 1 }
    }
}

/// One tet's gradient into `slot`: `Err` with the element's fault where the forward values
/// are refused (the accuracy rule of the assembly, applied to this element), or
/// [`Fault::Overflow`] where they are fine but their products with the cotangents leave
/// the `f64` range. The pairing's value comes from the forward values the assembly
/// computes; the gradient from the [`Vjp`] of the same element (`scratch` holds its frame),
/// or, for an element of the precise path, from the precise path's forward mode
/// ([`precise_gradient`]: double-double with error bounds, else exact).
fn tet_gradient(
    el: &Element<Tet>,
    plan: &Plan,
    layout: &SlotLayout,
    t: usize,
    cell: &[u32; 4],
    scratch: &[f64],
    slot: &mut [f64],
) -> std::result::Result<(), Fault> {
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let lt = &el.local;
    let dw = plan.edge_cotangent(t, cell);
    let (dm, dv) = plan.mass_cotangent(cell);
    let mut value = 0.0;
    if let Some((kind, _)) = plan.laplacian {
        value += dot(el.laplacian(kind)?.0.as_ref(), &dw);
    }
    if let Some((kind, _)) = plan.mass {
        let m = el.corner_mass(kind)?;
        value += if kind == MassKind::Circumcentric { dot(&m, &dm) } else { dv * el.measure() };
    }
    let (primal_share, dual_share) = match plan.laplacian {
        None => (0.0, 0.0),
        Some((LaplacianKind::Primal, _)) => (1.0, 0.0),
        Some((LaplacianKind::Dual, _)) => (0.0, 1.0),
        Some((LaplacianKind::Affine(s), _)) => (1.0 - s, s),
    };
    let g = if el.is_precise() {
        // the precise path of the accuracy rule, as for the values
        let pairing = Pairing {
            primal: (primal_share != 0.0).then(|| dw.map(|x| x * primal_share)),
            dual: plan.dual.then(|| dw.map(|x| x * dual_share)),
            cells: plan.dual.then_some(dm),
            volume: dv,
        };
        let x = el.corners();
        precise_gradient([x[0], x[1], x[2], x[3]], lt, el.vertex_weights(), &pairing).ok_or(Fault::Inaccurate)?
    } else {
        let omega = el.vertex_weights().map(|w| {
            let s2 = lt.scale * lt.scale;
            w.map(|wi| (wi - w[0]) / s2)
        });
        let mut vjp = Vjp::new(lt);
        if primal_share != 0.0 {
            vjp.primal(dw.map(|x| x * primal_share));
        }
        if plan.dual {
            vjp.dual(omega, dw.map(|x| x * dual_share), dm);
        }
        if dv != 0.0 {
            vjp.volume(dv);
        }
        vjp.finish()
    };
    let dim = layout.dim;
    if dim == 3 {
        for (out, c) in slot.chunks_exact_mut(3).zip(&g.corners) {
            out.copy_from_slice(&c.to_array());
        }
    } else {
        to_ambient(&g.corners, scratch, &mut slot[..4 * dim]);
    }
    if layout.weighted {
        slot[4 * dim..4 * dim + 4].copy_from_slice(&g.weights);
    }
    slot[layout.stride - 1] = value;
    if slot.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(Fault::Overflow)
    }
}

/// The gradient of `<dL, L> + <dM, M>` with respect to the points (and vertex weights) of
/// a tet mesh, and that pairing's value. See the [module docs](crate::assembly::vjp).
///
/// # Errors
/// The cotangents' shape ([`Error::Shape`]) or finiteness ([`Error::NonFiniteCotangent`]),
/// the options ([`Error::Threads`], [`Error::AffineParameter`],
/// [`Error::NotDifferentiable`] for the dual under [`Boundary::Barycentric`]), a degenerate
/// tet under [`crate::Degenerate::Raise`] ([`Error::Degenerate`], [`Error::NonFiniteResult`]),
/// products with the cotangents beyond the `f64` range ([`Error::Overflow`], whatever the
/// policy: the element is fine, its cotangents are too large), sums beyond the `f64` range
/// ([`Error::SumOverflow`]), [`Error::Cancelled`]; a mesh with a coefficient or a density
/// ([`Error::CoefficientUnsupported`]).
pub fn vjp(mesh: &TetView, cotangents: &Cotangents, opts: &Options) -> Result<MeshGradient> {
    mesh.plain("the derivatives (vjp)")?;
    super::install::<Tet, _>(opts, || {
        let plan = Plan::new(mesh, cotangents, opts)?;
        let (n, m, dim) = (mesh.n_vertices(), mesh.n_elements(), mesh.dim());
        let layout = SlotLayout::new(dim, mesh.vertex_weights().is_some());
        let stride = layout.stride;
        let elements = Elements::new(*mesh, &Options { boundary: Boundary::Circumcentric, ..opts.clone() })?;
        let (slots, incidence) = rayon::join(
            || -> Result<Vec<f64>> {
                let mut slots = vec![0.0; m * stride];
                let chunks = slots.par_chunks_mut(CHUNK * stride);
                let fault = chunked(&elements, opts, chunks, |c, chunk, scratch, faults| {
                    for (k, slot) in chunk.chunks_exact_mut(stride).enumerate() {
                        let t = c * CHUNK + k;
                        let el = elements.get(t, scratch);
                        let cell = &mesh.cells()[t];
                        if let Err(fault) = tet_gradient(&el, &plan, &layout, t, cell, scratch, slot) {
                            slot.fill(0.0);
                            faults.record(&elements, t, fault);
                        }
                    }
                })?;
                fault.check(opts.degenerate)?;
                Ok(slots)
            },
            || {
                // element-corners `4 t + c` around every vertex, ascending
                let corner = |r: usize| (mesh.cells()[r / 4][r % 4], r as u32);
                group_u32(n, 4 * m, corner, opts).map(|(offsets, items)| Incidence { offsets, items })
            },
        );
        let (slots, incidence) = (slots?, incidence?);
        opts.cancelled()?;
        let g = gather(&slots, &incidence, &layout, n);
        // per-tet values are finite; only a sum can overflow
        let bad = crate::threads::position_first(&g.points, |_, x| !x.is_finite())?
            .map(|k| k / dim)
            .or_else(|| g.weights.as_ref().and_then(|w| w.iter().position(|x| !x.is_finite())));
        if let Some(vertex) = bad {
            return Err(Error::SumOverflow { vertex });
        }
        if !g.value.is_finite() {
            // the pairing sums every element: no single vertex to blame
            return Err(Error::SumOverflow { vertex: 0 });
        }
        Ok(g)
    })
}

/// Sums the tet slots onto the vertices (tet corners in ascending order) and the pairings
/// (tets in ascending order, by chunks).
fn gather(slots: &[f64], incidence: &Incidence, layout: &SlotLayout, n: usize) -> MeshGradient {
    let (dim, stride) = (layout.dim, layout.stride);
    let mut points = vec![0.0; n * dim];
    points.par_chunks_mut(dim).enumerate().for_each(|(i, out)| {
        for &q in incidence.of(i) {
            let (t, c) = (q as usize / 4, q as usize % 4);
            let g = &slots[t * stride + c * dim..t * stride + (c + 1) * dim];
            for (o, x) in out.iter_mut().zip(g) {
                *o += x;
            }
        }
    });
    let weights = layout.weighted.then(|| {
        (0..n)
            .into_par_iter()
            .map(|i| {
                incidence
                    .of(i)
                    .iter()
                    .map(|&q| slots[(q as usize / 4) * stride + 4 * dim + q as usize % 4])
                    .sum()
            })
            .collect()
    });
    let partial: Vec<f64> = slots
        .par_chunks(CHUNK * stride)
        .map(|chunk| chunk.chunks_exact(stride).map(|s| s[stride - 1]).sum::<f64>())
        .collect();
    MeshGradient { points, weights, value: partial.iter().sum() }
}

#[cfg(test)]
mod tests;
