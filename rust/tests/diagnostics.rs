//! The mesh diagnostics on small hand-made cases: faces, edges, duplicates, quality, the
//! Delaunay test, operator checks and the semidefiniteness certificates.

mod common;

use common::{grid, tri_grid};
use tetlap::*;

const CORNER: [f64; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

fn opts() -> Options {
    Options::default()
}

#[test]
fn faces_of_two_tets_and_of_a_fan() {
    // two tets sharing the face (1, 2, 3)
    let f = faces::<Tet>(&[[0, 1, 2, 3], [4, 3, 2, 1]], 5, &opts()).unwrap();
    assert_eq!(f.interior, vec![[0, 0, 1, 0]]); // tet 0 opposite corner 0, tet 1 opposite corner 0
    assert_eq!(f.boundary, vec![[0, 1], [0, 2], [0, 3], [1, 1], [1, 2], [1, 3]]);
    assert!(f.nonmanifold.is_empty());
    // three tets on one face: non-manifold, reported once per consecutive pair
    let fan = [[0, 1, 2, 3], [0, 1, 2, 4], [2, 1, 0, 5]];
    let f = faces::<Tet>(&fan, 6, &opts()).unwrap();
    assert_eq!(f.nonmanifold, vec![[0, 1, 2]]);
    assert_eq!(f.interior, vec![[0, 3, 1, 3], [1, 3, 2, 3]]);
    assert_eq!(f.boundary.len(), 9);
    // triangles: the faces are the edges
    let f = faces::<Tri>(&[[0, 1, 2], [2, 1, 3]], 4, &opts()).unwrap();
    assert_eq!(f.interior, vec![[0, 0, 1, 2]]); // edge (1, 2)
    assert_eq!(f.boundary.len(), 4);
}

#[test]
fn faces_of_a_grid_add_up() {
    let k = 3;
    let (_, cells) = grid(k, 0.0, 0);
    let n = (k + 1) * (k + 1) * (k + 1);
    let f = faces::<Tet>(&cells, n, &opts()).unwrap();
    assert_eq!(f.boundary.len(), 6 * 2 * k * k); // two triangles per boundary square
    assert_eq!(f.boundary.len() + 2 * f.interior.len(), 4 * cells.len());
    // interior faces sorted by their sorted vertex triples
    let key = |&[t, c, _, _]: &[u32; 4]| {
        let mut v: Vec<u32> = (0..4).filter(|&i| i != c as usize).map(|i| cells[t as usize][i]).collect();
        v.sort_unstable();
        v
    };
    assert!(f.interior.windows(2).all(|w| key(&w[0]) < key(&w[1])));
    for face in &f.interior {
        let [t1, c1, t2, c2] = face.map(|x| x as usize);
        assert_eq!(key(face), key(&[t2 as u32, c2 as u32, t1 as u32, c1 as u32]));
        assert!(!cells[t2].contains(&cells[t1][c1]) && !cells[t1].contains(&cells[t2][c2]));
    }
}

#[test]
fn edges_and_duplicates() {
    assert_eq!(
        edges::<Tet>(&[[3, 1, 0, 2]], 5, &opts()).unwrap(),
        vec![[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]]
    );
    assert_eq!(edges::<Tri>(&[[0, 1, 2], [2, 1, 3]], 4, &opts()).unwrap(), vec![[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]]);
    let cells = [[0, 1, 2, 3], [3, 2, 1, 0], [0, 1, 2, 4], [4, 2, 1, 0], [0, 1, 2, 3]];
    assert_eq!(duplicate_elements::<Tet>(&cells, 5, &opts()).unwrap(), vec![false, true, false, true, true]);
    assert_eq!(duplicate_elements::<Tri>(&[[0, 1, 2], [1, 2, 0], [1, 2, 3]], 4, &opts()).unwrap(), vec![false, true, false]);
}

#[test]
fn quality_of_known_tets() {
    let corner = TetView::new(&CORNER, 3, &[[0, 1, 2, 3], [0, 2, 1, 3]]).unwrap();
    let q = quality(&corner, &opts()).unwrap();
    assert!((q[0].volume - 1.0 / 6.0).abs() < 1e-16 && (q[1].volume + 1.0 / 6.0).abs() < 1e-16);
    let slanted = (1.0f64 / 3f64.sqrt()).acos().to_degrees();
    for (a, b) in q[0].dihedral.iter().zip([90.0, 90.0, 90.0, slanted, slanted, slanted]) {
        assert!((a - b).abs() < 1e-12, "{a} {b}");
    }
    assert!(!q[0].well_centered); // right angles: the circumcenter lies on a face
    let s = 1.0 / 8f64.sqrt();
    let regular: Vec<f64> = [1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0, -1.0, -1.0, -1.0, 1.0].iter().map(|x| x * s).collect();
    let q = quality(&TetView::new(&regular, 3, &[[0, 1, 2, 3]]).unwrap(), &opts()).unwrap()[0];
    assert!(q.well_centered);
    assert!(q.dihedral.iter().all(|a| (a - (1.0f64 / 3.0).acos().to_degrees()).abs() < 1e-12));
    assert!((q.volume.abs() - 1.0 / (6.0 * 2f64.sqrt())).abs() < 1e-15); // edge 1
    // flat: zero volume, NaN angles, not well-centred
    let flat = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let q = quality(&TetView::new(&flat, 3, &[[0, 1, 2, 3]]).unwrap(), &opts()).unwrap()[0];
    assert!(q.volume == 0.0 && q.dihedral.iter().all(|a| a.is_nan()) && !q.well_centered);
    // immersed in R^4: the unsigned volume and the same angles
    let r4: Vec<f64> = CORNER.chunks_exact(3).flat_map(|p| [p[0], p[2], 5.0, p[1]]).collect();
    let q4 = quality(&TetView::new(&r4, 4, &[[0, 2, 1, 3]]).unwrap(), &opts()).unwrap()[0];
    assert!((q4.volume - 1.0 / 6.0).abs() < 1e-16);
}

#[test]
fn the_delaunay_test() {
    let x = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(inside_circumsphere(x, [0.5, 0.5, 0.5], DELAUNAY_RTOL)); // the circumcenter
    assert!(!inside_circumsphere(x, [2.0, 2.0, 2.0], DELAUNAY_RTOL));
    assert!(!inside_circumsphere(x, [1.0, 1.0, 1.0], DELAUNAY_RTOL)); // cospherical: on it
    assert!(inside_circumsphere(x, [0.999, 0.999, 0.999], DELAUNAY_RTOL));
    // a flat bipyramid: the 2-tet split is not Delaunay, the 3-tet split around the axis is
    let h = 0.1;
    let points = [1.0, 0.0, 0.0, -0.5, 0.866, 0.0, -0.5, -0.866, 0.0, 0.0, 0.0, h, 0.0, 0.0, -h];
    for (cells, expected) in [(vec![[0, 1, 2, 3], [0, 1, 2, 4]], vec![true]),
                              (vec![[3, 4, 0, 1], [3, 4, 1, 2], [3, 4, 2, 0]], vec![false; 3])] {
        let mesh = TetView::new(&points, 3, &cells).unwrap();
        let f = faces::<Tet>(&cells, 5, &opts()).unwrap();
        assert_eq!(non_delaunay_faces(&mesh, &f.interior, DELAUNAY_RTOL, &opts()).unwrap(), expected);
    }
    // a Kuhn grid is cospherical everywhere: Delaunay within the tolerance only
    let (points, cells) = grid(2, 0.0, 0);
    let mesh = TetView::new(&points, 3, &cells).unwrap();
    let f = faces::<Tet>(&cells, mesh.n_vertices(), &opts()).unwrap();
    assert!(non_delaunay_faces(&mesh, &f.interior, DELAUNAY_RTOL, &opts()).unwrap().iter().all(|&b| !b));
    assert!(non_delaunay_faces(&mesh, &f.interior, -1.0, &opts()).unwrap().iter().any(|&b| b));
}

#[test]
fn check_operator_of_the_corner_tet() {
    let tet = TetView::new(&CORNER, 3, &[[0, 1, 2, 3]]).unwrap();
    let l = laplacian(&tet, LaplacianKind::Primal, &opts()).unwrap();
    let c = check_operator(&l, &tet, &[true; 4], 1e-12, &opts()).unwrap();
    assert!(c.finite && c.local && c.symmetry_error == 0.0 && c.max_row_sum < 1e-15);
    assert_eq!((c.n_edges, c.n_edges_inner, c.n_negative), (6, 0, 0));
    assert_eq!((c.min_weight, c.scale), (0.0, 0.5)); // the right-angled edges weigh 0
    assert_eq!(c.linear_precision, None); // no interior vertex
    // an entry off the pattern and an asymmetric one
    let mut bad = l.clone();
    bad.data[1] += 0.25; // (0, 1)
    let c = check_operator(&bad, &tet, &[true; 4], 1e-12, &opts()).unwrap();
    assert!((c.symmetry_error - 0.25).abs() < 1e-15);
    assert!((c.max_row_sum - 0.25).abs() < 1e-15);
    let five = [CORNER.as_slice(), &[1.0, 1.0, 1.0]].concat(); // vertex 4 unused
    let two = TetView::new(&five, 3, &[[0, 1, 2, 3]]).unwrap();
    let far = Csr { n: 5, indptr: vec![0, 2, 2, 2, 2, 4], indices: vec![0, 4, 0, 4], data: vec![-1.0, 1.0, 1.0, -1.0] };
    assert!(!check_operator(&far, &two, &[true; 5], 1e-12, &opts()).unwrap().local);
}

/// The boundary flags of a mesh: the vertices of faces of one cell.
fn on_boundary<S: Simplex>(cells: &[S::Cell], n: usize) -> Vec<bool> {
    let f = faces::<S>(cells, n, &opts()).unwrap();
    let mut b = vec![false; n];
    for &[cell, corner] in &f.boundary {
        for (k, &v) in cells[cell as usize].as_ref().iter().enumerate() {
            b[v as usize] |= k != corner as usize;
        }
    }
    b
}

#[test]
fn linear_precision_does_not_depend_on_where_the_mesh_lies() {
    // offsets up to 1e12: the operator is that of the mesh translated back, and so is the
    // residual (measured in a frame centred on the mesh); a broken operator still fails
    let (points, cells) = grid(4, 0.2, 1);
    let (tpoints, tcells) = tri_grid(6, 0.2, 1);
    let b = on_boundary::<Tet>(&cells, points.len() / 3);
    let tb = on_boundary::<Tri>(&tcells, tpoints.len() / 2);
    for offset in [0.0, 1e3, 1e6, 1e9, 1e12] {
        let far: Vec<f64> = points.iter().map(|x| x + offset).collect();
        let back: Vec<f64> = far.iter().map(|x| x - offset).collect(); // exact
        let tfar: Vec<f64> = tpoints.iter().map(|x| x + offset).collect();
        for kind in [LaplacianKind::Primal, LaplacianKind::Dual] {
            let mesh = TetView::new(&far, 3, &cells).unwrap();
            let l = laplacian(&mesh, kind, &opts()).unwrap();
            let home = laplacian(&TetView::new(&back, 3, &cells).unwrap(), kind, &opts()).unwrap();
            assert_eq!(l.data, home.data, "{offset}: the operator is the translated-back one's");
            let lp = check_operator(&l, &mesh, &b, 1e-12, &opts()).unwrap().linear_precision.unwrap();
            assert!(lp < 1e-13, "{offset} {kind:?}: {lp}");
            let mut broken = l.clone();
            let (i, k) = (62, l.indptr[62] + 1); // vertex (2, 2, 2), interior: its first off-diagonal
            let j = l.indices[k] as usize;
            broken.data[k] += 0.01;
            let kk = l.indptr[j] + l.indices[l.indptr[j]..l.indptr[j + 1]].binary_search(&(i as u32)).unwrap();
            broken.data[kk] += 0.01;
            let dd = |r: usize| l.indptr[r] + l.indices[l.indptr[r]..l.indptr[r + 1]].binary_search(&(r as u32)).unwrap();
            broken.data[dd(i)] -= 0.01;
            broken.data[dd(j)] -= 0.01; // symmetric, zero row sums: only precision is lost
            let lp = check_operator(&broken, &mesh, &b, 1e-12, &opts()).unwrap().linear_precision.unwrap();
            assert!(lp > 1e-4, "{offset} {kind:?}: a broken operator passes ({lp})");
        }
        let tri = TriView::new(&tfar, 2, &tcells).unwrap();
        let l = laplacian(&tri, LaplacianKind::Primal, &opts()).unwrap();
        let lp = check_operator(&l, &tri, &tb, 1e-12, &opts()).unwrap().linear_precision.unwrap();
        assert!(lp < 1e-13, "{offset} triangles: {lp}");
    }
    // triangles immersed in R^3 (a curved surface in general) are not measured
    let (tpoints, tcells) = tri_grid(2, 0.0, 0);
    let lifted: Vec<f64> = tpoints.chunks(2).flat_map(|p| [p[0], p[1], 0.0]).collect();
    let tri = TriView::new(&lifted, 3, &tcells).unwrap();
    let l = laplacian(&tri, LaplacianKind::Primal, &opts()).unwrap();
    assert_eq!(check_operator(&l, &tri, &on_boundary::<Tri>(&tcells, 9), 1e-12, &opts()).unwrap().linear_precision, None);
}

/// A symmetric CSR from dense rows.
fn csr(rows: &[&[f64]]) -> Csr {
    let n = rows.len();
    let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
    for row in rows {
        for (j, &x) in row.iter().enumerate() {
            if x != 0.0 {
                indices.push(j as u32);
                data.push(x);
            }
        }
        indptr.push(indices.len());
    }
    Csr { n, indptr, indices, data }
}

#[test]
fn semidefiniteness_certificates_and_witnesses() {
    // non-negative weights: a graph Laplacian
    let path = csr(&[&[-1.0, 1.0, 0.0], &[1.0, -3.0, 2.0], &[0.0, 2.0, -2.0]]);
    assert_eq!(negative_semidefinite(&path, &[1e-12; 3], &opts()).unwrap(), Semidefinite::NonNegativeWeights);
    // one negative weight (-0.1) covered by the triangle's positive ones: -L is the
    // Laplacian of weights a, b, c with ab + bc + ca = 0.8 > 0, hence semidefinite
    let (a, b, c) = (-0.1, 1.0, 1.0);
    let covered = csr(&[&[-(a + b), a, b], &[a, -(a + c), c], &[b, c, -(b + c)]]);
    assert!(matches!(negative_semidefinite(&covered, &[1e-12; 3], &opts()).unwrap(),
                     Semidefinite::LocalCertificate { groups: 1, largest: 3 }));
    // a lone negative weight: -L = [[-1, 1], [1, -1]] has eigenvalue -2
    let negative = csr(&[&[1.0, -1.0], &[-1.0, 1.0]]);
    match negative_semidefinite(&negative, &[1e-12; 2], &opts()).unwrap() {
        Semidefinite::Indefinite { rayleigh, support, vertex } => {
            assert!((-2.0..0.0).contains(&rayleigh), "{rayleigh}");
            assert!(support <= 2 && vertex < 2);
        }
        other => panic!("expected a witness, got {other:?}"),
    }
    // too negative to be covered (ab + bc + ca = -0.1 - 0.1 + 0.01 < 0): indefinite too
    let (a, b, c) = (-1.0, 0.1, 0.1);
    let uncovered = csr(&[&[-(a + b), a, b], &[a, -(a + c), c], &[b, c, -(b + c)]]);
    assert!(matches!(negative_semidefinite(&uncovered, &[1e-12; 3], &opts()).unwrap(), Semidefinite::Indefinite { .. }));
    // the primal of a mesh is semidefinite: certified or non-negative, never a witness
    let (points, cells) = grid(3, 0.24, 5);
    let l = laplacian(&TetView::new(&points, 3, &cells).unwrap(), LaplacianKind::Primal, &opts()).unwrap();
    let tol = vec![1e-9 * l.data.iter().fold(0.0f64, |m, x| m.max(x.abs())); l.n];
    assert!(!matches!(negative_semidefinite(&l, &tol, &opts()).unwrap(), Semidefinite::Indefinite { .. }));
}
