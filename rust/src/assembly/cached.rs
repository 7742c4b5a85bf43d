//! A mesh that keeps its topology: re-assembly without the symbolic step, and updates that
//! recompute only what moved (strong locality, paper Sec. 7.1).

use crate::assembly::scatter::{finite_rows, laplacian_values, mass_values};
use crate::sparse::{Csr, Mass};
use crate::assembly::pass::{boundary_mask, Elements};
use crate::element::Request;
use crate::error::{Error, Result};
use crate::assembly::order::Layout;
use crate::mesh::{check_coefficient, check_density, Coefficient, MeshView};
use crate::options::{LaplacianKind, MassKind, Options};
use crate::assembly::pass::{values, values_of, FirstFault, Slots};
use crate::element::{LaplacianValues, Simplex, Tet};
use crate::assembly::pattern::Topology;
use rayon::prelude::*;
use std::ops::Range;

/// One cached operator: its per-element values and its assembled values.
#[derive(Debug, Clone)]
struct Cached<K, T> {
    kind: K,
    per_element: Vec<T>,
    /// CSR data on the topology's pattern, or one value per vertex for lumped masses.
    values: Vec<f64>,
}

/// What an update recomputed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Update {
    /// Vertices whose coordinates changed.
    pub moved_vertices: usize,
    /// Elements around them and elements whose coefficient or density changed
    /// (recomputed once per cached operator).
    pub recomputed_elements: usize,
    /// Rows (vertices) whose values were re-summed.
    pub recomputed_rows: usize,
}

/// A mesh with its topology computed once, and the operators asked for so far.
///
/// [`CachedMesh::update`] moves vertices and refreshes every cached operator by
/// recomputing only the elements around moved vertices and re-summing only the rows of
/// their corners. Rows are always summed over their elements in ascending order, so the
/// result is **bitwise equal** to a fresh assembly of the new geometry.
///
/// ```
/// use tetlap::{CachedMesh, LaplacianKind, Options, Tet, TetView};
/// let points = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
/// let mut mesh = CachedMesh::<Tet>::new(points.clone(), 3, vec![[0, 1, 2, 3], [4, 2, 1, 3]], Options::default())?;
/// let before = mesh.laplacian(LaplacianKind::Dual)?;
/// let mut moved = points.clone();
/// moved[14] = 1.5; // vertex 4 moves
/// let update = mesh.update(&moved)?;
/// assert_eq!(update.moved_vertices, 1);
/// let fresh = tetlap::laplacian(&TetView::new(&moved, 3, &mesh.cells())?,
///                               LaplacianKind::Dual, &Options::default())?;
/// assert_eq!(mesh.laplacian(LaplacianKind::Dual)?, fresh);
/// assert_ne!(before, fresh);
/// # Ok::<(), tetlap::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct CachedMesh<S: Simplex = Tet> {
    /// The mesh in internal order (coordinates kept up to date by updates).
    layout: Layout<S>,
    /// The coordinates in the user's order (kept up to date too: updates compare with them).
    user_points: Vec<f64>,
    /// Internal elements with the barycentric boundary fix.
    boundary: Option<Vec<bool>>,
    opts: Options,
    topology: Topology,
    laplacians: Vec<Cached<LaplacianKind, LaplacianValues<S>>>,
    masses: Vec<Cached<MassKind, S::CornerValues>>,
    /// The coefficient of the Laplacians, in the user's element order.
    coefficient: Option<Stored>,
    /// The density of the masses, in the user's element order.
    density: Option<Vec<f64>>,
}

/// A coefficient owned by a [`CachedMesh`].
#[derive(Debug, Clone, PartialEq)]
enum Stored {
    Scalar(Vec<f64>),
    Tensor(Vec<f64>),
    Constant(Vec<f64>),
}

impl Stored {
    fn new(c: Coefficient) -> Self {
        match c {
            Coefficient::Scalar(v) => Stored::Scalar(v.to_vec()),
            Coefficient::Tensor(v) => Stored::Tensor(v.to_vec()),
            Coefficient::Constant(v) => Stored::Constant(v.to_vec()),
        }
    }

    fn view(&self) -> Coefficient<'_> {
        match self {
            Stored::Scalar(v) => Coefficient::Scalar(v),
            Stored::Tensor(v) => Coefficient::Tensor(v),
            Stored::Constant(v) => Coefficient::Constant(v),
        }
    }
}

/// What [`CachedMesh::change`] changes; each `None` keeps what the mesh has.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Change<'a> {
    /// New coordinates (user order, the mesh's shape, finite).
    pub points: Option<&'a [f64]>,
    /// A new coefficient of the Laplacians (`Some(None)`: none, the plain Laplacians).
    pub coefficient: Option<Option<Coefficient<'a>>>,
    /// A new density of the masses (`Some(None)`: none).
    pub density: Option<Option<&'a [f64]>>,
}

/// The user elements whose values of `per` each differ between `old` and `new` (both of
/// `m` elements, or none: all of them when one is absent), ascending.
fn changed(old: Option<&[f64]>, new: Option<&[f64]>, per: usize, m: usize) -> Vec<u32> {
    match (old, new) {
        (None, None) => vec![],
        (Some(a), Some(b)) => {
            let differ = |t: usize| a[t * per..][..per].iter().zip(&b[t * per..][..per]).any(|(x, y)| x.to_bits() != y.to_bits());
            (0..m).into_par_iter().filter(|&t| differ(t)).map(|t| t as u32).collect()
        }
        _ => (0..m as u32).collect(),
    }
}

/// [`changed`] for coefficients: elements whose values differ, all of them when the form
/// changes (scalar, tensor, constant tensor); no coefficient is a scalar 1 (whose values
/// are the plain ones, bit for bit).
fn changed_coefficient<S: Simplex>(old: Option<Coefficient>, new: Option<Coefficient>, m: usize) -> Vec<u32> {
    let dd = S::MIN_DIM * S::MIN_DIM;
    let ones = |c: &[f64]| (0..m).into_par_iter().filter(|&t| c[t] != 1.0).map(|t| t as u32).collect();
    match (old, new) {
        (Some(Coefficient::Scalar(a)), Some(Coefficient::Scalar(b))) => changed(Some(a), Some(b), 1, m),
        (None, Some(Coefficient::Scalar(c))) | (Some(Coefficient::Scalar(c)), None) => ones(c),
        (Some(Coefficient::Tensor(a)), Some(Coefficient::Tensor(b))) => changed(Some(a), Some(b), dd, m),
        (Some(Coefficient::Constant(a)), Some(Coefficient::Constant(b))) if a == b => vec![],
        (None, None) => vec![],
        _ => (0..m as u32).collect(),
    }
}

impl<S: Simplex> CachedMesh<S> {
    /// Validates the mesh (as [`MeshView::new`]) and computes its topology.
    pub fn new(points: Vec<f64>, dim: usize, cells: Vec<S::Cell>, opts: Options) -> Result<Self> {
        Self::with_vertex_weights(points, dim, cells, None, opts)
    }

    /// [`CachedMesh::new`] with vertex weights for the dual (see [`MeshView::with_vertex_weights`]).
    pub fn with_vertex_weights(
        points: Vec<f64>,
        dim: usize,
        cells: Vec<S::Cell>,
        weights: Option<Vec<f64>>,
        opts: Options,
    ) -> Result<Self> {
        let (layout, topology, boundary) = super::install::<S, _>(&opts, || {
            let mesh = MeshView::<S>::new(&points, dim, &cells)?;
            let mesh = match &weights {
                Some(w) => mesh.with_vertex_weights(w)?,
                None => mesh,
            };
            let (layout, corners) = Layout::with_corners(&mesh, &opts)?;
            let (topology, boundary) = rayon::join(
                || Topology::new::<S>(&layout, corners, &opts),
                || boundary_mask(&layout.mesh(), &opts),
            );
            Ok((layout, topology?, boundary?))
        })?;
        opts.cancelled()?;
        let (laplacians, masses) = (vec![], vec![]);
        let (coefficient, density) = (None, None);
        Ok(CachedMesh { layout, user_points: points, boundary, opts, topology, laplacians, masses, coefficient, density })
    }

    /// The coefficient of the Laplacians (see [`MeshView::with_coefficient`]), if any.
    pub fn coefficient(&self) -> Option<Coefficient<'_>> {
        self.coefficient.as_ref().map(Stored::view)
    }

    /// The density of the masses (see [`MeshView::with_density`]), if any.
    pub fn density(&self) -> Option<&[f64]> {
        self.density.as_deref()
    }

    /// Sets the coefficient of the Laplacians (`None`: the plain ones) and refreshes every
    /// cached operator (see [`CachedMesh::change`]): only the elements whose coefficient
    /// changed are recomputed, no topology.
    ///
    /// ```
    /// use tetlap::{laplacian, CachedMesh, Coefficient, LaplacianKind, Options, Tet, TetView};
    /// let points = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.];
    /// let cells = vec![[0, 1, 2, 3], [4, 2, 1, 3]];
    /// let mut mesh = CachedMesh::<Tet>::new(points.clone(), 3, cells.clone(), Options::default())?;
    /// mesh.laplacian(LaplacianKind::Primal)?;
    /// for c in [[1.0, 4.0], [3.0, 4.0]] {
    ///     // the second tet four times more conductive, then the first three times
    ///     mesh.set_coefficient(Some(Coefficient::Scalar(&c)))?;
    ///     let fresh = TetView::new(&points, 3, &cells)?.with_coefficient(Coefficient::Scalar(&c))?;
    ///     assert_eq!(mesh.laplacian(LaplacianKind::Primal)?, laplacian(&fresh, LaplacianKind::Primal, &Options::default())?);
    /// }
    /// # Ok::<(), tetlap::Error>(())
    /// ```
    pub fn set_coefficient(&mut self, coefficient: Option<Coefficient>) -> Result<Update> {
        self.change(Change { coefficient: Some(coefficient), ..Change::default() })
    }

    /// Sets the density of the masses (`None`: none) and refreshes every cached operator
    /// (see [`CachedMesh::change`]).
    pub fn set_density(&mut self, density: Option<&[f64]>) -> Result<Update> {
        self.change(Change { density: Some(density), ..Change::default() })
    }

    /// Changes the coordinates, the coefficient and the density at once (each `None` of
    /// `change` keeps the mesh's) and refreshes every cached operator: only the elements
    /// around moved vertices and those whose coefficient or density changed (bitwise) are
    /// recomputed, and only the rows of their corners re-summed (beyond an eighth of the
    /// vertices or elements, all of them). No topology is recomputed: the result is
    /// bitwise equal to a fresh assembly of the new mesh. On error (bad input, an element
    /// that became degenerate under [`crate::Degenerate::Raise`], cancellation) nothing
    /// changes.
    pub fn change(&mut self, change: Change) -> Result<Update> {
        let (m, dim) = (self.layout.cells.len(), self.layout.dim);
        if let Some(Some(c)) = change.coefficient {
            super::install::<S, _>(&self.opts, || check_coefficient::<S>(c, m, dim))?;
        }
        if let Some(Some(d)) = change.density {
            super::install::<S, _>(&self.opts, || check_density::<S>(d, m))?;
        }
        let (moved, coords) = match change.points {
            Some(points) => {
                let moved = self.moved_vertices(points)?;
                let coords: Vec<f64> = moved.iter().flat_map(|&v| &points[v as usize * dim..][..dim]).copied().collect();
                (moved, coords)
            }
            None => (vec![], vec![]),
        };
        let mut elements: Vec<u32> = Vec::new();
        if let Some(c) = change.coefficient {
            elements.extend(changed_coefficient::<S>(self.coefficient(), c, m));
        }
        if let Some(d) = change.density {
            elements.extend(changed(self.density.as_deref(), d, 1, m));
        }
        let internal: Vec<u32> = elements.iter().map(|&t| self.layout.internal_of[t as usize]).collect();
        let old = (self.coefficient.clone(), self.density.clone());
        if let Some(c) = change.coefficient {
            self.coefficient = c.map(Stored::new);
        }
        if let Some(d) = change.density {
            self.density = d.map(<[f64]>::to_vec);
        }
        let result = self.move_vertices_and(&moved, &coords, &internal);
        if result.is_err() {
            (self.coefficient, self.density) = old;
        }
        result
    }

    /// The current coordinates in the user's order, row-major `(n, dim)` (a copy).
    pub fn points(&self) -> Vec<f64> {
        self.user_points.clone()
    }

    /// The elements in the user's order and numbering (a copy).
    pub fn cells(&self) -> Vec<S::Cell> {
        let mut out = vec![S::Cell::default(); self.layout.cells.len()];
        for (cell, &t) in self.layout.cells.iter().zip(&self.layout.element_of) {
            let mut user = *cell;
            for v in user.as_mut() {
                *v = self.layout.vertex_of[*v as usize];
            }
            out[t as usize] = user;
        }
        out
    }

    /// Number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.layout.n_vertices()
    }

    /// Ambient dimension.
    pub fn dim(&self) -> usize {
        self.layout.dim
    }

    /// The options the mesh was built with.
    pub fn options(&self) -> &Options {
        &self.opts
    }

    /// Sets (or clears) the cancel flag that the following calls poll (see
    /// [`Options::cancel`]).
    pub fn set_cancel(&mut self, cancel: Option<crate::Cancel>) {
        self.opts.cancel = cancel;
    }

    /// The cached topology (CSR pattern and slot map).
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    fn elements(&self) -> Elements<'_, S> {
        let boundary = self.boundary.as_deref().map(std::borrow::Cow::Borrowed);
        Elements::internal(self.layout.mesh(), &self.layout.element_of, boundary).with(self.coefficient(), self.density())
    }

    /// CSR data of the Laplacian of `kind` on [`CachedMesh::topology`]'s pattern, if it is
    /// cached.
    pub fn cached_laplacian_values(&self, kind: LaplacianKind) -> Option<&[f64]> {
        self.laplacians.iter().find(|c| c.kind == kind).map(|c| &c.values[..])
    }

    /// CSR data of the Laplacian of `kind` on [`CachedMesh::topology`]'s pattern (computed
    /// on first use, then kept up to date by [`CachedMesh::update`]).
    pub fn laplacian_values(&mut self, kind: LaplacianKind) -> Result<&[f64]> {
        let kind = kind.check()?;
        if let Some(index) = self.laplacians.iter().position(|c| c.kind == kind) {
            return Ok(&self.laplacians[index].values);
        }
        let (elements, topo, opts) = (self.elements(), &self.topology, &self.opts);
        let cached = super::install::<S, _>(opts, || {
            let m = self.layout.cells.len();
            let (mut w, mut d) = (vec![Default::default(); m], vec![Default::default(); m]);
            let out = Slots { w: Some(&mut w), d: Some(&mut d), m: None };
            values(&elements, opts, Request { laplacian: Some(kind), mass: None }, out)?;
            let w: Vec<_> = w.into_iter().zip(d).collect();
            let values = laplacian_values::<S>(topo, &w, None, vec![0.0; topo.nnz()], opts)?;
            finite_rows(topo.indptr(), &values)?;
            Ok(Cached { kind, per_element: w, values })
        })?;
        self.laplacians.push(cached);
        Ok(&self.laplacians.last().expect("just pushed").values)
    }

    /// The Laplacian of `kind` as a CSR matrix (a copy of the cached values).
    pub fn laplacian(&mut self, kind: LaplacianKind) -> Result<Csr> {
        let values = self.laplacian_values(kind)?.to_vec();
        Ok(self.topology.to_csr(values))
    }

    /// Values of the mass of `kind`, if cached (see [`CachedMesh::mass_values`]).
    pub fn cached_mass_values(&self, kind: MassKind) -> Option<&[f64]> {
        self.masses.iter().find(|c| c.kind == kind).map(|c| &c.values[..])
    }

    /// Values of the mass of `kind`: one per vertex for lumped kinds, CSR data on the
    /// pattern for [`MassKind::Fem`].
    pub fn mass_values(&mut self, kind: MassKind) -> Result<&[f64]> {
        if let Some(index) = self.masses.iter().position(|c| c.kind == kind) {
            return Ok(&self.masses[index].values);
        }
        let (elements, topo, opts) = (self.elements(), &self.topology, &self.opts);
        let cached = super::install::<S, _>(opts, || {
            let mut m = vec![S::CornerValues::default(); self.layout.cells.len()];
            values(&elements, opts, Request { laplacian: None, mass: Some(kind) }, Slots { w: None, d: None, m: Some(&mut m) })?;
            let values = mass_values::<S>(topo, kind, &m, None, vec![], opts)?;
            match kind {
                MassKind::Fem => finite_rows(topo.indptr(), &values)?,
                _ => finite_vertices(&values)?,
            }
            Ok(Cached { kind, per_element: m, values })
        })?;
        self.masses.push(cached);
        Ok(&self.masses.last().expect("just pushed").values)
    }

    /// The mass of `kind` (a copy of the cached values).
    pub fn mass(&mut self, kind: MassKind) -> Result<Mass> {
        let values = self.mass_values(kind)?.to_vec();
        Ok(match kind {
            MassKind::Fem => Mass::Consistent(self.topology.to_csr(values)),
            _ => Mass::Lumped(values),
        })
    }

    /// Moves the vertices to `points` (user order, same shape, finite) and refreshes every
    /// cached operator (see [`CachedMesh::move_vertices`]).
    pub fn update(&mut self, points: &[f64]) -> Result<Update> {
        self.change(Change { points: Some(points), ..Change::default() })
    }

    /// The (user) vertices whose coordinates differ in `points` (same shape as the mesh's),
    /// ascending.
    pub fn moved_vertices(&self, points: &[f64]) -> Result<Vec<u32>> {
        let (dim, current) = (self.layout.dim, &self.user_points);
        if points.len() != current.len() {
            return Err(Error::Shape {
                what: format!(
                    "the new points have {} coordinates, the mesh has {} ({} x {dim})",
                    points.len(),
                    current.len(),
                    current.len() / dim,
                ),
            });
        }
        // blocks of vertices compared at once, then vertex by vertex where they differ
        const BLOCK: usize = 4096;
        let current = &self.user_points;
        super::install::<S, _>(&self.opts, || {
            Ok(points
                .par_chunks(BLOCK * dim)
                .zip(current.par_chunks(BLOCK * dim))
                .enumerate()
                .flat_map_iter(|(b, (new, old))| {
                    let mut moved = Vec::new();
                    if new != old {
                        let pairs = new.chunks_exact(dim).zip(old.chunks_exact(dim));
                        moved.extend(pairs.enumerate().filter(|(_, (p, q))| p != q).map(|(k, _)| (b * BLOCK + k) as u32));
                    }
                    moved
                })
                .collect())
        })
    }

    /// Moves the (user) vertices `moved` (ascending, distinct) to `coords` (`dim` values
    /// each) and refreshes every cached operator: only the elements around them are
    /// recomputed and only the rows of those elements' corners re-summed (beyond an eighth
    /// of the vertices, all of them, in parallel). Degeneracy is checked by the cached
    /// operators (with none cached yet, by the next request). On error (an element became
    /// degenerate under [`crate::Degenerate::Raise`], a non-finite coordinate, a bad vertex
    /// list, cancellation) nothing changes.
    pub fn move_vertices(&mut self, moved: &[u32], coords: &[f64]) -> Result<Update> {
        self.move_vertices_and(moved, coords, &[])
    }

    /// [`CachedMesh::move_vertices`], recomputing also the internal elements `elements`
    /// (whose coefficient or density changed).
    fn move_vertices_and(&mut self, moved: &[u32], coords: &[f64], elements: &[u32]) -> Result<Update> {
        let (dim, n) = (self.layout.dim, self.n_vertices());
        if coords.len() != moved.len() * dim {
            return Err(Error::Shape {
                what: format!("{} coordinates for {} vertices of dimension {dim}", coords.len(), moved.len()),
            });
        }
        let bad = |k: usize| moved[k] as usize >= n || (k > 0 && moved[k - 1] >= moved[k]);
        if let Some(position) = (0..moved.len()).find(|&k| bad(k)) {
            return Err(Error::VertexList { position, vertex: moved[position], n_vertices: n });
        }
        if let Some(k) = coords.iter().position(|x| !x.is_finite()) {
            let (vertex, coordinate) = (moved[k / dim] as usize, k % dim);
            return Err(Error::NonFiniteCoordinate { vertex, coordinate, value: coords[k] });
        }
        // Patch the coordinates in place, remembering the old ones to undo a failure.
        let internal: Vec<u32> = moved.iter().map(|&u| self.layout.rank[u as usize]).collect();
        let span = |v: u32| v as usize * dim..(v as usize + 1) * dim;
        let old: Vec<f64> = internal.iter().flat_map(|&v| &self.layout.points[span(v)]).copied().collect();
        let write = |points: &mut [f64], values: &[f64]| {
            for (&v, c) in internal.iter().zip(values.chunks_exact(dim)) {
                points[span(v)].copy_from_slice(c);
            }
        };
        let write_user = |points: &mut [f64], values: &[f64]| {
            for (&u, c) in moved.iter().zip(values.chunks_exact(dim)) {
                points[span(u)].copy_from_slice(c);
            }
        };
        write(&mut self.layout.points, coords);
        write_user(&mut self.user_points, coords);
        let result = self.refresh(&internal, elements);
        if result.is_err() {
            write(&mut self.layout.points, &old);
            write_user(&mut self.user_points, &old);
        }
        result
    }

    /// Recomputes the cached operators after the internal vertices `moved` and the
    /// coefficients or densities of the internal elements `elements` changed (in place).
    fn refresh(&mut self, moved: &[u32], elements: &[u32]) -> Result<Update> {
        let (n, m) = (self.n_vertices(), self.layout.cells.len());
        if self.laplacians.is_empty() && self.masses.is_empty() {
            // nothing cached yet: the next request assembles from the new mesh
            return Ok(Update { moved_vertices: moved.len(), ..Update::default() });
        }
        let k = S::CORNERS;
        let full = moved.len() > n / 8 || elements.len() > m / 8;
        let topo = &self.topology;
        let (mut listed, mut rows) = (Vec::new(), Vec::new());
        if !full {
            listed = moved.iter().flat_map(|&v| topo.corners.of(v as usize)).map(|&q| q / k as u32).collect();
            listed.extend_from_slice(elements);
            listed.sort_unstable();
            listed.dedup();
            rows = listed.iter().flat_map(|&t| self.layout.cells[t as usize].as_ref().to_vec()).collect();
            rows.sort_unstable();
            rows.dedup();
        }
        let new = self.elements();
        let opts = &self.opts;
        let (laplacians, masses) =
            super::install::<S, _>(opts, || self.recompute(&new, (!full).then_some(&listed[..])))?;
        // Nothing failed: commit, keeping what is overwritten so that a sum that overflows
        // can be undone. (The sums run without the cancel flag: a commit is not cut short.)
        let (topo, all) = (&self.topology, (!full).then_some(&rows[..]));
        let only = (!full).then_some(&listed[..]);
        let commit_opts = Options { cancel: None, ..self.opts.clone() };
        let spans: Vec<std::ops::Range<usize>> = rows
            .iter()
            .map(|&v| {
                let u = topo.vertex_of()[v as usize] as usize;
                topo.indptr()[u]..topo.indptr()[u + 1]
            })
            .collect();
        let vertex_spans: Vec<std::ops::Range<usize>> =
            rows.iter().map(|&v| topo.vertex_of()[v as usize] as usize).map(|u| u..u + 1).collect();
        let mut undo_l = Vec::new();
        let mut undo_m = Vec::new();
        let result = super::install::<S, _>(&commit_opts, || {
            for (cached, new) in self.laplacians.iter_mut().zip(laplacians) {
                undo_l.push(Saved::take(cached, only, &spans));
                commit(&mut cached.per_element, only, new);
                let values = std::mem::take(&mut cached.values);
                cached.values = laplacian_values::<S>(topo, &cached.per_element, all, values, &commit_opts)?;
                check_rows(topo, &cached.values, full, &spans)?;
            }
            for (cached, new) in self.masses.iter_mut().zip(masses) {
                let spans = if cached.kind == MassKind::Fem { &spans } else { &vertex_spans };
                undo_m.push((Saved::take(cached, only, spans), spans));
                commit(&mut cached.per_element, only, new);
                let values = std::mem::take(&mut cached.values);
                cached.values = mass_values::<S>(topo, cached.kind, &cached.per_element, all, values, &commit_opts)?;
                match cached.kind {
                    MassKind::Fem => check_rows(topo, &cached.values, full, spans)?,
                    _ => finite_vertices(&cached.values)?,
                }
            }
            Ok(())
        });
        if let Err(e) = result {
            for (cached, saved) in self.laplacians.iter_mut().zip(undo_l) {
                saved.restore(cached, only, &spans);
            }
            for (cached, (saved, spans)) in self.masses.iter_mut().zip(undo_m) {
                saved.restore(cached, only, spans);
            }
            return Err(e);
        }
        Ok(Update {
            moved_vertices: moved.len(),
            recomputed_elements: if full { self.layout.cells.len() } else { listed.len() },
            recomputed_rows: if full { n } else { rows.len() },
        })
    }

    /// Per-element values of every cached operator for the `listed` elements (all of them
    /// when `None`), each element evaluated once per pair of a cached Laplacian and a cached
    /// mass (their shared dual computed once).
    #[allow(clippy::type_complexity)]
    fn recompute(
        &self,
        elements: &Elements<S>,
        listed: Option<&[u32]>,
    ) -> Result<(Vec<Vec<LaplacianValues<S>>>, Vec<Vec<S::CornerValues>>)> {
        let count = listed.map_or(self.layout.cells.len(), <[u32]>::len);
        let laplacian = || (vec![Default::default(); count], vec![Default::default(); count]);
        let mut l_new: Vec<(Vec<S::EdgeValues>, Vec<S::CornerValues>)> = self.laplacians.iter().map(|_| laplacian()).collect();
        let mut m_new: Vec<Vec<S::CornerValues>> = self.masses.iter().map(|_| vec![Default::default(); count]).collect();
        let mut first = FirstFault::default();
        let (mut ls, mut ms) = (l_new.iter_mut(), m_new.iter_mut());
        for i in 0..self.laplacians.len().max(self.masses.len()) {
            let (l, m) = (self.laplacians.get(i), self.masses.get(i));
            let request = Request { laplacian: l.map(|c| c.kind), mass: m.map(|c| c.kind) };
            let (w, d) = match l.and(ls.next()) {
                Some((w, d)) => (Some(&mut w[..]), Some(&mut d[..])),
                None => (None, None),
            };
            let out = Slots { w, d, m: m.and(ms.next()).map(|v| &mut v[..]) };
            first.merge(values_of(elements, &self.opts, listed, request, out)?);
        }
        first.check(self.opts.degenerate)?;
        Ok((l_new.into_iter().map(|(w, d)| w.into_iter().zip(d).collect()).collect(), m_new))
    }
}

/// What a commit overwrites in one cached operator: everything (a full refresh: moved out,
/// not copied) or the listed elements' values and the data of the recomputed rows.
enum Saved<T> {
    Full(Vec<T>, Vec<f64>),
    Partial(Vec<T>, Vec<f64>),
}

impl<T: Copy> Saved<T> {
    /// Takes (full) or copies (partial) what committing `listed` overwrites in `cached`.
    fn take<K>(cached: &mut Cached<K, T>, listed: Option<&[u32]>, spans: &[Range<usize>]) -> Self {
        match listed {
            None => Saved::Full(std::mem::take(&mut cached.per_element), std::mem::take(&mut cached.values)),
            Some(listed) => Saved::Partial(
                listed.iter().map(|&t| cached.per_element[t as usize]).collect(),
                spans.iter().flat_map(|r| cached.values[r.clone()].iter().copied()).collect(),
            ),
        }
    }

    /// Puts back what [`Saved::take`] saved.
    fn restore<K>(self, cached: &mut Cached<K, T>, listed: Option<&[u32]>, spans: &[Range<usize>]) {
        match self {
            Saved::Full(per_element, values) => {
                cached.per_element = per_element;
                cached.values = values;
            }
            Saved::Partial(per_element, values) => {
                for (&t, v) in listed.unwrap_or_default().iter().zip(per_element) {
                    cached.per_element[t as usize] = v;
                }
                let slots = spans.iter().flat_map(|r| r.clone());
                for (k, v) in slots.zip(values) {
                    cached.values[k] = v;
                }
            }
        }
    }
}

/// [`Error::SumOverflow`] for the first recomputed row with a value that is not finite.
fn check_rows(topo: &Topology, values: &[f64], full: bool, spans: &[std::ops::Range<usize>]) -> Result<()> {
    if full {
        return finite_rows(topo.indptr(), values);
    }
    for span in spans {
        if values[span.clone()].iter().any(|x| !x.is_finite()) {
            let vertex = topo.indptr().partition_point(|&p| p <= span.start) - 1;
            return Err(Error::SumOverflow { vertex });
        }
    }
    Ok(())
}

/// [`Error::SumOverflow`] for the first vertex whose lumped mass is not finite.
fn finite_vertices(values: &[f64]) -> Result<()> {
    match values.iter().position(|x| !x.is_finite()) {
        Some(vertex) => Err(Error::SumOverflow { vertex }),
        None => Ok(()),
    }
}



/// Stores new per-element values: all of them (`listed = None`) or those of the listed
/// elements.
fn commit<T: Copy>(per_element: &mut Vec<T>, listed: Option<&[u32]>, new: Vec<T>) {
    match listed {
        None => *per_element = new,
        Some(listed) => {
            for (&t, v) in listed.iter().zip(new) {
                per_element[t as usize] = v;
            }
        }
    }
}
