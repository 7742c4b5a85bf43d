//! Exact rational arithmetic: the last resort of the accuracy rule, for the elements that
//! neither `f64` nor certified double-double can serve (a needle so thin, or so far out of
//! scale, that the scaled frame's products leave the `f64` range or cancel beyond 106
//! bits).
//!
//! An [`Exact`] number is a fraction of two **dyadic integers** (`m 2^e`, `m` an odd big
//! integer): sums, differences and products of `f64` inputs are exact, quotients are kept
//! as fractions (never reduced but for powers of two, which the exponent absorbs), and
//! nothing over- or underflows. A value is rounded to `f64` once, at the end
//! ([`Real::to_f64`](crate::element::tet::Real::to_f64), within an ulp), so that the only
//! values refused are those whose exact magnitude leaves the `f64` range.
//!
//! [`Exact`] is a `Copy` handle into a per-thread arena of fractions, so that the generic
//! kernels ([`crate::element::tet::Field`]) run on it unchanged; [`exactly`] opens the
//! arena for one computation and empties it after. It is slow (an allocation per
//! operation, numbers of hundreds to thousands of bits) and meant for a few elements.

use super::exact::Dd;
use std::cell::RefCell;
use std::cmp::Ordering;

/// A signed dyadic integer `(-1)^neg mag 2^exp`, `mag` little-endian 64-bit limbs without
/// leading zero limbs and odd (zero: no limbs).
#[derive(Debug, Clone, PartialEq, Eq)]
struct Dyadic {
    neg: bool,
    mag: Vec<u64>,
    exp: i64,
}

/// `a` shifted left by `bits`.
fn shl(a: &[u64], bits: u64) -> Vec<u64> {
    let (limbs, rem) = ((bits / 64) as usize, (bits % 64) as u32);
    let mut out = vec![0u64; limbs];
    if rem == 0 {
        out.extend_from_slice(a);
    } else {
        let mut carry = 0u64;
        for &x in a {
            out.push(x << rem | carry);
            carry = x >> (64 - rem);
        }
        if carry != 0 {
            out.push(carry);
        }
    }
    out
}

/// `a` shifted right by `bits` (the bits shifted out are zero: the caller strips them).
fn shr(a: &[u64], bits: u64) -> Vec<u64> {
    let (limbs, rem) = ((bits / 64) as usize, (bits % 64) as u32);
    let a = &a[limbs.min(a.len())..];
    let mut out: Vec<u64> = if rem == 0 {
        a.to_vec()
    } else {
        (0..a.len()).map(|i| a[i] >> rem | a.get(i + 1).map_or(0, |&x| x << (64 - rem))).collect()
    };
    trim(&mut out);
    out
}

/// Drops leading zero limbs.
fn trim(a: &mut Vec<u64>) {
    while a.last() == Some(&0) {
        a.pop();
    }
}

fn cmp_mag(a: &[u64], b: &[u64]) -> Ordering {
    a.len().cmp(&b.len()).then_with(|| a.iter().rev().cmp(b.iter().rev()))
}

fn add_mag(a: &[u64], b: &[u64]) -> Vec<u64> {
    let (a, b) = if a.len() >= b.len() { (a, b) } else { (b, a) };
    let mut out = Vec::with_capacity(a.len() + 1);
    let mut carry = false;
    for (i, &x) in a.iter().enumerate() {
        let (s, c1) = x.overflowing_add(b.get(i).copied().unwrap_or(0));
        let (s, c2) = s.overflowing_add(carry as u64);
        out.push(s);
        carry = c1 || c2;
    }
    if carry {
        out.push(1);
    }
    out
}

/// `a - b` for `a >= b`.
fn sub_mag(a: &[u64], b: &[u64]) -> Vec<u64> {
    let mut out = Vec::with_capacity(a.len());
    let mut borrow = false;
    for (i, &x) in a.iter().enumerate() {
        let (d, b1) = x.overflowing_sub(b.get(i).copied().unwrap_or(0));
        let (d, b2) = d.overflowing_sub(borrow as u64);
        out.push(d);
        borrow = b1 || b2;
    }
    trim(&mut out);
    out
}

fn mul_mag(a: &[u64], b: &[u64]) -> Vec<u64> {
    if a.is_empty() || b.is_empty() {
        return Vec::new();
    }
    let mut out = vec![0u64; a.len() + b.len()];
    for (i, &x) in a.iter().enumerate() {
        let mut carry = 0u128;
        for (j, &y) in b.iter().enumerate() {
            let t = x as u128 * y as u128 + out[i + j] as u128 + carry;
            out[i + j] = t as u64;
            carry = t >> 64;
        }
        out[i + b.len()] = carry as u64;
    }
    trim(&mut out);
    out
}

/// Trailing zero bits of a non-zero magnitude.
fn trailing_zeros(a: &[u64]) -> u64 {
    let limb = a.iter().position(|&x| x != 0).expect("non-zero");
    limb as u64 * 64 + a[limb].trailing_zeros() as u64
}

impl Dyadic {
    fn zero() -> Self {
        Dyadic { neg: false, mag: Vec::new(), exp: 0 }
    }

    fn is_zero(&self) -> bool {
        self.mag.is_empty()
    }

    /// `(-1)^neg mag 2^exp` with the trailing zero bits of `mag` moved into `exp`.
    fn normalised(neg: bool, mag: Vec<u64>, exp: i64) -> Self {
        if mag.is_empty() {
            return Dyadic::zero();
        }
        let tz = trailing_zeros(&mag);
        let mag = if tz == 0 { mag } else { shr(&mag, tz) };
        Dyadic { neg, mag, exp: exp + tz as i64 }
    }

    /// The exact value of a finite `x`.
    fn from_f64(x: f64) -> Self {
        debug_assert!(x.is_finite());
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i64;
        let fraction = bits & ((1u64 << 52) - 1);
        let (m, e) = if biased == 0 { (fraction, -1074) } else { (fraction | 1 << 52, biased - 1075) };
        Dyadic::normalised(x.is_sign_negative(), if m == 0 { Vec::new() } else { vec![m] }, e)
    }

    fn neg(mut self) -> Self {
        if !self.is_zero() {
            self.neg = !self.neg;
        }
        self
    }

    fn mul(&self, o: &Dyadic) -> Dyadic {
        if self.is_zero() || o.is_zero() {
            return Dyadic::zero();
        }
        // odd times odd is odd: already normalised
        Dyadic { neg: self.neg != o.neg, mag: mul_mag(&self.mag, &o.mag), exp: self.exp + o.exp }
    }

    fn add(&self, o: &Dyadic) -> Dyadic {
        if self.is_zero() {
            return o.clone();
        }
        if o.is_zero() {
            return self.clone();
        }
        // align on the smaller exponent
        let (lo, hi) = if self.exp <= o.exp { (self, o) } else { (o, self) };
        let shifted = shl(&hi.mag, (hi.exp - lo.exp) as u64);
        let (neg, mag) = if lo.neg == hi.neg {
            (lo.neg, add_mag(&lo.mag, &shifted))
        } else {
            match cmp_mag(&lo.mag, &shifted) {
                Ordering::Equal => return Dyadic::zero(),
                Ordering::Greater => (lo.neg, sub_mag(&lo.mag, &shifted)),
                Ordering::Less => (hi.neg, sub_mag(&shifted, &lo.mag)),
            }
        };
        Dyadic::normalised(neg, mag, lo.exp)
    }

    /// `(m, k)` with `|self| = m 2^k (1 + r)`, `m` a double-double in `[2^127, 2^128)` and
    /// `|r| < 2^-110` (the leading 128 bits); `None` for zero.
    fn leading(&self) -> Option<(Dd, i64)> {
        let top = *self.mag.last()?;
        let bits = self.mag.len() as u64 * 64 - top.leading_zeros() as u64;
        // the leading 128 bits, as an integer (the bits below are dropped)
        let t: u128 = if bits <= 128 {
            let mut v = 0u128;
            for &x in self.mag.iter().rev() {
                v = v << 64 | x as u128;
            }
            v << (128 - bits)
        } else {
            let s = shr_raw(&self.mag, bits - 128);
            s[0] as u128 | (s[1] as u128) << 64
        };
        // t rounded, and the rest (t - hi, exact in i128 by wrapping: |t - hi| < 2^75); a
        // hi of 2^128 wraps to 0
        let hi = t as f64;
        let h = if hi >= 2f64.powi(128) { 0 } else { hi as u128 };
        let lo = t.wrapping_sub(h) as i128 as f64;
        Some((Dd { hi, lo }, self.exp + bits as i64 - 128))
    }
}

/// `a >> bits` without trimming or the zero-bits assumption (for the leading bits).
fn shr_raw(a: &[u64], bits: u64) -> Vec<u64> {
    let (limbs, rem) = ((bits / 64) as usize, (bits % 64) as u32);
    let a = &a[limbs..];
    (0..a.len().max(2))
        .map(|i| {
            let x = a.get(i).copied().unwrap_or(0);
            if rem == 0 { x } else { x >> rem | a.get(i + 1).map_or(0, |&y| y << (64 - rem)) }
        })
        .collect()
}

/// `x 2^k` rounded once when the result is normal (twice at most below: subnormal values
/// are only ever compared with normal ones of their kind); `inf` beyond the range.
pub fn ldexp(x: f64, k: i64) -> f64 {
    let step = |x: f64, k: i64| x * f64::from_bits(((k + 1023) as u64) << 52);
    let mut x = x;
    let mut k = k.clamp(-3000, 3000);
    while k > 1000 {
        x = step(x, 1000);
        k -= 1000;
    }
    while k < -1000 {
        x = step(x, -1000);
        k += 1000;
    }
    step(x, k)
}

/// A fraction `num / den` of dyadic integers, `den > 0` (`den = 0`: undefined, the result of
/// a division by zero, rounded to NaN).
#[derive(Debug, Clone)]
struct Fraction {
    num: Dyadic,
    den: Dyadic,
}

impl Fraction {
    fn from_f64(x: f64) -> Self {
        Fraction { num: Dyadic::from_f64(x), den: Dyadic::from_f64(1.0) }
    }

    fn signum(&self) -> i32 {
        if self.num.is_zero() { 0 } else if self.num.neg { -1 } else { 1 }
    }

    fn add(&self, o: &Fraction) -> Fraction {
        if self.den == o.den {
            return Fraction { num: self.num.add(&o.num), den: self.den.clone() };
        }
        Fraction { num: self.num.mul(&o.den).add(&o.num.mul(&self.den)), den: self.den.mul(&o.den) }
    }

    fn mul(&self, o: &Fraction) -> Fraction {
        Fraction { num: self.num.mul(&o.num), den: self.den.mul(&o.den) }
    }

    fn div(&self, o: &Fraction) -> Fraction {
        let (num, den) = (self.num.mul(&o.den), self.den.mul(&o.num));
        if den.neg { Fraction { num: num.neg(), den: den.neg() } } else { Fraction { num, den } }
    }

    /// The value rounded to `f64` (within an ulp; `inf` beyond the range, NaN if undefined).
    fn to_f64(&self) -> f64 {
        let (m, k) = self.split();
        ldexp(m, k)
    }

    /// `(m, k)`: the value is `m 2^k` with `m` rounded to `f64` (within an ulp, `1/2 < |m|
    /// < 2`; `(0, 0)` for zero, NaN if undefined).
    fn split(&self) -> (f64, i64) {
        let Some((d, kd)) = self.den.leading() else {
            return (f64::NAN, 0);
        };
        let Some((n, kn)) = self.num.leading() else {
            return (0.0, 0);
        };
        let q = (n / d).to_f64();
        (if self.num.neg { -q } else { q }, kn - kd)
    }
}

thread_local! {
    /// The fractions of the current [`exactly`] computation, by handle.
    static ARENA: RefCell<Vec<Fraction>> = const { RefCell::new(Vec::new()) };
}

/// An exact rational number: a handle to a fraction of the current [`exactly`] scope. Use
/// it only inside that scope.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Exact(u32);

impl Exact {
    fn push(f: Fraction) -> Exact {
        ARENA.with(|a| {
            let mut a = a.borrow_mut();
            a.push(f);
            Exact((a.len() - 1) as u32)
        })
    }

    fn binary(self, o: Exact, op: impl FnOnce(&Fraction, &Fraction) -> Fraction) -> Exact {
        let f = ARENA.with(|a| {
            let a = a.borrow();
            op(&a[self.0 as usize], &a[o.0 as usize])
        });
        Exact::push(f)
    }

    fn read<T>(self, f: impl FnOnce(&Fraction) -> T) -> T {
        ARENA.with(|a| f(&a.borrow()[self.0 as usize]))
    }

    /// `-1`, `0` or `1`: the exact sign.
    pub fn signum(self) -> i32 {
        self.read(Fraction::signum)
    }

    /// The value rounded to `f64` (within an ulp): infinite beyond the `f64` range, NaN for
    /// the result of a division by zero.
    pub fn to_f64(self) -> f64 {
        self.read(Fraction::to_f64)
    }

    /// `(m, k)` with the value `m 2^k`, `m` rounded to `f64` (within an ulp, `1/2 < |m| <
    /// 2`; `(0, 0)` for zero): the value in any range, for products of values that would
    /// leave the `f64` range on their own ([`ldexp`] rounds the product once).
    pub fn split(self) -> (f64, i64) {
        self.read(Fraction::split)
    }
}

/// Runs `f` with an empty arena for [`Exact`] numbers (one scope per thread at a time),
/// and empties it after.
pub fn exactly<T>(f: impl FnOnce() -> T) -> T {
    ARENA.with(|a| a.borrow_mut().clear());
    let out = f();
    ARENA.with(|a| {
        let mut a = a.borrow_mut();
        a.clear();
        a.shrink_to(1 << 10);
    });
    out
}

impl From<f64> for Exact {
    fn from(x: f64) -> Exact {
        Exact::push(Fraction::from_f64(x))
    }
}

impl std::ops::Add for Exact {
    type Output = Exact;
    fn add(self, o: Exact) -> Exact {
        self.binary(o, Fraction::add)
    }
}

impl std::ops::Neg for Exact {
    type Output = Exact;
    fn neg(self) -> Exact {
        let f = self.read(|f| Fraction { num: f.num.clone().neg(), den: f.den.clone() });
        Exact::push(f)
    }
}

impl std::ops::Sub for Exact {
    type Output = Exact;
    fn sub(self, o: Exact) -> Exact {
        self + -o
    }
}

impl std::ops::Mul for Exact {
    type Output = Exact;
    fn mul(self, o: Exact) -> Exact {
        self.binary(o, Fraction::mul)
    }
}

impl std::ops::Div for Exact {
    type Output = Exact;
    fn div(self, o: Exact) -> Exact {
        self.binary(o, Fraction::div)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sums_and_products_of_doubles_are_exact() {
        exactly(|| {
            let (a, b) = (Exact::from(1.0), Exact::from(1e-300));
            // 1 + 1e-300 - 1 is 1e-300 exactly, and so are products far out of range
            assert_eq!((a + b - a).to_f64(), 1e-300);
            let tiny = b * b * b; // 1e-900
            assert_eq!((tiny / (b * b)).to_f64(), 1e-300);
            let huge = Exact::from(1e300) * Exact::from(1e300);
            assert_eq!(huge.to_f64(), f64::INFINITY);
            assert_eq!((huge / Exact::from(1e300)).to_f64(), 1e300);
            assert_eq!((Exact::from(1.0) / Exact::from(3.0) * Exact::from(3.0)).to_f64(), 1.0);
            assert_eq!((Exact::from(2.0) - Exact::from(2.0)).signum(), 0);
            assert_eq!((Exact::from(-0.5) * Exact::from(3.0)).to_f64(), -1.5);
            assert!((Exact::from(1.0) / Exact::from(0.0)).to_f64().is_nan());
            assert_eq!(Exact::from(f64::MIN_POSITIVE / 8.0).to_f64(), f64::MIN_POSITIVE / 8.0);
        });
    }

    #[test]
    fn rounding_is_within_an_ulp() {
        let mut state = 7u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * ((state % 41) as f64 - 20.0).exp2()
        };
        exactly(|| {
            for _ in 0..2000 {
                let (a, b, c) = (next(), next(), next());
                // (a b + c) / b in double-double is within 2^-100 of the exact value
                let expect = (Dd::from(a) * Dd::from(b) + Dd::from(c)) / Dd::from(b);
                let got = ((Exact::from(a) * Exact::from(b) + Exact::from(c)) / Exact::from(b)).to_f64();
                let e = expect.to_f64();
                assert!((got - e).abs() <= e.abs() * f64::EPSILON, "{a} {b} {c}: {got} {e}");
            }
        });
    }
}
