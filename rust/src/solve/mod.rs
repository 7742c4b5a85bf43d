//! **Solve**: sparse symmetric factorizations of the operators, for repeated solves,
//! shift-invert eigensolvers and inertia counts.
//!
//! * [`Factorization`]: a sparse Cholesky `A = P L L^T P^T` or `A = P L D L^T P^T` of a
//!   symmetric matrix (faer's supernodal or simplicial factorization, whichever its flop
//!   count favours), with a fill-reducing ordering (AMD, or a permutation the caller
//!   computed, such as a nested dissection); [`Factorization::refactor`] reuses the
//!   symbolic analysis for a matrix of the same pattern; [`Factorization::inertia`]
//!   counts the signs of `D` (Sylvester's law of inertia).
//!
//! The factorization runs on one thread: faer's parallel dense kernels give results that
//! differ in the last bits between thread counts (measured in BENCHMARKS.md), and every
//! result of this crate is bitwise the same for any thread count.

mod factor;

pub use factor::{Factorization, Inertia, Method, Ordering};
