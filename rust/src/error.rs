//! The one error type of the crate. Every variant names the offending element.

use std::fmt;

/// Everything that can go wrong, each naming the tet, vertex or value at fault.
///
/// The core validates its input once ([`crate::TetMesh::new`]) and never panics on user
/// data: every problem surfaces as one of these variants.
#[derive(Debug, Clone, PartialEq)]
#[allow(missing_docs)] // the fields are named for what they hold
pub enum Error {
    /// Points are not a `(n, dim)` array with `dim >= 3` (`min_dim` = 2 for triangles).
    Shape { message: String },
    /// The mesh has no vertices or no elements.
    EmptyMesh { n_vertices: usize, n_elements: usize },
    /// More vertices than the `u32` / `i32` indices of the core and of the CSR output hold.
    TooManyVertices { n_vertices: usize, max: usize },
    /// A coordinate is NaN or infinite.
    NonFiniteCoordinate { vertex: usize, coordinate: usize, value: f64 },
    /// A vertex weight is NaN or infinite.
    NonFiniteWeight { vertex: usize, value: f64 },
    /// An element refers to a vertex index `< 0` or `>= n_vertices`.
    IndexOutOfRange { element: usize, corner: usize, index: i64, n_vertices: usize },
    /// The same vertex appears twice in one element.
    RepeatedVertex { element: usize, vertex: u32 },
    /// An element has exactly zero volume (its vertices are affinely dependent).
    Degenerate { element: usize },
    /// An element's contribution overflows `f64` (nearly degenerate, or huge coordinates).
    NonFiniteResult { element: usize },
    /// An option has a value outside its domain (e.g. `threads = 0`, `t` outside `[0, 1]`).
    InvalidOption { message: String },
}

/// `Result<T, tetlap::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A stable, short name of the variant (the bindings map it to an exception class).
    pub fn kind(&self) -> &'static str {
        match self {
            Error::Shape { .. } => "ShapeError",
            Error::EmptyMesh { .. } => "EmptyMeshError",
            Error::TooManyVertices { .. } => "IndexRangeError",
            Error::NonFiniteCoordinate { .. } => "NonFiniteError",
            Error::NonFiniteWeight { .. } => "NonFiniteError",
            Error::IndexOutOfRange { .. } => "IndexRangeError",
            Error::RepeatedVertex { .. } => "RepeatedVertexError",
            Error::Degenerate { .. } => "DegenerateElementError",
            Error::NonFiniteResult { .. } => "DegenerateElementError",
            Error::InvalidOption { .. } => "OptionError",
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Shape { message } => write!(f, "{message}"),
            Error::EmptyMesh { n_vertices, n_elements } => write!(
                f,
                "empty mesh: {n_vertices} vertices and {n_elements} elements \
                 (a Laplacian needs at least one element)"
            ),
            Error::TooManyVertices { n_vertices, max } => {
                write!(f, "{n_vertices} vertices: at most {max} are supported")
            }
            Error::NonFiniteCoordinate { vertex, coordinate, value } => write!(
                f,
                "vertex {vertex} has a non-finite coordinate {value} (column {coordinate})"
            ),
            Error::NonFiniteWeight { vertex, value } => {
                write!(f, "vertex {vertex} has a non-finite weight {value}")
            }
            Error::IndexOutOfRange { element, corner, index, n_vertices } => write!(
                f,
                "element {element} refers to vertex {index} (corner {corner}), \
                 but valid indices are 0..{n_vertices}"
            ),
            Error::RepeatedVertex { element, vertex } => {
                write!(f, "element {element} uses vertex {vertex} more than once")
            }
            Error::Degenerate { element } => write!(
                f,
                "element {element} is degenerate (zero volume); pass degenerate=\"skip\" \
                 to give such elements zero contribution"
            ),
            Error::NonFiniteResult { element } => write!(
                f,
                "element {element}: its contribution is not finite in double precision \
                 (a nearly degenerate tet, or coordinates so large that its volume \
                 overflows); pass degenerate=\"skip\" to drop it"
            ),
            Error::InvalidOption { message } => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for Error {}
