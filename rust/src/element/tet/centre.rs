//! The dual vertices of one tet as points, and the dual edges through its faces: what a
//! finite-volume code needs of the orthogonal dual (cell centres, face centres,
//! transmissibility lengths), from the closed forms of the power-diagram dual
//! ([`super::power_dual`]), so that they are the very centres behind the dual weights.
//!
//! For vertex weights `w` the centres are power centres (weighted circumcentres, the
//! orthocentres of a regular triangulation): the points of equal power `|c - x_i|^2 - w_i`
//! to the simplex's corners, in its affine hull; without weights, circumcentres. The dual
//! edge of a face crosses the face's plane at right angles at the face's centre, so the
//! part of it inside a tet is the signed distance of the tet's centre from the face.

use super::power::{centres, normals, relative, relative_precise, Real, V3};
use super::FACES;
use crate::element::frame::{precise_tet, LocalTet};
use glam::DVec3;

/// One tet's dual vertices and the dual edges through its faces, in the caller's units.
///
/// Points are offsets from corner 0 along the axes of the tet's frame
/// ([`crate::local_tet`]: the caller's own axes for a tet in R^3).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Centres {
    /// The tet's centre (its power centre, the circumcentre for equal weights) minus
    /// corner 0.
    pub centre: [f64; 3],
    /// The centre's barycentric coordinates (summing to 1): all positive when it lies
    /// strictly inside the tet.
    pub barycentric: [f64; 4],
    /// `faces[l]`: the centre of the face opposite corner `l` minus corner 0: where the dual
    /// edge of that face crosses its plane.
    pub faces: [[f64; 3]; 4],
    /// `heights[l]`: the signed distance of the tet's centre from the plane of face `l`,
    /// positive on the side of corner `l` (the tet's own side): the tet's part of the
    /// face's dual edge.
    pub heights: [f64; 4],
    /// `areas[l]`: the area of face `l`.
    pub areas: [f64; 4],
}

/// `|v|` without overflow or underflow in its squares (divided by its largest component
/// first).
fn scaled_length(v: DVec3) -> f64 {
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    m * (v / m).length()
}

/// The centres of a tet with corners `x` (`x[0] = 0`, scaled frame), determinant `det`,
/// vertex weights `w` relative to corner 0 (frame units), in the caller's units (`scale`).
fn centres_of<R: Real>(x: [V3<R>; 4], det: R, w: [R; 4], scale: f64) -> Centres {
    let (v, _, abs_det) = centres(x, det, w);
    // |n_l| by a scaled norm of its rounding: no square leaves the f64 range
    let norm = normals(x).map(|n| scaled_length(DVec3::from_array(n.map(Real::to_f64))));
    let point = |p: V3<R>| p.map(|c| c.to_f64() * scale);
    let face = |l: usize| {
        let mut p = [R::from(0.0); 3];
        for &k in &FACES[l] {
            for (pc, xc) in p.iter_mut().zip(x[k]) {
                *pc = *pc + v.face[l][k] * xc;
            }
        }
        point(p)
    };
    Centres {
        centre: point(v.centre),
        barycentric: v.tet.map(|mu| (mu / abs_det).to_f64()),
        faces: [face(0), face(1), face(2), face(3)],
        heights: std::array::from_fn(|l| v.tet[l].to_f64() / norm[l] * scale),
        // step by step: scale^2 alone could overflow
        areas: norm.map(|n| n / 2.0 * scale * scale),
    }
}

/// The centres of one tet with vertex weights `weights` (the user's, at its four
/// corners, in squared length units; only their differences matter; `None`: the
/// circumcentres), in `f64` from its frame.
///
/// ```
/// use tetlap::element::tet::power_centres;
/// // the corner tet: circumcentre (1/2, 1/2, 1/2), outside (lambda_0 = -1/2)
/// let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
/// let c = power_centres(&t, None);
/// assert_eq!(c.centre, [0.5, 0.5, 0.5]);
/// assert_eq!(c.barycentric, [-0.5, 0.5, 0.5, 0.5]);
/// // the centre lies 1/2 above the face z = 0 (opposite corner 3), on the tet's side
/// assert_eq!(c.heights[3], 0.5);
/// assert_eq!(c.faces[3], [0.5, 0.5, 0.0]);
/// ```
pub fn power_centres(t: &LocalTet, weights: Option<&[f64; 4]>) -> Centres {
    let x = super::Frame::new(t).x.map(|p| p.to_array());
    centres_of(x, t.det, relative(t.scale, weights), t.scale)
}

/// [`power_centres`] in double-double from the tet's input corners `x` (in R^d, `t` their
/// frame), rounded to `f64` at the end: the precise path of the accuracy rule.
pub fn power_centres_precise(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>) -> Centres {
    let (corners, det) = precise_tet(x, t.scale);
    centres_of(corners, det, relative_precise(t.scale, weights), t.scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::tet::test_tets::*;
    use crate::element::tet::{power_dual, Placement, EDGES, OPPOSITE};

    /// The tets of the power-dual tests, as input corners (for the precise path).
    fn corners() -> Vec<[[f64; 3]; 4]> {
        vec![
            [[0.1, 0., 0.], [1., 0.2, 0.], [0.3, 1., 0.1], [0.2, 0.3, 0.05]],
            [[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0.3, 0.2, -0.7]],
            [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            [[0., 0., 0.], [1., 0., 0.], [0.5, 1e-7, 0.], [0.5, 0.3, 1e-7]],
        ]
    }

    fn close(a: f64, b: f64, scale: f64) -> bool {
        (a - b).abs() <= 1e-12 * scale
    }

    /// The centre has equal power to the corners; each face centre equal power to its
    /// corners, in the face's plane; heights are distances from the face planes.
    #[test]
    fn centres_have_equal_powers_and_heights_are_distances() {
        for x in corners() {
            let t = tet(x);
            for w in [[0.0; 4], [0.01, -0.02, 0.0, 0.03]] {
                for c in [power_centres(&t, Some(&w)), power_centres_precise([&x[0], &x[1], &x[2], &x[3]], &t, Some(&w))] {
                    let p = |k: usize| DVec3::from_array(x[k]) - DVec3::from_array(x[0]);
                    let power = |q: DVec3, k: usize| (q - p(k)).length_squared() - w[k];
                    let centre = DVec3::from_array(c.centre);
                    let size = centre.length_squared().max(1.0);
                    assert!((1..4).all(|k| close(power(centre, k), power(centre, 0), size)), "{x:?} {c:?}");
                    for l in 0..4 {
                        let [a, b, d] = FACES[l];
                        let f = DVec3::from_array(c.faces[l]);
                        let fsize = f.length_squared().max(1.0);
                        assert!(close(power(f, a), power(f, b), fsize) && close(power(f, a), power(f, d), fsize), "{l}: {c:?}");
                        let n = (p(b) - p(a)).cross(p(d) - p(a));
                        assert!(close(n.dot(f - p(a)), 0.0, fsize), "face centre off its plane");
                        let towards = if n.dot(p(l) - p(a)) > 0.0 { n } else { -n };
                        assert!(close(c.heights[l], towards.normalize().dot(centre - p(a)), size.sqrt()));
                        assert!(close(c.areas[l], n.length() / 2.0, 1.0));
                        // the dual edge meets the face's plane at its centre, at right angles
                        let foot = centre - towards.normalize() * c.heights[l];
                        assert!((foot - f).length() <= 1e-9 * size.sqrt(), "{l}: {foot} vs {f}");
                    }
                    let lambda: f64 = c.barycentric.iter().sum();
                    assert!((lambda - 1.0).abs() < 1e-9 * c.barycentric.iter().fold(1.0f64, |m, b| m.max(b.abs())));
                }
            }
        }
    }

    /// The dual weights are the dual faces' areas over the edges: inside the tet, the dual
    /// face of edge `ab` is the two right triangles (edge point, face centre, tet centre)
    /// of the faces `abk` and `abl`, of signed area `h2 h3 / 2` (`h2` the face centre's
    /// signed distance from the line `ab`, positive towards `k`; `h3` the tet centre's from
    /// the face, positive towards `l`: its height).
    #[test]
    fn the_dual_faces_of_the_centres_give_the_dual_weights() {
        for x in corners() {
            let t = tet(x);
            let w = [0.01, -0.02, 0.0, 0.03];
            let c = power_centres(&t, Some(&w));
            let d = power_dual(&t, Some(&w), Placement::Centres);
            let p = |k: usize| DVec3::from_array(x[k]) - DVec3::from_array(x[0]);
            for (e, (&(a, b), &(k, l))) in EDGES.iter().zip(OPPOSITE.iter()).enumerate() {
                let ab = p(b) - p(a);
                let tau = (ab.length_squared() + w[a] - w[b]) / (2.0 * ab.length_squared());
                let edge_point = p(a) + ab * tau;
                // face `face` holds a, b and `third`; its centre's distance from the line ab
                let h2 = |face: usize, third: usize| {
                    let towards = p(third) - p(a);
                    let across = (towards - ab * (towards.dot(ab) / ab.length_squared())).normalize();
                    across.dot(DVec3::from_array(c.faces[face]) - edge_point)
                };
                let area = (h2(l, k) * c.heights[l] + h2(k, l) * c.heights[k]) / 2.0;
                let expected = d.weights[e] * ab.length();
                assert!((area - expected).abs() <= 1e-12 * expected.abs().max(1e-3), "{x:?} edge {e}: {area} vs {expected}");
            }
        }
    }

    #[test]
    fn the_precise_path_agrees_with_the_float_one() {
        for x in corners() {
            let t = tet(x);
            let (a, b) = (power_centres(&t, None), power_centres_precise([&x[0], &x[1], &x[2], &x[3]], &t, None));
            let scale = a.centre.iter().fold(1.0f64, |m, c| m.max(c.abs()));
            for (p, q) in a.centre.iter().zip(&b.centre).chain(a.heights.iter().zip(&b.heights)) {
                assert!((p - q).abs() <= 1e-9 * scale, "{x:?}: {a:?} vs {b:?}");
            }
        }
    }
}
