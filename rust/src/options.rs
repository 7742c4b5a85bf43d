//! What to compute and how: operator kinds and the options common to every call.

use crate::error::{Error, Result};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Which Laplacian (paper Sec. 4-5, 9).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaplacianKind {
    /// P1 FEM / cotan weights (Eq. 7): always negative semidefinite.
    Primal,
    /// Circumcentric dual / DEC weights (Eq. 19-20): non-negative on Delaunay interiors.
    Dual,
    /// `(1 - t) primal + t dual`, `t` in `[0, 1]` (Sec. 9).
    Affine(f64),
}

impl LaplacianKind {
    /// Checks the affine parameter.
    pub fn check(self) -> Result<Self> {
        match self {
            LaplacianKind::Affine(t) if !(0.0..=1.0).contains(&t) => {
                Err(Error::AffineParameter { t })
            }
            kind => Ok(kind),
        }
    }
}

/// Which mass matrix (paper Eq. 3, 4/21, consistent P1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MassKind {
    /// `Vol / 4` per tet corner (`Area / 3` per triangle corner), diagonal.
    Barycentric,
    /// Signed dual-cell volumes `Vol(*i)`, diagonal; negative on some non-Delaunay meshes.
    Circumcentric,
    /// The mixed ("hybrid Voronoi") dual-cell volumes, diagonal and positive: the
    /// circumcentric cells with every face circumcentre outside its triangle moved to the
    /// midpoint of the edge opposite its most negative barycentric coordinate and every tet
    /// circumcentre outside its tet to the (moved) centre of the face opposite its most
    /// negative coordinate (for triangles: Meyer et al.'s mixed areas). libigl's
    /// `massmatrix(V, T, MASSMATRIX_TYPE_VORONOI)` for tets.
    Mixed,
    /// Consistent P1 mass `Vol (1 + delta_ab) / 20` (triangles: `/ 12`), on the edge pattern.
    Fem,
}

/// What to do with an element of zero volume (or one so flat that its contribution
/// overflows).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Degenerate {
    /// Fail with [`Error::Degenerate`] / [`Error::NonFiniteResult`] naming the first such
    /// element.
    #[default]
    Raise,
    /// Give such elements zero weights and zero mass (their edges stay in the pattern).
    Skip,
}

/// Dual vertices of tets with a boundary face (paper Sec. 6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Boundary {
    /// Plain per-tet assembly: dual cells at the boundary are closed by the face
    /// circumcenters. Linear precision at every interior vertex; boundary weights and
    /// masses may be negative.
    #[default]
    Circumcentric,
    /// In tets with a boundary face, a tet or face circumcenter outside its simplex is
    /// replaced by the centroid: non-negative contributions of those tets to weights and
    /// masses, at the cost of linear precision at their vertices. Tets only.
    Barycentric,
}

/// A flag that stops a running computation: every long loop of the crate polls it and
/// returns [`Error::Cancelled`] soon after [`Cancel::cancel`] is called (from any thread).
///
/// ```
/// let cancel = tetlap::Cancel::new();
/// let opts = tetlap::Options { cancel: Some(cancel.clone()), ..Default::default() };
/// cancel.cancel();
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = tetlap::TetView::new(&points, 3, &[[0, 1, 2, 3]])?;
/// let result = tetlap::laplacian(&mesh, tetlap::LaplacianKind::Primal, &opts);
/// assert_eq!(result, Err(tetlap::Error::Cancelled));
/// # Ok::<(), tetlap::Error>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A new, unset flag.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every computation holding this flag to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`Cancel::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Options common to every computation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Options {
    /// Worker threads, `1..=`[`crate::max_threads`]; `None` uses
    /// [`crate::default_threads`]: `RAYON_NUM_THREADS` if set (bounded like this count),
    /// else all cores. Results do not depend on it.
    pub threads: Option<usize>,
    /// Policy for degenerate elements.
    pub degenerate: Degenerate,
    /// Boundary treatment of the dual Laplacian and the circumcentric mass.
    pub boundary: Boundary,
    /// Stops the computation early with [`Error::Cancelled`] when set.
    pub cancel: Option<Cancel>,
}

impl Options {
    /// Checks what does not depend on the mesh, the thread count ([`Error::Threads`], or
    /// for `None` the environment's, [`Error::ThreadsVariable`]): the one check, done by
    /// [`Options::install`] before anything runs.
    pub fn check(&self) -> Result<()> {
        match self.threads {
            Some(threads) => crate::threads::check_threads(threads),
            None => crate::threads::default_threads().map(drop),
        }
    }

    /// Runs `f` on the options' worker threads, after [`Options::check`]: the one way into
    /// a thread pool.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> Result<R> + Send) -> Result<R> {
        self.check()?;
        crate::threads::run(self.threads, f)?
    }

    /// Whether the cancel flag is set.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(Cancel::is_cancelled)
    }

    /// [`Error::Cancelled`] once the cancel flag is set.
    pub fn cancelled(&self) -> Result<()> {
        match &self.cancel {
            Some(c) if c.is_cancelled() => Err(Error::Cancelled),
            _ => Ok(()),
        }
    }
}
