//! **Assembly**: the drivers that turn per-element values into operators.
//!
//! * `order`: the internal locality order (Morton vertices, elements by first vertex);
//! * `pattern`: the symbolic step, rows of the CSR pattern and the slot map;
//! * `pass`: the parallel per-element pass and its faults;
//! * `scatter`: per-element values summed onto rows and vertices in a fixed order;
//! * `one_shot`: the public one-shot API; `cached`: [`CachedMesh`], local updates;
//! * `gradient`: the P1 gradients of every element ([`gradients`]);
//! * `centres`: the dual's centres of every tet and face, and its dual edges
//!   ([`dual_centres`]);
//! * `vjp`: derivatives of the operators with respect to the mesh.

pub(crate) mod cached;
pub(crate) mod centres;
pub(crate) mod gradient;
pub(crate) mod one_shot;
pub(crate) mod order;
pub(crate) mod pass;
pub(crate) mod pattern;
pub(crate) mod scatter;
pub mod vjp;

pub use cached::{CachedMesh, Change, Update};
pub use centres::{dual_centres, DualCentres, TetDual};
pub use gradient::gradients;
pub use one_shot::{contributions, edge_weights, element_laplacians, laplacian, mass, operators, operators_skipping, triplets, Skipped, Skips};
pub(crate) use pass::CHUNK;
pub use pattern::Topology;

use crate::element::Simplex;
use crate::error::{Error, Feature, Result};
use crate::options::{Boundary, Options};

/// Runs `f` on the options' threads after checking that meshes of `S` support them (the
/// barycentric boundary treatment is for tets only).
pub(crate) fn install<S: Simplex, R: Send>(opts: &Options, f: impl FnOnce() -> Result<R> + Send) -> Result<R> {
    if opts.boundary == Boundary::Barycentric && !S::WEIGHTED_DUAL {
        return Err(Error::Unsupported { option: Feature::BarycentricBoundary, element: S::NAME });
    }
    opts.install(f)
}
