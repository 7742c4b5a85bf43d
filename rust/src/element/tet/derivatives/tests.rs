//! Tests of the VJPs against central differences of the forward kernels, and their
//! invariances.
//!
//! **Finite differences.** Fourth-order central differences (the stencil `(8 (f(x + h) -
//! f(x - h)) - (f(x + 2h) - f(x - 2h))) / 12h`) in every user coordinate and every user
//! vertex weight, with the step `h = H * size` (`size` the tet's longest edge; `H *
//! size^2` for the weights), `H = 2^-13` (about 1.2e-4): truncation error ~ `H^4` and
//! rounding ~ `eps / H`, both near 1e-12 relative on well-shaped tets. (The plain
//! second-order stencil also passes, at `H = 2^-17`, but its truncation error, 3e-9 on these
//! tets, hides the gradients' own error.) Relative error: `max_i |g_i - fd_i| / max_i |g_i|`
//! over all coordinates of a tet (the weights separately); the target is 1e-6.
//!
//! **Slivers excluded.** Random tets are kept only if `quality = 6 sqrt(2) Vol / l_max^3`
//! (1 for the regular tet, 0 for a flat one) is at least [`MIN_QUALITY`] = 0.05. Observed
//! worst errors: about 1e-11 for quality at least 0.2, 1e-10 for 0.05 and 3e-9 for 0.01,
//! limited by the differences (their error falls with the step like `h^4`). Among the kept
//! tets many are obtuse (circumcenter outside the tet), and the tests check that enough of
//! them are.

use super::*;
use crate::element::frame::local_tet;
use crate::element::tet::{dual, power_dual, primal_weights, volume, Placement, EDGES};
use std::ops::{Add, Mul, Sub};

/// Tets below this quality (see the module docs) are slivers, excluded.
const MIN_QUALITY: f64 = 0.05;
/// Relative step of the central differences.
const H: f64 = 1.0 / 8192.0;
/// Target relative error.
const TOL: f64 = 1e-6;

/// splitmix64: a small deterministic generator for the tests.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
    fn array<const N: usize>(&mut self) -> [f64; N] {
        std::array::from_fn(|_| self.uniform())
    }
}

type Points = Vec<Vec<f64>>;

fn edge_len(p: &[f64], q: &[f64]) -> f64 {
    p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt()
}

fn size(x: &Points) -> f64 {
    EDGES.iter().map(|&(a, b)| edge_len(&x[a], &x[b])).fold(0.0, f64::max)
}

fn frame(x: &Points) -> (LocalTet, Vec<f64>) {
    let mut scratch = vec![0.0; 3 * x[0].len()];
    let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut scratch);
    (t, scratch)
}

fn quality(x: &Points) -> f64 {
    6.0 * 2f64.sqrt() * volume(&frame(x).0) / size(x).powi(3)
}

/// Whether the tet's circumcenter lies outside it (some barycentric coordinate negative).
fn circumcenter_outside(x: &Points) -> bool {
    let (t, _) = frame(x);
    let f = crate::element::tet::Frame::new(&t);
    let [_, e1, e2, e3] = f.x;
    let c = (e1.length_squared() * f.normals[1]
        + e2.length_squared() * f.normals[2]
        + e3.length_squared() * f.normals[3])
        / (2.0 * f.det);
    let lam =
        [f.normals[0].dot(c - e1), f.normals[1].dot(c), f.normals[2].dot(c), f.normals[3].dot(c)];
    lam.iter().any(|&l| l / f.det < 0.0)
}

/// A random tet of quality at least `MIN_QUALITY`, corners uniform in `[-scale, scale)^3`.
fn random_tet(rng: &mut Rng, scale: f64) -> Points {
    loop {
        let x: Points =
            (0..4).map(|_| rng.array::<3>().iter().map(|v| v * scale).collect()).collect();
        if quality(&x) >= MIN_QUALITY {
            return x;
        }
    }
}

/// What is differentiated, with its cotangents.
#[derive(Clone, Copy, Debug)]
enum Kernel {
    Primal {
        dw: [f64; 6],
    },
    /// Plain (`omega = None`) or weighted dual, user weights.
    Dual {
        omega: Option<[f64; 4]>,
        dw: [f64; 6],
        dm: [f64; 4],
    },
    Volume {
        dv: f64,
    },
    /// `(1 - t) primal + t dual` weights and the circumcentric mass.
    Affine {
        t: f64,
        dw: [f64; 6],
        dm: [f64; 4],
    },
}

fn dot<const N: usize>(a: [f64; N], b: [f64; N]) -> f64 {
    a.iter().zip(&b).map(|(x, y)| x * y).sum()
}

/// The scaled weights the kernels take, as the assembly builds them.
fn frame_weights(t: &LocalTet, omega: [f64; 4]) -> [f64; 4] {
    let s2 = t.scale * t.scale;
    omega.map(|w| (w - omega[0]) / s2)
}

/// `L` by the forward kernels, at points `x` (any dimension) and user weights.
fn forward(k: Kernel, x: &Points, omega_override: Option<[f64; 4]>) -> f64 {
    let (t, _) = frame(x);
    match k {
        Kernel::Primal { dw } => dot(dw, primal_weights(&t)),
        Kernel::Dual { omega, dw, dm } => {
            let d = match omega_override.or(omega) {
                None => dual(&t),
                Some(om) => power_dual(&t, Some(&om), Placement::Centres),
            };
            dot(dw, d.weights) + dot(dm, d.cell_volumes)
        }
        Kernel::Volume { dv } => dv * volume(&t),
        Kernel::Affine { t: s, dw, dm } => {
            let (p, d) = (primal_weights(&t), dual(&t));
            dot(dw, p) * (1.0 - s) + dot(dw, d.weights) * s + dot(dm, d.cell_volumes)
        }
    }
}

/// The VJP's gradient, corners in the user's R^d and user weights.
fn reverse(k: Kernel, x: &Points) -> (Points, [f64; 4]) {
    let (t, scratch) = frame(x);
    let mut v = Vjp::new(&t);
    match k {
        Kernel::Primal { dw } => {
            v.primal(dw);
        }
        Kernel::Dual { omega, dw, dm } => {
            v.dual(omega.map(|om| frame_weights(&t, om)), dw, dm);
        }
        Kernel::Volume { dv } => {
            v.volume(dv);
        }
        Kernel::Affine { t: s, dw, dm } => {
            v.primal(dw.map(|w| w * (1.0 - s)));
            v.dual(None, dw.map(|w| w * s), dm);
        }
    }
    let g = v.finish();
    let d = x[0].len();
    let corners = if d == 3 {
        g.corners.iter().map(|c| c.to_array().to_vec()).collect()
    } else {
        let mut out = vec![0.0; 4 * d];
        to_ambient(&g.corners, &scratch, &mut out);
        out.chunks(d).map(|c| c.to_vec()).collect()
    };
    (corners, g.weights)
}

/// The fourth-order central difference of `f` at 0 with step `h`.
fn stencil(f: impl Fn(f64) -> f64, h: f64) -> f64 {
    (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h)
}

/// Central differences of `forward` in every coordinate and (weighted duals) every weight.
fn differences(k: Kernel, x: &Points) -> (Points, [f64; 4]) {
    let h = H * size(x);
    let mut g = x.clone();
    for i in 0..4 {
        for c in 0..x[i].len() {
            let moved = |d: f64| {
                let mut y = x.clone();
                y[i][c] += d;
                forward(k, &y, None)
            };
            g[i][c] = stencil(moved, h);
        }
    }
    let mut gw = [0.0; 4];
    if let Kernel::Dual { omega: Some(om), .. } = k {
        let h = H * size(x) * size(x);
        for (i, gwi) in gw.iter_mut().enumerate() {
            let moved = |d: f64| {
                let mut p = om;
                p[i] += d;
                forward(k, x, Some(p))
            };
            *gwi = stencil(moved, h);
        }
    }
    (g, gw)
}

fn rel_err(g: &[f64], fd: &[f64]) -> f64 {
    let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let err = g.iter().zip(fd).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    if scale == 0.0 {
        err
    } else {
        err / scale
    }
}

/// Worst relative error of the VJP against central differences, coordinates and weights.
fn check(k: Kernel, x: &Points) -> (f64, f64) {
    let (g, gw) = reverse(k, x);
    let (fd, fdw) = differences(k, x);
    let flat = |p: &Points| p.concat();
    let ex = rel_err(&flat(&g), &flat(&fd));
    let ew =
        if matches!(k, Kernel::Dual { omega: Some(_), .. }) { rel_err(&gw, &fdw) } else { 0.0 };
    (ex, ew)
}

/// Every kernel with random cotangents; weights of magnitude up to `0.1 size^2`.
fn kernels(rng: &mut Rng, x: &Points) -> Vec<Kernel> {
    let s2 = size(x) * size(x);
    let omega = rng.array::<4>().map(|w| 0.1 * w * s2);
    vec![
        Kernel::Primal { dw: rng.array() },
        Kernel::Dual { omega: None, dw: rng.array(), dm: rng.array() },
        Kernel::Dual { omega: Some(omega), dw: rng.array(), dm: rng.array() },
        Kernel::Dual { omega: Some(omega), dw: [0.0; 6], dm: rng.array() },
        Kernel::Volume { dv: rng.uniform() },
        Kernel::Affine { t: 0.5 * (rng.uniform() + 1.0), dw: rng.array(), dm: rng.array() },
    ]
}

#[test]
fn gradients_match_central_differences_in_r3() {
    let mut rng = Rng(17);
    let mut worst = (0.0f64, 0.0f64);
    let mut outside = 0;
    for scale in [1e-3, 1.0, 1e3] {
        for _ in 0..100 {
            let x = random_tet(&mut rng, scale);
            outside += circumcenter_outside(&x) as usize;
            for k in kernels(&mut rng, &x) {
                let (ex, ew) = check(k, &x);
                assert!(ex <= TOL && ew <= TOL, "{k:?} at {x:?}: {ex:e} {ew:e}");
                worst = (worst.0.max(ex), worst.1.max(ew));
            }
        }
    }
    println!("worst relative error: coordinates {:e}, weights {:e}", worst.0, worst.1);
    // the sample covers non-well-centred tets (circumcenter outside) well
    assert!(outside >= 100, "{outside} of 300 tets with the circumcenter outside");
}

#[test]
fn obtuse_well_conditioned_tets_pass() {
    // Circumcenter outside, some faces obtuse, yet quality >= MIN_QUALITY: negative dual
    // weights and cell volumes, smooth derivatives.
    let tets: [[[f64; 3]; 4]; 5] = [
        [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0.3, 0.2, 0.5]],
        [[0., 0., 0.], [1., 0., 0.], [0.5, 0.9, 0.], [0.5, 0.3, 0.45]],
        [[0., 0., 0.], [1., 0., 0.], [0.2, 0.8, 0.], [0.1, 0.1, 0.8]],
        [[0., 0., 0.], [1., 0., 0.], [-0.3, 0.8, 0.], [0.2, 0.2, 0.8]],
        [[0., 0., 0.], [1., 0.1, 0.], [-0.2, 1., 0.], [0.9, 0.9, 0.6]],
    ];
    let mut rng = Rng(4);
    let mut negative = 0;
    for x in tets {
        let x: Points = x.iter().map(|p| p.to_vec()).collect();
        assert!(quality(&x) >= MIN_QUALITY, "quality {}", quality(&x));
        assert!(circumcenter_outside(&x), "{x:?}");
        let d = dual(&frame(&x).0);
        negative += d.weights.iter().chain(&d.cell_volumes).any(|&v| v < 0.0) as usize;
        for k in kernels(&mut rng, &x) {
            let (ex, ew) = check(k, &x);
            assert!(ex <= TOL && ew <= TOL, "{k:?} at {x:?}: {ex:e} {ew:e}");
        }
    }
    assert!(negative >= 4, "{negative} of 5 with negative dual weights or cell volumes");
}

/// A random rotation of R^4 (Gram-Schmidt of a random matrix), as rows.
fn random_rotation4(rng: &mut Rng) -> [[f64; 4]; 4] {
    let mut q = [[0.0; 4]; 4];
    for i in 0..4 {
        let mut v = rng.array::<4>();
        for _ in 0..2 {
            for qj in &q[..i] {
                let p = dot(v, *qj);
                v = std::array::from_fn(|c| v[c] - p * qj[c]);
            }
        }
        let n = dot(v, v).sqrt();
        q[i] = v.map(|a| a / n);
    }
    q
}

#[test]
fn immersed_tets_match_differences_in_r4() {
    let mut rng = Rng(44);
    let mut worst = 0.0f64;
    for scale in [1e-3, 1.0, 1e3] {
        for _ in 0..30 {
            let x3 = random_tet(&mut rng, scale);
            let rot = random_rotation4(&mut rng);
            let shift = rng.array::<4>().map(|v| v * scale);
            let x: Points = x3
                .iter()
                .map(|p| {
                    (0..4)
                        .map(|r| rot[r][0] * p[0] + rot[r][1] * p[1] + rot[r][2] * p[2] + shift[r])
                        .collect()
                })
                .collect();
            // the scratch of local_tet holds an orthonormal basis that reproduces the edges
            let (t, q) = frame(&x);
            for k in 1..4 {
                let e = t.edges[k - 1] * t.scale;
                for c in 0..4 {
                    let back = e.x * q[c] + e.y * q[4 + c] + e.z * q[8 + c];
                    assert!((back - (x[k][c] - x[0][c])).abs() <= 1e-14 * scale);
                }
            }
            for k in kernels(&mut rng, &x) {
                let (ex, ew) = check(k, &x);
                assert!(ex <= TOL && ew <= TOL, "{k:?} at {x:?}: {ex:e} {ew:e}");
                worst = worst.max(ex).max(ew);
            }
        }
    }
    println!("worst relative error in R^4: {worst:e}");
}

fn max_abs(g: &Points) -> f64 {
    g.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
}

#[test]
fn gradients_sum_to_zero() {
    let mut rng = Rng(5);
    for _ in 0..50 {
        let x = random_tet(&mut rng, 1.0);
        for k in kernels(&mut rng, &x) {
            let (g, gw) = reverse(k, &x);
            for c in 0..3 {
                let sum: f64 = g.iter().map(|p| p[c]).sum();
                assert!(sum.abs() <= 1e-14 * max_abs(&g), "{k:?}: {sum:e}");
            }
            let sum: f64 = gw.iter().sum();
            assert!(sum.abs() <= 1e-14 * gw.iter().fold(0.0f64, |m, v| m.max(v.abs())));
        }
    }
}

/// `R x + b` for every point, `R` a rotation of R^3 (from a random quaternion).
fn rotate(x: &Points, r: &glam::DMat3, b: DVec3) -> Points {
    x.iter().map(|p| (*r * DVec3::from_slice(p) + b).to_array().to_vec()).collect()
}

#[test]
fn rotations_rotate_the_gradients() {
    let mut rng = Rng(6);
    for _ in 0..50 {
        let x = random_tet(&mut rng, 1.0);
        let [a, b, c, d] = rng.array::<4>();
        let r = glam::DMat3::from_quat(glam::DQuat::from_xyzw(a, b, c, d).normalize());
        let y = rotate(&x, &r, DVec3::from_array(rng.array::<3>()));
        for k in kernels(&mut rng, &x) {
            let (g, gw) = reverse(k, &x);
            let (h, hw) = reverse(k, &y);
            let rg: Points =
                g.iter().map(|p| (r * DVec3::from_slice(p)).to_array().to_vec()).collect();
            assert!(rel_err(&h.concat(), &rg.concat()) < 1e-12, "{k:?}");
            assert!(rel_err(&hw, &gw) < 1e-12, "{k:?}");
        }
    }
}

#[test]
fn scaling_scales_the_gradients() {
    let mut rng = Rng(7);
    for _ in 0..50 {
        let x = random_tet(&mut rng, 1.0);
        let omega = rng.array::<4>().map(|w| 0.1 * w);
        let (dw, dm) = (rng.array::<6>(), rng.array::<4>());
        for s in [0.25, 8.0, 1e-3, 1e3] {
            let y: Points = x.iter().map(|p| p.iter().map(|v| v * s).collect()).collect();
            // weights: d w / d x is scale-invariant, d w / d omega scales like 1 / s
            let k = |om: Option<[f64; 4]>| Kernel::Dual { omega: om, dw, dm: [0.0; 4] };
            for (kx, ky) in [
                (Kernel::Primal { dw }, Kernel::Primal { dw }),
                (k(None), k(None)),
                (k(Some(omega)), k(Some(omega.map(|w| w * s * s)))),
            ] {
                let ((g, gw), (h, hw)) = (reverse(kx, &x), reverse(ky, &y));
                assert!(rel_err(&h.concat(), &g.concat()) < 1e-13, "{kx:?} {s}");
                assert!(rel_err(&hw, &gw.map(|v| v / s)) < 1e-13, "{kx:?} {s}");
            }
            // volumes: d Vol / d x and d m / d x scale like s^2, d m / d omega like s
            let k = |om: Option<[f64; 4]>| Kernel::Dual { omega: om, dw: [0.0; 6], dm };
            for (kx, ky) in [
                (Kernel::Volume { dv: 1.0 }, Kernel::Volume { dv: 1.0 }),
                (k(None), k(None)),
                (k(Some(omega)), k(Some(omega.map(|w| w * s * s)))),
            ] {
                let ((g, gw), (h, hw)) = (reverse(kx, &x), reverse(ky, &y));
                let g: Vec<f64> = g.concat().iter().map(|v| v * s * s).collect();
                assert!(rel_err(&h.concat(), &g) < 1e-13, "{kx:?} {s}");
                assert!(rel_err(&hw, &gw.map(|v| v * s)) < 1e-13, "{kx:?} {s}");
            }
        }
    }
}

/// The 24 permutations of four corners.
fn permutations() -> Vec<[usize; 4]> {
    let mut out = vec![];
    for a in 0..4 {
        for b in (0..4).filter(|&b| b != a) {
            for c in (0..4).filter(|&c| c != a && c != b) {
                out.push([a, b, c, 6 - a - b - c]);
            }
        }
    }
    out
}

fn edge_index(a: usize, b: usize) -> usize {
    EDGES.iter().position(|&e| e == (a.min(b), a.max(b))).unwrap()
}

#[test]
fn permuting_corners_permutes_the_gradients() {
    let mut rng = Rng(8);
    let perms = permutations();
    assert_eq!(perms.len(), 24);
    for _ in 0..20 {
        let x = random_tet(&mut rng, 1.0);
        for k in kernels(&mut rng, &x) {
            let (g, gw) = reverse(k, &x);
            for p in &perms {
                // corner i of y is corner p[i] of x; its edge e = (a, b) is x's (p[a], p[b])
                let y: Points = p.iter().map(|&i| x[i].clone()).collect();
                let edge_map: [usize; 6] = EDGES.map(|(a, b)| edge_index(p[a], p[b]));
                let pw = |dw: [f64; 6]| edge_map.map(|e| dw[e]);
                let pm = |dm: [f64; 4]| p.map(|i| dm[i]);
                let ky = match k {
                    Kernel::Primal { dw } => Kernel::Primal { dw: pw(dw) },
                    Kernel::Dual { omega, dw, dm } => {
                        Kernel::Dual { omega: omega.map(pm), dw: pw(dw), dm: pm(dm) }
                    }
                    Kernel::Volume { dv } => Kernel::Volume { dv },
                    Kernel::Affine { t, dw, dm } => Kernel::Affine { t, dw: pw(dw), dm: pm(dm) },
                };
                let (h, hw) = reverse(ky, &y);
                let pg: Points = p.iter().map(|&i| g[i].clone()).collect();
                assert!(rel_err(&h.concat(), &pg.concat()) < 1e-12, "{k:?} {p:?}");
                assert!(rel_err(&hw, &pm(gw)) < 1e-12, "{k:?} {p:?}");
            }
        }
    }
}

#[test]
fn forward_values_match_the_kernels() {
    let mut rng = Rng(9);
    for _ in 0..200 {
        let x = random_tet(&mut rng, 1.0);
        let (t, _) = frame(&x);
        let omega = rng.array::<4>().map(|w| 0.1 * w);
        let tol = |a: &[f64], b: &[f64]| rel_err(a, b) < 1e-12;
        assert!(tol(&Vjp::new(&t).primal([0.0; 6]), &primal_weights(&t)));
        assert!(tol(&[Vjp::new(&t).volume(0.0)], &[volume(&t)]));
        let plain = Vjp::new(&t).dual(None, [0.0; 6], [0.0; 4]);
        assert!(
            tol(&plain.weights, &dual(&t).weights)
                && tol(&plain.cell_volumes, &dual(&t).cell_volumes)
        );
        let w = frame_weights(&t, omega);
        let (closed, centers) = (
            Vjp::new(&t).dual(Some(w), [0.0; 6], [0.0; 4]),
            power_dual(&t, Some(&omega), Placement::Centres),
        );
        assert!(tol(&closed.weights, &centers.weights), "{closed:?} {centers:?}");
        assert!(tol(&closed.cell_volumes, &centers.cell_volumes), "{closed:?} {centers:?}");
    }
}

#[test]
fn zero_weights_give_the_plain_dual_gradient() {
    let mut rng = Rng(10);
    for _ in 0..50 {
        let x = random_tet(&mut rng, 1.0);
        let (t, _) = frame(&x);
        let (dw, dm) = (rng.array::<6>(), rng.array::<4>());
        let (g, gw) = dual_vjp(&t, None, dw, dm);
        let (h, _) = dual_vjp(&t, Some([0.0; 4]), dw, dm);
        assert_eq!(gw, [0.0; 4]);
        let flat = |g: [DVec3; 4]| g.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>();
        assert!(rel_err(&flat(h), &flat(g)) < 1e-13);
    }
}

#[test]
fn one_vjp_equals_the_sum_of_the_shorthands() {
    let mut rng = Rng(11);
    let x = random_tet(&mut rng, 1.0);
    let (t, _) = frame(&x);
    let (dp, dd, dm, dv) = (rng.array::<6>(), rng.array::<6>(), rng.array::<4>(), rng.uniform());
    let mut v = Vjp::new(&t);
    v.primal(dp);
    v.dual(None, dd, dm);
    v.volume(dv);
    let g = v.finish();
    let (a, b, c) = (primal_vjp(&t, dp), dual_vjp(&t, None, dd, dm).0, volume_vjp(&t, dv));
    for i in 0..4 {
        assert!(
            (g.corners[i] - (a[i] + b[i] + c[i])).length() < 1e-14 * g.corners[i].length().max(1.0)
        );
    }
}

#[test]
fn results_are_bitwise_reproducible() {
    let mut rng = Rng(12);
    let x = random_tet(&mut rng, 1.0);
    let (t, _) = frame(&x);
    let w = Some(rng.array::<4>().map(|w| 0.01 * w));
    let (dw, dm) = (rng.array::<6>(), rng.array::<4>());
    let first = dual_vjp(&t, w, dw, dm);
    for _ in 0..3 {
        // other work in between does not change a bit
        let _ = dual_vjp(&frame(&random_tet(&mut rng, 1.0)).0, None, dw, dm);
        assert_eq!(dual_vjp(&t, w, dw, dm), first);
    }
}

#[test]
fn hand_computed_corner_tet() {
    // Corner tet x0 = 0, x_k = e_k: Vol = 1/6, d Vol / d x_3 = (x_1 - x_0) x (x_2 - x_0) / 6.
    let x: Points = vec![vec![0., 0., 0.], vec![1., 0., 0.], vec![0., 1., 0.], vec![0., 0., 1.]];
    let (t, _) = frame(&x);
    let g = volume_vjp(&t, 1.0);
    assert_eq!(g[3], DVec3::new(0.0, 0.0, 1.0 / 6.0));
    assert_eq!(g[0], DVec3::splat(-1.0 / 6.0));
    // primal, with x_1 = (a, 0, 0), x_2 = (0, b, 0): n_0 . n_1 = -b^2, det = a b, so
    // w_01 = b / (6 a): d/da = -1/6, d/db = 1/6 at a = b = 1.
    let g = primal_vjp(&t, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!((g[1].x + 1.0 / 6.0).abs() < 1e-15 && (g[2].y - 1.0 / 6.0).abs() < 1e-15, "{g:?}");
}

#[test]
fn degenerate_tets_give_non_finite_gradients() {
    // four coplanar corners: the caller must check `is_degenerate` first
    let x: Points = vec![vec![0., 0., 0.], vec![1., 0., 0.], vec![0., 1., 0.], vec![1., 1., 0.]];
    let (t, _) = frame(&x);
    assert!(crate::element::tet::is_degenerate(&t));
    let finite = |g: [DVec3; 4]| g.iter().all(|v| v.is_finite());
    assert!(!finite(primal_vjp(&t, [1.0; 6])));
    assert!(!finite(dual_vjp(&t, None, [1.0; 6], [1.0; 4]).0));
}

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
