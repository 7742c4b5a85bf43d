//! Grouping records by a small integer key: the one parallel counting sort of the crate
//! (element-corners by vertex, elements by first vertex, faces by smallest vertex).

use crate::error::Result;
use crate::options::Options;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// Items grouped by key: group `g` owns `items[offsets[g]..offsets[g+1]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Incidence {
    /// Group starts, length `groups + 1`.
    pub offsets: Vec<usize>,
    /// The items, ascending within each group.
    pub items: Vec<u32>,
}

impl Incidence {
    /// Items of group `g`.
    #[inline]
    pub fn of(&self, g: usize) -> &[u32] {
        &self.items[self.offsets[g]..self.offsets[g + 1]]
    }
}

/// Splits `data` into consecutive groups of `offsets`, for parallel per-group writes.
pub(crate) fn groups_mut<'a, T>(mut data: &'a mut [T], offsets: &[usize]) -> Vec<&'a mut [T]> {
    let mut groups = Vec::with_capacity(offsets.len().saturating_sub(1));
    for w in offsets.windows(2) {
        let (group, rest) = data.split_at_mut(w[1] - w[0]);
        groups.push(group);
        data = rest;
    }
    groups
}

/// Records per work item of [`group_by`]'s first pass (and per poll of the cancel flag).
const RECORD_CHUNK: usize = 1 << 16;

/// The records `record(0..count)`, each `(group, value)` with `group < n`, grouped by
/// group: returns the group offsets (length `n + 1`) and the values, in record order
/// within each group (a stable counting sort). The result is unique, hence the same for
/// any thread count.
///
/// Two passes, `O(count + n)` work: chunks of records are evaluated once each, in
/// parallel, into buckets by *range* of groups (one range per work item of the second
/// pass); then every range counts its records, and scatters them into its own contiguous
/// part of the output in chunk order, which keeps record order. The cancel flag is polled
/// per chunk and per range.
pub(crate) fn group_by<T: Copy + Default + Send + Sync>(
    n: usize,
    count: usize,
    record: impl Fn(usize) -> (u32, T) + Sync,
    opts: &Options,
) -> Result<(Vec<usize>, Vec<T>)> {
    let ranges = (rayon::current_num_threads() * 4).clamp(1, n.max(1));
    let bounds: Vec<usize> = (0..=ranges).map(|p| p * n / ranges).collect();
    // the range of group g: the largest p with bounds[p] <= g
    let range_of = |g: u32| ((g as u64 + 1) * ranges as u64 - 1) as usize / n;
    let chunks: Vec<Vec<Vec<(u32, T)>>> = (0..count.div_ceil(RECORD_CHUNK))
        .into_par_iter()
        .map(|c| {
            opts.cancelled()?;
            let records = c * RECORD_CHUNK..count.min((c + 1) * RECORD_CHUNK);
            let mut buckets = vec![Vec::new(); ranges];
            for r in records {
                let (g, value) = record(r);
                buckets[range_of(g)].push((g, value));
            }
            Ok(buckets)
        })
        .collect::<Result<_>>()?;
    let bucket = |p: usize| chunks.iter().flat_map(move |c| &c[p]);
    let mut counts = vec![0usize; n];
    groups_mut(&mut counts, &bounds).into_par_iter().enumerate().for_each(|(p, counts)| {
        for &(g, _) in bucket(p) {
            counts[g as usize - bounds[p]] += 1;
        }
    });
    opts.cancelled()?;
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    for c in counts {
        offsets.push(offsets.last().expect("starts with 0") + c);
    }
    let mut values = vec![T::default(); count];
    let value_bounds: Vec<usize> = bounds.iter().map(|&b| offsets[b]).collect();
    groups_mut(&mut values, &value_bounds).into_par_iter().enumerate().for_each(|(p, out)| {
        let lo = bounds[p];
        let mut cursor: Vec<usize> = (lo..bounds[p + 1]).map(|g| offsets[g] - offsets[lo]).collect();
        for &(g, value) in bucket(p) {
            let slot = &mut cursor[g as usize - lo];
            out[*slot] = value;
            *slot += 1;
        }
    });
    opts.cancelled()?;
    Ok((offsets, values))
}

/// [`group_by`] for `u32` values, without a buffer of records: each worker counts the
/// groups of its contiguous part of the records, then places its records (each evaluated
/// again) from the positions those counts give, so that every group keeps record order.
/// The result is [`group_by`]'s, for any thread count; the only memory besides the output
/// is one count per group and worker. `count` must be below `2^32`.
pub(crate) fn group_u32(
    n: usize,
    count: usize,
    record: impl Fn(usize) -> (u32, u32) + Sync,
    opts: &Options,
) -> Result<(Vec<usize>, Vec<u32>)> {
    assert!(count <= u32::MAX as usize, "record positions are u32");
    let parts = rayon::current_num_threads().clamp(1, count.div_ceil(RECORD_CHUNK).max(1));
    let bounds: Vec<usize> = (0..=parts).map(|p| p * count / parts).collect();
    let width = n.max(1);
    // per part, the records of every group
    let mut counts = vec![0u32; parts * width];
    counts.par_chunks_mut(width).enumerate().try_for_each(|(p, counts)| {
        for (i, r) in (bounds[p]..bounds[p + 1]).enumerate() {
            if i % RECORD_CHUNK == 0 {
                opts.cancelled()?;
            }
            counts[record(r).0 as usize] += 1;
        }
        Ok::<(), crate::Error>(())
    })?;
    // the group offsets, and in place of each count, where that part's records of the
    // group start
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    let mut total = 0usize;
    for g in 0..n {
        for p in 0..parts {
            let c = counts[p * width + g];
            counts[p * width + g] = total as u32;
            total += c as usize;
        }
        offsets.push(total);
    }
    opts.cancelled()?;
    let values: Vec<AtomicU32> = vec![0u32; count].into_iter().map(AtomicU32::new).collect();
    counts.par_chunks_mut(width).enumerate().try_for_each(|(p, cursor)| {
        for (i, r) in (bounds[p]..bounds[p + 1]).enumerate() {
            if i % RECORD_CHUNK == 0 {
                opts.cancelled()?;
            }
            let (g, value) = record(r);
            let slot = &mut cursor[g as usize];
            values[*slot as usize].store(value, Ordering::Relaxed);
            *slot += 1;
        }
        Ok::<(), crate::Error>(())
    })?;
    // (collected in place: an AtomicU32 is a u32)
    Ok((offsets, values.into_iter().map(AtomicU32::into_inner).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouping_is_stable_and_complete() {
        let keys = [3u32, 0, 3, 1, 0, 3];
        let (offsets, values) = group_by(5, keys.len(), |r| (keys[r], r as u32), &Options::default()).unwrap();
        assert_eq!(offsets, vec![0, 2, 3, 3, 6, 6]);
        assert_eq!(values, vec![1, 4, 3, 0, 2, 5]);
    }

    #[test]
    fn grouping_equals_a_stable_sort_for_any_thread_count() {
        // more records than one chunk, skewed keys, empty groups
        let (n, count) = (1000usize, 3 * RECORD_CHUNK + 17);
        let key = |r: usize| ((r as u64 * 2654435761 % 1_000_003) % 997) as u32 / (1 + (r % 3) as u32);
        let mut expected: Vec<(u32, u32)> = (0..count).map(|r| (key(r), r as u32)).collect();
        expected.sort_by_key(|&(g, _)| g); // stable
        for threads in [1, 2, 3] {
            let (offsets, values) = crate::threads::run(Some(threads), || {
                group_by(n, count, |r| (key(r), r as u32), &Options::default())
            })
            .unwrap()
            .unwrap();
            assert_eq!(values, expected.iter().map(|&(_, r)| r).collect::<Vec<_>>());
            for g in 0..n {
                assert_eq!(offsets[g + 1] - offsets[g], expected.iter().filter(|e| e.0 as usize == g).count());
            }
            let (offsets_u32, values_u32) = crate::threads::run(Some(threads), || {
                group_u32(n, count, |r| (key(r), r as u32), &Options::default())
            })
            .unwrap()
            .unwrap();
            assert_eq!((offsets_u32, values_u32), (offsets, values));
        }
    }
}
