//! Timing of the forward kernels against their VJPs (ns per tet, one core), and of a
//! forward-mode (dual-number) primal gradient for comparison. Run with
//! `cargo test --release --lib local::derivatives::bench -- --ignored --nocapture`.

use super::*;
use crate::geometry::local_tet;
use crate::local::{dual, dual_from_centers, primal_weights, volume, Centers, EDGES};
use std::hint::black_box;
use std::ops::{Add, Mul, Sub};
use std::time::Instant;

/// A number with `N` tangents: forward-mode differentiation in `N` directions at once.
#[derive(Clone, Copy)]
struct Dn<const N: usize> {
    v: f64,
    d: [f64; N],
}

impl<const N: usize> Add for Dn<N> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Dn { v: self.v + o.v, d: std::array::from_fn(|i| self.d[i] + o.d[i]) }
    }
}

impl<const N: usize> Sub for Dn<N> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Dn { v: self.v - o.v, d: std::array::from_fn(|i| self.d[i] - o.d[i]) }
    }
}

impl<const N: usize> Mul for Dn<N> {
    type Output = Self;
    #[allow(clippy::suspicious_arithmetic_impl)] // the product rule
    fn mul(self, o: Self) -> Self {
        Dn { v: self.v * o.v, d: std::array::from_fn(|i| self.d[i] * o.v + self.v * o.d[i]) }
    }
}

type V3<const N: usize> = [Dn<N>; 3];

fn sub3<const N: usize>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross3<const N: usize>(a: V3<N>, b: V3<N>) -> V3<N> {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn dot3<const N: usize>(a: V3<N>, b: V3<N>) -> Dn<N> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The primal gradient by forward mode: the 9 edge coordinates seeded, the kernel's
/// expressions evaluated on [`Dn`], the 6 x 9 Jacobian contracted with `dw`.
fn primal_forward_mode(t: &LocalTet, dw: [f64; 6]) -> [DVec3; 4] {
    let e: [V3<9>; 3] = std::array::from_fn(|k| {
        std::array::from_fn(|c| {
            let mut d = [0.0; 9];
            d[3 * k + c] = 1.0;
            Dn { v: t.edges[k][c], d }
        })
    });
    let [e1, e2, e3] = e;
    let n = [cross3(sub3(e3, e1), sub3(e2, e1)), cross3(e2, e3), cross3(e3, e1), cross3(e1, e2)];
    let det = dot3(e1, n[1]);
    // w = -(n_a . n_b) / (6 |det|): d w = -(d P) / (6 |det|) + P sign / (6 det^2) d det
    let sigma = det.v.signum();
    let mut g = [0.0; 9];
    for (&(a, b), &dw) in EDGES.iter().zip(&dw) {
        let p = dot3(n[a], n[b]);
        let k = -1.0 / (6.0 * det.v.abs());
        for (i, gi) in g.iter_mut().enumerate() {
            *gi += dw * (k * p.d[i] - k * p.v * sigma / det.v.abs() * det.d[i]);
        }
    }
    let gk = |k: usize| DVec3::new(g[3 * k], g[3 * k + 1], g[3 * k + 2]);
    let (g1, g2, g3) = (gk(0), gk(1), gk(2));
    [-(g1 + g2 + g3), g1, g2, g3]
}

#[test]
fn forward_mode_agrees_with_reverse_mode() {
    let x = [[0.1, 0.0, 0.0], [1.0, 0.2, 0.0], [0.3, 1.0, 0.1], [0.2, 0.3, 0.8]];
    let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
    let dw = [0.3, -0.2, 0.5, 0.7, -1.1, 0.4];
    let (a, b) = (primal_forward_mode(&t, dw), primal_vjp(&t, dw));
    for i in 0..4 {
        assert!((a[i] - b[i]).length() < 1e-13 * b[i].length().max(1.0), "{a:?} {b:?}");
    }
}

/// Nanoseconds per call of `f` on every tet, one round.
fn round<R>(tets: &[LocalTet], f: &impl Fn(&LocalTet) -> R) -> f64 {
    let start = Instant::now();
    for t in tets {
        black_box(f(black_box(t)));
    }
    start.elapsed().as_nanos() as f64 / tets.len() as f64
}

/// `(forward ns, vjp ns, ratio)`: the best of 11 interleaved rounds each, and the median of
/// the 11 per-round ratios (robust to other load on the machine).
fn compare<R, S>(
    tets: &[LocalTet],
    forward: impl Fn(&LocalTet) -> R,
    vjp: impl Fn(&LocalTet) -> S,
) -> (f64, f64, f64) {
    let (mut best_f, mut best_v, mut ratios) = (f64::INFINITY, f64::INFINITY, vec![]);
    for _ in 0..11 {
        let (f, v) = (round(tets, &forward), round(tets, &vjp));
        best_f = best_f.min(f);
        best_v = best_v.min(v);
        ratios.push(v / f);
    }
    ratios.sort_by(f64::total_cmp);
    (best_f, best_v, ratios[5])
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn timing() {
    // well-shaped random tets (a fixed sequence)
    let mut state = 1u64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let tets: Vec<LocalTet> = (0..100_000)
        .map(|_| loop {
            let x: [[f64; 3]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| uniform()));
            let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
            if volume(&t) > 0.01 {
                break t;
            }
        })
        .collect();
    let w = [0.0, 0.01, -0.02, 0.015];
    let (dw, dm) = ([0.3, -0.2, 0.5, 0.7, -1.1, 0.4], [0.2, 0.1, -0.3, 0.5]);
    let rows = [
        ("volume", compare(&tets, volume, |t| volume_vjp(t, 1.0))),
        ("primal", compare(&tets, primal_weights, |t| primal_vjp(t, dw))),
        ("dual", compare(&tets, dual, |t| dual_vjp(t, None, dw, dm))),
        (
            "weighted dual",
            compare(
                &tets,
                |t| dual_from_centers(t, &Centers::weighted(t, w)),
                |t| dual_vjp(t, Some(w), dw, dm),
            ),
        ),
        (
            "affine + circumcentric",
            compare(
                &tets,
                |t| (primal_weights(t), dual(t)),
                |t| {
                    let mut v = Vjp::new(t);
                    let _ = v.primal(dw.map(|w| 0.5 * w));
                    v.dual(None, dw.map(|w| 0.5 * w), dm);
                    v.finish()
                },
            ),
        ),
        ("primal, dual numbers", compare(&tets, primal_weights, |t| primal_forward_mode(t, dw))),
    ];
    println!("{:<24} {:>10} {:>10} {:>6}", "kernel", "forward", "vjp", "ratio");
    for (name, (f, r, ratio)) in rows {
        println!("{name:<24} {f:>8.1}ns {r:>8.1}ns {ratio:>6.2}");
    }
}

/// A jittered Kuhn grid of the unit cube with `6 k^3` tets (points row-major, dim 3).
fn grid(k: usize) -> (Vec<f64>, Vec<[u32; 4]>) {
    let id = |x: usize, y: usize, z: usize| ((x * (k + 1) + y) * (k + 1) + z) as u32;
    let mut state = 7u64;
    let mut points = vec![];
    for x in 0..=k {
        for y in 0..=k {
            for z in 0..=k {
                for c in [x, y, z] {
                    state =
                        state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    let jitter = if c > 0 && c < k {
                        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                    } else {
                        0.0
                    };
                    points.push((c as f64 + 0.3 * jitter) / k as f64);
                }
            }
        }
    }
    let mut tets = vec![];
    for x in 0..k {
        for y in 0..k {
            for z in 0..k {
                for p in [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] {
                    let mut c = [x, y, z];
                    let mut tet = [id(x, y, z); 4];
                    for (s, axis) in p.into_iter().enumerate() {
                        c[axis] += 1;
                        tet[s + 1] = id(c[0], c[1], c[2]);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    (points, tets)
}

/// The gradient of the Dirichlet energy `sum_tets sum_e w_e (f_a - f_b)^2` plus
/// `sum_a m_a g_a` over a mesh, one thread, gathering and scattering like a driver would.
fn energy_gradient(points: &[f64], tets: &[[u32; 4]], f: &[f64], g: &[f64], out: &mut [DVec3]) {
    out.fill(DVec3::ZERO);
    for tet in tets {
        let p = tet.map(|v| &points[3 * v as usize..3 * v as usize + 3]);
        let t = local_tet(p, &mut []);
        let fv = tet.map(|v| f[v as usize]);
        let dw = EDGES.map(|(a, b)| (fv[a] - fv[b]) * (fv[a] - fv[b]));
        let mut vjp = Vjp::new(&t);
        vjp.dual(None, dw, tet.map(|v| g[v as usize]));
        let grad = vjp.finish();
        for (v, gv) in tet.iter().zip(grad.corners) {
            out[*v as usize] += gv;
        }
    }
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn mesh_timing() {
    use crate::{laplacian, operators, LaplacianKind, MassKind, Options, TetMesh};
    let (points, tets) = grid(40);
    let mesh = TetMesh::new(&points, 3, &tets).unwrap();
    let opts = Options { threads: Some(1), ..Default::default() };
    let n = points.len() / 3;
    let f: Vec<f64> =
        (0..n).map(|i| points[3 * i] * points[3 * i + 1] + points[3 * i + 2]).collect();
    let mut out = vec![DVec3::ZERO; n];
    let ns = |start: Instant| start.elapsed().as_secs_f64() * 1e9 / tets.len() as f64;
    // interleaved rounds: (L, L and M, VJP) ns per tet
    let mut rounds = vec![];
    for _ in 0..7 {
        let start = Instant::now();
        black_box(laplacian(&mesh, LaplacianKind::Dual, &opts).unwrap());
        let lap = ns(start);
        let start = Instant::now();
        black_box(operators(&mesh, LaplacianKind::Dual, MassKind::Circumcentric, &opts).unwrap());
        let ops = ns(start);
        let start = Instant::now();
        energy_gradient(&points, &tets, &f, &f, &mut out);
        black_box(&out);
        rounds.push((lap, ops, ns(start)));
    }
    let best = |k: fn(&(f64, f64, f64)) -> f64| rounds.iter().map(k).fold(f64::INFINITY, f64::min);
    let median = |k: fn(&(f64, f64, f64)) -> f64| {
        let mut r: Vec<f64> = rounds.iter().map(k).collect();
        r.sort_by(f64::total_cmp);
        r[3]
    };
    println!(
        "{} tets, one thread, ns per tet (best of 7; ratios: median of 7 rounds):",
        tets.len()
    );
    println!("  assembly of the dual L:        {:8.1}", best(|r| r.0));
    println!("  assembly of dual L and M:      {:8.1}", best(|r| r.1));
    println!(
        "  VJP of -f^T L f + g^T M (dual):{:8.1}  ({:.2}x L, {:.2}x L and M)",
        best(|r| r.2),
        median(|r| r.2 / r.0),
        median(|r| r.2 / r.1)
    );
}
