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
