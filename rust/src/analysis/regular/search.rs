//! The search for weights that lift every face condition to its floor: the squared
//! shortfall of the conditions ([`super::hinge`]), minimised by projected L-BFGS
//! ([`super::lbfgs`]).
//!
//! The conditions are rows `g_r(u) = g0_r + sum_k a_rk u[j_rk]` (five entries each, in the
//! caller's units `u`), with a floor and an aim above it each; the search is done as soon
//! as every row reaches its floor. Where it stalls short of them, the rows left short carry
//! the multipliers of its optimality condition ([`Outcome::short`]): where a proof of
//! infeasibility is to be looked for.

use super::hinge::{Hinge, Shortfall};
use super::lbfgs::{minimise, Budget, Stop};
use crate::error::{Error, Result};
use crate::options::Options;
use rayon::prelude::*;

/// Rows per parallel chunk.
const ROWS: usize = 4096;

/// Rows `g_r(u) = g0_r + sum_k coefficients[r][k] * u[vertices[r][k]]`.
#[derive(Debug, Clone, Copy)]
pub struct Rows<'a> {
    /// The five variables of every row.
    pub vertices: &'a [[u32; 5]],
    /// Every row's value at `u = 0`.
    pub g0: &'a [f64],
    /// The five coefficients of every row.
    pub coefficients: &'a [[f64; 5]],
}

impl Rows<'_> {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.g0.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.g0.is_empty()
    }

    /// `g_r(u)` of row `r`.
    #[inline]
    pub fn value(&self, r: usize, u: &[f64]) -> f64 {
        let (v, a) = (&self.vertices[r], &self.coefficients[r]);
        self.g0[r] + a[0] * u[v[0] as usize] + a[1] * u[v[1] as usize] + a[2] * u[v[2] as usize]
            + a[3] * u[v[3] as usize] + a[4] * u[v[4] as usize]
    }

    /// `g(u)` of every row.
    pub fn values(&self, u: &[f64]) -> Vec<f64> {
        (0..self.len()).into_par_iter().with_min_len(ROWS).map(|r| self.value(r, u)).collect()
    }

    pub(super) fn check(&self, n: usize) -> Result<()> {
        let shape = |what: String| Err(Error::Shape { what });
        if self.vertices.len() != self.len() || self.coefficients.len() != self.len() {
            return shape(format!(
                "rows: {} vertex rows, {} values, {} coefficient rows",
                self.vertices.len(),
                self.len(),
                self.coefficients.len()
            ));
        }
        if let Some(r) = self.vertices.iter().position(|v| v.iter().any(|&j| j as usize >= n)) {
            return shape(format!("row {r} refers to variable {:?}, but there are {n}", self.vertices[r]));
        }
        if let Some(r) = (0..self.len()).find(|&r| !self.g0[r].is_finite() || !self.coefficients[r].iter().all(|a| a.is_finite())) {
            return shape(format!("row {r} has a non-finite value or coefficient"));
        }
        Ok(())
    }
}

/// What one search is asked: per row the floor to reach and the aim (above it) of the
/// squared shortfall, and per variable its bounds.
#[derive(Debug, Clone, Copy)]
pub struct Targets<'a> {
    /// Every row's floor: the search is done when every row reaches it.
    pub floor: &'a [f64],
    /// Every row's aim (`>= floor`), where its shortfall starts.
    pub aim: &'a [f64],
    /// Lower bounds of the variables.
    pub lo: &'a [f64],
    /// Upper bounds of the variables.
    pub hi: &'a [f64],
}

/// The result of [`search`].
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Why it stopped: [`Stop::Done`] when every row reached its floor.
    pub stop: Stop,
    /// Iterations spent.
    pub iterations: usize,
    /// The rows short of their aim (when not done), largest shortfall first, each
    /// with its multiplier estimate `wgt_r * shortfall_r` (at a minimum of `F` these satisfy
    /// the optimality condition `sum_r y_r a_r = 0` up to the bounds: where a proof of
    /// infeasibility is to be looked for).
    pub short: Vec<(u32, f64)>,
}

/// The rows `index` as hinge rows with the floors and aims of `targets` (more may be pushed
/// before [`Hinge::finish`]).
pub(super) fn hinge_rows(rows: &Rows, targets: &Targets, index: impl IntoIterator<Item = usize>) -> Hinge {
    let mut hinge = Hinge::new();
    for r in index {
        let entries = rows.vertices[r].iter().copied().zip(rows.coefficients[r].iter().copied());
        hinge.push(entries, rows.g0[r], targets.aim[r], targets.floor[r]);
    }
    hinge
}

/// Searches `u` (updated in place; within the bounds) with every row at or above its
/// floor, from the given `u`, within `budget` (counted down). See the module docs.
pub fn search(rows: Rows, targets: &Targets, u: &mut [f64], budget: &mut Budget, opts: &Options) -> Result<Outcome> {
    let n = u.len();
    rows.check(n)?;
    let m = rows.len();
    if targets.floor.len() != m || targets.aim.len() != m || targets.lo.len() != n || targets.hi.len() != n {
        return Err(Error::Shape { what: format!("targets: {m} rows and {n} variables expected") });
    }
    if let Some(j) = (0..n).find(|&j| !(targets.lo[j] <= u[j] && u[j] <= targets.hi[j])) {
        return Err(Error::Shape { what: format!("u[{j}] = {} lies outside its bounds", u[j]) });
    }
    opts.install(|| {
        let hinge = hinge_rows(&rows, targets, 0..m).finish(n);
        let before = budget.iterations;
        let stop = minimise(&mut Shortfall::new(&hinge), u, targets.lo, targets.hi, budget, opts)?;
        let short = if stop == Stop::Done { vec![] } else { hinge.shortfalls(u) };
        Ok(Outcome { stop, iterations: before - budget.iterations, short })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of a 1-D chain: `u[i+1] - u[i] >= 1` for i < k, as five-entry rows.
    fn chain(k: usize) -> (Vec<[u32; 5]>, Vec<f64>, Vec<[f64; 5]>) {
        let vertices = (0..k as u32).map(|i| [i, i + 1, i, i, i]).collect();
        let coefficients = (0..k).map(|_| [-1.0, 1.0, 0.0, 0.0, 0.0]).collect();
        (vertices, vec![0.0; k], coefficients)
    }

    #[test]
    fn a_feasible_chain_reaches_its_floors_and_an_infeasible_cycle_reports_its_rows() {
        let (v, g0, a) = chain(20);
        let rows = Rows { vertices: &v, g0: &g0, coefficients: &a };
        let n = 21;
        let (floor, aim) = (vec![1.0; 20], vec![1.1; 20]);
        let (lo, hi) = (vec![-100.0; n], vec![100.0; n]);
        let targets = Targets { floor: &floor, aim: &aim, lo: &lo, hi: &hi };
        let mut u = vec![0.0; n];
        let mut budget = Budget { iterations: 1000, deadline: None };
        let out = search(rows, &targets, &mut u, &mut budget, &Options::default()).unwrap();
        assert_eq!(out.stop, Stop::Done);
        assert!(rows.values(&u).iter().all(|&g| g >= 1.0));
        // close the chain into a cycle: u[0] - u[20] >= 1 as well, impossible
        let (mut v, mut g0, mut a) = chain(20);
        v.push([20, 0, 0, 0, 0]);
        a.push([-1.0, 1.0, 0.0, 0.0, 0.0]);
        g0.push(0.0);
        let rows = Rows { vertices: &v, g0: &g0, coefficients: &a };
        let (floor, aim) = (vec![1.0; 21], vec![1.1; 21]);
        let targets = Targets { floor: &floor, aim: &aim, lo: &lo, hi: &hi };
        let mut u = vec![0.0; n];
        let mut budget = Budget { iterations: 1000, deadline: None };
        let out = search(rows, &targets, &mut u, &mut budget, &Options::default()).unwrap();
        assert_eq!(out.stop, Stop::Stalled);
        // every row is short by the same amount, and the multipliers cancel: sum y_r a_r = 0
        assert_eq!(out.short.len(), 21);
        let mut total = vec![0.0; n];
        for &(r, y) in &out.short {
            for k in 0..2 {
                total[v[r as usize][k] as usize] += y * a[r as usize][k];
            }
        }
        let scale: f64 = out.short.iter().map(|s| s.1).sum();
        assert!(total.iter().all(|t| t.abs() < 1e-6 * scale), "{total:?}");
    }
}
