//! **Topology**: what the elements alone (no coordinates) say about a mesh.
//!
//! * `group`: the one parallel counting sort of the crate (records grouped by a small key);
//! * `faces`: boundary, interior and non-manifold faces, repeated elements, edges.

pub(crate) mod faces;
pub(crate) mod group;

pub use faces::{boundary_elements, duplicate_elements, edges, faces, Faces};
pub use group::Incidence;
