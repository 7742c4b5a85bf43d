//! Validated, borrowed view of a tetrahedral mesh: the one place where input is checked.

use crate::error::{Error, Result};
use rayon::prelude::*;

/// Largest vertex count: indices are `u32` in the core and `i32` in the CSR output.
pub const MAX_VERTICES: usize = i32::MAX as usize;

/// A tetrahedral mesh whose input has been checked once.
///
/// * `points`: `n * dim` coordinates, row-major (vertex `i` is `points[i*dim..(i+1)*dim]`),
///   `dim >= 3`; `dim > 3` means the mesh is immersed (e.g. a 3-sphere in R^4).
/// * `tets`: `m` tets, 0-based vertex indices in any orientation.
///
/// Checked: `dim >= 3`, `points.len()` a multiple of `dim`, at least one vertex and one tet,
/// at most [`MAX_VERTICES`] vertices, finite coordinates, indices `< n`, four distinct
/// vertices per tet. Degenerate (zero-volume) tets are detected later by the kernels, under
/// the [`crate::Degenerate`] policy.
///
/// ```
/// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
/// let mesh = tetlap::TetMesh::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
/// assert_eq!((mesh.n_vertices(), mesh.n_tets()), (4, 1));
/// assert!(tetlap::TetMesh::new(&points, 3, &[[0, 1, 2, 4]]).is_err());
/// ```
#[derive(Debug, Clone, Copy)]
pub struct TetMesh<'a> {
    points: &'a [f64],
    dim: usize,
    tets: &'a [[u32; 4]],
    weights: Option<&'a [f64]>,
}

impl<'a> TetMesh<'a> {
    /// Checks the input and returns the view, or the first problem found.
    pub fn new(points: &'a [f64], dim: usize, tets: &'a [[u32; 4]]) -> Result<Self> {
        let n = check_points(points, dim, 3)?;
        check_elements(tets, n)?;
        Ok(TetMesh { points, dim, tets, weights: None })
    }

    /// The same mesh with vertex weights (one finite real per vertex, in squared length
    /// units): the dual Laplacian and circumcentric mass then use weighted circumcenters
    /// (the orthogonal dual of a regular triangulation, a power diagram). Zero weights give
    /// the plain circumcentric dual.
    pub fn with_weights(self, weights: &'a [f64]) -> Result<Self> {
        if weights.len() != self.n_vertices() {
            return Err(Error::Shape {
                message: format!(
                    "weights must hold one value per vertex ({}), got {}",
                    self.n_vertices(),
                    weights.len()
                ),
            });
        }
        if let Some(i) = weights.iter().position(|w| !w.is_finite()) {
            return Err(Error::NonFiniteWeight { vertex: i, value: weights[i] });
        }
        Ok(TetMesh { weights: Some(weights), ..self })
    }

    /// The vertex weights, if any.
    pub fn weights(&self) -> Option<&'a [f64]> {
        self.weights
    }

    /// A view of input that was checked before (same indices, new finite coordinates).
    pub(crate) fn trusted(
        points: &'a [f64],
        dim: usize,
        tets: &'a [[u32; 4]],
        weights: Option<&'a [f64]>,
    ) -> Self {
        TetMesh { points, dim, tets, weights }
    }

    /// Number of vertices `n`.
    pub fn n_vertices(&self) -> usize {
        self.points.len() / self.dim
    }

    /// Number of tets `m`.
    pub fn n_tets(&self) -> usize {
        self.tets.len()
    }

    /// Ambient dimension `d >= 3`.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The coordinates, row-major `(n, dim)`.
    pub fn points(&self) -> &'a [f64] {
        self.points
    }

    /// The tets.
    pub fn tets(&self) -> &'a [[u32; 4]] {
        self.tets
    }

    /// Coordinates of vertex `i` (length `dim`).
    #[inline]
    pub fn point(&self, i: u32) -> &'a [f64] {
        let i = i as usize * self.dim;
        &self.points[i..i + self.dim]
    }
}

/// A triangle mesh whose input has been checked once: `points` row-major `(n, dim)` with
/// `dim >= 2` (`dim > 2`: a surface immersed in R^dim), `tris` in any orientation.
///
/// ```
/// let points = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0];
/// let mesh = tetlap::TriMesh::new(&points, 2, &[[0, 1, 2]]).unwrap();
/// assert_eq!(mesh.n_triangles(), 1);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct TriMesh<'a> {
    points: &'a [f64],
    dim: usize,
    tris: &'a [[u32; 3]],
}

impl<'a> TriMesh<'a> {
    /// Checks the input (as [`TetMesh::new`], with `dim >= 2`).
    pub fn new(points: &'a [f64], dim: usize, tris: &'a [[u32; 3]]) -> Result<Self> {
        let n = check_points(points, dim, 2)?;
        check_elements(tris, n)?;
        Ok(TriMesh { points, dim, tris })
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.points.len() / self.dim
    }

    /// Number of triangles.
    pub fn n_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Ambient dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The triangles.
    pub fn triangles(&self) -> &'a [[u32; 3]] {
        self.tris
    }

    /// Coordinates of vertex `i`.
    #[inline]
    pub fn point(&self, i: u32) -> &'a [f64] {
        let i = i as usize * self.dim;
        &self.points[i..i + self.dim]
    }
}

/// Checks `points` as an `(n, dim)` array with `dim >= min_dim` and finite entries; returns `n`.
pub(crate) fn check_points(points: &[f64], dim: usize, min_dim: usize) -> Result<usize> {
    if dim < min_dim {
        return Err(Error::Shape {
            message: format!(
                "points must have at least {min_dim} coordinates per vertex, got {dim}"
            ),
        });
    }
    if points.len() % dim != 0 {
        return Err(Error::Shape {
            message: format!("{} coordinates do not form rows of {dim}", points.len()),
        });
    }
    let n = points.len() / dim;
    if n > MAX_VERTICES {
        return Err(Error::TooManyVertices { n_vertices: n, max: MAX_VERTICES });
    }
    if let Some(k) = points.par_iter().position_first(|x| !x.is_finite()) {
        return Err(Error::NonFiniteCoordinate {
            vertex: k / dim,
            coordinate: k % dim,
            value: points[k],
        });
    }
    Ok(n)
}

/// Checks index range and distinct corners of every element.
pub(crate) fn check_elements<const K: usize>(elements: &[[u32; K]], n: usize) -> Result<()> {
    if n == 0 || elements.is_empty() {
        return Err(Error::EmptyMesh { n_vertices: n, n_elements: elements.len() });
    }
    let problem = |element: usize, e: &[u32; K]| -> Option<Error> {
        for (corner, &v) in e.iter().enumerate() {
            if v as usize >= n {
                let index = v as i64;
                return Some(Error::IndexOutOfRange { element, corner, index, n_vertices: n });
            }
            if e[..corner].contains(&v) {
                return Some(Error::RepeatedVertex { element, vertex: v });
            }
        }
        None
    };
    // the first bad element, whatever the scheduling
    match elements.par_iter().enumerate().position_first(|(t, e)| problem(t, e).is_some()) {
        Some(t) => Err(problem(t, &elements[t]).expect("found above")),
        None => Ok(()),
    }
}

/// Converts signed 64-bit indices (`k` per element, row-major) to `u32` elements,
/// naming the first index that is negative or `>= n_vertices`.
///
/// This is how bindings hand over index arrays of any integer type without an unchecked
/// cast.
pub fn elements_from_i64<const K: usize>(flat: &[i64], n_vertices: usize) -> Result<Vec<[u32; K]>> {
    if n_vertices > MAX_VERTICES {
        return Err(Error::TooManyVertices { n_vertices, max: MAX_VERTICES });
    }
    if flat.len() % K != 0 {
        return Err(Error::Shape {
            message: format!("{} indices do not form rows of {K}", flat.len()),
        });
    }
    let out_of_range = |i: i64| i < 0 || i as u64 >= n_vertices as u64;
    if flat.par_iter().any(|&i| out_of_range(i)) {
        let k = flat.iter().position(|&i| out_of_range(i)).expect("found above");
        return Err(Error::IndexOutOfRange {
            element: k / K,
            corner: k % K,
            index: flat[k],
            n_vertices,
        });
    }
    Ok(flat.par_chunks_exact(K).map(|c| std::array::from_fn(|j| c[j] as u32)).collect())
}
