//! Adjoint of the dual weights and circumcentric cell volumes, weighted or not.
//!
//! The reverse pass collects the adjoints of every dot product of corners in a Gram
//! adjoint `gbar[i][j]` (the adjoint of `x_i . x_j`, `x_0 = 0`) and pulls it back once,
//! `xbar_k += sum_j (gbar[k][j] + gbar[j][k]) x_j`: each of the 12 generalised dots `D`,
//! the 6 squared lengths and the 12 projections costs a few scalar additions instead of
//! three vector updates.

use super::Vjp;
use crate::element::tet::{Dual, EDGES};
use glam::DVec3;

impl Vjp {
    /// Adds `sum_e dw[e] * w_e + sum_a dm[a] * m_a` for the dual weights `w_e` and cell
    /// volumes `m_a` of [`dual`](crate::element::tet::dual) (`weights = None`), or of
    /// [`power_dual`](crate::element::tet::power_dual) with the user weights `omega`
    /// (`weights = Some(w)`, `w` in the frame's units `(omega_i - omega_0) / scale^2`).
    ///
    /// With `None` nothing is added to the weight gradient; `Some([0.0; 4])` gives the same
    /// corner gradient and, in addition, the gradient with respect to the vertex weights at
    /// zero weights.
    ///
    /// Returns the forward values on the way, in user units (equal to the forward
    /// kernels' up to rounding). The closed form differentiated is in the
    /// [module docs](super).
    pub fn dual(&mut self, weights: Option<[f64; 4]>, dw: [f64; 6], dm: [f64; 4]) -> Dual {
        match weights {
            None => self.dual_impl::<false>([0.0; 4], dw, dm),
            Some(w) => self.dual_impl::<true>(w, dw, dm),
        }
    }

    fn dual_impl<const WEIGHTED: bool>(
        &mut self,
        om: [f64; 4],
        dw: [f64; 6],
        dm: [f64; 4],
    ) -> Dual {
        const SIXTH: f64 = 1.0 / 6.0;
        let x = self.x;
        let n = self.normals;
        let det = self.det;
        let sigma = det.signum();
        let s = self.scale;
        // User values: weights s w, volumes s^3 m; gradients in user coordinates divide by
        // s once. So the scaled objective is sum dw w + sum (s^2 dm) m.
        let dm = dm.map(|v| v * s * s);

        // ---- forward ----
        // Gram matrix of the corners (x_0 = 0): every dot below is a sum of its entries.
        let mut gram = [[0.0; 4]; 4];
        for i in 1..4 {
            for j in i..4 {
                gram[i][j] = x[i].dot(x[j]);
                gram[j][i] = gram[i][j];
            }
        }
        let len2 = EDGES.map(|(a, b)| gram[a][a] + gram[b][b] - 2.0 * gram[a][b]);
        let inv_len2 = if WEIGHTED { len2.map(|l| 1.0 / l) } else { [0.0; 6] };
        // 2 x_k . c = r_k (x_0 = 0), c = sum_k r_k n_k / (2 det)
        let r = [1, 2, 3].map(|k| gram[k][k] + om[0] - om[k]);
        let half_inv_det = 0.5 / det;
        let c = (r[0] * n[1] + r[1] * n[2] + r[2] * n[3]) * half_inv_det;
        // mu_l = lambda_l(c) |det|, from a corner of face l (x_1 for l = 0, x_0 = 0 else)
        let mu = [
            sigma * n[0].dot(c - x[1]),
            sigma * n[1].dot(c),
            sigma * n[2].dot(c),
            sigma * n[3].dot(c),
        ];
        let inv_nn = n.map(|v| 1.0 / v.length_squared());
        let g = [0, 1, 2, 3].map(|l| 0.25 * mu[l] * inv_nn[l]);
        // Per edge ab with opposite (k, l): D_k, D_l and the interpolation parameters t_k, t_l.
        let mut big_d = [[0.0; 2]; 6];
        let mut param = [[0.0; 2]; 6];
        let mut w = [0.0; 6];
        let mut m = [0.0; 4];
        each_edge!(|e, a, b, k, l| {
            for (j, p) in [k, l].into_iter().enumerate() {
                let dot = gram[a][b] - gram[a][p] - gram[b][p] + gram[p][p];
                big_d[e][j] = if WEIGHTED {
                    let t = (gram[b][p] - gram[a][b] - gram[a][p] + gram[a][a]) * inv_len2[e];
                    param[e][j] = t;
                    dot + om[a] + t * (om[b] - om[a]) - om[p]
                } else {
                    dot
                };
            }
            // w = D_k mu_l / (4 |n_l|^2) + D_l mu_k / (4 |n_k|^2)
            w[e] = big_d[e][0] * g[l] + big_d[e][1] * g[k];
            m[a] += (len2[e] + om[a] - om[b]) * w[e] * SIXTH;
            m[b] += (len2[e] + om[b] - om[a]) * w[e] * SIXTH;
        });

        // ---- reverse ----
        // gbar[i][j]: adjoint of x_i . x_j (symmetrised at the end).
        let mut gbar = [[0.0; 4]; 4];
        let mut bar_w = [0.0; 4];
        let mut bar_g = [0.0; 4];
        each_edge!(|e, a, b, k, l| {
            let wbar = dw[e]
                + ((len2[e] + om[a] - om[b]) * dm[a] + (len2[e] + om[b] - om[a]) * dm[b]) * SIXTH;
            let mut bar_len2 = w[e] * (dm[a] + dm[b]) * SIXTH;
            if WEIGHTED {
                let dom = w[e] * (dm[a] - dm[b]) * SIXTH;
                bar_w[a] += dom;
                bar_w[b] -= dom;
            }
            bar_g[l] += wbar * big_d[e][0];
            bar_g[k] += wbar * big_d[e][1];
            // D_k multiplies g_l, D_l multiplies g_k
            for (j, (p, q)) in [(k, l), (l, k)].into_iter().enumerate() {
                let bar_d = wbar * g[q];
                // (x_a - x_p).(x_b - x_p) = G_ab - G_ap - G_bp + G_pp
                gbar[a][b] += bar_d;
                gbar[a][p] -= bar_d;
                gbar[b][p] -= bar_d;
                gbar[p][p] += bar_d;
                if WEIGHTED {
                    // D += om_a + t (om_b - om_a) - om_p, t = B.K / |ab|^2 with
                    // B.K = (x_b - x_a).(x_p - x_a) = G_bp - G_ab - G_ap + G_aa
                    let t = param[e][j];
                    bar_w[a] += bar_d * (1.0 - t);
                    bar_w[b] += bar_d * t;
                    bar_w[p] -= bar_d;
                    let bar_bk = bar_d * (om[b] - om[a]) * inv_len2[e];
                    gbar[b][p] += bar_bk;
                    gbar[a][b] -= bar_bk;
                    gbar[a][p] -= bar_bk;
                    gbar[a][a] += bar_bk;
                    bar_len2 -= bar_bk * t;
                }
            }
            // |ab|^2 = G_aa + G_bb - 2 G_ab
            gbar[a][a] += bar_len2;
            gbar[b][b] += bar_len2;
            gbar[a][b] -= 2.0 * bar_len2;
        });
        // g_l = mu_l / (4 |n_l|^2), mu_l = sigma n_l . (c - x_f)
        let mut bar_c = DVec3::ZERO;
        let mut bar_x1 = DVec3::ZERO;
        for l in 0..4 {
            let bar_mu = sigma * 0.25 * bar_g[l] * inv_nn[l];
            let bar_nn = -bar_g[l] * g[l] * inv_nn[l];
            let rel = if l == 0 { c - x[1] } else { c };
            self.bar_normals[l] += 2.0 * bar_nn * n[l] + bar_mu * rel;
            bar_c += bar_mu * n[l];
            if l == 0 {
                bar_x1 -= bar_mu * n[0];
            }
        }
        // c = u / (2 det), u = sum_k r_k n_k, r_k = |x_k|^2 + om_0 - om_k
        let bar_u = bar_c * half_inv_det;
        self.bar_det -= 2.0 * bar_u.dot(c);
        for k in 1..4 {
            self.bar_normals[k] += r[k - 1] * bar_u;
            let bar_r = bar_u.dot(n[k]);
            gbar[k][k] += bar_r;
            if WEIGHTED {
                bar_w[k] -= bar_r;
            }
        }
        // Gram adjoint to corners: d (x_i . x_j) / d x_k = delta_ik x_j + delta_jk x_i
        for k in 1..4 {
            let mut acc = if k == 1 { bar_x1 } else { DVec3::ZERO };
            for j in 1..4 {
                acc += (gbar[k][j] + gbar[j][k]) * x[j];
            }
            self.bar_x[k] += acc;
            if WEIGHTED {
                self.bar_w[k] += bar_w[k];
            }
        }
        Dual { weights: w.map(|v| v * s), cell_volumes: m.map(|v| v * (s * s * s)) }
    }
}
