//! The one error type of the crate, in Rust terms. Every variant names what is at fault
//! (the element, the vertex, the value), so that callers (such as the Python bindings)
//! can word their own messages from the fields.

use std::fmt;

/// Everything that can go wrong, each naming the element, vertex or value at fault.
///
/// The core validates its input once ([`crate::MeshView::new`]) and never panics on user
/// data: every problem surfaces as one of these variants.
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)] // the fields are named for what they hold
pub enum Error {
    /// Points are not rows of `dim >= min_dim` coordinates, or an array does not have one
    /// entry per vertex (`what` says which array and how).
    Shape { what: String },
    /// The mesh has no vertices or no elements.
    EmptyMesh { n_vertices: usize, n_elements: usize },
    /// More vertices than the `u32` indices of the core and the `i32` ones of the CSR
    /// output hold.
    TooManyVertices { n_vertices: usize, max: usize },
    /// More elements than the `u32` element-corner ids of the core hold.
    TooManyElements { n_elements: usize, max: usize },
    /// A coordinate is NaN or infinite.
    NonFiniteCoordinate { vertex: usize, coordinate: usize, value: f64 },
    /// A vertex weight is NaN or infinite.
    NonFiniteWeight { vertex: usize, value: f64 },
    /// An element refers to a vertex index `< 0` or `>= n_vertices`.
    IndexOutOfRange { element: usize, corner: usize, index: i64, n_vertices: usize },
    /// The same vertex appears twice in one element.
    RepeatedVertex { element: usize, vertex: u32 },
    /// An element has exactly zero volume (a triangle: zero area; its vertices are
    /// affinely dependent).
    Degenerate { element: usize },
    /// A kind of an element's values leaves the normal `f64` range (a volume beyond it, or
    /// the weights or masses of a needle or a flat tet), or, for a tet immersed in R^d,
    /// `d > 3`, they cannot be computed to the documented accuracy
    /// ([`crate::element::ACCURACY`]; the rule is in `crate::element`'s docs).
    NonFiniteResult { element: usize },
    /// An element's values are fine, but their products with what a caller gave (the
    /// cotangents of [`crate::vjp`], such as a function `f` of the Dirichlet energy) leave
    /// the `f64` range.
    Overflow { element: usize },
    /// The entries of a row (or the masses at a vertex) sum beyond the `f64` range,
    /// although every element's own values are finite (coordinates too large).
    SumOverflow { vertex: usize },
    /// The affine parameter of [`crate::LaplacianKind::Affine`] lies outside `[0, 1]`.
    AffineParameter { t: f64 },
    /// [`crate::Options::threads`] is 0 or above [`crate::max_threads`].
    Threads { threads: usize, max: usize },
    /// [`crate::Options::threads`] is `None` and the environment variable
    /// `RAYON_NUM_THREADS` holds `value`, which is not `0` (all cores) or a count in
    /// `1..=max` ([`crate::default_threads`]).
    ThreadsVariable { value: String, max: usize },
    /// The operating system refused to start worker threads.
    ThreadPool { reason: String },
    /// An option that this kind of element does not support.
    Unsupported { option: Feature, element: &'static str },
    /// A vertex list of [`crate::CachedMesh::move_vertices`] is not ascending and distinct,
    /// or names a vertex `>= n_vertices` (`position` is its place in the list).
    VertexList { position: usize, vertex: u32, n_vertices: usize },
    /// A cotangent given to [`crate::vjp`] holds NaN or an infinity (`what` names the
    /// array, `index` the position in its flat values).
    NonFiniteCotangent { what: &'static str, index: usize, value: f64 },
    /// A derivative that [`crate::vjp`] does not provide (`what` says which).
    NotDifferentiable { what: &'static str },
    /// The computation was cancelled through [`crate::Options::cancel`].
    Cancelled,
    /// A Cholesky factorization ([`crate::solve::Method::Cholesky`]) met a pivot `<= 0`:
    /// the matrix is not positive definite (`row` is the matrix row of that pivot).
    NotPositiveDefinite { row: usize },
    /// An `LDL^T` factorization without pivoting ([`crate::solve::Method::Ldlt`]) met a
    /// zero pivot at matrix row `row`.
    Singular { row: usize },
    /// Not enough memory for `what`.
    OutOfMemory { what: &'static str },
    /// A value of a coefficient of the Laplacian or of a density of the masses is refused
    /// ([`crate::MeshView::with_coefficient`], [`crate::MeshView::with_density`]):
    /// `element` is the element it belongs to (`None`: the one tensor given for every
    /// element), `kind` names the elements ("tet", "triangle"), `density` whether it is the
    /// density.
    Coefficient { element: Option<usize>, kind: &'static str, density: bool, problem: CoefficientProblem },
    /// A computation that does not take a coefficient or a density was given a mesh with
    /// one (`what` names the computation).
    CoefficientUnsupported { what: &'static str },
}

/// Why a value of a coefficient or a density is refused (see [`Error::Coefficient`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[allow(missing_docs)] // the fields are named for what they hold
pub enum CoefficientProblem {
    /// NaN or an infinity (`entry`: its row and column in a tensor; `None` for a scalar).
    NonFinite { entry: Option<(usize, usize)>, value: f64 },
    /// A scalar that is zero or negative.
    NotPositive { value: f64 },
    /// A tensor whose entries `(row, col)` and `(col, row)` differ by more than
    /// [`SYMMETRY_RTOL`](crate::element::metric::SYMMETRY_RTOL) of its largest entry
    /// (`asymmetry`: that difference over the largest entry).
    NotSymmetric { row: usize, col: usize, asymmetry: f64 },
    /// A tensor that is not positive definite in `f64` (its Cholesky factorization meets
    /// a pivot `<= 0`), with its smallest and largest eigenvalues.
    NotPositiveDefinite { smallest: f64, largest: f64 },
}

/// Options that only some kinds of element support (see [`Error::Unsupported`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Vertex weights ([`crate::MeshView::with_vertex_weights`]): tets only.
    VertexWeights,
    /// [`crate::Boundary::Barycentric`]: tets only.
    BarycentricBoundary,
}

/// `Result<T, tetlap::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Shape { what } => write!(f, "{what}"),
            Error::EmptyMesh { n_vertices, n_elements } => write!(
                f,
                "empty mesh: {n_vertices} vertices and {n_elements} elements \
                 (a Laplacian needs at least one element)"
            ),
            Error::TooManyVertices { n_vertices, max } => {
                write!(f, "{n_vertices} vertices: at most {max} are supported")
            }
            Error::TooManyElements { n_elements, max } => {
                write!(f, "{n_elements} elements: at most {max} are supported")
            }
            Error::NonFiniteCoordinate { vertex, coordinate, value } => write!(
                f,
                "vertex {vertex} has a non-finite coordinate {value} (column {coordinate})"
            ),
            Error::NonFiniteWeight { vertex, value } => {
                write!(f, "vertex {vertex} has a non-finite weight {value}")
            }
            Error::IndexOutOfRange { element, corner, index, n_vertices } => match n_vertices {
                0 => write!(f, "element {element} refers to vertex {index} (corner {corner}), but there are no vertices"),
                n => write!(
                    f,
                    "element {element} refers to vertex {index} (corner {corner}), but there are {n} \
                     vertices, 0 to {}",
                    n - 1
                ),
            },
            Error::RepeatedVertex { element, vertex } => {
                write!(f, "element {element} uses vertex {vertex} more than once")
            }
            Error::Degenerate { element } => write!(
                f,
                "element {element} is degenerate (zero volume for a tet, zero area for a \
                 triangle); Degenerate::Skip gives such elements zero contribution"
            ),
            Error::NonFiniteResult { element } => write!(
                f,
                "element {element}: its values leave the f64 range (normal magnitudes 2.2e-308 \
                 to 1.8e308: a volume beyond it, or the weights or masses of a needle or a flat \
                 tet beyond it) or, immersed in R^d, cannot be computed to the documented \
                 accuracy; Degenerate::Skip drops it"
            ),
            Error::Overflow { element } => write!(
                f,
                "element {element}: the products of its values with the cotangents leave the f64 \
                 range (the cotangents are too large; scale them down)"
            ),
            Error::SumOverflow { vertex } => write!(
                f,
                "the values at vertex {vertex} sum beyond the f64 range (coordinates too large \
                 for double precision; scale the mesh down)"
            ),
            Error::AffineParameter { t } => {
                write!(f, "LaplacianKind::Affine(t) needs t in [0, 1], got {t}")
            }
            Error::Threads { threads, max } => {
                write!(f, "Options::threads must lie in 1..={max}, got {threads}")
            }
            Error::ThreadsVariable { value, max } => write!(
                f,
                "RAYON_NUM_THREADS={value:?} is not a thread count: it must be 0 (all cores) or lie in \
                 1..={max}, as Options::threads must"
            ),
            Error::ThreadPool { reason } => write!(f, "could not start worker threads: {reason}"),
            Error::Unsupported { option, element } => {
                let option = match option {
                    Feature::VertexWeights => "vertex weights (MeshView::with_vertex_weights)",
                    Feature::BarycentricBoundary => "Boundary::Barycentric",
                };
                write!(f, "{option} is not supported for {element} meshes")
            }
            Error::VertexList { position, vertex, n_vertices } => write!(
                f,
                "moved vertex {vertex} at position {position}: the list must be ascending, \
                 distinct and below {n_vertices}"
            ),
            Error::NonFiniteCotangent { what, index, value } => {
                write!(f, "{what} holds a non-finite value {value} (at flat index {index})")
            }
            Error::NotDifferentiable { what } => {
                write!(f, "derivatives of {what} are not available")
            }
            Error::Cancelled => write!(f, "cancelled"),
            Error::NotPositiveDefinite { row } => write!(
                f,
                "the matrix is not positive definite: the Cholesky pivot of row {row} is not positive \
                 (Method::Ldlt factorizes indefinite matrices)"
            ),
            Error::Singular { row } => {
                write!(f, "the LDL^T factorization met a zero pivot at row {row}: the matrix is singular there")
            }
            Error::OutOfMemory { what } => write!(f, "not enough memory for {what}"),
            Error::Coefficient { element, kind, density, problem } => {
                let name = if *density { "density" } else { "coefficient" };
                match element {
                    Some(t) => write!(f, "the {name} of {kind} {t} ")?,
                    None => write!(f, "the {name} (one tensor for every {kind}) ")?,
                }
                match problem {
                    CoefficientProblem::NonFinite { entry: None, value } => write!(f, "is not finite: {value}"),
                    CoefficientProblem::NonFinite { entry: Some((row, col)), value } => {
                        write!(f, "is not finite: {value} at ({row}, {col})")
                    }
                    CoefficientProblem::NotPositive { value } => write!(f, "is not positive: {value}"),
                    CoefficientProblem::NotSymmetric { row, col, asymmetry } => write!(
                        f,
                        "is not symmetric: entries ({row}, {col}) and ({col}, {row}) differ by {asymmetry:.3e} \
                         of its largest entry"
                    ),
                    CoefficientProblem::NotPositiveDefinite { smallest, largest } => write!(
                        f,
                        "is not positive definite: its smallest eigenvalue is {smallest:.6e} (largest {largest:.6e})"
                    ),
                }
            }
            Error::CoefficientUnsupported { what } => {
                write!(f, "{what} does not take a coefficient or a density")
            }
        }
    }
}

impl std::error::Error for Error {}
