//! Where the time goes: the phases of one-shot assembly of the Rust core, timed alone.
//!
//! `cargo bench --bench phases` (medians of 11 runs on a 998,250-tet Kuhn grid, in its
//! own order and scrambled).

use std::time::Instant;
use tetlap::{contributions, laplacian, operators, CachedMesh, LaplacianKind, MassKind, Options, Tet, TetView};

#[path = "grid.rs"]
mod grid;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let (points, tets) = grid::grid(55);
    let scrambled = grid::scrambled(&points, &tets);
    for (label, (points, tets)) in [("Kuhn grid", (points, tets)), ("Kuhn grid, scrambled", scrambled)] {
        phases(label, &points, &tets);
    }
}

fn phases(label: &str, points: &[f64], tets: &[[u32; 4]]) {
    let mesh = TetView::new(points, 3, tets).unwrap();
    let opts = Options::default();
    let cases: Vec<(&str, Box<dyn Fn()>)> = vec![
        ("cached mesh (layout + topology)", Box::new(|| {
            drop(CachedMesh::<Tet>::new(points.to_vec(), 3, tets.to_vec(), Options::default()).unwrap())
        })),
        ("kernels, primal", Box::new(|| drop(contributions(&mesh, LaplacianKind::Primal, &opts).unwrap()))),
        ("kernels, dual", Box::new(|| drop(contributions(&mesh, LaplacianKind::Dual, &opts).unwrap()))),
        ("laplacian, primal", Box::new(|| drop(laplacian(&mesh, LaplacianKind::Primal, &opts).unwrap()))),
        ("laplacian, dual", Box::new(|| drop(laplacian(&mesh, LaplacianKind::Dual, &opts).unwrap()))),
        ("operators, dual + circumcentric", Box::new(|| {
            drop(operators(&mesh, LaplacianKind::Dual, MassKind::Circumcentric, &opts).unwrap())
        })),
    ];
    println!("{label}: {} tets, {} threads", tets.len(), rayon::current_num_threads());
    for (name, f) in &cases {
        let times: Vec<f64> = (0..11)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        println!("{name:>34}: {:7.1} ms", median(times));
    }
}
