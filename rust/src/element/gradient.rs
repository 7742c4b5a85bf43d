//! Gradients of the barycentric coordinates of one element, in the ambient space: the P1
//! gradient operator's kernels (`grad f = sum_a f_a grad(lambda_a)` on the element).
//!
//! A tet's gradients are its face normals over its determinant, `grad(lambda_l) = n_l /
//! det` (the tet's frame of face normals, the same quantities the primal weights are built
//! from: `w_ab = -Vol grad(lambda_a) . grad(lambda_b)`), computed in the tet's scaled frame
//! ([`local_tet`]) with its correctly rounded determinant and mapped back to R^d for an
//! immersed tet. A triangle's are the perpendiculars of its edges over its determinant, in
//! its plane ([`local_tri`]), mapped back to R^d.

use super::frame::{local_tet, local_tri, norm};
use super::tet::derivatives::to_ambient;
use super::tet::Frame;
use glam::DVec3;

/// The gradients of the four barycentric coordinates of the tet `x` (each corner in R^d,
/// `d >= 3`) into `out` (`4 d` values, corner by corner), and its unsigned volume.
///
/// `scratch` holds at least `3 d` values when `d > 3`. A degenerate tet (zero determinant)
/// gives volume 0 and leaves `out` untouched; a tet so flat or so large that a value leaves
/// the `f64` range gives non-finite values (the caller checks). The four gradients sum to
/// zero (to rounding) and `grad(lambda_a) . (x_b - x_c) = delta_ab - delta_ac`.
///
/// ```
/// let x = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let mut g = [0.0; 12];
/// let vol = tetlap::element::gradient::tet_gradients([&x[0], &x[1], &x[2], &x[3]], &mut [], &mut g);
/// assert_eq!(vol, 1.0 / 3.0);
/// assert_eq!(g, [-0.5, -1., -1., 0.5, 0., 0., 0., 1., 0., 0., 0., 1.]);
/// ```
pub fn tet_gradients(x: [&[f64]; 4], scratch: &mut [f64], out: &mut [f64]) -> f64 {
    let t = local_tet(x, scratch);
    if t.det == 0.0 {
        return 0.0;
    }
    // n / det / scale, in this order: det * scale may underflow where the gradient is finite
    let local: [DVec3; 4] = Frame::new(&t).normals.map(|n| n / t.det / t.scale);
    if x[0].len() == 3 {
        for (row, g) in out.chunks_exact_mut(3).zip(local) {
            row.copy_from_slice(&g.to_array());
        }
    } else {
        to_ambient(&local, scratch, out);
    }
    t.det.abs() / 6.0 * t.scale * t.scale * t.scale
}

/// The gradients of the three barycentric coordinates of the triangle `x` (each corner in
/// R^d, `d >= 2`) into `out` (`3 d` values, corner by corner), and its unsigned area.
///
/// A degenerate triangle (collinear corners) gives area 0 and leaves `out` untouched;
/// values beyond the `f64` range come out non-finite (the caller checks).
///
/// ```
/// let x = [[0.0, 0.0, 5.0], [2.0, 0.0, 5.0], [0.0, 1.0, 5.0]];
/// let mut g = [0.0; 9];
/// let area = tetlap::element::gradient::tri_gradients([&x[0], &x[1], &x[2]], &mut g);
/// assert_eq!(area, 1.0);
/// assert_eq!(g, [-0.5, -1., 0., 0.5, 0., 0., 0., 1., 0.]);
/// ```
pub fn tri_gradients(x: [&[f64]; 3], out: &mut [f64]) -> f64 {
    let t = local_tri(x);
    if t.det == 0.0 {
        return 0.0;
    }
    let [e1, e2] = t.edges;
    // grad(lambda_1) is orthogonal to e2 with grad(lambda_1) . e1 = 1, and so on
    let g1 = glam::DVec2::new(e2.y, -e2.x) / t.det / t.scale;
    let g2 = glam::DVec2::new(-e1.y, e1.x) / t.det / t.scale;
    let local = [-(g1 + g2), g1, g2];
    let d = x[0].len();
    if d == 2 {
        for (row, g) in out.chunks_exact_mut(2).zip(local) {
            row.copy_from_slice(&g.to_array());
        }
    } else {
        // the orthonormal frame of the plane that `local_tri` used: q0 along x1 - x0, q1
        // along the rest of x2 - x0 (Gram-Schmidt twice)
        let diff = |k: usize| -> Vec<f64> { (0..d).map(|c| (x[k][c] - x[0][c]) / t.scale).collect() };
        let unit = |v: Vec<f64>| -> Vec<f64> {
            let n = norm(&v);
            v.into_iter().map(|a| a / n).collect()
        };
        let q0 = unit(diff(1));
        let mut r = diff(2);
        for _pass in 0..2 {
            let p: f64 = q0.iter().zip(&r).map(|(a, b)| a * b).sum();
            r.iter_mut().zip(&q0).for_each(|(v, q)| *v -= p * q);
        }
        let q1 = unit(r);
        for (row, g) in out.chunks_exact_mut(d).zip(local) {
            for (c, o) in row.iter_mut().enumerate() {
                *o = g.x * q0[c] + g.y * q1[c];
            }
        }
    }
    t.det.abs() / 2.0 * t.scale * t.scale
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `grad(lambda_a) . (x_b - x_0) = delta_ab - delta_a0` for every corner pair.
    fn check_duality(x: &[Vec<f64>], g: &[f64]) {
        let (k, d) = (x.len(), x[0].len());
        for a in 0..k {
            for b in 1..k {
                let dot: f64 = (0..d).map(|c| g[a * d + c] * (x[b][c] - x[0][c])).sum();
                let want = f64::from(u8::from(a == b)) - f64::from(u8::from(a == 0));
                assert!((dot - want).abs() < 1e-12, "corner {a}, edge {b}: {dot}");
            }
        }
    }

    #[test]
    fn tets_in_r3_and_r5() {
        let x = vec![vec![0.1, 0.2, 0.3], vec![1.3, 0.1, -0.2], vec![0.2, 1.1, 0.4], vec![0.3, 0.1, 0.9]];
        let mut g = vec![0.0; 12];
        let vol = tet_gradients([&x[0], &x[1], &x[2], &x[3]], &mut [], &mut g);
        check_duality(&x, &g);
        // the same tet in R^5, rotated in the (x0, x3) plane and shifted in x4
        let (c, s) = (0.6f64, 0.8f64);
        let y: Vec<Vec<f64>> = x.iter().map(|p| vec![c * p[0], p[1], p[2], s * p[0], 7.0]).collect();
        let mut h = vec![0.0; 20];
        let mut scratch = vec![0.0; 15];
        let vol5 = tet_gradients([&y[0], &y[1], &y[2], &y[3]], &mut scratch, &mut h);
        check_duality(&y, &h);
        assert!((vol - vol5).abs() < 1e-15);
        for a in 0..4 {
            // the gradient rotates with the tet and has no component off its space
            assert!((h[a * 5] - c * g[a * 3]).abs() < 1e-12 && (h[a * 5 + 3] - s * g[a * 3]).abs() < 1e-12);
            assert!(h[a * 5 + 4].abs() < 1e-12);
        }
    }

    #[test]
    fn triangles_in_r2_and_r4() {
        let x = vec![vec![0.1, 0.2], vec![1.3, 0.1], vec![0.2, 1.1]];
        let mut g = vec![0.0; 6];
        let area = tri_gradients([&x[0], &x[1], &x[2]], &mut g);
        check_duality(&x, &g);
        let y: Vec<Vec<f64>> = x.iter().map(|p| vec![p[0], -3.0, p[1], 0.5 * p[1]]).collect();
        let mut h = vec![0.0; 12];
        let area4 = tri_gradients([&y[0], &y[1], &y[2]], &mut h);
        check_duality(&y, &h);
        assert!((area4 - area * 1.25f64.sqrt()).abs() < 1e-14);
        assert!(h.iter().skip(1).step_by(4).all(|v| v.abs() < 1e-14));
    }

    #[test]
    fn degenerate_elements_give_zero_measure() {
        let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
        let mut g = [7.0; 12];
        assert_eq!(tet_gradients([&x[0], &x[1], &x[2], &x[3]], &mut [], &mut g), 0.0);
        assert_eq!(g, [7.0; 12]);
        let mut g = [7.0; 9];
        assert_eq!(tri_gradients([&x[0], &x[1], &[2.0, 0.0, 0.0]], &mut g), 0.0);
    }
}
