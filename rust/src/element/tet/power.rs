//! Dual construction from explicit dual vertices: weighted circumcenters (power diagram
//! duals) and the barycentric boundary fix (paper Sec. 6), by the signed pieces of
//! Eq. 17-21 taken literally.

use super::{Dual, EDGES, FACES, OPPOSITE};
use crate::element::frame::LocalTet;
use glam::DVec3;

/// Dual vertices of one tet: a point on every edge, in every face's plane, and in space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Centers {
    /// One point on the line of every local edge ([`EDGES`] order).
    pub edges: [DVec3; 6],
    /// One point in the plane of every face, indexed by the opposite corner.
    pub faces: [DVec3; 4],
    /// One point for the tet.
    pub tet: DVec3,
}

/// The point `c` of the affine hull of `points` with equal power `|c - x_i|^2 - w_i` to
/// all of them (for `w = 0`, the circumcenter). `points.len()` is 2, 3 or 4.
fn power_center(x: &[DVec3], w: &[f64]) -> DVec3 {
    let (o, w0) = (x[0], w[0]);
    // 2 e_k . (c - o) = |e_k|^2 + w_0 - w_k, with c - o in the span of the e_k
    let rhs = |k: usize| ((x[k] - o).length_squared() + w0 - w[k]) / 2.0;
    match x.len() {
        2 => {
            let e = x[1] - o;
            o + e * (rhs(1) / e.length_squared())
        }
        3 => {
            let (a, b) = (x[1] - o, x[2] - o);
            let n = a.cross(b);
            // c - o = (r_a (b x n) + r_b (n x a)) / |n|^2
            o + (rhs(1) * b.cross(n) + rhs(2) * n.cross(a)) / n.length_squared()
        }
        _ => {
            let (a, b, c) = (x[1] - o, x[2] - o, x[3] - o);
            let det = a.dot(b.cross(c));
            o + (rhs(1) * b.cross(c) + rhs(2) * c.cross(a) + rhs(3) * a.cross(b)) / det
        }
    }
}

impl Centers {
    /// Weighted circumcenters (orthocenters) of every edge, face and the tet, for vertex
    /// weights `w` (in the units of the tet's scaled coordinates squared). `w = 0` gives
    /// the circumcentric dual.
    pub fn weighted(t: &LocalTet, w: [f64; 4]) -> Self {
        let x = corners(t);
        Centers {
            edges: EDGES.map(|(a, b)| power_center(&[x[a], x[b]], &[w[a], w[b]])),
            faces: FACES.map(|f| power_center(&f.map(|k| x[k]), &f.map(|k| w[k]))),
            tet: power_center(&x, &w),
        }
    }

    /// Paper Sec. 6: every face center outside its triangle and the tet center outside the
    /// tet replaced by the centroid (edge points stay).
    pub fn clamp_to_centroids(mut self, t: &LocalTet) -> Self {
        let x = corners(t);
        for (l, f) in FACES.iter().enumerate() {
            let p = f.map(|k| x[k]);
            if !inside_triangle(p, self.faces[l]) {
                self.faces[l] = (p[0] + p[1] + p[2]) / 3.0;
            }
        }
        if !inside_tet(x, self.tet) {
            self.tet = (x[0] + x[1] + x[2] + x[3]) / 4.0;
        }
        self
    }
}

fn corners(t: &LocalTet) -> [DVec3; 4] {
    [DVec3::ZERO, t.edges[0], t.edges[1], t.edges[2]]
}

/// Strictly inside the triangle `p` (c in its plane): all three sub-areas positive.
fn inside_triangle(p: [DVec3; 3], c: DVec3) -> bool {
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    (0..3).all(|i| (p[(i + 1) % 3] - p[i]).cross(c - p[i]).dot(n) > 0.0)
}

/// Strictly inside the tet `x`: all four barycentric coordinates positive.
fn inside_tet(x: [DVec3; 4], c: DVec3) -> bool {
    let det = |a: DVec3, b: DVec3, d: DVec3, e: DVec3| (b - a).dot((d - a).cross(e - a));
    let total = det(x[0], x[1], x[2], x[3]);
    let sub = [det(c, x[1], x[2], x[3]), det(x[0], c, x[2], x[3]), det(x[0], x[1], c, x[3]), det(x[0], x[1], x[2], c)];
    sub.iter().all(|&s| s * total > 0.0)
}

/// The dual of one tet with vertex weights (its power centres) and, if `fix_boundary`, the
/// barycentric boundary fix of paper Sec. 6 ([`Centers::clamp_to_centroids`]).
///
/// `weights` are the user's vertex weights of the tet's corners (squared length units);
/// only their differences matter, so they enter relative to corner 0, in the frame's units.
pub fn power_dual(t: &LocalTet, weights: Option<&[f64; 4]>, fix_boundary: bool) -> Dual {
    let s2 = t.scale * t.scale;
    let relative = weights.map_or([0.0; 4], |w| w.map(|wi| (wi - w[0]) / s2));
    let centers = Centers::weighted(t, relative);
    let centers = if fix_boundary { centers.clamp_to_centroids(t) } else { centers };
    dual_from_centers(t, &centers)
}

/// Dual weights and cell volumes of one tet from explicit dual vertices.
///
/// The piece of the flag (vertex `a`, edge `ab`, face `abk`) is the tet
/// `(x_a, c_ab, c_abk, c_abkl)`, signed `det[c_ab - x_a, c_abk - x_a, c_abkl - x_a] / 6`
/// times the sign of the tet's orientation. The pieces at `a` sum to `Vol(*a)` restricted
/// to the tet, and all 24 to its volume, for any dual vertices on their edges and faces.
/// The triangle `(c_ab, c_abk, c_abkl)` is the base of the pieces at `a` and at `b`,
/// whose apexes lie on opposite sides at heights summing to `|ab|` (for an orthogonal
/// dual, whose face is perpendicular to `ab`): its signed area is
/// `3 (v(a,b,k) + v(b,a,k)) / |ab|`, and the weight, dual area over length, is
/// `w_ab = 3 (v(a,b,k) + v(b,a,k) + v(a,b,l) + v(b,a,l)) / |ab|^2`. With the edge point at
/// the midpoint both pyramids are equal and this is Eq. 20, `6 (v(a,b,k) + v(a,b,l)) /
/// |ab|^2`; for weighted duals they are not.
pub fn dual_from_centers(t: &LocalTet, c: &Centers) -> Dual {
    let x = corners(t);
    // det[c_ab - x_a, c_f - x_a, c - x_a] / 6 for the flag (a, edge e, face f)
    let det = |a: usize, e: usize, face: usize| {
        let o = x[a];
        (c.edges[e] - o).dot((c.faces[face] - o).cross(c.tet - o)) / 6.0
    };
    // sign of det[x_q - x_p, x_r - x_p, x_u - x_p]
    let sign = |p: usize, q: usize, r: usize, u: usize| {
        (x[q] - x[p]).dot((x[r] - x[p]).cross(x[u] - x[p])).signum()
    };
    let mut weights = [0.0; 6];
    let mut cell_volumes = [0.0; 4];
    for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
        // v(a,b,k) = det[c_ab - x_a, c_abk - x_a, c_abkl - x_a] / 6
        //            * sign det[x_b - x_a, x_k - x_a, x_l - x_a]   (SPEC §2);
        // face abk is the face opposite l, face abl the one opposite k.
        let v_abk = det(a, e, l) * sign(a, b, k, l);
        let v_bak = det(b, e, l) * sign(b, a, k, l);
        let v_abl = det(a, e, k) * sign(a, b, l, k);
        let v_bal = det(b, e, k) * sign(b, a, l, k);
        weights[e] = 3.0 * (v_abk + v_bak + v_abl + v_bal) / (x[a] - x[b]).length_squared()
            * t.scale;
        cell_volumes[a] += v_abk + v_abl;
        cell_volumes[b] += v_bak + v_bal;
    }
    // scaled step by step (exact powers of two): s^3 alone could overflow
    Dual { weights, cell_volumes: cell_volumes.map(|v| v * t.scale * t.scale * t.scale) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;
    use crate::element::tet::{dual, volume};

    fn tets() -> Vec<LocalTet> {
        vec![
            regular(),
            corner(),
            tet([[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]]),
            tet([[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0.3, 0.2, -0.7]]),
        ]
    }

    #[test]
    fn zero_weights_reproduce_the_circumcentric_dual() {
        for t in tets() {
            let general = dual_from_centers(&t, &Centers::weighted(&t, [0.0; 4]));
            let fast = dual(&t);
            let scale = fast.weights.iter().fold(0.0f64, |m, w| m.max(w.abs()));
            assert!(close(&general.weights, &fast.weights, 1e-12 * scale), "{general:?} {fast:?}");
            let v = volume(&t);
            assert!(close(&general.cell_volumes, &fast.cell_volumes, 1e-12 * v.max(1e-300) * 1e3));
        }
    }

    #[test]
    fn pieces_sum_to_the_volume_for_any_centers() {
        for t in tets() {
            for w in [[0.1, -0.2, 0.05, 0.3], [0.0, 0.0, 0.4, 0.0]] {
                for centers in [Centers::weighted(&t, w), Centers::weighted(&t, w).clamp_to_centroids(&t)] {
                    let d = dual_from_centers(&t, &centers);
                    let total: f64 = d.cell_volumes.iter().sum();
                    assert!((total - volume(&t)).abs() < 1e-13, "{total} vs {}", volume(&t));
                }
            }
        }
    }

    #[test]
    fn centroids_make_everything_positive() {
        for t in tets() {
            let d = dual_from_centers(&t, &Centers::weighted(&t, [0.0; 4]).clamp_to_centroids(&t));
            assert!(d.cell_volumes.iter().all(|&v| v > 0.0), "{d:?}");
            assert!(d.weights.iter().all(|&w| w >= 0.0), "{d:?}");
        }
    }
}
