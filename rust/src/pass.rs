//! The parallel per-element pass: every element writes its own output slot (so the result
//! does not depend on the scheduling), faults are collected as the faulty element with the
//! lowest user index, and the cancel flag is polled between chunks.

use crate::element::{Element, Elements, Fault};
use crate::error::Result;
use crate::options::{Degenerate, Options};
use crate::simplex::Simplex;
use rayon::prelude::*;
use std::sync::Mutex;

/// Elements per work item (and per poll of the cancel flag).
pub(crate) const CHUNK: usize = 2048;

/// The first faulty element seen: `(user index, index in the pass)`, lowest user index.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct FirstFault(Option<(usize, usize)>);

impl FirstFault {
    /// Records element `t` of `elements` as faulty.
    pub fn record<S: Simplex>(&mut self, elements: &Elements<S>, t: usize) {
        let user = elements.user_index(t);
        if self.0.is_none_or(|(u, _)| user < u) {
            self.0 = Some((user, t));
        }
    }

    fn merge(&mut self, other: FirstFault) {
        if let Some((user, t)) = other.0 {
            if self.0.is_none_or(|(u, _)| user < u) {
                self.0 = Some((user, t));
            }
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
            if faults.0.is_some() {
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
            *slot = f(&elements.get(t, scratch)).unwrap_or_else(|_| {
                faults.record(elements, t);
                T::default()
            });
        }
    })?;
    fault_to_error(elements, opts.degenerate, fault)
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
            if u.is_err() || v.is_err() {
                faults.record(elements, t);
            }
            (*x, *y) = (u.unwrap_or_default(), v.unwrap_or_default());
        }
    })?;
    fault_to_error(elements, opts.degenerate, fault)
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
        if r.is_err() {
            fault.record(elements, t as usize);
        }
    }
    fault_to_error(elements, opts.degenerate, fault)?;
    Ok(results.into_iter().map(|r| r.unwrap_or_default()).collect())
}

/// The error for the first faulty element under the policy (`Skip`: none).
pub(crate) fn fault_to_error<S: Simplex>(elements: &Elements<S>, degenerate: Degenerate, first: FirstFault) -> Result<()> {
    match first.0 {
        Some((_, t)) if degenerate == Degenerate::Raise => Err(elements.fault_error(t)),
        _ => Ok(()),
    }
}
