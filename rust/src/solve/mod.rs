//! **Solve**: sparse symmetric factorizations of the operators, for repeated solves,
//! shift-invert eigensolvers and inertia counts.
//!
//! * [`Factorization`]: a sparse Cholesky `A = P L L^T P^T` or `A = P L D L^T P^T` of a
//!   symmetric matrix (faer's supernodal or simplicial factorization, whichever its flop
//!   count favours), with a fill-reducing ordering (AMD, or a permutation the caller
//!   computed, such as a nested dissection); [`Factorization::refactor`] reuses the
//!   symbolic analysis for a matrix of the same pattern; [`Factorization::inertia`]
//!   counts the signs of `D` (Sylvester's law of inertia).
//! * [`Analysis`]: its symbolic half alone; [`Analysis::numeric`] factorizes values into a
//!   caller's slice (a pure function, which a caller may run where it can be abandoned, such
//!   as a child process) and [`Factorization::from_parts`] takes them.
//! * [`LuFactors`]: solves with the factors `P_r A P_c = L U` of a sparse LU made elsewhere
//!   (SciPy's SuperLU, in a child process of the Python package).
//!
//! The factorization runs on one thread: faer's parallel dense kernels give results that
//! differ in the last bits between thread counts (measured in BENCHMARKS.md), and every
//! result of this crate is bitwise the same for any thread count.

mod factor;
mod lu;

pub use factor::{Analysis, Factorization, Inertia, Method, Ordering, Workspace};
pub use lu::LuFactors;
