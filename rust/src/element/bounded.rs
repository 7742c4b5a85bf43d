//! Double-double numbers that carry a bound on their own error: the precise path of the
//! accuracy rule knows, element by element, whether its values are good to
//! [`ACCURACY`](crate::element::ACCURACY), and hands the element on to exact arithmetic
//! ([`crate::element::rational`]) when they are not.
//!
//! A [`Bd`] is a [`Dd`] value `v` with a bound `e >= |v - x|` on its distance from the exact
//! value `x` of the expression it was computed by (a running error analysis, as in Higham,
//! "Accuracy and Stability of Numerical Algorithms", 3.3): inputs are exact (`e = 0`), and
//! every operation adds what its operands' errors can do to its result plus its own
//! rounding, `U |v|` (double-double arithmetic rounds to within `3 2^-106` relative;
//! `U = 2^-100`) and `ETA` (the trailing part of a value below `2^-969` loses bits, at
//! most `2^-1074` per rounding). A quotient by a value within its bound of zero, and any
//! overflow, make the bound infinite (or NaN). The bounds are computed in `f64`; their own
//! rounding (a relative `2^-53` per operation, a few hundred operations) is far inside the
//! margin between [`CERTIFIED`] and the documented accuracy.
//!
//! [`BdLanes`] is [`LANES`] of them side by side, bit for bit (value and bound), for the
//! batched precise path.

use super::exact::{Dd, DdLanes};
use super::tet::batch::{lanes, Lanes, LANES};

/// The relative rounding bound of one double-double operation (with slack).
const U: f64 = 1.0 / (1u128 << 100) as f64;

/// The absolute rounding bound of one operation whose trailing part is subnormal.
const ETA: f64 = f64::from_bits(1 << 9); // 2^-1065, subnormal

/// The largest error a certified value may have, relative to the scale of its kind
/// (`2^-45`: the documented [`ACCURACY`](crate::element::ACCURACY) `2^-40` less the final
/// rounding to `f64` and the bounds' own rounding).
pub const CERTIFIED: f64 = 1.0 / (1u64 << 45) as f64;

/// The bound of `a + b` (or `a - b`) with value `v`.
#[inline(always)]
fn sum_bound(ea: f64, eb: f64, v: f64) -> f64 {
    ea + eb + (U * v.abs() + ETA)
}

/// The bound of `a b` with value `v` (`a`, `b` the operands' leading parts).
#[inline(always)]
fn product_bound(a: f64, ea: f64, b: f64, eb: f64, v: f64) -> f64 {
    a.abs() * eb + b.abs() * ea + ea * eb + (U * v.abs() + ETA)
}

/// The bound of `a / b` with value `v`: `|a/b - x/y| <= (ea + |v| eb) / (|b| - eb)` for
/// `|x - a| <= ea`, `|y - b| <= eb < |b|`; infinite when `b` may be zero.
#[inline(always)]
fn quotient_bound(ea: f64, b: f64, eb: f64, v: f64) -> f64 {
    let room = b.abs() - eb;
    if room > 0.0 {
        (ea + v.abs() * eb) / room + (U * v.abs() + ETA)
    } else {
        f64::INFINITY
    }
}

/// A double-double value `v` with a bound `e` on its error (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Bd {
    /// The value.
    pub v: Dd,
    /// A bound on `|v - exact|`.
    pub e: f64,
}

impl Bd {
    /// `v` with the error bound `e`.
    pub fn new(v: Dd, e: f64) -> Self {
        Bd { v, e }
    }

    /// `(hi + lo) f` for an exact double-double `hi + lo` and a power of two `f` (which may
    /// be zero or infinite, the square of a frame's scale): exact, but for what leaves the
    /// normal range (bounded by `2^-1072` below it, unbounded above).
    pub fn scaled(hi: f64, lo: f64, f: f64) -> Self {
        let (h, l) = (hi * f, lo * f);
        let lost = |x: f64, y: f64| y != 0.0 && x.abs() < f64::MIN_POSITIVE;
        let e = if !h.is_finite() || (hi != 0.0 && f == 0.0) {
            f64::INFINITY
        } else if lost(h, hi) || lost(l, lo) {
            4.0 * f64::from_bits(1)
        } else {
            0.0
        };
        Bd { v: Dd { hi: h, lo: l }, e }
    }

    /// The value rounded to `f64`.
    #[inline]
    pub fn to_f64(self) -> f64 {
        self.v.to_f64()
    }

    /// `|self|` (the same bound).
    #[inline]
    pub fn abs(self) -> Self {
        Bd { v: self.v.abs(), e: self.e }
    }

    /// The square root, for `self >= 0` (within its bound): `|sqrt(x) - sqrt(v)|` is at
    /// most `e / sqrt(v)` and at most `sqrt(e)`.
    pub fn sqrt(self) -> Self {
        let v = self.v.sqrt();
        let r = v.hi;
        let spread = if r > 0.0 { (self.e / r).min(self.e.sqrt()) } else { self.e.sqrt() };
        Bd { v, e: spread + (U * r + ETA) }
    }

    /// Whether the sign of the value is that of the exact one for certain.
    #[inline]
    pub fn sign_certain(self) -> bool {
        self.v.hi.abs() > self.e
    }

    /// The same value with an infinite bound: not to be certified.
    #[inline]
    pub fn doubtful(self) -> Self {
        Bd { v: self.v, e: f64::INFINITY }
    }
}

impl From<f64> for Bd {
    #[inline]
    fn from(x: f64) -> Self {
        Bd { v: Dd::from(x), e: 0.0 }
    }
}

impl std::ops::Neg for Bd {
    type Output = Bd;
    #[inline]
    fn neg(self) -> Bd {
        Bd { v: -self.v, e: self.e }
    }
}

impl std::ops::Add for Bd {
    type Output = Bd;
    #[inline]
    fn add(self, o: Bd) -> Bd {
        let v = self.v + o.v;
        Bd { v, e: sum_bound(self.e, o.e, v.hi) }
    }
}

impl std::ops::Sub for Bd {
    type Output = Bd;
    #[inline]
    fn sub(self, o: Bd) -> Bd {
        let v = self.v - o.v;
        Bd { v, e: sum_bound(self.e, o.e, v.hi) }
    }
}

impl std::ops::Mul for Bd {
    type Output = Bd;
    #[inline]
    fn mul(self, o: Bd) -> Bd {
        let v = self.v * o.v;
        Bd { v, e: product_bound(self.v.hi, self.e, o.v.hi, o.e, v.hi) }
    }
}

impl std::ops::Div for Bd {
    type Output = Bd;
    #[inline]
    fn div(self, o: Bd) -> Bd {
        let v = self.v / o.v;
        Bd { v, e: quotient_bound(self.e, o.v.hi, o.e, v.hi) }
    }
}

/// [`LANES`] [`Bd`]s side by side: every operation is [`Bd`]'s, lane by lane, bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BdLanes {
    /// The values.
    pub v: DdLanes,
    /// Their bounds.
    pub e: Lanes,
}

impl BdLanes {
    /// The lanes of `f(lane)`.
    pub fn from_fn(mut f: impl FnMut(usize) -> Bd) -> Self {
        let b: [Bd; LANES] = std::array::from_fn(&mut f);
        BdLanes { v: DdLanes::from_fn(|i| b[i].v), e: b.map(|x| x.e) }
    }

    /// Lane `i` as a [`Bd`].
    pub fn get(self, i: usize) -> Bd {
        Bd { v: self.v.get(i), e: self.e[i] }
    }

    /// `|self|` per lane.
    #[inline(always)]
    pub fn abs(self) -> Self {
        BdLanes { v: self.v.abs(), e: self.e }
    }
}

impl From<f64> for BdLanes {
    #[inline(always)]
    fn from(x: f64) -> Self {
        BdLanes { v: DdLanes::from(x), e: [0.0; LANES] }
    }
}

impl std::ops::Neg for BdLanes {
    type Output = BdLanes;
    #[inline(always)]
    fn neg(self) -> BdLanes {
        BdLanes { v: -self.v, e: self.e }
    }
}

impl std::ops::Add for BdLanes {
    type Output = BdLanes;
    #[inline(always)]
    fn add(self, o: BdLanes) -> BdLanes {
        let v = self.v + o.v;
        BdLanes { v, e: lanes(|i| sum_bound(self.e[i], o.e[i], v.hi[i])) }
    }
}

impl std::ops::Sub for BdLanes {
    type Output = BdLanes;
    #[inline(always)]
    fn sub(self, o: BdLanes) -> BdLanes {
        let v = self.v - o.v;
        BdLanes { v, e: lanes(|i| sum_bound(self.e[i], o.e[i], v.hi[i])) }
    }
}

impl std::ops::Mul for BdLanes {
    type Output = BdLanes;
    #[inline(always)]
    fn mul(self, o: BdLanes) -> BdLanes {
        let v = self.v * o.v;
        BdLanes { v, e: lanes(|i| product_bound(self.v.hi[i], self.e[i], o.v.hi[i], o.e[i], v.hi[i])) }
    }
}

impl std::ops::Div for BdLanes {
    type Output = BdLanes;
    #[inline(always)]
    fn div(self, o: BdLanes) -> BdLanes {
        let v = self.v / o.v;
        BdLanes { v, e: lanes(|i| quotient_bound(self.e[i], o.v.hi[i], o.e[i], v.hi[i])) }
    }
}

/// The values rounded to `f64` if every bound is within [`CERTIFIED`] of `scale(i)`, the
/// scale of value `i`'s kind (and finite); `None` otherwise.
pub fn certified<const K: usize>(values: [Bd; K], scale: impl Fn(usize) -> f64) -> Option<[f64; K]> {
    let ok = (0..K).all(|i| values[i].e <= CERTIFIED * scale(i) && values[i].v.hi.is_finite());
    ok.then(|| values.map(Bd::to_f64))
}

/// The largest `|value|` of `values` (the scale of a kind whose values are all measured
/// against the largest).
pub fn largest(values: &[Bd]) -> f64 {
    values.iter().fold(0.0, |m, x| m.max(x.v.hi.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_cover_the_error_and_grow_with_cancellation() {
        // (1 + 2^-80) - 1 is exact: a tiny bound; 1 / 3 * 3 - 1 is within its bound of 0
        let one = Bd::from(1.0);
        let x = (one + Bd::from(2f64.powi(-80))) - one;
        assert_eq!(x.to_f64(), 2f64.powi(-80));
        assert!(x.e < 1e-29);
        let y = one / Bd::from(3.0) * Bd::from(3.0) - one;
        assert!(y.to_f64().abs() <= y.e && y.e < 1e-29 && !y.sign_certain());
        // a quotient by something that may be zero: unbounded
        assert_eq!((one / y).e, f64::INFINITY);
        // within 2^-45 of a kind whose largest value is 1, not of its own size
        assert!(certified([x, one], |_| 1.0).is_some());
        assert!(certified([x], |_| 2f64.powi(-80)).is_none());
        assert!(certified([x, one / y], |_| 1.0).is_none());
        // tiny values: the trailing part's underflow is in the bound
        let tiny = Bd::from(1e-300) * Bd::from(1e-10);
        assert!(tiny.e >= ETA);
        assert!(Bd::from(4.0).sqrt().to_f64() == 2.0 && Bd::from(4.0).sqrt().e < 1e-29);
    }

    #[test]
    fn lanes_carry_the_bounds_of_single_values_bit_for_bit() {
        let mut state = 5u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let x = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.3;
            Bd::new(Dd::from(x) + Dd::from(x * 1e-17), x.abs() * 1e-25)
        };
        for _ in 0..200 {
            let a: [Bd; LANES] = std::array::from_fn(|_| next());
            let b: [Bd; LANES] = std::array::from_fn(|_| next());
            let (la, lb) = (BdLanes::from_fn(|i| a[i]), BdLanes::from_fn(|i| b[i]));
            for (lanes, scalar) in [
                (la + lb, std::array::from_fn::<Bd, LANES, _>(|i| a[i] + b[i])),
                (la - lb, std::array::from_fn(|i| a[i] - b[i])),
                (la * lb, std::array::from_fn(|i| a[i] * b[i])),
                (la / lb, std::array::from_fn(|i| a[i] / b[i])),
                (-la.abs(), std::array::from_fn(|i| -a[i].abs())),
            ] {
                for i in 0..LANES {
                    let (x, y) = (lanes.get(i), scalar[i]);
                    assert_eq!((x.v.hi.to_bits(), x.v.lo.to_bits(), x.e.to_bits()), (y.v.hi.to_bits(), y.v.lo.to_bits(), y.e.to_bits()));
                }
            }
        }
    }
}
