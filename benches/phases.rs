//! Where the time goes: the phases of one-shot assembly of the Rust core, timed alone.
//!
//! `cargo bench --bench phases` (medians of 11 runs on a 998,250-tet Kuhn grid).

use std::time::Instant;
use tetlap::{contributions, laplacian, operators, LaplacianKind, MassKind, Options, Tet, TetMesh, Topology};

#[path = "grid.rs"]
mod grid;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let (points, tets) = grid::grid(55);
    let mesh = TetMesh::new(&points, 3, &tets).unwrap();
    let opts = Options::default();
    let n = points.len() / 3;
    let cases: Vec<(&str, Box<dyn Fn()>)> = vec![
        ("cached topology (Topology::new)", Box::new(|| drop(Topology::new::<Tet>(&tets, n).unwrap()))),
        ("kernels, primal", Box::new(|| drop(contributions(&mesh, LaplacianKind::Primal, &opts).unwrap()))),
        ("kernels, dual", Box::new(|| drop(contributions(&mesh, LaplacianKind::Dual, &opts).unwrap()))),
        ("laplacian, primal", Box::new(|| drop(laplacian(&mesh, LaplacianKind::Primal, &opts).unwrap()))),
        ("laplacian, dual", Box::new(|| drop(laplacian(&mesh, LaplacianKind::Dual, &opts).unwrap()))),
        ("operators, dual + circumcentric", Box::new(|| {
            drop(operators(&mesh, LaplacianKind::Dual, MassKind::Circumcentric, &opts).unwrap())
        })),
    ];
    println!("{} tets, {} threads", tets.len(), rayon::current_num_threads());
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
