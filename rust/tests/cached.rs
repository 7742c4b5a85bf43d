//! `CachedMesh` equals the one-shot functions to the last bit: at first, after updates
//! of one vertex, of many and of all of them, for tets (plain, weighted, barycentric
//! boundary) and triangles; and an update recomputes exactly the star of what moved.

mod common;

use common::{bits, grid, tri_grid, Rng};
use tetlap::*;

const KINDS: [LaplacianKind; 3] = [LaplacianKind::Primal, LaplacianKind::Dual, LaplacianKind::Affine(0.5)];
const MASSES: [MassKind; 3] = [MassKind::Barycentric, MassKind::Circumcentric, MassKind::Fem];

fn same_csr(a: &Csr, b: &Csr) -> bool {
    a.n == b.n && a.indptr == b.indptr && a.indices == b.indices && bits(&a.data) == bits(&b.data)
}

fn same_mass(a: &Mass, b: &Mass) -> bool {
    match (a, b) {
        (Mass::Lumped(x), Mass::Lumped(y)) => bits(x) == bits(y),
        (Mass::Consistent(x), Mass::Consistent(y)) => same_csr(x, y),
        _ => false,
    }
}

/// Every cached operator against a fresh one-shot assembly of `mesh`.
fn assert_equal_to_one_shot<S: Simplex>(cached: &mut CachedMesh<S>, mesh: &MeshView<S>, opts: &Options) {
    for kind in KINDS {
        let fresh = laplacian(mesh, kind, opts).unwrap();
        assert!(same_csr(&cached.laplacian(kind).unwrap(), &fresh), "laplacian {kind:?}");
    }
    for kind in MASSES {
        let fresh = mass(mesh, kind, opts).unwrap();
        assert!(same_mass(&cached.mass(kind).unwrap(), &fresh), "mass {kind:?}");
    }
}

/// The one-shot view of the same mesh (weighted if the cached one is).
fn one_shot<'a, S: Simplex>(points: &'a [f64], dim: usize, cells: &'a [S::Cell], weights: Option<&'a [f64]>) -> MeshView<'a, S> {
    let mesh = MeshView::<S>::new(points, dim, cells).unwrap();
    match weights {
        Some(w) => mesh.with_vertex_weights(w).unwrap(),
        None => mesh,
    }
}

/// Moves 1, 5, a third and all of the vertices (random ones, small random steps) and
/// compares every operator with a one-shot assembly after each update.
fn updates<S: Simplex>(points: Vec<f64>, dim: usize, cells: Vec<S::Cell>, weights: Option<Vec<f64>>, opts: Options) {
    let n = points.len() / dim;
    let w = weights.as_deref();
    let mut cached = CachedMesh::<S>::with_vertex_weights(points.clone(), dim, cells.clone(), weights.clone(), opts.clone()).unwrap();
    assert_equal_to_one_shot(&mut cached, &one_shot(&points, dim, &cells, w), &opts);
    let mut rng = Rng::new(7);
    let mut current = points;
    for count in [1, 5, n / 3, n] {
        let moved = if count == n { (0..n).collect() } else { rng.permutation(n)[..count].to_vec() };
        for &v in &moved {
            for c in 0..dim {
                current[v * dim + c] += rng.uniform(-1e-3, 1e-3) / n as f64;
            }
        }
        let update = cached.update(&current).unwrap();
        assert_eq!(update.moved_vertices, count);
        assert_eq!(bits(&cached.points()), bits(&current));
        assert_eq!(cached.cells(), cells);
        assert_equal_to_one_shot(&mut cached, &one_shot(&current, dim, &cells, w), &opts);
    }
}

#[test]
fn tets_after_updates_of_one_many_and_all_vertices() {
    let (points, cells) = grid(6, 0.2, 1);
    updates::<Tet>(points, 3, cells, None, Options::default());
}

#[test]
fn weighted_tets_with_the_barycentric_boundary() {
    let (points, cells) = grid(5, 0.2, 2);
    let weights = (0..points.len() / 3).map(|i| 2e-3 * ((i * 7) % 5) as f64).collect();
    let opts = Options { boundary: Boundary::Barycentric, threads: Some(2), ..Default::default() };
    updates::<Tet>(points, 3, cells, Some(weights), opts);
}

#[test]
fn triangles_after_updates() {
    let (points, cells) = tri_grid(12, 0.2, 3);
    updates::<Tri>(points.clone(), 2, cells.clone(), None, Options::default());
    // the same triangles immersed in R^3
    let lifted: Vec<f64> = points.chunks_exact(2).flat_map(|p| [p[0], p[1], 0.3 * p[0] * p[1]]).collect();
    updates::<Tri>(lifted, 3, cells, None, Options::default());
}

#[test]
fn an_update_recomputes_the_star_of_the_moved_vertex() {
    let k = 4;
    let (points, cells) = grid(k, 0.2, 4);
    let v = (2 * (k + 1) + 2) * (k + 1) + 2; // the interior vertex (2, 2, 2)
    let mut cached = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), Options::default()).unwrap();
    // nothing cached yet: the update only moves the vertex
    let mut moved = points.clone();
    moved[3 * v] += 0.01;
    let first = cached.update(&moved).unwrap();
    assert_eq!((first.moved_vertices, first.recomputed_elements, first.recomputed_rows), (1, 0, 0));
    cached.laplacian(LaplacianKind::Dual).unwrap();
    moved[3 * v] += 0.01;
    let star: Vec<&[u32; 4]> = cells.iter().filter(|c| c.contains(&(v as u32))).collect();
    let mut rows: Vec<u32> = star.iter().flat_map(|c| c.iter().copied()).collect();
    rows.sort_unstable();
    rows.dedup();
    let update = cached.update(&moved).unwrap();
    assert_eq!(update, Update { moved_vertices: 1, recomputed_elements: star.len(), recomputed_rows: rows.len() });
    assert_eq!((star.len(), rows.len()), (24, 15)); // a Kuhn grid's interior vertex
    assert_eq!(cached.update(&moved).unwrap(), Update::default()); // nothing moved
    assert_eq!(cached.moved_vertices(&moved).unwrap(), Vec::<u32>::new());
}

#[test]
fn move_vertices_is_update() {
    let (points, cells) = grid(4, 0.2, 5);
    let mut a = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), Options::default()).unwrap();
    let mut b = a.clone();
    a.laplacian(LaplacianKind::Dual).unwrap();
    b.laplacian(LaplacianKind::Dual).unwrap();
    let mut moved = points.clone();
    let list = [6u32, 31, 62];
    let mut coords = vec![];
    for &v in &list {
        moved[3 * v as usize + 2] -= 0.02;
        coords.extend_from_slice(&moved[3 * v as usize..3 * v as usize + 3]);
    }
    assert_eq!(a.moved_vertices(&moved).unwrap(), list.to_vec());
    assert_eq!(a.update(&moved).unwrap(), b.move_vertices(&list, &coords).unwrap());
    assert!(same_csr(&a.laplacian(LaplacianKind::Dual).unwrap(), &b.laplacian(LaplacianKind::Dual).unwrap()));
    assert_eq!(bits(&a.points()), bits(&b.points()));
}

#[test]
fn the_pattern_and_the_values_views() {
    let (points, cells) = grid(3, 0.1, 6);
    let mesh = TetView::new(&points, 3, &cells).unwrap();
    let mut cached = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), Options::default()).unwrap();
    assert_eq!(cached.cached_laplacian_values(LaplacianKind::Dual), None);
    let l = laplacian(&mesh, LaplacianKind::Dual, &Options::default()).unwrap();
    assert_eq!(bits(cached.laplacian_values(LaplacianKind::Dual).unwrap()), bits(&l.data));
    assert_eq!(cached.cached_laplacian_values(LaplacianKind::Dual).map(bits), Some(bits(&l.data)));
    let topo = cached.topology();
    assert_eq!((topo.n(), topo.indptr(), topo.indices()), (l.n, &l.indptr[..], &l.indices[..]));
    assert_eq!(topo.edges(), edges::<Tet>(&cells, mesh.n_vertices(), &Options::default()).unwrap());
    let Mass::Lumped(m) = mass(&mesh, MassKind::Circumcentric, &Options::default()).unwrap() else { panic!() };
    assert_eq!(bits(cached.mass_values(MassKind::Circumcentric).unwrap()), bits(&m));
    assert_eq!((cached.n_vertices(), cached.dim()), (mesh.n_vertices(), 3));
}

#[test]
fn new_coefficients_and_densities_are_a_one_shot_assembly() {
    let (points, cells) = grid(5, 0.2, 21);
    let m = cells.len();
    let opts = Options::default();
    let mut cached = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), opts.clone()).unwrap();
    for kind in [LaplacianKind::Dual, LaplacianKind::Affine(0.3)] {
        cached.laplacian(kind).unwrap();
    }
    cached.mass(MassKind::Circumcentric).unwrap();
    let mut scalars = vec![1.0; m];
    scalars[3] = 2.0;
    let tensors: Vec<f64> = (0..m).flat_map(|t| [1.0 + t as f64 / m as f64, 0.2, 0.0, 0.2, 1.0, 0.0, 0.0, 0.0, 5.0]).collect();
    let mut tensors2 = tensors.clone();
    tensors2[9 * 7] *= 3.0;
    let constant = [2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let density: Vec<f64> = (0..m).map(|t| 1.0 + (t % 3) as f64).collect();
    let steps: [(Option<Coefficient>, Option<&[f64]>, usize); 6] = [
        (Some(Coefficient::Scalar(&scalars)), None, 1), // from none: only the tet whose scalar is not 1
        (Some(Coefficient::Tensor(&tensors)), None, m),
        (Some(Coefficient::Tensor(&tensors2)), None, 1),
        (Some(Coefficient::Constant(&constant)), Some(&density), m),
        (Some(Coefficient::Constant(&constant)), Some(&density), 0),
        (None, None, m),
    ];
    for (c, d, recomputed) in steps {
        let update = cached.change(Change { coefficient: Some(c), density: Some(d), ..Change::default() }).unwrap();
        assert!(update.recomputed_elements == recomputed || recomputed > m / 8, "{update:?}");
        let mut fresh = TetView::new(&points, 3, &cells).unwrap();
        if let Some(c) = c {
            fresh = fresh.with_coefficient(c).unwrap();
        }
        if let Some(d) = d {
            fresh = fresh.with_density(d).unwrap();
        }
        assert_equal_to_one_shot(&mut cached, &fresh, &opts);
    }
    // a bad coefficient changes nothing
    let before = cached.laplacian(LaplacianKind::Dual).unwrap();
    let bad = vec![-1.0; m];
    assert!(cached.set_coefficient(Some(Coefficient::Scalar(&bad))).is_err());
    assert!(cached.coefficient().is_none());
    assert_eq!(cached.laplacian(LaplacianKind::Dual).unwrap(), before);
}
