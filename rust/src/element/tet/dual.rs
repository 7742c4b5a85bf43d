//! Dual (circumcentric DEC / finite-volume) weights and dual-cell volumes of one tet,
//! paper Eq. 17-21.

use super::{Frame, EDGES, OPPOSITE};
use crate::element::frame::LocalTet;

/// One tet's contributions to the dual Laplacian and the circumcentric mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual {
    /// `w_ab = 6 (v(a,b,k) + v(a,b,l)) / |x_a - x_b|^2` per local edge (Eq. 19-20).
    pub weights: [f64; 6],
    /// `Vol(*a)` restricted to this tet: the six signed pieces `v(a, b, c)` at corner `a`
    /// (Eq. 21). They sum to the tet's volume.
    pub cell_volumes: [f64; 4],
}

/// Dual weights and cell volumes of one tet, from its signed circumcentric pieces.
///
/// The piece of the flag (vertex `a`, edge `ab`, face `abk`; `l` the fourth corner) is the
/// tet `(x_a, c_ab, c_abk, c_abkl)` with mutually orthogonal edges, of signed volume
/// `v = (1/6) (|ab|/2) h2 h3` where
/// * `h2 = (|ab|/2) cot(gamma_k)` is the signed distance of the face circumcenter `c_abk`
///   from the line `ab`, positive towards `k` (`gamma_k` the face angle at `k`);
/// * `h3 = lambda_l(c) |det| / |n_l|` is the signed distance of the tet circumcenter `c` from
///   the face `abk`, positive towards `l` (`lambda_l` a barycentric coordinate).
///
/// With `cot(gamma_k) = (x_a - x_k).(x_b - x_k) / |n_l|` this gives
/// `v = |ab|^2 ((x_a - x_k).(x_b - x_k)) lambda_l(c) |det| / (24 |n_l|^2)`: every factor is
/// independent of the tet's orientation and of its vertex order. Negative pieces (an
/// obtuse face angle, a circumcenter outside the tet) are how non-Delaunay tets make
/// negative weights and negative cell volumes. In `f64` from the frame: the values of a
/// [well-shaped](super::well_shaped) tet (others take [`super::power_dual_precise`]).
///
/// ```
/// // The corner tet (SPEC §10): weights 1/4 at the right-angled corner's edges,
/// // cell volume 1/8 there and 1/72 at the other corners.
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// let d = tetlap::element::tet::dual(&t);
/// assert!((d.weights[0] - 0.25).abs() < 1e-15);
/// assert!((d.cell_volumes[0] - 1.0 / 8.0).abs() < 1e-15);
/// assert!((d.cell_volumes[1] - 1.0 / 72.0).abs() < 1e-15);
/// ```
pub fn dual(t: &LocalTet) -> Dual {
    let f = Frame::new(t);
    let [_, e1, e2, e3] = f.x;
    // Tet circumcenter relative to x_0.
    let c = (e1.length_squared() * f.normals[1]
        + e2.length_squared() * f.normals[2]
        + e3.length_squared() * f.normals[3])
        / (2.0 * f.det);
    // Barycentric coordinates of c; lambda_0 from a vertex of its own face, not 1 - sum.
    let lambda = [
        f.normals[0].dot(c - e1) / f.det,
        f.normals[1].dot(c) / f.det,
        f.normals[2].dot(c) / f.det,
        f.normals[3].dot(c) / f.det,
    ];
    // h3 / |n_l| * (1/|n_l|) per face, times |det| / 4: the common factor of each term.
    let g = lambda.map(|lam| lam * f.det.abs() / 4.0);
    let g = [0, 1, 2, 3].map(|l| g[l] / f.normals[l].length_squared());
    let mut weights = [0.0; 6];
    let mut cell_volumes = [0.0; 4];
    for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
        let dot_k = (f.x[a] - f.x[k]).dot(f.x[b] - f.x[k]);
        let dot_l = (f.x[a] - f.x[l]).dot(f.x[b] - f.x[l]);
        // w = 6 (v_k + v_l) / |ab|^2 = (|det|/4) (dot_k lambda_l/|n_l|^2 + dot_l lambda_k/|n_k|^2)
        let w = dot_k * g[l] + dot_l * g[k];
        weights[e] = w * t.scale;
        // the two pieces at a (and, by mirror symmetry, at b) sum to |ab|^2 w / 6
        let pieces = (f.x[a] - f.x[b]).length_squared() * w / 6.0;
        cell_volumes[a] += pieces;
        cell_volumes[b] += pieces;
    }
    // scaled step by step (exact powers of two): s^3 alone could overflow
    Dual { weights, cell_volumes: cell_volumes.map(|v| v * t.scale * t.scale * t.scale) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;
    use crate::element::tet::{primal_weights, volume};

    #[test]
    fn golden_regular_tet() {
        let d = dual(&regular());
        assert!(close(&row0(d.weights), &[-0.176777, 0.058926, 0.058926, 0.058926], 1e-6));
        assert!(close(&d.cell_volumes, &[0.029463; 4], 1e-6));
    }

    #[test]
    fn golden_corner_tet() {
        let d = dual(&corner());
        assert!(close(&row0(d.weights), &[-0.75, 0.25, 0.25, 0.25], 1e-15));
        let m = 1.0 / 72.0;
        assert!(close(&d.cell_volumes, &[0.125, m, m, m], 1e-15));
    }

    #[test]
    fn cell_volumes_sum_to_the_volume() {
        let t = tet([[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]]);
        let d = dual(&t);
        let total: f64 = d.cell_volumes.iter().sum();
        assert!((total - volume(&t)).abs() < 1e-14 * volume(&t).max(1.0));
        // a flat-ish tet has its circumcenter far outside: some weights are negative
        assert!(d.weights.iter().any(|&w| w < 0.0));
        // the primal weights of the same tet differ
        assert!(!close(&d.weights, &primal_weights(&t), 1e-3));
    }
}
