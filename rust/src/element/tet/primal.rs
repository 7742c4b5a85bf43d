//! Primal (P1 FEM / cotan) weights of one tet, paper Eq. 7, and its corners' diagonal
//! entries.

use super::power::{cross, dot, exact_tet, sub, Field, V3};
use super::batch::{Lanes, LANES};
use super::{Frame, EDGES};
use crate::element::bounded::{certified, Bd, BdLanes};
use crate::element::frame::{precise_tet, LocalTet};
use crate::element::metric::{exact_mapped_tet, precise_mapped_tet, Tensor};
use crate::element::rational::{exactly, Exact};

/// One tet's contributions to the primal Laplacian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primal {
    /// `w_ab = -(n_a . n_b) / (6 |det|)` per local edge: the off-diagonal entries.
    pub weights: [f64; 6],
    /// `-|n_a|^2 / (6 |det|) = -Vol |grad lambda_a|^2` per corner: the diagonal entries,
    /// each accurate relative to itself (minus the sum of the corner's weights only up to
    /// their rounding, which for a needle is more than this value).
    pub diagonal: [f64; 4],
}

/// The six primal weights of one tet: `w_ab = |x_k - x_l| cot(theta_kl) / 6` for edge `ab`
/// with opposite edge `kl` and dihedral angle `theta_kl` there.
///
/// Computed as minus the P1 stiffness `Vol * grad(lambda_a) . grad(lambda_b)`
/// `= -(n_a . n_b) / (6 |det|)`, with `n_a` the (unnormalised) face normals, in `f64` from
/// the frame: the values of a [well-shaped](super::well_shaped) tet (others take
/// [`primal_precise`]). Independent of the tet's orientation. Infinite or NaN for a
/// degenerate tet (the caller checks).
///
/// ```
/// // The corner tet: the three edges at the right-angled corner get 1/6, the others 0.
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// let w = tetlap::element::tet::primal_weights(&t);
/// assert!((w[0] - 1.0 / 6.0).abs() < 1e-15 && w[5].abs() < 1e-15);
/// ```
pub fn primal_weights(t: &LocalTet) -> [f64; 6] {
    let f = Frame::new(t);
    let k = -t.scale / (6.0 * f.det.abs());
    EDGES.map(|(a, b)| f.normals[a].dot(f.normals[b]) * k)
}

/// [`primal_weights`] and the diagonal entries `-|n_a|^2 / (6 |det|)`, in `f64`.
///
/// ```
/// // the corner tet: row 0 of its Laplacian is [-1/2, 1/6, 1/6, 1/6]
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// let p = tetlap::element::tet::primal(&t);
/// assert!((p.diagonal[0] + 0.5).abs() < 1e-15 && (p.diagonal[1] + 1.0 / 6.0).abs() < 1e-15);
/// ```
pub fn primal(t: &LocalTet) -> Primal {
    let f = Frame::new(t);
    let k = -t.scale / (6.0 * f.det.abs());
    Primal { weights: EDGES.map(|(a, b)| f.normals[a].dot(f.normals[b]) * k), diagonal: f.normals.map(|n| n.length_squared() * k) }
}

/// The weights and diagonal entries of the tet with corners `p` (`p[0] = 0`), determinant
/// `det`, in units `scale` (in any [`Field`]).
#[inline(always)]
pub(crate) fn primal_of<R: Field>(p: [V3<R>; 4], det: R, scale: R) -> ([R; 6], [R; 4]) {
    let n = [cross(sub(p[3], p[1]), sub(p[2], p[1])), cross(p[2], p[3]), cross(p[3], p[1]), cross(p[1], p[2])];
    let k = -scale / (R::from(6.0) * det.oriented(det));
    (EDGES.map(|(a, b)| dot(n[a], n[b]) * k), n.map(|n| dot(n, n) * k))
}

/// [`primal`] by the precise path of the accuracy rule, from the tet's input corners `x`
/// (`t` their frame): in double-double from the exact edges and determinant, with error
/// bounds ([`Bd`]), for tets whose thin faces make the face normals a small difference of
/// large products; where the bounds do not certify every weight to within
/// [`CERTIFIED`](crate::element::bounded::CERTIFIED) of `sqrt(|d_a d_b|)` (its corners'
/// diagonal entries) and every diagonal entry to within that of itself, in exact rational
/// arithmetic (tets in R^3). Values beyond the `f64` range are infinite; NaN for an
/// immersed tet (d > 3) that double-double cannot serve.
pub fn primal_precise(x: [&[f64]; 4], t: &LocalTet) -> Primal {
    primal_precise_in(x, t, None)
}

/// [`primal_precise`] of the tet, or of the tet mapped by a tensor `map = (mapped, k)`
/// (`mapped` its frame, [`crate::element::metric::mapped_tet`]): the values of the mapped
/// tet in its frame's unit, the same steps on its mapped exact corners.
pub(crate) fn primal_precise_in(x: [&[f64]; 4], t: &LocalTet, map: Option<(&LocalTet, &Tensor<3>)>) -> Primal {
    primal_certified(x, t, map)
        .or_else(|| primal_exact(x, map.map(|(_, k)| k)))
        .unwrap_or(Primal { weights: [f64::NAN; 6], diagonal: [f64::NAN; 4] })
}

/// The weights and diagonal entries if their bounds certify them (see [`primal_precise`]).
fn certify_primal(w: [Bd; 6], d: [Bd; 4]) -> Option<Primal> {
    let size = d.map(|d| d.v.hi.abs());
    let weights = certified(w, |e| (size[EDGES[e].0] * size[EDGES[e].1]).sqrt())?;
    Some(Primal { weights, diagonal: certified(d, |a| size[a])? })
}

/// [`primal_precise`]'s double-double step.
fn primal_certified(x: [&[f64]; 4], t: &LocalTet, map: Option<(&LocalTet, &Tensor<3>)>) -> Option<Primal> {
    let ((p, det), scale) = match map {
        None => (precise_tet(x, t.scale), t.scale),
        Some((mapped, k)) => (precise_mapped_tet(x, t, mapped, k), mapped.scale),
    };
    let (w, d) = primal_of(p, det, Bd::from(scale));
    certify_primal(w, d)
}

/// [`primal_precise`]'s last step, exactly from the input coordinates (`None` for an
/// immersed tet).
fn primal_exact(x: [&[f64]; 4], map: Option<&Tensor<3>>) -> Option<Primal> {
    exactly(|| {
        let (p, det) = match map {
            None => exact_tet(x)?,
            Some(k) => exact_mapped_tet(x, k)?,
        };
        let (w, d) = primal_of(p, det, Exact::from(1.0));
        Some(Primal { weights: w.map(Exact::to_f64), diagonal: d.map(Exact::to_f64) })
    })
}

/// [`primal_precise`]'s double-double step for [`LANES`] tets at once: `corners[i]` and
/// `det[i]` the precise frame of lane `i` ([`precise_tet`]), `scale[i]` its scale. The
/// weights and diagonal entries of the lanes their bounds certify (flagged `true`), bit
/// for bit the one-tet function's.
pub(crate) fn primal_precise_lanes(corners: &[[[Bd; 3]; 4]; LANES], det: [Bd; LANES], scale: Lanes) -> ([Lanes; 6], [Lanes; 4], [bool; LANES]) {
    let p: [[BdLanes; 3]; 4] = std::array::from_fn(|k| std::array::from_fn(|a| BdLanes::from_fn(|i| corners[i][k][a])));
    let det = BdLanes::from_fn(|i| det[i]);
    let scale = BdLanes::from_fn(|i| Bd::from(scale[i]));
    let (w, d) = primal_of(p, det, scale);
    let (mut weights, mut diagonal, mut ok) = ([[0.0; LANES]; 6], [[0.0; LANES]; 4], [false; LANES]);
    for i in 0..LANES {
        if let Some(p) = certify_primal(w.map(|v| v.get(i)), d.map(|v| v.get(i))) {
            (0..6).for_each(|e| weights[e][i] = p.weights[e]);
            (0..4).for_each(|c| diagonal[c][i] = p.diagonal[c]);
            ok[i] = true;
        }
    }
    (weights, diagonal, ok)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;

    #[test]
    fn golden_regular_tet() {
        let w = primal_weights(&regular());
        assert!(close(&row0(w), &[-0.176777, 0.058926, 0.058926, 0.058926], 1e-6));
    }

    #[test]
    fn golden_corner_tet() {
        let w = primal_weights(&corner());
        let s = 1.0 / 6.0;
        assert!(close(&row0(w), &[-0.5, s, s, s], 1e-15));
        // the edges of the slanted face meet the corner's right dihedral angles: weight 0
        assert!(close(&w[3..], &[0.0; 3], 1e-15));
    }

    #[test]
    fn the_precise_path_agrees_with_the_float_one() {
        let x: [[f64; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.2, 0.3, 1.]];
        let t = tet(x);
        let corners = [&x[0][..], &x[1][..], &x[2][..], &x[3][..]];
        assert!(close(&primal_weights(&t), &primal_precise(corners, &t).weights, 1e-15));
        assert!(close(&primal(&t).diagonal, &primal_precise(corners, &t).diagonal, 1e-15));
    }

    #[test]
    fn orientation_does_not_matter() {
        let a = primal_weights(&tet([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.2, 0.3, 1.]]));
        let b = primal_weights(&tet([[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0.2, 0.3, 1.]]));
        // swapping corners 1 and 2 maps edges (0,1)<->(0,2), (1,3)<->(2,3); (0,3), (1,2) stay
        let perm = [1, 0, 2, 3, 5, 4];
        for e in 0..6 {
            assert!((a[e] - b[perm[e]]).abs() < 1e-15);
        }
    }
}
