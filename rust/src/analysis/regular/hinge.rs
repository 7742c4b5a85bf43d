//! Hinge least squares: sparse linear rows lifted to their aims, the objective of the
//! search and of the mass step.
//!
//! For rows `g_r(u) = g0_r + a_r . u` with aims, floors and weights `wgt_r = 1 / |a_r|^2`,
//!
//! ```text
//! F(u) = 1/2 sum_r wgt_r max(0, aim_r - g_r(u))^2
//! ```
//!
//! (`sqrt(wgt_r) (aim_r - g_r)` is the distance of `u` to the half-space `g_r >= aim_r`) is
//! a convex piecewise quadratic, done as soon as every row reaches its floor; it is
//! minimised by [`super::lbfgs`]. Every row and every variable has its own slot (the
//! gradient is gathered per variable in row order) and sums are taken by fixed chunks: the
//! values are bitwise the same for any thread count.

use super::lbfgs::{dot, fill, Objective};

/// `f(i)` for `i < n`, in parallel by chunks (sequential for small `n`).
fn map(n: usize, f: impl Fn(usize) -> f64 + Sync + Send) -> Vec<f64> {
    let mut out = vec![0.0; n];
    fill(&mut out, f);
    out
}

/// Sparse rows over local variables, with their aims, floors and weights.
#[derive(Debug, Clone, Default)]
pub struct Hinge {
    indptr: Vec<usize>,
    cols: Vec<u32>,
    coef: Vec<f64>,
    g0: Vec<f64>,
    aim: Vec<f64>,
    floor: Vec<f64>,
    wgt: Vec<f64>,
    /// Per variable, its positions in `cols` ascending; the row of every position.
    offsets: Vec<usize>,
    positions: Vec<u32>,
    row_of: Vec<u32>,
}

impl Hinge {
    /// No rows over `n` variables; add them with [`Hinge::push`], then [`Hinge::finish`].
    pub fn new() -> Self {
        Hinge { indptr: vec![0], ..Hinge::default() }
    }

    /// Adds the row `g0 + sum coef_k u[col_k] >= floor`, aiming at `aim`.
    pub fn push(&mut self, entries: impl IntoIterator<Item = (u32, f64)>, g0: f64, aim: f64, floor: f64) {
        let mut norm2 = 0.0;
        for (j, a) in entries {
            self.cols.push(j);
            self.coef.push(a);
            norm2 += a * a;
        }
        self.indptr.push(self.cols.len());
        self.g0.push(g0);
        self.aim.push(aim);
        self.floor.push(floor);
        self.wgt.push(if norm2 > 0.0 { 1.0 / norm2 } else { 0.0 });
    }

    /// Builds the transpose over `n` variables (every column `< n`).
    pub fn finish(mut self, n: usize) -> Self {
        let mut offsets = vec![0usize; n + 1];
        for &j in &self.cols {
            offsets[j as usize + 1] += 1;
        }
        for j in 0..n {
            offsets[j + 1] += offsets[j];
        }
        let mut positions = vec![0u32; self.cols.len()];
        let mut next = offsets.clone();
        for (p, &j) in self.cols.iter().enumerate() {
            positions[next[j as usize]] = p as u32;
            next[j as usize] += 1;
        }
        self.row_of = (0..self.len()).flat_map(|r| std::iter::repeat_n(r as u32, self.indptr[r + 1] - self.indptr[r])).collect();
        self.offsets = offsets;
        self.positions = positions;
        self
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.g0.len()
    }

    /// `a_r . v` of every row.
    fn apply(&self, v: &[f64]) -> Vec<f64> {
        map(self.len(), |r| (self.indptr[r]..self.indptr[r + 1]).map(|p| self.coef[p] * v[self.cols[p] as usize]).sum())
    }

    /// `g_r(u)` of every row.
    pub fn values(&self, u: &[f64]) -> Vec<f64> {
        let mut g = self.apply(u);
        g.iter_mut().zip(&self.g0).for_each(|(x, g0)| *x += g0);
        g
    }

    /// `sum_r x_r a_r`, gathered per variable in row order.
    fn apply_transposed(&self, x: &[f64]) -> Vec<f64> {
        map(self.offsets.len() - 1, |j| {
            self.positions[self.offsets[j]..self.offsets[j + 1]]
                .iter()
                .map(|&p| self.coef[p as usize] * x[self.row_of[p as usize] as usize])
                .sum()
        })
    }

    /// Rows below their floor at the values `g`.
    pub fn below(&self, g: &[f64]) -> usize {
        g.iter().zip(&self.floor).filter(|(g, f)| g < f).count()
    }

    /// The rows short of their aim at `u`, largest distance first (ties by row), with
    /// `wgt * shortfall` (at a minimum of `F` these satisfy `sum_r y_r a_r = 0` up to the
    /// bounds).
    pub fn shortfalls(&self, u: &[f64]) -> Vec<(u32, f64)> {
        let g = self.values(u);
        let mut short: Vec<(u32, f64, f64)> = (0..self.len())
            .filter_map(|r| {
                let d = self.aim[r] - g[r];
                let distance = d * self.wgt[r].sqrt();
                (distance > 1e-12).then(|| (r as u32, distance, self.wgt[r] * d))
            })
            .collect();
        short.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        short.into_iter().map(|(r, _, y)| (r, y)).collect()
    }
}

/// The rows as an [`Objective`]: `F` and its gradient, done when every row reaches its
/// floor.
pub struct Shortfall<'h> {
    hinge: &'h Hinge,
    below: usize,
}

impl<'h> Shortfall<'h> {
    pub fn new(hinge: &'h Hinge) -> Self {
        Shortfall { hinge, below: usize::MAX }
    }
}

impl Objective for Shortfall<'_> {
    fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64 {
        let h = self.hinge;
        let g = h.values(u);
        self.below = h.below(&g);
        let weighted: Vec<f64> =
            g.iter().zip(&h.aim).zip(&h.wgt).map(|((g, a), w)| if a > g { w * (a - g) } else { 0.0 }).collect();
        let f = 0.5 * dot(&weighted, &g.iter().zip(&h.aim).map(|(g, a)| (a - g).max(0.0)).collect::<Vec<f64>>());
        let pulled = h.apply_transposed(&weighted);
        grad.iter_mut().zip(pulled).for_each(|(x, p)| *x = -p);
        f
    }

    fn done(&self) -> bool {
        self.below == 0
    }
}

#[cfg(test)]
mod tests {
    use super::super::lbfgs::{minimise, Budget, Stop};
    use super::*;
    use crate::options::Options;

    /// `u[i+1] - u[i] >= 1` for `i < k`, closed into a cycle (infeasible) if asked.
    fn chain(k: usize, cycle: bool) -> Hinge {
        let mut h = Hinge::new();
        for i in 0..k as u32 {
            h.push([(i, -1.0), (i + 1, 1.0)], 0.0, 1.1, 1.0);
        }
        if cycle {
            h.push([(k as u32, -1.0), (0, 1.0)], 0.0, 1.1, 1.0);
        }
        h.finish(k + 1)
    }

    fn run(h: &Hinge, n: usize, bound: f64, threads: usize) -> (Vec<f64>, Stop, usize) {
        let opts = Options { threads: Some(threads), ..Options::default() };
        let mut u = vec![0.0; n];
        let mut budget = Budget { iterations: 2000, deadline: None };
        let (lo, hi) = (vec![-bound; n], vec![bound; n]);
        let stop = opts.install(|| minimise(&mut Shortfall::new(h), &mut u, &lo, &hi, &mut budget, &opts)).unwrap();
        (u, stop, budget.iterations)
    }

    #[test]
    fn a_feasible_chain_reaches_its_floors_the_same_on_any_thread_count() {
        let h = chain(30, false);
        let (u, stop, left) = run(&h, 31, 100.0, 1);
        assert_eq!(stop, Stop::Done);
        assert!(h.values(&u).iter().all(|&g| g >= 1.0));
        assert_eq!(run(&h, 31, 100.0, 2), (u.clone(), stop, left));
        assert_eq!(run(&h, 31, 100.0, 3), (u, stop, left));
        // 30 steps of 1 do not fit in [-2, 2]: the bounds hold, the floors are not reached
        let (u, stop, _) = run(&h, 31, 2.0, 1);
        assert!(u.iter().all(|x| (-2.0..=2.0).contains(x)));
        assert_eq!(stop, Stop::Stalled);
    }

    #[test]
    fn an_infeasible_cycle_stalls_with_multipliers_that_cancel() {
        let h = chain(20, true);
        let (u, stop, _) = run(&h, 21, 100.0, 1);
        assert_eq!(stop, Stop::Stalled);
        let short = h.shortfalls(&u);
        assert_eq!(short.len(), 21);
        let mut x = vec![0.0; 21];
        for &(r, y) in &short {
            x[r as usize] = y;
        }
        let total = h.apply_transposed(&x);
        let scale: f64 = x.iter().sum();
        assert!(total.iter().all(|t| t.abs() < 1e-4 * scale), "{total:?}");
    }
}
