//! # tetlap — Laplace operators of tetrahedral meshes
//!
//! The two discrete Laplacians of Alexa, Herholz, Kohlbrenner and Sorkine-Hornung,
//! *Properties of Laplace Operators for Tetrahedral Meshes* (SGP 2020), with their mass
//! matrices:
//!
//! * the **primal** Laplacian (P1 FEM / cotan, Eq. 7): always negative semidefinite;
//! * the **dual** Laplacian (circumcentric DEC / finite volume, Eq. 17-21): non-negative
//!   weights on Delaunay meshes (a maximum principle), but indefinite on bad meshes;
//! * barycentric, circumcentric (signed dual-cell volumes) and consistent P1 mass matrices.
//!
//! Tets ([`Tet`]) and triangles ([`Tri`], where primal and dual coincide) go through the
//! same API: every function is generic over the [`Simplex`] kind of a [`MeshView`].
//!
//! ## Conventions
//! * Points: `n x dim` row-major `f64`, `dim >= 3` for tets, `dim >= 2` for triangles
//!   (larger: an immersed mesh, every element computed in its own space). Elements:
//!   `[u32; 4]` or `[u32; 3]`, 0-based, **any orientation**: results never depend on the
//!   orientation or vertex order of an element.
//! * Sign (paper Eq. 1): `L[i, j] = w_ij` for an edge, `L[i, i] = -sum_j w_ij`; rows sum to
//!   zero; the primal `L` is negative semidefinite.
//! * Local edge order inside a tet: `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`.
//! * Deterministic: the same input gives bitwise-identical output for any thread count.
//!
//! ## Example
//! ```
//! use tetlap::{operators, LaplacianKind, Mass, MassKind, Options, TetView};
//! // two tets sharing the face (1, 2, 3), the second one negatively oriented
//! let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
//! let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
//! let mesh = TetView::new(&points, 3, &tets)?;
//! let (l, m) = operators(&mesh, LaplacianKind::Dual, MassKind::Circumcentric, &Options::default())?;
//! assert_eq!(l.n, 5);
//! let row_sum: f64 = (0..5).map(|j| l.get(1, j)).sum();
//! assert!(row_sum.abs() < 1e-15);
//! let Mass::Lumped(m) = m else { unreachable!() };
//! assert!((m.iter().sum::<f64>() - 0.5).abs() < 1e-14); // total volume 1/6 + 1/3
//! # Ok::<(), tetlap::Error>(())
//! ```
//!
//! ## Layout
//! The crate is built in layers; a module uses only the layers below it (checked by the
//! test `rust/tests/layers.rs`):
//!
//! 1. [`error`](Error), options and threads ([`Options`], [`Options::install`]), the
//!    sparse outputs ([`Csr`], [`Coo`], [`Mass`]);
//! 2. [`mod@element`]: kernels, pure functions of one element, and the accuracy rule;
//!    [`Simplex`] ties them to an element kind;
//! 3. the validated mesh view, [`MeshView`];
//! 4. [`mod@topology`]: what the elements alone say (grouping, faces);
//! 5. [`mod@assembly`]: the drivers (internal order, pattern, per-element pass, scatter,
//!    [`CachedMesh`], derivatives: [`vjp`], [`mod@derivatives`]);
//! 6. [`mod@analysis`]: checks and certificates of an operator on its mesh;
//! 7. [`mod@solve`]: sparse factorizations of the operators for linear systems,
//!    repeated solves and eigenproblems ([`solve::Factorization`]).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
mod threads;
mod options;
mod sparse;
pub mod element;
mod mesh;
pub mod topology;
pub mod assembly;
pub mod analysis;
pub mod solve;

pub use analysis::{
    check_operator, negative_semidefinite, negative_semidefinite_by_elements, non_delaunay_faces, quality,
    OperatorCheck, Semidefinite, MAX_GROUP,
};
pub use assembly::vjp as derivatives;
pub use assembly::vjp::{vjp, Columns, Cotangents, LaplacianCotangent, MassCotangent, MeshGradient};
pub use assembly::gradients;
pub use assembly::{dual_centres, DualCentres, TetDual};
pub use assembly::{
    contributions, edge_weights, element_laplacians, laplacian, mass, operators, operators_skipping, triplets, CachedMesh, Change,
    Skipped, Skips, Topology, Update,
};
pub use element::tet::{inside_circumsphere, tet_quality, TetQuality, DELAUNAY_RTOL};
pub use element::{local_tet, local_tri, LocalTet, LocalTri, Simplex, Tet, Tri, Values};
pub use error::{CoefficientProblem, Error, Feature, Result};
pub use mesh::{cells_from_i64, check_coefficient, check_density, Coefficient, MeshView, TetView, TriView, MAX_VERTICES};
pub use options::{Boundary, Cancel, Degenerate, LaplacianKind, MassKind, Options};
pub use sparse::{Coo, Csr, CsrRef, Mass};
pub use threads::{default_threads, max_threads, THREADS_VARIABLE};
pub use topology::{boundary_elements, duplicate_elements, edges, faces, Faces, Incidence};
