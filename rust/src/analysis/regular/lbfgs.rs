//! A projected L-BFGS minimiser within bounds, deterministic for any thread count.
//!
//! Each iteration: the variables at a bound whose gradient pushes outwards are held
//! (the *active* bounds); on the others, the L-BFGS direction of the two-loop recursion
//! (memory [`MEMORY`], initial scaling `s.y / y.y`); then a line search along the projected
//! path `clamp(u + t d)` from `t = 1` for the weak Wolfe conditions (bisection within a
//! bracket, doubling before one is found). When that fails, the
//! memory is dropped and the step retried along the steepest descent. It stops when the
//! objective reports that it is done, when the objective fell by less than [`STALL_DROP`]
//! over [`STALL_WINDOW`] iterations (a slow tail, where the caller looks for a proof of
//! infeasibility or relaxes), when no descent step exists, or at the budget.
//!
//! Every sum over the variables is taken by fixed chunks added in order ([`dot`]), so the
//! iterates are bitwise the same for any thread count.

use crate::error::Result;
use crate::options::Options;
use rayon::prelude::*;
use std::time::Instant;

/// Pairs `(s, y)` kept by the two-loop recursion.
pub const MEMORY: usize = 10;
/// The line search's sufficient decrease (Armijo) and curvature (weak Wolfe) constants.
const ARMIJO: f64 = 1e-4;
const WOLFE: f64 = 0.9;
/// The stall test: the objective fell by less than this fraction...
pub const STALL_DROP: f64 = 0.01;
/// ... over this many iterations.
pub const STALL_WINDOW: usize = 100;
/// Chunk of the deterministic sums and of the parallel loops (fixed, whatever the thread
/// count).
pub(super) const CHUNK: usize = 4096;

/// A function to minimise.
pub trait Objective {
    /// The value at `u`, its gradient written to `grad`.
    fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64;
    /// Whether the point of the last [`Objective::eval`] is good enough to stop.
    fn done(&self) -> bool;
}

/// Why the minimiser stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stop {
    /// The objective said it was done.
    Done,
    /// The objective fell by less than `STALL_DROP` over `STALL_WINDOW` iterations, or
    /// no descent step was found (a minimum, to rounding).
    Stalled,
    /// The iteration budget ran out.
    Iterations,
    /// The caller's wall-clock deadline passed (an explicit opt-in).
    Deadline,
}

/// What the minimiser may spend: iterations (deterministic) and, only if the caller asks
/// for it, a wall-clock deadline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budget {
    /// Iterations left.
    pub iterations: usize,
    /// A wall-clock deadline (the caller's explicit opt-in; results then depend on speed).
    pub deadline: Option<Instant>,
}

impl Budget {
    /// Whether the deadline, if any, has passed.
    pub fn late(&self) -> bool {
        self.deadline.is_some_and(|d| Instant::now() >= d)
    }

    /// At most `iterations` of this budget, to be given back with [`Budget::spend`].
    pub fn part(&self, iterations: usize) -> Budget {
        Budget { iterations: self.iterations.min(iterations), deadline: self.deadline }
    }

    /// Takes what `part` (from [`Budget::part`] with `asked` iterations) spent; returns it.
    pub fn spend(&mut self, part: &Budget, asked: usize) -> usize {
        let spent = self.iterations.min(asked) - part.iterations;
        self.iterations -= spent;
        spent
    }
}

/// `sum_i a_i b_i`, by fixed chunks added in order.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    if a.len() <= CHUNK {
        return a.iter().zip(b).map(|(x, y)| x * y).sum();
    }
    let parts: Vec<f64> =
        a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum()).collect();
    parts.iter().sum()
}

/// `out[i] = f(i)`, in parallel by chunks for long vectors.
pub(super) fn fill(out: &mut [f64], f: impl Fn(usize) -> f64 + Sync + Send) {
    if out.len() <= CHUNK {
        out.iter_mut().enumerate().for_each(|(i, x)| *x = f(i));
    } else {
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, chunk)| {
            chunk.iter_mut().enumerate().for_each(|(k, x)| *x = f(c * CHUNK + k));
        });
    }
}

/// Minimises `objective` from `u` within `lo <= u <= hi` (updated in place; `u` must lie
/// within the bounds), for at most `budget.iterations` iterations (counted down).
pub fn minimise(
    objective: &mut impl Objective,
    u: &mut [f64],
    lo: &[f64],
    hi: &[f64],
    budget: &mut Budget,
    opts: &Options,
) -> Result<Stop> {
    let n = u.len();
    let mut grad = vec![0.0; n];
    let mut f = objective.eval(u, &mut grad);
    let mut memory: Vec<(Vec<f64>, Vec<f64>, f64)> = Vec::with_capacity(MEMORY);
    let mut history = vec![f];
    let (mut d, mut trial, mut trial_grad, mut step) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut free = vec![false; n];
    loop {
        if objective.done() {
            return Ok(Stop::Done);
        }
        if budget.iterations == 0 {
            return Ok(Stop::Iterations);
        }
        if budget.late() {
            return Ok(Stop::Deadline);
        }
        opts.cancelled()?;
        for i in 0..n {
            free[i] = !((u[i] <= lo[i] && grad[i] > 0.0) || (u[i] >= hi[i] && grad[i] < 0.0));
        }
        let mut accepted = false;
        for attempt in 0..2 {
            if attempt == 1 {
                if memory.is_empty() {
                    break;
                }
                memory.clear();
            }
            direction(&grad, &free, &memory, &mut d);
            let slope = dot(&grad, &d);
            if slope.is_nan() || slope >= 0.0 {
                continue;
            }
            // weak Wolfe conditions by bracketing: sufficient decrease, and enough rise of
            // the slope along the step that the pair (s, y) carries curvature
            let (mut t, mut lower, mut upper) = (1.0, 0.0f64, f64::INFINITY);
            for _ in 0..40 {
                fill(&mut trial, |i| (u[i] + t * d[i]).clamp(lo[i], hi[i]));
                fill(&mut step, |i| trial[i] - u[i]);
                let decrease = dot(&grad, &step);
                if decrease.is_nan() || decrease >= 0.0 {
                    break;
                }
                let f_trial = objective.eval(&trial, &mut trial_grad);
                if f_trial.is_nan() || f_trial > f + ARMIJO * decrease {
                    upper = t;
                } else if dot(&trial_grad, &step) < WOLFE * decrease && !objective.done() {
                    lower = t;
                } else {
                    let y: Vec<f64> = trial_grad.iter().zip(&grad).map(|(a, b)| a - b).collect();
                    let sy = dot(&step, &y);
                    if sy > 1e-12 * dot(&y, &y).sqrt() * dot(&step, &step).sqrt() {
                        if memory.len() == MEMORY {
                            memory.remove(0);
                        }
                        memory.push((step.clone(), y, 1.0 / sy));
                    }
                    u.copy_from_slice(&trial);
                    grad.copy_from_slice(&trial_grad);
                    f = f_trial;
                    accepted = true;
                    break;
                }
                t = if upper.is_finite() { 0.5 * (lower + upper) } else { 2.0 * lower };
            }
            if !accepted && lower > 0.0 {
                // the decrease held but the slope did not rise enough: take the last point
                // that decreased
                fill(&mut trial, |i| (u[i] + lower * d[i]).clamp(lo[i], hi[i]));
                f = objective.eval(&trial, &mut grad);
                u.copy_from_slice(&trial);
                memory.clear();
                accepted = true;
            }
            if accepted {
                break;
            }
        }
        if !accepted {
            // the last evaluation was a rejected trial: evaluate the current point again so
            // that `done` and the caller see it
            objective.eval(u, &mut grad);
            return Ok(if objective.done() { Stop::Done } else { Stop::Stalled });
        }
        budget.iterations -= 1;
        history.push(f);
        let k = history.len() - 1;
        if k >= STALL_WINDOW && f > (1.0 - STALL_DROP) * history[k - STALL_WINDOW] && !objective.done() {
            return Ok(Stop::Stalled);
        }
    }
}

/// The L-BFGS direction `-H grad` on the `free` variables (zero on the others).
fn direction(grad: &[f64], free: &[bool], memory: &[(Vec<f64>, Vec<f64>, f64)], d: &mut [f64]) {
    let mut q: Vec<f64> = grad.iter().zip(free).map(|(g, &f)| if f { *g } else { 0.0 }).collect();
    let mut alpha = vec![0.0; memory.len()];
    for (k, (s, y, rho)) in memory.iter().enumerate().rev() {
        alpha[k] = rho * dot(s, &q);
        q.iter_mut().zip(y).zip(free).for_each(|((x, yi), &f)| {
            if f {
                *x -= alpha[k] * yi
            }
        });
    }
    let gamma = memory.last().map_or(1.0, |(_, y, rho)| 1.0 / (rho * dot(y, y)));
    q.iter_mut().for_each(|x| *x *= gamma);
    for (k, (s, y, rho)) in memory.iter().enumerate() {
        let beta = rho * dot(y, &q);
        q.iter_mut().zip(s).zip(free).for_each(|((x, si), &f)| {
            if f {
                *x += (alpha[k] - beta) * si
            }
        });
    }
    d.iter_mut().zip(&q).zip(free).for_each(|((di, qi), &f)| *di = if f { -qi } else { 0.0 });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `sum_i c_i r_i^2 / 2` with coupled residuals `r_i`.
    struct Quadratic {
        target: Vec<f64>,
    }

    impl Objective for Quadratic {
        fn eval(&mut self, u: &[f64], grad: &mut [f64]) -> f64 {
            let n = u.len();
            let mut f = 0.0;
            grad.iter_mut().for_each(|g| *g = 0.0);
            for i in 0..n {
                let c = 1.0 + i as f64;
                let r = u[i] - self.target[i] + 0.3 * (u[(i + 1) % n] - u[i]);
                f += 0.5 * c * r * r;
                grad[i] += c * r * 0.7;
                grad[(i + 1) % n] += c * r * 0.3;
            }
            f
        }
        fn done(&self) -> bool {
            false
        }
    }

    #[test]
    fn a_quadratic_is_minimised_within_its_bounds_the_same_on_any_thread_count() {
        let n = 50;
        let target: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() * 2.0).collect();
        let run = |threads| {
            let opts = Options { threads: Some(threads), ..Options::default() };
            let mut q = Quadratic { target: target.clone() };
            let mut u = vec![0.0; n];
            let (lo, hi) = (vec![-1.0; n], vec![1.0; n]);
            let mut budget = Budget { iterations: 500, deadline: None };
            let stop = opts.install(|| minimise(&mut q, &mut u, &lo, &hi, &mut budget, &opts)).unwrap();
            (u, stop, budget.iterations)
        };
        let (u, stop, left) = run(1);
        assert!(u.iter().all(|x| (-1.0..=1.0).contains(x)));
        assert_eq!(stop, Stop::Stalled, "{left}");
        // the bounds are active somewhere (the unconstrained minimum leaves the box)
        assert!(u.iter().any(|x| x.abs() == 1.0));
        assert_eq!(run(2), (u.clone(), stop, left));
        assert_eq!(run(3), (u, stop, left));
    }
}
