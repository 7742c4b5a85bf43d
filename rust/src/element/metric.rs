//! The coefficient of one element, as its kernels use it: the Laplacian of `div(K grad u)`
//! with `K` a positive scalar `c` or a symmetric positive definite tensor.
//!
//! # The definitions
//! * Primal: `L_ij = -sum_t Vol_t grad(lambda_i) . K_t grad(lambda_j)`.
//! * Dual: each element's circumcentric contribution in the metric `K^-1`, i.e. that of
//!   the element mapped by any `A` with `A^T A = K^-1` (such maps differ by a rotation,
//!   which changes no weight), times `sqrt(det K)`. The kernels take `A = C^-1` for the
//!   Cholesky factor `K = C C^T`, and `sqrt(det K) = det C`: no eigen-decomposition.
//! * The primal is the same construction: the P1 stiffness of the mapped element times
//!   `det C` (gradients map by `C^T`, volumes by `det C^-1`). The kernels map the element
//!   and run the usual kernels on it, for both; the tests check the primal against its
//!   direct formula.
//! * A scalar `c`: `c` times the element's values (its metric `I / c` changes no angle).
//! * Vertex weights `w` (power centres) are powers in the metric: the dual vertices have
//!   equal `|c - x_i|^2_{K^-1} - w_i` to the corners; for a scalar `c` these are the
//!   Euclidean power centres of the weights `c w`.
//! * The masses do not depend on the coefficient.
//!
//! # Scaling and accuracy
//! A tensor is divided by the power of two `2^e` that brings its largest entry into
//! `[1, 2)` before it is factored; both Laplacians are linear in `K`, so the values of
//! `K / 2^e` are multiplied by `2^e` at the end, exactly: a tensor scaled by `2^k` gives
//! every value scaled by `2^k`, bit for bit, and no product of the kernels leaves the
//! range on the tensor's account. Its factor `C` is computed in `f64`: the values are those
//! of `2^e C C^T`, which differs from `K` by the rounding of a Cholesky factorization
//! (backward stable: a few units of `2^-53` of `sqrt(K_ii K_jj)` per entry).
//!
//! The mapped element is a frame like any other: its edges `C^-1 e` are computed in
//! double-double from the exact edges and rounded once (as accurate as any element's
//! frame), scaled by a power of two, its determinant `det C^-1` times the element's (which
//! is rounded correctly). So the accuracy rule ([`crate::element`]) holds for it as it does
//! for any element: a mapped tet is computed in `f64` when it is well-shaped *in the
//! metric*, else by the precise path, whose double-double and exact rational steps map the
//! element's exact edges by the same `C^-1` (its entries are `f64` numbers, so the mapped
//! element is exact too).

use super::exact::Dd;
use super::frame::{precise_tet, LocalTet, LocalTri};
use super::rational::{ldexp, Exact};
use super::tet::batch::{Lanes, LANES};
use super::tet::exact_tet;
use crate::element::bounded::Bd;
use crate::error::CoefficientProblem;
use glam::{DVec2, DVec3};
use std::ops::{Mul, Sub};

/// The largest asymmetry of an accepted tensor, `|K_ij - K_ji|` over its largest entry:
/// `2^-40` (about `9.1e-13`), far above the rounding of a tensor computed in `f64` (such
/// as `R D R^T`), far below a tensor that is not symmetric. The kernels use
/// `(K + K^T) / 2`.
pub const SYMMETRY_RTOL: f64 = 1.0 / (1u64 << 40) as f64;

/// What the kernels need of a factored tensor beyond its map (see [`Tensor`]).
pub trait Factored: Copy {
    /// The power of two divided out of `K`.
    fn exponent(&self) -> i32;
    /// A value `v` of the mapped element as a value of `K` ([`Tensor::values`]).
    fn values(&self, v: f64) -> f64;
}

impl<const D: usize> Factored for Tensor<D> {
    fn exponent(&self) -> i32 {
        self.exponent
    }

    fn values(&self, v: f64) -> f64 {
        Tensor::values(self, v)
    }
}

/// One element's coefficient: a positive scalar, or a tensor factored for its kernels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Metric<T> {
    /// `c > 0`: the element's values times `c`.
    Scalar(f64),
    /// An SPD tensor: the element mapped by its factor.
    Tensor(T),
}

/// A symmetric positive definite `D x D` tensor factored for the kernels:
/// `K = 2^exponent C C^T` with `C` lower triangular, held as its entries below the diagonal
/// and the reciprocals of its diagonal (so that mapping by `C^-1` takes no division).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tensor<const D: usize> {
    /// `C`'s entries below the diagonal, row by row: `(1,0)`, `(2,0)`, `(2,1)`.
    lower: [f64; 3],
    /// `1 / C_ii`.
    inv_diag: [f64; D],
    /// The power of two divided out of `K`.
    exponent: i32,
    /// `2^exponent` where that is a normal `f64` (else 0, and the values are scaled by
    /// [`ldexp`]).
    power: f64,
    /// Whether each `inv_diag` is a power of two (the map's products with it are exact).
    exact: [bool; D],
    /// `det C = 1 / det C^-1`.
    sqrt_det: f64,
}

/// The position of `C_ij`, `i > j`, in [`Tensor::lower`].
const fn below(i: usize, j: usize) -> usize {
    i * (i - 1) / 2 + j
}

/// The `k` with `x / 2^k` in `[1/2, 1)`, for a finite `x > 0` (subnormal too).
fn exponent_of(x: f64) -> i32 {
    if x >= f64::MIN_POSITIVE {
        ((x.to_bits() >> 52) & 0x7ff) as i32 - 1022
    } else {
        exponent_of(x * (1u64 << 60) as f64) - 60
    }
}

impl<const D: usize> Tensor<D> {
    /// Checks the tensor `k` (`D x D`, row-major) and factors it: every entry finite,
    /// symmetric to within [`SYMMETRY_RTOL`] of its largest entry, and positive definite
    /// to `f64` precision (every pivot of the Cholesky factorization of `(K + K^T) / 2`, in
    /// `f64`, above [`PIVOT_RTOL`] of its diagonal entry).
    ///
    /// ```
    /// use tetlap::element::metric::Tensor;
    /// assert!(Tensor::<3>::new(&[2.0, 0.5, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 3.0]).is_ok());
    /// assert!(Tensor::<2>::new(&[1.0, 2.0, 2.0, 1.0]).is_err()); // eigenvalues -1 and 3
    /// ```
    pub fn new(k: &[f64]) -> Result<Self, CoefficientProblem> {
        if let Some(p) = k.iter().position(|x| !x.is_finite()) {
            return Err(CoefficientProblem::NonFinite { entry: Some((p / D, p % D)), value: k[p] });
        }
        let (a, exponent) = normalised::<D>(k);
        let largest = a.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        for i in 0..D {
            for j in i + 1..D {
                let asymmetry = (a[i][j] - a[j][i]).abs() / largest;
                if asymmetry > SYMMETRY_RTOL {
                    return Err(CoefficientProblem::NotSymmetric { row: i, col: j, asymmetry });
                }
            }
        }
        let sym = symmetric(&a);
        let (lower, inv_diag, pivots) = cholesky(&sym);
        if largest > 0.0 && (0..D).all(|i| pivots[i] > PIVOT_RTOL * sym[i][i] && inv_diag[i].is_finite()) {
            return Ok(Self::from_parts(lower, inv_diag, exponent));
        }
        let (smallest, largest) = eigenvalue_range::<D>(&sym);
        let scale = |x: f64| ldexp(x, i64::from(exponent));
        Err(CoefficientProblem::NotPositiveDefinite { smallest: scale(smallest), largest: scale(largest) })
    }

    /// The factorization of a tensor [`Tensor::new`] accepts, without its checks (a tensor
    /// it refuses gives NaN or infinite entries, hence NaN values, never a panic).
    #[inline]
    pub fn factor(k: &[f64]) -> Self {
        let (a, exponent) = normalised::<D>(k);
        let (lower, inv_diag, _) = cholesky(&symmetric(&a));
        Self::from_parts(lower, inv_diag, exponent)
    }

    /// [`Tensor::factor`] of [`LANES`] tensors at once (`k[lane][..D * D]`, row-major),
    /// the same operations lane by lane, side by side, and whether each passes
    /// [`Tensor::new`]'s checks (which say why one does not).
    #[inline(always)]
    pub fn factor_lanes(k: &[[f64; 9]; LANES]) -> ([Self; LANES], [bool; LANES]) {
        let n = D * D;
        // normalised: the largest entry, its exponent, the entries scaled
        let mut largest = [0.0f64; LANES];
        let mut finite = [true; LANES];
        for c in 0..n {
            for i in 0..LANES {
                largest[i] = largest[i].max(k[i][c].abs());
                finite[i] &= k[i][c].is_finite();
            }
        }
        let exponent: [i32; LANES] =
            std::array::from_fn(|i| if largest[i] > 0.0 && largest[i].is_finite() { exponent_of(largest[i]) - 1 } else { 0 });
        let mut a = [[[0.0f64; LANES]; D]; D];
        for i in 0..LANES {
            let e = exponent[i];
            for r in 0..D {
                for c in 0..D {
                    a[r][c][i] = if (-1021..=1021).contains(&e) {
                        k[i][r * D + c] * f64::from_bits(((1023 - e) as u64) << 52)
                    } else {
                        ldexp(k[i][r * D + c], -i64::from(e))
                    };
                }
            }
        }
        // the checks of Tensor::new: finite, symmetric, then the pivots
        let mut valid = finite;
        let mut scaled_largest = [0.0f64; LANES];
        for row in &a {
            for v in row {
                for i in 0..LANES {
                    scaled_largest[i] = scaled_largest[i].max(v[i].abs());
                }
            }
        }
        for r in 0..D {
            for c in r + 1..D {
                for i in 0..LANES {
                    valid[i] &= (a[r][c][i] - a[c][r][i]).abs() / scaled_largest[i] <= SYMMETRY_RTOL;
                }
            }
        }
        // symmetric, then cholesky, lane by lane
        let sym = |r: usize, c: usize, i: usize| if r == c { a[r][r][i] } else { (a[r][c][i] + a[c][r][i]) * 0.5 };
        let mut lower = [[0.0f64; LANES]; 3];
        let mut inv_diag = [[0.0f64; LANES]; D];
        for r in 0..D {
            for c in 0..r {
                for i in 0..LANES {
                    let mut s = sym(r, c, i);
                    for l in 0..c {
                        s -= lower[below(r, l)][i] * lower[below(c, l)][i];
                    }
                    lower[below(r, c)][i] = s * inv_diag[c][i];
                }
            }
            for i in 0..LANES {
                let mut pivot = sym(r, r, i);
                for l in 0..r {
                    pivot -= lower[below(r, l)][i] * lower[below(r, l)][i];
                }
                inv_diag[r][i] = 1.0 / pivot.sqrt();
                valid[i] &= pivot > PIVOT_RTOL * sym(r, r, i) && inv_diag[r][i].is_finite();
            }
        }
        for i in 0..LANES {
            valid[i] &= scaled_largest[i] > 0.0;
        }
        let tensors = std::array::from_fn(|i| {
            Self::from_parts(std::array::from_fn(|b| lower[b][i]), std::array::from_fn(|c| inv_diag[c][i]), exponent[i])
        });
        (tensors, valid)
    }

    #[inline(always)]
    fn from_parts(lower: [f64; 3], inv_diag: [f64; D], exponent: i32) -> Self {
        let power = if (-1022..=1023).contains(&exponent) { f64::from_bits(((1023 + exponent) as u64) << 52) } else { 0.0 };
        let sqrt_det = 1.0 / inv_diag.iter().product::<f64>();
        let exact = inv_diag.map(|d| d.is_normal() && d.to_bits() & ((1 << 52) - 1) == 0);
        Tensor { lower, inv_diag, exponent, power, exact, sqrt_det }
    }

    /// `C^-1 e`: forward substitution with the reciprocals of the diagonal (in any
    /// arithmetic with exact `f64` constants: `f64`, double-double, exact rationals).
    #[inline(always)]
    pub fn map<R: Copy + From<f64> + Sub<Output = R> + Mul<Output = R>>(&self, e: [R; D]) -> [R; D] {
        let mut y = e;
        for i in 0..D {
            let mut s = e[i];
            for j in 0..i {
                s = s - R::from(self.lower[below(i, j)]) * y[j];
            }
            y[i] = s * R::from(self.inv_diag[i]);
        }
        y
    }

    /// [`Tensor::map`] in `f64` of an edge whose components are each rounded (within a
    /// relative `2^-53`) from the exact edge, with a bound on the error of the result
    /// against `C^-1` of the exact edge (a running error analysis: every operation adds
    /// its own rounding, unless it is exact (a product with 0 or with a power of two, a
    /// difference with 0), and what its operands' errors can do; for a diagonal tensor of
    /// powers of two the bound is that of the edge itself), the largest over the
    /// components.
    #[inline(always)]
    pub fn map_bounded(&self, e: [f64; D]) -> ([f64; D], f64) {
        let mut y = [0.0; D];
        let mut err = [0.0; D];
        for i in 0..D {
            let mut s = e[i];
            let mut es = UNIT * e[i].abs();
            for j in 0..i {
                let l = self.lower[below(i, j)];
                let t = l * y[j];
                s = s - t;
                let rounding = if l == 0.0 { 0.0 } else { UNIT * t.abs() + UNIT * s.abs() };
                es = es + (l.abs() * err[j] + rounding);
            }
            y[i] = s * self.inv_diag[i];
            let rounding = if self.exact[i] { 0.0 } else { UNIT * y[i].abs() };
            err[i] = rounding + self.inv_diag[i].abs() * es;
        }
        (y, err.iter().fold(0.0f64, |m, &b| m.max(b)))
    }

    /// [`Tensor::map`] in double-double, its products by [`Dd::times`] (exact zeros
    /// without a fused multiply-add): the map of [`mapped_tet`] and [`mapped_tri`].
    #[inline(always)]
    pub fn map_dd(&self, e: [Dd; D]) -> [Dd; D] {
        let mut y = e;
        for i in 0..D {
            let mut s = e[i];
            for j in 0..i {
                s = s - y[j].times(self.lower[below(i, j)]);
            }
            y[i] = s.times(self.inv_diag[i]);
        }
        y
    }

    /// A bound on the magnitudes of [`Tensor::map`]'s steps for an edge `e` (`|C^-1| |e|`
    /// evaluated with absolute values, in `f64`): what the error of a double-double
    /// evaluation of the map is relative to.
    #[inline(always)]
    pub fn magnitude(&self, e: [f64; D]) -> f64 {
        let mut m = [0.0; D];
        for i in 0..D {
            let mut s = e[i].abs();
            for j in 0..i {
                s += self.lower[below(i, j)].abs() * m[j];
            }
            m[i] = s * self.inv_diag[i].abs();
        }
        m.iter().fold(0.0f64, |a, &b| a.max(b))
    }

    /// `det C^-1`, the product of [`Tensor::map`]'s diagonal, in `f64`.
    #[inline(always)]
    pub fn inv_det(&self) -> f64 {
        self.inv_diag.iter().product()
    }

    /// `sqrt(det (K / 2^exponent)) = det C`, the factor of the mapped element's values.
    #[inline(always)]
    pub fn sqrt_det(&self) -> f64 {
        self.sqrt_det
    }

    /// The power of two divided out of `K` (the values are multiplied by `2^exponent`).
    #[inline(always)]
    pub fn exponent(&self) -> i32 {
        self.exponent
    }

    /// The values of the mapped element `v` as the values of `K`: times
    /// [`Tensor::sqrt_det`], then times `2^exponent` (exact but for values that leave the
    /// normal range, which the caller's range rule refuses).
    #[inline(always)]
    pub fn values(&self, v: f64) -> f64 {
        let x = v * self.sqrt_det;
        match self.power {
            0.0 => ldexp(x, i64::from(self.exponent)),
            power => x * power,
        }
    }
}

/// `k` (row-major) divided by the power of two `2^e` that brings its largest entry into
/// `[1, 2)` (so that a diagonal tensor of powers of four has a factor of powers of two,
/// whose map is exact), and `e` (0 for a zero or non-finite `k`): exact but for entries
/// `2^1021` times smaller than the largest.
#[inline(always)]
fn normalised<const D: usize>(k: &[f64]) -> ([[f64; D]; D], i32) {
    let largest = k[..D * D].iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let e = if largest > 0.0 && largest.is_finite() { exponent_of(largest) - 1 } else { 0 };
    let a = if (-1021..=1021).contains(&e) {
        let inv = f64::from_bits(((1023 - e) as u64) << 52); // 2^-e, a normal number
        std::array::from_fn(|i| std::array::from_fn(|j| k[i * D + j] * inv))
    } else {
        std::array::from_fn(|i| std::array::from_fn(|j| ldexp(k[i * D + j], -i64::from(e))))
    };
    (a, e)
}

/// The Cholesky factorization `a = C C^T` of the symmetric `a`: `C`'s entries below the
/// diagonal (as [`Tensor::lower`]), the reciprocals of its diagonal, and the pivots (the
/// squares of its diagonal; NaN or infinite reciprocals where a pivot is not positive).
fn cholesky<const D: usize>(a: &[[f64; D]; D]) -> ([f64; 3], [f64; D], [f64; D]) {
    let mut lower = [0.0; 3];
    let mut inv_diag = [0.0; D];
    let mut pivots = [0.0; D];
    for i in 0..D {
        for j in 0..i {
            // C_ij = (a_ij - sum_{l<j} C_il C_jl) / C_jj
            let mut s = a[i][j];
            for l in 0..j {
                s -= lower[below(i, l)] * lower[below(j, l)];
            }
            lower[below(i, j)] = s * inv_diag[j];
        }
        let mut pivot = a[i][i];
        for l in 0..i {
            pivot -= lower[below(i, l)] * lower[below(i, l)];
        }
        pivots[i] = pivot;
        inv_diag[i] = 1.0 / pivot.sqrt();
    }
    (lower, inv_diag, pivots)
}

/// The smallest accepted Cholesky pivot relative to its diagonal entry, `2^-50` (four
/// units of `2^-52`): below it a pivot is the rounding of zero, and the tensor singular
/// to `f64` precision (its condition number beyond about `1e15`).
pub const PIVOT_RTOL: f64 = 1.0 / (1u64 << 50) as f64;

/// `(a + a^T) / 2`.
fn symmetric<const D: usize>(a: &[[f64; D]; D]) -> [[f64; D]; D] {
    std::array::from_fn(|i| std::array::from_fn(|j| if i == j { a[i][i] } else { (a[i][j] + a[j][i]) * 0.5 }))
}

/// The smallest and largest eigenvalues of the symmetric `a` (`D` = 2 or 3), in closed
/// form: for messages.
fn eigenvalue_range<const D: usize>(a: &[[f64; D]; D]) -> (f64, f64) {
    let m = |i: usize, j: usize| a[i][j];
    if D == 2 {
        let (mean, half) = ((m(0, 0) + m(1, 1)) / 2.0, (m(0, 0) - m(1, 1)) / 2.0);
        let r = half.hypot(m(0, 1));
        return (mean - r, mean + r);
    }
    // Smith's trigonometric solution of the characteristic cubic
    let off = m(0, 1) * m(0, 1) + m(0, 2) * m(0, 2) + m(1, 2) * m(1, 2);
    let diag = [m(0, 0), m(1, 1), m(2, 2)];
    if off == 0.0 {
        let lo = diag.iter().fold(f64::INFINITY, |x, &y| x.min(y));
        let hi = diag.iter().fold(f64::NEG_INFINITY, |x, &y| x.max(y));
        return (lo, hi);
    }
    let q = (diag[0] + diag[1] + diag[2]) / 3.0;
    let p = ((diag.iter().map(|d| (d - q) * (d - q)).sum::<f64>() + 2.0 * off) / 6.0).sqrt();
    let b = |i: usize, j: usize| (m(i, j) - if i == j { q } else { 0.0 }) / p;
    let det = b(0, 0) * (b(1, 1) * b(2, 2) - b(1, 2) * b(2, 1)) - b(0, 1) * (b(1, 0) * b(2, 2) - b(1, 2) * b(2, 0))
        + b(0, 2) * (b(1, 0) * b(2, 1) - b(1, 1) * b(2, 0));
    let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    (smallest, largest)
}

/// `2^k` for a power-of-two exponent `k` of a frame (the result may leave the normal
/// range only for elements far beyond it, whose values the range rule refuses).
#[inline(always)]
fn pow2(k: i32) -> f64 {
    if (-1022..=1023).contains(&k) {
        f64::from_bits(((1023 + k) as u64) << 52)
    } else {
        ldexp(1.0, i64::from(k))
    }
}

/// A tet with corners `x` (in R^3; `t` its frame) mapped by the tensor `k`: the frame its
/// Laplacian kernels see and the slack of its shape test ([`SLACK`] and above). The mapped
/// edges `C^-1 e` are the frame's edges mapped in `f64` where the bound on that map's
/// rounding, over `2^-53` of the largest component, is at most [`SLACK`] (that ratio is
/// the slack: 1, the frame's own rounding, for a diagonal tensor of powers of two); else
/// they are computed in double-double from the exact edges and rounded once, as accurate
/// as any frame's edges (slack 1, but for `2^-100` of the map's magnitudes). They are
/// scaled by a power of two, the length unit as `scale`, the determinant `det C^-1` times
/// the tet's (correctly rounded). Edges that leave the range (coordinates whose
/// differences overflow) give an infinite slack: the precise path.
pub fn mapped_tet(x: [&[f64]; 4], t: &LocalTet, k: &Tensor<3>) -> (LocalTet, f64) {
    let mut y = [[0.0; 3]; 3];
    let mut err = 0.0f64;
    for (yv, e) in y.iter_mut().zip(&t.edges) {
        let (v, bound) = k.map_bounded(e.to_array());
        *yv = v;
        err = err.max(bound);
    }
    if !(err <= SLACK * UNIT * largest(&y)) {
        (y, err) = map_exactly(x, t.scale, k);
    }
    match frame_of_mapped(&y, err, t.det, t.scale, k) {
        None => (LocalTet { edges: [DVec3::ZERO; 3], scale: t.scale, det: 0.0 }, f64::INFINITY),
        Some((inv, scale, det, slack)) => (LocalTet { edges: y.map(|v| DVec3::from_array(v) * inv), scale, det }, slack),
    }
}

/// The largest slack of an `f64` map of a tet's edges ([`mapped_tet`]), 4: the shape
/// test's radius-ratio bound widened by at most 2; beyond it the edges are mapped in
/// double-double.
pub const SLACK: f64 = 64.0;

/// The largest absolute value of the mapped edges `y`.
#[inline(always)]
fn largest(y: &[[f64; 3]; 3]) -> f64 {
    y.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// The edges of the tet with corners `x` (frame unit `scale`) mapped by `k` in
/// double-double from their exact values, rounded, and the bound on their error (the
/// rounding, `2^-53` of the largest, and `2^-100` of the map's magnitudes).
fn map_exactly(x: [&[f64]; 4], scale: f64, k: &Tensor<3>) -> ([[f64; 3]; 3], f64) {
    let inv = 1.0 / scale;
    let mut y = [[0.0; 3]; 3];
    let mut magnitude = 0.0f64;
    for (v, yv) in y.iter_mut().enumerate() {
        let e: [Dd; 3] = std::array::from_fn(|c| {
            let (hi, lo) = super::exact::two_sum(x[v + 1][c], -x[0][c]);
            Dd { hi: hi * inv, lo: lo * inv }
        });
        *yv = k.map_dd(e).map(Dd::to_f64);
        magnitude = magnitude.max(k.magnitude(e.map(|d| d.hi)));
    }
    let err = UNIT * largest(&y) + DD_ERROR * magnitude;
    (y, err)
}

/// [`mapped_tet`]'s mapped edges of [`LANES`] tets with corners `x(lane)`, frame edges
/// `e[edge]` (as [`super::tet::batch::Frames`] holds them, `[axis][lane]`) and units
/// `scale`, by `k[lane]`: the `f64` map lane by lane, side by side, with the same
/// operations, and the double-double map of the lanes that need it, one by one: the
/// mapped edges (`[lane][edge][axis]`) and their error bounds.
#[inline(always)]
pub(crate) fn map_edges_lanes<'p>(
    x: impl Fn(usize) -> [&'p [f64]; 4],
    e: [[Lanes; 3]; 3],
    scale: Lanes,
    k: &[Tensor<3>; LANES],
) -> ([[[f64; 3]; 3]; LANES], Lanes) {
    let mut l = [[0.0; LANES]; 3];
    let mut d = [[0.0; LANES]; 3];
    let mut exact = [[false; LANES]; 3];
    for (i, t) in k.iter().enumerate() {
        for b in 0..3 {
            (l[b][i], d[b][i], exact[b][i]) = (t.lower[b], t.inv_diag[b], t.exact[b]);
        }
    }
    let mut y = [[[0.0; 3]; 3]; LANES];
    let mut err = [0.0f64; LANES];
    for (v, ev) in e.iter().enumerate() {
        // Tensor::map_bounded, operation by operation
        let mut yc = [[0.0; LANES]; 3];
        let mut ec = [[0.0; LANES]; 3];
        for c in 0..3 {
            let mut s = ev[c];
            let mut es: Lanes = std::array::from_fn(|i| UNIT * ev[c][i].abs());
            for j in 0..c {
                let lc = &l[below(c, j)];
                for i in 0..LANES {
                    let t = lc[i] * yc[j][i];
                    s[i] = s[i] - t;
                    let rounding = if lc[i] == 0.0 { 0.0 } else { UNIT * t.abs() + UNIT * s[i].abs() };
                    es[i] = es[i] + (lc[i].abs() * ec[j][i] + rounding);
                }
            }
            for i in 0..LANES {
                yc[c][i] = s[i] * d[c][i];
                let rounding = if exact[c][i] { 0.0 } else { UNIT * yc[c][i].abs() };
                ec[c][i] = rounding + d[c][i].abs() * es[i];
            }
        }
        for i in 0..LANES {
            y[i][v] = [yc[0][i], yc[1][i], yc[2][i]];
            err[i] = err[i].max(ec[0][i].max(ec[1][i]).max(ec[2][i]));
        }
    }
    for i in 0..LANES {
        if !(err[i] <= SLACK * UNIT * largest(&y[i])) {
            (y[i], err[i]) = map_exactly(x(i), scale[i], &k[i]);
        }
    }
    (y, err)
}

/// [`mapped_tet`]'s frame of the mapped edges `y` (with the error bound `err`) of a tet of
/// determinant `det` and unit `scale`: the power of two that scales the edges, the mapped
/// unit, determinant and slack; `None` for edges all zero or not finite. The one
/// definition for [`mapped_tet`] and the batches.
#[inline(always)]
pub(crate) fn frame_of_mapped(y: &[[f64; 3]; 3], err: f64, det: f64, scale: f64, k: &Tensor<3>) -> Option<(f64, f64, f64, f64)> {
    let max_abs = largest(y);
    if !(max_abs > 0.0 && max_abs.is_finite() && err.is_finite()) {
        return None;
    }
    let q = exponent_of(max_abs);
    let inv = pow2(-q);
    let mapped_det = det * k.inv_det() * inv * inv * inv;
    let slack = if det.abs() >= f64::MIN_POSITIVE { err / (UNIT * max_abs) } else { f64::INFINITY };
    Some((inv, scale * pow2(q), mapped_det, slack.max(1.0)))
}

/// The error of [`map_exactly`]'s double-double map, relative to its magnitude (`2^-100`,
/// with slack for the operations' count).
const DD_ERROR: f64 = 1.0 / (1u128 << 100) as f64;

/// The unit roundoff of `f64`, `2^-53`.
const UNIT: f64 = 1.0 / (1u64 << 53) as f64;

/// The precise frame ([`precise_tet`]) of the tet with corners `x` (its frame `t`) mapped
/// by `k` into the frame `mapped` ([`mapped_tet`]): the mapped corners and determinant in
/// double-double with error bounds, in the mapped frame's unit.
pub(crate) fn precise_mapped_tet(x: [&[f64]; 4], t: &LocalTet, mapped: &LocalTet, k: &Tensor<3>) -> ([[Bd; 3]; 4], Bd) {
    let (p, det) = precise_tet(x, t.scale);
    let inv = Bd::from(t.scale / mapped.scale);
    let corners = p.map(|c| k.map(c).map(|v| v * inv));
    let d = k.inv_diag.iter().fold(det, |p, &x| p * Bd::from(x));
    (corners, d * inv * inv * inv)
}

/// The corners of the tet `x` (in R^3) mapped by `k` relative to the first, exactly, and
/// their determinant, inside [`crate::element::rational::exactly`].
pub(crate) fn exact_mapped_tet(x: [&[f64]; 4], k: &Tensor<3>) -> Option<([[Exact; 3]; 4], Exact)> {
    let (p, det) = exact_tet(x)?;
    let d = k.inv_diag.iter().fold(det, |p, &x| p * Exact::from(x));
    Some((p.map(|c| k.map(c)), d))
}

/// A triangle in R^2 with corners `x` (its frame `t`) mapped by `k`: the edges `C^-1 e` of
/// its exact edges, in double-double, rounded once and scaled by a power of two (as
/// accurate as any triangle's frame), its determinant `det C^-1` times the triangle's.
pub fn mapped_tri(x: [&[f64]; 3], t: &LocalTri, k: &Tensor<2>) -> LocalTri {
    let edge = |v: usize| -> [Dd; 2] {
        std::array::from_fn(|c| {
            let (hi, lo) = super::exact::two_sum(x[v][c], -x[0][c]);
            Dd::from(hi) + Dd::from(lo)
        })
    };
    let y = [1, 2].map(|v| k.map_dd(edge(v)).map(Dd::to_f64));
    let max_abs = y.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(max_abs > 0.0 && max_abs.is_finite()) {
        return LocalTri { edges: [DVec2::ZERO; 2], scale: t.scale, det: 0.0 };
    }
    let q = exponent_of(max_abs);
    let inv = pow2(-q);
    let edges = y.map(|v| DVec2::from_array(v) * inv);
    let unit = t.scale * inv; // from the triangle's frame to the mapped one
    LocalTri { edges, scale: pow2(q), det: t.det * k.inv_det() * unit * unit }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tensor(k: [[f64; 3]; 3]) -> Result<Tensor<3>, CoefficientProblem> {
        Tensor::<3>::new(&k.concat())
    }

    #[test]
    fn the_factor_reproduces_the_tensor() {
        let k = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.25], [0.5, -0.25, 2.0]];
        let t = tensor(k).unwrap();
        // C C^T 2^e from the stored factor
        let c: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| match i.cmp(&j) {
                std::cmp::Ordering::Greater => t.lower[below(i, j)],
                std::cmp::Ordering::Equal => 1.0 / t.inv_diag[i],
                _ => 0.0,
            })
        });
        for i in 0..3 {
            for j in 0..3 {
                let kij: f64 = (0..3).map(|l| c[i][l] * c[j][l]).sum::<f64>() * pow2(t.exponent);
                assert!((kij - k[i][j]).abs() < 1e-15 * 4.0, "{i} {j}: {kij}");
            }
        }
        // C^-1 maps C e back to e
        let e = [0.3, -1.2, 0.7];
        let ce: [f64; 3] = std::array::from_fn(|i| (0..3).map(|j| c[i][j] * e[j]).sum());
        let back = t.map(ce);
        assert!(back.iter().zip(&e).all(|(a, b)| (a - b).abs() < 1e-15));
    }

    #[test]
    fn bad_tensors_are_named() {
        let nan = tensor([[1.0, 0.0, 0.0], [0.0, f64::NAN, 0.0], [0.0, 0.0, 1.0]]);
        assert!(matches!(nan, Err(CoefficientProblem::NonFinite { entry: Some((1, 1)), .. })));
        let skew = tensor([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(matches!(skew, Err(CoefficientProblem::NotSymmetric { row: 0, col: 1, .. })), "{skew:?}");
        // symmetric up to rounding is accepted
        assert!(tensor([[1.0, 0.1, 0.0], [0.1 + 1e-16, 1.0, 0.0], [0.0, 0.0, 1.0]]).is_ok());
        match tensor([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 5.0]]) {
            Err(CoefficientProblem::NotPositiveDefinite { smallest, largest }) => {
                assert!((smallest + 1.0).abs() < 1e-12 && (largest - 5.0).abs() < 1e-12, "{smallest} {largest}");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(tensor([[0.0; 3]; 3]), Err(CoefficientProblem::NotPositiveDefinite { .. })));
        let semi = Tensor::<2>::new(&[1.0, 1.0, 1.0, 1.0]);
        assert!(matches!(semi, Err(CoefficientProblem::NotPositiveDefinite { .. })), "{semi:?}");
    }

    #[test]
    fn powers_of_two_scale_only_the_exponent() {
        let k = [[2.0, 0.5, 0.0], [0.5, 1.0, 0.25], [0.0, 0.25, 3.0]];
        let t = tensor(k).unwrap();
        for s in [-1000, -500, -1, 1, 300, 1000] {
            let scaled = tensor(k.map(|r| r.map(|x| ldexp(x, s)))).unwrap();
            assert_eq!((scaled.lower, scaled.inv_diag), (t.lower, t.inv_diag));
            assert_eq!(scaled.exponent, t.exponent + s as i32);
        }
    }

    /// A small deterministic generator.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }

        /// An SPD tensor `R diag(l) R^T`, eigenvalues from 1 to `10^decades`, a random
        /// rotation, scaled by `scale`, symmetric to the last bit.
        fn spd(&mut self, decades: f64, scale: f64) -> [f64; 9] {
            let mut q = [[0.0; 3]; 3];
            #[allow(clippy::needless_range_loop)]
            for i in 0..3 {
                for c in 0..3 {
                    q[i][c] = self.uniform() - 0.5;
                }
                for j in 0..i {
                    let d: f64 = (0..3).map(|c| q[i][c] * q[j][c]).sum();
                    let qj = q[j];
                    q[i].iter_mut().zip(qj).for_each(|(x, y)| *x -= d * y);
                }
                let n = q[i].iter().map(|x| x * x).sum::<f64>().sqrt();
                q[i].iter_mut().for_each(|x| *x /= n);
            }
            let l = [1.0, 10f64.powf(decades * self.uniform()), 10f64.powf(decades)];
            let mut k = [0.0; 9];
            for i in 0..3 {
                for j in 0..=i {
                    let v = (0..3).map(|c| q[c][i] * l[c] * q[c][j]).sum::<f64>() * scale;
                    (k[3 * i + j], k[3 * j + i]) = (v, v);
                }
            }
            k
        }
    }

    /// Tets of every shape the accuracy rule tells apart: well-shaped, slivers and caps
    /// flat down to `1e-12`, needles, far from the origin.
    fn test_tets(rng: &mut Rng) -> Vec<[[f64; 3]; 4]> {
        let mut out = vec![];
        for k in 0..400 {
            let flat = [1.0, 1.0, 1.0, 0.3, 1e-2, 1e-5, 1e-9, 1e-12][k % 8];
            let needle = if k % 7 == 0 { 1e-6 } else { 1.0 };
            let offset = [rng.uniform() * 1e3, rng.uniform(), rng.uniform() * 1e6];
            out.push(std::array::from_fn(|_| {
                let p = [rng.uniform(), rng.uniform() * needle, rng.uniform() * flat];
                std::array::from_fn(|a| p[a] + offset[a])
            }));
        }
        out
    }

    #[test]
    fn mapped_tets_keep_the_accuracy_rule_against_exact_rationals() {
        use crate::element::rational::exactly;
        use crate::element::tet::power::dual_of;
        use crate::element::tet::primal::primal_of;
        use crate::element::tet::{mapped_dual_precise, primal_precise_in, well_shaped_within, Placement};
        use crate::element::ACCURACY;
        let mut rng = Rng(11);
        let (mut float, mut precise, mut worst) = (0, 0, 0.0f64);
        for (i, x) in test_tets(&mut rng).into_iter().enumerate() {
            let k = Tensor::<3>::new(&rng.spd([0.0, 1.0, 3.0, 6.0][i % 4], 1.0)).unwrap();
            let corners = [&x[0][..], &x[1][..], &x[2][..], &x[3][..]];
            let t = crate::element::frame::local_tet(corners, &mut []);
            if t.det == 0.0 {
                continue;
            }
            let (mapped, slack) = mapped_tet(corners, &t, &k);
            let fast = well_shaped_within(&mapped, slack);
            let (p, w) = if fast {
                float += 1;
                let p = crate::element::tet::primal(&mapped);
                (p, crate::element::tet::dual(&mapped).weights)
            } else {
                precise += 1;
                let p = primal_precise_in(corners, &t, Some((&mapped, &k)));
                (p, mapped_dual_precise(corners, &t, &mapped, &k, None, Placement::Centres))
            };
            let (pe, de, we) = exactly(|| {
                let (y, det) = exact_mapped_tet(corners, &k).unwrap();
                let (pw, pd) = primal_of(y, det, Exact::from(1.0));
                let (dw, _) = dual_of(y, det, [Exact::from(0.0); 4], Placement::Centres);
                (pw.map(Exact::to_f64), pd.map(Exact::to_f64), dw.map(Exact::to_f64))
            });
            for (e, &(a, b)) in crate::element::tet::EDGES.iter().enumerate() {
                let size = (de[a] * de[b]).abs().sqrt();
                assert!((p.weights[e] - pe[e]).abs() <= ACCURACY * size, "{x:?} {fast}: primal {e}: {} vs {}", p.weights[e], pe[e]);
            }
            for c in 0..4 {
                assert!((p.diagonal[c] - de[c]).abs() <= ACCURACY * de[c].abs(), "{x:?} {fast}: diagonal {c}");
            }
            let wmax = we.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if fast {
                let err = (0..6).map(|e| (w[e] - we[e]).abs() / wmax).fold(0.0f64, f64::max);
                let perr = (0..6).map(|e| { let (a, b) = crate::element::tet::EDGES[e]; (p.weights[e] - pe[e]).abs() / (de[a] * de[b]).abs().sqrt() }).fold(0.0f64, f64::max);
                worst = worst.max(err.max(perr) / ACCURACY);
            }
            for e in 0..6 {
                assert!((w[e] - we[e]).abs() <= ACCURACY * wmax, "{x:?} {fast}: dual {e}: {} vs {}", w[e], we[e]);
            }
        }
        assert!(float > 50 && precise > 50, "{float} float, {precise} precise");
        eprintln!("{float} float, {precise} precise, worst float error {worst:e} of the accuracy");
    }

    #[test]
    fn the_mapped_primal_is_the_direct_formula() {
        // L_ab = -Vol grad(lambda_a) . K grad(lambda_b), the gradients from the normals
        let mut rng = Rng(3);
        for x in test_tets(&mut rng).into_iter().step_by(8) {
            let kv = rng.spd(2.0, 3.0);
            let k = Tensor::<3>::new(&kv).unwrap();
            let corners = [&x[0][..], &x[1][..], &x[2][..], &x[3][..]];
            let t = crate::element::frame::local_tet(corners, &mut []);
            let (mapped, _) = mapped_tet(corners, &t, &k);
            let p = crate::element::tet::primal(&mapped);
            let e = t.edges.map(|v| v * t.scale);
            let det = e[0].dot(e[1].cross(e[2]));
            let n = [(e[2] - e[0]).cross(e[1] - e[0]), e[1].cross(e[2]), e[2].cross(e[0]), e[0].cross(e[1])];
            let kn = |v: DVec3| DVec3::new(
                kv[0] * v.x + kv[1] * v.y + kv[2] * v.z,
                kv[3] * v.x + kv[4] * v.y + kv[5] * v.z,
                kv[6] * v.x + kv[7] * v.y + kv[8] * v.z,
            );
            let direct = |a: usize, b: usize| -n[a].dot(kn(n[b])) / (6.0 * det.abs());
            let scale = (0..4).fold(0.0f64, |m, a| m.max(direct(a, a).abs()));
            for (i, &(a, b)) in crate::element::tet::EDGES.iter().enumerate() {
                let got = k.values(p.weights[i]);
                assert!((got - direct(a, b)).abs() <= 1e-9 * scale, "{x:?}: {got} vs {}", direct(a, b));
            }
        }
    }

    #[test]
    fn factoring_lanes_at_once_is_factoring_each_bit_for_bit() {
        let mut rng = Rng(5);
        let mut cases: Vec<[f64; 9]> = (0..200)
            .map(|c| {
                let scale = [1.0, 1e-300, 1e300, 3.0, 1e-310][c % 5];
                rng.spd([0.0, 2.0, 6.0, 15.0][c % 4], scale)
            })
            .collect();
        // and tensors each check refuses
        cases.push([1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        cases.push([1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        cases.push([1.0, 0.0, 0.0, 0.0, f64::NAN, 0.0, 0.0, 0.0, 1.0]);
        cases.push([0.0; 9]);
        cases.push([1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        cases.push([4.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.25]);
        let (mut accepted, mut refused) = (0, 0);
        for group in cases.chunks(LANES) {
            let k: [[f64; 9]; LANES] = std::array::from_fn(|i| group[i % group.len()]);
            let (three, valid) = Tensor::<3>::factor_lanes(&k);
            let (two, valid2) = Tensor::<2>::factor_lanes(&k);
            for i in 0..LANES {
                let bits = |t: &Tensor<3>| format!("{:?}", (t.lower.map(f64::to_bits), t.inv_diag.map(f64::to_bits), t.exponent, t.power.to_bits(), t.sqrt_det.to_bits(), t.exact));
                assert_eq!(bits(&three[i]), bits(&Tensor::<3>::factor(&k[i])), "{:?}", k[i]);
                assert_eq!(valid[i], Tensor::<3>::new(&k[i]).is_ok(), "{:?}", k[i]);
                assert_eq!(format!("{:?}", two[i]), format!("{:?}", Tensor::<2>::factor(&k[i][..4])));
                assert_eq!(valid2[i], Tensor::<2>::new(&k[i][..4]).is_ok(), "{:?}", k[i]);
                if valid[i] { accepted += 1 } else { refused += 1 }
            }
        }
        assert!(accepted > 100 && refused >= 5, "{accepted} {refused}");
    }

    #[test]
    fn eigenvalues_in_closed_form() {
        let (lo, hi) = eigenvalue_range::<3>(&[[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        assert!((lo - 1.0).abs() < 1e-14 && (hi - 5.0).abs() < 1e-14, "{lo} {hi}");
        let (lo, hi) = eigenvalue_range::<2>(&[[2.0, 1.0], [1.0, 2.0]]);
        assert!((lo - 1.0).abs() < 1e-15 && (hi - 3.0).abs() < 1e-15);
    }
}
