//! Exactly rounded determinants of an element's edge vectors, for the elements whose
//! floating-point determinant cannot be trusted.
//!
//! An element's determinant (six times a tet's signed volume, twice a triangle's area) is
//! the one ill-conditioned quantity of every kernel: for a flat element it is a small
//! difference of large products, and its relative error in `f64` grows like `eps` over the
//! flatness (`1e-4` at a flatness of `1e-12`). Every value of the element is inversely
//! proportional to it (dual weights, masses, primal weights), so that error reaches all of
//! them. With the determinant rounded correctly, the rest of each kernel is accurate to a
//! few `eps` relative to the element's largest value (tested against exact rationals).
//!
//! The determinant is first computed in `f64` with a rigorous error bound (the permanent
//! of the absolute edge components times `8 eps`, which covers the rounding of the input
//! differences too); only when that bound exceeds [`DET_RTOL`] of the result is it
//! recomputed exactly, from the input coordinates: each difference `x_k - x_0` as the
//! exact sum of two doubles ([`two_sum`]), every product of three as the exact sum of four
//! ([`two_product`]), all of them summed into a floating-point expansion (Shewchuk,
//! "Adaptive precision floating-point arithmetic", 1997) whose value is then rounded.
//!
//! [`Dd`] (double-double, about 32 significant digits) is the arithmetic of the kernels'
//! precise path, with a bound on its error ([`crate::element::bounded::Bd`]): the
//! elements flatter than a float evaluation can serve are evaluated in it from their exact
//! edge vectors ([`exact_edges`]) and exact determinant ([`det3_dd`]).

use crate::element::tet::batch::{lanes, Lanes, LANES};

/// The largest accepted relative error bound of a floating-point determinant (`2^-43`,
/// about `1.1e-13`); beyond it the determinant is computed exactly.
pub const DET_RTOL: f64 = 1.0 / (1u64 << 43) as f64;

/// `8 eps` (`eps = 2^-53`): a bound on the relative rounding of a 3 x 3 determinant's
/// evaluation, inputs' differences included, against the permanent of its absolute values.
pub(crate) const DET_ERROR: f64 = 8.0 / (1u64 << 53) as f64;

/// `a + b = s + e` exactly, `s` the rounded sum.
#[inline]
pub fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bv = s - a;
    let av = s - bv;
    (s, (a - av) + (b - bv))
}

/// `a b = p + e` exactly (barring underflow), `p` the rounded product.
///
/// Dekker's product of the two halves of each factor (Veltkamp's splitting), which is exact
/// whenever its partial products neither overflow nor underflow (`|a|, |b| <= 2^995`,
/// `2^-960 <= |p| <= 2^1000`); otherwise a fused multiply-add (a function call without the
/// `fma` target feature). Both give the one exact error `ab - p`, bit for bit.
#[inline]
pub fn two_product(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    if a.abs() <= SPLIT_MAX && b.abs() <= SPLIT_MAX && (PRODUCT_MIN..=PRODUCT_MAX).contains(&p.abs()) {
        let (ah, al) = split(a);
        let (bh, bl) = split(b);
        (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
    } else {
        (p, a.mul_add(b, -p))
    }
}

/// `a = hi + lo` exactly with 26-bit halves (Veltkamp), for `|a| <= 2^995`.
#[inline]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a; // 2^27 + 1
    let hi = c - (c - a);
    (hi, a - hi)
}

/// The range where [`two_product`]'s splitting is exact.
const SPLIT_MAX: f64 = f64::from_bits(((1023 + 995) as u64) << 52);
const PRODUCT_MIN: f64 = f64::from_bits(((1023 - 960) as u64) << 52);
const PRODUCT_MAX: f64 = f64::from_bits(((1023 + 1000) as u64) << 52);

/// The most components an [`Expansion`] here holds: the 192 products of [`det3`].
const EXPANSION_LEN: usize = 192;

/// A sum of doubles held exactly: non-overlapping components in increasing magnitude.
#[derive(Debug)]
struct Expansion {
    parts: [f64; EXPANSION_LEN],
    len: usize,
}

impl Default for Expansion {
    fn default() -> Self {
        Expansion { parts: [0.0; EXPANSION_LEN], len: 0 }
    }
}

impl Expansion {
    /// Adds `b` exactly (Shewchuk's Grow-Expansion, zero components dropped).
    fn add(&mut self, b: f64) {
        let mut q = b;
        let mut kept = 0;
        for k in 0..self.len {
            let (s, e) = two_sum(q, self.parts[k]);
            q = s;
            if e != 0.0 {
                self.parts[kept] = e;
                kept += 1;
            }
        }
        self.len = kept;
        if q != 0.0 {
            self.parts[self.len] = q;
            self.len += 1;
        }
    }

    /// The components, smallest first.
    fn parts(&self) -> &[f64] {
        &self.parts[..self.len]
    }

    /// The value, rounded (summed from the smallest component: the components do not
    /// overlap, so this is within an ulp or two of the exact sum).
    fn value(&self) -> f64 {
        self.parts().iter().sum()
    }

    /// The value as a double-double (summed from the smallest component).
    fn value_dd(&self) -> Dd {
        self.parts().iter().fold(Dd::default(), |s, &c| s + Dd::from(c))
    }
}

/// A double-double number `hi + lo` (`|lo| <= ulp(hi) / 2`): about 106 bits of precision,
/// the arithmetic of the kernels' precise path. Only what the kernels need is here.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Dd {
    /// The leading part, `hi + lo` rounded to `f64`.
    pub hi: f64,
    /// The trailing part.
    pub lo: f64,
}

impl Dd {
    /// `hi + lo` renormalised.
    #[inline]
    fn new(hi: f64, lo: f64) -> Self {
        let (s, e) = two_sum(hi, lo);
        Dd { hi: s, lo: e }
    }

    /// `self c` for an `f64` `c` (to double-double precision): the exact product of the
    /// leading part (by [`two_product`], or 0 when a factor is 0, which needs no fused
    /// multiply-add), plus the trailing part's.
    #[inline]
    pub fn times(self, c: f64) -> Self {
        let (p, e) = if self.hi == 0.0 || c == 0.0 { (self.hi * c, 0.0) } else { two_product(self.hi, c) };
        Dd::new(p, e + self.lo * c)
    }

    /// The value rounded to `f64`.
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }

    /// The square root (one Newton step on the `f64` root), for `self >= 0`.
    pub fn sqrt(self) -> Self {
        if self.hi <= 0.0 {
            return Dd::default();
        }
        let s = self.hi.sqrt();
        let r = self - Dd::from(s) * Dd::from(s);
        Dd::new(s, r.hi / (2.0 * s))
    }

    /// `|self|`.
    #[inline]
    pub fn abs(self) -> Self {
        if self.hi < 0.0 || (self.hi == 0.0 && self.lo < 0.0) {
            -self
        } else {
            self
        }
    }
}

impl From<f64> for Dd {
    #[inline]
    fn from(x: f64) -> Self {
        Dd { hi: x, lo: 0.0 }
    }
}

impl std::ops::Neg for Dd {
    type Output = Dd;
    #[inline]
    fn neg(self) -> Dd {
        Dd { hi: -self.hi, lo: -self.lo }
    }
}

impl std::ops::Add for Dd {
    type Output = Dd;
    #[inline]
    fn add(self, o: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, o.hi);
        let (t, f) = two_sum(self.lo, o.lo);
        let (s, e) = two_sum(s, e + t);
        Dd::new(s, e + f)
    }
}

impl std::ops::Sub for Dd {
    type Output = Dd;
    #[inline]
    fn sub(self, o: Dd) -> Dd {
        self + -o
    }
}

impl std::ops::Mul for Dd {
    type Output = Dd;
    #[inline]
    fn mul(self, o: Dd) -> Dd {
        let (p, e) = two_product(self.hi, o.hi);
        Dd::new(p, e + (self.hi * o.lo + self.lo * o.hi))
    }
}

impl std::ops::Div for Dd {
    type Output = Dd;
    #[inline(always)]
    fn div(self, o: Dd) -> Dd {
        // a quotient and one correction step: q1 + (self - q1 o) / o
        let q1 = self.hi / o.hi;
        let r = self - o * Dd::from(q1);
        let q2 = r.hi / o.hi;
        let r = r - o * Dd::from(q2);
        Dd::new(q1, q2) + Dd::from(r.hi / o.hi)
    }
}

/// [`LANES`] double-doubles side by side: every operation is [`Dd`]'s, lane by lane, bit
/// for bit, written so that the compiler evaluates the lanes in vector registers (the
/// precise path of several elements at once).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DdLanes {
    /// The leading parts.
    pub hi: Lanes,
    /// The trailing parts.
    pub lo: Lanes,
}

/// [`two_sum`] per lane.
#[inline(always)]
fn two_sums(a: Lanes, b: Lanes) -> (Lanes, Lanes) {
    let s = lanes(|i| a[i] + b[i]);
    let bv = lanes(|i| s[i] - a[i]);
    let av = lanes(|i| s[i] - bv[i]);
    (s, lanes(|i| (a[i] - av[i]) + (b[i] - bv[i])))
}

/// [`two_product`] per lane: Dekker's product for all lanes when every lane is in its
/// exact range (the common case), else lane by lane.
#[inline(always)]
fn two_products(a: Lanes, b: Lanes) -> (Lanes, Lanes) {
    let p = lanes(|i| a[i] * b[i]);
    let exact = (0..LANES).all(|i| {
        a[i].abs() <= SPLIT_MAX && b[i].abs() <= SPLIT_MAX && (PRODUCT_MIN..=PRODUCT_MAX).contains(&p[i].abs())
    });
    if !exact {
        return (p, lanes(|i| two_product(a[i], b[i]).1));
    }
    let ca = lanes(|i| 134_217_729.0 * a[i]);
    let ah = lanes(|i| ca[i] - (ca[i] - a[i]));
    let al = lanes(|i| a[i] - ah[i]);
    let cb = lanes(|i| 134_217_729.0 * b[i]);
    let bh = lanes(|i| cb[i] - (cb[i] - b[i]));
    let bl = lanes(|i| b[i] - bh[i]);
    (p, lanes(|i| ((ah[i] * bh[i] - p[i]) + ah[i] * bl[i] + al[i] * bh[i]) + al[i] * bl[i]))
}

impl DdLanes {
    /// `hi + lo` renormalised ([`Dd`]'s constructor).
    #[inline(always)]
    fn new(hi: Lanes, lo: Lanes) -> Self {
        let (hi, lo) = two_sums(hi, lo);
        DdLanes { hi, lo }
    }

    /// The lanes as [`Dd`]s.
    pub fn get(self, i: usize) -> Dd {
        Dd { hi: self.hi[i], lo: self.lo[i] }
    }

    /// The lanes of `f(lane)`.
    pub fn from_fn(mut f: impl FnMut(usize) -> Dd) -> Self {
        let d: [Dd; LANES] = std::array::from_fn(&mut f);
        DdLanes { hi: d.map(|x| x.hi), lo: d.map(|x| x.lo) }
    }

    /// Each lane rounded to `f64`.
    #[inline(always)]
    pub fn to_f64(self) -> Lanes {
        lanes(|i| self.hi[i] + self.lo[i])
    }

    /// `|self|` per lane ([`Dd::abs`]).
    #[inline(always)]
    pub fn abs(self) -> Self {
        let negative: [bool; LANES] = std::array::from_fn(|i| self.hi[i] < 0.0 || (self.hi[i] == 0.0 && self.lo[i] < 0.0));
        DdLanes {
            hi: lanes(|i| if negative[i] { -self.hi[i] } else { self.hi[i] }),
            lo: lanes(|i| if negative[i] { -self.lo[i] } else { self.lo[i] }),
        }
    }
}

impl From<f64> for DdLanes {
    #[inline(always)]
    fn from(x: f64) -> Self {
        DdLanes { hi: [x; LANES], lo: [0.0; LANES] }
    }
}

impl std::ops::Neg for DdLanes {
    type Output = DdLanes;
    #[inline(always)]
    fn neg(self) -> DdLanes {
        DdLanes { hi: lanes(|i| -self.hi[i]), lo: lanes(|i| -self.lo[i]) }
    }
}

impl std::ops::Add for DdLanes {
    type Output = DdLanes;
    #[inline(always)]
    fn add(self, o: DdLanes) -> DdLanes {
        let (s, e) = two_sums(self.hi, o.hi);
        let (t, f) = two_sums(self.lo, o.lo);
        let (s, e) = two_sums(s, lanes(|i| e[i] + t[i]));
        DdLanes::new(s, lanes(|i| e[i] + f[i]))
    }
}

impl std::ops::Sub for DdLanes {
    type Output = DdLanes;
    #[inline(always)]
    fn sub(self, o: DdLanes) -> DdLanes {
        self + -o
    }
}

impl std::ops::Mul for DdLanes {
    type Output = DdLanes;
    #[inline(always)]
    fn mul(self, o: DdLanes) -> DdLanes {
        let (p, e) = two_products(self.hi, o.hi);
        DdLanes::new(p, lanes(|i| e[i] + (self.hi[i] * o.lo[i] + self.lo[i] * o.hi[i])))
    }
}

impl std::ops::Div for DdLanes {
    type Output = DdLanes;
    #[inline(always)]
    fn div(self, o: DdLanes) -> DdLanes {
        let of = |q: Lanes| DdLanes { hi: q, lo: [0.0; LANES] };
        let q1 = lanes(|i| self.hi[i] / o.hi[i]);
        let r = self - o * of(q1);
        let q2 = lanes(|i| r.hi[i] / o.hi[i]);
        let r = r - o * of(q2);
        DdLanes::new(q1, q2) + of(lanes(|i| r.hi[i] / o.hi[i]))
    }
}

/// `x y z` added exactly to `sum` (as the four doubles of two products).
fn add_product(sum: &mut Expansion, x: f64, y: f64, z: f64) {
    if x == 0.0 || y == 0.0 || z == 0.0 {
        return;
    }
    let (p, e) = two_product(x, y);
    for part in [two_product(p, z), two_product(e, z)] {
        sum.add(part.0);
        sum.add(part.1);
    }
}

/// The exact differences `(b - a) s` as `(hi, lo)`, `s` a power of two.
fn difference(a: f64, b: f64, s: f64) -> (f64, f64) {
    let (hi, lo) = two_sum(b, -a);
    (hi * s, lo * s)
}

/// The exact edges `x_k - x_0`, `k = 1, 2, 3`, as unevaluated sums `(hi, lo)` of two
/// doubles (to be scaled by the frame's power of two).
pub fn exact_edges(x: [[f64; 3]; 4]) -> [[(f64, f64); 3]; 3] {
    std::array::from_fn(|k| std::array::from_fn(|c| two_sum(x[k + 1][c], -x[0][c])))
}

/// `det[x1 - x0, x2 - x0, x3 - x0] s^3` rounded from its exact value, `s` a power of two
/// that keeps the scaled differences in range (the frame's scaling).
pub fn det3(x: [[f64; 3]; 4], s: f64) -> f64 {
    det3_expansion(x, s).value()
}

/// [`det3`] to double-double precision.
pub fn det3_dd(x: [[f64; 3]; 4], s: f64) -> Dd {
    det3_expansion(x, s).value_dd()
}

/// The exact value of [`det3`]'s determinant as an expansion.
fn det3_expansion(x: [[f64; 3]; 4], s: f64) -> Expansion {
    let d: [[(f64, f64); 3]; 3] = std::array::from_fn(|k| std::array::from_fn(|c| difference(x[0][c], x[k + 1][c], s)));
    let mut sum = Expansion::default();
    // the six terms of the Leibniz formula, each a product of three two-part numbers
    for (p, sign) in [([0, 1, 2], 1.0), ([1, 2, 0], 1.0), ([2, 0, 1], 1.0), ([0, 2, 1], -1.0), ([1, 0, 2], -1.0), ([2, 1, 0], -1.0)] {
        let [a, b, c] = [d[0][p[0]], d[1][p[1]], d[2][p[2]]];
        for x in [a.0, a.1] {
            for y in [b.0, b.1] {
                for z in [c.0, c.1] {
                    add_product(&mut sum, sign * x, y, z);
                }
            }
        }
    }
    sum
}

/// `det[x1 - x0, x2 - x0] s^2` rounded from its exact value (see [`det3`]).
pub fn det2(x: [[f64; 2]; 3], s: f64) -> f64 {
    let d: [[(f64, f64); 2]; 2] = std::array::from_fn(|k| std::array::from_fn(|c| difference(x[0][c], x[k + 1][c], s)));
    let mut sum = Expansion::default();
    for (p, sign) in [([0, 1], 1.0), ([1, 0], -1.0)] {
        let [a, b] = [d[0][p[0]], d[1][p[1]]];
        for x in [a.0, a.1] {
            for y in [b.0, b.1] {
                add_product(&mut sum, sign * x, y, 1.0);
            }
        }
    }
    sum.value()
}

/// The permanent of the 3 x 3 matrix of the absolute values of `rows`: the sum of the six
/// products of a determinant's expansion taken in absolute value, the scale of its
/// rounding errors.
pub fn permanent(rows: [[f64; 3]; 3]) -> f64 {
    let a = rows.map(|r| r.map(f64::abs));
    a[0][0] * (a[1][1] * a[2][2] + a[1][2] * a[2][1])
        + a[0][1] * (a[1][0] * a[2][2] + a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] + a[1][1] * a[2][0])
}

/// Whether `det`, evaluated in `f64` from (rounded) edges whose absolute values have the
/// permanent `permanent`, is within [`DET_RTOL`] of the exact determinant for certain.
#[inline]
pub fn trusted(det: f64, permanent: f64) -> bool {
    DET_ERROR * permanent <= DET_RTOL * det.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_free_transformations_are_exact() {
        let (s, e) = two_sum(1.0, 1e-20);
        assert_eq!((s, e), (1.0, 1e-20));
        let (p, e) = two_product(1.0 + f64::EPSILON, 1.0 - f64::EPSILON);
        assert_eq!(p, 1.0);
        assert_eq!(e, -f64::EPSILON * f64::EPSILON);
        // Dekker's product and the fused multiply-add agree bit for bit, splitting or not
        let mut state = 3u64;
        for _ in 0..100_000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let exponent = |k: u64| ((k % 2000) as i32 - 1000) as f64;
            let (a, b) = (
                f64::from_bits(state >> 12 | 0x3ff0_0000_0000_0000) * exponent(state >> 7).exp2(),
                -f64::from_bits(state << 12 >> 12 | 0x3ff0_0000_0000_0000) * exponent(state >> 23).exp2(),
            );
            let (p, e) = two_product(a, b);
            assert_eq!((p.to_bits(), e.to_bits()), ((a * b).to_bits(), a.mul_add(b, -(a * b)).to_bits()), "{a} {b}");
        }
    }

    #[test]
    fn a_flat_determinant_is_exact() {
        // corners on the plane z = 0 but one, lifted by 2^-60 (exact in binary), far from the
        // origin: the float determinant is all rounding, the exact one is 2^-60 * 2 (area 1)
        let o = 1e6 + 0.5;
        let x = [[o, o, 0.0], [o + 1.0, o, 0.0], [o, o + 2.0, 0.0], [o + 0.25, o + 0.5, 2f64.powi(-60)]];
        assert_eq!(det3(x, 1.0), 2.0 * 2f64.powi(-60));
        assert_eq!(det3(x, 0.5), 2.0 * 2f64.powi(-60) / 8.0);
        // coplanar exactly: zero
        let flat = [[o, o, 0.0], [o + 1.0, o, 0.0], [o, o + 2.0, 0.0], [o + 0.25, o + 0.5, 0.0]];
        assert_eq!(det3(flat, 1.0), 0.0);
        // a needle triangle one ulp of o (2^-33) high: det = 1 * 2^-33 - 0 * 2 exactly
        let tri = [[o, o], [o + 1.0, o], [o + 2.0, o + 2f64.powi(-33)]];
        assert_eq!(det2(tri, 1.0), 2f64.powi(-33));
        assert_eq!(det2([[o, o], [o + 1.0, o + 1.0], [o + 3.0, o + 3.0]], 1.0), 0.0);
    }

    #[test]
    fn double_doubles_carry_about_32_digits() {
        let third = Dd::from(1.0) / Dd::from(3.0);
        let back = third * Dd::from(3.0) - Dd::from(1.0);
        assert!(back.to_f64().abs() < 1e-31, "{back:?}");
        let x = Dd::from(1.0) + Dd::from(1e-20);
        assert_eq!((x.hi, x.lo), (1.0, 1e-20));
        assert_eq!((x - Dd::from(1.0)).to_f64(), 1e-20);
        assert_eq!((-x).abs(), x);
        let root = Dd::from(2.0).sqrt();
        assert!((root * root - Dd::from(2.0)).to_f64().abs() < 1e-31);
        let o = 1e6 + 0.5;
        let x = [[o, o, 0.0], [o + 1.0, o, 0.0], [o, o + 2.0, 0.0], [o + 0.25, o + 0.5, 2f64.powi(-60)]];
        assert_eq!(det3_dd(x, 1.0).to_f64(), 2.0 * 2f64.powi(-60));
        assert_eq!(exact_edges(x)[2][2], (2f64.powi(-60), 0.0));
    }

    #[test]
    fn lanes_of_double_doubles_are_double_doubles_bit_for_bit() {
        let mut state = 11u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let x = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.3;
            let scale = ((state % 13) as f64 * 7.0 - 40.0).exp2();
            Dd::from(x * scale) + Dd::from(x * scale * 1e-17)
        };
        for round in 0..200 {
            let a: [Dd; LANES] = std::array::from_fn(|_| next());
            let mut b: [Dd; LANES] = std::array::from_fn(|_| next());
            if round % 7 == 0 {
                b[3] = Dd::from(1e-300); // a lane outside Dekker's range
            }
            let (la, lb) = (DdLanes::from_fn(|i| a[i]), DdLanes::from_fn(|i| b[i]));
            for (lanes, scalar) in [
                (la + lb, std::array::from_fn::<Dd, LANES, _>(|i| a[i] + b[i])),
                (la - lb, std::array::from_fn(|i| a[i] - b[i])),
                (la * lb, std::array::from_fn(|i| a[i] * b[i])),
                (la / lb, std::array::from_fn(|i| a[i] / b[i])),
                (-la.abs(), std::array::from_fn(|i| -a[i].abs())),
            ] {
                for i in 0..LANES {
                    let (x, y) = (lanes.get(i), scalar[i]);
                    assert_eq!((x.hi.to_bits(), x.lo.to_bits()), (y.hi.to_bits(), y.lo.to_bits()), "{round} {i}");
                }
            }
        }
    }

    #[test]
    fn the_bound_accepts_good_and_rejects_flat_determinants() {
        assert_eq!(permanent([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, -9.0]]), 1.0 * (45.0 + 48.0) + 2.0 * (36.0 + 42.0) + 3.0 * (32.0 + 35.0));
        assert!(trusted(1.0, 6.0));
        assert!(!trusted(1e-12, 1.0));
    }
}
