//! The parallel per-element pass: every element writes its own output slot (so the result
//! does not depend on the scheduling), faults are collected as the faulty element with the
//! lowest user index, and the cancel flag is polled between chunks.

use crate::element::metric::Metric;
use crate::element::tet::batch::LANES;
use crate::element::{Element, Fault, Request, Scales, Simplex};
use crate::error::{Error, Result};
use crate::mesh::{Coefficient, MeshView};
use crate::options::{Boundary, Degenerate, Options};
use crate::topology::boundary_elements;
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::Mutex;

/// The elements of a mesh as [`Element`]s, with the boundary mask the options ask for.
pub(crate) struct Elements<'a, S: Simplex> {
    mesh: MeshView<'a, S>,
    boundary: Option<Cow<'a, [bool]>>,
    /// The user's index of every element of `mesh` (`None`: the same order).
    element_of: Option<&'a [u32]>,
    /// The coefficient of the Laplacians, in the user's element order.
    coefficient: Option<Prepared<'a, S::Tensor>>,
    /// The density of the masses, in the user's element order.
    density: Option<&'a [f64]>,
}

/// A coefficient as the elements take it: a constant tensor factored once.
#[derive(Clone, Copy)]
enum Prepared<'a, T> {
    Scalar(&'a [f64]),
    Tensor(&'a [f64]),
    Constant(T),
}

/// Which elements get the barycentric boundary fix, if the options ask for it.
pub(crate) fn boundary_mask<S: Simplex>(mesh: &MeshView<S>, opts: &Options) -> Result<Option<Vec<bool>>> {
    if opts.boundary != Boundary::Barycentric {
        return Ok(None);
    }
    boundary_elements::<S>(mesh.cells(), mesh.n_vertices(), opts).map(Some)
}

impl<'a, S: Simplex> Elements<'a, S> {
    /// The elements of a mesh in the user's order.
    pub fn new(mesh: MeshView<'a, S>, opts: &Options) -> Result<Self> {
        let elements = Elements {
            mesh,
            boundary: boundary_mask(&mesh, opts)?.map(Cow::Owned),
            element_of: None,
            coefficient: None,
            density: None,
        };
        Ok(elements.with(mesh.coefficient(), mesh.density()))
    }

    /// The elements of an internal mesh whose element `t` is the user's `element_of[t]`,
    /// with a boundary mask computed before (see [`boundary_mask`]).
    pub fn internal(mesh: MeshView<'a, S>, element_of: &'a [u32], boundary: Option<Cow<'a, [bool]>>) -> Self {
        Elements { mesh, boundary, element_of: Some(element_of), coefficient: None, density: None }
    }

    /// The same elements with a coefficient and a density in the user's element order
    /// (checked before: [`MeshView::with_coefficient`], [`MeshView::with_density`]).
    pub fn with(mut self, coefficient: Option<Coefficient<'a>>, density: Option<&'a [f64]>) -> Self {
        self.coefficient = coefficient.map(|c| match c {
            Coefficient::Scalar(v) => Prepared::Scalar(v),
            Coefficient::Tensor(v) => Prepared::Tensor(v),
            Coefficient::Constant(k) => Prepared::Constant(S::tensor_unchecked(k)),
        });
        self.density = density;
        self
    }

    /// The coefficient of the element with user index `u`.
    #[inline]
    fn metric(&self, u: usize) -> Option<Metric<S::Tensor>> {
        let dd = S::MIN_DIM * S::MIN_DIM;
        self.coefficient.map(|c| match c {
            Prepared::Scalar(v) => Metric::Scalar(v[u]),
            Prepared::Tensor(v) => Metric::Tensor(S::tensor_unchecked(&v[u * dd..][..dd])),
            Prepared::Constant(k) => Metric::Tensor(k),
        })
    }

    /// The user's index of element `t`.
    #[inline]
    pub fn user_index(&self, t: usize) -> usize {
        self.element_of.map_or(t, |e| e[t] as usize)
    }

    pub fn scratch_len(&self) -> usize {
        S::scratch_len(self.mesh.dim())
    }

    /// Element `t` (`scratch`: [`Elements::scratch_len`] values).
    pub fn get(&self, t: usize, scratch: &mut [f64]) -> Element<'a, S> {
        let local = self.mesh.local(t, scratch);
        let cell = self.mesh.cells()[t];
        let vertex_weights = self.mesh.vertex_weights().map(|w| {
            let mut corner = S::CornerValues::default();
            for (out, &v) in corner.as_mut().iter_mut().zip(cell.as_ref()) {
                *out = w[v as usize];
            }
            corner
        });
        let fix_boundary = self.boundary.as_ref().is_some_and(|b| b[t]);
        let u = self.user_index(t);
        Element::new(local, self.mesh.points(), self.mesh.dim(), cell, vertex_weights, fix_boundary)
            .with(self.metric(u), self.density.map(|d| d[u]))
    }
}

impl<S: Simplex> Elements<'_, S> {
    /// Evaluates `request` on `count` elements, the `k`-th being element `t_of(k)`: its
    /// values into slot `k` of `out` (the default for an element that fails), its fault
    /// into `faults`. Groups of [`LANES`] elements go through the vectorised kernels
    /// ([`Simplex::at_once`]), those they leave through the batched precise path
    /// ([`Simplex::precise_at_once`]), the rest through [`Element`]: the same values, bit
    /// for bit, by any route.
    pub fn evaluate(
        &self,
        count: usize,
        t_of: impl Fn(usize) -> usize,
        request: Request,
        out: Slots<'_, S>,
        scratch: &mut [f64],
        faults: &mut FirstFault,
    ) {
        let Slots { mut w, mut d, mut m } = out;
        let (points, dim, cells) = (self.mesh.points(), self.mesh.dim(), self.mesh.cells());
        let batched = self.mesh.vertex_weights().is_none() && request.batched();
        // the elements' coefficients and densities in the order of this call, gathered at
        // once (the elements come in the internal order, the values in the user's: loads
        // that overlap, instead of one cache miss per element in the kernels' loop)
        let gather = |v: &[f64], per: usize| -> Vec<f64> {
            let mut out = Vec::with_capacity(count * per);
            (0..count).for_each(|k| out.extend_from_slice(&v[self.user_index(t_of(k)) * per..][..per]));
            out
        };
        let dd = S::MIN_DIM * S::MIN_DIM;
        let coefficients = match self.coefficient {
            Some(Prepared::Scalar(v)) if batched => gather(v, 1),
            Some(Prepared::Tensor(v)) if batched => gather(v, dd),
            _ => Vec::new(),
        };
        let densities = self.density.filter(|_| batched).map(|v| gather(v, 1));
        // the lanes' coefficients and densities
        let scales = |items: &[(usize, usize)]| -> Scales<S::Tensor> {
            let k = |i: usize| items[i.min(items.len() - 1)].0;
            let at = |v: &[f64]| std::array::from_fn(|i| v[k(i)]);
            let (coefficient, tensors) = match self.coefficient {
                None => (None, None),
                Some(Prepared::Scalar(_)) => (Some(at(&coefficients)), None),
                Some(Prepared::Tensor(_)) => {
                    let mut raw = [[0.0; 9]; LANES];
                    for (i, r) in raw.iter_mut().enumerate() {
                        r[..dd].copy_from_slice(&coefficients[k(i) * dd..][..dd]);
                    }
                    (None, Some(S::tensors(&raw).0))
                }
                Some(Prepared::Constant(k)) => (None, Some([k; LANES])),
            };
            Scales { coefficient, tensors, density: densities.as_deref().map(at) }
        };
        let fixed = |t: usize| self.boundary.as_ref().is_some_and(|b| b[t]);
        // the elements no batch computed: (k, t)
        let mut left: Vec<(usize, usize)> = Vec::new();
        let mut store = |k: usize, (wl, dl): &(S::EdgeValues, S::CornerValues), ml: &S::CornerValues| {
            if let Some(w) = w.as_deref_mut() {
                w[k] = *wl;
            }
            if let Some(d) = d.as_deref_mut() {
                d[k] = *dl;
            }
            if let Some(m) = m.as_deref_mut() {
                m[k] = *ml;
            }
        };
        let mut group = |items: &[(usize, usize)], left: &mut Vec<(usize, usize)>, precise: bool| {
            let cells: [S::Cell; LANES] = std::array::from_fn(|i| cells[items[i.min(items.len() - 1)].1]);
            let mut wl = [S::EdgeValues::default(); LANES];
            let mut dl = [S::CornerValues::default(); LANES];
            let mut ml = [S::CornerValues::default(); LANES];
            let cells = &cells[..items.len()];
            let out = (&mut wl[..], &mut dl[..], &mut ml[..]);
            let done = match precise {
                false => S::at_once(points, dim, cells, request, &scales(items), out),
                true => S::precise_at_once(points, dim, cells, request, &scales(items), out),
            };
            for (i, &(k, t)) in items.iter().enumerate() {
                if done[i] && !fixed(t) {
                    store(k, &(wl[i], dl[i]), &ml[i]);
                } else {
                    left.push((k, t));
                }
            }
        };
        if batched {
            let mut first = Vec::new();
            for start in (0..count).step_by(LANES) {
                let len = LANES.min(count - start);
                let items: [(usize, usize); LANES] = std::array::from_fn(|i| (start + i, t_of(start + i.min(len - 1))));
                group(&items[..len], &mut first, false);
            }
            for items in first.chunks(LANES) {
                group(items, &mut left, true);
            }
        } else {
            left = (0..count).map(|k| (k, t_of(k))).collect();
        }
        for (k, t) in left {
            let el = self.get(t, scratch);
            let lap = request.laplacian.map(|kind| el.laplacian(kind));
            let mass = request.mass.map(|kind| el.corner_mass(kind));
            let fault = lap.and_then(|r| r.err()).or(mass.and_then(|r| r.err()));
            if let Some(fault) = fault {
                faults.record(self, t, fault);
            }
            let wl = lap.map(|r| r.unwrap_or_default()).unwrap_or_default();
            let ml = mass.map(|r| r.unwrap_or_default()).unwrap_or_default();
            store(k, &wl, &ml);
        }
    }
}

/// `values` split into `n` chunks of [`CHUNK`] (none when absent).
fn chunks_of<T>(values: Option<&mut [T]>, n: usize) -> Vec<Option<&mut [T]>> {
    match values {
        Some(v) => v.chunks_mut(CHUNK).map(Some).collect(),
        None => (0..n).map(|_| None).collect(),
    }
}

/// Where a pass writes its elements' values, one slot per element (the default for a
/// faulty one), each only if asked for: the Laplacian's edge values `w`, its diagonal
/// entries `d` (needed only where they are not minus the sums of the edge values:
/// [`Simplex::own_diagonal`]), the corner masses `m`.
pub(crate) struct Slots<'s, S: Simplex> {
    pub w: Option<&'s mut [S::EdgeValues]>,
    pub d: Option<&'s mut [S::CornerValues]>,
    pub m: Option<&'s mut [S::CornerValues]>,
}

/// `request` on every element, in parallel chunks: values into `out`; the first fault
/// under the policy.
pub(crate) fn values<S: Simplex>(elements: &Elements<S>, opts: &Options, request: Request, out: Slots<'_, S>) -> Result<()> {
    values_of(elements, opts, None, request, out)?.check(opts.degenerate)
}

/// `request` on the `listed` elements (all of them when `None`), in parallel chunks:
/// values into `out` (one slot per listed element); the faulty elements.
pub(crate) fn values_of<S: Simplex>(
    elements: &Elements<S>,
    opts: &Options,
    listed: Option<&[u32]>,
    request: Request,
    out: Slots<'_, S>,
) -> Result<FirstFault> {
    let count = listed.map_or(elements.mesh.n_elements(), <[u32]>::len);
    let t_of = |k: usize| listed.map_or(k, |l| l[k] as usize);
    values_by(elements, opts, count, t_of, request, out)
}

/// `request` on `count` elements, the `k`-th being element `t_of(k)`, in parallel chunks:
/// values into `out` (one slot per element listed); the faulty elements.
pub(crate) fn values_by<S: Simplex>(
    elements: &Elements<S>,
    opts: &Options,
    count: usize,
    t_of: impl Fn(usize) -> usize + Sync,
    request: Request,
    out: Slots<'_, S>,
) -> Result<FirstFault> {
    let n = count.div_ceil(CHUNK);
    let chunks = chunks_of(out.w, n).into_par_iter().zip(chunks_of(out.d, n)).zip(chunks_of(out.m, n));
    chunked(elements, opts, chunks, |c, ((w, d), m), scratch, faults| {
        let len = CHUNK.min(count - c * CHUNK);
        elements.evaluate(len, |k| t_of(c * CHUNK + k), request, Slots { w, d, m }, scratch, faults);
    })
}

/// Scratch handed to parallel tasks and taken back: a pass allocates one per task running
/// at once (about one per worker), not one per task.
pub(crate) struct Pool<T>(Mutex<Vec<T>>);

impl<T> Pool<T> {
    pub fn new() -> Self {
        Pool(Mutex::new(Vec::new()))
    }

    /// `f` of a scratch from the pool, or of `make()` when none is free.
    pub fn with<R>(&self, make: impl FnOnce() -> T, f: impl FnOnce(&mut T) -> R) -> R {
        let taken = self.0.lock().unwrap_or_else(|e| e.into_inner()).pop();
        let mut scratch = taken.unwrap_or_else(make);
        let result = f(&mut scratch);
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(scratch);
        result
    }
}

/// Elements per work item (and per poll of the cancel flag).
pub(crate) const CHUNK: usize = 2048;

/// The first faulty element seen (lowest user index) with its fault, the first whose
/// fault no policy skips ([`Fault::Overflow`]), and every faulty element (what
/// [`Degenerate::Skip`] drops).
#[derive(Debug, Default, Clone)]
pub(crate) struct FirstFault {
    any: Option<(usize, Fault)>,
    overflow: Option<usize>,
    all: Vec<(usize, Fault)>,
}

/// The lower of two optional `(user index, ...)` records.
fn lowest<T: Copy>(a: Option<(usize, T)>, b: Option<(usize, T)>) -> Option<(usize, T)> {
    match (a, b) {
        (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
        (x, y) => x.or(y),
    }
}

impl FirstFault {
    /// Records element `t` of `elements` as faulty.
    pub fn record<S: Simplex>(&mut self, elements: &Elements<S>, t: usize, fault: Fault) {
        let user = elements.user_index(t);
        let overflow = (fault == Fault::Overflow).then_some(user);
        self.merge(FirstFault { any: Some((user, fault)), overflow, all: vec![(user, fault)] });
    }

    pub fn merge(&mut self, mut other: FirstFault) {
        self.any = lowest(self.any, other.any);
        self.overflow = lowest(self.overflow.map(|u| (u, ())), other.overflow.map(|u| (u, ()))).map(|(u, _)| u);
        self.all.append(&mut other.all);
    }

    /// Every faulty element (user index, ascending, each once) with its fault.
    pub fn all(mut self) -> Vec<(usize, Fault)> {
        self.all.sort_unstable_by_key(|&(u, _)| u);
        self.all.dedup_by_key(|&mut (u, _)| u);
        self.all
    }

    /// The error for the first faulty element under the policy (`Skip`: none, but for an
    /// overflow, which is never skipped).
    pub fn check(&self, degenerate: Degenerate) -> Result<()> {
        if let Some(element) = self.overflow {
            return Err(Error::Overflow { element });
        }
        match self.any {
            Some((element, Fault::Degenerate)) if degenerate == Degenerate::Raise => {
                Err(Error::Degenerate { element })
            }
            Some((element, _)) if degenerate == Degenerate::Raise => Err(Error::NonFiniteResult { element }),
            _ => Ok(()),
        }
    }
}

/// Runs `fill(chunk_index, chunk, scratch, faults)` over `chunks` (one per [`CHUNK`]
/// elements) in parallel; `fill` records its faulty elements. Returns the first faulty
/// element overall, or [`crate::Error::Cancelled`].
pub(crate) fn chunked<S: Simplex, C: Send>(
    elements: &Elements<S>,
    opts: &Options,
    chunks: impl IndexedParallelIterator<Item = C>,
    fill: impl Fn(usize, C, &mut [f64], &mut FirstFault) + Sync,
) -> Result<FirstFault> {
    let first = Mutex::new(FirstFault::default());
    chunks.enumerate().try_for_each_init(
        || vec![0.0; elements.scratch_len()],
        |scratch, (c, chunk)| {
            opts.cancelled()?;
            let mut faults = FirstFault::default();
            fill(c, chunk, scratch, &mut faults);
            if faults.any.is_some() {
                first.lock().unwrap_or_else(|e| e.into_inner()).merge(faults);
            }
            Ok(())
        },
    )?;
    Ok(first.into_inner().unwrap_or_else(|e| e.into_inner()))
}
