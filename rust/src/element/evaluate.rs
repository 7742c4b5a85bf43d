//! One element evaluated for the operators: its kernels, its vertex weights, the placement
//! of its dual vertices, and the one accuracy rule that decides how its values are computed
//! and whether they can be trusted.
//!
//! # The accuracy rule
//! Every value of an element (an edge value of any Laplacian, a mass of any kind) is
//! computed to within [`ACCURACY`] of the largest value of its kind in that element; the
//! primal's diagonal entries each to within that of themselves, and its weights to within
//! that of `sqrt(|L_ii L_jj|)` of their corners' entries (what makes its semidefiniteness
//! checkable):
//!
//! * the element's determinant is rounded correctly ([`crate::element::exact`]), and where
//!   the scaled frame's determinant leaves the normal range it is decided exactly: "degenerate"
//!   means exactly flat, and volumes, barycentric and FEM masses are exact to rounding;
//! * a [well-shaped](Simplex::well_shaped) element (a tet with radius ratio at least
//!   [`WELL_SHAPED`](crate::element::tet::WELL_SHAPED), 1/32; every triangle) is computed
//!   in `f64`;
//! * any other (a sliver, a cap, a needle, a wedge) is computed in double-double from its
//!   exact input coordinates with a bound on every value's error
//!   ([`crate::element::bounded`]): its primal and every variant of its dual (plain,
//!   weighted, with the barycentric boundary fix, in the affine family, as circumcentric
//!   or mixed masses), by the same code;
//! * where those bounds do not certify the accuracy (a needle whose thin directions are
//!   many orders below its length, or whose frame's products leave the `f64` range), the
//!   same code runs in exact rational arithmetic ([`crate::element::rational`]) from the
//!   input coordinates, and the values are rounded once;
//! * an element is refused only when it is exactly degenerate or when a kind's scale (its
//!   largest value; each primal diagonal entry) is not a normal `f64` (beyond about
//!   `1.8e308` or below `2.2e-308`): its values leave the range where they can be held to
//!   the accuracy. (A tet immersed in R^d, `d > 3`, has no exact step: it is refused too
//!   when double-double cannot be certified.)
//!
//! The tests check every path against exact rationals, with and without vertex weights,
//! down to a flatness of `1e-12`, and needles of every orientation and vertex order up to
//! the ends of the `f64` range. Vertex weights do not enter the rule: the dual is computed
//! through products of barycentric coordinates ([`crate::element::tet::power_dual`]),
//! which stay accurate for weights of any size. Elements immersed in a larger space (tets
//! in R^d, d > 3; triangles in R^d, d > 2) are computed in a QR frame of their own space,
//! in double-double too when not well-shaped.

use super::metric::{Factored, Metric, Tensor};
use super::simplex::{corner_sums, Simplex, Values};
use super::tet::batch::{Edges, Frames, Lanes, LANES};
use super::tet::Placement;
use crate::options::{LaplacianKind, MassKind};
use std::cell::OnceCell;

/// The documented accuracy of every value, relative to the largest value of its kind in
/// its element (`2^-40`, about `9e-13`).
pub const ACCURACY: f64 = 1.0 / (1u64 << 40) as f64;

/// Why one element has no values: the [`crate::Degenerate`] policy decides what happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    /// Zero volume: its corners are affinely dependent (decided exactly).
    Degenerate,
    /// A kind of its values leaves the normal `f64` range (see the accuracy rule), or, for
    /// an immersed tet, cannot be computed to the documented accuracy.
    Inaccurate,
    /// Its values are fine, but what a caller multiplies them with (a derivative's
    /// cotangents) leaves the `f64` range: never skipped, whatever the policy.
    Overflow,
}

/// What a pass asks of every element: the edge values of a Laplacian, the corner values
/// of a mass, or both.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Request {
    /// The Laplacian whose edge values (`w_ij`) are asked for.
    pub laplacian: Option<LaplacianKind>,
    /// The mass whose corner values are asked for.
    pub mass: Option<MassKind>,
}

impl Request {
    /// Whether the batched kernels ([`Simplex::at_once`]) serve this request: all but the
    /// mixed mass, whose snapped centres only the one-element path computes.
    pub fn batched(self) -> bool {
        self.mass != Some(MassKind::Mixed)
    }
}

/// An element's dual: edge weights and cell volumes (each checked by whoever asks for it).
type DualValues<S> = (<S as Simplex>::EdgeValues, <S as Simplex>::CornerValues);

/// An element's Laplacian: its edge values (the off-diagonals `w_ij`) and its corners'
/// diagonal entries.
pub(crate) type LaplacianValues<S> = (<S as Simplex>::EdgeValues, <S as Simplex>::CornerValues);

/// One element as the kernels see it, with each dual it needs computed once however many
/// operators ask for it.
pub(crate) struct Element<'a, S: Simplex> {
    pub local: S::Local,
    /// The input coordinates and the corners (for the precise path).
    points: &'a [f64],
    dim: usize,
    cell: S::Cell,
    /// The corners' vertex weights (weighted duals only).
    vertex_weights: Option<S::CornerValues>,
    /// Where the dual's vertices go: the centres, or centroids (the barycentric boundary fix
    /// of a tet with a boundary face).
    placement: Placement,
    /// Not well-shaped: every kernel takes the precise path.
    precise: bool,
    dual: OnceCell<DualValues<S>>,
    /// The dual of the mixed mass (snapped circumcentres, no weights).
    mixed: OnceCell<DualValues<S>>,
    /// The element's coefficient ([`crate::element::metric`]; none: the plain Laplacian).
    coefficient: Option<Metric<S::Tensor>>,
    /// The element's density (its masses' factor; none: 1).
    density: Option<f64>,
    /// The element mapped by its tensor and the slack of its shape test (computed once).
    mapped: OnceCell<(S::Local, f64)>,
    /// The Laplacian's dual weights with the coefficient (computed once).
    coefficient_dual: OnceCell<S::EdgeValues>,
}

/// `v` if its values are finite and the largest is a normal `f64` (a kind measured against
/// its largest value).
fn in_range<V: Values>(v: V) -> Result<V, Fault> {
    let largest = v.as_ref().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if v.as_ref().iter().all(|x| x.is_finite()) && largest >= f64::MIN_POSITIVE {
        Ok(v)
    } else {
        Err(Fault::Inaccurate)
    }
}

/// `v` if every value is a normal `f64` (values each measured against itself).
fn each_normal<V: Values>(v: V) -> Result<V, Fault> {
    if v.as_ref().iter().all(|x| x.is_normal()) {
        Ok(v)
    } else {
        Err(Fault::Inaccurate)
    }
}

/// `v` if every value is finite.
fn finite<V: Values>(v: V) -> Result<V, Fault> {
    if v.as_ref().iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(Fault::Inaccurate)
    }
}

/// `v` times `c`, value by value.
fn times<V: Values>(v: V, c: f64) -> V {
    each(v, |x| x * c)
}

/// `f` of every value of `v`.
fn each<V: Values>(mut v: V, f: impl Fn(f64) -> f64) -> V {
    v.as_mut().iter_mut().for_each(|x| *x = f(*x));
    v
}

fn filled<V: Values>(x: f64) -> V {
    let mut v = V::default();
    v.as_mut().fill(x);
    v
}

/// The Laplacian of `kind` from an element's `primal` (weights and diagonal entries) and
/// `dual` weights, each asked for only if needed, under the range rule: the one
/// definition for [`Element`] and the batches.
fn laplacian_of<S: Simplex>(
    kind: LaplacianKind,
    primal: impl FnOnce() -> Result<LaplacianValues<S>, Fault>,
    dual: impl FnOnce() -> S::EdgeValues,
) -> Result<LaplacianValues<S>, Fault> {
    let primal = || -> Result<LaplacianValues<S>, Fault> {
        let (w, d) = primal()?;
        Ok((in_range(w)?, each_normal(d)?))
    };
    let dual = || -> Result<LaplacianValues<S>, Fault> {
        let w = in_range(dual())?;
        Ok((w, finite(corner_sums::<S>(&w))?))
    };
    match kind {
        LaplacianKind::Primal => primal(),
        LaplacianKind::Dual => dual(),
        LaplacianKind::Affine(s) => {
            let ((mut w, mut d), (dw, dd)) = (primal()?, dual()?);
            let mix = |p: &mut f64, q: &f64| *p = (1.0 - s) * *p + s * q;
            w.as_mut().iter_mut().zip(dw.as_ref()).for_each(|(p, q)| mix(p, q));
            if S::own_diagonal(kind) {
                d.as_mut().iter_mut().zip(dd.as_ref()).for_each(|(p, q)| mix(p, q));
            } else {
                d = corner_sums::<S>(&w);
            }
            Ok((finite(w)?, finite(d)?))
        }
    }
}

/// An element's Laplacian of `kind` (`values`, under the range rule) times a scalar
/// coefficient `c`, under the range rule of its kind again: the edge values times `c`,
/// the diagonal entries times `c` where they are the element's own, else minus the sums
/// of the scaled edge values (as a scatter forms them). The one definition for
/// [`Element`] and the batches.
fn scaled<S: Simplex>(kind: LaplacianKind, (w, d): LaplacianValues<S>, c: f64) -> Result<LaplacianValues<S>, Fault> {
    let w = times(w, c);
    let d = if S::own_diagonal(kind) { times(d, c) } else { corner_sums::<S>(&w) };
    match kind {
        LaplacianKind::Primal => Ok((in_range(w)?, each_normal(d)?)),
        LaplacianKind::Dual => Ok((in_range(w)?, finite(d)?)),
        LaplacianKind::Affine(_) => Ok((finite(w)?, finite(d)?)),
    }
}

/// The corner masses of a lumped `kind` (for [`MassKind::Fem`] the measure in every slot)
/// from an element's `measure` and its dual's cell volumes `cells` (asked for only if
/// needed), under the range rule: the measure (the barycentric and FEM masses' scale) or
/// the largest cell volume (which can be far larger than their sum, the measure) a
/// normal `f64`. The one definition for [`Element`] and the batches.
fn mass_of<S: Simplex>(kind: MassKind, measure: f64, cells: impl FnOnce() -> S::CornerValues) -> Result<S::CornerValues, Fault> {
    match kind {
        MassKind::Circumcentric | MassKind::Mixed => in_range(cells()),
        _ if !measure.is_normal() => Err(Fault::Inaccurate),
        MassKind::Barycentric => finite(filled(measure / S::CORNERS as f64)),
        MassKind::Fem => finite(filled(measure)),
    }
}

impl<'a, S: Simplex> Element<'a, S> {
    /// Element `cell` of `points` (`dim` columns) with its local frame `local`, its corners'
    /// vertex weights and, if `fix_boundary`, the barycentric boundary fix.
    pub fn new(
        local: S::Local,
        points: &'a [f64],
        dim: usize,
        cell: S::Cell,
        vertex_weights: Option<S::CornerValues>,
        fix_boundary: bool,
    ) -> Self {
        let placement = if fix_boundary { Placement::Centroids } else { Placement::Centres };
        let precise = !S::well_shaped(&local);
        Element {
            local,
            points,
            dim,
            cell,
            vertex_weights,
            placement,
            precise,
            dual: OnceCell::new(),
            mixed: OnceCell::new(),
            coefficient: None,
            density: None,
            mapped: OnceCell::new(),
            coefficient_dual: OnceCell::new(),
        }
    }

    /// The element with a coefficient for its Laplacians (a scalar multiplies its values, a
    /// tensor maps the element: [`crate::element::metric`]) and a density for its masses.
    pub fn with(mut self, coefficient: Option<Metric<S::Tensor>>, density: Option<f64>) -> Self {
        self.coefficient = coefficient;
        self.density = density;
        self
    }

    /// The corners' vertex weights, if the mesh has them.
    pub fn vertex_weights(&self) -> Option<&S::CornerValues> {
        self.vertex_weights.as_ref()
    }

    /// Zero volume, decided exactly (a frame whose determinant underflows is not flat).
    fn degenerate(&self) -> Result<(), Fault> {
        if S::is_degenerate(&self.local) && S::exactly_degenerate(&self.corners()) {
            Err(Fault::Degenerate)
        } else {
            Ok(())
        }
    }

    /// Whether the element takes the precise path (it is not well shaped).
    pub fn is_precise(&self) -> bool {
        self.precise
    }

    /// The element's input corners (for the precise path).
    pub fn corners(&self) -> Vec<&'a [f64]> {
        self.cell.as_ref().iter().map(|&v| &self.points[v as usize * self.dim..][..self.dim]).collect()
    }

    /// The element mapped by the tensor `k` and the slack of its shape test (computed once).
    fn mapped(&self, k: &S::Tensor) -> &(S::Local, f64) {
        self.mapped.get_or_init(|| {
            let mut corners: [&[f64]; 4] = [&[]; 4];
            for (c, &v) in corners.iter_mut().zip(self.cell.as_ref()) {
                *c = &self.points[v as usize * self.dim..][..self.dim];
            }
            S::mapped(&corners[..S::CORNERS], &self.local, k)
        })
    }

    /// The primal weights and diagonal entries of the element mapped by the tensor `k`,
    /// under the accuracy rule, as values of `k`.
    fn tensor_primal(&self, k: &S::Tensor) -> LaplacianValues<S> {
        let (mapped, slack) = self.mapped(k);
        let precise = !S::well_shaped_within(mapped, *slack);
        let values = precise.then(|| S::primal_mapped_precise(&self.corners(), &self.local, mapped, k)).flatten();
        let (w, d) = values.unwrap_or_else(|| S::primal(mapped));
        (each(w, |v| k.values(v)), each(d, |v| k.values(v)))
    }

    /// The dual weights of the element mapped by the tensor `k` (its power centres in the
    /// metric `K^-1`: the vertex weights times the tensor's power of two in the mapped
    /// frame), under the accuracy rule, as values of `k` (computed once).
    fn tensor_dual(&self, k: &S::Tensor) -> S::EdgeValues {
        *self.coefficient_dual.get_or_init(|| {
            let (mapped, slack) = self.mapped(k);
            let e = i64::from(k.exponent());
            let weights = self.vertex_weights.map(|w| each(w, |x| crate::element::rational::ldexp(x, e)));
            let precise = !S::well_shaped_within(mapped, *slack);
            let values = precise
                .then(|| S::dual_mapped_precise(&self.corners(), &self.local, mapped, k, weights.as_ref(), self.placement))
                .flatten();
            let w = values.unwrap_or_else(|| S::dual(mapped, weights.as_ref(), self.placement).0);
            each(w, |v| k.values(v))
        })
    }

    /// The dual weights for a scalar coefficient `c`, before the factor `c`: those of the
    /// power centres of the vertex weights times `c` (their powers in the metric `I / c`;
    /// the plain dual without weights or for `c = 1`).
    fn scalar_dual(&self, c: f64) -> S::EdgeValues {
        match self.vertex_weights.filter(|_| c != 1.0) {
            None => self.dual().0,
            Some(w) => *self.coefficient_dual.get_or_init(|| self.evaluate(Some(&times(w, c)), self.placement).0),
        }
    }

    /// The element's measure (volume, area) in the caller's units, correctly rounded.
    pub fn measure(&self) -> f64 {
        if S::measure_trusted(&self.local) {
            S::measure(&self.local)
        } else {
            S::measure_exact(&self.corners(), &self.local)
        }
    }

    /// The primal weights and diagonal entries under the accuracy rule (unchecked).
    fn primal(&self) -> LaplacianValues<S> {
        let precise = self.precise.then(|| S::primal_precise(&self.corners(), &self.local)).flatten();
        precise.unwrap_or_else(|| S::primal(&self.local))
    }

    /// The dual with `weights` and `placement` under the accuracy rule.
    fn evaluate(&self, weights: Option<&S::CornerValues>, placement: Placement) -> DualValues<S> {
        let precise = self.precise.then(|| S::dual_precise(&self.corners(), &self.local, weights, placement)).flatten();
        precise.unwrap_or_else(|| S::dual(&self.local, weights, placement))
    }

    /// The dual's edge weights and cell volumes (computed once).
    fn dual(&self) -> &DualValues<S> {
        self.dual.get_or_init(|| self.evaluate(self.vertex_weights.as_ref(), self.placement))
    }

    /// The element's Laplacian of `kind`: its edge values (the off-diagonals `w_ij`) and
    /// its corners' diagonal entries.
    pub fn laplacian(&self, kind: LaplacianKind) -> Result<LaplacianValues<S>, Fault> {
        self.degenerate()?;
        match self.coefficient {
            None => laplacian_of::<S>(kind, || Ok(self.primal()), || self.dual().0),
            Some(Metric::Scalar(c)) => {
                let values = laplacian_of::<S>(kind, || Ok(self.primal()), || self.scalar_dual(c))?;
                scaled::<S>(kind, values, c)
            }
            Some(Metric::Tensor(k)) => laplacian_of::<S>(kind, || Ok(self.tensor_primal(&k)), || self.tensor_dual(&k)),
        }
    }

    /// The element's corner masses for a lumped `kind`; for [`MassKind::Fem`] its measure
    /// in every slot. A fault also when the measure is not a normal `f64` in the caller's
    /// units (it underflows or overflows: masses would be silently zero or infinite).
    pub fn corner_mass(&self, kind: MassKind) -> Result<S::CornerValues, Fault> {
        self.degenerate()?;
        let cells = || match kind {
            MassKind::Mixed => self.mixed.get_or_init(|| self.evaluate(None, Placement::Snapped)).1,
            _ => self.dual().1,
        };
        match self.density {
            None => mass_of::<S>(kind, self.measure(), cells),
            Some(rho) => mass_of::<S>(kind, self.measure() * rho, || times(cells(), rho)),
        }
    }
}

/// [`Request`] on up to [`LANES`] tets of `points` (R^3, no vertex weights, no boundary fix,
/// no mixed mass: [`Request::batched`]) at once, by the batched `f64` kernels
/// ([`super::tet::batch`]): the values of every tet that the rule computes in `f64` from
/// its float determinant and whose values are in range, in `w[k]` (with the diagonal
/// entries in `d[k]`) and `m[k]` for `cells[k]`, flagged `true`. The others (the precise
/// path, exact determinants, faults) are left to [`tets_precise_at_once`] and [`Element`];
/// the flagged values are bit for bit [`Element`]'s.
///
/// With tensors (`scales.tensors`) the Laplacian's values are those of the tets' frames
/// mapped by them ([`Frames::mapped`]) that are plain, times each tensor's factor, as
/// [`Element`] computes them; the masses are the tets' own.
pub(crate) fn tets_at_once(
    points: &[f64],
    cells: &[[u32; 4]],
    request: Request,
    scales: &Scales<Tensor<3>>,
    out: Outputs<'_>,
) -> [bool; LANES] {
    let lanes = cells.len().min(LANES);
    let corners: [[Lanes; 3]; 4] = std::array::from_fn(|c| {
        std::array::from_fn(|a| std::array::from_fn(|i| if i < lanes { points[3 * cells[i][c] as usize + a] } else { 0.0 }))
    });
    let Some(tensors) = &scales.tensors else {
        let f = Frames::new(&corners);
        let mut ok = f.plain;
        ok[lanes..].fill(false);
        let primal = || {
            let (w, d) = f.primal();
            (w, d, [true; LANES])
        };
        let dual = || {
            let (w, m) = f.dual();
            (w, m, [true; LANES])
        };
        return finish(request, scales, ok, primal, dual, f.volume(), out.first(lanes));
    };
    let edges = Edges::new(&corners);
    let corner = |i: usize, c: usize| &points[3 * cells[i.min(lanes - 1)][c] as usize..][..3];
    let g = Frames::mapped(&edges, |i| [corner(i, 0), corner(i, 1), corner(i, 2), corner(i, 3)], tensors);
    // the tet's own frame for its masses, the mapped one for its Laplacian
    let f = request.mass.map(|_| Frames::of(&edges));
    let mut ok = f.as_ref().map_or(edges.framed, |f| f.plain);
    ok[lanes..].fill(false);
    let values = |v: [Lanes; 6]| v.map(|x| lanes_of(|i| tensors[i].values(x[i])));
    let primal = || {
        let (w, d) = g.primal();
        (values(w), d.map(|x| lanes_of(|i| tensors[i].values(x[i]))), g.plain)
    };
    let lap_dual = matches!(request.laplacian, Some(LaplacianKind::Dual | LaplacianKind::Affine(_)));
    let dual = || {
        let (w, ok) = if lap_dual { (values(g.dual().0), g.plain) } else { ([[0.0; LANES]; 6], [true; LANES]) };
        let cells = match (&f, request.mass) {
            (Some(f), Some(MassKind::Circumcentric)) => f.dual().1,
            _ => [[0.0; LANES]; 4],
        };
        (w, cells, ok)
    };
    finish(request, scales, ok, primal, dual, edges.volume(), out.first(lanes))
}

/// `f(lane)` for every lane.
fn lanes_of(f: impl FnMut(usize) -> f64) -> Lanes {
    std::array::from_fn(f)
}

/// The factors of a batch's lanes: each element's scalar coefficient (its Laplacian's
/// values', `Element::with`) or its tensor `T`, and its density (its masses'); none: 1.
#[derive(Debug, Clone, Copy)]
pub struct Scales<T> {
    /// The lanes' scalar coefficients.
    pub coefficient: Option<Lanes>,
    /// The lanes' tensors, factored.
    pub tensors: Option<[T; LANES]>,
    /// The lanes' densities.
    pub density: Option<Lanes>,
}

impl<T> Default for Scales<T> {
    fn default() -> Self {
        Scales { coefficient: None, tensors: None, density: None }
    }
}

/// The outputs of a batch: edge values, diagonal entries and corner masses, one per lane.
pub(crate) struct Outputs<'o> {
    pub w: &'o mut [[f64; 6]],
    pub d: &'o mut [[f64; 4]],
    pub m: &'o mut [[f64; 4]],
}

impl<'o> Outputs<'o> {
    /// The outputs of the first `lanes` lanes.
    fn first(self, lanes: usize) -> Outputs<'o> {
        Outputs { w: &mut self.w[..lanes], d: &mut self.d[..lanes], m: &mut self.m[..lanes] }
    }
}

/// [`Request`] on up to [`LANES`] tets of `points` (as [`tets_at_once`]) that take the
/// precise path (not well shaped, not flat, with a normal determinant), at once in
/// double-double with error bounds ([`crate::element::bounded::BdLanes`]): the values of
/// those whose bounds certify them and whose values are in range, bit for bit
/// [`Element`]'s, flagged `true`; the others are left to [`Element`].
pub(crate) fn tets_precise_at_once(
    points: &[f64],
    cells: &[[u32; 4]],
    request: Request,
    scales: &Scales<Tensor<3>>,
    out: Outputs<'_>,
) -> [bool; LANES] {
    use super::frame::{local_tet, precise_tet};
    use super::tet::{circumcentric_dual_precise_lanes, primal_precise_lanes, volume, well_shaped};
    let lanes = cells.len().min(LANES);
    let corner = |i: usize, c: usize| &points[3 * cells[i][c] as usize..][..3];
    let x = |i: usize| [corner(i, 0), corner(i, 1), corner(i, 2), corner(i, 3)];
    let local: [_; LANES] = std::array::from_fn(|i| (i < lanes).then(|| local_tet(x(i), &mut [])));
    if let Some(tensors) = &scales.tensors {
        return mapped_precise_at_once(x, local, tensors, request, scales, out.first(lanes));
    }
    let mut ok: [bool; LANES] = local.map(|t| t.is_some_and(|t| t.det.abs() >= f64::MIN_POSITIVE && !well_shaped(&t)));
    let Some(first) = ok.iter().position(|&p| p) else {
        return ok;
    };
    // the precise frames (lanes that take no precise path compute the first one's again)
    let lane = |i: usize| if ok[i] { i } else { first };
    let frames: [_; LANES] = std::array::from_fn(|i| {
        let t = local[lane(i)].expect("a tet");
        (precise_tet(x(lane(i)), t.scale), t.scale, volume(&t))
    });
    let corners = frames.map(|((c, _), _, _)| c);
    let (det, scale, volume) = (frames.map(|((_, d), _, _)| d), frames.map(|(_, s, _)| s), frames.map(|(_, _, v)| v));
    ok[lanes..].fill(false);
    finish(
        request,
        scales,
        ok,
        || primal_precise_lanes(&corners, det, scale),
        || circumcentric_dual_precise_lanes(&corners, det, scale),
        volume,
        out.first(lanes),
    )
}

/// [`tets_precise_at_once`] of tets (corners `x(lane)`, frames `local`) mapped by
/// `tensors`: the lanes whose mapped tet takes the precise path, in double-double with
/// error bounds from their mapped exact corners ([`crate::element::metric`]), with the
/// masses that need no dual (the tets' own volumes); the others, and every lane of a
/// request for a mass from a dual, are left to [`Element`].
fn mapped_precise_at_once<'p>(
    x: impl Fn(usize) -> [&'p [f64]; 4],
    local: [Option<super::frame::LocalTet>; LANES],
    tensors: &[Tensor<3>; LANES],
    request: Request,
    scales: &Scales<Tensor<3>>,
    out: Outputs<'_>,
) -> [bool; LANES] {
    use super::metric::{mapped_tet, precise_mapped_tet};
    use super::tet::{circumcentric_dual_precise_lanes, primal_precise_lanes, volume, well_shaped_within};
    if matches!(request.mass, Some(MassKind::Circumcentric | MassKind::Mixed)) {
        return [false; LANES];
    }
    let mapped: [_; LANES] = std::array::from_fn(|i| local[i].map(|t| (t, mapped_tet(x(i), &t, &tensors[i]))));
    let mut ok = mapped.map(|m| {
        m.is_some_and(|(t, (g, slack))| t.det.abs() >= f64::MIN_POSITIVE && !well_shaped_within(&g, slack))
    });
    let Some(first) = ok.iter().position(|&p| p) else {
        return ok;
    };
    // the precise frames (lanes that take no precise path compute the first one's again)
    let lane = |i: usize| if ok[i] { i } else { first };
    let frames: [_; LANES] = std::array::from_fn(|i| {
        let (t, (g, _)) = mapped[lane(i)].expect("a tet");
        (precise_mapped_tet(x(lane(i)), &t, &g, &tensors[lane(i)]), g.scale, volume(&t))
    });
    let corners = frames.map(|((c, _), _, _)| c);
    let (det, scale, volume) = (frames.map(|((_, d), _, _)| d), frames.map(|(_, s, _)| s), frames.map(|(_, _, v)| v));
    ok[out.w.len()..].fill(false);
    let values = |v: Lanes, i: usize| tensors[i].values(v[i]);
    let primal = || {
        let (w, d, ok) = primal_precise_lanes(&corners, det, scale);
        (w.map(|v| lanes_of(|i| values(v, i))), d.map(|v| lanes_of(|i| values(v, i))), ok)
    };
    let dual = || {
        let (w, _, ok) = circumcentric_dual_precise_lanes(&corners, det, scale);
        (w.map(|v| lanes_of(|i| values(v, i))), [[0.0; LANES]; 4], ok)
    };
    finish(request, scales, ok, primal, dual, volume, out)
}

/// The values `request` asks for from a batch's kernels (`primal`: weights, diagonal
/// entries and the lanes they serve; `dual`: the plain circumcentric one and the lanes it
/// serves; `volume`), checked by the rule of [`Element`] ([`laplacian_of`], [`mass_of`],
/// written here for whole lanes: the batch test checks the two bit for bit), into `out`
/// for the lanes still `ok`; returns those lanes.
fn finish<T>(
    request: Request,
    scales: &Scales<T>,
    mut ok: [bool; LANES],
    primal: impl FnOnce() -> ([Lanes; 6], [Lanes; 4], [bool; LANES]),
    dual: impl FnOnce() -> ([Lanes; 6], [Lanes; 4], [bool; LANES]),
    volume: Lanes,
    out: Outputs<'_>,
) -> [bool; LANES] {
    let kind = request.laplacian;
    let needs_primal = matches!(kind, Some(LaplacianKind::Primal | LaplacianKind::Affine(_)));
    let needs_dual = matches!(kind, Some(LaplacianKind::Dual | LaplacianKind::Affine(_)))
        || request.mass == Some(MassKind::Circumcentric);
    let none = || ([[0.0; LANES]; 6], [[0.0; LANES]; 4], [true; LANES]);
    let (pw, pd, p_ok) = if needs_primal { primal() } else { none() };
    let (dw, mut dm, d_ok) = if needs_dual { dual() } else { none() };
    let mut volume = volume;
    if let Some(rho) = scales.density {
        lanes_times(&mut dm, &rho);
        lanes_times(std::slice::from_mut(&mut volume), &rho);
    }
    for i in 0..LANES {
        ok[i] &= p_ok[i] && d_ok[i];
    }
    let Outputs { w, d, m } = out;
    let transpose = |lw: &[Lanes; 6], ld: &[Lanes; 4], w: &mut [[f64; 6]], d: &mut [[f64; 4]]| {
        for i in 0..w.len() {
            (w[i], d[i]) = (std::array::from_fn(|e| lw[e][i]), std::array::from_fn(|c| ld[c][i]));
        }
    };
    let check_primal = |ok: &mut [bool; LANES]| {
        lanes_in_range(&pw, ok);
        lanes_each_normal(&pd, ok);
    };
    let check_dual = |ok: &mut [bool; LANES]| {
        lanes_in_range(&dw, ok);
        let dd = lanes_corner_sums(&dw);
        lanes_finite(&dd, ok);
        dd
    };
    if let Some(kind) = kind {
        let (mut lw, mut ld) = match kind {
            LaplacianKind::Primal => {
                check_primal(&mut ok);
                (pw, pd)
            }
            LaplacianKind::Dual => {
                let dd = check_dual(&mut ok);
                (dw, dd)
            }
            LaplacianKind::Affine(s) => {
                check_primal(&mut ok);
                let dd = check_dual(&mut ok);
                let mix = |p: &Lanes, q: &Lanes| -> Lanes { std::array::from_fn(|i| (1.0 - s) * p[i] + s * q[i]) };
                let lw: [Lanes; 6] = std::array::from_fn(|e| mix(&pw[e], &dw[e]));
                let ld: [Lanes; 4] = std::array::from_fn(|c| mix(&pd[c], &dd[c]));
                lanes_finite(&lw, &mut ok);
                lanes_finite(&ld, &mut ok);
                (lw, ld)
            }
        };
        if let Some(c) = scales.coefficient {
            // [`scaled`], lane by lane
            lanes_times(&mut lw, &c);
            if <super::simplex::Tet as Simplex>::own_diagonal(kind) {
                lanes_times(&mut ld, &c);
            } else {
                ld = lanes_corner_sums(&lw);
            }
            match kind {
                LaplacianKind::Primal => {
                    lanes_in_range(&lw, &mut ok);
                    lanes_each_normal(&ld, &mut ok);
                }
                LaplacianKind::Dual => {
                    lanes_in_range(&lw, &mut ok);
                    lanes_finite(&ld, &mut ok);
                }
                LaplacianKind::Affine(_) => {
                    lanes_finite(&lw, &mut ok);
                    lanes_finite(&ld, &mut ok);
                }
            }
        }
        transpose(&lw, &ld, w, d);
    }
    if let Some(kind) = request.mass {
        let values: [Lanes; 4] = match kind {
            MassKind::Circumcentric => {
                lanes_in_range(&dm, &mut ok);
                dm
            }
            MassKind::Barycentric | MassKind::Fem => {
                for i in 0..LANES {
                    ok[i] &= volume[i].is_normal();
                }
                let per_corner = if kind == MassKind::Fem { 1.0 } else { 4.0 };
                let v: Lanes = std::array::from_fn(|i| volume[i] / per_corner);
                lanes_finite(&[v], &mut ok);
                [v; 4]
            }
            MassKind::Mixed => unreachable!("no batch serves the mixed mass"),
        };
        for (i, out) in m.iter_mut().enumerate() {
            *out = std::array::from_fn(|c| values[c][i]);
        }
    }
    ok
}

/// Every lane of `v` (`[value][lane]`) times its factor.
fn lanes_times(v: &mut [Lanes], factor: &Lanes) {
    for x in v {
        for i in 0..LANES {
            x[i] *= factor[i];
        }
    }
}

/// [`in_range`] of every lane of `v` (`[value][lane]`), into `ok`.
fn lanes_in_range(v: &[Lanes], ok: &mut [bool; LANES]) {
    for (i, ok) in ok.iter_mut().enumerate() {
        let largest = v.iter().fold(0.0f64, |m, x| m.max(x[i].abs()));
        *ok &= v.iter().all(|x| x[i].is_finite()) && largest >= f64::MIN_POSITIVE;
    }
}

/// [`each_normal`] of every lane of `v`, into `ok`.
fn lanes_each_normal(v: &[Lanes], ok: &mut [bool; LANES]) {
    for (i, ok) in ok.iter_mut().enumerate() {
        *ok &= v.iter().all(|x| x[i].is_normal());
    }
}

/// [`finite`] of every lane of `v`, into `ok`.
fn lanes_finite(v: &[Lanes], ok: &mut [bool; LANES]) {
    for (i, ok) in ok.iter_mut().enumerate() {
        *ok &= v.iter().all(|x| x[i].is_finite());
    }
}

/// [`corner_sums`] of every lane of the tet weights `w` (`[edge][lane]`), in its order.
fn lanes_corner_sums(w: &[Lanes; 6]) -> [Lanes; 4] {
    let mut d = [[0.0; LANES]; 4];
    for (&(a, b), x) in super::tet::EDGES.iter().zip(w) {
        for i in 0..LANES {
            d[a][i] -= x[i];
            d[b][i] -= x[i];
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::Tet;

    /// Random tets, a third of them flat (most of those take the precise path), some of
    /// them exactly flat, in lanes of every occupancy.
    fn points_and_cells() -> (Vec<f64>, Vec<[u32; 4]>) {
        let mut state = 5u64;
        let mut uniform = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut points, mut cells) = (vec![], vec![]);
        for t in 0..600u32 {
            let flat = [1.0, 1e-3, 1e-9, 0.0][t as usize % 4];
            let offset = uniform() * 100.0;
            for _ in 0..4 {
                points.extend([uniform() + offset, uniform(), uniform() * flat]);
            }
            cells.push([4 * t, 4 * t + 1, 4 * t + 2, 4 * t + 3]);
        }
        (points, cells)
    }

    #[test]
    fn batches_compute_what_the_one_element_path_computes_bit_for_bit() {
        let (points, cells) = points_and_cells();
        let kinds = [LaplacianKind::Primal, LaplacianKind::Dual, LaplacianKind::Affine(0.3)];
        let masses = [MassKind::Barycentric, MassKind::Circumcentric, MassKind::Fem];
        let (mut plain, mut precise, mut mapped) = (0, 0, 0);
        // the lanes' scalar coefficients and densities: none, or over ten decades
        let factor = |g: usize, i: usize, k: usize| 10f64.powi(((g * 7 + i * 3 + k) % 11) as i32 - 5) * 1.3;
        for request in kinds.iter().flat_map(|&l| masses.iter().map(move |&m| Request { laplacian: Some(l), mass: Some(m) })) {
            for (g, group) in cells.chunks(LANES).enumerate() {
                let group = &group[..group.len() - g % 3]; // partly filled lanes too
                // SPD tensors over ten decades, anisotropic, with off-diagonal entries
                let tensor = |i: usize| {
                    let (a, b) = (factor(g, i, 2), 0.3 + 0.05 * (i % 5) as f64);
                    let k = [a, b * a, 0.1 * a, b * a, 2.0 * a, -0.2 * a, 0.1 * a, -0.2 * a, 40.0 * a];
                    crate::element::metric::Tensor::<3>::new(&k).expect("SPD")
                };
                let scales = match g % 3 {
                    0 => Scales::default(),
                    1 => Scales {
                        coefficient: Some(std::array::from_fn(|i| factor(g, i, 0))),
                        tensors: None,
                        density: Some(std::array::from_fn(|i| factor(g, i, 1))),
                    },
                    _ => Scales {
                        coefficient: None,
                        tensors: Some(std::array::from_fn(tensor)),
                        density: Some(std::array::from_fn(|i| factor(g, i, 1))),
                    },
                };
                let (mut w, mut d, mut m) = ([[0.0; 6]; LANES], [[0.0; 4]; LANES], [[0.0; 4]; LANES]);
                let (mut pw, mut pd, mut pm) = ([[0.0; 6]; LANES], [[0.0; 4]; LANES], [[0.0; 4]; LANES]);
                let done = tets_at_once(&points, group, request, &scales, Outputs { w: &mut w, d: &mut d, m: &mut m });
                let out = Outputs { w: &mut pw, d: &mut pd, m: &mut pm };
                let done_precise = tets_precise_at_once(&points, group, request, &scales, out);
                for (i, cell) in group.iter().enumerate() {
                    let x = cell.map(|v| &points[3 * v as usize..][..3]);
                    let local = crate::element::frame::local_tet(x, &mut []);
                    let metric = match (scales.coefficient, scales.tensors) {
                        (Some(c), _) => Some(Metric::Scalar(c[i])),
                        (_, Some(k)) => Some(Metric::Tensor(k[i])),
                        _ => None,
                    };
                    let el = Element::<Tet>::new(local, &points, 3, *cell, None, false).with(metric, scales.density.map(|r| r[i]));
                    let expected = (el.laplacian(request.laplacian.unwrap()), el.corner_mass(request.mass.unwrap()));
                    assert!(!(done[i] && done_precise[i]), "one route per tet");
                    let (got_w, got_d, got_m) = match (done[i], done_precise[i]) {
                        (true, _) => (w[i], d[i], m[i]),
                        (_, true) => (pw[i], pd[i], pm[i]),
                        _ => continue,
                    };
                    plain += done[i] as usize;
                    mapped += (done[i] && scales.tensors.is_some()) as usize;
                    precise += done_precise[i] as usize;
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let (ew, ed) = expected.0.expect("computed");
                    assert_eq!(bits(&got_w), bits(&ew), "{request:?} {x:?}");
                    assert_eq!(bits(&got_d), bits(&ed), "{request:?} {x:?}");
                    assert_eq!(bits(&got_m), bits(&expected.1.expect("computed")), "{request:?} {x:?}");
                }
            }
        }
        assert!(plain > 500 && precise > 1000 && mapped > 100, "{plain} plain, {precise} precise, {mapped} mapped");
    }
}
