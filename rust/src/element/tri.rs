//! Kernels of one triangle: cotan (primal) weights, circumcentric dual (Eq. 16) and masses.
//!
//! Local edge order `(0,1), (0,2), (1,2)`. For triangles primal and dual coincide
//! (paper Sec. 4.3): the two kernels are independent routes to the same weights.

use super::frame::LocalTri;
use glam::DVec2;

/// Edges of a triangle in local order.
pub const EDGES: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];

/// The corner opposite each local edge.
const OPPOSITE_CORNER: [usize; 3] = [2, 1, 0];

fn corners(t: &LocalTri) -> [DVec2; 3] {
    [DVec2::ZERO, t.edges[0], t.edges[1]]
}

/// Twice the signed area, `det[x1 - x0, x2 - x0]` (correctly rounded in R^2: see
/// [`LocalTri::det`]).
fn det(t: &LocalTri) -> f64 {
    t.det
}

/// Whether the triangle's corners are collinear (zero area).
pub fn is_degenerate(t: &LocalTri) -> bool {
    det(t) == 0.0
}

/// Unsigned area, in the caller's units.
pub fn area(t: &LocalTri) -> f64 {
    det(t).abs() / 2.0 * t.scale * t.scale
}

/// Cotan weights (Eq. 6): `w_ij = cot(theta_k) / 2`, `theta_k` the angle opposite the edge,
/// computed as `(x_i - x_k).(x_j - x_k) / (2 |det|)`.
///
/// ```
/// let x = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
/// let w = tetlap::element::tri::cotan_weights(&tetlap::local_tri([&x[0], &x[1], &x[2]]));
/// assert!((w[0] - 0.5).abs() < 1e-15 && w[2].abs() < 1e-15); // edge (1,2) faces the right angle
/// ```
pub fn cotan_weights(t: &LocalTri) -> [f64; 3] {
    if is_extreme(t) {
        return careful(t).0;
    }
    let x = corners(t);
    let d = det(t).abs();
    std::array::from_fn(|e| {
        let ((i, j), k) = (EDGES[e], OPPOSITE_CORNER[e]);
        (x[i] - x[k]).dot(x[j] - x[k]) / (2.0 * d)
    })
}

/// Circumcentric dual of one triangle: weights from Eq. 16, `Vol(*(ij))_k / |ij|` with the
/// signed dual-edge piece `2 det[c_ij - x_i, c_ijk - x_i] / |ij|`, and the signed Voronoi
/// areas `(weights, cell_areas)` of its corners (each the two pieces
/// `(x_i, c_ij, c_ijk)` at `i`; they sum to the triangle's area).
pub fn dual(t: &LocalTri) -> ([f64; 3], [f64; 3]) {
    if is_extreme(t) {
        return careful(t);
    }
    let x = corners(t);
    let (a, b) = (t.edges[0], t.edges[1]);
    // circumcenter: c . a = |a|^2 / 2, c . b = |b|^2 / 2
    let c = (b.perp() * a.length_squared() - a.perp() * b.length_squared()) / (-2.0 * det(t));
    let mut weights = [0.0; 3];
    let mut areas = [0.0; 3];
    for (e, (&(i, j), &k)) in EDGES.iter().zip(&OPPOSITE_CORNER).enumerate() {
        let m = (x[i] + x[j]) / 2.0;
        // Eq. 16's determinant, signed by the orientation of (x_i, x_j, x_k): that of the
        // triangle for (0, 1, 2) and (1, 2, 0), the opposite for (0, 2, 1)
        let s = if (i, j, k) == (0, 2, 1) { -det(t).signum() } else { det(t).signum() };
        let piece_i = (m - x[i]).perp_dot(c - x[i]) * s; // 2 * signed area at i
        let piece_j = -(m - x[j]).perp_dot(c - x[j]) * s; // mirror image at j
        let len2 = (x[j] - x[i]).length_squared();
        weights[e] = 2.0 * piece_i / len2;
        areas[i] += piece_i / 2.0;
        areas[j] += piece_j / 2.0;
    }
    (weights, areas.map(|v| v * t.scale * t.scale))
}

/// The mixed ("hybrid Voronoi", Meyer et al. 2003) areas of the corners: the signed
/// Voronoi areas of [`dual`] when no angle is obtuse, else half the area at the obtuse
/// corner and a quarter at the others (the circumcenter snapped to the midpoint of the
/// longest edge). Positive for every non-degenerate triangle.
///
/// ```
/// let x = [[0.0, 0.0], [4.0, 0.0], [1.0, 0.5]]; // obtuse at corner 2
/// let t = tetlap::local_tri([&x[0], &x[1], &x[2]]);
/// assert_eq!(tetlap::element::tri::mixed_area(&t), [0.25, 0.25, 0.5]);
/// ```
pub fn mixed_area(t: &LocalTri) -> [f64; 3] {
    let x = corners(t);
    let obtuse = OPPOSITE_CORNER.iter().zip(&EDGES).find(|(&k, &(i, j))| (x[i] - x[k]).dot(x[j] - x[k]) < 0.0);
    match obtuse {
        None => dual(t).1,
        Some((&k, _)) => {
            let a = area(t);
            std::array::from_fn(|c| if c == k { a / 2.0 } else { a / 4.0 })
        }
    }
}

/// Below this squared edge length (in the normalised frame, `2^-600`) the direct formulas
/// can underflow.
const SMALL: f64 = f64::from_bits(((1023 - 600) as u64) << 52);

/// Whether an edge is short enough for the direct formulas to underflow.
fn is_extreme(t: &LocalTri) -> bool {
    let x = corners(t);
    EDGES.iter().any(|&(i, j)| (x[i] - x[j]).length_squared() < SMALL)
}

/// Unit vector and length of `v` without squaring tiny components.
fn unit(v: DVec2) -> (DVec2, f64) {
    let m = v.abs().max_element();
    if m == 0.0 {
        return (DVec2::ZERO, 0.0);
    }
    let u = v / m;
    let len = u.length();
    (u / len, m * len)
}

/// Cotan weights `cot(theta_k) / 2` and Voronoi areas `sum_j |ij|^2 w_ij / 4` of a
/// triangle with tiny edges, from unit vectors (the two routes coincide here).
fn careful(t: &LocalTri) -> ([f64; 3], [f64; 3]) {
    let x = corners(t);
    let weights: [f64; 3] = std::array::from_fn(|e| {
        let ((i, j), k) = (EDGES[e], OPPOSITE_CORNER[e]);
        let (u, v) = (unit(x[i] - x[k]).0, unit(x[j] - x[k]).0);
        u.dot(v) / u.perp_dot(v).abs() / 2.0
    });
    let mut areas = [0.0; 3];
    for (e, &(i, j)) in EDGES.iter().enumerate() {
        let len = unit(x[i] - x[j]).1;
        let piece = len * (len * weights[e]) / 4.0;
        areas[i] += piece;
        areas[j] += piece;
    }
    (weights, areas.map(|a| a * t.scale * t.scale))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::frame::local_tri;

    fn tri(x: [[f64; 2]; 3]) -> LocalTri {
        local_tri([&x[0], &x[1], &x[2]])
    }

    #[test]
    fn dual_equals_cotan_for_any_triangle_and_orientation() {
        for x in [
            [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0]],
            [[0.1, 0.2], [3.0, 0.1], [0.4, 0.3]], // obtuse: a negative weight
            [[0.0, 0.0], [1.0, 0.0], [0.5, 0.866]],
        ] {
            let t = tri(x);
            let (w, areas) = dual(&t);
            let c = cotan_weights(&t);
            for e in 0..3 {
                assert!((w[e] - c[e]).abs() < 1e-12 * c.iter().fold(1.0f64, |m, v| m.max(v.abs())), "{w:?} {c:?}");
            }
            let total: f64 = areas.iter().sum();
            assert!((total - area(&t)).abs() < 1e-13, "{areas:?} vs {}", area(&t));
        }
    }

    #[test]
    fn needles_keep_their_cotangents() {
        for h in [1e-10, 1e-100, 1e-160, 1e-200] {
            // (0,0), (1,0), (0,h): the weight of edge 01 is cot(angle at 2) / 2 = h / 2
            let t = tri([[0.0, 0.0], [1.0, 0.0], [0.0, h]]);
            let w = cotan_weights(&t);
            assert!((w[0] / (h / 2.0) - 1.0).abs() < 1e-13, "{h}: {w:?}");
            assert!((w[1] - 1.0 / (2.0 * h)).abs() <= 1e-13 / h, "{h}: {w:?}");
            let (d, areas) = dual(&t);
            assert!(d.iter().zip(&w).all(|(a, b)| (a - b).abs() <= 1e-13 * b.abs()), "{d:?} {w:?}");
            let total: f64 = areas.iter().sum();
            assert!((total / (h / 2.0) - 1.0).abs() < 1e-13, "{h}: {areas:?}");
        }
    }

    #[test]
    fn immersed_triangle_keeps_its_shape() {
        let x3 = [[0.0, 0.0, 0.0], [0.6, 0.0, 0.8], [0.0, 1.0, 0.0]];
        let t = local_tri([&x3[0], &x3[1], &x3[2]]);
        let flat = tri([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        let (a, b) = (cotan_weights(&t), cotan_weights(&flat));
        assert!(a.iter().zip(&b).all(|(p, q)| (p - q).abs() < 1e-15), "{a:?} {b:?}");
    }
}
