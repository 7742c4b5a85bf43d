//! Criterion benchmarks of the core: one group per operator, throughput in tets.
//!
//! `cargo bench --bench assemble` (add `-- --quick` for a fast pass). Meshes are Kuhn
//! grids of the unit cube with jittered interior vertices (6 k^3 tets).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use tetlap::{LaplacianKind, MassKind, Options, TetView};

#[path = "grid.rs"]
mod grid;
use grid::grid;

fn bench(c: &mut Criterion) {
    let sizes = [10, 30, 60]; // 6k, 162k, 1.3M tets
    let meshes: Vec<_> = sizes.iter().map(|&k| grid(k)).collect();
    let opts = Options::default();
    let cases: [(&str, Option<LaplacianKind>, Option<MassKind>); 4] = [
        ("primal", Some(LaplacianKind::Primal), None),
        ("dual", Some(LaplacianKind::Dual), None),
        ("circumcentric_mass", None, Some(MassKind::Circumcentric)),
        ("dual+circumcentric", Some(LaplacianKind::Dual), Some(MassKind::Circumcentric)),
    ];
    for (name, lap, mass) in cases {
        let mut group = c.benchmark_group(name);
        group.sample_size(10);
        for (points, tets) in &meshes {
            let mesh = TetView::new(points, 3, tets).unwrap();
            group.throughput(Throughput::Elements(tets.len() as u64));
            group.bench_with_input(BenchmarkId::from_parameter(tets.len()), &mesh, |b, mesh| {
                b.iter(|| match (lap, mass) {
                    (Some(l), Some(m)) => drop(tetlap::operators(mesh, l, m, &opts).unwrap()),
                    (Some(l), None) => drop(tetlap::laplacian(mesh, l, &opts).unwrap()),
                    (None, Some(m)) => drop(tetlap::mass(mesh, m, &opts).unwrap()),
                    (None, None) => unreachable!(),
                })
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
