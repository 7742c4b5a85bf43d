//! The kinds of element: what the drivers need to know about tetrahedra and triangles.
//!
//! Every driver of the crate (validation, the per-element pass, the row layout, the
//! assembly, the cached mesh) is written once, generic over [`Simplex`]; the two
//! implementations below only say how many corners and which edges an element has and
//! which kernels of [`super::tet`] and [`super::tri`] compute its contributions.

use super::evaluate::{tets_at_once, tets_precise_at_once, Outputs, Request, Scales};
use super::frame::{local_tet, local_tri, LocalTet, LocalTri};
use super::tet::batch::LANES;
use super::tet::Placement;
use super::{tet, tri};
use super::metric::{mapped_tet, mapped_tri, Factored, Tensor};
use crate::error::CoefficientProblem;
use crate::options::LaplacianKind;
use std::fmt::Debug;

/// Fixed-size per-element values (`[f64; K]`): edge weights or corner masses.
pub trait Values:
    Copy + Default + Debug + PartialEq + Send + Sync + AsRef<[f64]> + AsMut<[f64]> + 'static
{
}

impl<const K: usize> Values for [f64; K] where [f64; K]: Default {}

/// A kind of simplex with its local kernels.
///
/// Local edge order: the pairs of corners in lexicographic order, [`Simplex::EDGES`].
pub trait Simplex: Copy + Debug + Default + Send + Sync + 'static {
    /// Corners per element: 4 for tets, 3 for triangles.
    const CORNERS: usize;
    /// The local edges as pairs of corners, lexicographic.
    const EDGES: &'static [(usize, usize)];
    /// The smallest ambient dimension (3 for tets, 2 for triangles).
    const MIN_DIM: usize;
    /// A name for messages ("tet", "triangle").
    const NAME: &'static str;
    /// The consistent P1 mass is `measure / FEM.0` off the diagonal, `measure / FEM.1` on it.
    const FEM: (f64, f64);
    /// Whether the dual takes vertex weights and the barycentric boundary treatment.
    const WEIGHTED_DUAL: bool;

    /// The vertex indices of one element, `[u32; CORNERS]`.
    type Cell: Copy + Default + Debug + PartialEq + Send + Sync + AsRef<[u32]> + AsMut<[u32]>;
    /// One value per local edge, `[f64; EDGES.len()]`.
    type EdgeValues: Values;
    /// One value per corner, `[f64; CORNERS]`.
    type CornerValues: Values;
    /// One element as its kernels see it (a scaled local frame).
    type Local: Copy + Send + Sync;

    /// The element `cell` of `points` (row-major, `dim` columns) in its local frame;
    /// `scratch` holds [`Simplex::scratch_len`] values.
    fn local(points: &[f64], dim: usize, cell: &Self::Cell, scratch: &mut [f64]) -> Self::Local;
    /// Scratch length for [`Simplex::local`] in `dim` dimensions.
    fn scratch_len(dim: usize) -> usize;
    /// Whether the corners may be affinely dependent: the frame's determinant is zero
    /// ([`Simplex::exactly_degenerate`] decides).
    fn is_degenerate(l: &Self::Local) -> bool;
    /// Whether the corners (of an element whose frame [`Simplex::is_degenerate`]) are
    /// affinely dependent, decided exactly (a frame's determinant can underflow); the
    /// frame's word by default.
    fn exactly_degenerate(corners: &[&[f64]]) -> bool {
        let _ = corners;
        true
    }
    /// Unsigned volume (area) in the caller's units, from the frame.
    fn measure(l: &Self::Local) -> f64;
    /// Whether [`Simplex::measure`] is correctly rounded (the frame's determinant is a
    /// normal `f64`); by default it is.
    fn measure_trusted(l: &Self::Local) -> bool {
        let _ = l;
        true
    }
    /// The measure from the element's input corners, correctly rounded whatever the frame.
    fn measure_exact(corners: &[&[f64]], l: &Self::Local) -> f64 {
        let _ = corners;
        Self::measure(l)
    }
    /// Whether the corners' diagonal entries of the Laplacian `kind` are the element's own
    /// (the tet primal's `-Vol |grad lambda_a|^2`), not minus the sums of its edge values
    /// at each corner ([`corner_sums`]), which a scatter can form as it adds them up.
    fn own_diagonal(kind: LaplacianKind) -> bool {
        let _ = kind;
        false
    }
    /// Primal (P1 FEM / cotan) edge weights and the corners' diagonal entries.
    fn primal(l: &Self::Local) -> (Self::EdgeValues, Self::CornerValues);
    /// [`Simplex::primal`] by the precise path of the accuracy rule from the element's
    /// input corners, or `None` when this kind has none.
    fn primal_precise(corners: &[&[f64]], l: &Self::Local) -> Option<(Self::EdgeValues, Self::CornerValues)>;
    /// Whether `f64` serves the element's kernels to the documented accuracy (else the
    /// precise path of the accuracy rule, [`crate::element`]).
    fn well_shaped(l: &Self::Local) -> bool;
    /// Dual edge weights and dual-cell volumes (circumcentric corner masses) in `f64`, with
    /// the corners' vertex weights and dual vertices placed by `placement` (weights and
    /// [`Placement::Centroids`] only when [`Simplex::WEIGHTED_DUAL`]).
    fn dual(l: &Self::Local, weights: Option<&Self::CornerValues>, placement: Placement) -> (Self::EdgeValues, Self::CornerValues);
    /// [`Simplex::dual`] in extended precision from the element's input corners (the
    /// precise path of the accuracy rule), or `None` when this kind has none.
    fn dual_precise(
        corners: &[&[f64]],
        l: &Self::Local,
        weights: Option<&Self::CornerValues>,
        placement: Placement,
    ) -> Option<(Self::EdgeValues, Self::CornerValues)>;
    /// A symmetric positive definite tensor of this kind's own space (`MIN_DIM` squared
    /// values), factored for the kernels ([`crate::element::metric::Tensor`]).
    type Tensor: Factored + Debug + PartialEq + Send + Sync;
    /// Checks and factors the tensor `k` (row-major): the one check of every tensor.
    fn tensor(k: &[f64]) -> Result<Self::Tensor, CoefficientProblem>;
    /// [`Simplex::tensor`] of a tensor it accepts, without the checks.
    fn tensor_unchecked(k: &[f64]) -> Self::Tensor;
    /// [`Simplex::tensor_unchecked`] of [`LANES`] tensors at once (`k[lane]`, the first
    /// `MIN_DIM` squared values), bit for bit, and whether each passes
    /// [`Simplex::tensor`]'s checks.
    fn tensors(k: &[[f64; 9]; LANES]) -> ([Self::Tensor; LANES], [bool; LANES]);
    /// The element with corners `corners` (in `MIN_DIM`-space) and frame `l` mapped by the
    /// factor of `k` ([`crate::element::metric`]): the frame its Laplacian kernels see (its
    /// length unit as its scale) and the slack of its shape test
    /// ([`Simplex::well_shaped_within`]).
    fn mapped(corners: &[&[f64]], l: &Self::Local, k: &Self::Tensor) -> (Self::Local, f64);
    /// [`Simplex::well_shaped`] of a frame whose edges are rounded `slack` times more
    /// coarsely than an element's own (a mapped element).
    fn well_shaped_within(l: &Self::Local, slack: f64) -> bool {
        let _ = slack;
        Self::well_shaped(l)
    }
    /// [`Simplex::primal_precise`] of the element (corners, frame `l`) mapped by `k` into
    /// the frame `mapped`, or `None` when this kind has no precise path.
    fn primal_mapped_precise(
        corners: &[&[f64]],
        l: &Self::Local,
        mapped: &Self::Local,
        k: &Self::Tensor,
    ) -> Option<(Self::EdgeValues, Self::CornerValues)> {
        let _ = (corners, l, mapped, k);
        None
    }
    /// The dual weights of the element mapped by `k` by the precise path (vertex weights in
    /// the mapped frame's squared lengths), or `None` when this kind has none.
    fn dual_mapped_precise(
        corners: &[&[f64]],
        l: &Self::Local,
        mapped: &Self::Local,
        k: &Self::Tensor,
        weights: Option<&Self::CornerValues>,
        placement: Placement,
    ) -> Option<Self::EdgeValues> {
        let _ = (corners, l, mapped, k, weights, placement);
        None
    }
    /// `request` (one that is [`Request::batched`]) on up to [`LANES`] elements `cells` of
    /// `points` (`dim` columns, no vertex weights, no boundary fix; `scales` their scalar
    /// coefficients or tensors, and densities) at once, by vectorised `f64`
    /// kernels: which of them it computed (into `w[k]`, the Laplacian's diagonal entries
    /// into `d[k]`, `m[k]`), bit for bit as the one-element path would; the others take
    /// that path. None of them by default.
    fn at_once(points: &[f64], dim: usize, cells: &[Self::Cell], request: Request, scales: &Scales<Self::Tensor>, out: Out<'_, Self>) -> [bool; LANES] {
        let _ = (points, dim, cells, request, scales, out);
        [false; LANES]
    }
    /// [`Simplex::at_once`] for the elements of the precise path of the accuracy rule,
    /// computed together in extended precision; none of them by default.
    fn precise_at_once(
        points: &[f64],
        dim: usize,
        cells: &[Self::Cell],
        request: Request,
        scales: &Scales<Self::Tensor>,
        out: Out<'_, Self>,
    ) -> [bool; LANES] {
        let _ = (points, dim, cells, request, scales, out);
        [false; LANES]
    }
}

/// The outputs of a batch of elements of `S` (one slot per lane): edge values, the
/// Laplacian's diagonal entries, corner masses.
pub type Out<'o, S> = (&'o mut [<S as Simplex>::EdgeValues], &'o mut [<S as Simplex>::CornerValues], &'o mut [<S as Simplex>::CornerValues]);

/// Minus the sums of an element's edge values `w` at each corner (edges in local order):
/// the diagonal entries of a Laplacian defined by its off-diagonals (the dual's).
pub fn corner_sums<S: Simplex>(w: &S::EdgeValues) -> S::CornerValues {
    let mut d = S::CornerValues::default();
    for (&(a, b), &x) in S::EDGES.iter().zip(w.as_ref()) {
        d.as_mut()[a] -= x;
        d.as_mut()[b] -= x;
    }
    d
}

/// Tetrahedra (in R^3 or immersed in R^d, d > 3).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tet;

/// Triangles (in R^2 or immersed in R^d, d > 2), where primal and dual coincide.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tri;

/// The coordinates of the corners of `cell`.
fn corners<'p, const K: usize>(points: &'p [f64], dim: usize, cell: &[u32; K]) -> [&'p [f64]; K] {
    cell.map(|v| {
        let i = v as usize * dim;
        &points[i..i + dim]
    })
}

impl Simplex for Tet {
    const CORNERS: usize = 4;
    const EDGES: &'static [(usize, usize)] = &tet::EDGES;
    const MIN_DIM: usize = 3;
    const NAME: &'static str = "tet";
    const FEM: (f64, f64) = (20.0, 10.0);
    const WEIGHTED_DUAL: bool = true;

    type Cell = [u32; 4];
    type EdgeValues = [f64; 6];
    type CornerValues = [f64; 4];
    type Local = LocalTet;
    type Tensor = Tensor<3>;

    fn tensor(k: &[f64]) -> Result<Tensor<3>, CoefficientProblem> {
        Tensor::new(k)
    }

    fn tensor_unchecked(k: &[f64]) -> Tensor<3> {
        Tensor::factor(k)
    }

    fn tensors(k: &[[f64; 9]; LANES]) -> ([Tensor<3>; LANES], [bool; LANES]) {
        Tensor::factor_lanes(k)
    }

    fn mapped(corners: &[&[f64]], l: &LocalTet, k: &Tensor<3>) -> (LocalTet, f64) {
        mapped_tet([corners[0], corners[1], corners[2], corners[3]], l, k)
    }

    fn well_shaped_within(l: &LocalTet, slack: f64) -> bool {
        tet::well_shaped_within(l, slack)
    }

    fn primal_mapped_precise(corners: &[&[f64]], l: &LocalTet, mapped: &LocalTet, k: &Tensor<3>) -> Option<([f64; 6], [f64; 4])> {
        let p = tet::primal_precise_in([corners[0], corners[1], corners[2], corners[3]], l, Some((mapped, k)));
        Some((p.weights, p.diagonal))
    }

    fn dual_mapped_precise(
        corners: &[&[f64]],
        l: &LocalTet,
        mapped: &LocalTet,
        k: &Tensor<3>,
        weights: Option<&[f64; 4]>,
        placement: Placement,
    ) -> Option<[f64; 6]> {
        let x = [corners[0], corners[1], corners[2], corners[3]];
        Some(tet::mapped_dual_precise(x, l, mapped, k, weights, placement))
    }

    fn local(points: &[f64], dim: usize, cell: &[u32; 4], scratch: &mut [f64]) -> LocalTet {
        local_tet(corners(points, dim, cell), scratch)
    }

    fn scratch_len(dim: usize) -> usize {
        if dim > 3 { 3 * dim } else { 0 }
    }

    fn is_degenerate(l: &LocalTet) -> bool {
        tet::is_degenerate(l)
    }

    fn exactly_degenerate(corners: &[&[f64]]) -> bool {
        tet::exactly_flat([corners[0], corners[1], corners[2], corners[3]])
    }

    fn own_diagonal(kind: LaplacianKind) -> bool {
        kind != LaplacianKind::Dual
    }

    fn measure(l: &LocalTet) -> f64 {
        tet::volume(l)
    }

    fn measure_trusted(l: &LocalTet) -> bool {
        l.det.abs() >= f64::MIN_POSITIVE
    }

    fn measure_exact(corners: &[&[f64]], l: &LocalTet) -> f64 {
        tet::volume_exact([corners[0], corners[1], corners[2], corners[3]], l)
    }

    fn primal(l: &LocalTet) -> ([f64; 6], [f64; 4]) {
        let p = tet::primal(l);
        (p.weights, p.diagonal)
    }

    fn primal_precise(corners: &[&[f64]], l: &LocalTet) -> Option<([f64; 6], [f64; 4])> {
        let p = tet::primal_precise([corners[0], corners[1], corners[2], corners[3]], l);
        Some((p.weights, p.diagonal))
    }

    fn well_shaped(l: &LocalTet) -> bool {
        tet::well_shaped(l)
    }

    fn dual(l: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> ([f64; 6], [f64; 4]) {
        // weights defined up to a constant: equal weights are none (bitwise)
        let weights = weights.filter(|w| w.iter().any(|&x| x != w[0]));
        let d = match (weights, placement) {
            (None, Placement::Centres) => tet::dual(l),
            _ => tet::power_dual(l, weights, placement),
        };
        (d.weights, d.cell_volumes)
    }

    fn at_once(
        points: &[f64],
        dim: usize,
        cells: &[[u32; 4]],
        request: Request,
        scales: &Scales<Tensor<3>>,
        (w, d, m): Out<'_, Self>,
    ) -> [bool; LANES] {
        if dim != 3 {
            return [false; LANES];
        }
        tets_at_once(points, cells, request, scales, Outputs { w, d, m })
    }

    fn precise_at_once(
        points: &[f64],
        dim: usize,
        cells: &[[u32; 4]],
        request: Request,
        scales: &Scales<Tensor<3>>,
        (w, d, m): Out<'_, Self>,
    ) -> [bool; LANES] {
        if dim != 3 {
            return [false; LANES];
        }
        tets_precise_at_once(points, cells, request, scales, Outputs { w, d, m })
    }

    fn dual_precise(corners: &[&[f64]], l: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> Option<([f64; 6], [f64; 4])> {
        let corners = [corners[0], corners[1], corners[2], corners[3]];
        let d = tet::power_dual_precise(corners, l, weights, placement);
        Some((d.weights, d.cell_volumes))
    }
}

impl Simplex for Tri {
    const CORNERS: usize = 3;
    const EDGES: &'static [(usize, usize)] = &tri::EDGES;
    const MIN_DIM: usize = 2;
    const NAME: &'static str = "triangle";
    const FEM: (f64, f64) = (12.0, 6.0);
    const WEIGHTED_DUAL: bool = false;

    type Cell = [u32; 3];
    type EdgeValues = [f64; 3];
    type CornerValues = [f64; 3];
    type Local = LocalTri;
    type Tensor = Tensor<2>;

    fn tensor(k: &[f64]) -> Result<Tensor<2>, CoefficientProblem> {
        Tensor::new(k)
    }

    fn tensor_unchecked(k: &[f64]) -> Tensor<2> {
        Tensor::factor(k)
    }

    fn tensors(k: &[[f64; 9]; LANES]) -> ([Tensor<2>; LANES], [bool; LANES]) {
        Tensor::factor_lanes(k)
    }

    fn mapped(corners: &[&[f64]], l: &LocalTri, k: &Tensor<2>) -> (LocalTri, f64) {
        (mapped_tri([corners[0], corners[1], corners[2]], l, k), 1.0)
    }

    fn local(points: &[f64], dim: usize, cell: &[u32; 3], _: &mut [f64]) -> LocalTri {
        local_tri(corners(points, dim, cell))
    }

    fn scratch_len(_: usize) -> usize {
        0
    }

    fn is_degenerate(l: &LocalTri) -> bool {
        tri::is_degenerate(l)
    }

    fn measure(l: &LocalTri) -> f64 {
        tri::area(l)
    }

    fn primal(l: &LocalTri) -> ([f64; 3], [f64; 3]) {
        let w = tri::cotan_weights(l);
        (w, corner_sums::<Tri>(&w))
    }

    fn primal_precise(_: &[&[f64]], _: &LocalTri) -> Option<([f64; 3], [f64; 3])> {
        None
    }

    fn well_shaped(_: &LocalTri) -> bool {
        // with its determinant rounded correctly a triangle's kernels need no precise path
        true
    }

    fn dual(l: &LocalTri, _: Option<&[f64; 3]>, placement: Placement) -> ([f64; 3], [f64; 3]) {
        let (w, m) = tri::dual(l);
        match placement {
            Placement::Snapped => (w, tri::mixed_area(l)),
            _ => (w, m),
        }
    }

    fn dual_precise(_: &[&[f64]], _: &LocalTri, _: Option<&[f64; 3]>, _: Placement) -> Option<([f64; 3], [f64; 3])> {
        None
    }
}

/// Local edge index of corners `(a, b)`, `a != b`, of a simplex with `k` corners: edges in
/// lexicographic order.
#[inline]
pub(crate) const fn edge_index(k: usize, a: usize, b: usize) -> usize {
    let (a, b) = if a < b { (a, b) } else { (b, a) };
    a * (2 * k - a - 1) / 2 + (b - a - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn edges_are_lexicographic<S: Simplex>() {
        let mut expected = vec![];
        for a in 0..S::CORNERS {
            for b in a + 1..S::CORNERS {
                expected.push((a, b));
            }
        }
        assert_eq!(S::EDGES, &expected[..]);
        for (e, &(a, b)) in S::EDGES.iter().enumerate() {
            assert_eq!(edge_index(S::CORNERS, a, b), e);
            assert_eq!(edge_index(S::CORNERS, b, a), e);
        }
        assert_eq!(S::EdgeValues::default().as_ref().len(), S::EDGES.len());
        assert_eq!(S::CornerValues::default().as_ref().len(), S::CORNERS);
        assert_eq!(S::Cell::default().as_ref().len(), S::CORNERS);
    }

    #[test]
    fn local_edge_orders() {
        edges_are_lexicographic::<Tet>();
        edges_are_lexicographic::<Tri>();
    }
}
