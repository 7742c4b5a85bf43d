//! **Elements**: one element's coordinates in, its values out.
//!
//! The lowest layer of the crate: pure functions of one element (no indices, no threads, no
//! allocation) and the rule that decides how an element's values are computed and whether
//! they can be trusted (the accuracy rule: `evaluate.rs`, [`ACCURACY`]).
//!
//! * [`frame`]: an element's coordinates in its own space, scaled by a power of two, with
//!   its determinant rounded correctly ([`exact`] where `f64` cannot be trusted);
//! * [`bounded`], [`rational`]: the arithmetic of the precise path (double-double with
//!   error bounds) and of its last resort (exact rationals);
//! * [`tet`]: the kernels of one tet (primal, dual, power-diagram dual, masses, quality)
//!   and their reverse derivatives ([`tet::derivatives`]);
//! * [`tri`]: the kernels of one triangle;
//! * [`gradient`]: the gradients of an element's barycentric coordinates (P1 gradients);
//! * [`metric`]: an element's coefficient (a conductivity `K`: a positive scalar or an SPD
//!   tensor) as its kernels use it: the element mapped into the metric `K^-1`;
//! * [`Simplex`]: what the drivers need to know about an element kind ([`Tet`], [`Tri`]).

pub mod bounded;
pub mod exact;
pub mod frame;
pub mod gradient;
pub mod metric;
pub mod rational;
pub mod tet;
pub mod tri;

mod evaluate;
mod simplex;

pub(crate) use evaluate::{Element, Fault, LaplacianValues};
pub use evaluate::{Request, Scales, ACCURACY};
pub use frame::{local_tet, local_tri, LocalTet, LocalTri};
pub(crate) use simplex::edge_index;
pub use simplex::{corner_sums, Simplex, Tet, Tri, Values};
