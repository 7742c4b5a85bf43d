//! Per-element evaluation: one element's local frame, vertex weights and boundary fix, and
//! its contributions for a requested operator kind, with the faults that the
//! [`crate::Degenerate`] policy decides about.

use crate::error::Error;
use crate::mesh::Mesh;
use crate::options::{Boundary, LaplacianKind, MassKind, Options};
use crate::simplex::{Simplex, Values};
use crate::topology::boundary_elements;
use std::borrow::Cow;
use std::cell::OnceCell;

/// One element could not be evaluated: zero volume, or a value that is not finite
/// ([`Elements::fault_error`] tells which).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Fault;

/// One element as the kernels see it, with its dual computed at most once however many
/// operators ask for it.
pub(crate) struct Element<S: Simplex> {
    pub local: S::Local,
    /// The corners' vertex weights (weighted duals only).
    weights: Option<S::CornerValues>,
    /// Whether the barycentric boundary fix applies (a tet with a boundary face).
    fix_boundary: bool,
    dual: OnceCell<(S::EdgeValues, S::CornerValues)>,
}

fn finite<V: Values>(v: V) -> Result<V, Fault> {
    if v.as_ref().iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(Fault)
    }
}

fn filled<V: Values>(x: f64) -> V {
    let mut v = V::default();
    v.as_mut().fill(x);
    v
}

impl<S: Simplex> Element<S> {
    fn dual(&self) -> &(S::EdgeValues, S::CornerValues) {
        self.dual.get_or_init(|| S::dual(&self.local, self.weights.as_ref(), self.fix_boundary))
    }

    /// The element's edge weights for `kind`.
    pub fn weights(&self, kind: LaplacianKind) -> Result<S::EdgeValues, Fault> {
        if S::is_degenerate(&self.local) {
            return Err(Fault);
        }
        finite(match kind {
            LaplacianKind::Primal => S::primal(&self.local),
            LaplacianKind::Dual => self.dual().0,
            LaplacianKind::Affine(s) => {
                let (mut w, d) = (S::primal(&self.local), self.dual().0);
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
        if S::is_degenerate(&self.local) || !S::measure(&self.local).is_normal() {
            return Err(Fault);
        }
        finite(match kind {
            MassKind::Barycentric => S::barycentric(&self.local),
            MassKind::Circumcentric => self.dual().1,
            MassKind::Fem => filled(S::measure(&self.local)),
        })
    }

    /// Weights and corner masses, each with its own fault (the dual, if both need it, is
    /// computed once): an element that fails for one output is dropped from that output
    /// only, exactly as when the output is computed alone.
    pub fn weights_and_mass(
        &self,
        lap: LaplacianKind,
        mass: MassKind,
    ) -> (Result<S::EdgeValues, Fault>, Result<S::CornerValues, Fault>) {
        (self.weights(lap), self.corner_mass(mass))
    }
}

/// The elements of a mesh as [`Element`]s, with the boundary mask the options ask for.
pub(crate) struct Elements<'a, S: Simplex> {
    mesh: Mesh<'a, S>,
    boundary: Option<Cow<'a, [bool]>>,
    /// The user's index of every element of `mesh` (`None`: the same order).
    element_of: Option<&'a [u32]>,
}

/// Which elements get the barycentric boundary fix, if the options ask for it.
pub(crate) fn boundary_mask<S: Simplex>(mesh: &Mesh<S>, opts: &Options) -> Option<Vec<bool>> {
    (opts.boundary == Boundary::Barycentric).then(|| boundary_elements::<S>(mesh.cells()))
}

impl<'a, S: Simplex> Elements<'a, S> {
    /// The elements of a mesh in the user's order.
    pub fn new(mesh: Mesh<'a, S>, opts: &Options) -> Self {
        Elements { mesh, boundary: boundary_mask(&mesh, opts).map(Cow::Owned), element_of: None }
    }

    /// The elements of an internal mesh whose element `t` is the user's `element_of[t]`,
    /// with a boundary mask computed before (see [`boundary_mask`]).
    pub fn internal(mesh: Mesh<'a, S>, element_of: &'a [u32], boundary: Option<Cow<'a, [bool]>>) -> Self {
        Elements { mesh, boundary, element_of: Some(element_of) }
    }

    /// The user's index of element `t`.
    #[inline]
    pub fn user_index(&self, t: usize) -> usize {
        self.element_of.map_or(t, |e| e[t] as usize)
    }

    pub fn scratch_len(&self) -> usize {
        S::scratch_len(self.mesh.dim())
    }

    /// Element `t` (`scratch`: [`Elements::scratch_len`] values).
    pub fn get(&self, t: usize, scratch: &mut [f64]) -> Element<S> {
        let local = self.mesh.local(t, scratch);
        let cell = self.mesh.cells()[t];
        let weights = self.mesh.weights().map(|w| {
            let mut corner = S::CornerValues::default();
            for (out, &v) in corner.as_mut().iter_mut().zip(cell.as_ref()) {
                *out = w[v as usize];
            }
            corner
        });
        let fix_boundary = self.boundary.as_ref().is_some_and(|b| b[t]);
        Element { local, weights, fix_boundary, dual: OnceCell::new() }
    }

    /// The error for element `t`, known to fail: zero measure or a non-finite value,
    /// naming the user's index.
    pub fn fault_error(&self, t: usize) -> Error {
        let el = self.get(t, &mut vec![0.0; self.scratch_len()]);
        let element = self.user_index(t);
        if S::is_degenerate(&el.local) {
            Error::Degenerate { element }
        } else {
            Error::NonFiniteResult { element }
        }
    }
}
