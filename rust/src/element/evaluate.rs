//! One element evaluated for the operators: its kernels, its vertex weights, the
//! barycentric boundary fix, and the one accuracy rule that decides whether its values can
//! be trusted.

use super::simplex::{Simplex, Values};
use crate::options::{LaplacianKind, MassKind};
use std::cell::OnceCell;

/// Why one element has no values: the [`crate::Degenerate`] policy decides what happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Fault {
    /// Zero volume: its corners are affinely dependent.
    Degenerate,
    /// Its values cannot be computed accurately in `f64` (they overflow, or they fail the
    /// accuracy rule of [`Element::dual`]).
    Inaccurate,
}

/// An element's dual: edge weights and cell volumes, or why it has none.
type DualValues<S> = Result<(<S as Simplex>::EdgeValues, <S as Simplex>::CornerValues), Fault>;

/// One element as the kernels see it, with its dual computed at most once however many
/// operators ask for it.
pub(crate) struct Element<S: Simplex> {
    pub local: S::Local,
    /// The corners' vertex weights (weighted duals only).
    vertex_weights: Option<S::CornerValues>,
    /// Whether the barycentric boundary fix applies (a tet with a boundary face).
    fix_boundary: bool,
    dual: OnceCell<DualValues<S>>,
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

impl<S: Simplex> Element<S> {
    /// The element of `local` with its corners' vertex weights and boundary fix.
    pub fn new(local: S::Local, vertex_weights: Option<S::CornerValues>, fix_boundary: bool) -> Self {
        Element { local, vertex_weights, fix_boundary, dual: OnceCell::new() }
    }

    /// Zero volume.
    fn degenerate(&self) -> Result<(), Fault> {
        if S::is_degenerate(&self.local) {
            Err(Fault::Degenerate)
        } else {
            Ok(())
        }
    }

    /// The dual's edge weights and cell volumes, under the accuracy rule: with dual vertices
    /// other than the circumcentres (vertex weights, the boundary fix), the pieces must sum
    /// to the element's volume within `1e-8` of it; far-off centres (weights much larger than
    /// the squared edges) make them huge and of both signs, and when their sum has lost more
    /// than half of the digits nothing computed from them is trustworthy.
    fn dual(&self) -> Result<&(S::EdgeValues, S::CornerValues), Fault> {
        let dual = self.dual.get_or_init(|| {
            let d = S::dual(&self.local, self.vertex_weights.as_ref(), self.fix_boundary);
            if self.vertex_weights.is_some() || self.fix_boundary {
                let volume = S::measure(&self.local);
                let total: f64 = d.1.as_ref().iter().sum();
                if !((total - volume).abs() <= 1e-8 * volume) {
                    return Err(Fault::Inaccurate);
                }
            }
            Ok(d)
        });
        dual.as_ref().map_err(|&f| f)
    }

    /// The element's edge values (the off-diagonals `w_ij` of its Laplacian) for `kind`.
    pub fn laplacian(&self, kind: LaplacianKind) -> Result<S::EdgeValues, Fault> {
        self.degenerate()?;
        finite(match kind {
            LaplacianKind::Primal => S::primal(&self.local),
            LaplacianKind::Dual => self.dual()?.0,
            LaplacianKind::Affine(s) => {
                let (mut w, d) = (S::primal(&self.local), self.dual()?.0);
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
            MassKind::Circumcentric => self.dual()?.1,
            MassKind::Fem => filled(S::measure(&self.local)),
        })
    }
}
