//! Every public operator is bitwise equal for 1, 2 and 3 worker threads and for rayon's
//! global pool, on a jittered grid and on the same grid in random order (several chunks
//! of elements and of rows each, so that the work really is split).

mod common;

use common::{bits, grid, shuffled, threads, tri_grid, THREADS};
use tetlap::*;

const KINDS: [LaplacianKind; 3] = [LaplacianKind::Primal, LaplacianKind::Dual, LaplacianKind::Affine(0.3)];
const MASSES: [MassKind; 3] = [MassKind::Barycentric, MassKind::Circumcentric, MassKind::Fem];

/// Everything computed from a matrix, as bit patterns.
fn csr(l: &Csr) -> Vec<u64> {
    let mut out: Vec<u64> = l.indptr.iter().map(|&x| x as u64).collect();
    out.extend(l.indices.iter().map(|&x| x as u64));
    out.extend(bits(&l.data));
    out
}

fn mass_bits(m: &Mass) -> Vec<u64> {
    match m {
        Mass::Lumped(values) => bits(values),
        Mass::Consistent(l) => csr(l),
    }
}

/// `(what, bits)` of every one-shot and cached operator of a tet mesh.
fn tet_outputs(points: &[f64], cells: &[[u32; 4]], opts: &Options) -> Vec<(String, Vec<u64>)> {
    let mesh = TetView::new(points, 3, cells).unwrap();
    let weights: Vec<f64> = (0..mesh.n_vertices()).map(|i| 1e-3 * (i % 7) as f64).collect();
    let weighted = mesh.with_vertex_weights(&weights).unwrap();
    let barycentric = Options { boundary: Boundary::Barycentric, ..opts.clone() };
    let mut out = vec![];
    let mut push = |what: String, b: Vec<u64>| out.push((what, b));
    for kind in KINDS {
        push(format!("laplacian {kind:?}"), csr(&laplacian(&mesh, kind, opts).unwrap()));
    }
    let dual = LaplacianKind::Dual;
    let flat: Vec<f64> = contributions(&mesh, dual, opts).unwrap().concat();
    push("contributions".into(), bits(&flat));
    let t = triplets(&mesh, LaplacianKind::Affine(0.3), opts).unwrap();
    let mut b: Vec<u64> = t.rows.iter().chain(&t.cols).map(|&x| x as u64).collect();
    b.extend(bits(&t.vals));
    push("triplets".into(), b);
    let (edge_list, w) = edge_weights(&mesh, dual, opts).unwrap();
    let mut b: Vec<u64> = edge_list.iter().flatten().map(|&x| x as u64).collect();
    b.extend(bits(&w));
    push("edge_weights".into(), b);
    push("weighted laplacian".into(), csr(&laplacian(&weighted, dual, opts).unwrap()));
    push("barycentric boundary".into(), csr(&laplacian(&mesh, dual, &barycentric).unwrap()));
    for kind in MASSES {
        push(format!("mass {kind:?}"), mass_bits(&mass(&mesh, kind, opts).unwrap()));
    }
    let (l, m) = operators(&mesh, dual, MassKind::Fem, opts).unwrap();
    push("operators".into(), [csr(&l), mass_bits(&m)].concat());
    let m = mass(&weighted, MassKind::Circumcentric, &barycentric).unwrap();
    push("weighted barycentric-boundary mass".into(), mass_bits(&m));
    // the cached mesh: first assembly, then an update of every tenth vertex
    let mut cached = CachedMesh::<Tet>::new(points.to_vec(), 3, cells.to_vec(), opts.clone()).unwrap();
    push("cached laplacian".into(), csr(&cached.laplacian(LaplacianKind::Dual).unwrap()));
    push("cached mass".into(), mass_bits(&cached.mass(MassKind::Fem).unwrap()));
    let mut moved = points.to_vec();
    for v in (0..moved.len() / 3).step_by(10) {
        moved[3 * v + 1] += 1e-3;
    }
    let update = cached.update(&moved).unwrap();
    push("update".into(), vec![update.moved_vertices as u64, update.recomputed_elements as u64,
                               update.recomputed_rows as u64]);
    push("updated laplacian".into(), csr(&cached.laplacian(LaplacianKind::Dual).unwrap()));
    push("updated mass".into(), mass_bits(&cached.mass(MassKind::Fem).unwrap()));
    // diagnostics
    let n = mesh.n_vertices();
    let f = faces::<Tet>(cells, n, opts).unwrap();
    push("faces".into(), format!("{f:?}").into_bytes().into_iter().map(u64::from).collect());
    push("edges".into(), edges::<Tet>(cells, n, opts).unwrap().iter().flatten().map(|&x| x as u64).collect());
    push("duplicates".into(), duplicate_elements::<Tet>(cells, n, opts).unwrap().iter().map(|&x| x as u64).collect());
    let q = quality(&mesh, opts).unwrap();
    push("quality".into(), format!("{q:?}").into_bytes().into_iter().map(u64::from).collect());
    let nd = non_delaunay_faces(&mesh, &f.interior, DELAUNAY_RTOL, opts).unwrap();
    push("non-Delaunay faces".into(), nd.iter().map(|&x| x as u64).collect());
    let mut boundary = vec![false; n];
    for &[t, c] in &f.boundary {
        for (k, &v) in cells[t as usize].iter().enumerate() {
            boundary[v as usize] |= k != c as usize;
        }
    }
    let l = laplacian(&mesh, LaplacianKind::Dual, opts).unwrap();
    let check = check_operator(&l, &mesh, &boundary, 1e-12, opts).unwrap();
    push("check_operator".into(), format!("{check:?}").into_bytes().into_iter().map(u64::from).collect());
    out
}

fn assert_same_for_every_thread_count(points: &[f64], cells: &[[u32; 4]]) {
    let reference = tet_outputs(points, cells, &threads(Some(1)));
    assert_eq!(reference.len(), 24); // every push of tet_outputs
    for t in &THREADS[1..] {
        let other = tet_outputs(points, cells, &threads(*t));
        for ((what, a), (_, b)) in reference.iter().zip(&other) {
            assert!(a == b, "{what} differs between 1 thread and {t:?}");
        }
    }
}

#[test]
fn jittered_grid() {
    let (points, cells) = grid(8, 0.2, 1); // 3072 tets, 729 vertices: 2 element and 2 row chunks
    assert_same_for_every_thread_count(&points, &cells);
}

#[test]
fn random_order_grid() {
    let (points, cells) = grid(8, 0.2, 2);
    let (points, cells, _) = shuffled(&points, 3, &cells, 3);
    assert_same_for_every_thread_count(&points, &cells);
}

#[test]
fn negative_semidefinite_certificates() {
    // a strongly jittered small grid: the dual has negative weights to certify
    let (points, cells) = grid(5, 0.24, 11);
    let mesh = TetView::new(&points, 3, &cells).unwrap();
    let l = laplacian(&mesh, LaplacianKind::Dual, &Options::default()).unwrap();
    let tol = vec![1e-9 * l.data.iter().fold(0.0f64, |m, x| m.max(x.abs())); l.n];
    let reference = format!("{:?}", negative_semidefinite(&l, &tol, &threads(Some(1))).unwrap());
    for t in &THREADS[1..] {
        assert_eq!(format!("{:?}", negative_semidefinite(&l, &tol, &threads(*t)).unwrap()), reference);
    }
}

#[test]
fn triangles() {
    let (points, cells) = tri_grid(60, 0.2, 4); // 7200 triangles
    let (points2, cells2, _) = shuffled(&points, 2, &cells, 5);
    for (p, c) in [(&points, &cells), (&points2, &cells2)] {
        let mesh = TriView::new(p, 2, c).unwrap();
        let run = |opts: &Options| {
            let (l, m) = operators(&mesh, LaplacianKind::Primal, MassKind::Fem, opts).unwrap();
            let lumped = mass(&mesh, MassKind::Circumcentric, opts).unwrap();
            let w: Vec<f64> = contributions(&mesh, LaplacianKind::Dual, opts).unwrap().concat();
            let mut cached = CachedMesh::<Tri>::new(p.clone(), 2, c.clone(), opts.clone()).unwrap();
            let cl = cached.laplacian(LaplacianKind::Dual).unwrap();
            [csr(&l), mass_bits(&m), mass_bits(&lumped), bits(&w), csr(&cl)].concat()
        };
        let reference = run(&threads(Some(1)));
        for t in &THREADS[1..] {
            assert!(run(&threads(*t)) == reference, "triangles differ for {t:?}");
        }
    }
}

#[test]
fn coefficients_and_densities() {
    // per-tet scalars, per-tet tensors (batched and one by one), a constant tensor, densities
    let (points, cells) = grid(8, 0.2, 6);
    let (points, cells, _) = shuffled(&points, 3, &cells, 7);
    let m = cells.len();
    let scalars: Vec<f64> = (0..m).map(|t| 0.5 + (t % 13) as f64 / 4.0).collect();
    let tensors: Vec<f64> = (0..m)
        .flat_map(|t| {
            let (a, b) = (1.0 + (t % 5) as f64, 0.1 * (t % 3) as f64);
            [a, b, 0.0, b, 2.0, 0.3, 0.0, 0.3, 10.0 * a]
        })
        .collect();
    let constant = [3.0, 0.5, 0.0, 0.5, 1.0, 0.2, 0.0, 0.2, 2.0];
    let coefficients = [Coefficient::Scalar(&scalars), Coefficient::Tensor(&tensors), Coefficient::Constant(&constant)];
    let run = |opts: &Options| -> Vec<u64> {
        let mut out = vec![];
        for c in coefficients {
            let mesh = TetView::new(&points, 3, &cells).unwrap().with_coefficient(c).unwrap().with_density(&scalars).unwrap();
            for kind in KINDS {
                out.extend(csr(&laplacian(&mesh, kind, opts).unwrap()));
            }
            let (l, m) = operators(&mesh, LaplacianKind::Affine(0.4), MassKind::Circumcentric, opts).unwrap();
            out.extend([csr(&l), mass_bits(&m)].concat());
            let mut cached = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), opts.clone()).unwrap();
            cached.laplacian(LaplacianKind::Dual).unwrap();
            cached.set_coefficient(Some(c)).unwrap();
            out.extend(csr(&cached.laplacian(LaplacianKind::Dual).unwrap()));
        }
        out
    };
    let reference = run(&threads(Some(1)));
    for t in &THREADS[1..] {
        assert!(run(&threads(*t)) == reference, "coefficients differ for {t:?}");
    }
}
