//! Duals of one tet through the barycentric coordinates of their dual vertices: the power
//! (weighted) centres of a regular triangulation, the barycentric boundary fix (paper
//! Sec. 6) and the snapped centres of the mixed mass, in `f64` or, for the elements a float
//! evaluation cannot serve, in double-double ([`Dd`]).
//!
//! # The pieces as products
//! The piece of the flag (vertex `a`, edge `ab`, face `abk`; `l` the fourth corner) is the
//! tet `(x_a, c_ab, c_abk, c)` with `c_ab` on the line `ab`, `c_abk` in the plane of `abk`
//! and `c` anywhere. In barycentric coordinates (`c_ab` at `b`: `tau`, `c_abk` at `k`:
//! `beta`, `c` at `l`: `lambda`) its signed volume is a product, without cancellation:
//!
//! ```text
//! v(a, b, k) = tau_{a->b} beta^{abk}_k lambda_l |det| / 6
//! ```
//!
//! (`det[c_ab - x_a, c_abk - x_a, c - x_a]` is `det` times that of the lower triangular
//! matrix of the three points' coordinates at `b`, `k`, `l`). The edge's weight is the dual
//! face's area over its length, `w_ab = 3 (pieces at ab) / |ab|^2 = (beta^{abk}_k mu_l +
//! beta^{abl}_l mu_k) / (2 |ab|^2)` with `mu = lambda |det|`, and the cell volume at `a`
//! is `m_a = sum_b tau_{a->b} |ab|^2 w_ab / 3`. For power centres (vertex weights `w_i`;
//! `w = 0`: circumcentres):
//!
//! * `tau_{a->b} = (|ab|^2 + w_a - w_b) / (2 |ab|^2)`;
//! * `beta^{abk}_k = |ab|^2 D_k / (2 |n_l|^2)`, `D_k = (x_a - x_k).(x_b - x_k) + w~_k - w_k`
//!   with `w~_k = w_a + t (w_b - w_a)`, `t = (x_b - x_a).(x_k - x_a) / |ab|^2`;
//! * `mu_l = sign(det) n_l . (c - x_f)`, `c = sum_k r_k n_k / (2 det)`,
//!   `r_k = |x_k - x_0|^2 + w_0 - w_k` (`x_f` a corner of face `l`).
//!
//! These are the closed forms of [`crate::element::tet::derivatives`] and, for zero
//! weights, of [`super::dual`]; the tests check them against explicit centres.
//!
//! # Accuracy
//! Every step is a product or a short sum: weights of any size (tested up to `1e6` times
//! the squared edges) lose nothing. For the shapes where `f64` cannot serve (see the
//! accuracy rule of [`crate::element`]) the same code runs in [`Dd`] from the exact edges.

use super::batch::{Lanes, LANES};
use super::{Dual, Frame, EDGES, FACES, OPPOSITE};
use crate::element::exact::{two_sum, Dd, DdLanes};
use crate::element::frame::{precise_tet, LocalTet};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic of the closed forms: `f64`, [`Dd`] for the precise path, or [`DdLanes`]
/// for several precise elements at once.
pub trait Field:
    Copy + From<f64> + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// `self` where `det` rounds to a positive `f64`, `-self` elsewhere (per lane).
    fn oriented(self, det: Self) -> Self;
}

/// A [`Field`] of single numbers, which can be rounded to `f64` (and compared).
pub trait Real: Field {
    /// The value rounded to `f64`.
    fn to_f64(self) -> f64;
}

impl Field for f64 {
    #[inline]
    fn oriented(self, det: f64) -> f64 {
        if det > 0.0 { self } else { -self }
    }
}

impl Real for f64 {
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
}

impl Field for Dd {
    #[inline]
    fn oriented(self, det: Dd) -> Dd {
        if det.to_f64() > 0.0 { self } else { -self }
    }
}

impl Real for Dd {
    #[inline]
    fn to_f64(self) -> f64 {
        Dd::to_f64(self)
    }
}

impl Field for DdLanes {
    #[inline(always)]
    fn oriented(self, det: DdLanes) -> DdLanes {
        let positive = det.to_f64().map(|d| d > 0.0);
        let (neg, hi, lo) = (-self, self.hi, self.lo);
        DdLanes {
            hi: std::array::from_fn(|i| if positive[i] { hi[i] } else { neg.hi[i] }),
            lo: std::array::from_fn(|i| if positive[i] { lo[i] } else { neg.lo[i] }),
        }
    }
}

pub(crate) type V3<R> = [R; 3];

#[inline(always)]
pub(crate) fn sub<R: Field>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub(crate) fn dot<R: Field>(a: V3<R>, b: V3<R>) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
pub(crate) fn cross<R: Field>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// Which dual vertices: the power centres as they are, or moved into their simplices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// The power centres (circumcentres for zero weights): the orthogonal dual.
    Centres,
    /// Paper Sec. 6: a face or tet centre not strictly inside its simplex becomes the
    /// simplex's centroid (edge points stay).
    Centroids,
    /// The mixed ("hybrid Voronoi") rule: a face centre outside its triangle becomes the
    /// midpoint of the edge opposite its most negative coordinate; a tet centre outside the
    /// tet becomes the (moved) centre of the face opposite its most negative coordinate.
    Snapped,
}

/// The dual vertices of one tet in barycentric coordinates.
pub(super) struct Vertices<R> {
    /// For edge `e = (a, b)`: the coordinate of its point at `b` (its distance from `a` over
    /// `|ab|`).
    pub edge: [R; 6],
    /// For the face opposite `l`: its point's coordinates at the four corners (0 at `l`).
    pub face: [[R; 4]; 4],
    /// The tet's point: its coordinates times `|det|` (`mu`; finite however far it lies).
    pub tet: [R; 4],
    /// The tet's power centre minus corner 0, in frame coordinates (before any placement).
    pub centre: V3<R>,
}

/// The face normals of a tet with corners `x` (`x[0] = 0`): `n[l]` is the cross product of
/// two edges of the face opposite corner `l`, `n[l] / det` the gradient of `lambda_l`, and
/// `|n[l]|` twice the face's area.
#[inline(always)]
pub(super) fn normals<R: Field>(x: [V3<R>; 4]) -> [V3<R>; 4] {
    [cross(sub(x[3], x[1]), sub(x[2], x[1])), cross(x[2], x[3]), cross(x[3], x[1]), cross(x[1], x[2])]
}

/// The dual vertices of a tet with corners `x` (`x[0] = 0`, scaled frame), determinant
/// `det`, vertex weights `w` relative to corner 0 (frame units), at the power centres; with
/// the squared edge lengths and `|det|`.
#[inline(always)]
pub(super) fn centres<R: Field>(x: [V3<R>; 4], det: R, w: [R; 4]) -> (Vertices<R>, [R; 6], R) {
    let zero = R::from(0.0);
    let abs_det = det.oriented(det);
    let n = normals(x);
    let len2 = EDGES.map(|(a, b)| {
        let d = sub(x[b], x[a]);
        dot(d, d)
    });
    // the tet's power centre c = sum_k r_k n_k / (2 det) and mu_l = lambda_l(c) |det|
    let r = [1, 2, 3].map(|k| dot(x[k], x[k]) + w[0] - w[k]);
    let scale = R::from(0.5) / det;
    let c: V3<R> = std::array::from_fn(|i| (r[0] * n[1][i] + r[1] * n[2][i] + r[2] * n[3][i]) * scale);
    let mut v = Vertices {
        edge: std::array::from_fn(|e| {
            let (a, b) = EDGES[e];
            (len2[e] + w[a] - w[b]) / (R::from(2.0) * len2[e])
        }),
        face: [[zero; 4]; 4],
        tet: std::array::from_fn(|l| dot(n[l], sub(c, x[FACES[l][0]])).oriented(det)),
        centre: c,
    };
    // the face centres, from the edge and the corner opposite it in each face
    for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
        let ab = sub(x[b], x[a]);
        for (p, q) in [(k, l), (l, k)] {
            // face q holds a, b and p: the coordinate of its centre at p
            let t = dot(ab, sub(x[p], x[a])) / len2[e];
            let big_d = dot(sub(x[a], x[p]), sub(x[b], x[p])) + w[a] + t * (w[b] - w[a]) - w[p];
            v.face[q][p] = len2[e] * big_d / (R::from(2.0) * dot(n[q], n[q]));
        }
    }
    (v, len2, abs_det)
}

/// Moves the dual vertices `v` of a tet with `|det| = abs_det` by `placement`.
fn place<R: Real>(v: &mut Vertices<R>, placement: Placement, abs_det: R) {
    let zero = R::from(0.0);
    let (half, quarter, third) = (R::from(0.5), R::from(0.25), R::from(1.0 / 3.0));
    let outside = |coords: &[R]| coords.iter().any(|b| b.to_f64() <= 0.0);
    let most_negative = |coords: &[R; 4], skip: usize| {
        (0..4).filter(|&i| i != skip).min_by(|&i, &j| coords[i].to_f64().total_cmp(&coords[j].to_f64())).expect("3 corners")
    };
    match placement {
        Placement::Centres => {}
        Placement::Centroids => {
            for (l, face) in v.face.iter_mut().enumerate() {
                if outside(&FACES[l].map(|p| face[p])) {
                    FACES[l].iter().for_each(|&p| face[p] = third);
                }
            }
            if outside(&v.tet) {
                v.tet = [abs_det * quarter; 4];
            }
        }
        Placement::Snapped => {
            for (l, face) in v.face.iter_mut().enumerate() {
                if FACES[l].iter().any(|&p| face[p].to_f64() < 0.0) {
                    let j = most_negative(face, l);
                    FACES[l].iter().for_each(|&p| face[p] = if p == j { zero } else { half });
                }
            }
            if v.tet.iter().any(|m| m.to_f64() < 0.0) {
                let j = most_negative(&v.tet, 4);
                v.tet = v.face[j].map(|b| b * abs_det);
            }
        }
    }
}

/// The edge weights and cell volumes of the dual with vertices `v` (squared edge lengths
/// `len2`), in frame units.
#[inline(always)]
fn pieces<R: Field>(v: &Vertices<R>, len2: [R; 6]) -> ([R; 6], [R; 4]) {
    let zero = R::from(0.0);
    let (half, sixth) = (R::from(0.5), R::from(1.0 / 6.0));
    let mut weights = [zero; 6];
    let mut cells = [zero; 4];
    for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
        // twice the dual face's area times |ab|: the pieces at ab times 6
        let area = v.face[l][k] * v.tet[l] + v.face[k][l] * v.tet[k];
        weights[e] = area * half / len2[e];
        cells[a] = cells[a] + v.edge[e] * area * sixth;
        cells[b] = cells[b] + (R::from(1.0) - v.edge[e]) * area * sixth;
    }
    (weights, cells)
}

/// The dual of a tet with corners `x` (`x[0] = 0`, scaled frame), determinant `det`,
/// vertex weights `w` relative to corner 0 (frame units), vertices placed by `placement`.
fn dual_of<R: Real>(x: [V3<R>; 4], det: R, w: [R; 4], placement: Placement) -> ([R; 6], [R; 4]) {
    let (mut v, len2, abs_det) = centres(x, det, w);
    place(&mut v, placement, abs_det);
    pieces(&v, len2)
}

/// [`power_dual_precise`] of [`LANES`] tets at once without vertex weights, at the
/// circumcentres: `corners[i]` and `det[i]` the precise frame of lane `i`
/// ([`precise_tet`]), `scale[i]` its scale. Bit for bit the one-tet function.
pub(crate) fn circumcentric_dual_precise_lanes(corners: &[[[Dd; 3]; 4]; LANES], det: [Dd; LANES], scale: Lanes) -> ([Lanes; 6], [Lanes; 4]) {
    let x: [V3<DdLanes>; 4] = std::array::from_fn(|k| std::array::from_fn(|a| DdLanes::from_fn(|i| corners[i][k][a])));
    let det = DdLanes::from_fn(|i| det[i]);
    let (v, len2, _) = centres(x, det, [DdLanes::from(0.0); 4]);
    let (w, m) = pieces(&v, len2);
    let s = scale;
    (
        w.map(|v| {
            let v = v.to_f64();
            std::array::from_fn(|i| v[i] * s[i])
        }),
        m.map(|v| {
            let v = v.to_f64();
            std::array::from_fn(|i| v[i] * s[i] * s[i] * s[i])
        }),
    )
}

/// The dual of one tet with vertex weights `weights` (the user's, at its four corners, in
/// squared length units; only their differences matter) and its dual vertices placed by
/// `placement`, in `f64` from the frame. `weights = None`: the circumcentres.
///
/// ```
/// use tetlap::element::tet::{power_dual, dual, Placement};
/// let x = [[0.1, 0.0, 0.0], [1.0, 0.2, 0.0], [0.3, 1.0, 0.1], [0.2, 0.3, 0.8]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// // zero weights: the circumcentric dual
/// let (a, b) = (power_dual(&t, Some(&[0.0; 4]), Placement::Centres), dual(&t));
/// assert!(a.weights.iter().zip(&b.weights).all(|(p, q)| (p - q).abs() < 1e-14));
/// // any weights: the cell volumes sum to the tet's volume
/// let d = power_dual(&t, Some(&[0.02, -0.01, 0.0, 0.03]), Placement::Centres);
/// let total: f64 = d.cell_volumes.iter().sum();
/// assert!((total - tetlap::element::tet::volume(&t)).abs() < 1e-15);
/// ```
pub fn power_dual(t: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> Dual {
    let f = Frame::new(t);
    let x = f.x.map(|p| p.to_array());
    let (w, m) = dual_of(x, t.det, relative(t.scale, weights), placement);
    scaled(t.scale, w, m)
}

/// [`power_dual`] in double-double from the tet's input corners `x` (in R^d, `t` their
/// frame): exact edges, determinant and weight differences, about 32 digits throughout,
/// rounded to `f64` at the end. The precise path of the accuracy rule.
pub fn power_dual_precise(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> Dual {
    let (corners, det) = precise_tet(x, t.scale);
    let (w, m) = dual_of(corners, det, relative_precise(t.scale, weights), placement);
    scaled(t.scale, w.map(|v| v.to_f64()), m.map(|v| v.to_f64()))
}

/// The corner weights relative to corner 0, in the frame's units (squared lengths).
pub(super) fn relative(scale: f64, weights: Option<&[f64; 4]>) -> [f64; 4] {
    let s2 = scale * scale;
    weights.map_or([0.0; 4], |w| w.map(|wi| (wi - w[0]) / s2))
}

/// [`relative`] in double-double: the differences exact, then scaled.
pub(super) fn relative_precise(scale: f64, weights: Option<&[f64; 4]>) -> [Dd; 4] {
    let inv2 = 1.0 / (scale * scale);
    weights.map_or([Dd::default(); 4], |w| {
        w.map(|wi| {
            let (hi, lo) = two_sum(wi, -w[0]);
            Dd { hi: hi * inv2, lo: lo * inv2 }
        })
    })
}

/// Frame values back in the caller's units (step by step: `s^3` alone could overflow).
fn scaled(s: f64, w: [f64; 6], m: [f64; 4]) -> Dual {
    Dual { weights: w.map(|v| v * s), cell_volumes: m.map(|v| v * s * s * s) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;
    use crate::element::tet::{dual, volume};
    use glam::DVec3;

    fn tets() -> Vec<LocalTet> {
        vec![
            regular(),
            corner(),
            tet([[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]]),
            tet([[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0.3, 0.2, -0.7]]),
        ]
    }

    /// An independent route: explicit power centres (Cramer's rule) and the signed piece
    /// determinants of SPEC §2, `w_ab = 3 (pieces at ab) / |ab|^2`; `w` the user's weights.
    fn explicit(t: &LocalTet, w: [f64; 4], centroids: bool) -> Dual {
        let x = [DVec3::ZERO, t.edges[0], t.edges[1], t.edges[2]];
        let w = relative(t.scale, Some(&w));
        let centre = |p: &[usize]| {
            let o = x[p[0]];
            let rhs = |k: usize| ((x[p[k]] - o).length_squared() + w[p[0]] - w[p[k]]) / 2.0;
            let e: Vec<DVec3> = p[1..].iter().map(|&q| x[q] - o).collect();
            match e.len() {
                1 => o + e[0] * (rhs(1) / e[0].length_squared()),
                2 => {
                    let n = e[0].cross(e[1]);
                    o + (rhs(1) * e[1].cross(n) + rhs(2) * n.cross(e[0])) / n.length_squared()
                }
                _ => o + (rhs(1) * e[1].cross(e[2]) + rhs(2) * e[2].cross(e[0]) + rhs(3) * e[0].cross(e[1])) / e[0].dot(e[1].cross(e[2])),
            }
        };
        let mut faces = FACES.map(|f| centre(&f));
        let mut middle = centre(&[0, 1, 2, 3]);
        if centroids {
            let inside = |p: &[DVec3], c: DVec3| {
                let n = (p[1] - p[0]).cross(p[2] - p[0]);
                (0..3).all(|i| (p[(i + 1) % 3] - p[i]).cross(c - p[i]).dot(n) > 0.0)
            };
            for (l, f) in FACES.iter().enumerate() {
                let p = f.map(|k| x[k]);
                if !inside(&p, faces[l]) {
                    faces[l] = (p[0] + p[1] + p[2]) / 3.0;
                }
            }
            let d = |a: DVec3, b: DVec3, c: DVec3, e: DVec3| (b - a).dot((c - a).cross(e - a));
            let total = d(x[0], x[1], x[2], x[3]);
            let sub = [d(middle, x[1], x[2], x[3]), d(x[0], middle, x[2], x[3]), d(x[0], x[1], middle, x[3]), d(x[0], x[1], x[2], middle)];
            if !sub.iter().all(|&s| s * total > 0.0) {
                middle = (x[0] + x[1] + x[2] + x[3]) / 4.0;
            }
        }
        let sign = |p: usize, q: usize, r: usize, u: usize| (x[q] - x[p]).dot((x[r] - x[p]).cross(x[u] - x[p])).signum();
        let piece = |a: usize, b: usize, face: usize| {
            let edge = centre(&[a.min(b), a.max(b)]);
            (edge - x[a]).dot((faces[face] - x[a]).cross(middle - x[a])) / 6.0
        };
        let mut weights = [0.0; 6];
        let mut cells = [0.0; 4];
        for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
            let v_abk = piece(a, b, l) * sign(a, b, k, l);
            let v_bak = piece(b, a, l) * sign(b, a, k, l);
            let v_abl = piece(a, b, k) * sign(a, b, l, k);
            let v_bal = piece(b, a, k) * sign(b, a, l, k);
            weights[e] = 3.0 * (v_abk + v_bak + v_abl + v_bal) / (x[a] - x[b]).length_squared();
            cells[a] += v_abk + v_abl;
            cells[b] += v_bak + v_bal;
        }
        scaled(t.scale, weights, cells)
    }

    fn scale(v: &[f64]) -> f64 {
        v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
    }

    #[test]
    fn the_products_equal_explicit_centres() {
        for t in tets() {
            for w in [[0.0; 4], [0.1, -0.2, 0.05, 0.3], [0.0, 0.0, 0.4, 0.0]] {
                for (placement, centroids) in [(Placement::Centres, false), (Placement::Centroids, true)] {
                    let (a, b) = (power_dual(&t, Some(&w), placement), explicit(&t, w, centroids));
                    assert!(close(&a.weights, &b.weights, 1e-13 * scale(&b.weights)), "{a:?} {b:?}");
                    assert!(close(&a.cell_volumes, &b.cell_volumes, 1e-13 * scale(&b.cell_volumes)), "{a:?} {b:?}");
                }
            }
        }
    }

    #[test]
    fn zero_weights_reproduce_the_circumcentric_dual() {
        for t in tets() {
            let (general, fast) = (power_dual(&t, None, Placement::Centres), dual(&t));
            assert!(close(&general.weights, &fast.weights, 1e-14 * scale(&fast.weights)), "{general:?} {fast:?}");
            assert!(close(&general.cell_volumes, &fast.cell_volumes, 1e-14 * scale(&fast.cell_volumes)));
        }
    }

    #[test]
    fn pieces_sum_to_the_volume_for_any_placement() {
        for t in tets() {
            for w in [[0.1, -0.2, 0.05, 0.3], [0.0, 0.0, 0.4, 0.0]] {
                for placement in [Placement::Centres, Placement::Centroids, Placement::Snapped] {
                    let d = power_dual(&t, Some(&w), placement);
                    let total: f64 = d.cell_volumes.iter().sum();
                    assert!((total - volume(&t)).abs() < 1e-14, "{placement:?}: {total} vs {}", volume(&t));
                }
            }
        }
    }

    #[test]
    fn centroids_and_snapped_centres_make_the_masses_positive() {
        for t in tets() {
            let d = power_dual(&t, None, Placement::Centroids);
            assert!(d.cell_volumes.iter().all(|&v| v > 0.0), "{d:?}");
            assert!(d.weights.iter().all(|&w| w >= 0.0), "{d:?}");
            let d = power_dual(&t, None, Placement::Snapped);
            assert!(d.cell_volumes.iter().all(|&v| v > 0.0), "{d:?}");
        }
    }

    #[test]
    fn the_precise_path_agrees_with_the_float_one() {
        let x: [[f64; 3]; 4] = [[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]];
        let t = tet(x);
        for placement in [Placement::Centres, Placement::Centroids, Placement::Snapped] {
            let w = [0.01, 0.0, -0.02, 0.005];
            let corners = [&x[0][..], &x[1][..], &x[2][..], &x[3][..]];
            let (a, b) = (power_dual(&t, Some(&w), placement), power_dual_precise(corners, &t, Some(&w), placement));
            assert!(close(&a.weights, &b.weights, 1e-14 * scale(&b.weights)), "{a:?} {b:?}");
            assert!(close(&a.cell_volumes, &b.cell_volumes, 1e-14 * scale(&b.cell_volumes)), "{a:?} {b:?}");
        }
    }
}
