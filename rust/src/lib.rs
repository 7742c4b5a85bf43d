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
//! same API: every function is generic over the [`Simplex`] kind of a [`Mesh`].
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
//! use tetlap::{operators, LaplacianKind, Mass, MassKind, Options, TetMesh};
//! // two tets sharing the face (1, 2, 3), the second one negatively oriented
//! let points = [0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
//! let tets = [[0, 1, 2, 3], [4, 2, 1, 3]];
//! let mesh = TetMesh::new(&points, 3, &tets)?;
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
//! [`mod@local`] holds the kernels, pure functions of one element; [`Simplex`] ties them to
//! an element kind; the drivers (validation in [`Mesh`], the per-element pass, the row
//! layout in [`Topology`], the scatter) are written once for every kind. [`vjp`]
//! differentiates the operators of a tet mesh with respect to its points and vertex weights
//! ([`mod@derivatives`]).

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod assemble;
mod cached;
mod check;
mod csr;
mod definite;
mod element_certificate;
pub mod derivatives;
mod element;
mod error;
mod faces;
mod geometry;
mod group;
mod layout;
pub mod local;
mod mesh;
mod operators;
mod options;
mod parallel;
mod pass;
mod quality;
mod simplex;
mod topology;

pub use cached::{CachedMesh, Update};
pub use check::{check_operator, OperatorCheck};
pub use csr::{Coo, Csr, Mass};
pub use definite::{negative_semidefinite, Semidefinite, MAX_GROUP};
pub use element_certificate::negative_semidefinite_by_elements;
pub use derivatives::{
    vjp, Columns, Cotangents, CsrRef, LaplacianCotangent, MassCotangent, MeshGradient,
};
pub use error::{Error, Feature, Result};
pub use geometry::{local_tet, local_tri, LocalTet, LocalTri};
pub use mesh::{cells_from_i64, Mesh, TetMesh, TriMesh, MAX_VERTICES};
pub use operators::{contributions, edge_weights, laplacian, mass, operators, triplets, upper_triangle};
pub use options::{Boundary, Cancel, Degenerate, LaplacianKind, MassKind, Options};
pub use parallel::max_threads;
pub use quality::{inside_circumsphere, non_delaunay_faces, quality, tet_quality, TetQuality, DELAUNAY_RTOL};
pub use simplex::{Simplex, Tet, Tri, Values};
pub use faces::{duplicate_elements, edges, faces, Faces};
pub use group::Incidence;
pub use topology::{boundary_elements, Topology};
