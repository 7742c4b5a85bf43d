//! The parallel per-element pass: every element writes its own output slot (so the result
//! does not depend on the scheduling), faults are collected as the lowest faulty element,
//! and the cancel flag is polled between chunks.

use crate::element::{Element, Elements, Fault};
use crate::error::Result;
use crate::options::{Degenerate, Options};
use crate::simplex::Simplex;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Elements per work item (and per poll of the cancel flag).
pub(crate) const CHUNK: usize = 2048;

/// Runs `fill(chunk_index, chunk, scratch)` over `chunks` (one per [`CHUNK`] elements) in
/// parallel; `fill` returns the first faulty element of its chunk. Returns the first faulty
/// element overall, or [`crate::Error::Cancelled`].
pub(crate) fn chunked<S: Simplex, C: Send>(
    elements: &Elements<S>,
    opts: &Options,
    chunks: impl IndexedParallelIterator<Item = C>,
    fill: impl Fn(usize, C, &mut [f64]) -> Option<usize> + Sync,
) -> Result<Option<usize>> {
    let first_fault = AtomicUsize::new(usize::MAX);
    chunks.enumerate().try_for_each_init(
        || vec![0.0; elements.scratch_len()],
        |scratch, (c, chunk)| {
            opts.cancelled()?;
            if let Some(t) = fill(c, chunk, scratch) {
                first_fault.fetch_min(t, Ordering::Relaxed);
            }
            Ok(())
        },
    )?;
    let t = first_fault.into_inner();
    Ok((t != usize::MAX).then_some(t))
}

/// Evaluates elements `t0..t0 + slots.len()` into their slots: `f`'s value, or the default
/// for a faulty element. Returns the first faulty element.
pub(crate) fn fill_slots<S: Simplex, T: Default>(
    elements: &Elements<S>,
    t0: usize,
    slots: &mut [T],
    scratch: &mut [f64],
    f: &impl Fn(&Element<S>) -> std::result::Result<T, Fault>,
) -> Option<usize> {
    let mut fault = None;
    for (k, slot) in slots.iter_mut().enumerate() {
        let t = t0 + k;
        *slot = f(&elements.get(t, scratch)).unwrap_or_else(|_| {
            fault = fault.or(Some(t));
            T::default()
        });
    }
    fault
}

/// `f` of every element into `out` (one slot per element).
pub(crate) fn per_element<S: Simplex, T: Default + Send>(
    elements: &Elements<S>,
    opts: &Options,
    out: &mut [T],
    f: impl Fn(&Element<S>) -> std::result::Result<T, Fault> + Sync,
) -> Result<()> {
    let fault = chunked(elements, opts, out.par_chunks_mut(CHUNK), |c, slots, scratch| {
        fill_slots(elements, c * CHUNK, slots, scratch, &f)
    })?;
    fault_to_error(elements, opts.degenerate, fault)
}

/// `f` of every element into two outputs (weights and corner masses in one pass).
pub(crate) fn per_element_pair<S: Simplex, A: Default + Send, B: Default + Send>(
    elements: &Elements<S>,
    opts: &Options,
    a: &mut [A],
    b: &mut [B],
    f: impl Fn(&Element<S>) -> std::result::Result<(A, B), Fault> + Sync,
) -> Result<()> {
    let chunks = a.par_chunks_mut(CHUNK).zip(b.par_chunks_mut(CHUNK));
    let fault = chunked(elements, opts, chunks, |c, (a, b), scratch| {
        let mut fault = None;
        for (k, (x, y)) in a.iter_mut().zip(b.iter_mut()).enumerate() {
            let t = c * CHUNK + k;
            (*x, *y) = f(&elements.get(t, scratch)).unwrap_or_else(|_| {
                fault = fault.or(Some(t));
                Default::default()
            });
        }
        fault
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
        .map_init(|| vec![0.0; elements.scratch_len()], |scratch, &t| {
            f(&elements.get(t as usize, scratch))
        })
        .collect();
    opts.cancelled()?;
    let first = listed.iter().zip(&results).filter(|(_, r)| r.is_err()).map(|(&t, _)| t as usize).min();
    fault_to_error(elements, opts.degenerate, first)?;
    Ok(results.into_iter().map(|r| r.unwrap_or_default()).collect())
}

/// The error for the first faulty element under the policy (`Skip`: none).
pub(crate) fn fault_to_error<S: Simplex>(
    elements: &Elements<S>,
    degenerate: Degenerate,
    first_fault: Option<usize>,
) -> Result<()> {
    match first_fault {
        Some(t) if degenerate == Degenerate::Raise => Err(elements.fault_error(t)),
        _ => Ok(()),
    }
}
