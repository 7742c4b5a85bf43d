//! The benchmark mesh: a jittered Kuhn grid of the unit cube, deterministic.

/// Jittered Kuhn grid: (points, tets) with 6 k^3 tets.
pub fn grid(k: usize) -> (Vec<f64>, Vec<[u32; 4]>) {
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

/// The same mesh with its vertices and its tets renumbered by `i -> i * a mod len` for a
/// large `a` coprime to the length: consecutive indices land far apart, as in a shuffled
/// user mesh, deterministically and without a random-number crate.
#[allow(dead_code)] // used by some of the benchmarks that include this file
pub fn scrambled(points: &[f64], tets: &[[u32; 4]]) -> (Vec<f64>, Vec<[u32; 4]>) {
    let scramble = |len: usize| -> Vec<usize> {
        let mut a = 2_654_435_761usize % len.max(2);
        while gcd(a, len) != 1 {
            a += 1;
        }
        (0..len).map(|i| i * a % len).collect()
    };
    let n = points.len() / 3;
    let new_of_old = scramble(n);
    let mut moved = vec![0.0; points.len()];
    for (old, &new) in new_of_old.iter().enumerate() {
        moved[3 * new..3 * new + 3].copy_from_slice(&points[3 * old..3 * old + 3]);
    }
    let order = scramble(tets.len());
    let renumbered = order.iter().map(|&t| tets[t].map(|v| new_of_old[v as usize] as u32)).collect();
    (moved, renumbered)
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}
