//! Underflow-free variants of the kernels for extremely anisotropic elements.
//!
//! In its normalised frame (largest edge component in `[1/2, 1)`) an element whose
//! shortest edges or smallest faces are many orders of magnitude below the largest (a
//! needle or a thin blade, `1e-80` and less) makes the direct formulas square quantities
//! below the smallest normal `f64` (`|n|^2`, `|e|^2 n`): they lose digits silently. These
//! variants work with unit vectors, lengths and cotangents only, so that no product leaves
//! the `f64` range unless the element is degenerate to double precision. The kernels use
//! them only when a face of the frame is that small ([`is_extreme`]), so results on every
//! ordinary mesh are bit for bit those of the direct formulas.

use super::{Frame, EDGES, FACES, OPPOSITE};
use crate::element::frame::LocalTet;
use glam::DVec3;

/// Below this `|n|^2` (a face's normal in the normalised frame) the direct formulas can
/// underflow: `2^-600`, faces smaller than ~1e-90 of the largest edge squared.
pub(crate) const SMALL: f64 = f64::from_bits(((1023 - 600) as u64) << 52);

/// Whether the frame has a face small enough for the direct formulas to underflow.
pub(crate) fn is_extreme(f: &Frame) -> bool {
    f.normals.iter().any(|n| n.length_squared() < SMALL)
}

/// Whether a face is small by its size (the product of two of its edges' squared lengths
/// underflows like its normal would), not by cancellation (a normal that rounds to zero
/// between long edges): the needles the unit-vector forms are for.
pub(crate) fn has_tiny_face(f: &Frame) -> bool {
    FACES.iter().any(|&[p, q, r]| (f.x[q] - f.x[p]).length_squared() * (f.x[r] - f.x[p]).length_squared() < SMALL)
}

/// `(v / |v|, |v|)` without squaring small components (a scaled norm); zero stays zero.
pub(crate) fn unit(v: DVec3) -> (DVec3, f64) {
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return (DVec3::ZERO, m);
    }
    let u = v / m;
    let len = u.length();
    (u / len, m * len)
}

/// The cotangent of the angle between `u` and `v` (scale-free).
fn cot(u: DVec3, v: DVec3) -> f64 {
    let (u, v) = (unit(u).0, unit(v).0);
    u.dot(v) / unit(u.cross(v)).1
}

/// The unit normal of the triangle `p`, `q`, `r` (right-hand rule).
fn face_normal(p: DVec3, q: DVec3, r: DVec3) -> DVec3 {
    let (u, v) = (unit(q - p).0, unit(r - p).0);
    unit(u.cross(v)).0
}

/// Primal weights `w_ab = |x_k - x_l| cot(theta_kl) / 6` (Eq. 7) from unit normals.
pub(crate) fn primal_weights(t: &LocalTet) -> [f64; 6] {
    let x = [DVec3::ZERO, t.edges[0], t.edges[1], t.edges[2]];
    let normals: [DVec3; 4] = std::array::from_fn(|l| {
        let [p, q, r] = FACES[l].map(|c| x[c]);
        face_normal(p, q, r)
    });
    std::array::from_fn(|e| {
        let ((a, b), (k, l)) = (EDGES[e], OPPOSITE[e]);
        // the dihedral angle at kl lies between the faces opposite a and b: cos = -n_a.n_b
        // for normals pointing the same way around the tet (both outward or both inward)
        let outward = |c: usize, n: DVec3| if n.dot(x[c] - x[FACES[c][0]]) > 0.0 { -n } else { n };
        let (na, nb) = (outward(a, normals[a]), outward(b, normals[b]));
        let cot_theta = -na.dot(nb) / unit(na.cross(nb)).1;
        unit(x[k] - x[l]).1 * cot_theta / 6.0 * t.scale
    })
}

/// Dual weights and cell volumes, `w_ab = (cot(g_k) h_l + cot(g_l) h_k) / 4` with `g_k` the
/// angle at `k` in the face `abk` and `h_l` the signed distance of the circumcenter from
/// that face (positive towards `l`), and the pieces `|ab|^2 w_ab / 6` at `a` and at `b`.
pub(crate) fn dual(t: &LocalTet) -> ([f64; 6], [f64; 4]) {
    let x = [DVec3::ZERO, t.edges[0], t.edges[1], t.edges[2]];
    // circumcenter: 2 e_k . c = |e_k|^2, rows scaled to unit edge directions
    let e: [(DVec3, f64); 3] = std::array::from_fn(|k| unit(x[k + 1]));
    let (u, len) = (e.map(|p| p.0), e.map(|p| p.1));
    let det = u[0].dot(u[1].cross(u[2]));
    let c = (len[0] * u[1].cross(u[2]) + len[1] * u[2].cross(u[0]) + len[2] * u[0].cross(u[1])) / (2.0 * det);
    // signed distance of c from the face opposite l, positive towards l
    let height = |l: usize| {
        let [p, q, r] = FACES[l].map(|k| x[k]);
        let n = face_normal(p, q, r);
        let towards = if n.dot(x[l] - p) >= 0.0 { n } else { -n };
        towards.dot(c - p)
    };
    let h = [height(0), height(1), height(2), height(3)];
    let mut weights = [0.0; 6];
    let mut cell_volumes = [0.0; 4];
    for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
        let cot_k = cot(x[a] - x[k], x[b] - x[k]);
        let cot_l = cot(x[a] - x[l], x[b] - x[l]);
        let w = (cot_k * h[l] + cot_l * h[k]) / 4.0;
        weights[e] = w * t.scale;
        let ab = unit(x[a] - x[b]).1;
        let pieces = ab * (ab * w) / 6.0;
        cell_volumes[a] += pieces;
        cell_volumes[b] += pieces;
    }
    // scaled step by step (exact powers of two): s^3 alone could overflow
    (weights, cell_volumes.map(|v| v * t.scale * t.scale * t.scale))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;

    #[test]
    fn careful_kernels_agree_with_the_direct_ones_on_ordinary_tets() {
        for t in [regular(), corner(), tet([[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]])] {
            let (p, q) = (crate::element::tet::primal_weights(&t), primal_weights(&t));
            assert!(close(&p, &q, 1e-13), "{p:?} {q:?}");
            let d = crate::element::tet::dual(&t);
            let (w, m) = dual(&t);
            assert!(close(&d.weights, &w, 1e-13), "{:?} {w:?}", d.weights);
            assert!(close(&d.cell_volumes, &m, 1e-14), "{:?} {m:?}", d.cell_volumes);
        }
    }

    #[test]
    fn a_needle_keeps_its_exact_weights() {
        // (0,0,0), (h,0,0), (0,h,0), (0,0,1): the dual weight of edge 01 is 1/4 for every h
        for h in [1e-10, 1e-80, 1e-120, 1e-150, 1e-160] {
            let t = tet([[0., 0., 0.], [h, 0., 0.], [0., h, 0.], [0., 0., 1.]]);
            let (w, m) = dual(&t);
            assert!((w[0] - 0.25).abs() < 1e-14, "{h}: {w:?}");
            assert!((m.iter().sum::<f64>() / (h * h / 6.0) - 1.0).abs() < 1e-13 || h < 1e-150, "{h}: {m:?}");
            let p = primal_weights(&t);
            assert!((p[0] - 1.0 / 6.0).abs() < 1e-14, "{h}: {p:?}");
        }
    }
}
