//! The quality of one tet: signed volume, dihedral angles, well-centredness, and the
//! circumsphere test of the local Delaunay property.

use super::{EDGES, OPPOSITE};
use super::power::Field;
use crate::element::frame::LocalTet;
use glam::DVec3;

/// Relative tolerance of the local Delaunay test: a point counts as inside a circumsphere
/// only if the lifted determinant exceeds `DELAUNAY_RTOL` times its Hadamard bound, so
/// that cospherical points (a Kuhn grid's cubes) are not flagged.
pub const DELAUNAY_RTOL: f64 = 1e-10;

/// The quality of one tet.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TetQuality {
    /// `det[x1-x0, x2-x0, x3-x0] / 6` in R^3 (positive: the VTK/gmsh/Medit orientation);
    /// the unsigned volume for an immersed tet.
    pub volume: f64,
    /// The dihedral angles in degrees at the local edges `(0,1), (0,2), (0,3), (1,2),
    /// (1,3), (2,3)`; NaN for a flat tet.
    pub dihedral: [f64; 6],
    /// The circumcenter is strictly inside the tet and every face angle is acute.
    pub well_centered: bool,
    /// The sign of `det[x1-x0, x2-x0, x3-x0]`, exact (`volume` may underflow to zero for a
    /// tet below `1e-100` in size): `1`, `-1`, or `0` for a flat tet; `1` for a tet
    /// immersed in R^d, d > 3, that is not flat.
    pub orientation: i8,
}

/// The quality of one tet from its local frame; `signed` keeps the orientation (R^3).
pub fn tet_quality(t: &LocalTet, signed: bool) -> TetQuality {
    let [e1, e2, e3] = t.edges;
    let x = [DVec3::ZERO, e1, e2, e3];
    let normals = [(e3 - e1).cross(e2 - e1), e2.cross(e3), e3.cross(e1), e1.cross(e2)];
    let det = t.det;
    let volume = if signed { det } else { det.abs() } / 6.0 * t.scale * t.scale * t.scale;
    let dihedral = std::array::from_fn(|e| {
        let (k, l) = OPPOSITE[e];
        let (a, b) = (normals[k], normals[l]);
        if det == 0.0 {
            f64::NAN
        } else {
            // the angle between the faces opposite k and l, at the edge they share
            a.cross(b).length().atan2(-a.dot(b)).to_degrees()
        }
    });
    // circumcenter c: 2 e_k . c = |e_k|^2, barycentric coordinates n_l . (c - x_face) / det
    let c = (e1.length_squared() * normals[1] + e2.length_squared() * normals[2] + e3.length_squared() * normals[3])
        / (2.0 * det);
    let lambda = [normals[0].dot(c - e1), normals[1].dot(c), normals[2].dot(c), normals[3].dot(c)];
    let inside = det != 0.0 && lambda.iter().all(|&l| l * det > 0.0);
    let acute = EDGES.iter().all(|&(a, b)| {
        // the face angles at corners a and b of every face through edge ab
        (0..4).filter(|&c| c != a && c != b).all(|c| (x[b] - x[a]).dot(x[c] - x[a]) > 0.0 && (x[a] - x[b]).dot(x[c] - x[b]) > 0.0)
    });
    let orientation = if signed { det.signum() as i8 } else { 1 } * (det != 0.0) as i8;
    TetQuality { volume, dihedral, well_centered: inside && acute, orientation }
}

/// Whether [`tet_quality`] from the frame serves a tet in R^3: its determinant is a normal
/// `f64` and no face is so thin (`|n|^2` below `2^-60` times the product of two of its
/// squared edges: an angle below `2^-30`) that its rounded normal, and the dihedral angles
/// from it, lose their digits. The others take [`tet_quality_exact`].
pub fn quality_from_frame(t: &LocalTet) -> bool {
    let [e1, e2, e3] = t.edges;
    let x = [DVec3::ZERO, e1, e2, e3];
    let thin = super::FACES.iter().any(|&[p, q, r]| {
        let (u, v) = (x[q] - x[p], x[r] - x[p]);
        u.cross(v).length_squared() < THIN_FACE * u.length_squared() * v.length_squared()
    });
    t.det.abs() >= f64::MIN_POSITIVE && !thin
}

/// `2^-60`: see [`quality_from_frame`].
const THIN_FACE: f64 = 1.0 / (1u64 << 60) as f64;

/// [`tet_quality`] of the tet with corners `x` in R^3 from exact arithmetic: the volume
/// rounded once, the dihedral angles from the exact face normals (each rounded after
/// dividing out its largest component), the well-centredness from exact signs.
pub fn tet_quality_exact(x: [&[f64]; 4], signed: bool) -> TetQuality {
    use super::power::{cross, dot, exact_tet, sub};
    use crate::element::rational::{exactly, Exact};
    exactly(|| {
        let (p, det) = exact_tet(x).expect("a tet in R^3");
        let volume = (det / Exact::from(6.0)).to_f64();
        let volume = if signed { volume } else { volume.abs() };
        let n = [cross(sub(p[3], p[1]), sub(p[2], p[1])), cross(p[2], p[3]), cross(p[3], p[1]), cross(p[1], p[2])];
        // each normal's direction in f64: divided by its largest component first
        let direction = |v: [Exact; 3]| {
            let size = v.iter().copied().max_by(|a, b| {
                let (a, b) = (a.oriented(*a), b.oriented(*b));
                (a - b).signum().cmp(&0)
            });
            let size = size.map(|s| s.oriented(s)).expect("three components");
            DVec3::from(v.map(|c| (c / size).to_f64()))
        };
        let flat = det.signum() == 0;
        let unit = n.map(|v| if flat { DVec3::ZERO } else { direction(v) });
        let dihedral = std::array::from_fn(|e| {
            let (k, l) = OPPOSITE[e];
            let (a, b) = (unit[k], unit[l]);
            if flat { f64::NAN } else { a.cross(b).length().atan2(-a.dot(b)).to_degrees() }
        });
        let well_centered = !flat && {
            let r = [1, 2, 3].map(|k| dot(p[k], p[k]));
            let c: [Exact; 3] = std::array::from_fn(|i| (r[0] * n[1][i] + r[1] * n[2][i] + r[2] * n[3][i]) / (Exact::from(2.0) * det));
            let lambda = [dot(n[0], sub(c, p[1])), dot(n[1], c), dot(n[2], c), dot(n[3], c)];
            let inside = lambda.iter().all(|&l| l.signum() * det.signum() > 0);
            let acute = EDGES.iter().all(|&(a, b)| {
                (0..4).filter(|&c| c != a && c != b).all(|c| {
                    dot(sub(p[b], p[a]), sub(p[c], p[a])).signum() > 0 && dot(sub(p[a], p[b]), sub(p[c], p[b])).signum() > 0
                })
            });
            inside && acute
        };
        let orientation = if signed { det.signum() as i8 } else { (!flat) as i8 };
        TetQuality { volume, dihedral, well_centered, orientation }
    })
}

/// `det` of the 4 x 4 matrix with rows `r`.
fn det4(r: [[f64; 4]; 4]) -> f64 {
    let minor = |a: usize, b: usize, c: usize, col: [usize; 3]| {
        let m = |i: usize, j: usize| r[i][col[j]];
        m(a, 0) * (m(b, 1) * m(c, 2) - m(b, 2) * m(c, 1)) - m(a, 1) * (m(b, 0) * m(c, 2) - m(b, 2) * m(c, 0))
            + m(a, 2) * (m(b, 0) * m(c, 1) - m(b, 1) * m(c, 0))
    };
    // expansion along the last column (the lifted coordinate)
    -r[0][3] * minor(1, 2, 3, [0, 1, 2]) + r[1][3] * minor(0, 2, 3, [0, 1, 2]) - r[2][3] * minor(0, 1, 3, [0, 1, 2])
        + r[3][3] * minor(0, 1, 2, [0, 1, 2])
}

/// Whether `q` lies strictly inside the circumsphere of the tet `x` (up to `rtol` times
/// the Hadamard bound of the lifted determinant). Invariant under translation, rotation
/// and scaling (the points are scaled by a power of two first).
pub fn inside_circumsphere(x: [[f64; 3]; 4], q: [f64; 3], rtol: f64) -> bool {
    let rel: [DVec3; 4] = x.map(|p| DVec3::from(p) - DVec3::from(q));
    let largest = rel.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
    if !(largest > 0.0 && largest.is_finite()) {
        return false;
    }
    let s = 2f64.powi(-(largest.log2().ceil() as i32));
    let rel = rel.map(|v| v * s);
    let lifted = rel.map(|v| [v.x, v.y, v.z, v.length_squared()]);
    let det = det4(lifted);
    let orient = (rel[1] - rel[0]).dot((rel[2] - rel[0]).cross(rel[3] - rel[0])).signum();
    let bound: f64 = lifted.iter().map(|r| r.iter().map(|c| c * c).sum::<f64>().sqrt()).product();
    // det[x_i - q, |x_i - q|^2] has the sign of -orient when q is inside the sphere
    -orient * det > rtol * bound
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::element::frame::local_tet;

    fn quality_of(x: [[f64; 3]; 4]) -> TetQuality {
        tet_quality(&local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []), true)
    }

    #[test]
    fn regular_and_corner_tets() {
        let s = 1.0 / 8f64.sqrt();
        let q = quality_of([[s, s, s], [s, -s, -s], [-s, s, -s], [-s, -s, s]]);
        for d in q.dihedral {
            assert!((d - (1.0f64 / 3.0).acos().to_degrees()).abs() < 1e-12);
        }
        assert!(q.well_centered);
        let q = quality_of([[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]);
        assert!((q.volume - 1.0 / 6.0).abs() < 1e-16);
        // right angles at the edges through the corner, the others arccos(1/sqrt(3))
        for e in 0..3 {
            assert!((q.dihedral[e] - 90.0).abs() < 1e-12);
            assert!((q.dihedral[e + 3] - (1.0f64 / 3.0).sqrt().acos().to_degrees()).abs() < 1e-12);
        }
        assert!(!q.well_centered); // right face angles
        let flipped = quality_of([[0., 0., 0.], [0., 1., 0.], [1., 0., 0.], [0., 0., 1.]]);
        assert_eq!(flipped.volume, -q.volume);
    }

    #[test]
    fn circumsphere_test() {
        let x = [[1., 0., 0.], [-1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]; // on the unit sphere
        assert!(inside_circumsphere(x, [0.0, 0.0, -0.5], DELAUNAY_RTOL));
        assert!(!inside_circumsphere(x, [0.0, 0.0, -1.5], DELAUNAY_RTOL));
        assert!(!inside_circumsphere(x, [0.0, -1.0, 0.0], DELAUNAY_RTOL)); // cospherical
        let flip = [x[1], x[0], x[2], x[3]];
        assert!(inside_circumsphere(flip, [0.0, 0.0, -0.5], DELAUNAY_RTOL));
        let huge = x.map(|p| p.map(|c| c * 1e150));
        assert!(inside_circumsphere(huge, [0.0, 0.0, -0.5e150], DELAUNAY_RTOL));
    }
}
