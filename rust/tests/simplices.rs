//! Tets and triangles through the one API: the same functions for both, the invariants
//! every Laplacian and mass has, a triangle mesh's primal == dual, a tet mesh's masses
//! summing to its volume, and hand-computed values of single elements.

mod common;

use common::{grid, tri_grid, volume};
use tetlap::*;

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

fn lumped(m: Mass) -> Vec<f64> {
    match m {
        Mass::Lumped(v) => v,
        Mass::Consistent(_) => panic!("a lumped mass was expected"),
    }
}

fn mass_total(m: &Mass) -> f64 {
    match m {
        Mass::Lumped(v) => v.iter().sum(),
        Mass::Consistent(c) => c.data.iter().sum(),
    }
}

/// Runs every function of the API on a mesh of `S`, checks the invariants common to all
/// kinds of element, and returns the total of each mass kind.
fn through_the_api<S: Simplex>(points: &[f64], dim: usize, cells: &[S::Cell]) -> [f64; 3] {
    let opts = Options::default();
    let mesh = MeshView::<S>::new(points, dim, cells).unwrap();
    let n = mesh.n_vertices();
    for kind in [LaplacianKind::Primal, LaplacianKind::Dual, LaplacianKind::Affine(0.5)] {
        let l = laplacian(&mesh, kind, &opts).unwrap();
        let scale = max_abs(&l.data);
        for i in 0..n {
            let row: f64 = (l.indptr[i]..l.indptr[i + 1]).map(|k| l.data[k]).sum();
            assert!(row.abs() <= 1e-13 * scale, "row sum {row}");
            for k in l.indptr[i]..l.indptr[i + 1] {
                assert_eq!(l.data[k], l.get(l.indices[k] as usize, i), "symmetric");
            }
        }
        // the same Laplacian from the triplets, the edge weights and the contributions
        let t = triplets(&mesh, kind, &opts).unwrap();
        assert_eq!(t.vals.len(), S::CORNERS * S::CORNERS * cells.len());
        let mut dense = vec![0.0; n * n];
        for ((&r, &c), &v) in t.rows.iter().zip(&t.cols).zip(&t.vals) {
            dense[r as usize * n + c as usize] += v;
        }
        for i in 0..n {
            for j in 0..n {
                assert!((dense[i * n + j] - l.get(i, j)).abs() <= 1e-14 * scale);
            }
        }
        let (edge_list, w) = edge_weights(&mesh, kind, &opts).unwrap();
        assert_eq!(edge_list, edges::<S>(cells, n, &opts).unwrap());
        for (&[i, j], &wij) in edge_list.iter().zip(&w) {
            assert_eq!(wij, l.get(i as usize, j as usize));
        }
        let per_element = contributions(&mesh, kind, &opts).unwrap();
        let mut summed = vec![0.0; n * n];
        for (cell, values) in cells.iter().zip(&per_element) {
            for (&(a, b), &v) in S::EDGES.iter().zip(values.as_ref()) {
                let (i, j) = (cell.as_ref()[a] as usize, cell.as_ref()[b] as usize);
                summed[i.min(j) * n + i.max(j)] += v;
            }
        }
        for (&[i, j], &wij) in edge_list.iter().zip(&w) {
            assert!((summed[i as usize * n + j as usize] - wij).abs() <= 1e-14 * scale);
        }
        // the cached mesh gives the same
        let mut cached = CachedMesh::<S>::new(points.to_vec(), dim, cells.to_vec(), opts.clone()).unwrap();
        assert_eq!(cached.laplacian(kind).unwrap(), l);
    }
    let totals = [MassKind::Barycentric, MassKind::Circumcentric, MassKind::Fem].map(|kind| {
        let m = mass(&mesh, kind, &opts).unwrap();
        let (l, m2) = operators(&mesh, LaplacianKind::Dual, kind, &opts).unwrap();
        assert_eq!(m, m2);
        assert_eq!(l, laplacian(&mesh, LaplacianKind::Dual, &opts).unwrap());
        mass_total(&m)
    });
    let f = faces::<S>(cells, n, &opts).unwrap();
    assert_eq!(f.boundary.len() + 2 * f.interior.len(), S::CORNERS * cells.len());
    assert!(duplicate_elements::<S>(cells, n, &opts).unwrap().iter().all(|&d| !d));
    totals
}

#[test]
fn tets_and_triangles_go_through_the_same_functions() {
    let (points, cells) = grid(3, 0.2, 1);
    let volume_sum: f64 = cells.iter().map(|c| volume(&points, c).abs()).sum();
    assert!((volume_sum - 1.0).abs() < 1e-13); // the unit cube
    for total in through_the_api::<Tet>(&points, 3, &cells) {
        assert!((total - volume_sum).abs() < 1e-13, "{total}");
    }
    let (points, cells) = tri_grid(5, 0.2, 2);
    for total in through_the_api::<Tri>(&points, 2, &cells) {
        assert!((total - 1.0).abs() < 1e-13, "{total}"); // the unit square's area
    }
}

#[test]
fn a_tet_meshs_masses_are_its_volume() {
    let (points, cells) = grid(4, 0.24, 3);
    let mesh = TetView::new(&points, 3, &cells).unwrap();
    let opts = Options::default();
    let mut expected = vec![0.0; mesh.n_vertices()];
    for c in &cells {
        for &v in c {
            expected[v as usize] += volume(&points, c).abs() / 4.0;
        }
    }
    let m = lumped(mass(&mesh, MassKind::Barycentric, &opts).unwrap());
    for (a, b) in m.iter().zip(&expected) {
        assert!((a - b).abs() <= 1e-15, "{a} {b}");
    }
    // every circumcentric cell is signed; their total is still the volume, and on a
    // strongly jittered grid some dual weights are negative
    let c = lumped(mass(&mesh, MassKind::Circumcentric, &opts).unwrap());
    assert!((c.iter().sum::<f64>() - 1.0).abs() < 1e-13);
    let (_, w) = edge_weights(&mesh, LaplacianKind::Dual, &opts).unwrap();
    assert!(w.iter().any(|&x| x < 0.0));
}

#[test]
fn a_triangle_meshs_primal_is_its_dual() {
    for (k, jitter) in [(8, 0.0), (8, 0.24), (15, 0.2)] {
        let (points, cells) = tri_grid(k, jitter, 4);
        let mesh = TriView::new(&points, 2, &cells).unwrap();
        let opts = Options::default();
        let p = laplacian(&mesh, LaplacianKind::Primal, &opts).unwrap();
        let d = laplacian(&mesh, LaplacianKind::Dual, &opts).unwrap();
        assert_eq!((&p.indptr, &p.indices), (&d.indptr, &d.indices));
        let scale = max_abs(&p.data);
        for (a, b) in p.data.iter().zip(&d.data) {
            assert!((a - b).abs() <= 1e-13 * scale, "{a} {b}");
        }
    }
}

#[test]
fn an_immersed_triangle_mesh_is_the_flat_one() {
    let (points, cells) = tri_grid(6, 0.2, 5);
    // the plane rotated into R^4: (x, y) -> (x c, y, x s, 1)
    let (c, s) = (0.6f64, 0.8f64);
    let lifted: Vec<f64> = points.chunks_exact(2).flat_map(|p| [p[0] * c, p[1], p[0] * s, 1.0]).collect();
    let opts = Options::default();
    let flat = laplacian(&TriView::new(&points, 2, &cells).unwrap(), LaplacianKind::Dual, &opts).unwrap();
    let up = laplacian(&TriView::new(&lifted, 4, &cells).unwrap(), LaplacianKind::Dual, &opts).unwrap();
    let scale = max_abs(&flat.data);
    for (a, b) in flat.data.iter().zip(&up.data) {
        assert!((a - b).abs() <= 1e-13 * scale);
    }
}

#[test]
fn single_elements_by_hand() {
    let opts = Options::default();
    // the corner tet (SPEC golden values): dual row 0 = (-3/4, 1/4, 1/4, 1/4), dual cell
    // volumes (1/8, 1/72, 1/72, 1/72); primal row 0 = (-1/2, 1/6, 1/6, 1/6)
    let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let tet = TetView::new(&points, 3, &[[0, 1, 2, 3]]).unwrap();
    let d = laplacian(&tet, LaplacianKind::Dual, &opts).unwrap();
    let p = laplacian(&tet, LaplacianKind::Primal, &opts).unwrap();
    for (j, (dv, pv)) in [(-0.75, -0.5), (0.25, 1.0 / 6.0), (0.25, 1.0 / 6.0), (0.25, 1.0 / 6.0)].iter().enumerate() {
        assert!((d.get(0, j) - dv).abs() < 1e-15 && (p.get(0, j) - pv).abs() < 1e-15);
    }
    let m = lumped(mass(&tet, MassKind::Circumcentric, &opts).unwrap());
    for (a, b) in m.iter().zip([1.0 / 8.0, 1.0 / 72.0, 1.0 / 72.0, 1.0 / 72.0]) {
        assert!((a - b).abs() < 1e-16);
    }
    // the consistent mass Vol (1 + delta_ab) / 20
    let Mass::Consistent(f) = mass(&tet, MassKind::Fem, &opts).unwrap() else { panic!() };
    assert!((f.get(0, 0) - 1.0 / 60.0).abs() < 1e-16 && (f.get(0, 1) - 1.0 / 120.0).abs() < 1e-16);
    // the right triangle (0,0), (1,0), (0,1): w = cot(opposite angle) / 2
    let tri = TriView::new(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 2, &[[0, 1, 2]]).unwrap();
    let w = contributions(&tri, LaplacianKind::Primal, &opts).unwrap()[0];
    assert!((w[0] - 0.5).abs() < 1e-15 && (w[1] - 0.5).abs() < 1e-15 && w[2].abs() < 1e-15);
    let Mass::Consistent(f) = mass(&tri, MassKind::Fem, &opts).unwrap() else { panic!() };
    assert!((f.get(1, 1) - 1.0 / 12.0).abs() < 1e-16 && (f.get(1, 2) - 1.0 / 24.0).abs() < 1e-16);
}

#[test]
fn options_that_only_tets_support() {
    let (points, cells) = tri_grid(2, 0.0, 0);
    let tri = TriView::new(&points, 2, &cells).unwrap();
    let weights = vec![0.0; tri.n_vertices()];
    assert_eq!(
        tri.with_vertex_weights(&weights).unwrap_err(),
        Error::Unsupported { option: Feature::VertexWeights, element: "triangle" }
    );
    let opts = Options { boundary: Boundary::Barycentric, ..Default::default() };
    assert_eq!(
        laplacian(&tri, LaplacianKind::Dual, &opts).unwrap_err(),
        Error::Unsupported { option: Feature::BarycentricBoundary, element: "triangle" }
    );
    // the same options are fine for tets
    let (points, cells) = grid(2, 0.0, 0);
    let tet = TetView::new(&points, 3, &cells).unwrap();
    let weights = vec![0.0; tet.n_vertices()];
    assert!(laplacian(&tet.with_vertex_weights(&weights).unwrap(), LaplacianKind::Dual, &opts).is_ok());
}
