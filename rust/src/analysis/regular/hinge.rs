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

use super::lbfgs::{fill, Objective, CHUNK};
use rayon::prelude::*;

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
    /// The transpose: per variable, its rows ascending and their coefficients.
    offsets: Vec<usize>,
    t_rows: Vec<u32>,
    t_coef: Vec<f64>,
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
        let (mut t_rows, mut t_coef) = (vec![0u32; self.cols.len()], vec![0.0; self.cols.len()]);
        let mut next = offsets.clone();
        for r in 0..self.len() {
            for p in self.indptr[r]..self.indptr[r + 1] {
                let slot = &mut next[self.cols[p] as usize];
                (t_rows[*slot], t_coef[*slot]) = (r as u32, self.coef[p]);
                *slot += 1;
            }
        }
        (self.offsets, self.t_rows, self.t_coef) = (offsets, t_rows, t_coef);
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

    /// `-sum_r x_r a_r` of variable `j`, gathered in row order.
    #[inline]
    fn gather(&self, j: usize, x: &[f64]) -> f64 {
        let range = self.offsets[j]..self.offsets[j + 1];
        self.t_rows[range.clone()].iter().zip(&self.t_coef[range]).fold(0.0, |acc, (&r, a)| acc - a * x[r as usize])
    }

    /// `sum_r x_r a_r`, gathered per variable in row order.
    #[cfg(test)]
    fn apply_transposed(&self, x: &[f64]) -> Vec<f64> {
        map(self.offsets.len() - 1, |j| -self.gather(j, x))
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
///
/// Most rows are far above their aims (90% of the faces of a random mesh) and contribute
/// nothing, so each evaluation visits a *working set* only, without changing a bit of the
/// result: at a *reference* point (the first evaluation, and whenever the next one is out of
/// reach) every row is evaluated, and the working set is the rows within [`REACH`]
/// (times `|a_r|_1`) of their aim. A row outside it has `aim_r - g_r(u) <= -|a_r|_1 *
/// reach` there, so it stays above its aim (and its floor) for every `u` with `|u -
/// reference|_inf < reach`, and `F`, its gradient and the rows below their floors are those
/// of the working set alone. Sums run over the rows in order, by fixed chunks.
pub struct Shortfall<'h> {
    hinge: &'h Hinge,
    below: usize,
    /// `|a_r|_1` of every row.
    norm1: Vec<f64>,
    /// The reference point, the working rows (ascending) and how far from the reference
    /// they stay exact.
    reference: Vec<f64>,
    in_working: Vec<bool>,
    reach: f64,
    /// The variables of the working rows.
    touched: Vec<bool>,
    /// Scratch: `wgt * shortfall` of every row (0 outside the working set and at the aim).
    weighted: Vec<f64>,
}

/// The working set of [`Shortfall`]: rows within `REACH * |a_r|_1` of their aim.
pub const REACH: f64 = 1.0;

impl<'h> Shortfall<'h> {
    pub fn new(hinge: &'h Hinge) -> Self {
        let norm1 = (0..hinge.len()).map(|r| hinge.coef[hinge.indptr[r]..hinge.indptr[r + 1]].iter().map(|a| a.abs()).sum()).collect();
        Shortfall {
            hinge,
            below: usize::MAX,
            norm1,
            reference: vec![],
            in_working: vec![false; hinge.len()],
            reach: 0.0,
            touched: vec![],
            weighted: vec![0.0; hinge.len()],
        }
    }

    /// Every row at `u`: the new reference and working set.
    fn refer(&mut self, u: &[f64]) {
        let h = self.hinge;
        let g = h.values(u);
        let slack: Vec<f64> = (0..h.len()).map(|r| (g[r] - h.aim[r]) / self.norm1[r]).collect();
        for r in 0..h.len() {
            self.in_working[r] = slack[r].is_nan() || slack[r] <= REACH;
            if !self.in_working[r] {
                self.weighted[r] = 0.0;
            }
        }
        // the reach: how far u may move with every other row still above its aim
        self.reach = slack.iter().filter(|&&s| s > REACH).fold(f64::INFINITY, |a, &s| a.min(s));
        self.reference = u.to_vec();
        self.touched = vec![false; u.len()];
        for r in (0..h.len()).filter(|&r| self.in_working[r]) {
            h.cols[h.indptr[r]..h.indptr[r + 1]].iter().for_each(|&j| self.touched[j as usize] = true);
        }
    }
}

impl Objective for Shortfall<'_> {
    fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64 {
        let distance = if self.reference.is_empty() {
            f64::INFINITY
        } else {
            u.iter().zip(&self.reference).fold(0.0f64, |a, (x, y)| a.max((x - y).abs()))
        };
        if distance.is_nan() || distance >= self.reach {
            self.refer(u);
        }
        let h = self.hinge;
        let in_working = &self.in_working;
        // every working row's weighted shortfall in its slot, by chunks: (F, rows below floor)
        let chunk = |(c, out): (usize, &mut [f64])| -> (f64, usize) {
            let (mut f, mut below) = (0.0, 0);
            for (k, slot) in out.iter_mut().enumerate() {
                let r = c * CHUNK + k;
                if !in_working[r] {
                    continue;
                }
                let g = h.g0[r] + (h.indptr[r]..h.indptr[r + 1]).map(|p| h.coef[p] * u[h.cols[p] as usize]).sum::<f64>();
                below += usize::from(g < h.floor[r]);
                let short = h.aim[r] - g;
                *slot = if short > 0.0 { h.wgt[r] * short } else { 0.0 };
                f += 0.5 * short.max(0.0) * *slot;
            }
            (f, below)
        };
        let parts: Vec<(f64, usize)> = if h.len() <= CHUNK {
            self.weighted.chunks_mut(CHUNK).enumerate().map(chunk).collect()
        } else {
            self.weighted.par_chunks_mut(CHUNK).enumerate().map(chunk).collect()
        };
        self.below = parts.iter().map(|p| p.1).sum();
        // the gradient, -sum_r weighted_r a_r, gathered per variable in row order
        let (weighted, touched) = (&self.weighted, &self.touched);
        fill(grad, |j| if touched[j] { h.gather(j, weighted) } else { 0.0 });
        parts.iter().map(|p| p.0).sum()
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

