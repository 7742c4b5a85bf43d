//! The precise path of the accuracy rule for derivatives: the gradient of one tet's
//! pairing `sum_e dw[e] w_e + sum_a dm[a] m_a + dv Vol` (as [`Vjp`](super::Vjp) computes
//! it in `f64`) by forward mode, for the tets whose values take the precise path.
//!
//! A [`Jet`] carries a value and its partial derivatives with respect to the nine frame
//! coordinates of corners 1 to 3 and the three vertex weights of corners 1 to 3 (relative
//! to corner 0, in the frame's units); run through the closed forms of the primal and the
//! dual (the same generic code as the values: [`crate::element::tet::Field`]), it gives the
//! gradient of every value at once. In double-double with error bounds
//! ([`Bd`]) the gradient is kept when its bounds are within
//! [`CERTIFIED`](crate::element::bounded::CERTIFIED) of its largest component (corners and
//! weights measured separately); otherwise it is computed in exact rational arithmetic
//! from the input coordinates ([`Exact`]; tets in R^3), and rounded once.

use super::Gradient;
use crate::element::bounded::Bd;
use crate::element::exact::two_sum;
use crate::element::frame::{precise_tet, LocalTet};
use crate::element::rational::{exactly, Exact};
use crate::element::tet::power::{cross, dot, dual_of, exact_tet, Field, Real, V3};
use crate::element::tet::primal::primal_of;
use crate::element::tet::Placement;
use glam::DVec3;
use std::cmp::Ordering;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Partial derivatives per [`Jet`]: corners 1 to 3 (three coordinates each), then the
/// vertex weights of corners 1 to 3.
const N: usize = 12;

/// A value and its partial derivatives (see the module docs), in any [`Field`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Jet<R> {
    v: R,
    d: [R; N],
}

impl<R: Field> Jet<R> {
    /// `v` with the derivative 1 in direction `k`.
    fn variable(v: R, k: usize) -> Self {
        let mut d = [R::from(0.0); N];
        d[k] = R::from(1.0);
        Jet { v, d }
    }
}

impl<R: Field> From<f64> for Jet<R> {
    fn from(x: f64) -> Self {
        Jet { v: R::from(x), d: [R::from(0.0); N] }
    }
}

impl<R: Field> Add for Jet<R> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Jet { v: self.v + o.v, d: std::array::from_fn(|k| self.d[k] + o.d[k]) }
    }
}

impl<R: Field> Sub for Jet<R> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Jet { v: self.v - o.v, d: std::array::from_fn(|k| self.d[k] - o.d[k]) }
    }
}

impl<R: Field> Neg for Jet<R> {
    type Output = Self;
    fn neg(self) -> Self {
        Jet { v: -self.v, d: self.d.map(|x| -x) }
    }
}

impl<R: Field> Jet<R> {
    /// The product rule.
    fn product(self, o: Self) -> Self {
        Jet { v: self.v * o.v, d: std::array::from_fn(|k| self.v * o.d[k] + self.d[k] * o.v) }
    }

    /// The quotient rule, `(a' - q b') / b` with `q = a / b`.
    fn quotient(self, o: Self) -> Self {
        let q = self.v / o.v;
        Jet { v: q, d: std::array::from_fn(|k| (self.d[k] - q * o.d[k]) / o.v) }
    }
}

impl<R: Field> Mul for Jet<R> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        self.product(o)
    }
}

impl<R: Field> Div for Jet<R> {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        self.quotient(o)
    }
}

impl<R: Field> Field for Jet<R> {
    fn oriented(self, det: Self) -> Self {
        Jet { v: self.v.oriented(det.v), d: self.d.map(|x| x.oriented(det.v)) }
    }
}

impl<R: Real> Real for Jet<R> {
    fn to_f64(self) -> f64 {
        self.v.to_f64()
    }

    fn sign_certain(self) -> bool {
        self.v.sign_certain()
    }

    fn doubtful(self) -> Self {
        Jet { v: self.v.doubtful(), d: self.d.map(R::doubtful) }
    }

    fn compare(self, other: Self) -> Ordering {
        self.v.compare(other.v)
    }
}

/// What the gradient is of: the cotangents of the primal and dual weights (the affine
/// family's shares already applied), of the circumcentric cell volumes and of the volume.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pairing {
    pub primal: Option<[f64; 6]>,
    pub dual: Option<[f64; 6]>,
    pub cells: Option<[f64; 4]>,
    pub volume: f64,
}

/// The pairing's gradient in a frame of scale `s` (corners `p`, `p[0] = 0`, determinant
/// `det`, vertex weights `w` relative to corner 0; all in the frame's units) as
/// `(corners 1..3 in user units per frame axis, weights 1..3 per user weight)`, each
/// summed in `R`.
fn gradient_of<R: Real>(p: [V3<R>; 4], det: R, w: [R; 4], s: f64, pairing: &Pairing) -> ([R; 9], [R; 3]) {
    let jet = |v: R, k: usize| Jet::variable(v, k);
    let zero = Jet::<R>::from(0.0);
    let x: [V3<Jet<R>>; 4] = std::array::from_fn(|j| {
        if j == 0 { [zero; 3] } else { std::array::from_fn(|c| jet(p[j][c], 3 * (j - 1) + c)) }
    });
    // the determinant's value as given (rounded from the exact one), its derivatives
    // from the corners
    let det = Jet { v: det, d: dot(x[1], cross(x[2], x[3])).d };
    let w: [Jet<R>; 4] = std::array::from_fn(|i| if i == 0 { zero } else { jet(w[i], 9 + i - 1) });
    let r = |x: f64| R::from(x);
    // d(user value) / d(user coordinate) = scale^(k - 1) d(frame value) / d(frame
    // coordinate) for a value of length^k; per user weight, scale^(k - 2)
    let (corner_mass, weight_weight, weight_mass) = (r(s * s), r(1.0 / s), r(s));
    let mut g = [r(0.0); N];
    let mut add = |cot: f64, value: Jet<R>, mass: bool| {
        for (k, gk) in g.iter_mut().enumerate() {
            let factor = match (mass, k < 9) {
                (false, true) => r(1.0),
                (false, false) => weight_weight,
                (true, true) => corner_mass,
                (true, false) => weight_mass,
            };
            *gk = *gk + r(cot) * value.d[k] * factor;
        }
    };
    if let Some(dw) = pairing.primal {
        let (weights, _) = primal_of(x, det, Jet::from(1.0));
        dw.iter().zip(weights).for_each(|(&c, v)| add(c, v, false));
    }
    if pairing.dual.is_some() || pairing.cells.is_some() {
        let (weights, cells) = dual_of(x, det, w, Placement::Centres);
        let (dw, dm) = (pairing.dual.unwrap_or([0.0; 6]), pairing.cells.unwrap_or([0.0; 4]));
        dw.iter().zip(weights).for_each(|(&c, v)| add(c, v, false));
        dm.iter().zip(cells).for_each(|(&c, v)| add(c, v, true));
    }
    if pairing.volume != 0.0 {
        add(pairing.volume, det.oriented(det) / Jet::from(6.0), true);
    }
    (std::array::from_fn(|k| g[k]), [g[9], g[10], g[11]])
}

/// The [`Gradient`] from the gradients of corners 1 to 3 and of weights 1 to 3 (corner 0
/// and weight 0: minus their sums, translation and constant-weight invariance).
fn assembled(corners: [f64; 9], weights: [f64; 3]) -> Gradient {
    let c = [0, 1, 2].map(|j| DVec3::new(corners[3 * j], corners[3 * j + 1], corners[3 * j + 2]));
    let [w1, w2, w3] = weights;
    Gradient { corners: [-(c[0] + c[1] + c[2]), c[0], c[1], c[2]], weights: [-(w1 + w2 + w3), w1, w2, w3] }
}

/// The gradient of `pairing` for the tet with input corners `x` (`t` their frame, the
/// corners' vertex weights `weights`), in the frame's axes as [`Vjp::finish`](super::Vjp)
/// gives it: in double-double if the bounds certify it, else exactly (R^3). `None` for an
/// immersed tet that double-double cannot serve.
pub(crate) fn precise_gradient(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>, pairing: &Pairing) -> Option<Gradient> {
    certified_gradient(x, t, weights, pairing).or_else(|| exact_gradient(x, weights, pairing))
}

/// The values of `v` if their bounds are within [`CERTIFIED`] of the largest.
fn certify<const K: usize>(v: [Bd; K]) -> Option<[f64; K]> {
    crate::element::bounded::certified(v, |_| crate::element::bounded::largest(&v))
}

fn certified_gradient(x: [&[f64]; 4], t: &LocalTet, weights: Option<&[f64; 4]>, pairing: &Pairing) -> Option<Gradient> {
    let (p, det) = precise_tet(x, t.scale);
    let inv = 1.0 / t.scale;
    let w = weights.map_or([Bd::default(); 4], |w| {
        w.map(|wi| {
            let (hi, lo) = two_sum(wi, -w[0]);
            Bd::scaled(hi, lo, inv * inv)
        })
    });
    let (corners, weights) = gradient_of(p, det, w, t.scale, pairing);
    Some(assembled(certify(corners)?, certify(weights)?))
}

fn exact_gradient(x: [&[f64]; 4], weights: Option<&[f64; 4]>, pairing: &Pairing) -> Option<Gradient> {
    exactly(|| {
        let (p, det) = exact_tet(x)?;
        let w = weights.map_or([Exact::from(0.0); 4], |w| w.map(|wi| Exact::from(wi) - Exact::from(w[0])));
        let (corners, weights) = gradient_of(p, det, w, 1.0, pairing);
        Some(assembled(corners.map(Exact::to_f64), weights.map(Exact::to_f64)))
    })
}
