//! Meshes for the integration tests, built here without the crate: Kuhn grids of the unit
//! cube (tets) and square (triangles), seeded jitter, random renumbering.

#![allow(dead_code)] // every test file uses its own part

/// SplitMix64: a small seeded generator (the tests need no `rand`).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// A random permutation of `0..n` (Fisher-Yates).
    pub fn permutation(&mut self, n: usize) -> Vec<usize> {
        let mut p: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            p.swap(i, self.below(i + 1));
        }
        p
    }
}

/// The unit cube split into `k^3` cells of 6 Kuhn tets each, `(k+1)^3` vertices, row-major
/// points; interior vertices moved by up to `jitter / k` per coordinate (`jitter < 0.25`
/// keeps every tet valid). Tets in both orientations.
pub fn grid(k: usize, jitter: f64, seed: u64) -> (Vec<f64>, Vec<[u32; 4]>) {
    let n1 = k + 1;
    let index = |i: usize, j: usize, l: usize| ((i * n1 + j) * n1 + l) as u32;
    let mut rng = Rng::new(seed);
    let mut points = Vec::with_capacity(3 * n1 * n1 * n1);
    for i in 0..n1 {
        for j in 0..n1 {
            for l in 0..n1 {
                let interior = [i, j, l].iter().all(|&c| c > 0 && c < k);
                for c in [i, j, l] {
                    let shift = if interior { rng.uniform(-jitter, jitter) } else { 0.0 };
                    points.push((c as f64 + shift) / k as f64);
                }
            }
        }
    }
    let mut cells = Vec::with_capacity(6 * k * k * k);
    let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    for i in 0..k {
        for j in 0..k {
            for l in 0..k {
                for perm in perms {
                    let mut c = [i, j, l];
                    let mut cell = [index(i, j, l); 4];
                    for (step, &axis) in perm.iter().enumerate() {
                        c[axis] += 1;
                        cell[step + 1] = index(c[0], c[1], c[2]);
                    }
                    cells.push(cell);
                }
            }
        }
    }
    (points, cells)
}

/// The unit square split into `k^2` cells of 2 triangles, `(k+1)^2` vertices in 2-D,
/// interior vertices jittered by up to `jitter / k`.
pub fn tri_grid(k: usize, jitter: f64, seed: u64) -> (Vec<f64>, Vec<[u32; 3]>) {
    let n1 = k + 1;
    let index = |i: usize, j: usize| (i * n1 + j) as u32;
    let mut rng = Rng::new(seed);
    let mut points = Vec::with_capacity(2 * n1 * n1);
    for i in 0..n1 {
        for j in 0..n1 {
            let interior = i > 0 && i < k && j > 0 && j < k;
            for c in [i, j] {
                let shift = if interior { rng.uniform(-jitter, jitter) } else { 0.0 };
                points.push((c as f64 + shift) / k as f64);
            }
        }
    }
    let mut cells = Vec::with_capacity(2 * k * k);
    for i in 0..k {
        for j in 0..k {
            let (a, b, c, d) = (index(i, j), index(i + 1, j), index(i, j + 1), index(i + 1, j + 1));
            cells.push([a, b, d]);
            cells.push([a, d, c]);
        }
    }
    (points, cells)
}

/// The mesh with its vertices renumbered and its elements reordered at random, and the
/// new index of every old vertex.
pub fn shuffled<const K: usize>(
    points: &[f64],
    dim: usize,
    cells: &[[u32; K]],
    seed: u64,
) -> (Vec<f64>, Vec<[u32; K]>, Vec<usize>) {
    let mut rng = Rng::new(seed);
    let n = points.len() / dim;
    let old_of_new = rng.permutation(n);
    let mut new_of_old = vec![0; n];
    for (new, &old) in old_of_new.iter().enumerate() {
        new_of_old[old] = new;
    }
    let new_points = old_of_new.iter().flat_map(|&o| points[o * dim..(o + 1) * dim].iter().copied()).collect();
    let order = rng.permutation(cells.len());
    let new_cells = order.iter().map(|&t| cells[t].map(|v| new_of_old[v as usize] as u32)).collect();
    (new_points, new_cells, new_of_old)
}

/// Signed volume `det[x1-x0, x2-x0, x3-x0] / 6` of a tet of 3-D points.
pub fn volume(points: &[f64], cell: &[u32; 4]) -> f64 {
    let p = |k: usize| &points[3 * cell[k] as usize..3 * cell[k] as usize + 3];
    let e = |k: usize| [p(k)[0] - p(0)[0], p(k)[1] - p(0)[1], p(k)[2] - p(0)[2]];
    let (a, b, c) = (e(1), e(2), e(3));
    (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6.0
}

/// The bit patterns of `values` (bitwise comparisons: -0.0 != 0.0, NaN == NaN).
pub fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|x| x.to_bits()).collect()
}

/// `Options` with the given thread count.
pub fn threads(threads: Option<usize>) -> tetlap::Options {
    tetlap::Options { threads, ..Default::default() }
}

/// The thread counts every determinism test compares: 1, 2, 3 and rayon's global pool.
pub const THREADS: [Option<usize>; 4] = [Some(1), Some(2), Some(3), None];
