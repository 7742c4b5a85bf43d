//! Primal (P1 FEM / cotan) weights of one tet, paper Eq. 7.

use super::power::{cross, dot, sub};
use super::{Frame, EDGES};
use super::batch::{Lanes, LANES};
use crate::element::exact::{Dd, DdLanes};
use crate::element::frame::{precise_tet, LocalTet};

/// The six primal weights of one tet: `w_ab = |x_k - x_l| cot(theta_kl) / 6` for edge `ab`
/// with opposite edge `kl` and dihedral angle `theta_kl` there.
///
/// Computed as minus the P1 stiffness `Vol * grad(lambda_a) . grad(lambda_b)`
/// `= -(n_a . n_b) / (6 |det|)`, with `n_a` the (unnormalised) face normals. Independent of
/// the tet's orientation. Infinite or NaN for a degenerate tet (the caller checks). A tet
/// with faces too small for these products (a needle) goes through cotangents of unit
/// vectors instead, `|x_k - x_l| cot(theta_kl) / 6`, with the same precision.
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
    if super::careful::is_extreme(&f) {
        return super::careful::primal_weights(t);
    }
    let k = -t.scale / (6.0 * f.det.abs());
    EDGES.map(|(a, b)| f.normals[a].dot(f.normals[b]) * k)
}

/// [`primal_weights`] in double-double from the tet's input corners `x` (exact edges and
/// determinant): the precise path of the accuracy rule, for tets whose thin faces make the
/// face normals a small difference of large products.
pub fn primal_weights_precise(x: [&[f64]; 4], t: &LocalTet) -> [f64; 6] {
    let (p, det) = precise_tet(x, t.scale);
    let n = [cross(sub(p[3], p[1]), sub(p[2], p[1])), cross(p[2], p[3]), cross(p[3], p[1]), cross(p[1], p[2])];
    let k = Dd::from(-t.scale) / (Dd::from(6.0) * det.abs());
    EDGES.map(|(a, b)| (dot(n[a], n[b]) * k).to_f64())
}

/// [`primal_weights_precise`] of [`LANES`] tets at once: `corners[i]` and `det[i]` the
/// precise frame of lane `i` ([`precise_tet`]), `scale[i]` its scale. Bit for bit the
/// one-tet function.
pub(crate) fn primal_weights_precise_lanes(corners: &[[[Dd; 3]; 4]; LANES], det: [Dd; LANES], scale: Lanes) -> [Lanes; 6] {
    let p: [[DdLanes; 3]; 4] = std::array::from_fn(|k| std::array::from_fn(|a| DdLanes::from_fn(|i| corners[i][k][a])));
    let det = DdLanes::from_fn(|i| det[i]);
    let n = [cross(sub(p[3], p[1]), sub(p[2], p[1])), cross(p[2], p[3]), cross(p[3], p[1]), cross(p[1], p[2])];
    let k = DdLanes { hi: scale.map(|s| -s), lo: [0.0; LANES] } / (DdLanes::from(6.0) * det.abs());
    EDGES.map(|(a, b)| (dot(n[a], n[b]) * k).to_f64())
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
        assert!(close(&primal_weights(&t), &primal_weights_precise(corners, &t), 1e-15));
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
