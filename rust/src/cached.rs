//! A mesh that keeps its topology: re-assembly without the symbolic step, and updates that
//! recompute only what moved (strong locality, paper Sec. 7.1).

use crate::assemble::{
    check_kind, corner_mass, laplacian_values, mass_values, per_tet, per_tet_subset, run,
    boundary_mask, weights, Degenerate, Element, Elements, Fault, LaplacianKind, MassKind, Source,
    Options,
};
use crate::csr::Csr;
use crate::error::{Error, Result};
use crate::mesh::TetMesh;
use crate::operators::Mass;
use crate::topology::Topology;
use std::sync::atomic::{AtomicUsize, Ordering};
use rayon::prelude::*;

/// One cached operator: its per-tet values and its assembled values.
#[derive(Debug, Clone)]
struct Cached<K, T> {
    kind: K,
    per_tet: Vec<T>,
    /// CSR data on the topology's pattern, or one value per vertex for lumped masses.
    values: Vec<f64>,
}

/// What an update recomputed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Update {
    /// Vertices whose coordinates changed.
    pub moved_vertices: usize,
    /// Tets around them (recomputed once per cached operator).
    pub recomputed_tets: usize,
    /// Rows (vertices) whose values were re-summed.
    pub recomputed_rows: usize,
}

/// A tet mesh with its topology computed once, and the operators asked for so far.
///
/// [`Mesh::update`] moves vertices and refreshes every cached operator by recomputing only
/// the tets around moved vertices and re-summing only the rows of their corners. Rows are
/// always summed over their tets in ascending order, so the result is **bitwise equal** to
/// a fresh assembly of the new geometry.
///
/// ```
/// use tetlap::{LaplacianKind, Mesh, Options};
/// let points = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
/// let mut mesh = Mesh::new(points.clone(), 3, vec![[0, 1, 2, 3], [4, 2, 1, 3]], Options::default())?;
/// let before = mesh.laplacian(LaplacianKind::Dual)?;
/// let mut moved = points.clone();
/// moved[14] = 1.5; // vertex 4 moves
/// let update = mesh.update(&moved)?;
/// assert_eq!(update.moved_vertices, 1);
/// let fresh = tetlap::laplacian(&tetlap::TetMesh::new(&moved, 3, mesh.tets())?,
///                               LaplacianKind::Dual, &Options::default())?;
/// assert_eq!(mesh.laplacian(LaplacianKind::Dual)?, fresh);
/// assert_ne!(before, fresh);
/// # Ok::<(), tetlap::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Mesh {
    points: Vec<f64>,
    dim: usize,
    tets: Vec<[u32; 4]>,
    weights: Option<Vec<f64>>,
    boundary: Option<Vec<bool>>,
    opts: Options,
    topology: Topology,
    laplacians: Vec<Cached<LaplacianKind, [f64; 6]>>,
    masses: Vec<Cached<MassKind, [f64; 4]>>,
}

impl Mesh {
    /// Validates the mesh (as [`TetMesh::new`]) and computes its topology.
    pub fn new(points: Vec<f64>, dim: usize, tets: Vec<[u32; 4]>, opts: Options) -> Result<Self> {
        Self::with_weights(points, dim, tets, None, opts)
    }

    /// [`Mesh::new`] with vertex weights for the dual (see [`TetMesh::with_weights`]).
    pub fn with_weights(
        points: Vec<f64>,
        dim: usize,
        tets: Vec<[u32; 4]>,
        weights: Option<Vec<f64>>,
        opts: Options,
    ) -> Result<Self> {
        let mesh = TetMesh::new(&points, dim, &tets)?;
        if let Some(w) = &weights {
            mesh.with_weights(w)?;
        }
        let (topology, boundary) = run(opts.threads, || {
            rayon::join(|| Topology::new(&tets, points.len() / dim), || boundary_mask(&mesh, &opts))
        })?;
        let topology = topology?;
        let (laplacians, masses) = (vec![], vec![]);
        Ok(Mesh { points, dim, tets, weights, boundary, opts, topology, laplacians, masses })
    }

    /// The current coordinates, row-major `(n, dim)`.
    pub fn points(&self) -> &[f64] {
        &self.points
    }

    /// The tets.
    pub fn tets(&self) -> &[[u32; 4]] {
        &self.tets
    }

    /// Ambient dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The cached topology (CSR pattern and slot map).
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    fn elements<'a>(&'a self, points: &'a [f64]) -> Elements<'a> {
        let mesh = TetMesh::trusted(points, self.dim, &self.tets, self.weights.as_deref());
        Elements::with_mask(mesh, self.boundary.as_deref())
    }

    /// CSR data of the Laplacian of `kind` on [`Mesh::topology`]'s pattern (computed on
    /// first use, then kept up to date by [`Mesh::update`]).
    pub fn laplacian_values(&mut self, kind: LaplacianKind) -> Result<&[f64]> {
        check_kind(kind)?;
        let index = match self.laplacians.iter().position(|c| c.kind == kind) {
            Some(index) => index,
            None => {
                let (elements, topo, opts) = (self.elements(&self.points), &self.topology, self.opts);
                let cached = run(opts.threads, || -> Result<_> {
                    let mut w = vec![[0.0; 6]; self.tets.len()];
                    per_tet(&elements, opts.degenerate, &mut w, |t| weights(t, kind))?;
                    let values = laplacian_values(topo, &w, None, vec![0.0; topo.nnz()]);
                    Ok(Cached { kind, per_tet: w, values })
                })??;
                self.laplacians.push(cached);
                self.laplacians.len() - 1
            }
        };
        Ok(&self.laplacians[index].values)
    }

    /// The Laplacian of `kind` as a CSR matrix (a copy of the cached values).
    pub fn laplacian(&mut self, kind: LaplacianKind) -> Result<Csr> {
        let values = self.laplacian_values(kind)?.to_vec();
        Ok(self.topology.to_csr(values))
    }

    /// Values of the mass of `kind`: one per vertex for lumped kinds, CSR data on the
    /// pattern for [`MassKind::Fem`].
    pub fn mass_values(&mut self, kind: MassKind) -> Result<&[f64]> {
        let index = match self.masses.iter().position(|c| c.kind == kind) {
            Some(index) => index,
            None => {
                let (elements, topo, opts) = (self.elements(&self.points), &self.topology, self.opts);
                let cached = run(opts.threads, || -> Result<_> {
                    let mut m = vec![[0.0; 4]; self.tets.len()];
                    per_tet(&elements, opts.degenerate, &mut m, |t| corner_mass(t, kind))?;
                    let values = mass_values(topo, kind, &m, None, vec![]);
                    Ok(Cached { kind, per_tet: m, values })
                })??;
                self.masses.push(cached);
                self.masses.len() - 1
            }
        };
        Ok(&self.masses[index].values)
    }

    /// The mass of `kind` (a copy of the cached values).
    pub fn mass(&mut self, kind: MassKind) -> Result<Mass> {
        let values = self.mass_values(kind)?.to_vec();
        Ok(match kind {
            MassKind::Fem => Mass::Consistent(self.topology.to_csr(values)),
            _ => Mass::Lumped(values),
        })
    }

    /// Moves the vertices to `points` (same shape, finite) and refreshes every cached
    /// operator (see [`Mesh::move_vertices`]).
    pub fn update(&mut self, points: &[f64]) -> Result<Update> {
        let moved = self.moved_vertices(points)?;
        let dim = self.dim;
        let coords: Vec<f64> =
            moved.iter().flat_map(|&v| &points[v as usize * dim..(v as usize + 1) * dim]).copied().collect();
        self.move_vertices(&moved, &coords)
    }

    /// The vertices whose coordinates differ in `points` (same shape as the mesh's).
    pub fn moved_vertices(&self, points: &[f64]) -> Result<Vec<u32>> {
        if points.len() != self.points.len() {
            return Err(Error::Shape {
                message: format!(
                    "the new points have {} coordinates, the mesh has {} ({} x {})",
                    points.len(),
                    self.points.len(),
                    self.points.len() / self.dim,
                    self.dim
                ),
            });
        }
        let dim = self.dim;
        run(self.opts.threads, || {
            (0..self.points.len() / dim)
                .into_par_iter()
                .filter(|&i| self.points[i * dim..(i + 1) * dim] != points[i * dim..(i + 1) * dim])
                .map(|i| i as u32)
                .collect()
        })
    }

    /// Moves the vertices `moved` (ascending, distinct) to `coords` (`dim` values each) and
    /// refreshes every cached operator: only the tets around them are recomputed and only
    /// the rows of those tets' corners re-summed (beyond an eighth of the vertices, all of
    /// them, in parallel). Degeneracy is checked by the cached operators (with none cached
    /// yet, by the next request). On error (a tet became degenerate under
    /// [`crate::Degenerate::Raise`], a non-finite coordinate, bad indices) nothing changes.
    pub fn move_vertices(&mut self, moved: &[u32], coords: &[f64]) -> Result<Update> {
        let (dim, n) = (self.dim, self.points.len() / self.dim);
        if coords.len() != moved.len() * dim {
            return Err(Error::Shape {
                message: format!("{} coordinates for {} vertices of dimension {dim}", coords.len(), moved.len()),
            });
        }
        if let Some(k) = moved.iter().position(|&v| v as usize >= n) {
            let index = moved[k] as i64;
            return Err(Error::IndexOutOfRange { element: k, corner: 0, index, n_vertices: n });
        }
        if moved.windows(2).any(|w| w[0] >= w[1]) {
            return Err(Error::InvalidOption { message: "moved vertices must be ascending and distinct".into() });
        }
        if let Some(k) = coords.iter().position(|x| !x.is_finite()) {
            let (vertex, coordinate) = (moved[k / dim] as usize, k % dim);
            return Err(Error::NonFiniteCoordinate { vertex, coordinate, value: coords[k] });
        }
        // Patch the coordinates in place, remembering the old ones to undo a failure.
        let span = |v: u32| v as usize * dim..(v as usize + 1) * dim;
        let old: Vec<f64> = moved.iter().flat_map(|&v| &self.points[span(v)]).copied().collect();
        let write = |points: &mut [f64], values: &[f64]| {
            for (&v, c) in moved.iter().zip(values.chunks_exact(dim)) {
                points[span(v)].copy_from_slice(c);
            }
        };
        write(&mut self.points, coords);
        let result = self.refresh(moved);
        if result.is_err() {
            write(&mut self.points, &old);
        }
        result
    }

    /// Recomputes the cached operators after `moved` changed (coordinates already in place).
    fn refresh(&mut self, moved: &[u32]) -> Result<Update> {
        let n = self.points.len() / self.dim;
        if self.laplacians.is_empty() && self.masses.is_empty() {
            // nothing cached yet: the next request assembles from the new coordinates
            return Ok(Update { moved_vertices: moved.len(), ..Update::default() });
        }
        let full = moved.len() > n / 8;
        let topo = &self.topology;
        let (mut tets, mut rows) = (Vec::new(), Vec::new());
        if !full {
            tets = moved.iter().flat_map(|&v| topo.corners.of(v as usize)).map(|&k| k / 4).collect();
            tets.sort_unstable();
            tets.dedup();
            rows = tets.iter().flat_map(|&t| self.tets[t as usize]).collect();
            rows.sort_unstable();
            rows.dedup();
        }
        let new = self.elements(&self.points);
        let opts = self.opts;
        let (laplacians, masses) = run(opts.threads, || -> Result<_> {
            if full {
                return self.recompute_all(&new);
            }
            let l = recompute(&new, opts, &tets, &self.laplacians, |t, k| weights(t, k))?;
            let m = recompute(&new, opts, &tets, &self.masses, |t, k| corner_mass(t, k))?;
            Ok((l, m))
        })??;
        // Nothing failed: commit.
        let (topo, all) = (&self.topology, (!full).then_some(&rows[..]));
        let listed = (!full).then_some(&tets[..]);
        run(opts.threads, || {
            for (cached, new) in self.laplacians.iter_mut().zip(laplacians) {
                commit(&mut cached.per_tet, listed, new);
                let values = std::mem::take(&mut cached.values);
                cached.values = laplacian_values(topo, &cached.per_tet, all, values);
            }
            for (cached, new) in self.masses.iter_mut().zip(masses) {
                commit(&mut cached.per_tet, listed, new);
                let values = std::mem::take(&mut cached.values);
                cached.values = mass_values(topo, cached.kind, &cached.per_tet, all, values);
            }
        })?;
        Ok(Update {
            moved_vertices: moved.len(),
            recomputed_tets: if full { self.tets.len() } else { tets.len() },
            recomputed_rows: if full { n } else { rows.len() },
        })
    }
}

impl Mesh {
    /// Per-tet values of every cached operator for all tets, in one pass over the tets
    /// (each tet's frame and dual are computed once for all of them).
    fn recompute_all(&self, elements: &Elements) -> Result<(Vec<Vec<[f64; 6]>>, Vec<Vec<[f64; 4]>>)> {
        let m = self.tets.len();
        let n_chunks = m.div_ceil(CHUNK);
        let mut l_new: Vec<Vec<[f64; 6]>> = self.laplacians.iter().map(|_| vec![[0.0; 6]; m]).collect();
        let mut m_new: Vec<Vec<[f64; 4]>> = self.masses.iter().map(|_| vec![[0.0; 4]; m]).collect();
        let (l_kinds, m_kinds): (Vec<_>, Vec<_>) = (
            self.laplacians.iter().map(|c| c.kind).collect(),
            self.masses.iter().map(|c| c.kind).collect(),
        );
        let first_fault = AtomicUsize::new(usize::MAX);
        // a failing tet keeps the zeros of the fresh buffer (the Skip policy)
        fn store<T>(fault: &AtomicUsize, t: usize, out: &mut [T], k: usize, r: std::result::Result<T, Fault>) {
            match r {
                Ok(v) => out[k] = v,
                Err(_) => {
                    fault.fetch_min(t, Ordering::Relaxed);
                }
            }
        }
        let work = chunked(&mut l_new, n_chunks).into_par_iter().zip(chunked(&mut m_new, n_chunks));
        work.enumerate().for_each_init(
            || vec![0.0; 3 * self.dim],
            |scratch, (c, (mut ls, mut ms))| {
                for k in 0..CHUNK.min(m - c * CHUNK) {
                    let t = c * CHUNK + k;
                    let el = elements.get(t, scratch);
                    for (out, &kind) in ls.iter_mut().zip(&l_kinds) {
                        store(&first_fault, t, out, k, weights(&el, kind));
                    }
                    for (out, &kind) in ms.iter_mut().zip(&m_kinds) {
                        store(&first_fault, t, out, k, corner_mass(&el, kind));
                    }
                }
            },
        );
        let t = first_fault.into_inner();
        if t != usize::MAX && self.opts.degenerate == Degenerate::Raise {
            return Err(elements.fault_error(t));
        }
        Ok((l_new, m_new))
    }
}

/// New per-tet values of every cached operator for the listed tets.
fn recompute<K: Copy + Sync, T: Copy + Default + Send + Sync>(
    elements: &Elements,
    opts: Options,
    tets: &[u32],
    cached: &[Cached<K, T>],
    f: impl Fn(&Element, K) -> std::result::Result<T, Fault> + Sync,
) -> Result<Vec<Vec<T>>> {
    cached.iter().map(|c| per_tet_subset(elements, opts.degenerate, tets, |t| f(t, c.kind))).collect()
}

/// Tets per work item of [`Mesh::recompute_all`].
const CHUNK: usize = 2048;

/// `v`'s chunks of [`CHUNK`] tets, appended to the per-chunk lists.
fn chunked<'a, T>(caches: &'a mut [Vec<T>], n_chunks: usize) -> Vec<Vec<&'a mut [T]>> {
    let mut chunks: Vec<Vec<&mut [T]>> = (0..n_chunks).map(|_| Vec::new()).collect();
    for v in caches.iter_mut() {
        for (c, part) in v.chunks_mut(CHUNK).enumerate() {
            chunks[c].push(part);
        }
    }
    chunks
}

/// Stores new per-tet values: all of them (`tets = None`) or those of the listed tets.
fn commit<T: Copy>(per_tet: &mut Vec<T>, tets: Option<&[u32]>, new: Vec<T>) {
    match tets {
        None => *per_tet = new,
        Some(tets) => {
            for (&t, v) in tets.iter().zip(new) {
                per_tet[t as usize] = v;
            }
        }
    }
}

