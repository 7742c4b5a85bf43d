//! One element evaluated for the operators: its kernels, its vertex weights, the placement
//! of its dual vertices, and the one accuracy rule that decides how its values are computed
//! and whether they can be trusted.
//!
//! # The accuracy rule
//! Every value of an element (an edge value of any Laplacian, a mass of any kind) is
//! computed to within [`ACCURACY`] of the largest value of its kind in that element:
//!
//! * the element's determinant is rounded correctly ([`crate::element::exact`]): its
//!   volume, barycentric and FEM masses are exact to rounding, and "degenerate" means
//!   exactly flat;
//! * a [well-shaped](Simplex::well_shaped) element (a tet with radius ratio at least
//!   [`WELL_SHAPED`](crate::element::tet::WELL_SHAPED), 1/32; every triangle) is computed
//!   in `f64`;
//! * any other (a sliver, a cap, a needle, a wedge) is computed in double-double from its
//!   exact input coordinates: its primal and every variant of its dual (plain, weighted,
//!   with the barycentric boundary fix, in the affine family, as circumcentric or mixed
//!   masses), by the same code;
//! * an element is refused only when it is exactly degenerate or a value leaves the `f64`
//!   range.
//!
//! The tests check every path against exact rationals, with and without vertex weights,
//! down to a flatness of `1e-12`. Vertex weights do not enter the rule: the dual is
//! computed through products of barycentric coordinates
//! ([`crate::element::tet::power_dual`]), which stay accurate for weights of any size.
//! Elements immersed in a larger space (tets in R^d, d > 3; triangles in R^d, d > 2) are
//! computed in a QR frame of their own space, in double-double too when not well-shaped.

use super::simplex::{Simplex, Values};
use super::tet::batch::{Frames, Lanes, LANES};
use super::tet::Placement;
use crate::options::{LaplacianKind, MassKind};
use std::cell::OnceCell;

/// The documented accuracy of every value, relative to the largest value of its kind in
/// its element (`2^-40`, about `9e-13`).
pub const ACCURACY: f64 = 1.0 / (1u64 << 40) as f64;

/// Why one element has no values: the [`crate::Degenerate`] policy decides what happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    /// Zero volume: its corners are affinely dependent.
    Degenerate,
    /// A value leaves the `f64` range.
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
}

/// `v` if every value is finite.
fn finite<V: Values>(v: V) -> Result<V, Fault> {
    if v.as_ref().iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(Fault::Inaccurate)
    }
}

fn filled<V: Values>(x: f64) -> V {
    let mut v = V::default();
    v.as_mut().fill(x);
    v
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
        Element { local, points, dim, cell, vertex_weights, placement, precise, dual: OnceCell::new(), mixed: OnceCell::new() }
    }

    /// The corners' vertex weights, if the mesh has them.
    pub fn vertex_weights(&self) -> Option<&S::CornerValues> {
        self.vertex_weights.as_ref()
    }

    /// Zero volume.
    fn degenerate(&self) -> Result<(), Fault> {
        if S::is_degenerate(&self.local) {
            Err(Fault::Degenerate)
        } else {
            Ok(())
        }
    }

    /// The element's input corners (for the precise path).
    fn corners(&self) -> Vec<&'a [f64]> {
        self.cell.as_ref().iter().map(|&v| &self.points[v as usize * self.dim..][..self.dim]).collect()
    }

    /// The primal weights under the accuracy rule.
    fn primal(&self) -> Result<S::EdgeValues, Fault> {
        let precise = self.precise.then(|| S::primal_precise(&self.corners(), &self.local)).flatten();
        finite(precise.unwrap_or_else(|| S::primal(&self.local)))
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

    /// The element's edge values (the off-diagonals `w_ij` of its Laplacian) for `kind`.
    pub fn laplacian(&self, kind: LaplacianKind) -> Result<S::EdgeValues, Fault> {
        self.degenerate()?;
        finite(match kind {
            LaplacianKind::Primal => self.primal()?,
            LaplacianKind::Dual => self.dual().0,
            LaplacianKind::Affine(s) => {
                let (mut w, d) = (self.primal()?, self.dual().0);
                for (p, d) in w.as_mut().iter_mut().zip(d.as_ref()) {
                    *p = (1.0 - s) * *p + s * d;
                }
                w
            }
        })
    }

    /// The element's corner masses for a lumped `kind`; for [`MassKind::Fem`] its measure
    /// in every slot. A fault also when the measure is not a normal `f64` in the caller's
    /// units (it underflows or overflows: masses would be silently zero or infinite).
    pub fn corner_mass(&self, kind: MassKind) -> Result<S::CornerValues, Fault> {
        self.degenerate()?;
        if !S::measure(&self.local).is_normal() {
            return Err(Fault::Inaccurate);
        }
        finite(match kind {
            MassKind::Barycentric => S::barycentric(&self.local),
            MassKind::Circumcentric => self.dual().1,
            MassKind::Mixed => self.mixed.get_or_init(|| self.evaluate(None, Placement::Snapped)).1,
            MassKind::Fem => filled(S::measure(&self.local)),
        })
    }
}

/// [`Request`] on up to [`LANES`] tets of `points` (R^3, no vertex weights, no boundary fix,
/// no mixed mass: [`Request::batched`])
/// at once, by the batched `f64` kernels ([`super::tet::batch`]): the values of every tet
/// that the rule computes in `f64` from its float determinant and whose values are
/// finite, in `w[k]` / `m[k]` for `cells[k]`, flagged `true`. The others (the precise and
/// careful paths, exact determinants, faults) are left to [`tets_precise_at_once`] and
/// [`Element`]; the flagged values are bit for bit [`Element`]'s.
pub(crate) fn tets_at_once(
    points: &[f64],
    cells: &[[u32; 4]],
    request: Request,
    w: &mut [[f64; 6]],
    m: &mut [[f64; 4]],
) -> [bool; LANES] {
    let lanes = cells.len().min(LANES);
    let corners: [[Lanes; 3]; 4] = std::array::from_fn(|c| {
        std::array::from_fn(|a| std::array::from_fn(|i| if i < lanes { points[3 * cells[i][c] as usize + a] } else { 0.0 }))
    });
    let f = Frames::new(&corners);
    let mut ok = f.plain;
    ok[lanes..].fill(false);
    finish(request, ok, || f.primal(), || f.dual(), f.volume(), &mut w[..lanes], &mut m[..lanes])
}

/// [`Request`] on up to [`LANES`] tets of `points` (as [`tets_at_once`]) that take the
/// precise path (not well shaped, not flat), at once in double-double
/// ([`crate::element::exact::DdLanes`]): the values of those whose values are finite, bit
/// for bit [`Element`]'s, flagged `true`; the others are left to [`Element`].
pub(crate) fn tets_precise_at_once(
    points: &[f64],
    cells: &[[u32; 4]],
    request: Request,
    w: &mut [[f64; 6]],
    m: &mut [[f64; 4]],
) -> [bool; LANES] {
    use super::frame::{local_tet, precise_tet};
    use super::tet::{circumcentric_dual_precise_lanes, primal_weights_precise_lanes, volume, well_shaped};
    let lanes = cells.len().min(LANES);
    let corner = |i: usize, c: usize| &points[3 * cells[i][c] as usize..][..3];
    let x = |i: usize| [corner(i, 0), corner(i, 1), corner(i, 2), corner(i, 3)];
    let local: [_; LANES] = std::array::from_fn(|i| (i < lanes).then(|| local_tet(x(i), &mut [])));
    let mut ok: [bool; LANES] = local.map(|t| t.is_some_and(|t| t.det != 0.0 && !well_shaped(&t)));
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
        ok,
        || primal_weights_precise_lanes(&corners, det, scale),
        || circumcentric_dual_precise_lanes(&corners, det, scale),
        volume,
        &mut w[..lanes],
        &mut m[..lanes],
    )
}

/// The values `request` asks for from a batch's kernels (`primal`, `dual`: the plain
/// circumcentric one, `volume`), checked as [`Element`] checks them, into `w` and `m` for
/// the lanes still `ok`; returns those lanes.
fn finish(
    request: Request,
    mut ok: [bool; LANES],
    primal: impl FnOnce() -> [Lanes; 6],
    dual: impl FnOnce() -> ([Lanes; 6], [Lanes; 4]),
    volume: Lanes,
    w: &mut [[f64; 6]],
    m: &mut [[f64; 4]],
) -> [bool; LANES] {
    let all_finite = |v: &[Lanes], ok: &mut [bool; LANES]| {
        for (i, ok) in ok.iter_mut().enumerate() {
            *ok &= v.iter().all(|x| x[i].is_finite());
        }
    };
    let needs_dual = matches!(request.laplacian, Some(LaplacianKind::Dual | LaplacianKind::Affine(_)))
        || request.mass == Some(MassKind::Circumcentric);
    let (dw, dm) = if needs_dual { dual() } else { ([[0.0; LANES]; 6], [[0.0; LANES]; 4]) };
    if let Some(kind) = request.laplacian {
        let values = match kind {
            LaplacianKind::Primal => primal(),
            LaplacianKind::Dual => dw,
            LaplacianKind::Affine(s) => {
                // Element::laplacian: the primal must be finite on its own
                let p = primal();
                all_finite(&p, &mut ok);
                std::array::from_fn(|e| std::array::from_fn(|i| (1.0 - s) * p[e][i] + s * dw[e][i]))
            }
        };
        all_finite(&values, &mut ok);
        for (k, out) in w.iter_mut().enumerate() {
            *out = std::array::from_fn(|e| values[e][k]);
        }
    }
    if let Some(kind) = request.mass {
        for (i, ok) in ok.iter_mut().enumerate() {
            *ok &= volume[i].is_normal();
        }
        let values: [Lanes; 4] = match kind {
            MassKind::Barycentric => [std::array::from_fn(|i| volume[i] / 4.0); 4],
            MassKind::Circumcentric => dm,
            MassKind::Fem => [volume; 4],
            MassKind::Mixed => unreachable!("no batch serves the mixed mass"),
        };
        all_finite(&values, &mut ok);
        for (k, out) in m.iter_mut().enumerate() {
            *out = std::array::from_fn(|c| values[c][k]);
        }
    }
    ok
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
        let (mut plain, mut precise) = (0, 0);
        for request in kinds.iter().flat_map(|&l| masses.iter().map(move |&m| Request { laplacian: Some(l), mass: Some(m) })) {
            for (g, group) in cells.chunks(LANES).enumerate() {
                let group = &group[..group.len() - g % 3]; // partly filled lanes too
                let (mut w, mut m) = ([[0.0; 6]; LANES], [[0.0; 4]; LANES]);
                let (mut pw, mut pm) = ([[0.0; 6]; LANES], [[0.0; 4]; LANES]);
                let done = tets_at_once(&points, group, request, &mut w, &mut m);
                let done_precise = tets_precise_at_once(&points, group, request, &mut pw, &mut pm);
                for (i, cell) in group.iter().enumerate() {
                    let x = cell.map(|v| &points[3 * v as usize..][..3]);
                    let local = crate::element::frame::local_tet(x, &mut []);
                    let el = Element::<Tet>::new(local, &points, 3, *cell, None, false);
                    let expected = (el.laplacian(request.laplacian.unwrap()), el.corner_mass(request.mass.unwrap()));
                    assert!(!(done[i] && done_precise[i]), "one route per tet");
                    let (got_w, got_m) = match (done[i], done_precise[i]) {
                        (true, _) => (w[i], m[i]),
                        (_, true) => (pw[i], pm[i]),
                        _ => continue,
                    };
                    plain += done[i] as usize;
                    precise += done_precise[i] as usize;
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&got_w), bits(&expected.0.expect("computed")), "{request:?} {x:?}");
                    assert_eq!(bits(&got_m), bits(&expected.1.expect("computed")), "{request:?} {x:?}");
                }
            }
        }
        assert!(plain > 1000 && precise > 1000, "{plain} plain, {precise} precise");
    }
}
