//! **Analysis**: what can be proved about an operator and its mesh.
//!
//! * `check`: the Table-1 properties read off an operator in one pass;
//! * `definite`: negative semidefiniteness from the operator's weights;
//! * `element_certificate`: negative semidefiniteness from the element matrices;
//! * `quality`: per-tet quality and the local Delaunay test;
//! * [`regular`]: vertex weights that make a mesh regular (weighted Delaunay).

pub(crate) mod check;
pub(crate) mod definite;
pub(crate) mod element_certificate;
pub(crate) mod quality;
pub mod regular;

pub use check::{check_operator, OperatorCheck};
pub use definite::{negative_semidefinite, Semidefinite, MAX_GROUP};
pub use element_certificate::negative_semidefinite_by_elements;
pub use quality::{non_delaunay_faces, quality};
