//! Validated, borrowed view of a simplicial mesh: the one place where input is checked.

use crate::error::{CoefficientProblem, Error, Feature, Result};
use crate::element::tet::batch::LANES;
use crate::element::{Simplex, Tet, Tri};
use rayon::prelude::*;

/// The coefficient `K` of the Laplacian of `div(K grad u)` in a heterogeneous or
/// anisotropic medium (a conductivity, a diffusivity), per element in the user's element
/// order. See [`crate::element::metric`] for the definitions.
///
/// `d` is the element's own dimension (3 for tets, 2 for triangles): tensors serve meshes
/// in their own space (tets in R^3, triangles in R^2) only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Coefficient<'a> {
    /// One positive scalar per element, `(m,)`: each element's values times it.
    Scalar(&'a [f64]),
    /// One symmetric positive definite `d x d` tensor per element, `(m, d, d)` row-major.
    Tensor(&'a [f64]),
    /// One symmetric positive definite `d x d` tensor for every element, `(d, d)`.
    Constant(&'a [f64]),
}

impl<'a> Coefficient<'a> {
    /// The values, row-major.
    pub fn values(&self) -> &'a [f64] {
        match *self {
            Coefficient::Scalar(v) | Coefficient::Tensor(v) | Coefficient::Constant(v) => v,
        }
    }
}

/// Checks a coefficient for `m` elements of kind `S` in `dim`-space: its length, tensors
/// only in the elements' own space, and every value (a scalar finite and positive; a
/// tensor finite, symmetric and positive definite: [`Simplex::tensor`]); the first problem
/// in element order, naming the element. The one check of every coefficient.
///
/// ```
/// use tetlap::{check_coefficient, Coefficient, Error, Tet};
/// assert!(check_coefficient::<Tet>(Coefficient::Scalar(&[1.0, 2.0]), 2, 3).is_ok());
/// let err = check_coefficient::<Tet>(Coefficient::Scalar(&[1.0, -2.0]), 2, 3).unwrap_err();
/// assert!(matches!(err, Error::Coefficient { element: Some(1), .. }));
/// ```
pub fn check_coefficient<S: Simplex>(coefficient: Coefficient, m: usize, dim: usize) -> Result<()> {
    let d = S::MIN_DIM;
    let (values, per, what) = match coefficient {
        Coefficient::Scalar(v) => (v, 1, format!("({m},)")),
        Coefficient::Tensor(v) => (v, d * d, format!("({m}, {d}, {d})")),
        Coefficient::Constant(v) => (v, d * d, format!("({d}, {d})")),
    };
    let expected = if matches!(coefficient, Coefficient::Constant(_)) { per } else { m * per };
    if values.len() != expected {
        let got = values.len();
        return Err(Error::Shape { what: format!("the coefficient must hold {expected} values, {what}, got {got}") });
    }
    if per > 1 && dim != d {
        return Err(Error::Shape {
            what: format!(
                "a tensor coefficient needs the {}s in their own {d}-space; this mesh is immersed in R^{dim} \
                 (give one scalar per element)",
                S::NAME
            ),
        });
    }
    let problem = |k: &[f64]| if per == 1 { scalar_problem(k[0]) } else { S::tensor(k).err() };
    let error = |element: Option<usize>, problem| Error::Coefficient { element, kind: S::NAME, density: false, problem };
    if let Coefficient::Constant(k) = coefficient {
        return problem(k).map_or(Ok(()), |p| Err(error(None, p)));
    }
    let at = |t: usize| &values[t * per..][..per];
    let first = match per {
        1 => first_element(m, |t| problem(at(t)).is_some())?,
        _ => first_tensor::<S>(values, m)?,
    };
    match first {
        None => Ok(()),
        Some(t) => Err(error(Some(t), problem(at(t)).expect("found above"))),
    }
}

/// The first of the `m` tensors `values` (`MIN_DIM` squared values each) that
/// [`Simplex::tensor`] refuses, checked [`LANES`] at a time ([`Simplex::tensors`]).
fn first_tensor<S: Simplex>(values: &[f64], m: usize) -> Result<Option<usize>> {
    let dd = S::MIN_DIM * S::MIN_DIM;
    let groups = m.div_ceil(LANES);
    let bad_group = |g: usize| {
        let mut k = [[0.0; 9]; LANES];
        for (i, k) in k.iter_mut().enumerate() {
            let t = (g * LANES + i).min(m - 1);
            k[..dd].copy_from_slice(&values[t * dd..][..dd]);
        }
        !S::tensors(&k).1.iter().all(|&ok| ok)
    };
    let group = first_element(groups, bad_group)?;
    Ok(group.and_then(|g| (g * LANES..m.min((g + 1) * LANES)).find(|&t| S::tensor(&values[t * dd..][..dd]).is_err())))
}

/// The first of `m` elements for which `bad` holds, whatever the scheduling: searched in
/// parallel by chunks, each chunk in order, on the calling pool's threads.
fn first_element(m: usize, bad: impl Fn(usize) -> bool + Sync) -> Result<Option<usize>> {
    const CHUNK: usize = 1 << 12;
    crate::threads::here(|| {
        (0..m.div_ceil(CHUNK)).into_par_iter().find_map_first(|c| (c * CHUNK..m.min((c + 1) * CHUNK)).find(|&t| bad(t)))
    })
}

/// Checks a density for `m` elements of kind `S`: `(m,)` finite positive values; the first problem in
/// element order, naming the element.
pub fn check_density<S: Simplex>(density: &[f64], m: usize) -> Result<()> {
    if density.len() != m {
        return Err(Error::Shape { what: format!("the density must hold one value per element, ({m},), got {}", density.len()) });
    }
    match crate::threads::position_first(density, |_, &x| scalar_problem(x).is_some())? {
        None => Ok(()),
        Some(t) => Err(Error::Coefficient {
            element: Some(t),
            kind: S::NAME,
            density: true,
            problem: scalar_problem(density[t]).expect("found above"),
        }),
    }
}

/// What is wrong with a scalar coefficient or density: not finite, or not positive.
fn scalar_problem(x: f64) -> Option<CoefficientProblem> {
    if !x.is_finite() {
        Some(CoefficientProblem::NonFinite { entry: None, value: x })
    } else if x <= 0.0 {
        Some(CoefficientProblem::NotPositive { value: x })
    } else {
        None
    }
}

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
    coefficient: Option<Coefficient<'a>>,
    density: Option<&'a [f64]>,
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
        Ok(MeshView { points, dim, cells, vertex_weights: None, coefficient: None, density: None })
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

    /// The same mesh with a coefficient for its Laplacians, `div(K grad u)` (see
    /// [`Coefficient`], [`crate::element::metric`]), checked by [`check_coefficient`].
    /// The masses do not depend on it.
    ///
    /// ```
    /// use tetlap::{laplacian, Coefficient, LaplacianKind, Options, TetView};
    /// let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    /// let mesh = TetView::new(&points, 3, &[[0, 1, 2, 3]])?;
    /// let k = [2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0]; // 2 I: twice the Laplacian
    /// let twice = mesh.with_coefficient(Coefficient::Constant(&k))?;
    /// let (a, b) = (laplacian(&mesh, LaplacianKind::Dual, &Options::default())?,
    ///               laplacian(&twice, LaplacianKind::Dual, &Options::default())?);
    /// assert!((b.get(0, 1) - 2.0 * a.get(0, 1)).abs() < 1e-15);
    /// # Ok::<(), tetlap::Error>(())
    /// ```
    pub fn with_coefficient(self, coefficient: Coefficient<'a>) -> Result<Self> {
        check_coefficient::<S>(coefficient, self.n_elements(), self.dim)?;
        Ok(MeshView { coefficient: Some(coefficient), ..self })
    }

    /// The same mesh with a density for its masses (one positive value per element, such
    /// as `rho c_p`): every mass kind's contributions of an element times its density.
    /// Checked by [`check_density`]; the Laplacians do not depend on it.
    pub fn with_density(self, density: &'a [f64]) -> Result<Self> {
        check_density::<S>(density, self.n_elements())?;
        Ok(MeshView { density: Some(density), ..self })
    }

    /// A view of input that was checked before (same cells, new finite coordinates),
    /// without coefficient or density.
    pub(crate) fn trusted(
        points: &'a [f64],
        dim: usize,
        cells: &'a [S::Cell],
        vertex_weights: Option<&'a [f64]>,
    ) -> Self {
        MeshView { points, dim, cells, vertex_weights, coefficient: None, density: None }
    }

    /// The coefficient of the Laplacians, if any.
    pub fn coefficient(&self) -> Option<Coefficient<'a>> {
        self.coefficient
    }

    /// The density of the masses, if any.
    pub fn density(&self) -> Option<&'a [f64]> {
        self.density
    }

    /// [`Error::CoefficientUnsupported`] if the mesh has a coefficient or a density: for
    /// the computations that do not take them (`what` names the computation).
    pub(crate) fn plain(&self, what: &'static str) -> Result<()> {
        match self.coefficient.is_some() || self.density.is_some() {
            true => Err(Error::CoefficientUnsupported { what }),
            false => Ok(()),
        }
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
