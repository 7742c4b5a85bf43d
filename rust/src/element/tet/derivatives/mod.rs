//! Derivatives of the per-tet kernels: vector-Jacobian products (reverse mode), derived by
//! hand.
//!
//! For one tet with corners `x_0..x_3` (and, for a weighted dual, vertex weights `omega_i`)
//! and cotangents `dw` on its six edge weights (local order [`EDGES`](super::EDGES)), `dm`
//! on its four corner masses and `dv` on its volume, a [`Vjp`] computes the gradient of the
//! scalar
//!
//! ```text
//! L = sum_e dw[e] * w_e  +  sum_a dm[a] * m_a  +  dv * Vol
//! ```
//!
//! with respect to the four corner positions and the four vertex weights. Every term is
//! optional and they can be mixed: add the kernels a caller needs to one [`Vjp`] (they
//! share the tet's face normals and determinant, and the final back-propagation into the
//! corners is done once, by [`Vjp::finish`]).
//!
//! | kernel (forward)                                              | adjoint            |
//! |---------------------------------------------------------------|--------------------|
//! | [`primal_weights`](super::primal_weights)                     | [`Vjp::primal`]    |
//! | [`dual`](super::dual) (weights, circumcentric cell volumes)   | [`Vjp::dual`] `(None, ..)` |
//! | [`power_dual`](super::power_dual)`(t, Some(w), Placement::Centres)` | [`Vjp::dual`] `(Some(w), ..)` |
//! | [`volume`](super::volume); barycentric and FEM masses        | [`Vjp::volume`]    |
//! | affine weights `(1 - t) primal + t dual`                      | `primal((1 - t) dw)` and `dual(None, t dw, ..)` |
//!
//! Masses that are multiples of the volume are composed by the caller: the barycentric mass
//! `Vol / 4` at every corner gives `dv = (dm_0 + dm_1 + dm_2 + dm_3) / 4`; the consistent FEM
//! mass `M_ab = Vol (1 + delta_ab) / 20` gives `dv = sum_ab dM_ab (1 + delta_ab) / 20`.
//! The barycentric boundary fix ([`Placement::Centroids`](super::Placement::Centroids)) is not
//! covered.
//!
//! # Units and frames
//! A [`LocalTet`] holds the edges `(x_k - x_0) / scale` with `scale` a power of two, in an
//! orthonormal frame of the tet's own 3-space. The gradients returned are those of the
//! **user-unit** values (weights in length, volumes in length^3) with respect to
//! **user-unit** coordinates (and user weights, in length^2), expressed in the axes of the
//! local frame. The power of two is handled inside: the gradient of a weight is
//! scale-invariant, that of a volume scales like `scale^2`, that of a weight with respect to
//! a vertex weight like `1 / scale`.
//!
//! * `dim = 3`: the local frame's axes are the user's axes (only the power of two is
//!   divided out), so [`Gradient::corners`] is the gradient with respect to the points.
//! * `dim > 3` (an immersed tet): every kernel is invariant under orthogonal maps, so it is
//!   a function `F(G)` of the Gram matrix `G = E^T E` of the edge matrix `E = [x_1 - x_0,
//!   x_2 - x_0, x_3 - x_0]` (d x 3). With `E = Q R` (`Q` the d x 3 orthonormal frame, `R`
//!   the local edges), `dF/dE = 2 E S = Q (2 R S) = Q dF/dR` (`S` the symmetrised `dF/dG`):
//!   the gradient in R^d is the local gradient mapped back with the frame basis,
//!   `g_user = Q g_local` for every corner ([`to_ambient`]). It has no component normal to
//!   the tet's 3-space, which is right: such a motion changes `G` only at second order.
//!   [`local_tet`](crate::element::frame::local_tet) leaves `Q` in its scratch (rows `q_0, q_1, q_2`).
//!
//! Weighted duals take the weights as the kernels do, in the frame's units:
//! `(omega_i - omega_0) / scale^2`. The weight gradient [`Gradient::weights`] is with
//! respect to the user's `omega_i` (all four, summing to zero: adding a constant to every
//! weight changes nothing). The corner gradients sum to zero (translation invariance): the
//! gradient of `x_0` is set to minus the sum of the others.
//!
//! # For a driver
//! Per tet, as for assembly: `local_tet` (keep its scratch when `dim > 3`), the tet's
//! scaled weights `(omega_i - omega_0) / scale^2` if the dual is weighted, the cotangents
//! gathered from the caller's per-edge / per-vertex cotangents (for the Dirichlet energy
//! `E = -f^T L f = sum_edges w_ij (f_i - f_j)^2`, `dw_e = (f_a - f_b)^2` per tet edge),
//! one [`Vjp`], [`Vjp::finish`], [`to_ambient`] when `dim > 3`, then a scatter-add of the
//! four corner gradients (and four weight gradients) into per-vertex sums. For bitwise
//! determinism under threads, give every tet its own output slot and reduce the slots of
//! each vertex in a fixed order, as the assembly does. Degenerate tets must be caught
//! before (see below); tets under the barycentric boundary fix are not covered.
//!
//! # What is differentiated
//! With `n_l` the face normal opposite corner `l` (`n_l / det` the gradient of the
//! barycentric coordinate `lambda_l`, `|n_l|` twice the face's area, `det` six times the
//! signed volume,
//! `sigma = sign(det)`), all in the scaled frame with `x_0 = 0`:
//!
//! * volume: `Vol = sigma det / 6`, and `d det / d x_l = n_l` (all four corners).
//! * primal: `w_ab = -(n_a . n_b) / (6 |det|)`.
//! * dual, weighted or not, in a closed form equal to the signed pieces of
//!   [`power_dual`](super::power_dual) (checked by the tests): with `c` the
//!   tet's power center (`2 e_k . c = |e_k|^2 + omega_0 - omega_k`, so
//!   `c = sum_k r_k n_k / (2 det)`), `mu_l = lambda_l(c) |det| = sigma n_l . (c - x_f)`
//!   (`x_f` a corner of face `l`) and, for edge `ab` with opposite corners `k, l`,
//!
//!   ```text
//!   D_k = (x_a - x_k) . (x_b - x_k) + omega~_k - omega_k,
//!   omega~_k = omega_a + t_k (omega_b - omega_a),  t_k = (x_b - x_a).(x_k - x_a) / |ab|^2
//!   w_ab = D_k mu_l / (4 |n_l|^2) + D_l mu_k / (4 |n_k|^2)
//!   m_a  = sum over edges ab at a of (|ab|^2 + omega_a - omega_b) w_ab / 6
//!   ```
//!
//!   (`omega~_k` is the weight interpolated linearly along `ab` at the foot of `x_k`).
//!   Derivation: the dual face of `ab` inside the tet is the quadrilateral `c_ab, c_abk, c,
//!   c_abl`, perpendicular to `ab`; its triangle `c_ab, c_abk, c` has a right angle at
//!   `c_abk`, with legs `h2 = lambda^abk_k(c_abk) |n_l| / |ab|` (the face's power center,
//!   towards `k`) and `h3 = mu_l / |n_l|` (the tet's, towards `l`). The face's barycentric
//!   coordinate is `lambda^abk_k = |ab|^2 D_k / (2 |n_l|^2)`, so the triangle's area over
//!   `|ab|` is `D_k mu_l / (4 |n_l|^2)`. The edge's power point lies at distance
//!   `(|ab|^2 + omega_a - omega_b) / (2 |ab|)` from `x_a`, the height of the pyramids at
//!   `a`. Without weights `D_k = (x_a - x_k).(x_b - x_k)` and this is [`dual`](super::dual).
//!
//! The reverse pass applies the chain rule to these expressions in reverse order (adjoints
//! of the weights, then of `D`, `mu`, `|n_l|^2`, `c`, `r_k`, then of the normals and the
//! determinant). The adjoints of all dot products of corners are collected in a 3 x 3
//! Gram adjoint and pulled back at the end (`xbar_k += sum_j (Gbar_kj + Gbar_jk) x_j`), a
//! few scalar additions per dot instead of three vector updates. The normals' adjoints are pulled back once, in [`Vjp::finish`]: with
//! `n_0 = -(n_1 + n_2 + n_3)`, `n_1 = e_2 x e_3` and cyclically, and `h_l = nbar_l -
//! nbar_0`, the edge adjoints are `ebar_1 = h_2 x e_3 + e_2 x h_3` and cyclically, plus
//! `detbar n_k`.
//!
//! # Why by hand, not by dual numbers
//! Forward mode (dual numbers over a generic scalar) needs one tangent per input: 9
//! coordinates (12 with the weights), so a gradient costs about 9-12 forward passes' worth
//! of tangent arithmetic, while reverse mode costs a small constant times the forward pass
//! whatever the number of inputs. Measured (`cargo bench --bench kernels`; one core of a
//! shared machine, so ratios are reliable to about +-20%; the dual-number primal is the
//! test `forward_mode_agrees_with_reverse_mode`'s implementation, timed once):
//!
//! | VJP against its forward kernel                       | ratio     |
//! |------------------------------------------------------|-----------|
//! | primal                                               | 1.2-1.4x  |
//! | dual (weights and cell volumes)                      | 2.2-2.5x  |
//! | weighted dual (against the explicit-centers forward) | 0.45x     |
//! | affine weights and circumcentric mass, one [`Vjp`]   | 1.5-1.8x  |
//! | volume (three cross products against one; a few ns)  | 2-5x      |
//! | primal by 9-tangent dual numbers (for comparison)    | 6-12x     |
//!
//! Over a mesh (`bench::mesh_timing`: 384 000 tets, one thread, gathering the cotangents
//! and scattering the gradients like a driver), the gradient of `-f^T L f + g^T M` (dual,
//! circumcentric) costs about half of the one-shot assembly of `L`.
//!
//! Accuracy: the gradients are the forward expressions differentiated exactly, with
//! forward-like rounding. They agree with fourth-order central differences to about 1e-10
//! relative (worst case over random tets of quality at least 0.05, scales 1e-3 to 1e3, in
//! R^3 and R^4); the differences, not the gradients, limit that number.
//!
//! Pure functions: no allocation, no indices, no threads; the same input gives the same
//! bits. A degenerate tet (`det = 0`) gives infinities or NaN; the caller checks
//! [`is_degenerate`](super::is_degenerate) as for the forward kernels.
//!
//! # Example
//! ```
//! use tetlap::element::tet::{self, derivatives::Vjp};
//! let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.2, 0.3, 1.0]];
//! let t = tetlap::local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
//! // d/dx of w_01 (primal) + 2 Vol, in one pass
//! let mut vjp = Vjp::new(&t);
//! vjp.primal([1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! vjp.volume(2.0);
//! let g = vjp.finish();
//! // compare with a central difference in x_3.z
//! let f = |z: f64| {
//!     let mut y = x;
//!     y[3][2] = z;
//!     let t = tetlap::local_tet([&y[0], &y[1], &y[2], &y[3]], &mut []);
//!     tet::primal_weights(&t)[0] + 2.0 * tet::volume(&t)
//! };
//! let h = 1e-6;
//! let fd = (f(1.0 + h) - f(1.0 - h)) / (2.0 * h);
//! assert!((g.corners[3].z - fd).abs() < 1e-8);
//! // translation invariance: the corner gradients sum to zero
//! let sum = g.corners.iter().copied().sum::<glam::DVec3>();
//! assert!(sum.length() < 1e-15);
//! ```

/// Runs `body` once per local edge, with `e`, its corners `(a, b)` and the opposite corners
/// `(k, l)` bound to constants (`EDGES` and `OPPOSITE` order): unrolled, so that the
/// small arrays indexed by corners stay in registers instead of memory (a third faster).
macro_rules! each_edge {
    (|$e:ident, $a:ident, $b:ident, $k:ident, $l:ident| $body:block) => {
        each_edge!(@ $e $a $b $k $l $body;
            0 0 1 2 3; 1 0 2 1 3; 2 0 3 1 2; 3 1 2 0 3; 4 1 3 0 2; 5 2 3 0 1)
    };
    (@ $e:ident $a:ident $b:ident $k:ident $l:ident $body:block;
        $($ev:literal $av:literal $bv:literal $kv:literal $lv:literal);*) => {
        $({
            let ($e, $a, $b, $k, $l): (usize, usize, usize, usize, usize) = ($ev, $av, $bv, $kv, $lv);
            debug_assert_eq!((crate::element::tet::EDGES[$e], crate::element::tet::OPPOSITE[$e]), (($a, $b), ($k, $l)));
            $body
        })*
    };
}

mod dual;
pub(crate) mod precise;
mod primal;

#[cfg(test)]
mod tests;

use crate::element::frame::LocalTet;
use glam::DVec3;

use super::Frame;

/// Reverse-mode derivative of one tet's kernels: the tet's shared forward quantities and
/// the adjoints accumulated so far.
///
/// Build it with [`Vjp::new`], add the kernels with their cotangents ([`Vjp::primal`],
/// [`Vjp::dual`], [`Vjp::volume`]; any number, in any order), then [`Vjp::finish`].
#[derive(Debug, Clone)]
pub struct Vjp {
    /// Corners in the scaled frame, `x[0] = 0`.
    x: [DVec3; 4],
    /// Face normals as in `Frame` (`normals[l] / det` = grad lambda_l).
    normals: [DVec3; 4],
    /// `6 * signed volume` in the scaled frame.
    det: f64,
    /// The power of two divided out of the coordinates.
    scale: f64,
    /// Adjoint of each normal.
    bar_normals: [DVec3; 4],
    /// Adjoint of `det`.
    bar_det: f64,
    /// Direct adjoints of the corners 1..3 (index 0 unused: recovered by translation
    /// invariance).
    bar_x: [DVec3; 4],
    /// Adjoints of the scaled vertex weights 1..3 (index 0 likewise unused).
    bar_w: [f64; 4],
}

/// The gradient of `L` with respect to one tet's corners and vertex weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gradient {
    /// `dL / dx_i` for the four corners, in user units, in the axes of the tet's local
    /// frame (the user's axes for `dim = 3`; see [`to_ambient`] otherwise). Sums to zero.
    pub corners: [DVec3; 4],
    /// `dL / d omega_i` for the four user vertex weights (length^2); zero unless a weighted
    /// dual was added. Sums to zero.
    pub weights: [f64; 4],
}

impl Vjp {
    /// The forward quantities of tet `t` shared by every kernel (face normals and
    /// determinant), with zero adjoints.
    pub fn new(t: &LocalTet) -> Self {
        let f = Frame::new(t);
        Vjp {
            x: f.x,
            normals: f.normals,
            det: f.det,
            scale: t.scale,
            bar_normals: [DVec3::ZERO; 4],
            bar_det: 0.0,
            bar_x: [DVec3::ZERO; 4],
            bar_w: [0.0; 4],
        }
    }

    /// Pulls the accumulated adjoints back to the corners and the vertex weights.
    pub fn finish(self) -> Gradient {
        let [_, e1, e2, e3] = self.x;
        let n = self.normals;
        // n_0 = -(n_1 + n_2 + n_3): its adjoint moves to the other three.
        let [h1, h2, h3] = [1, 2, 3].map(|l| self.bar_normals[l] - self.bar_normals[0]);
        let d = self.bar_det;
        // n_1 = e_2 x e_3, n_2 = e_3 x e_1, n_3 = e_1 x e_2; for n = u x v with adjoint h,
        // ubar = v x h and vbar = h x u. And d det / d e_k = n_k.
        let g1 = self.bar_x[1] + h2.cross(e3) + e2.cross(h3) + d * n[1];
        let g2 = self.bar_x[2] + h3.cross(e1) + e3.cross(h1) + d * n[2];
        let g3 = self.bar_x[3] + h1.cross(e2) + e1.cross(h2) + d * n[3];
        // The scaled weights are (omega - omega_0) / scale^2 and the user values carry one
        // more factor scale (see `Vjp::dual`): d L / d omega = bar_w / scale.
        let inv = 1.0 / self.scale;
        let [w1, w2, w3] = [1, 2, 3].map(|k| self.bar_w[k] * inv);
        Gradient { corners: [-(g1 + g2 + g3), g1, g2, g3], weights: [-(w1 + w2 + w3), w1, w2, w3] }
    }
}

/// Gradient of `sum_e dw[e] * w_e` (primal weights) with respect to the four corners.
///
/// Shorthand for [`Vjp::primal`] alone; see the [module docs](self) for units and frames.
pub fn primal_vjp(t: &LocalTet, dw: [f64; 6]) -> [DVec3; 4] {
    let mut v = Vjp::new(t);
    v.primal(dw);
    v.finish().corners
}

/// Gradient of `sum_e dw[e] * w_e + sum_a dm[a] * m_a` (dual weights and circumcentric cell
/// volumes; weighted by `weights`, in the frame's units, if given) with respect to the four
/// corners and the four user vertex weights (zeros for `None`).
///
/// Shorthand for [`Vjp::dual`] alone; see the [module docs](self) for units and frames.
pub fn dual_vjp(
    t: &LocalTet,
    weights: Option<[f64; 4]>,
    dw: [f64; 6],
    dm: [f64; 4],
) -> ([DVec3; 4], [f64; 4]) {
    let mut v = Vjp::new(t);
    v.dual(weights, dw, dm);
    let g = v.finish();
    (g.corners, g.weights)
}

/// Gradient of `dv * Vol` with respect to the four corners.
///
/// Shorthand for [`Vjp::volume`] alone; see the [module docs](self) for units and frames.
pub fn volume_vjp(t: &LocalTet, dv: f64) -> [DVec3; 4] {
    // d det / d x_k = n_k (k = 1, 2, 3): no normals to pull back, so no `Vjp` needed.
    let [e1, e2, e3] = t.edges;
    let (n1, n2, n3) = (e2.cross(e3), e3.cross(e1), e1.cross(e2));
    let k = dv * t.scale * t.scale * e1.dot(n1).signum() / 6.0;
    let (g1, g2, g3) = (k * n1, k * n2, k * n3);
    [-(g1 + g2 + g3), g1, g2, g3]
}

/// Maps local corner gradients of an immersed tet to R^d: `out[i*d..(i+1)*d] = sum_j
/// corners[i][j] q_j`.
///
/// `basis` holds the local frame's orthonormal vectors `q_0, q_1, q_2` as three rows of
/// `d` values, as [`local_tet`](crate::element::frame::local_tet) leaves them in its scratch for `d > 3`
/// (for `d = 3` the local frame is the user's: use the gradients as they are). `out`
/// holds `4 * d` values.
///
/// # Panics
/// If `basis` has fewer than `3 * d` or `out` fewer than `4 * d` values, `d = out.len() / 4`.
pub fn to_ambient(corners: &[DVec3; 4], basis: &[f64], out: &mut [f64]) {
    let d = out.len() / 4;
    let (q0, rest) = basis.split_at(d);
    let (q1, rest) = rest.split_at(d);
    let q2 = &rest[..d];
    for (g, row) in corners.iter().zip(out.chunks_exact_mut(d)) {
        for (c, o) in row.iter_mut().enumerate() {
            *o = g.x * q0[c] + g.y * q1[c] + g.z * q2[c];
        }
    }
}
