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
