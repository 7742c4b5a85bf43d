//! The kernels of one tet, single-threaded: nanoseconds per tet, forward and reverse.
//!
//! `cargo bench --bench kernels` (add `-- --quick` for a fast pass). Every case runs its
//! kernel over the same 100,000 well-shaped random tets; criterion's throughput (tets per
//! second) gives the time per tet. The VJPs of [`tetlap::element::tet::derivatives`] are
//! timed beside the forward kernels they differentiate, and a tensor coefficient's steps
//! (its checks and factor, the tet mapped by it) beside them.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use tetlap::element::tet::derivatives::{dual_vjp, primal_vjp, volume_vjp, Vjp};
use tetlap::element::tet::batch::{Edges, Frames, Lanes, LANES};
use tetlap::element::metric::{mapped_tet, Tensor};
use tetlap::element::tet::{barycentric_mass, dual, power_dual, primal_weights, volume, Placement};
use tetlap::{local_tet, LocalTet};

/// 100,000 random tets of the unit cube with volume above 0.01 (a fixed sequence).
fn tets() -> Vec<LocalTet> {
    corners().iter().map(|x| local_tet([&x[0], &x[1], &x[2], &x[3]], &mut [])).collect()
}

/// The corners of [`tets`].
fn corners() -> Vec<[[f64; 3]; 4]> {
    let mut state = 1u64;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..100_000)
        .map(|_| loop {
            let x: [[f64; 3]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| uniform()));
            let t = local_tet([&x[0], &x[1], &x[2], &x[3]], &mut []);
            if volume(&t) > 0.01 {
                break x;
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let tets = tets();
    let w = [0.0, 0.01, -0.02, 0.015];
    let (dw, dm) = ([0.3, -0.2, 0.5, 0.7, -1.1, 0.4], [0.2, 0.1, -0.3, 0.5]);
    let mut group = c.benchmark_group("kernels");
    group.sample_size(20);
    group.throughput(Throughput::Elements(tets.len() as u64));
    let mut case = |name: &str, f: &dyn Fn(&LocalTet)| {
        group.bench_function(name, |b| b.iter(|| tets.iter().for_each(|t| f(black_box(t)))));
    };
    case("volume", &|t| { black_box(volume(t)); });
    case("barycentric mass", &|t| { black_box(barycentric_mass(t)); });
    case("primal", &|t| { black_box(primal_weights(t)); });
    case("dual", &|t| { black_box(dual(t)); });
    case("power dual", &|t| { black_box(power_dual(t, Some(&w), Placement::Centres)); });
    case("volume vjp", &|t| { black_box(volume_vjp(t, 1.0)); });
    case("primal vjp", &|t| { black_box(primal_vjp(t, dw)); });
    case("dual vjp", &|t| { black_box(dual_vjp(t, None, dw, dm)); });
    case("power dual vjp", &|t| { black_box(dual_vjp(t, Some(w), dw, dm)); });
    case("affine + circumcentric vjp", &|t| {
        let mut v = Vjp::new(t);
        let _ = v.primal(dw.map(|x| 0.5 * x));
        v.dual(None, dw.map(|x| 0.5 * x), dm);
        black_box(v.finish());
    });
    group.finish();
    // a coefficient: the tensor's checks and factor, the tet mapped by it, its kernels
    let tensors: Vec<[f64; 9]> = (0..tets.len())
        .map(|t| {
            let (a, b) = (1.0 + (t % 7) as f64, 0.1 * (t % 5) as f64);
            [a, b, 0.05, b, 2.0, -0.3, 0.05, -0.3, 5.0 * a]
        })
        .collect();
    let factors: Vec<Tensor<3>> = tensors.iter().map(|k| Tensor::factor(k)).collect();
    let mut group = c.benchmark_group("coefficient");
    group.sample_size(20);
    group.throughput(Throughput::Elements(tets.len() as u64));
    group.bench_function("tensor check + factor", |b| b.iter(|| tensors.iter().for_each(|k| { let _ = black_box(Tensor::<3>::new(black_box(k))); })));
    group.bench_function("tensor factor", |b| b.iter(|| tensors.iter().for_each(|k| { black_box(Tensor::<3>::factor(black_box(k))); })));
    let xs = corners();
    let mut case = |name: &str, f: &dyn Fn(&[[f64; 3]; 4], &LocalTet, &Tensor<3>)| {
        group.bench_function(name, |b| {
            b.iter(|| xs.iter().zip(&tets).zip(&factors).for_each(|((x, t), k)| f(black_box(x), black_box(t), black_box(k))))
        });
    };
    let mapped = |x: &[[f64; 3]; 4], t: &LocalTet, k: &Tensor<3>| mapped_tet([&x[0], &x[1], &x[2], &x[3]], t, k).0;
    case("mapped tet", &|x, t, k| { black_box(mapped(x, t, k)); });
    case("mapped tet + primal", &|x, t, k| { black_box(primal_weights(&mapped(x, t, k))); });
    case("mapped tet + dual", &|x, t, k| { black_box(dual(&mapped(x, t, k))); });
    group.finish();
    // the same tets, LANES at a time, as structure of arrays
    let batches: Vec<[[Lanes; 3]; 4]> = corners()
        .chunks_exact(LANES)
        .map(|b| std::array::from_fn(|k| std::array::from_fn(|a| std::array::from_fn(|i| b[i][k][a]))))
        .collect();
    let mut group = c.benchmark_group("batched");
    group.sample_size(20);
    group.throughput(Throughput::Elements((batches.len() * LANES) as u64));
    let mut case = |name: &str, f: &dyn Fn(&[[Lanes; 3]; 4])| {
        group.bench_function(name, |b| b.iter(|| batches.iter().for_each(|x| f(black_box(x)))));
    };
    case("frame", &|x| { black_box(Frames::new(x)); });
    case("frame + primal", &|x| { black_box(Frames::new(x).primal()); });
    case("frame + dual", &|x| { black_box(Frames::new(x).dual()); });
    case("frame + volume", &|x| { black_box(Frames::new(x).volume()); });
    let lanes_of: Vec<[Tensor<3>; LANES]> = factors.chunks_exact(LANES).map(|k| std::array::from_fn(|i| k[i])).collect();
    let mut case = |name: &str, f: &dyn Fn(&[[Lanes; 3]; 4], &[Tensor<3>; LANES])| {
        group.bench_function(name, |b| b.iter(|| batches.iter().zip(&lanes_of).for_each(|(x, k)| f(black_box(x), black_box(k)))));
    };
    let at = |x: &[[Lanes; 3]; 4], i: usize| -> [[f64; 3]; 4] { std::array::from_fn(|c| std::array::from_fn(|a| x[c][a][i])) };
    case("frame + mapped + primal", &|x, k| {
        let xs: [[[f64; 3]; 4]; LANES] = std::array::from_fn(|i| at(x, i));
        black_box(Frames::mapped(&Edges::new(x), |i| [&xs[i][0], &xs[i][1], &xs[i][2], &xs[i][3]], k).primal());
    });
    case("frame + mapped + dual", &|x, k| {
        let xs: [[[f64; 3]; 4]; LANES] = std::array::from_fn(|i| at(x, i));
        black_box(Frames::mapped(&Edges::new(x), |i| [&xs[i][0], &xs[i][1], &xs[i][2], &xs[i][3]], k).dual());
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
