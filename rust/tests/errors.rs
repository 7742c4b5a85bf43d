//! Every `Error` variant that the public API can reach, naming the right element, vertex
//! or value; cancellation; and failures that leave a `CachedMesh` unchanged.
//! (`TooManyVertices`, `TooManyElements` and `ThreadPool` need 2^31 vertices, 2^30
//! elements or an operating system that refuses threads: not reachable in a test.)

mod common;

use common::{bits, grid, threads, tri_grid, THREADS};
use tetlap::*;

const CORNER: [f64; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

fn dual(mesh: &TetView, opts: &Options) -> Result<Csr> {
    laplacian(mesh, LaplacianKind::Dual, opts)
}

#[test]
fn input_errors_name_the_element_and_the_vertex() {
    assert!(matches!(TetView::new(&CORNER[..8], 2, &[[0, 1, 2, 3]]), Err(Error::Shape { .. })));
    assert!(matches!(TetView::new(&CORNER[..11], 3, &[[0, 1, 2, 3]]), Err(Error::Shape { .. })));
    assert_eq!(TetView::new(&CORNER, 3, &[]).unwrap_err(), Error::EmptyMesh { n_vertices: 4, n_elements: 0 });
    assert_eq!(TetView::new(&[], 3, &[[0, 1, 2, 3]]).unwrap_err(), Error::EmptyMesh { n_vertices: 0, n_elements: 1 });
    let mut nan = CORNER;
    nan[3 * 2 + 1] = f64::NAN;
    let Err(Error::NonFiniteCoordinate { vertex, coordinate, value }) = TetView::new(&nan, 3, &[[0, 1, 2, 3]])
    else { panic!("expected NonFiniteCoordinate") };
    assert_eq!((vertex, coordinate), (2, 1));
    assert!(value.is_nan());
    let cells = [[0, 1, 2, 3], [0, 1, 2, 3], [3, 2, 1, 4], [0, 0, 1, 2]];
    assert_eq!(
        TetView::new(&CORNER, 3, &cells).unwrap_err(),
        Error::IndexOutOfRange { element: 2, corner: 3, index: 4, n_vertices: 4 }
    );
    assert_eq!(TetView::new(&CORNER, 3, &cells[3..]).unwrap_err(), Error::RepeatedVertex { element: 0, vertex: 0 });
    assert_eq!(
        cells_from_i64::<Tet>(&[0, 1, 2, 3, 3, 2, -1, 0], 4).unwrap_err(),
        Error::IndexOutOfRange { element: 1, corner: 2, index: -1, n_vertices: 4 }
    );
    let tet = TetView::new(&CORNER, 3, &[[0, 1, 2, 3]]).unwrap();
    assert!(matches!(tet.with_vertex_weights(&[0.0; 3]), Err(Error::Shape { .. })));
    assert_eq!(
        tet.with_vertex_weights(&[0.0, 0.0, 0.0, f64::INFINITY]).unwrap_err(),
        Error::NonFiniteWeight { vertex: 3, value: f64::INFINITY }
    );
}

#[test]
fn the_first_bad_element_is_named_whatever_the_thread_count() {
    let (points, mut cells) = grid(8, 0.1, 1);
    let (a, b) = (1500, 2900);
    cells[b][1] = cells[b][0]; // a repeated vertex in element 2900
    cells[a][2] = 10_000; // an index out of range in element 1500, first
    // validation runs on the caller's rayon pool: try pools of 1, 2 and 3 threads
    for t in 1..=3 {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap();
        let e = pool.install(|| TetView::new(&points, 3, &cells).unwrap_err());
        assert_eq!(e, Error::IndexOutOfRange { element: a, corner: 2, index: 10_000, n_vertices: 729 }, "{t}");
        assert!(e.to_string().contains("element 1500 refers to vertex 10000"));
    }
    cells[a][2] = 0;
    assert_eq!(TetView::new(&points, 3, &cells).unwrap_err(), Error::RepeatedVertex { element: b, vertex: cells[b][0] });
}

#[test]
fn degenerate_elements_are_named_or_skipped() {
    let (mut points, cells) = grid(4, 0.0, 2);
    // flatten the tets around an edge: move vertex 31 onto vertex 30's line
    let flat_points = {
        let v = 31;
        for c in 0..3 {
            points[3 * v + c] = points[3 * 30 + c];
        }
        points
    };
    let flats: Vec<usize> = (0..cells.len()).filter(|&t| common::volume(&flat_points, &cells[t]) == 0.0).collect();
    assert!(!flats.is_empty());
    let mesh = TetView::new(&flat_points, 3, &cells).unwrap();
    for t in THREADS {
        for kind in [LaplacianKind::Primal, LaplacianKind::Dual] {
            assert_eq!(laplacian(&mesh, kind, &threads(t)).unwrap_err(), Error::Degenerate { element: flats[0] });
        }
        assert_eq!(mass(&mesh, MassKind::Fem, &threads(t)).unwrap_err(), Error::Degenerate { element: flats[0] });
    }
    let skip = Options { degenerate: Degenerate::Skip, ..Default::default() };
    let w = contributions(&mesh, LaplacianKind::Dual, &skip).unwrap();
    assert!(flats.iter().all(|&t| w[t] == [0.0; 6]));
    assert!(w.iter().flatten().all(|x| x.is_finite()));
    // a flat triangle
    let tri = TriView::new(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 2.0, 0.0], 2, &[[0, 1, 2], [0, 1, 3]]).unwrap();
    assert_eq!(laplacian(&tri, LaplacianKind::Primal, &Options::default()).unwrap_err(), Error::Degenerate { element: 1 });
}

#[test]
fn results_that_overflow_are_named() {
    let huge: Vec<f64> = CORNER.iter().map(|x| x * 1e150).collect();
    let tet = TetView::new(&huge, 3, &[[0, 1, 2, 3]]).unwrap();
    let e = mass(&tet, MassKind::Circumcentric, &Options::default()).unwrap_err();
    assert_eq!(e, Error::NonFiniteResult { element: 0 });
    assert!(e.to_string().contains("element 0"));
    let skip = Options { degenerate: Degenerate::Skip, ..Default::default() };
    assert_eq!(mass(&tet, MassKind::Circumcentric, &skip).unwrap(), Mass::Lumped(vec![0.0; 4]));
}

#[test]
fn option_errors() {
    let tet = TetView::new(&CORNER, 3, &[[0, 1, 2, 3]]).unwrap();
    let opts = Options::default();
    for t in [-0.5, 1.5, f64::NAN] {
        let e = laplacian(&tet, LaplacianKind::Affine(t), &opts).unwrap_err();
        assert!(matches!(e, Error::AffineParameter { t: got } if got.to_bits() == t.to_bits()));
        assert!(matches!(contributions(&tet, LaplacianKind::Affine(t), &opts), Err(Error::AffineParameter { .. })));
    }
    let max = max_threads();
    for bad in [0, max + 1] {
        assert_eq!(dual(&tet, &threads(Some(bad))).unwrap_err(), Error::Threads { threads: bad, max });
        assert_eq!(
            CachedMesh::<Tet>::new(CORNER.to_vec(), 3, vec![[0, 1, 2, 3]], threads(Some(bad))).unwrap_err(),
            Error::Threads { threads: bad, max }
        );
    }
    assert!(dual(&tet, &threads(Some(max))).is_ok());
}

#[test]
fn cancellation_returns_cancelled_everywhere() {
    let (points, cells) = grid(4, 0.2, 3);
    let cancel = Cancel::new();
    cancel.cancel();
    let opts = Options { cancel: Some(cancel.clone()), ..Default::default() };
    let mesh = TetView::new(&points, 3, &cells).unwrap();
    let n = mesh.n_vertices();
    assert_eq!(dual(&mesh, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(mass(&mesh, MassKind::Fem, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(operators(&mesh, LaplacianKind::Primal, MassKind::Barycentric, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(contributions(&mesh, LaplacianKind::Dual, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(faces::<Tet>(&cells, n, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(quality(&mesh, &opts).unwrap_err(), Error::Cancelled);
    assert_eq!(CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), opts.clone()).unwrap_err(), Error::Cancelled);
    let (tp, tc) = tri_grid(4, 0.1, 1);
    let tri = TriView::new(&tp, 2, &tc).unwrap();
    assert_eq!(laplacian(&tri, LaplacianKind::Primal, &opts).unwrap_err(), Error::Cancelled);
    assert!(Cancel::new() != cancel && cancel.is_cancelled());
}

/// An error leaves the cached mesh exactly as it was: coordinates and every operator.
fn assert_unchanged(cached: &mut CachedMesh<Tet>, points: &[f64], before: &Csr, mass_before: &Mass) {
    assert_eq!(bits(&cached.points()), bits(points));
    let now = cached.laplacian(LaplacianKind::Dual).unwrap();
    assert_eq!((&now.indptr, &now.indices, bits(&now.data)), (&before.indptr, &before.indices, bits(&before.data)));
    assert_eq!(&cached.mass(MassKind::Circumcentric).unwrap(), mass_before);
}

#[test]
fn a_failed_or_cancelled_update_changes_nothing() {
    let (points, cells) = grid(4, 0.2, 4);
    let n = points.len() / 3;
    let mut cached = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), Options::default()).unwrap();
    let before = cached.laplacian(LaplacianKind::Dual).unwrap();
    let mass_before = cached.mass(MassKind::Circumcentric).unwrap();
    let mut moved = points.clone();
    for v in (0..n).step_by(3) {
        moved[3 * v] += 1e-3;
    }
    // cancelled: Error::Cancelled, nothing changed; the same update succeeds afterwards
    let cancel = Cancel::new();
    cached.set_cancel(Some(cancel.clone()));
    cancel.cancel();
    assert_eq!(cached.update(&moved).unwrap_err(), Error::Cancelled);
    cached.set_cancel(None);
    assert_unchanged(&mut cached, &points, &before, &mass_before);
    // an element that becomes flat
    let mut flat = points.clone();
    let (a, b) = (31, 30);
    for c in 0..3 {
        flat[3 * a + c] = flat[3 * b + c];
    }
    assert!(matches!(cached.update(&flat).unwrap_err(), Error::Degenerate { .. }));
    assert_unchanged(&mut cached, &points, &before, &mass_before);
    // bad coordinates, a bad shape, a bad vertex list
    let mut nan = points.clone();
    nan[3 * 7 + 2] = f64::NAN;
    assert!(matches!(
        cached.move_vertices(&[7], &nan[21..24]),
        Err(Error::NonFiniteCoordinate { vertex: 7, coordinate: 2, value }) if value.is_nan()
    ));
    assert!(matches!(cached.update(&nan), Err(Error::NonFiniteCoordinate { vertex: 7, coordinate: 2, .. })));
    assert!(matches!(cached.update(&points[3..]), Err(Error::Shape { .. })));
    assert!(matches!(cached.move_vertices(&[1, 2], &[0.0; 3]), Err(Error::Shape { .. })));
    assert_eq!(
        cached.move_vertices(&[4, 9, 9], &[0.5; 9]).unwrap_err(),
        Error::VertexList { position: 2, vertex: 9, n_vertices: n }
    );
    assert_eq!(
        cached.move_vertices(&[4, n as u32], &[0.5; 6]).unwrap_err(),
        Error::VertexList { position: 1, vertex: n as u32, n_vertices: n }
    );
    assert_unchanged(&mut cached, &points, &before, &mass_before);
    cached.update(&moved).unwrap();
    assert_eq!(bits(&cached.points()), bits(&moved));
}

#[test]
fn check_operator_refuses_a_matrix_of_another_size() {
    let tet = TetView::new(&CORNER, 3, &[[0, 1, 2, 3]]).unwrap();
    let l = Csr { n: 3, indptr: vec![0, 1, 2, 3], indices: vec![0, 1, 2], data: vec![0.0; 3] };
    assert!(matches!(check_operator(&l, &tet, &[false; 4], 1e-12, &Options::default()), Err(Error::Shape { .. })));
}
