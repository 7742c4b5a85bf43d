//! Kernels of one tet: pure functions of its coordinates (a [`LocalTet`]) returning its
//! contributions to the six edges and four vertices. No indices, no threads, no allocation.
//!
//! Local edge order: `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`; [`EDGES`].
//! Sign convention (paper Eq. 1): a weight `w_ij` is the off-diagonal `L[i, j]`; positive on
//! well-shaped tets.

pub mod batch;
mod centre;
pub mod derivatives;
pub(crate) mod dual;
mod mass;
pub(crate) mod power;
pub(crate) mod primal;
mod quality;

pub use centre::{power_centres, power_centres_precise, Centres};
pub use dual::{dual, Dual};
pub use mass::barycentric_mass;
pub use power::{power_dual, power_dual_precise, Field, Placement, Real};
pub(crate) use power::{circumcentric_dual_precise_lanes, exact_tet, mapped_dual_precise};
pub(crate) use primal::{primal_precise_in, primal_precise_lanes};
pub use primal::{primal, primal_precise, primal_weights, Primal};
pub use quality::{inside_circumsphere, quality_from_frame, tet_quality, tet_quality_exact, TetQuality, DELAUNAY_RTOL};

use super::frame::LocalTet;
use glam::DVec3;

/// The six edges of a tet in local order, as pairs of corners.
pub const EDGES: [(usize, usize); 6] = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)];

/// The three corners of the face opposite corner `l`, ascending.
pub const FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// For local edge `e = (a, b)`, the other two corners `(k, l)` with `k < l`.
pub const OPPOSITE: [(usize, usize); 6] = [(2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1)];

/// Quantities of one tet shared by the kernels.
///
/// `normals[l]` is the cross product of the two edges of the face opposite corner `l`,
/// oriented so that `normals[l] / det` is the gradient of the barycentric coordinate
/// `lambda_l`; `det = 6 * signed volume`. `|normals[l]| = 2 * area(face l)`.
pub(crate) struct Frame {
    pub x: [DVec3; 4],
    pub normals: [DVec3; 4],
    pub det: f64,
}

impl Frame {
    pub fn new(t: &LocalTet) -> Self {
        let [e1, e2, e3] = t.edges;
        let normals = [(e3 - e1).cross(e2 - e1), e2.cross(e3), e3.cross(e1), e1.cross(e2)];
        Frame { x: [DVec3::ZERO, e1, e2, e3], normals, det: t.det }
    }
}

/// Whether the tet's frame determinant is zero: its corners are affinely dependent, or
/// the frame's determinant underflows (a needle many orders thinner than long; see
/// [`exactly_flat`]).
pub fn is_degenerate(t: &LocalTet) -> bool {
    t.det == 0.0
}

/// Whether the corners `x` (in R^d) are affinely dependent, decided exactly: in R^3 the
/// determinant of the edges, in R^d every 3 x 3 minor of the d x 3 edge matrix.
pub fn exactly_flat(x: [&[f64]; 4]) -> bool {
    use crate::element::rational::{exactly, Exact};
    use power::{cross, dot};
    let d = x[0].len();
    exactly(|| {
        let edge = |k: usize, c: usize| Exact::from(x[k][c]) - Exact::from(x[0][c]);
        let minor = |c: [usize; 3]| {
            let e = [1, 2, 3].map(|k| c.map(|c| edge(k, c)));
            dot(e[0], cross(e[1], e[2])).signum()
        };
        (0..d).all(|a| (a + 1..d).all(|b| (b + 1..d).all(|c| minor([a, b, c]) == 0)))
    })
}

/// The unsigned volume of the tet with corners `x` (`t` their frame), correctly rounded
/// where the frame's determinant is not a normal `f64`: exactly from the corners in R^3,
/// from the frame's diagonal scaled one factor at a time in R^d.
pub fn volume_exact(x: [&[f64]; 4], t: &LocalTet) -> f64 {
    use crate::element::rational::{exactly, Exact};
    if x[0].len() != 3 {
        let [a, b, c] = [t.edges[0].x, t.edges[1].y, t.edges[2].z].map(|r| (r * t.scale).abs());
        return a * b * c / 6.0;
    }
    exactly(|| {
        let (_, det) = exact_tet(x).expect("a tet in R^3");
        (det / Exact::from(6.0)).to_f64().abs()
    })
}

/// The smallest radius ratio (`3 r_in / R`: 1 for the regular tet, 0 for a flat one) at
/// which [`well_shaped`] holds: `1/32`. Over caps, slivers, needles, wedges and random tets
/// (with vertex weights up to `1e-2` of the squared edges) the float kernels' error
/// against exact rationals stays below `3 eps / rho^2` of the tet's largest value, `1e-12`
/// at this ratio.
pub const WELL_SHAPED: f64 = 1.0 / 32.0;

/// Whether `f64` serves the tet's kernels to [`crate::element::ACCURACY`]: its radius ratio
/// is at least [`WELL_SHAPED`] (tested through the lower bound `3 |det| / (4 max_l |n_l|
/// |c|)`, `c` the circumcentre relative to a corner, without a square root), with `det^2`
/// a normal `f64` (no product of the frame under- or overflows) and the frame's rounded
/// edges true to the tet (their `f64` determinant is trusted: a needle far longer than
/// wide can round two edges to one). The other tets are computed by the precise path
/// ([`power_dual_precise`], [`primal_precise`]).
pub fn well_shaped(t: &LocalTet) -> bool {
    well_shaped_within(t, 1.0)
}

/// [`well_shaped`] with the radius-ratio bound widened by `sqrt(slack)`, `slack >= 1`: for
/// a frame whose edges are rounded `slack` times more coarsely than a tet's own (a tet
/// mapped by a tensor, [`crate::element::metric::mapped_tet`]), so that its `f64` values
/// keep the same error bound.
pub(crate) fn well_shaped_within(t: &LocalTet, slack: f64) -> bool {
    let f = Frame::new(t);
    let [_, e1, e2, e3] = f.x;
    let rounded = e1.dot(e2.cross(e3));
    if !crate::element::exact::trusted(rounded, crate::element::exact::permanent(t.edges.map(|e| e.to_array()))) {
        return false;
    }
    let c = (e1.length_squared() * f.normals[1] + e2.length_squared() * f.normals[2] + e3.length_squared() * f.normals[3])
        / (2.0 * f.det);
    let largest = f.normals.iter().map(|n| n.length_squared()).fold(0.0, f64::max);
    // rho >= 3 |det| / (4 |n|_max |c|) >= WELL_SHAPED, squared
    let det2 = f.det * f.det;
    det2 >= f64::MIN_POSITIVE && 9.0 * det2 >= 16.0 * WELL_SHAPED * WELL_SHAPED * slack * largest * c.length_squared()
}

/// Unsigned volume of the tet (`|det[x1-x0, x2-x0, x3-x0]| / 6`), in the caller's units.
///
/// Zero exactly for a degenerate tet (affinely dependent corners); for a tet in R^3 the
/// determinant is correctly rounded, so a flat tet's volume is accurate too.
pub fn volume(t: &LocalTet) -> f64 {
    t.det.abs() / 6.0 * t.scale * t.scale * t.scale
}

#[cfg(test)]
pub(crate) mod test_tets {
    use crate::element::frame::{local_tet, LocalTet};

    pub fn tet(x: [[f64; 3]; 4]) -> LocalTet {
        local_tet([&x[0], &x[1], &x[2], &x[3]], &mut [])
    }

    pub fn regular() -> LocalTet {
        let s = 1.0 / 8f64.sqrt(); // edge length 1
        tet([[s, s, s], [s, -s, -s], [-s, s, -s], [-s, -s, s]])
    }

    pub fn corner() -> LocalTet {
        tet([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]])
    }

    /// Row 0 of the 4 x 4 Laplacian of one tet from its six weights.
    pub fn row0(w: [f64; 6]) -> [f64; 4] {
        [-(w[0] + w[1] + w[2]), w[0], w[1], w[2]]
    }

    pub fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }
}
