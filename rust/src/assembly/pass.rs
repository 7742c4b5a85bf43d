//! The parallel per-element pass: every element writes its own output slot (so the result
//! does not depend on the scheduling), faults are collected as the faulty element with the
//! lowest user index, and the cancel flag is polled between chunks.

use crate::element::{Element, Fault, Simplex};
use crate::error::{Error, Result};
use crate::mesh::MeshView;
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
        Ok(Elements { mesh, boundary: boundary_mask(&mesh, opts)?.map(Cow::Owned), element_of: None })
    }

    /// The elements of an internal mesh whose element `t` is the user's `element_of[t]`,
    /// with a boundary mask computed before (see [`boundary_mask`]).
    pub fn internal(mesh: MeshView<'a, S>, element_of: &'a [u32], boundary: Option<Cow<'a, [bool]>>) -> Self {
        Elements { mesh, boundary, element_of: Some(element_of) }
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
        Element::new(local, self.mesh.points(), self.mesh.dim(), cell, vertex_weights, fix_boundary)
    }
}

/// Elements per work item (and per poll of the cancel flag).
pub(crate) const CHUNK: usize = 2048;

/// The first faulty element seen (lowest user index) with its fault, and the first whose
/// fault no policy skips ([`Fault::Overflow`]).
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct FirstFault {
    any: Option<(usize, Fault)>,
    overflow: Option<usize>,
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
        let overflow = (fault == Fault::Overflow).then_some((user, ()));
        self.merge(FirstFault { any: Some((user, fault)), overflow: overflow.map(|(u, _)| u) });
    }

    fn merge(&mut self, other: FirstFault) {
        self.any = lowest(self.any, other.any);
        self.overflow = lowest(self.overflow.map(|u| (u, ())), other.overflow.map(|u| (u, ()))).map(|(u, _)| u);
    }

    /// The error for the first faulty element under the policy (`Skip`: none, but for an
    /// overflow, which is never skipped).
    pub fn into_result(self, degenerate: Degenerate) -> Result<()> {
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

/// `f` of every element into `out` (one slot per element; the default for a faulty one).
pub(crate) fn per_element<S: Simplex, T: Default + Send>(
    elements: &Elements<S>,
    opts: &Options,
    out: &mut [T],
    f: impl Fn(&Element<S>) -> std::result::Result<T, Fault> + Sync,
) -> Result<()> {
    let fault = chunked(elements, opts, out.par_chunks_mut(CHUNK), |c, slots, scratch, faults| {
        for (k, slot) in slots.iter_mut().enumerate() {
            let t = c * CHUNK + k;
            *slot = f(&elements.get(t, scratch)).unwrap_or_else(|fault| {
                faults.record(elements, t, fault);
                T::default()
            });
        }
    })?;
    fault.into_result(opts.degenerate)
}

/// `f` of every element into two outputs (weights and corner masses in one pass); each
/// output gets the default for an element that fails for it.
pub(crate) fn per_element_pair<S: Simplex, A: Default + Send, B: Default + Send>(
    elements: &Elements<S>,
    opts: &Options,
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(&Element<S>) -> (std::result::Result<A, Fault>, std::result::Result<B, Fault>) + Sync,
) -> Result<()> {
    let chunks = a.par_chunks_mut(CHUNK).zip(b.par_chunks_mut(CHUNK));
    let fault = chunked(elements, opts, chunks, |c, (a, b), scratch, faults| {
        for (k, (x, y)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
            let t = c * CHUNK + k;
            let (u, v) = f(&elements.get(t, scratch));
            if let Some(fault) = u.as_ref().err().or(v.as_ref().err()) {
                faults.record(elements, t, *fault);
            }
            (*x, *y) = (u.unwrap_or_default(), v.unwrap_or_default());
        }
    })?;
    fault.into_result(opts.degenerate)
}

/// `f` of the listed elements only: their values, in the order of `listed`.
pub(crate) fn per_element_subset<S: Simplex, T: Default + Send>(
    elements: &Elements<S>,
    opts: &Options,
    listed: &[u32],
    f: impl Fn(&Element<S>) -> std::result::Result<T, Fault> + Sync,
) -> Result<Vec<T>> {
    let results: Vec<_> = listed
        .par_iter()
        .map_init(|| vec![0.0; elements.scratch_len()], |scratch, &t| f(&elements.get(t as usize, scratch)))
        .collect();
    opts.cancelled()?;
    let mut fault = FirstFault::default();
    for (&t, r) in listed.iter().zip(&results) {
        if let Err(f) = r {
            fault.record(elements, t as usize, *f);
        }
    }
    fault.into_result(opts.degenerate)?;
    Ok(results.into_iter().map(|r| r.unwrap_or_default()).collect())
}
