//! Keeping the weighted circumcentric masses positive while the faces stay regular.
//!
//! Weights that make the faces regular may move power centres of boundary tets far
//! outside them, and the signed pieces they cut can make a boundary vertex's cell volume
//! (its circumcentric mass) non-positive where the plain one was positive. Rounds of:
//!
//! 1. the vertices whose mass is below `floor` times their positive plain mass join the
//!    *watched* ones; their masses, linearised at the current `u` (exact derivatives: every
//!    tet's reverse derivative, [`Vjp::dual`]), become hinge rows `J_s u >= b_s` aiming a
//!    little above the floor, normalised like the faces' rows (a distance in `u`);
//! 2. the faces' squared shortfall (all rows, kept at half their floors) plus those hinge
//!    rows, minimised from `u` ([`super::hinge`]); when it leaves faces below half their
//!    floors, the faces alone are searched back to them;
//! 3. the step `u -> v` is not taken whole: the linearisation only holds near `u` (a
//!    boundary cell is a signed sum of pieces cut by power centres that move far for small
//!    weights). Power centres are affine in the weights and every piece is a triple product
//!    of three of them, so every mass is a cubic polynomial on the segment, known exactly
//!    from its values at `t = 0, 1/3, 2/3, 1`; the point of [`LINE`] with the fewest masses
//!    lost, then the smallest deficit below the floor, is kept if it improves on `u` (the
//!    faces' margins, affine, keep half their floors on the whole segment, as both ends
//!    do); else the next round is confined to a tenth of the step (a trust region).
//!
//! Masses are those of the operators: each tet by the element's accuracy rule (a tet it
//! refuses contributes nothing, as with `Degenerate::Skip`). Deterministic: per-tet slots
//! gathered per vertex in a fixed order.

use super::hinge::Shortfall;
use super::lbfgs::{minimise, Budget};
use super::search::{hinge_rows, search, Rows, Targets};
use crate::element::frame::LocalTet;
use crate::element::tet::derivatives::Vjp;
use crate::element::{Element, Tet};
use crate::error::{Error, Result};
use crate::mesh::TetView;
use crate::options::{MassKind, Options};
use crate::topology::group::group_by;
use rayon::prelude::*;

/// Rounds of the mass step at most.
pub const ROUNDS: usize = 30;
/// Iterations of one minimisation (with the mass rows, or the faces alone) at most.
pub const PASS_ITERATIONS: usize = 300;
/// The faces of a pass with the mass rows: those with a corner of a watched vertex's tets,
/// and those whose margin is within this of their aim (the others are checked after it).
pub const MASS_ACTIVE: f64 = 0.05;
/// Tets per parallel chunk.
const TETS: usize = 1024;

/// The points `t` of the line search on `[0, 1]`: `2^-k` (the linearised step may only be
/// good very near its start, `k = 1..12`) and a uniform grid of 64 steps.
fn line() -> Vec<f64> {
    let mut t: Vec<f64> = (1..=12).map(|k| 0.5f64.powi(k)).chain((1..=64).map(|k| k as f64 / 64.0)).collect();
    t.sort_by(f64::total_cmp);
    t.dedup();
    t
}

/// What the masses are asked: per vertex its plain circumcentric mass, the relative floor,
/// and the scale from the search's variables to weights (`w = u * scale`).
#[derive(Debug, Clone, Copy)]
pub struct MassTargets<'a> {
    /// The plain circumcentric mass of every vertex (those `<= 0` are not watched).
    pub plain: &'a [f64],
    /// Keep `m_i >= floor * plain_i`, `0 <= floor < 1`.
    pub floor: f64,
    /// `w = u * scale` per vertex.
    pub scale: &'a [f64],
}

/// The result of [`keep_masses`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassOutcome {
    /// Rounds run.
    pub rounds: usize,
    /// Iterations spent.
    pub iterations: usize,
    /// Rounds whose step was kept.
    pub kept: usize,
    /// Positive plain masses that are non-positive at the end.
    pub lost: usize,
    /// Their sum of relative deficits below the floor at the end.
    pub deficit: f64,
}

/// `(lost, deficit)` of masses against positive plain ones, `(m_i, m0_i)`: compared
/// lexicographically (fewer lost first).
fn score(m: impl Iterator<Item = (f64, f64)>, floor: f64) -> (usize, f64) {
    m.fold((0, 0.0), |(lost, deficit), (mi, m0)| (lost + usize::from(mi.is_nan() || mi <= 0.0), deficit + (floor - mi / m0).max(0.0)))
}

fn better(a: (usize, f64), b: (usize, f64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1)
}

/// Tet `t`'s corner masses for weights `w4` by the element's accuracy rule (`None`: refused).
fn corner_masses(mesh: &TetView, t: usize, local: &LocalTet, w4: [f64; 4]) -> Option<[f64; 4]> {
    Element::<Tet>::new(*local, mesh.points(), mesh.dim(), mesh.cells()[t], Some(w4), false).corner_mass(MassKind::Circumcentric).ok()
}

/// The mesh's tets and their corners' incidence, for the masses of every vertex.
struct MassMesh<'a> {
    mesh: &'a TetView<'a>,
    /// Per vertex, its `4 t + corner` records ascending.
    offsets: Vec<usize>,
    records: Vec<u32>,
}

impl<'a> MassMesh<'a> {
    fn new(mesh: &'a TetView<'a>, opts: &Options) -> Result<Self> {
        let cells = mesh.cells();
        let (offsets, records) = group_by(mesh.n_vertices(), 4 * cells.len(), |r| (cells[r / 4][r % 4], r as u32), opts)?;
        Ok(MassMesh { mesh, offsets, records })
    }

    /// The weighted circumcentric mass of every vertex (tets refused by the accuracy rule
    /// contribute nothing), summed per vertex in the order of its tet corners.
    fn masses(&self, weights: &[f64], opts: &Options) -> Result<Vec<f64>> {
        let cells = self.mesh.cells();
        let mut per_tet = vec![[0.0; 4]; cells.len()];
        per_tet.par_chunks_mut(TETS).enumerate().try_for_each_init(
            || vec![0.0; 3],
            |scratch, (c, chunk)| {
                opts.cancelled()?;
                for (k, slot) in chunk.iter_mut().enumerate() {
                    let t = c * TETS + k;
                    let local = self.mesh.local(t, scratch);
                    *slot = corner_masses(self.mesh, t, &local, cells[t].map(|v| weights[v as usize])).unwrap_or([0.0; 4]);
                }
                Ok::<(), Error>(())
            },
        )?;
        Ok((0..self.mesh.n_vertices())
            .into_par_iter()
            .map(|i| self.records[self.offsets[i]..self.offsets[i + 1]].iter().map(|&r| per_tet[r as usize / 4][r as usize % 4]).sum())
            .collect())
    }

    /// `d m_i / d w_j` of vertex `i` at `weights`: `(j, value)` ascending in `j`, summed
    /// over its tets in order (a tet refused by the accuracy rule contributes nothing).
    fn gradient(&self, i: u32, weights: &[f64]) -> Vec<(u32, f64)> {
        let cells = self.mesh.cells();
        let mut scratch = [0.0; 3];
        let mut parts: Vec<(u32, f64)> = vec![];
        for &r in &self.records[self.offsets[i as usize]..self.offsets[i as usize + 1]] {
            let (t, a) = (r as usize / 4, r as usize % 4);
            let local = self.mesh.local(t, &mut scratch);
            let w4 = cells[t].map(|v| weights[v as usize]);
            if corner_masses(self.mesh, t, &local, w4).is_none() {
                continue;
            }
            let s2 = local.scale * local.scale;
            let mut dm = [0.0; 4];
            dm[a] = 1.0;
            let mut vjp = Vjp::new(&local);
            vjp.dual(Some(w4.map(|wi| (wi - w4[0]) / s2)), [0.0; 6], dm);
            parts.extend(cells[t].iter().copied().zip(vjp.finish().weights));
        }
        parts.sort_by_key(|p| p.0);
        let mut merged: Vec<(u32, f64)> = vec![];
        for (j, g) in parts {
            match merged.last_mut() {
                Some(last) if last.0 == j => last.1 += g,
                _ => merged.push((j, g)),
            }
        }
        merged
    }
}

/// The values `m(t)` on [`line`] of the cubics through `m(0), m(1/3), m(2/3), m(1)`.
fn cubic(m: [&[f64]; 4], t: f64) -> impl Fn(usize) -> f64 + '_ {
    // Lagrange basis on the nodes 0, 1/3, 2/3, 1
    let nodes = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0];
    let basis: [f64; 4] = std::array::from_fn(|k| {
        (0..4).filter(|&l| l != k).map(|l| (t - nodes[l]) / (nodes[k] - nodes[l])).product()
    });
    move |i| (0..4).map(|k| basis[k] * m[k][i]).sum()
}

/// Moves `u` (in place; every face row at its floor) so that fewer positive plain masses
/// are lost and fewer fall below `masses.floor` of their plain value, keeping every face
/// row at half its floor at least (module docs). `targets` are the faces' floors (reached
/// by `u`) and aims, and the bounds of `u`.
pub fn keep_masses(
    mesh: &TetView,
    rows: Rows,
    targets: &Targets,
    masses: &MassTargets,
    u: &mut [f64],
    budget: &mut Budget,
    opts: &Options,
) -> Result<MassOutcome> {
    let (n, m) = (mesh.n_vertices(), rows.len());
    if u.len() != n || masses.plain.len() != n || masses.scale.len() != n {
        return Err(Error::Shape { what: format!("keep_masses: {n} vertices expected") });
    }
    if !(0.0..1.0).contains(&masses.floor) {
        return Err(Error::Shape { what: format!("the mass floor must lie in [0, 1), got {}", masses.floor) });
    }
    rows.check(n)?;
    if targets.floor.len() != m || targets.aim.len() != m || targets.lo.len() != n || targets.hi.len() != n {
        return Err(Error::Shape { what: format!("targets: {m} rows and {n} variables expected") });
    }
    opts.install(|| {
        let mm = MassMesh::new(mesh, opts)?;
        let weights = |u: &[f64]| -> Vec<f64> { u.iter().zip(masses.scale).map(|(x, s)| x * s).collect() };
        let positive: Vec<u32> = (0..n as u32).filter(|&i| masses.plain[i as usize] > 0.0).collect();
        let score_of = |m: &dyn Fn(usize) -> f64| {
            score(positive.iter().map(|&i| (m(i as usize), masses.plain[i as usize])), masses.floor)
        };
        let below = |m: &[f64], i: u32| m[i as usize] < masses.floor * masses.plain[i as usize];
        let goal = masses.floor + 0.1 * (1.0 - masses.floor);
        // the faces aim a little above their floors and may give up half of them
        let aim_faces: Vec<f64> = targets.floor.iter().map(|&f| f + 0.1 * f.max(0.0)).collect();
        let half: Vec<f64> = targets.floor.iter().map(|&f| f.min(f / 2.0)).collect();
        let faces_ok = |u: &[f64]| rows.values(u).iter().zip(&half).all(|(g, f)| g >= f);
        let mut full = mm.masses(&weights(u), opts)?;
        let mut current = score_of(&|i| full[i]);
        let mut watched = vec![false; n];
        let mut radius = f64::INFINITY;
        let mut outcome = MassOutcome { rounds: 0, iterations: 0, kept: 0, lost: current.0, deficit: current.1 };
        let points = line();
        for _ in 0..ROUNDS {
            let low: Vec<u32> = positive.iter().copied().filter(|&i| below(&full, i)).collect();
            if low.is_empty() || budget.iterations == 0 || budget.late() {
                break;
            }
            outcome.rounds += 1;
            low.iter().for_each(|&i| watched[i as usize] = true);
            // the watched masses linearised at u, in u units, over their plain mass
            let w = weights(u);
            let linear: Vec<(Vec<(u32, f64)>, f64)> = (0..n as u32)
                .into_par_iter()
                .filter(|&i| watched[i as usize])
                .map(|i| {
                    let m0 = masses.plain[i as usize];
                    let entries: Vec<(u32, f64)> =
                        mm.gradient(i, &w).into_iter().map(|(j, g)| (j, g * masses.scale[j as usize] / m0)).collect();
                    let at_u: f64 = entries.iter().map(|&(j, a)| a * u[j as usize]).sum();
                    (entries, goal - full[i as usize] / m0 + at_u)
                })
                .collect();
            let lo: Vec<f64> = (0..n).map(|j| targets.lo[j].max(u[j] - radius)).collect();
            let hi: Vec<f64> = (0..n).map(|j| targets.hi[j].min(u[j] + radius)).collect();
            // the faces near their aims, and those of the watched vertices' tets' corners:
            // the others are far above and are checked after the pass
            let g = rows.values(u);
            let mut near_watched = vec![false; n];
            for (t, cell) in mesh.cells().iter().enumerate() {
                if cell.iter().any(|&v| watched[v as usize]) {
                    mesh.cells()[t].iter().for_each(|&v| near_watched[v as usize] = true);
                }
            }
            let working = (0..m).filter(|&r| {
                g[r] < aim_faces[r] + MASS_ACTIVE || rows.vertices[r].iter().any(|&j| near_watched[j as usize])
            });
            let faces = Targets { floor: &half, aim: &aim_faces, lo: &lo, hi: &hi };
            let mut hinge = hinge_rows(&rows, &faces, working);
            for (entries, b) in linear {
                hinge.push(entries, 0.0, b, b);
            }
            let hinge = hinge.finish(n);
            let mut v = u.to_vec();
            let mut pass = Budget { iterations: budget.iterations.min(PASS_ITERATIONS), deadline: budget.deadline };
            minimise(&mut Shortfall::new(&hinge), &mut v, &lo, &hi, &mut pass, opts)?;
            let spent = budget.iterations.min(PASS_ITERATIONS) - pass.iterations;
            budget.iterations -= spent;
            outcome.iterations += spent;
            if !faces_ok(&v) {
                // back to half the floors, the faces alone
                let back = Targets { floor: &half, aim: &aim_faces, lo: &lo, hi: &hi };
                let mut pass = Budget { iterations: budget.iterations.min(PASS_ITERATIONS), deadline: budget.deadline };
                let found = search(rows, &back, &mut v, &mut pass, opts)?;
                budget.iterations -= found.iterations;
                outcome.iterations += found.iterations;
            }
            let step = (0..n).fold(0.0f64, |a, j| a.max((v[j] - u[j]).abs()));
            if !faces_ok(&v) || step == 0.0 {
                radius = 0.1 * step;
                continue;
            }
            // the masses on the segment u -> v: cubic, from four points
            let at = |t: f64| -> Vec<f64> { (0..n).map(|j| u[j] + t * (v[j] - u[j])).collect() };
            let m1 = mm.masses(&weights(&at(1.0 / 3.0)), opts)?;
            let m2 = mm.masses(&weights(&at(2.0 / 3.0)), opts)?;
            let m3 = mm.masses(&weights(&v), opts)?;
            let scores: Vec<(usize, f64)> = points
                .par_iter()
                .map(|&t| {
                    let f = cubic([&full, &m1, &m2, &m3], t);
                    score_of(&f)
                })
                .collect();
            let best = (0..points.len()).fold(0, |b, k| if better(scores[k], scores[b]) { k } else { b });
            let t = points[best];
            let u_t = at(t);
            let m_t = if t == 1.0 { m3 } else { mm.masses(&weights(&u_t), opts)? };
            let s_t = score_of(&|i| m_t[i]);
            if faces_ok(&u_t) && better(s_t, current) {
                u.copy_from_slice(&u_t);
                full = m_t;
                current = s_t;
                outcome.kept += 1;
            } else {
                radius = 0.1 * step;
            }
        }
        outcome.lost = current.0;
        outcome.deficit = current.1;
        Ok(outcome)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A jittered k x k x k Kuhn grid: (points, tets), boundary vertices in place.
    pub(crate) fn grid(k: usize, jitter: f64) -> (Vec<f64>, Vec<[u32; 4]>) {
        let id = |i: usize, j: usize, l: usize| (i * (k + 1) * (k + 1) + j * (k + 1) + l) as u32;
        let mut points = vec![];
        let mut state = 12345u64;
        let mut random = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for i in 0..=k {
            for j in 0..=k {
                for l in 0..=k {
                    let inner = [i, j, l].iter().all(|&c| c > 0 && c < k);
                    let d = if inner { jitter } else { 0.0 };
                    points.extend([i as f64 + d * random(), j as f64 + d * random(), l as f64 + d * random()]);
                }
            }
        }
        let mut tets = vec![];
        for i in 0..k {
            for j in 0..k {
                for l in 0..k {
                    let c = |a: usize, b: usize, e: usize| id(i + a, j + b, l + e);
                    let (v0, v7) = (c(0, 0, 0), c(1, 1, 1));
                    for (a, b) in [
                        (c(1, 0, 0), c(1, 1, 0)),
                        (c(1, 0, 0), c(1, 0, 1)),
                        (c(0, 1, 0), c(1, 1, 0)),
                        (c(0, 1, 0), c(0, 1, 1)),
                        (c(0, 0, 1), c(1, 0, 1)),
                        (c(0, 0, 1), c(0, 1, 1)),
                    ] {
                        tets.push([v0, a, b, v7]);
                    }
                }
            }
        }
        (points, tets)
    }

    #[test]
    fn mass_gradients_match_central_differences_and_masses_are_cubic_on_a_segment() {
        let (points, tets) = grid(3, 0.4);
        let mesh = TetView::new(&points, 3, &tets).unwrap();
        let n = mesh.n_vertices();
        let opts = Options::default();
        let mm = MassMesh::new(&mesh, &opts).unwrap();
        let w: Vec<f64> = (0..n).map(|j| 0.02 * ((j as f64) * 0.7).sin()).collect();
        let h = 1e-6;
        for i in [0u32, 21, 42] {
            for (j, g) in mm.gradient(i, &w) {
                let mut up = w.clone();
                up[j as usize] += h;
                let fp = mm.masses(&up, &opts).unwrap()[i as usize];
                up[j as usize] -= 2.0 * h;
                let fm = mm.masses(&up, &opts).unwrap()[i as usize];
                let fd = (fp - fm) / (2.0 * h);
                assert!((fd - g).abs() < 1e-6 * (1.0 + fd.abs()), "vertex {i}, weight {j}: {fd} vs {g}");
            }
        }
        // the cubic through four points of a segment of weights is the masses on all of it
        let v: Vec<f64> = (0..n).map(|j| 0.03 * ((j as f64) * 1.3).cos()).collect();
        let at = |t: f64| -> Vec<f64> { (0..n).map(|j| w[j] + t * (v[j] - w[j])).collect() };
        let m: Vec<Vec<f64>> = [0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0].iter().map(|&t| mm.masses(&at(t), &opts).unwrap()).collect();
        for t in [0.1, 0.5, 0.9] {
            let exact = mm.masses(&at(t), &opts).unwrap();
            let f = cubic([&m[0], &m[1], &m[2], &m[3]], t);
            assert!((0..n).all(|i| (f(i) - exact[i]).abs() < 1e-12), "t = {t}");
        }
    }
}
