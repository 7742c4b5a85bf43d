//! Criterion benchmarks of the core: one group per operator, throughput in tets.
//!
//! `cargo bench --bench assemble` (add `-- --quick` for a fast pass). Meshes are Kuhn
//! grids of the unit cube with jittered interior vertices (6 k^3 tets).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use tetlap::{LaplacianKind, MassKind, Options, TetMesh};

/// Jittered Kuhn grid: (points, tets) with 6 k^3 tets.
fn grid(k: usize) -> (Vec<f64>, Vec<[u32; 4]>) {
    let id = |x: usize, y: usize, z: usize| ((x * (k + 1) + y) * (k + 1) + z) as u32;
    let mut points = Vec::with_capacity(3 * (k + 1).pow(3));
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut jitter = |on: bool| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        if on { ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.4 } else { 0.0 }
    };
    for x in 0..=k {
        for y in 0..=k {
            for z in 0..=k {
                let inside = [x, y, z].iter().all(|&c| c > 0 && c < k);
                for c in [x, y, z] {
                    points.push((c as f64 + jitter(inside)) / k as f64);
                }
            }
        }
    }
    let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let mut tets = Vec::with_capacity(6 * k * k * k);
    for x in 0..k {
        for y in 0..k {
            for z in 0..k {
                for p in perms {
                    let mut c = [x, y, z];
                    let mut tet = [id(x, y, z); 4];
                    for (s, axis) in p.iter().enumerate() {
                        c[*axis] += 1;
                        tet[s + 1] = id(c[0], c[1], c[2]);
                    }
                    tets.push(tet);
                }
            }
        }
    }
    (points, tets)
}

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
            let mesh = TetMesh::new(points, 3, tets).unwrap();
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
