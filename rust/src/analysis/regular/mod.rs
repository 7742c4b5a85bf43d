//! **Regular weights**: the per-face and per-tet work of finding vertex weights that make a
//! tet mesh regular (weighted Delaunay), for the Python package `tetlap.regular`, which
//! decides, proves and reports.
//!
//! * [`conditions`]: every interior face's margin, affine in the vertex weights;
//! * [`search`](search()): weights that lift every condition to a floor (the squared
//!   shortfall of the conditions);
//! * [`keep_masses`]: the circumcentric masses kept positive with the faces regular;
//! * `hinge`: squared shortfalls of sparse linear rows, the objective of both;
//! * `lbfgs`: the minimiser (projected L-BFGS), deterministic for any thread count
//!   ([`Budget`], [`Stop`]).
//!
//! Budgets count iterations; a wall-clock deadline is only an explicit opt-in of the
//! caller. Every result is bitwise the same for any thread count.

mod conditions;
mod hinge;
mod lbfgs;
mod masses;
mod search;

pub use conditions::{conditions, lifted_signs, Conditions, VERIFY_RTOL};
pub use lbfgs::{Budget, Stop};
pub use masses::{keep_masses, MassOutcome, MassTargets, PASS_ITERATIONS, ROUNDS};
pub use search::{search, Outcome, Rows, Targets};
