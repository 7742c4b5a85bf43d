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
//! The vector work of an iteration is over the *live* variables only, those whose gradient
//! has been non-zero (the others never move): on a mesh whose faces to repair are a few
//! percent, a few percent of the vertices. Every sum over the variables is taken by fixed
//! chunks added in order ([`dot`]), so the iterates are bitwise the same for any thread
//! count.

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
/// Vectors at least this long are summed and filled in parallel (by the same chunks, so
/// the values do not depend on it); shorter ones in one thread, where waking the pool for
/// a few microseconds of work costs more than it saves on a loaded machine.
pub(super) const PARALLEL: usize = 1 << 16;

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
    let part = |(x, y): (&[f64], &[f64])| -> f64 { x.iter().zip(y).map(|(p, q)| p * q).sum() };
    if a.len() <= CHUNK {
        return part((a, b));
    }
    let parts: Vec<f64> = if a.len() < PARALLEL {
        a.chunks(CHUNK).zip(b.chunks(CHUNK)).map(part).collect()
    } else {
        a.par_chunks(CHUNK).zip(b.par_chunks(CHUNK)).map(part).collect()
    };
    parts.iter().sum()
}

/// `out[i] = f(i)`, in parallel by chunks for long vectors.
pub(super) fn fill(out: &mut [f64], f: impl Fn(usize) -> f64 + Sync + Send) {
    if out.len() < PARALLEL {
        out.iter_mut().enumerate().for_each(|(i, x)| *x = f(i));
    } else {
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, chunk)| {
            chunk.iter_mut().enumerate().for_each(|(k, x)| *x = f(c * CHUNK + k));
        });
    }
}

/// The *live* variables: those whose gradient has been non-zero, in the order they became
/// live. Every other variable has had a zero gradient at every point so far, so every
/// L-BFGS direction (a combination of gradients) is zero there and it never moves: the
/// vector work of an iteration is over the live ones only (compact vectors, indexed by
/// position in `order`), not over all of `u`.
struct Live {
    order: Vec<u32>,
    is_live: Vec<bool>,
}

impl Live {
    fn new(n: usize) -> Self {
        Live { order: vec![], is_live: vec![false; n] }
    }

    /// Adds the variables where `grad` is non-zero (or NaN), ascending.
    fn grow(&mut self, grad: &[f64]) {
        for (j, g) in grad.iter().enumerate() {
            if *g != 0.0 && !self.is_live[j] {
                self.is_live[j] = true;
                self.order.push(j as u32);
            }
        }
    }

    /// `x[live]`, compact.
    fn gather(&self, x: &[f64]) -> Vec<f64> {
        self.order.iter().map(|&j| x[j as usize]).collect()
    }
}

/// `sum_p a_p b_p` over the common length (the shorter vector is zero beyond its end), by
/// fixed chunks ([`dot`]).
fn dot_common(a: &[f64], b: &[f64]) -> f64 {
    let k = a.len().min(b.len());
    dot(&a[..k], &b[..k])
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
    let mut live = Live::new(n);
    live.grow(&grad);
    // the pairs (s, y, 1 / s.y), compact over the live variables of their time
    let mut memory: Vec<(Vec<f64>, Vec<f64>, f64)> = Vec::with_capacity(MEMORY);
    let mut history = vec![f];
    let (mut trial, mut trial_grad) = (u.to_vec(), vec![0.0; n]);
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
        let order = live.order.clone();
        let g = live.gather(&grad);
        let free: Vec<bool> = order
            .iter()
            .zip(&g)
            .map(|(&j, &gj)| {
                let j = j as usize;
                !((u[j] <= lo[j] && gj > 0.0) || (u[j] >= hi[j] && gj < 0.0))
            })
            .collect();
        let mut d = vec![0.0; order.len()];
        let mut step = vec![0.0; order.len()];
        let mut accepted = false;
        for attempt in 0..2 {
            if attempt == 1 {
                if memory.is_empty() {
                    break;
                }
                memory.clear();
            }
            direction(&g, &free, &memory, &mut d);
            let slope = dot(&g, &d);
            if slope.is_nan() || slope >= 0.0 {
                continue;
            }
            // weak Wolfe conditions by bracketing: sufficient decrease, and enough rise of
            // the slope along the step that the pair (s, y) carries curvature
            let (mut t, mut lower, mut upper) = (1.0, 0.0f64, f64::INFINITY);
            let moved = |u: &[f64], trial: &mut [f64], step: &mut [f64], t: f64| {
                for (p, &j) in order.iter().enumerate() {
                    let j = j as usize;
                    trial[j] = (u[j] + t * d[p]).clamp(lo[j], hi[j]);
                    step[p] = trial[j] - u[j];
                }
            };
            for _ in 0..40 {
                moved(u, &mut trial, &mut step, t);
                let decrease = dot(&g, &step);
                if decrease.is_nan() || decrease >= 0.0 {
                    break;
                }
                let f_trial = objective.eval(&trial, &mut trial_grad);
                if f_trial.is_nan() || f_trial > f + ARMIJO * decrease {
                    upper = t;
                } else if dot(&live.gather(&trial_grad), &step) < WOLFE * decrease && !objective.done() {
                    lower = t;
                } else {
                    // the pair on the live variables, those the new gradient adds included
                    let known = order.len();
                    live.grow(&trial_grad);
                    let y: Vec<f64> = live.order.iter().map(|&j| trial_grad[j as usize] - grad[j as usize]).collect();
                    step.resize(live.order.len(), 0.0);
                    let sy = dot_common(&step, &y);
                    if sy > 1e-12 * dot(&y, &y).sqrt() * dot(&step, &step).sqrt() {
                        if memory.len() == MEMORY {
                            memory.remove(0);
                        }
                        memory.push((step.clone(), y, 1.0 / sy));
                    }
                    step.truncate(known);
                    u.copy_from_slice(&trial);
                    std::mem::swap(&mut grad, &mut trial_grad);
                    f = f_trial;
                    accepted = true;
                    break;
                }
                t = if upper.is_finite() { 0.5 * (lower + upper) } else { 2.0 * lower };
            }
            if !accepted && lower > 0.0 {
                // the decrease held but the slope did not rise enough: take the last point
                // that decreased
                moved(u, &mut trial, &mut step, lower);
                f = objective.eval(&trial, &mut grad);
                u.copy_from_slice(&trial);
                live.grow(&grad);
                memory.clear();
                accepted = true;
            }
            if accepted {
                break;
            }
        }
        // the trial point is u again where it is not (a rejected trial)
        trial.copy_from_slice(u);
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

/// The L-BFGS direction `-H grad` on the `free` variables (zero on the others), compact
/// over the live variables (`grad`, `free`, `d`); the pairs of `memory` may be shorter
/// (zero beyond their ends: variables that became live after them).
fn direction(grad: &[f64], free: &[bool], memory: &[(Vec<f64>, Vec<f64>, f64)], d: &mut [f64]) {
    let mut q: Vec<f64> = grad.iter().zip(free).map(|(g, &f)| if f { *g } else { 0.0 }).collect();
    let mut alpha = vec![0.0; memory.len()];
    for (k, (s, y, rho)) in memory.iter().enumerate().rev() {
        alpha[k] = rho * dot_common(s, &q);
        q.iter_mut().zip(y).zip(free).for_each(|((x, yi), &f)| {
            if f {
                *x -= alpha[k] * yi
            }
        });
    }
    let gamma = memory.last().map_or(1.0, |(_, y, rho)| 1.0 / (rho * dot(y, y)));
    q.iter_mut().for_each(|x| *x *= gamma);
    for (k, (s, y, rho)) in memory.iter().enumerate() {
        let beta = rho * dot_common(y, &q);
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
