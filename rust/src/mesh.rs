//! Validated, borrowed view of a simplicial mesh: the one place where input is checked.

use crate::error::{Error, Feature, Result};
use crate::element::{Simplex, Tet, Tri};
use rayon::prelude::*;

/// Largest vertex count: indices are `u32` in the core and `i32` in the CSR output.
pub const MAX_VERTICES: usize = i32::MAX as usize;

/// A mesh of simplices of kind `S` whose input has been checked once.
///
/// * `points`: `n * dim` coordinates, row-major (vertex `i` is `points[i*dim..(i+1)*dim]`),
///   `dim >= S::MIN_DIM` (3 for tets, 2 for triangles); a larger `dim` means the mesh is
///   immersed (e.g. a 3-sphere in R^4) and every element is computed in its own space.
/// * `cells`: `m` elements, 0-based vertex indices in any orientation.
///
/// Checked: the dimension, `points.len()` a multiple of `dim`, at least one vertex and one
/// element, at most [`MAX_VERTICES`] vertices, finite coordinates, indices `< n`, distinct
/// corners per element. Degenerate (zero-volume) elements are detected later by the
/// kernels, under the [`crate::Degenerate`] policy.
///
/// ```
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = tetlap::TetView::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// assert_eq!((mesh.n_vertices(), mesh.n_elements()), (4, 1));
/// assert!(tetlap::TetView::new(&points, 3, &[[0, 1, 2, 4]]).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct MeshView<'a, S: Simplex> {
    points: &'a [f64],
    dim: usize,
    cells: &'a [S::Cell],
    vertex_weights: Option<&'a [f64]>,
}

/// A tetrahedral mesh.
pub type TetView<'a> = MeshView<'a, Tet>;

/// A triangle mesh.
pub type TriView<'a> = MeshView<'a, Tri>;

impl<'a, S: Simplex> MeshView<'a, S> {
    /// Checks the input and returns the view, or the first problem found. The checks run
    /// in parallel on the threads of the calling pool (inside [`crate::Options::install`]),
    /// else on [`crate::default_threads`].
    pub fn new(points: &'a [f64], dim: usize, cells: &'a [S::Cell]) -> Result<Self> {
        let n = check_points(points, dim, S::MIN_DIM)?;
        check_cells::<S>(cells, n)?;
        Ok(MeshView { points, dim, cells, vertex_weights: None })
    }

    /// The same mesh with vertex weights (one finite real per vertex, in squared length
    /// units): the dual Laplacian and circumcentric mass then use weighted circumcenters
    /// (the orthogonal dual of a regular triangulation, a power diagram). Zero weights give
    /// the plain circumcentric dual. Tets only.
    pub fn with_vertex_weights(self, weights: &'a [f64]) -> Result<Self> {
        if !S::WEIGHTED_DUAL {
            return Err(Error::Unsupported { option: Feature::VertexWeights, element: S::NAME });
        }
        if weights.len() != self.n_vertices() {
            return Err(Error::Shape {
                what: format!(
                    "weights must hold one value per vertex ({}), got {}",
                    self.n_vertices(),
                    weights.len()
                ),
            });
        }
        if let Some(i) = weights.iter().position(|w| !w.is_finite()) {
            return Err(Error::NonFiniteWeight { vertex: i, value: weights[i] });
        }
        Ok(MeshView { vertex_weights: Some(weights), ..self })
    }

    /// A view of input that was checked before (same cells, new finite coordinates).
    pub(crate) fn trusted(
        points: &'a [f64],
        dim: usize,
        cells: &'a [S::Cell],
        vertex_weights: Option<&'a [f64]>,
    ) -> Self {
        MeshView { points, dim, cells, vertex_weights }
    }

    /// The vertex weights, if any.
    pub fn vertex_weights(&self) -> Option<&'a [f64]> {
        self.vertex_weights
    }

    /// Number of vertices `n`.
    pub fn n_vertices(&self) -> usize {
        self.points.len() / self.dim
    }

    /// Number of elements `m`.
    pub fn n_elements(&self) -> usize {
        self.cells.len()
    }

    /// Ambient dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The coordinates, row-major `(n, dim)`.
    pub fn points(&self) -> &'a [f64] {
        self.points
    }

    /// The elements.
    pub fn cells(&self) -> &'a [S::Cell] {
        self.cells
    }

    /// Element `t` in its local frame (`scratch`: [`Simplex::scratch_len`] values).
    #[inline]
    pub(crate) fn local(&self, t: usize, scratch: &mut [f64]) -> S::Local {
        S::local(self.points, self.dim, &self.cells[t], scratch)
    }
}

/// Checks `points` as an `(n, dim)` array with `dim >= min_dim` and finite entries;
/// returns `n`.
pub(crate) fn check_points(points: &[f64], dim: usize, min_dim: usize) -> Result<usize> {
    if dim < min_dim {
        return Err(Error::Shape {
            what: format!("points must have at least {min_dim} coordinates per vertex, got {dim}"),
        });
    }
    if points.len() % dim != 0 {
        return Err(Error::Shape {
            what: format!("{} coordinates do not form rows of {dim}", points.len()),
        });
    }
    let n = points.len() / dim;
    if n > MAX_VERTICES {
        return Err(Error::TooManyVertices { n_vertices: n, max: MAX_VERTICES });
    }
    if let Some(k) = crate::threads::position_first(points, |_, x| !x.is_finite())? {
        return Err(Error::NonFiniteCoordinate {
            vertex: k / dim,
            coordinate: k % dim,
            value: points[k],
        });
    }
    Ok(n)
}

/// The largest element count: element-corner ids `K t + c` are `u32`.
pub(crate) fn max_elements<S: Simplex>() -> usize {
    u32::MAX as usize / S::CORNERS
}

/// Checks the element count, index range and distinct corners of every element.
fn check_cells<S: Simplex>(cells: &[S::Cell], n: usize) -> Result<()> {
    if n == 0 || cells.is_empty() {
        return Err(Error::EmptyMesh { n_vertices: n, n_elements: cells.len() });
    }
    if cells.len() > max_elements::<S>() {
        return Err(Error::TooManyElements { n_elements: cells.len(), max: max_elements::<S>() });
    }
    let problem = |element: usize, cell: &S::Cell| -> Option<Error> {
        let cell = cell.as_ref();
        for (corner, &v) in cell.iter().enumerate() {
            if v as usize >= n {
                let index = v as i64;
                return Some(Error::IndexOutOfRange { element, corner, index, n_vertices: n });
            }
            if cell[..corner].contains(&v) {
                return Some(Error::RepeatedVertex { element, vertex: v });
            }
        }
        None
    };
    // the first bad element, whatever the scheduling
    match crate::threads::position_first(cells, |t, c| problem(t, c).is_some())? {
        Some(t) => Err(problem(t, &cells[t]).expect("found above")),
        None => Ok(()),
    }
}

/// Converts signed 64-bit indices (`S::CORNERS` per element, row-major) to cells, naming
/// the first index that is negative or `>= n_vertices`.
///
/// This is how bindings hand over index arrays of any integer type without an unchecked
/// cast.
///
/// ```
/// let cells = tetlap::cells_from_i64::<tetlap::Tet>(&[0, 1, 2, 3], 4)?;
/// assert_eq!(cells, vec![[0, 1, 2, 3]]);
/// assert!(tetlap::cells_from_i64::<tetlap::Tet>(&[0, 1, 2, -1], 4).is_err());
/// # Ok::<(), tetlap::Error>(())
/// ```
pub fn cells_from_i64<S: Simplex>(flat: &[i64], n_vertices: usize) -> Result<Vec<S::Cell>> {
    let k = S::CORNERS;
    if n_vertices > MAX_VERTICES {
        return Err(Error::TooManyVertices { n_vertices, max: MAX_VERTICES });
    }
    if flat.len() % k != 0 {
        return Err(Error::Shape { what: format!("{} indices do not form rows of {k}", flat.len()) });
    }
    let out_of_range = |i: i64| i < 0 || i as u64 >= n_vertices as u64;
    if let Some(at) = crate::threads::position_first(flat, |_, &i| out_of_range(i))? {
        return Err(Error::IndexOutOfRange {
            element: at / k,
            corner: at % k,
            index: flat[at],
            n_vertices,
        });
    }
    crate::threads::here(|| {
        flat.par_chunks_exact(k)
            .map(|c| {
                let mut cell = S::Cell::default();
                for (out, &i) in cell.as_mut().iter_mut().zip(c) {
                    *out = i as u32;
                }
                cell
            })
            .collect()
    })
}
