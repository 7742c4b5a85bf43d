//! Grouping records by a small integer key: the one parallel counting sort of the crate
//! (element-corners by vertex, elements by first vertex, faces by smallest vertex).

use crate::error::Result;
use crate::options::Options;
use rayon::prelude::*;

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

/// The records `record(0..count)`, each `(group, value)` with `group < n`, grouped by
/// group: returns the group offsets (length `n + 1`) and the values, in record order
/// within each group (a stable counting sort).
///
/// Parallel over ranges of groups: every worker scans all records and keeps those of its
/// own range, so the result does not depend on the scheduling; the cancel flag is polled
/// between passes.
pub(crate) fn group_by<T: Copy + Default + Send + Sync>(
    n: usize,
    count: usize,
    record: impl Fn(usize) -> (u32, T) + Sync,
    opts: &Options,
) -> Result<(Vec<usize>, Vec<T>)> {
    let parts = (rayon::current_num_threads() * 2).clamp(1, n.max(1));
    let bounds: Vec<usize> = (0..=parts).map(|p| p * n / parts).collect();
    let mut counts = vec![0usize; n];
    groups_mut(&mut counts, &bounds).into_par_iter().enumerate().try_for_each(|(p, counts)| {
        let lo = bounds[p];
        for r in 0..count {
            if let Some(c) = (record(r).0 as usize).checked_sub(lo).and_then(|g| counts.get_mut(g)) {
                *c += 1;
            }
        }
        opts.cancelled()
    })?;
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0);
    for c in counts {
        offsets.push(offsets.last().expect("starts with 0") + c);
    }
    let mut values = vec![T::default(); count];
    let value_bounds: Vec<usize> = bounds.iter().map(|&b| offsets[b]).collect();
    groups_mut(&mut values, &value_bounds).into_par_iter().enumerate().try_for_each(|(p, out)| {
        let (lo, hi) = (bounds[p], bounds[p + 1]);
        let mut cursor: Vec<usize> = (lo..hi).map(|g| offsets[g] - offsets[lo]).collect();
        for r in 0..count {
            let (g, value) = record(r);
            let g = g as usize;
            if (lo..hi).contains(&g) {
                out[cursor[g - lo]] = value;
                cursor[g - lo] += 1;
            }
        }
        opts.cancelled()
    })?;
    Ok((offsets, values))
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
}
