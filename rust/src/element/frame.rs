//! One tet's coordinates in its own 3-space, scaled by an exact power of two.
//!
//! Kernels see a tet as three edge vectors `e_k = x_k - x_0` (k = 1, 2, 3) in R^3. For an
//! immersed tet (`dim > 3`) they are expressed in an orthonormal frame of the tet's affine
//! hull (a QR factorisation by twice-iterated Gram-Schmidt: lengths and angles are kept,
//! orientation is not, and no kernel depends on it). Every tet is also scaled by a power of
//! two so that its largest edge component lies in `[1/2, 1)`: the scaling is exact, so
//! coordinates as large as 1e150 or as small as 1e-150 neither overflow nor underflow in
//! the kernels' fourth-degree products.

use crate::element::bounded::Bd;
use crate::element::exact::{det3_dd, exact_edges, two_sum};
use glam::{DVec2, DVec3};

/// A tet as seen by the kernels: `edges[k-1] = (x_k - x_0) / scale`, `scale` a power of two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalTet {
    /// Scaled edge vectors from vertex 0 to vertices 1, 2, 3.
    pub edges: [DVec3; 3],
    /// The power of two that was divided out (lengths scale by it, volumes by its cube).
    pub scale: f64,
    /// `det[e1, e2, e3]` of the scaled edges (six times the signed volume over `scale^3`),
    /// correctly rounded from the input coordinates for tets in R^3 (see
    /// [`crate::element::exact`]); for an immersed tet, the product of the diagonal of its
    /// QR factor.
    pub det: f64,
}

impl LocalTet {
    /// The tet with edges `edges` (already scaled by `scale`), its determinant evaluated in
    /// `f64`: for tets given by their edges alone (tests, benches; no input coordinates to
    /// recompute a flat determinant from).
    pub fn from_edges(edges: [DVec3; 3], scale: f64) -> Self {
        LocalTet { edges, scale, det: edges[0].dot(edges[1].cross(edges[2])) }
    }
}

/// A tet's corners in its own 3-space in double-double with error bounds ([`Bd`]; the
/// first corner at the origin), scaled by `1 / scale`, and their determinant: the frame
/// of the kernels' precise path. In R^3 the edges and the determinant are exact (then
/// rounded to double-double; bounded where they leave the normal range); in R^d, `d > 3`,
/// a Gram-Schmidt QR factorisation (twice) in double-double.
pub(crate) fn precise_tet(x: [&[f64]; 4], scale: f64) -> ([[Bd; 3]; 4], Bd) {
    let inv = 1.0 / scale;
    let zero = Bd::default();
    if x[0].len() == 3 {
        let corners = x.map(|p| [p[0], p[1], p[2]]);
        let e = exact_edges(corners).map(|edge| edge.map(|(hi, lo)| Bd::scaled(hi, lo, inv)));
        let det = det3_dd(corners, inv);
        // rounded from the exact value, but for products below the normal range
        let det = Bd::new(det, DET_DD_ERROR * det.hi.abs() + DET_DD_FLOOR);
        return ([[zero; 3], e[0], e[1], e[2]], det);
    }
    let d = x[0].len();
    let edge = |k: usize| -> Vec<Bd> {
        (0..d)
            .map(|c| {
                let (hi, lo) = two_sum(x[k][c], -x[0][c]);
                Bd::scaled(hi, lo, inv)
            })
            .collect()
    };
    let dot = |a: &[Bd], b: &[Bd]| a.iter().zip(b).fold(zero, |s, (p, q)| s + *p * *q);
    let mut q: Vec<Vec<Bd>> = Vec::with_capacity(3);
    let mut r = [[zero; 3]; 3];
    for k in 0..3 {
        let mut v = edge(k + 1);
        for _pass in 0..2 {
            for (j, qj) in q.iter().enumerate() {
                let proj = dot(qj, &v);
                r[j][k] = r[j][k] + proj;
                v.iter_mut().zip(qj).for_each(|(vc, qc)| *vc = *vc - proj * *qc);
            }
        }
        let norm = dot(&v, &v).sqrt();
        r[k][k] = norm;
        if norm.v.hi > 0.0 {
            v.iter_mut().for_each(|vc| *vc = *vc / norm);
        }
        q.push(v);
    }
    let corners = [[zero; 3], [r[0][0], zero, zero], [r[0][1], r[1][1], zero], [r[0][2], r[1][2], r[2][2]]];
    (corners, r[0][0] * r[1][1] * r[2][2])
}

/// The relative error of [`det3_dd`] (its rounding of the exact expansion to
/// double-double) and its absolute error where the expansion's products underflow.
const DET_DD_ERROR: f64 = 1.0 / (1u128 << 104) as f64;
const DET_DD_FLOOR: f64 = f64::from_bits(1 << 14); // 2^-1060, subnormal

/// `det[e1, e2, e3]` of the scaled edges of the corners `x` (prescaled by `pre`, scaled by
/// `inv`), from the `f64` evaluation when its error bound allows, else exactly.
fn tet_det(e: &[DVec3; 3], x: impl Fn(usize) -> [f64; 3], inv: f64) -> f64 {
    let det = e[0].dot(e[1].cross(e[2]));
    if crate::element::exact::trusted(det, crate::element::exact::permanent(e.map(|v| v.to_array()))) {
        det
    } else {
        crate::element::exact::det3([x(0), x(1), x(2), x(3)], inv)
    }
}

/// `2^k` for `k` in `[-1022, 1023]`, exactly.
fn pow2(k: i32) -> f64 {
    debug_assert!((-1022..=1023).contains(&k));
    f64::from_bits(((k + 1023) as u64) << 52)
}

/// The `k` with `x / 2^k` in `[1/2, 1)`, for a normal `x > 0`.
fn scale_exponent(x: f64) -> i32 {
    ((x.to_bits() >> 52) & 0x7ff) as i32 - 1022
}

/// How to scale the differences `x_k - x_0` exactly: `(x_k pre - x_0 pre) inv`, with
/// `scale = 1 / (pre inv)` the power of two divided out.
struct Normalisation {
    pre: f64,
    inv: f64,
    scale: f64,
}

/// The normalisation that brings the largest difference `|x_k - x_0|` into `[1/2, 1)`,
/// or `None` when all points coincide. Differences that overflow or come close are
/// prescaled by 2^-600, differences near the subnormal range by 2^600 (exact).
fn normalisation(x: &[&[f64]]) -> Option<Normalisation> {
    let max_diff = |pre: f64| {
        let mut m = 0.0f64;
        for xk in &x[1..] {
            for (a, b) in xk.iter().zip(x[0]) {
                m = m.max((a * pre - b * pre).abs());
            }
        }
        m
    };
    let mut pre = 1.0;
    let mut max_abs = max_diff(pre);
    if !(max_abs < pow2(1000)) {
        pre = pow2(-600);
        max_abs = max_diff(pre);
    } else if max_abs < pow2(-1000) && max_abs > 0.0 {
        pre = pow2(600);
        max_abs = max_diff(pre);
    }
    if max_abs == 0.0 {
        return None;
    }
    let k = scale_exponent(max_abs);
    Some(Normalisation { pre, inv: pow2(-k), scale: pow2(k) / pre })
}

/// Edge vectors of a tet in R^d (`d = x[0].len()`), in its own 3-space, scaled.
///
/// `scratch` must hold at least `3 * d` values when `d > 3` (unused for `d = 3`).
/// All four points coinciding gives zero edges (a degenerate tet).
///
/// # The frame it leaves in `scratch` (a contract)
/// For `d = 3` the frame's axes are the user's: `edges[k - 1] = (x_k - x_0) / scale`.
/// For `d > 3`, on return `scratch[..3 * d]` holds the frame: three orthonormal rows
/// `q_0, q_1, q_2` of `d` values each (the Q of the QR factorisation of the edge matrix),
/// with `(x_k - x_0) / scale = sum_j edges[k - 1][j] q_j` up to rounding, and `edges`
/// upper triangular (`R`). Maps from the frame back to R^d, such as
/// [`to_ambient`](crate::element::tet::derivatives::to_ambient) for gradients, rely on this. For a
/// degenerate tet (a zero diagonal entry of `R`) the rows after the first dependent edge are
/// not normalised and must not be used.
///
/// ```
/// // a tet in the plane x_3 = 2 of R^4, skewed in the x_0-x_1 plane
/// let x = [[0., 0., 0., 2.], [1., 1., 0., 2.], [0., 1., 0., 2.], [0., 0., 1., 2.]];
/// let mut q = vec![0.0; 12];
/// let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut q);
/// for k in 1..4 {
///     for c in 0..4 {
///         let e: f64 = (0..3).map(|j| t.edges[k - 1][j] * q[j * 4 + c]).sum();
///         assert!((e * t.scale - (x[k][c] - x[0][c])).abs() < 1e-15);
///     }
/// }
/// ```
pub fn local_tet(x: [&[f64]; 4], scratch: &mut [f64]) -> LocalTet {
    let d = x[0].len();
    if d == 3 {
        // The common case, without prescaling: differences in the normal range.
        let p = |k: usize| DVec3::new(x[k][0], x[k][1], x[k][2]);
        let e = [p(1) - p(0), p(2) - p(0), p(3) - p(0)];
        let max_abs = e[0].abs().max(e[1].abs()).max(e[2].abs()).max_element();
        if (pow2(-1000)..pow2(1000)).contains(&max_abs) {
            let k = scale_exponent(max_abs);
            let inv = pow2(-k);
            let edges = e.map(|v| v * inv);
            let det = tet_det(&edges, |k| [x[k][0], x[k][1], x[k][2]], inv);
            return LocalTet { edges, scale: pow2(k), det };
        }
    }
    let Some(Normalisation { pre, inv, scale }) = normalisation(&x) else {
        return LocalTet { edges: [DVec3::ZERO; 3], scale: 1.0, det: 0.0 };
    };
    let diff = |k: usize, c: usize| (x[k][c] * pre - x[0][c] * pre) * inv;
    if d == 3 {
        let e = |k| DVec3::new(diff(k, 0), diff(k, 1), diff(k, 2));
        let edges = [e(1), e(2), e(3)];
        let det = tet_det(&edges, |k| [x[k][0] * pre, x[k][1] * pre, x[k][2] * pre], inv);
        return LocalTet { edges, scale, det };
    }
    // R of the QR factorisation of the 3 x d edge matrix: r[j][k] = q_j . e_k, with the
    // orthonormal q_j built in `scratch` by Gram-Schmidt, iterated twice for stability.
    let mut r = [[0.0f64; 3]; 3];
    for kk in 0..3 {
        let (done, rest) = scratch.split_at_mut(kk * d);
        let v = &mut rest[..d];
        for (c, vc) in v.iter_mut().enumerate() {
            *vc = diff(kk + 1, c);
        }
        for _pass in 0..2 {
            for j in 0..kk {
                let qj = &done[j * d..(j + 1) * d];
                let proj: f64 = qj.iter().zip(v.iter()).map(|(a, b)| a * b).sum();
                r[j][kk] += proj;
                for (vc, qc) in v.iter_mut().zip(qj) {
                    *vc -= proj * qc;
                }
            }
        }
        let norm = norm(v);
        r[kk][kk] = norm;
        if norm > 0.0 {
            v.iter_mut().for_each(|a| *a /= norm);
        }
    }
    LocalTet {
        edges: [
            DVec3::new(r[0][0], 0.0, 0.0),
            DVec3::new(r[0][1], r[1][1], 0.0),
            DVec3::new(r[0][2], r[1][2], r[2][2]),
        ],
        scale,
        det: r[0][0] * r[1][1] * r[2][2],
    }
}

/// A triangle as seen by its kernels: `edges[k-1] = (x_k - x_0) / scale` in an orthonormal
/// frame of its own plane, `scale` a power of two.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalTri {
    /// Scaled edge vectors from vertex 0 to vertices 1, 2.
    pub edges: [DVec2; 2],
    /// The power of two that was divided out.
    pub scale: f64,
    /// `det[e1, e2]` of the scaled edges (twice the signed area over `scale^2`), correctly
    /// rounded from the input coordinates for triangles in R^2 (see
    /// [`crate::element::exact`]); for an immersed triangle, from its QR factor.
    pub det: f64,
}

impl LocalTri {
    /// The triangle of `edges` in its plane, its determinant from them.
    fn new(edges: [DVec2; 2], scale: f64) -> Self {
        LocalTri { edges, scale, det: edges[0].perp_dot(edges[1]) }
    }
}

/// Below this sum of squares a norm is recomputed with the largest component divided out
/// (`2^-900`): squares of components below ~1e-154 would underflow and lose digits.
const TINY_SQUARE: f64 = f64::from_bits(((1023 - 900) as u64) << 52);

/// The Euclidean norm of `v`, without underflow: the plain sum of squares, or, when that is
/// tiny, the sum of squares of `v / max|v_i|` times `max|v_i|`.
pub(crate) fn norm(v: &[f64]) -> f64 {
    let squares: f64 = v.iter().map(|a| a * a).sum();
    if squares >= TINY_SQUARE {
        return squares.sqrt();
    }
    let m = v.iter().fold(0.0f64, |m, a| m.max(a.abs()));
    if m == 0.0 {
        return 0.0;
    }
    m * v.iter().map(|a| (a / m) * (a / m)).sum::<f64>().sqrt()
}

/// Edge vectors of a triangle in R^d (`d >= 2`) in its own plane, scaled like
/// [`local_tet`] (a QR factorisation of the 2 x d edge matrix; no scratch needed).
pub fn local_tri(x: [&[f64]; 3]) -> LocalTri {
    let d = x[0].len();
    let Some(Normalisation { pre, inv, scale }) = normalisation(&x) else {
        return LocalTri::new([DVec2::ZERO; 2], 1.0);
    };
    let diff = |k: usize, c: usize| (x[k][c] * pre - x[0][c] * pre) * inv;
    if d == 2 {
        let edges = [DVec2::new(diff(1, 0), diff(1, 1)), DVec2::new(diff(2, 0), diff(2, 1))];
        let mut t = LocalTri::new(edges, scale);
        let a = edges.map(|v| v.abs());
        if !crate::element::exact::trusted(t.det, a[0].x * a[1].y + a[0].y * a[1].x) {
            t.det = crate::element::exact::det2(x.map(|p| [p[0] * pre, p[1] * pre]), inv);
        }
        return t;
    }
    // R of the QR factorisation of the two edges, without storing q: with r00 = |e1|,
    // r01 = e1.e2 / |e1|, r11 = |e2 - (e1.e2 / |e1|^2) e1| (twice for stability).
    let dot = |a: usize, b: usize| (0..d).map(|c| diff(a, c) * diff(b, c)).sum::<f64>();
    if dot(1, 1) < TINY_SQUARE || dot(2, 2) < TINY_SQUARE {
        return needle_tri(d, &diff, scale);
    }
    let r00 = dot(1, 1).sqrt();
    let proj = dot(1, 2) / r00;
    let residual = |c: usize| diff(2, c) - proj / r00 * diff(1, c);
    let fix = (0..d).map(|c| residual(c) * diff(1, c)).sum::<f64>() / r00;
    let r11_squared = (0..d)
        .map(|c| {
            let v = residual(c) - fix / r00 * diff(1, c);
            v * v
        })
        .sum::<f64>();
    if r11_squared < TINY_SQUARE {
        return needle_tri(d, &diff, scale);
    }
    let r11 = r11_squared.sqrt();
    LocalTri::new([DVec2::new(r00, 0.0), DVec2::new(proj + fix, r11)], scale)
}

/// [`local_tri`]'s QR for a triangle with tiny edges or height, through unit vectors and
/// scaled norms (no squares of tiny components).
fn needle_tri(d: usize, diff: &impl Fn(usize, usize) -> f64, scale: f64) -> LocalTri {
    let e1: Vec<f64> = (0..d).map(|c| diff(1, c)).collect();
    let e2: Vec<f64> = (0..d).map(|c| diff(2, c)).collect();
    let r00 = norm(&e1);
    if r00 == 0.0 {
        return LocalTri::new([DVec2::ZERO, DVec2::new(norm(&e2), 0.0)], scale);
    }
    let q: Vec<f64> = e1.iter().map(|a| a / r00).collect();
    let mut r01 = 0.0;
    let mut residual = e2;
    for _pass in 0..2 {
        let proj: f64 = q.iter().zip(&residual).map(|(a, b)| a * b).sum();
        r01 += proj;
        residual.iter_mut().zip(&q).for_each(|(v, qc)| *v -= proj * qc);
    }
    LocalTri::new([DVec2::new(r00, 0.0), DVec2::new(r01, norm(&residual))], scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaling_is_an_exact_power_of_two() {
        let x: [[f64; 3]; 4] = [[0.0; 3], [3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
        assert_eq!(t.scale, 4.0);
        assert_eq!(t.edges[0], DVec3::new(0.75, 0.0, 0.0));
    }

    #[test]
    fn tiny_and_huge_tets_are_rescaled() {
        for s in [1e-150, 1e150, 1e-300, 1e300] {
            let x: [[f64; 3]; 4] = [[0.0; 3], [s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]];
            let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
            assert!((0.5..1.0).contains(&t.edges[0].x), "{s}: {:?}", t);
            assert!((t.edges[0].x * t.scale - s).abs() <= 1e-15 * s);
        }
    }

    #[test]
    fn immersed_tet_keeps_lengths_and_angles() {
        // The corner tet rotated into R^4 (a rotation in the x-w plane).
        let (c, s) = (0.6f64, 0.8f64);
        let rot = |p: [f64; 3]| [c * p[0], p[1], p[2], s * p[0]];
        let x = [rot([0.; 3]), rot([1., 0., 0.]), rot([0., 1., 0.]), rot([0., 0., 1.])];
        let mut scratch = vec![0.0; 12];
        let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut scratch);
        let e: Vec<DVec3> = t.edges.iter().map(|e| *e * t.scale).collect();
        for (a, b) in [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)] {
            let want = if a == b { 1.0 } else { 0.0 };
            assert!((e[a].dot(e[b]) - want).abs() < 1e-15);
        }
    }
}
