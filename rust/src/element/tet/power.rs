//! Duals of one tet through the barycentric coordinates of their dual vertices: the power
//! (weighted) centres of a regular triangulation, the barycentric boundary fix (paper
//! Sec. 6) and the snapped centres of the mixed mass, in `f64` or, for the elements a float
//! evaluation cannot serve, in double-double with error bounds ([`Bd`]) or exactly
//! ([`Exact`]).
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
//! accuracy rule of [`crate::element`]) the same code runs in double-double from the exact
//! edges, with a bound on its error ([`Bd`]); where that bound exceeds the documented
//! accuracy, in exact rational arithmetic ([`Exact`]) from the input coordinates.

use super::batch::{Lanes, LANES};
use super::{Dual, Frame, EDGES, FACES, OPPOSITE};
use crate::element::bounded::{certified, largest, Bd, BdLanes};
use crate::element::exact::two_sum;
use crate::element::frame::{precise_tet, LocalTet};
use crate::element::metric::{exact_mapped_tet, precise_mapped_tet, Tensor};
use crate::element::rational::{exactly, Exact};
use std::cmp::Ordering;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic of the closed forms: `f64`, [`Bd`] for the precise path, [`BdLanes`] for
/// several precise elements at once, or [`Exact`].
pub trait Field:
    Copy + From<f64> + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + Neg<Output = Self>
{
    /// `self` where `det` rounds to a positive `f64`, `-self` elsewhere (per lane).
    fn oriented(self, det: Self) -> Self;
}

/// A [`Field`] of single numbers, which can be rounded to `f64` and compared.
pub trait Real: Field {
    /// The value rounded to `f64`.
    fn to_f64(self) -> f64;
    /// Whether the sign of the value is certainly that of the exact value it stands for
    /// (always, but for a [`Bd`] within its error bound of zero).
    fn sign_certain(self) -> bool {
        true
    }
    /// The value marked as not to be certified (a [`Bd`]'s bound made infinite).
    fn doubtful(self) -> Self {
        self
    }
    /// The order of two values (by their `f64` roundings; exactly for [`Exact`]).
    fn compare(self, other: Self) -> Ordering {
        self.to_f64().total_cmp(&other.to_f64())
    }
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

impl Field for Bd {
    #[inline]
    fn oriented(self, det: Bd) -> Bd {
        let s = if det.to_f64() > 0.0 { self } else { -self };
        if det.sign_certain() { s } else { s.doubtful() }
    }
}

impl Real for Bd {
    #[inline]
    fn to_f64(self) -> f64 {
        Bd::to_f64(self)
    }

    fn sign_certain(self) -> bool {
        self.e == 0.0 || Bd::sign_certain(self)
    }

    fn doubtful(self) -> Self {
        Bd::doubtful(self)
    }
}

impl Field for BdLanes {
    #[inline(always)]
    fn oriented(self, det: BdLanes) -> BdLanes {
        let positive = det.v.to_f64().map(|d| d > 0.0);
        let neg = -self;
        BdLanes::from_fn(|i| {
            let s = if positive[i] { self.get(i) } else { neg.get(i) };
            if det.get(i).sign_certain() { s } else { s.doubtful() }
        })
    }
}

impl Field for Exact {
    fn oriented(self, det: Exact) -> Exact {
        if det.signum() > 0 { self } else { -self }
    }
}

impl Real for Exact {
    fn to_f64(self) -> f64 {
        Exact::to_f64(self)
    }

    fn compare(self, other: Self) -> Ordering {
        (self - other).signum().cmp(&0)
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

/// The decisions of [`place`], remembering whether any of them rests on a sign the
/// arithmetic cannot vouch for.
#[derive(Default)]
struct Decisions {
    doubt: bool,
}

impl Decisions {
    /// `x <= 0`.
    fn non_positive<R: Real>(&mut self, x: R) -> bool {
        self.doubt |= !x.sign_certain();
        x.to_f64() <= 0.0
    }

    /// `x < 0`.
    fn negative<R: Real>(&mut self, x: R) -> bool {
        self.doubt |= !x.sign_certain();
        x.to_f64() < 0.0
    }

    /// The corner (not `skip`) of the most negative of `coords`.
    fn most_negative<R: Real>(&mut self, coords: &[R; 4], skip: usize) -> usize {
        let others = || (0..4).filter(|&i| i != skip);
        let j = others().min_by(|&i, &j| coords[i].compare(coords[j])).expect("3 corners");
        self.doubt |= others().any(|i| i != j && !(coords[i] - coords[j]).sign_certain());
        j
    }
}

/// Moves the dual vertices `v` of a tet with `|det| = abs_det` by `placement` (made
/// [`doubtful`](Real::doubtful) when a decision rests on an uncertain sign).
fn place<R: Real>(v: &mut Vertices<R>, placement: Placement, abs_det: R) {
    let zero = R::from(0.0);
    let (half, quarter, third) = (R::from(0.5), R::from(0.25), R::from(1.0 / 3.0));
    let mut decide = Decisions::default();
    match placement {
        Placement::Centres => {}
        Placement::Centroids => {
            for (l, face) in v.face.iter_mut().enumerate() {
                if FACES[l].iter().fold(false, |out, &p| decide.non_positive(face[p]) | out) {
                    FACES[l].iter().for_each(|&p| face[p] = third);
                }
            }
            if v.tet.iter().fold(false, |out, &m| decide.non_positive(m) | out) {
                v.tet = [abs_det * quarter; 4];
            }
        }
        Placement::Snapped => {
            for (l, face) in v.face.iter_mut().enumerate() {
                if FACES[l].iter().fold(false, |out, &p| decide.negative(face[p]) | out) {
                    let j = decide.most_negative(face, l);
                    FACES[l].iter().for_each(|&p| face[p] = if p == j { zero } else { half });
                }
            }
            if v.tet.iter().fold(false, |out, &m| decide.negative(m) | out) {
                let j = decide.most_negative(&v.tet, 4);
                v.tet = v.face[j].map(|b| b * abs_det);
            }
        }
    }
    if decide.doubt {
        v.edge = v.edge.map(R::doubtful);
        v.face = v.face.map(|f| f.map(R::doubtful));
        v.tet = v.tet.map(R::doubtful);
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
pub(crate) fn dual_of<R: Real>(x: [V3<R>; 4], det: R, w: [R; 4], placement: Placement) -> ([R; 6], [R; 4]) {
    let (mut v, len2, abs_det) = centres(x, det, w);
    place(&mut v, placement, abs_det);
    pieces(&v, len2)
}

/// [`power_dual_precise`] of [`LANES`] tets at once without vertex weights, at the
/// circumcentres, in [`BdLanes`]: `corners[i]` and `det[i]` the precise frame of lane `i`
/// ([`precise_tet`]), `scale[i]` its scale. The values of the lanes whose values the
/// bounds certify (flagged `true`), bit for bit the one-tet function's; the others take
/// exact arithmetic one by one.
pub(crate) fn circumcentric_dual_precise_lanes(
    corners: &[[[Bd; 3]; 4]; LANES],
    det: [Bd; LANES],
    scale: Lanes,
) -> ([Lanes; 6], [Lanes; 4], [bool; LANES]) {
    let x: [V3<BdLanes>; 4] = std::array::from_fn(|k| std::array::from_fn(|a| BdLanes::from_fn(|i| corners[i][k][a])));
    let det = BdLanes::from_fn(|i| det[i]);
    let (v, len2, _) = centres(x, det, [BdLanes::from(0.0); 4]);
    let (w, m) = pieces(&v, len2);
    let (mut weights, mut cells, mut ok) = ([[0.0; LANES]; 6], [[0.0; LANES]; 4], [false; LANES]);
    for i in 0..LANES {
        if let Some(d) = certify_dual(w.map(|v| v.get(i)), m.map(|v| v.get(i)), scale[i]) {
            (0..6).for_each(|e| weights[e][i] = d.weights[e]);
            (0..4).for_each(|c| cells[c][i] = d.cell_volumes[c]);
            ok[i] = true;
        }
    }
    (weights, cells, ok)
}

/// A dual in the frame's units (scale `s`) in the caller's, if the bounds certify its
/// weights against the largest weight and its cell volumes against the largest cell.
fn certify_dual(w: [Bd; 6], m: [Bd; 4], s: f64) -> Option<Dual> {
    let (wmax, mmax) = (largest(&w), largest(&m));
    Some(scaled(s, certified(w, |_| wmax)?, certified(m, |_| mmax)?))
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

/// [`power_dual`] by the precise path of the accuracy rule, from the tet's input corners
/// `x` (in R^d, `t` their frame): in double-double from the exact edges, determinant and
/// weight differences, with a bound on every value's error ([`Bd`]); when the bounds do
/// not certify the documented accuracy, in exact rational arithmetic from the input
/// coordinates (tets in R^3), rounded at the end. Values beyond the `f64` range are
/// infinite (or lose their digits below it); NaN for an immersed tet (d > 3) that
/// double-double cannot serve.
pub fn power_dual_precise(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> Dual {
    power_dual_certified(x, t, weights, placement)
        .or_else(|| power_dual_exact(x, weights, placement))
        .unwrap_or(Dual { weights: [f64::NAN; 6], cell_volumes: [f64::NAN; 4] })
}

/// [`power_dual_precise`]'s double-double step: the values if their bounds certify them.
fn power_dual_certified(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>, placement: Placement) -> Option<Dual> {
    let (corners, det) = precise_tet(x, t.scale);
    let (w, m) = dual_of(corners, det, relative_precise(t.scale, weights), placement);
    certify_dual(w, m, t.scale)
}

/// [`power_dual_precise`]'s last step, in exact arithmetic from the input coordinates (the
/// caller's units: no frame); `None` for an immersed tet.
fn power_dual_exact(x: [&[f64]; 4], weights: Option<&[f64; 4]>, placement: Placement) -> Option<Dual> {
    exactly(|| {
        let (corners, det) = exact_tet(x)?;
        let w = weights.map_or([Exact::from(0.0); 4], |w| w.map(|wi| Exact::from(wi) - Exact::from(w[0])));
        let (w, m) = dual_of(corners, det, w, placement);
        Some(Dual { weights: w.map(Exact::to_f64), cell_volumes: m.map(Exact::to_f64) })
    })
}

/// The dual weights of the tet with corners `x` (its frame `t`) mapped by a tensor `k`
/// into the frame `mapped` ([`crate::element::metric::mapped_tet`]), with vertex weights
/// `weights` (in the mapped frame's squared lengths, the caller's unit) and dual vertices
/// placed by `placement`, by the precise path of the accuracy rule: in double-double with
/// error bounds from the mapped exact corners, else exactly; the values of the mapped tet
/// in the caller's unit, NaN where neither serves.
pub(crate) fn mapped_dual_precise(
    x: [&[f64]; 4],
    t: &LocalTet,
    mapped: &LocalTet,
    k: &Tensor<3>,
    weights: Option<&[f64; 4]>,
    placement: Placement,
) -> [f64; 6] {
    let certified_weights = || {
        let (corners, det) = precise_mapped_tet(x, t, mapped, k);
        let (w, _) = dual_of(corners, det, relative_precise(mapped.scale, weights), placement);
        let wmax = largest(&w);
        Some(certified(w, |_| wmax)?.map(|v| v * mapped.scale))
    };
    let exact_weights = || {
        exactly(|| {
            let (corners, det) = exact_mapped_tet(x, k)?;
            let w = weights.map_or([Exact::from(0.0); 4], |w| w.map(|wi| Exact::from(wi) - Exact::from(w[0])));
            Some(dual_of(corners, det, w, placement).0.map(Exact::to_f64))
        })
    };
    certified_weights().or_else(exact_weights).unwrap_or([f64::NAN; 6])
}

/// The corners of a tet in R^3 relative to the first, exactly, and their determinant (six
/// times the signed volume), inside [`exactly`]; `None` for an immersed tet.
pub(crate) fn exact_tet(x: [&[f64]; 4]) -> Option<([V3<Exact>; 4], Exact)> {
    if x[0].len() != 3 {
        return None;
    }
    let p: [V3<Exact>; 4] = std::array::from_fn(|k| std::array::from_fn(|c| Exact::from(x[k][c]) - Exact::from(x[0][c])));
    Some((p, dot(p[1], cross(p[2], p[3]))))
}

/// The corner weights relative to corner 0, in the frame's units (squared lengths).
pub(super) fn relative(scale: f64, weights: Option<&[f64; 4]>) -> [f64; 4] {
    let s2 = scale * scale;
    weights.map_or([0.0; 4], |w| w.map(|wi| (wi - w[0]) / s2))
}

/// [`relative`] in double-double with error bounds: the differences exact, then scaled.
pub(super) fn relative_precise(scale: f64, weights: Option<&[f64; 4]>) -> [Bd; 4] {
    let inv = 1.0 / scale;
    weights.map_or([Bd::default(); 4], |w| {
        w.map(|wi| {
            let (hi, lo) = two_sum(wi, -w[0]);
            Bd::scaled(hi, lo, inv * inv)
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
