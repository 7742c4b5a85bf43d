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

use super::lbfgs::{fill, Objective, CHUNK, PARALLEL};
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
    #[cfg(test)]
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
/// nothing, so each evaluation visits a *working set* only (the values are those of all
/// rows, up to the order of the sums): at a *reference* point (the first evaluation, and whenever the next one is out of
/// reach) every row is evaluated, and the working set is the rows within a reach (from
/// [`REACH`], see [`RENEW`]; times `|a_r|_1`) of their aim. Every other row `r` has the
/// slack `s_r = (g_r - aim_r) / |a_r|_1 >` reach there, and stays above its aim while each of its variables `j` moves
/// less than `s_r` from the reference (`sum_k |a_rk| |du_k| < |a_r|_1 s_r`): each variable
/// gets the *cap* `min s_r` over the rows outside the working set that hold it, and while
/// every variable is within its cap, `F`, its gradient and the rows below their floors are
/// those of the working set alone. Only the variables of working rows move (the gradient,
/// and so every L-BFGS direction, is zero elsewhere), so an evaluation costs the working
/// rows and their variables, not the mesh. Sums run over the working rows in order, by
/// fixed chunks.
pub struct Shortfall<'h> {
    hinge: &'h Hinge,
    below: usize,
    /// `|a_r|_1` of every row.
    norm1: Vec<f64>,
    /// The reference point (empty before the first evaluation).
    reference: Vec<f64>,
    /// The working rows, ascending, copied together (a [`Hinge`] of their own: scattered
    /// over all rows, every value read would miss the cache), and per variable its cap
    /// (infinite when no row outside the working set holds it).
    working: Hinge,
    cap: Vec<f64>,
    /// The variables of the working rows, ascending, and per one of them its working rows
    /// (positions in `working`, ascending) with their coefficients.
    touched: Vec<u32>,
    t_offsets: Vec<usize>,
    t_rows: Vec<u32>,
    t_coef: Vec<f64>,
    /// Scratch: `wgt * shortfall` of every working row (0 at or above the aim).
    weighted: Vec<f64>,
    /// The reach of the working set (from [`REACH`], doubled up to 1 while the reference
    /// has to be renewed within [`RENEW`] evaluations), and the evaluations since it was.
    reach: f64,
    evaluations: usize,
}

/// The working set of [`Shortfall`] starts as the rows within `REACH * |a_r|_1` of their aim.
pub const REACH: f64 = 0.005;
/// A reference renewed within this many evaluations doubles the reach: where many rows
/// are short and the variables move far (a mesh with many faces to repair), a wider
/// working set costs less than renewing it at every step.
pub const RENEW: usize = 10;

impl<'h> Shortfall<'h> {
    pub fn new(hinge: &'h Hinge) -> Self {
        let norm1 = (0..hinge.len()).map(|r| hinge.coef[hinge.indptr[r]..hinge.indptr[r + 1]].iter().map(|a| a.abs()).sum()).collect();
        Shortfall {
            hinge,
            below: usize::MAX,
            norm1,
            reference: vec![],
            working: Hinge::new(),
            cap: vec![],
            touched: vec![],
            t_offsets: vec![],
            t_rows: vec![],
            t_coef: vec![],
            weighted: vec![],
            reach: REACH,
            evaluations: 0,
        }
    }

    /// Every row at `u`: the new reference, working set and caps.
    fn refer(&mut self, u: &[f64]) {
        if !self.reference.is_empty() && self.evaluations < RENEW {
            self.reach = (2.0 * self.reach).min(1.0);
        }
        self.evaluations = 0;
        let reach = self.reach;
        let h = self.hinge;
        let g = h.values(u);
        let slack: Vec<f64> = (0..h.len()).map(|r| (g[r] - h.aim[r]) / self.norm1[r]).collect();
        let in_working = |r: usize| slack[r].is_nan() || slack[r] <= reach;
        let n = u.len();
        // per variable: its cap
        self.cap = map(n, |j| {
            let range = h.offsets[j]..h.offsets[j + 1];
            h.t_rows[range].iter().filter(|&&r| !in_working(r as usize)).fold(f64::INFINITY, |a, &r| a.min(slack[r as usize]))
        });
        // the working rows and their transpose, over the variables they touch
        let mut working = Hinge::new();
        let mut count = vec![0usize; n];
        for r in (0..h.len()).filter(|&r| in_working(r)) {
            let range = h.indptr[r]..h.indptr[r + 1];
            h.cols[range.clone()].iter().for_each(|&j| count[j as usize] += 1);
            working.cols.extend_from_slice(&h.cols[range.clone()]);
            working.coef.extend_from_slice(&h.coef[range]);
            working.indptr.push(working.cols.len());
            working.g0.push(h.g0[r]);
            working.aim.push(h.aim[r]);
            working.floor.push(h.floor[r]);
            working.wgt.push(h.wgt[r]);
        }
        self.touched = (0..n as u32).filter(|&j| count[j as usize] > 0).collect();
        self.t_offsets = Vec::with_capacity(self.touched.len() + 1);
        self.t_offsets.push(0);
        let mut slot = vec![0usize; n];
        for &j in &self.touched {
            slot[j as usize] = *self.t_offsets.last().unwrap_or(&0);
            self.t_offsets.push(slot[j as usize] + count[j as usize]);
        }
        let nnz = *self.t_offsets.last().unwrap_or(&0);
        (self.t_rows, self.t_coef) = (vec![0; nnz], vec![0.0; nnz]);
        for k in 0..working.len() {
            for p in working.indptr[k]..working.indptr[k + 1] {
                let s = &mut slot[working.cols[p] as usize];
                (self.t_rows[*s], self.t_coef[*s]) = (k as u32, working.coef[p]);
                *s += 1;
            }
        }
        self.working = working;
        self.weighted = vec![0.0; self.working.len()];
        self.reference = u.to_vec();
    }

    /// Whether some variable left its cap since the reference (or there is none yet).
    fn out_of_reach(&self, u: &[f64]) -> bool {
        self.reference.is_empty()
            || u.iter().zip(&self.reference).zip(&self.cap).any(|((x, y), c)| {
                let d = (x - y).abs();
                d.is_nan() || d >= *c
            })
    }
}

impl Objective for Shortfall<'_> {
    fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64 {
        if self.out_of_reach(u) {
            self.refer(u);
        }
        self.evaluations += 1;
        let h = &self.working;
        // every working row's weighted shortfall in its slot, by chunks: (F, rows below floor)
        let chunk = |(c, out): (usize, &mut [f64])| -> (f64, usize) {
            let (mut f, mut below) = (0.0, 0);
            for (k, slot) in out.iter_mut().enumerate() {
                let r = c * CHUNK + k;
                let g = h.g0[r] + (h.indptr[r]..h.indptr[r + 1]).map(|p| h.coef[p] * u[h.cols[p] as usize]).sum::<f64>();
                below += usize::from(g < h.floor[r]);
                let short = h.aim[r] - g;
                *slot = if short > 0.0 { h.wgt[r] * short } else { 0.0 };
                f += 0.5 * short.max(0.0) * *slot;
            }
            (f, below)
        };
        let parts: Vec<(f64, usize)> = if h.len() < PARALLEL {
            self.weighted.chunks_mut(CHUNK).enumerate().map(chunk).collect()
        } else {
            self.weighted.par_chunks_mut(CHUNK).enumerate().map(chunk).collect()
        };
        self.below = parts.iter().map(|p| p.1).sum();
        // the gradient, -sum_r weighted_r a_r, gathered per touched variable in row order
        grad.iter_mut().for_each(|x| *x = 0.0);
        let (weighted, offsets, rows, coef) = (&self.weighted, &self.t_offsets, &self.t_rows, &self.t_coef);
        let gather = |k: usize| -> f64 {
            (offsets[k]..offsets[k + 1]).fold(0.0, |acc, p| acc - coef[p] * weighted[rows[p] as usize])
        };
        let values = map(self.touched.len(), gather);
        self.touched.iter().zip(values).for_each(|(&j, x)| grad[j as usize] = x);
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

