//! The mesh-level VJP against fourth-order central differences of the assembled operators
//! (same stencil and sliver rule as the kernels' tests: jittered grids have no slivers),
//! and its determinism, options and errors.

use super::*;
use crate::sparse::{Csr, Mass};
use crate::options::Degenerate;
use crate::{laplacian, mass, Cancel};

/// splitmix64.
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
    fn vec(&mut self, n: usize) -> Vec<f64> {
        (0..n).map(|_| self.uniform()).collect()
    }
}

/// A Kuhn grid of `6 k^3` tets with interior vertices jittered by up to `0.25 / k`, and
/// every other tet's orientation flipped.
fn grid(k: usize, rng: &mut Rng) -> (Vec<f64>, Vec<[u32; 4]>) {
    let id = |x: usize, y: usize, z: usize| ((x * (k + 1) + y) * (k + 1) + z) as u32;
    let mut points = vec![];
    for x in 0..=k {
        for y in 0..=k {
            for z in 0..=k {
                let interior = [x, y, z].iter().all(|&c| c > 0 && c < k);
                for c in [x, y, z] {
                    let j = if interior { 0.25 * rng.uniform() } else { 0.0 };
                    points.push((c as f64 + j) / k as f64);
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
                    if tets.len() % 2 == 1 {
                        tet.swap(2, 3);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    (points, tets)
}

/// The same points in R^4, rotated out of the x-y-z space (and shifted).
fn immerse(points: &[f64]) -> Vec<f64> {
    let (c, s) = (0.6, 0.8);
    points.chunks_exact(3).flat_map(|p| [c * p[0] + 0.1, p[1], p[2] - 0.2, s * p[0] + 0.3]).collect()
}

/// `<A, B>` over the entries of two CSR matrices (B's pattern, A looked up).
fn frobenius(a: CsrRef, b: &Csr) -> f64 {
    let mut s = 0.0;
    for i in 0..b.n {
        for k in b.indptr[i]..b.indptr[i + 1] {
            s += a.get(i, b.indices[k] as usize) * b.data[k];
        }
    }
    s
}

/// An owned cotangent in one of the forms, for building [`Cotangents`].
#[derive(Clone)]
enum Form {
    Elements(Vec<[f64; 6]>),
    Matrix(Csr),
    Columns(Vec<f64>, usize),
    Diagonal(Vec<f64>),
}

#[derive(Clone)]
struct Case {
    lap: Option<(LaplacianKind, Form)>,
    mass: Option<(MassKind, Form)>,
}

impl Case {
    fn cotangents(&self) -> Cotangents<'_> {
        Cotangents {
            laplacian: self.lap.as_ref().map(|(k, f)| {
                (
                    *k,
                    match f {
                        Form::Elements(e) => LaplacianCotangent::Elements(e),
                        Form::Matrix(m) => LaplacianCotangent::Matrix(m.into()),
                        Form::Columns(v, c) => LaplacianCotangent::Dirichlet(Columns::new(v, *c)),
                        Form::Diagonal(_) => unreachable!(),
                    },
                )
            }),
            mass: self.mass.as_ref().map(|(k, f)| {
                (
                    *k,
                    match f {
                        Form::Diagonal(d) => MassCotangent::Diagonal(d),
                        Form::Matrix(m) => MassCotangent::Matrix(m.into()),
                        Form::Columns(v, c) => MassCotangent::Quadratic(Columns::new(v, *c)),
                        Form::Elements(_) => unreachable!(),
                    },
                )
            }),
        }
    }

    /// `<dL, L> + <dM, M>` from the forward operators.
    fn forward(&self, points: &[f64], dim: usize, tets: &[[u32; 4]], weights: Option<&[f64]>) -> f64 {
        let mut mesh = TetView::new(points, dim, tets).unwrap();
        if let Some(w) = weights {
            mesh = mesh.with_vertex_weights(w).unwrap();
        }
        let opts = Options::default();
        let n = mesh.n_vertices();
        let mut phi = 0.0;
        if let Some((kind, form)) = &self.lap {
            match form {
                Form::Elements(e) => {
                    let w = crate::contributions(&mesh, *kind, &opts).unwrap();
                    phi += w
                        .iter()
                        .zip(e)
                        .map(|(w, e)| w.iter().zip(e).map(|(a, b)| a * b).sum::<f64>())
                        .sum::<f64>();
                }
                Form::Matrix(dl) => phi += frobenius(dl.into(), &laplacian(&mesh, *kind, &opts).unwrap()),
                Form::Columns(f, k) => {
                    let l = laplacian(&mesh, *kind, &opts).unwrap();
                    for i in 0..n {
                        for p in l.indptr[i]..l.indptr[i + 1] {
                            let j = l.indices[p] as usize;
                            phi -= l.data[p] * (0..*k).map(|c| f[i * k + c] * f[j * k + c]).sum::<f64>();
                        }
                    }
                }
                Form::Diagonal(_) => unreachable!(),
            }
        }
        if let Some((kind, form)) = &self.mass {
            let m = mass(&mesh, *kind, &opts).unwrap();
            let entries = match m {
                Mass::Lumped(d) => {
                    Csr { n, indptr: (0..=n).collect(), indices: (0..n as u32).collect(), data: d }
                }
                Mass::Consistent(c) => c,
            };
            phi += match form {
                Form::Diagonal(d) => (0..n).map(|i| d[i] * entries.get(i, i)).sum::<f64>(),
                Form::Matrix(dm) => frobenius(dm.into(), &entries),
                Form::Columns(f, k) => {
                    let mut s = 0.0;
                    for i in 0..n {
                        for p in entries.indptr[i]..entries.indptr[i + 1] {
                            let j = entries.indices[p] as usize;
                            s += entries.data[p] * (0..*k).map(|c| f[i * k + c] * f[j * k + c]).sum::<f64>();
                        }
                    }
                    s
                }
                Form::Elements(_) => unreachable!(),
            };
        }
        phi
    }
}

const H: f64 = 1.0 / 8192.0;

fn stencil(f: impl Fn(f64) -> f64, h: f64) -> f64 {
    (8.0 * (f(h) - f(-h)) - (f(2.0 * h) - f(-2.0 * h))) / (12.0 * h)
}

fn rel_err(g: &[f64], fd: &[f64]) -> f64 {
    let scale = g.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-300);
    g.iter().zip(fd).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max) / scale
}

/// Checks the VJP of `case` against differences in every coordinate (and weight).
fn check(case: &Case, points: &[f64], dim: usize, tets: &[[u32; 4]], weights: Option<&[f64]>) -> f64 {
    let mut mesh = TetView::new(points, dim, tets).unwrap();
    if let Some(w) = weights {
        mesh = mesh.with_vertex_weights(w).unwrap();
    }
    let g = vjp(&mesh, &case.cotangents(), &Options::default()).unwrap();
    let value = case.forward(points, dim, tets, weights);
    assert!((g.value - value).abs() <= 1e-12 * value.abs().max(1e-12), "{} vs {value}", g.value);
    let mut fd = vec![0.0; points.len()];
    for (k, d) in fd.iter_mut().enumerate() {
        *d = stencil(
            |h| {
                let mut p = points.to_vec();
                p[k] += h;
                case.forward(&p, dim, tets, weights)
            },
            H,
        );
    }
    let mut err = rel_err(&g.points, &fd);
    if let Some(w) = weights {
        let fdw: Vec<f64> = (0..w.len())
            .map(|i| {
                stencil(
                    |h| {
                        let mut v = w.to_vec();
                        v[i] += h;
                        case.forward(points, dim, tets, Some(&v))
                    },
                    H * 0.1,
                )
            })
            .collect();
        let gw = g.weights.as_ref().unwrap();
        let wscale = gw.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if wscale > 0.0 {
            err = err.max(rel_err(gw, &fdw));
        }
    }
    err
}

/// A random cotangent matrix on L's pattern plus a few entries off it.
fn random_matrix(mesh: &TetView, rng: &mut Rng) -> Csr {
    let mut l = laplacian(mesh, LaplacianKind::Primal, &Options::default()).unwrap();
    for v in l.data.iter_mut() {
        *v = rng.uniform();
    }
    l
}

fn cases(mesh: &TetView, rng: &mut Rng) -> Vec<Case> {
    let (n, m) = (mesh.n_vertices(), mesh.n_elements());
    let f = rng.vec(2 * n);
    let d = rng.vec(n);
    let e: Vec<[f64; 6]> = (0..m).map(|_| std::array::from_fn(|_| rng.uniform())).collect();
    let matrix = random_matrix(mesh, rng);
    let mut out = vec![];
    for kind in [LaplacianKind::Primal, LaplacianKind::Dual, LaplacianKind::Affine(0.3)] {
        out.push(Case { lap: Some((kind, Form::Columns(f.clone(), 2))), mass: None });
        out.push(Case { lap: Some((kind, Form::Matrix(matrix.clone()))), mass: None });
        out.push(Case { lap: Some((kind, Form::Elements(e.clone()))), mass: None });
    }
    for kind in [MassKind::Barycentric, MassKind::Circumcentric, MassKind::Fem] {
        out.push(Case { lap: None, mass: Some((kind, Form::Diagonal(d.clone()))) });
        out.push(Case { lap: None, mass: Some((kind, Form::Matrix(matrix.clone()))) });
        out.push(Case { lap: None, mass: Some((kind, Form::Columns(f[..n].to_vec(), 1))) });
    }
    out.push(Case {
        lap: Some((LaplacianKind::Dual, Form::Columns(f.clone(), 2))),
        mass: Some((MassKind::Circumcentric, Form::Diagonal(d.clone()))),
    });
    out
}

#[test]
fn gradients_match_central_differences() {
    let mut rng = Rng(1);
    let (points, tets) = grid(2, &mut rng);
    let mesh = TetView::new(&points, 3, &tets).unwrap();
    for (k, case) in cases(&mesh, &mut rng).iter().enumerate() {
        let err = check(case, &points, 3, &tets, None);
        assert!(err < 1e-8, "case {k}: relative error {err:e}");
    }
}

#[test]
fn immersed_meshes_match_central_differences() {
    let mut rng = Rng(2);
    let (points, tets) = grid(2, &mut rng);
    let p4 = immerse(&points);
    let mesh = TetView::new(&p4, 4, &tets).unwrap();
    let all = cases(&mesh, &mut rng);
    for k in [0, 4, 10, 13, 18] {
        let err = check(&all[k], &p4, 4, &tets, None);
        assert!(err < 1e-8, "case {k}: relative error {err:e}");
    }
}

#[test]
fn weighted_duals_match_central_differences() {
    let mut rng = Rng(3);
    let (points, tets) = grid(2, &mut rng);
    let n = points.len() / 3;
    let w: Vec<f64> = rng.vec(n).iter().map(|x| 0.02 * x).collect();
    let mesh = TetView::new(&points, 3, &tets).unwrap().with_vertex_weights(&w).unwrap();
    let all = cases(&mesh, &mut rng);
    for k in [3, 4, 13, 18] {
        let err = check(&all[k], &points, 3, &tets, Some(&w));
        assert!(err < 1e-7, "case {k}: relative error {err:e}");
    }
    // weights get zero gradient from the primal and the barycentric mass
    let g = vjp(&mesh, &all[0].cotangents(), &Options::default()).unwrap();
    assert!(g.weights.unwrap().iter().all(|&x| x == 0.0));
}

#[test]
fn bitwise_identical_for_any_thread_count() {
    let mut rng = Rng(4);
    let (points, tets) = grid(6, &mut rng);
    let mesh = TetView::new(&points, 3, &tets).unwrap();
    let w = rng.vec(mesh.n_vertices());
    let weighted = mesh.with_vertex_weights(&w).unwrap();
    let all = cases(&mesh, &mut rng);
    for case in [&all[1], &all[18]] {
        for m in [&mesh, &weighted] {
            let runs: Vec<MeshGradient> = [None, Some(1), Some(2), Some(3)]
                .into_iter()
                .map(|threads| {
                    vjp(m, &case.cotangents(), &Options { threads, ..Default::default() }).unwrap()
                })
                .collect();
            for r in &runs[1..] {
                assert_eq!(
                    r.points.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    runs[0].points.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
                );
                assert_eq!(r.value.to_bits(), runs[0].value.to_bits());
                assert_eq!(r.weights, runs[0].weights);
            }
        }
    }
}

#[test]
fn translations_give_zero_total_gradient() {
    let mut rng = Rng(5);
    let (points, tets) = grid(3, &mut rng);
    let mesh = TetView::new(&points, 3, &tets).unwrap();
    for case in cases(&mesh, &mut rng) {
        let g = vjp(&mesh, &case.cotangents(), &Options::default()).unwrap();
        let scale = g.points.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        for c in 0..3 {
            let s: f64 = g.points.iter().skip(c).step_by(3).sum();
            assert!(s.abs() < 1e-12 * scale * g.points.len() as f64);
        }
    }
}

#[test]
fn errors_and_policies() {
    let mut rng = Rng(6);
    let (points, tets) = grid(2, &mut rng);
    let mesh = TetView::new(&points, 3, &tets).unwrap();
    let n = mesh.n_vertices();
    let f = vec![1.0; n];
    let dirichlet = |kind| Cotangents {
        laplacian: Some((kind, LaplacianCotangent::Dirichlet(Columns::new(&f, 1)))),
        mass: None,
    };
    let bary = Options { boundary: Boundary::Barycentric, ..Default::default() };
    assert!(matches!(
        vjp(&mesh, &dirichlet(LaplacianKind::Dual), &bary),
        Err(Error::NotDifferentiable { .. })
    ));
    assert!(vjp(&mesh, &dirichlet(LaplacianKind::Primal), &bary).is_ok());
    assert!(matches!(
        vjp(&mesh, &dirichlet(LaplacianKind::Affine(1.5)), &Options::default()),
        Err(Error::AffineParameter { .. })
    ));
    let short = &f[1..];
    let bad = Cotangents {
        laplacian: Some((LaplacianKind::Primal, LaplacianCotangent::Dirichlet(Columns::new(short, 1)))),
        mass: None,
    };
    assert!(matches!(vjp(&mesh, &bad, &Options::default()), Err(Error::Shape { .. })));
    let mut nan = f.clone();
    nan[3] = f64::NAN;
    let bad = Cotangents { laplacian: None, mass: Some((MassKind::Fem, MassCotangent::Diagonal(&nan))) };
    assert!(matches!(vjp(&mesh, &bad, &Options::default()), Err(Error::NonFiniteCotangent { index: 3, .. })));
    // a matrix with unsorted columns
    let mut m = random_matrix(&mesh, &mut rng);
    m.indices.swap(0, 1);
    let bad = Cotangents {
        laplacian: Some((LaplacianKind::Primal, LaplacianCotangent::Matrix((&m).into()))),
        mass: None,
    };
    assert!(matches!(vjp(&mesh, &bad, &Options::default()), Err(Error::Shape { .. })));
    // a degenerate tet: raise names it, skip drops it
    let mut flat = points.clone();
    let t = tets[5];
    for c in 0..3 {
        flat[3 * t[3] as usize + c] = flat[3 * t[0] as usize + c];
    }
    let sliver_tets = vec![tets[5]];
    let flat_mesh = TetView::new(&flat, 3, &sliver_tets).unwrap();
    assert!(matches!(
        vjp(&flat_mesh, &dirichlet(LaplacianKind::Dual), &Options::default()),
        Err(Error::Degenerate { element: 0 })
    ));
    let skip = Options { degenerate: Degenerate::Skip, ..Default::default() };
    let g = vjp(&flat_mesh, &dirichlet(LaplacianKind::Dual), &skip).unwrap();
    assert!(g.points.iter().all(|&x| x == 0.0) && g.value == 0.0);
    // cancelled
    let cancel = Cancel::new();
    cancel.cancel();
    let opts = Options { cancel: Some(cancel), ..Default::default() };
    assert_eq!(vjp(&mesh, &dirichlet(LaplacianKind::Primal), &opts), Err(Error::Cancelled));
}
