//! Adjoints of the primal weights and of the volume.

use super::Vjp;

impl Vjp {
    /// Adds `sum_e dw[e] * w_e` for the primal weights of
    /// [`primal_weights`](crate::element::tet::primal_weights), and returns the weights (user
    /// units; computed on the way, equal to the forward kernel's).
    ///
    /// `w_ab = -(n_a . n_b) / (6 |det|)` (scale-free: the user weight is `scale` times the
    /// scaled one and its gradient is taken in user coordinates): `nbar_a += dw k n_b`,
    /// `nbar_b += dw k n_a` with `k = -1 / (6 |det|)`, and `d w / d det = -w / det`.
    pub fn primal(&mut self, dw: [f64; 6]) -> [f64; 6] {
        let n = self.normals;
        let k = -1.0 / (6.0 * self.det.abs());
        let mut w = [0.0; 6];
        let mut bar_det = 0.0;
        each_edge!(|e, a, b, _k, _l| {
            w[e] = n[a].dot(n[b]) * k;
            bar_det -= dw[e] * w[e];
            let dk = dw[e] * k;
            self.bar_normals[a] += dk * n[b];
            self.bar_normals[b] += dk * n[a];
        });
        self.bar_det += bar_det / self.det;
        w.map(|w| w * self.scale)
    }

    /// Adds `dv * Vol` for the tet's unsigned [`volume`](crate::element::tet::volume)
    /// `sign(det) det / 6`, and returns the volume (user units: `scale^3` times the scaled
    /// one, so its gradient in user coordinates carries `scale^2`).
    pub fn volume(&mut self, dv: f64) -> f64 {
        let s = self.scale;
        let sigma = self.det.signum();
        self.bar_det += dv * s * s * sigma / 6.0;
        sigma * self.det / 6.0 * s * s * s
    }
}
