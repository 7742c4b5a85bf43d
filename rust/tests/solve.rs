//! `tetlap::solve::Factorization`: solves checked against a dense reference, refactoring on
//! the same pattern, inertia of indefinite matrices, determinism, and errors (never panics).

use tetlap::solve::{Analysis, Factorization, Inertia, LuFactors, Method, Ordering};
use tetlap::{laplacian, CsrRef, Error, LaplacianKind, Options, TetView};

/// A square CSR matrix, owned.
struct Matrix {
    n: usize,
    indptr: Vec<usize>,
    indices: Vec<u32>,
    data: Vec<f64>,
}

impl Matrix {
    fn view(&self) -> CsrRef<'_> {
        CsrRef { n: self.n, indptr: &self.indptr, indices: &self.indices, data: &self.data }
    }

    fn times(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| (self.indptr[i]..self.indptr[i + 1]).map(|k| self.data[k] * x[self.indices[k] as usize]).sum())
            .collect()
    }

    /// `-L + shift I` of the primal Laplacian of a jittered grid with `k^3` cubes, its
    /// first vertex fixed (dropped), so that `shift = 0` is positive definite.
    fn grid(k: usize, shift: f64) -> Matrix {
        let (points, tets) = grid_mesh(k);
        let mesh = TetView::new(&points, 3, &tets).unwrap();
        let l = laplacian(&mesh, LaplacianKind::Primal, &Options::default()).unwrap();
        let mut m = Matrix { n: l.n - 1, indptr: vec![0], indices: vec![], data: vec![] };
        for i in 1..l.n {
            for k in l.indptr[i]..l.indptr[i + 1] {
                let j = l.indices[k] as usize;
                if j > 0 {
                    m.indices.push(j as u32 - 1);
                    m.data.push(-l.data[k] + if i == j { shift } else { 0.0 });
                }
            }
            m.indptr.push(m.indices.len());
        }
        m
    }
}

/// A Kuhn grid of the unit cube with deterministic jitter.
fn grid_mesh(k: usize) -> (Vec<f64>, Vec<[u32; 4]>) {
    let id = |x: usize, y: usize, z: usize| (x + (k + 1) * (y + (k + 1) * z)) as u32;
    let mut points = vec![];
    let mut state = 12345u64;
    for z in 0..=k {
        for y in 0..=k {
            for x in 0..=k {
                for c in [x, y, z] {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    let jitter = ((state >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 0.2;
                    points.push((c as f64 + if c > 0 && c < k { jitter } else { 0.0 }) / k as f64);
                }
            }
        }
    }
    let mut tets = vec![];
    for z in 0..k {
        for y in 0..k {
            for x in 0..k {
                let c = |dx, dy, dz| id(x + dx, y + dy, z + dz);
                let (a, g) = (c(0, 0, 0), c(1, 1, 1));
                for path in [[c(1, 0, 0), c(1, 1, 0)], [c(1, 0, 0), c(1, 0, 1)], [c(0, 1, 0), c(1, 1, 0)],
                             [c(0, 1, 0), c(0, 1, 1)], [c(0, 0, 1), c(1, 0, 1)], [c(0, 0, 1), c(0, 1, 1)]] {
                    tets.push([a, path[0], path[1], g]);
                }
            }
        }
    }
    (points, tets)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn residual(a: &Matrix, x: &[f64], b: &[f64]) -> f64 {
    let ax = a.times(x);
    max_abs(&ax.iter().zip(b).map(|(p, q)| p - q).collect::<Vec<_>>()) / max_abs(b)
}

/// The eigenvalues of a small symmetric matrix, ascending, by cyclic Jacobi rotations (a
/// dense reference independent of the factorization under test).
fn dense_eigenvalues(a: &Matrix) -> Vec<f64> {
    let n = a.n;
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        for k in a.indptr[i]..a.indptr[i + 1] {
            m[i * n + a.indices[k] as usize] = a.data[k];
        }
    }
    for _sweep in 0..100 {
        let off: f64 = (0..n).flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j))).map(|(i, j)| m[i * n + j].powi(2)).sum();
        if off < 1e-24 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = m[p * n + q];
                if apq.abs() < 1e-300 {
                    continue;
                }
                let theta = (m[q * n + q] - m[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                for k in 0..n {
                    let (akp, akq) = (m[k * n + p], m[k * n + q]);
                    m[k * n + p] = c * akp - s * akq;
                    m[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (m[p * n + k], m[q * n + k]);
                    m[p * n + k] = c * apk - s * aqk;
                    m[q * n + k] = s * apk + c * aqk;
                }
            }
        }
    }
    let mut lam: Vec<f64> = (0..n).map(|i| m[i * n + i]).collect();
    lam.sort_by(f64::total_cmp);
    lam
}

#[test]
fn a_positive_definite_system_is_solved_with_every_ordering_and_method() {
    let a = Matrix::grid(5, 0.0);
    let b: Vec<f64> = (0..a.n).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
    let reverse: Vec<u32> = (0..a.n as u32).rev().collect();
    for ordering in [Ordering::Amd, Ordering::Identity, Ordering::Custom(reverse)] {
        for method in [Method::Cholesky, Method::Ldlt] {
            let f = Factorization::new(a.view(), method, &ordering, &Options::default()).unwrap_or_else(|e| panic!("{ordering:?} {method:?} {e}"));
            let mut x = b.clone();
            f.solve(&mut x, &Options::default()).unwrap();
            assert!(residual(&a, &x, &b) < 1e-12, "{ordering:?} {method:?}");
            assert_eq!(f.inertia(), Inertia { negative: 0, zero: 0, positive: a.n });
            assert_eq!(f.method(), method);
            assert!(f.factor_entries() >= a.n);
        }
    }
}

#[test]
fn several_right_hand_sides_are_solved_at_once() {
    let a = Matrix::grid(4, 0.0);
    let opts = Options::default();
    let f = Factorization::new(a.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    let columns: Vec<Vec<f64>> = (0..3).map(|c| (0..a.n).map(|i| ((i + c) % 5) as f64).collect()).collect();
    let mut block: Vec<f64> = columns.concat();
    f.solve(&mut block, &opts).unwrap();
    for (c, b) in columns.iter().enumerate() {
        let mut x = b.clone();
        f.solve(&mut x, &opts).unwrap();
        assert_eq!(&block[c * a.n..(c + 1) * a.n], &x[..], "column {c}: the block solve is the single solve");
        assert!(residual(&a, &x, b) < 1e-12);
    }
}

#[test]
fn refactoring_the_same_pattern_matches_a_fresh_factorization_bitwise() {
    let a = Matrix::grid(4, 0.0);
    let opts = Options::default();
    let mut f = Factorization::new(a.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    // a time step M - t L: every value changes, the pattern does not
    let mut b = Matrix { data: a.data.iter().map(|v| 0.3 * v).collect(), indptr: a.indptr.clone(), indices: a.indices.clone(), n: a.n };
    for i in 0..b.n {
        for k in b.indptr[i]..b.indptr[i + 1] {
            if b.indices[k] as usize == i {
                b.data[k] += 0.01;
            }
        }
    }
    f.refactor(b.view(), &opts).unwrap();
    let fresh = Factorization::new(b.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    let rhs: Vec<f64> = (0..a.n).map(|i| (i % 3) as f64).collect();
    let (mut x, mut y) = (rhs.clone(), rhs.clone());
    f.solve(&mut x, &opts).unwrap();
    fresh.solve(&mut y, &opts).unwrap();
    assert_eq!(x, y);
    assert!(residual(&b, &x, &rhs) < 1e-12);
    // another pattern is refused, not mis-solved
    let smaller = Matrix::grid(3, 0.0);
    assert!(matches!(f.refactor(smaller.view(), &opts), Err(Error::Shape { .. })));
}

#[test]
fn the_inertia_of_an_indefinite_matrix_counts_its_negative_eigenvalues() {
    // -L - s I has as many negative eigenvalues as -L has below s
    let a = Matrix::grid(3, 0.0);
    let lam = dense_eigenvalues(&a);
    let opts = Options::default();
    for k in [1, 5, 17, 40] {
        let s = (lam[k - 1] + lam[k]) / 2.0;
        let shifted = Matrix::grid(3, -s);
        let f = Factorization::new(shifted.view(), Method::Ldlt, &Ordering::Amd, &opts).unwrap();
        assert_eq!(f.inertia(), Inertia { negative: k, zero: 0, positive: a.n - k }, "shift between eigenvalues {k} and {}", k + 1);
        let b: Vec<f64> = (0..a.n).map(|i| (i % 4) as f64 - 1.5).collect();
        let mut x = b.clone();
        f.solve(&mut x, &opts).unwrap();
        assert!(residual(&shifted, &x, &b) < 1e-9);
        // the Cholesky refuses it, naming a row
        let err = Factorization::new(shifted.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap_err();
        assert!(matches!(err, Error::NotPositiveDefinite { row } if row < a.n), "{err}");
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let a = Matrix::grid(6, 0.0);
    let b: Vec<f64> = (0..a.n).map(|i| (i % 9) as f64).collect();
    let solve = |threads| {
        let opts = Options { threads: Some(threads), ..Default::default() };
        let f = Factorization::new(a.view(), Method::Ldlt, &Ordering::Amd, &opts).unwrap();
        let mut x = b.clone();
        f.solve(&mut x, &opts).unwrap();
        x.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    };
    assert_eq!(solve(1), solve(2));
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let opts = Options::default();
    let a = Matrix::grid(2, 0.0);
    // not a permutation, wrong length
    for order in [vec![0u32; a.n], vec![0, 1]] {
        assert!(matches!(Factorization::new(a.view(), Method::Cholesky, &Ordering::Custom(order), &opts), Err(Error::Shape { .. })));
    }
    // a broken layout
    let bad = CsrRef { indptr: &a.indptr[..a.n], ..a.view() };
    assert!(matches!(Factorization::new(bad, Method::Ldlt, &Ordering::Amd, &opts), Err(Error::Shape { .. })));
    // a zero pivot in LDL^T: [[0, 1], [1, 0]] without pivoting
    let (indptr, indices, data) = ([0, 1, 2], [1, 0], [1.0, 1.0]);
    let swap = CsrRef { n: 2, indptr: &indptr, indices: &indices, data: &data };
    let err = Factorization::new(swap, Method::Ldlt, &Ordering::Identity, &opts).unwrap_err();
    assert!(matches!(err, Error::Singular { row } if row < 2), "{err}");
    // a 1 x 1 negative matrix: the failed pivot is named, not an index past the end
    let (indptr, indices, data) = ([0, 1], [0], [-1.0]);
    let negative = CsrRef { n: 1, indptr: &indptr, indices: &indices, data: &data };
    assert_eq!(Factorization::new(negative, Method::Cholesky, &Ordering::Amd, &opts).unwrap_err(), Error::NotPositiveDefinite { row: 0 });
    // right-hand sides of the wrong length, a bad thread count
    let f = Factorization::new(a.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    assert!(matches!(f.solve(&mut vec![0.0; a.n + 1], &opts), Err(Error::Shape { .. })));
    let threads = Options { threads: Some(0), ..Default::default() };
    assert!(matches!(f.solve(&mut vec![0.0; a.n], &threads), Err(Error::Threads { .. })));
    // cancelled before the work
    let cancel = tetlap::Cancel::new();
    cancel.cancel();
    let cancelled = Options { cancel: Some(cancel), ..Default::default() };
    assert_eq!(Factorization::new(a.view(), Method::Cholesky, &Ordering::Amd, &cancelled).unwrap_err(), Error::Cancelled);
}

#[test]
fn a_singular_matrix_has_a_pivot_tiny_against_its_diagonal() {
    // -L of the whole grid (constants in its null space) against -L with a vertex dropped
    let (points, tets) = grid_mesh(3);
    let mesh = TetView::new(&points, 3, &tets).unwrap();
    let l = laplacian(&mesh, LaplacianKind::Primal, &Options::default()).unwrap();
    let singular = Matrix { n: l.n, indptr: l.indptr.clone(), indices: l.indices.clone(), data: l.data.iter().map(|v| -v).collect() };
    let opts = Options::default();
    let f = Factorization::new(singular.view(), Method::Ldlt, &Ordering::Amd, &opts).unwrap();
    let (row, ratio) = f.smallest_pivot();
    assert!(ratio < 1e-13 && row < l.n, "{row} {ratio}");
    let a = Matrix::grid(3, 0.0);
    for method in [Method::Cholesky, Method::Ldlt] {
        let f = Factorization::new(a.view(), method, &Ordering::Amd, &opts).unwrap();
        assert!(f.smallest_pivot().1 > 1e-3, "{method:?} {:?}", f.smallest_pivot());
        let pivots = f.pivots();
        assert_eq!(pivots.len(), a.n);
        assert!(pivots.iter().all(|&d| d > 0.0));
    }
    // a symmetric diagonal scaling changes no ratio
    let s: Vec<f64> = (0..a.n).map(|i| 10f64.powi(i as i32 % 7 - 3)).collect();
    let mut scaled = Matrix { n: a.n, indptr: a.indptr.clone(), indices: a.indices.clone(), data: a.data.clone() };
    for i in 0..a.n {
        for k in a.indptr[i]..a.indptr[i + 1] {
            scaled.data[k] *= s[i] * s[a.indices[k] as usize];
        }
    }
    let plain = Factorization::new(a.view(), Method::Cholesky, &Ordering::Identity, &opts).unwrap().smallest_pivot();
    let other = Factorization::new(scaled.view(), Method::Cholesky, &Ordering::Identity, &opts).unwrap().smallest_pivot();
    assert!((plain.1 - other.1).abs() <= 1e-12 * plain.1, "{plain:?} {other:?}");
}

#[test]
fn the_numeric_step_into_a_callers_slice_is_the_factorization_bitwise() {
    // what a caller runs elsewhere (a child process) and hands back with from_parts
    let a = Matrix::grid(4, 0.0);
    let opts = Options::default();
    let rhs: Vec<f64> = (0..a.n).map(|i| (i % 5) as f64 - 2.0).collect();
    for (method, ordering) in [(Method::Cholesky, Ordering::Amd), (Method::Ldlt, Ordering::Identity)] {
        let whole = Factorization::new(a.view(), method, &ordering, &opts).unwrap();
        let analysis = Analysis::new(a.view(), method, &ordering, &opts).unwrap();
        let mut values = vec![f64::NAN; analysis.values_len()];
        analysis.numeric(&a.data, &mut values, &mut analysis.workspace().unwrap()).unwrap();
        let parts = Factorization::from_parts(analysis, &a.data, values).unwrap();
        let (mut x, mut y) = (rhs.clone(), rhs.clone());
        whole.solve(&mut x, &opts).unwrap();
        parts.solve(&mut y, &opts).unwrap();
        assert_eq!(x, y, "{method:?}");
        assert_eq!(whole.pivots(), parts.pivots());
        assert_eq!(whole.smallest_pivot(), parts.smallest_pivot());
        assert_eq!(whole.factor_entries(), parts.factor_entries());
        // refactor_with: the numeric step done by the caller, into storage it chooses
        let mut other = parts;
        let doubled: Vec<f64> = a.data.iter().map(|v| 2.0 * v).collect();
        let b = Matrix { data: doubled.clone(), indptr: a.indptr.clone(), indices: a.indices.clone(), n: a.n };
        other
            .refactor_with(b.view(), |analysis, values| {
                *values = vec![0.0; analysis.values_len()];
                analysis.numeric(&doubled, values, &mut analysis.workspace()?)
            })
            .unwrap();
        let mut z = rhs.clone();
        other.solve(&mut z, &opts).unwrap();
        assert!(z.iter().zip(&x).all(|(z, x)| (2.0 * z - x).abs() <= 1e-12 * x.abs().max(1.0)));
    }
}

#[test]
fn the_parts_of_a_factorization_are_checked() {
    let a = Matrix::grid(3, 0.0);
    let opts = Options::default();
    let analysis = Analysis::new(a.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    let len = analysis.values_len();
    let mut workspace = analysis.workspace().unwrap();
    let short = vec![0.0; len - 1];
    assert!(matches!(analysis.numeric(&a.data, &mut vec![0.0; len - 1], &mut workspace), Err(Error::Shape { .. })));
    assert!(matches!(analysis.numeric(&a.data[1..], &mut vec![0.0; len], &mut workspace), Err(Error::Shape { .. })));
    let smaller = Matrix::grid(2, 0.0);
    assert!(matches!(analysis.check_pattern(smaller.view()), Err(Error::Shape { .. })));
    assert!(matches!(Factorization::from_parts(analysis, &a.data, short), Err(Error::Shape { .. })));
    // a failed pivot names its row, in the numeric step as in the whole factorization
    let indefinite = Matrix::grid(3, -50.0);
    let analysis = Analysis::new(indefinite.view(), Method::Cholesky, &Ordering::Amd, &opts).unwrap();
    let mut values = vec![0.0; analysis.values_len()];
    let err = analysis.numeric(&indefinite.data, &mut values, &mut analysis.workspace().unwrap()).unwrap_err();
    assert_eq!(Err(err), Factorization::new(indefinite.view(), Method::Cholesky, &Ordering::Amd, &opts).map(drop));
}

/// `P_r^T L U P_c^T` of unit lower `l` and upper `u` (dense, row-major) as CSR, and the
/// factors by columns (the CSR of their transposes).
fn lu_product(l: &[f64], u: &[f64], rows: &[u32], columns: &[u32], n: usize) -> (Matrix, Matrix, Matrix) {
    let mut lu = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            lu[i * n + j] = (0..n).map(|k| l[i * n + k] * u[k * n + j]).sum();
        }
    }
    // P_r A P_c = LU: row i of A is row rows[i] of LU, column k of A its column columns[k]
    let mut a = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..n {
            a[i * n + k] = lu[rows[i] as usize * n + columns[k] as usize];
        }
    }
    let csr = |m: &[f64], transpose: bool| {
        let mut out = Matrix { n, indptr: vec![0], indices: vec![], data: vec![] };
        for i in 0..n {
            for j in 0..n {
                let v = if transpose { m[j * n + i] } else { m[i * n + j] };
                if v != 0.0 || i == j {
                    out.indices.push(j as u32);
                    out.data.push(v);
                }
            }
            out.indptr.push(out.indices.len());
        }
        out
    };
    (csr(&a, false), csr(l, true), csr(u, true))
}

#[test]
fn lu_factors_made_elsewhere_solve_their_matrix() {
    let n = 7;
    let mut state = 99u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 33) as f64 / (1u64 << 31) as f64) - 0.5
    };
    let (mut l, mut u) = (vec![0.0; n * n], vec![0.0; n * n]);
    for i in 0..n {
        for j in 0..n {
            if i > j && (i + j) % 3 != 0 {
                l[i * n + j] = next();
            }
            if i < j && (i * j) % 4 != 1 {
                u[i * n + j] = next();
            }
        }
        l[i * n + i] = 1.0;
        u[i * n + i] = 2.0 + next();
    }
    let rows = [3, 0, 6, 1, 5, 2, 4];
    let columns = [1, 4, 0, 6, 2, 5, 3];
    let (a, lc, uc) = lu_product(&l, &u, &rows, &columns, n);
    let f = LuFactors::new(lc.view(), uc.view(), &rows, &columns).unwrap();
    assert_eq!(f.n(), n);
    let opts = Options::default();
    let b: Vec<f64> = (0..2 * n).map(|i| (i % 5) as f64 - 1.5).collect();
    let mut x = b.clone();
    f.solve(&mut x, &opts).unwrap();
    for c in 0..2 {
        assert!(residual(&a, &x[c * n..(c + 1) * n], &b[c * n..(c + 1) * n]) < 1e-13, "column {c}");
    }
    let [(lp, li, ld), _] = f.factors();
    assert_eq!((lp, ld), (lc.indptr.as_slice(), lc.data.as_slice()));
    assert!(li.iter().zip(&lc.indices).all(|(&a, &b)| a == b as usize));
    // factors that are not triangular, lack a diagonal entry, or permutations that are not
    let swapped = LuFactors::new(uc.view(), lc.view(), &rows, &columns);
    assert!(matches!(swapped, Err(Error::Shape { .. })), "{swapped:?}");
    let mut holed = Matrix { n, indptr: lc.indptr.clone(), indices: lc.indices.clone(), data: lc.data.clone() };
    holed.indices.remove(0);
    holed.data.remove(0);
    for p in &mut holed.indptr[1..] {
        *p -= 1;
    }
    assert!(matches!(LuFactors::new(holed.view(), uc.view(), &rows, &columns), Err(Error::Shape { .. })));
    assert!(matches!(LuFactors::new(lc.view(), uc.view(), &[0, 0, 1, 2, 3, 4, 5], &columns), Err(Error::Shape { .. })));
    assert!(matches!(f.solve(&mut [1.0; 3], &opts), Err(Error::Shape { .. })));
}
