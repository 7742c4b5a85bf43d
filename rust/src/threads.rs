//! Worker threads: rayon's global pool, or one pool per requested thread count, built on
//! first use and kept (a call never pays for starting threads twice). Every computation
//! enters its pool through [`crate::Options::install`], which checks the count once.

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The largest accepted [`crate::Options::threads`]: four threads per core (at least 8).
///
/// More workers than that cannot make anything faster; the bound keeps a typo such as
/// `threads = 10**9` from starting thousands of OS threads.
pub fn max_threads() -> usize {
    static MAX: OnceLock<usize> = OnceLock::new();
    *MAX.get_or_init(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (4 * cores).max(8)
    })
}

/// Checks a requested thread count against `1..=max_threads()`: the one check of
/// [`crate::Options::threads`].
pub(crate) fn check_threads(threads: usize) -> Result<()> {
    let max = max_threads();
    if (1..=max).contains(&threads) {
        Ok(())
    } else {
        Err(Error::Threads { threads, max })
    }
}

/// The pool of `threads` workers, started on first use.
fn pool(threads: usize) -> Result<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Mutex<BTreeMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
    if let Some(pool) = pools.get(&threads) {
        return Ok(pool.clone());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("tetlap-{threads}-{i}"))
        .build()
        .map_err(|e| Error::ThreadPool { reason: e.to_string() })?;
    let pool = Arc::new(pool);
    pools.insert(threads, pool.clone());
    Ok(pool)
}

/// The index of the first item of `items` for which `bad(index, item)` holds, searched in
/// parallel by chunks, each chunk scanned in order (rayon's per-item search pays an atomic
/// load per item: 5% of a one-shot assembly on validation alone).
pub(crate) fn position_first<T: Sync>(items: &[T], bad: impl Fn(usize, &T) -> bool + Sync) -> Option<usize> {
    const CHUNK: usize = 1 << 14;
    items.par_chunks(CHUNK).enumerate().find_map_first(|(c, chunk)| {
        let start = c * CHUNK;
        chunk.iter().enumerate().position(|(k, x)| bad(start + k, x)).map(|k| start + k)
    })
}

/// Runs `f` on `threads` workers (their own cached pool; the count checked before, by
/// [`check_threads`]) or on rayon's global pool.
pub(crate) fn run<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    match threads {
        None => Ok(f()),
        Some(k) => Ok(pool(k)?.install(f)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pools_are_reused_and_sized() {
        let a = pool(3).unwrap();
        let b = pool(3).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert_eq!(run(Some(3), rayon::current_num_threads).unwrap(), 3);
        assert_eq!(run(Some(1), rayon::current_num_threads).unwrap(), 1);
    }

    #[test]
    fn thread_counts_are_bounded() {
        assert_eq!(check_threads(0), Err(Error::Threads { threads: 0, max: max_threads() }));
        let too_many = max_threads() + 1;
        assert!(matches!(check_threads(too_many), Err(Error::Threads { .. })));
        assert_eq!(check_threads(max_threads()), Ok(()));
    }
}
