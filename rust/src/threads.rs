//! Worker threads: one pool per thread count, built on first use and kept (a call never
//! pays for starting threads twice). Every computation enters its pool through
//! [`crate::Options::install`], which checks the count once. rayon's global pool is never
//! used: it would size itself from `RAYON_NUM_THREADS` without any bound.

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The largest accepted [`crate::Options::threads`]: four threads per core (at least 8).
///
/// More workers than that cannot make anything faster; the bound keeps a typo such as
/// `threads = 10**9` from starting thousands of OS threads.
pub fn max_threads() -> usize {
    (4 * cores()).max(8)
}

/// The cores this process may run on, asked once (the answer reads the cgroup's files).
fn cores() -> usize {
    static CORES: OnceLock<usize> = OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
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

/// The environment variable that sets the thread count when [`crate::Options::threads`]
/// is `None`, as it does for rayon.
pub const THREADS_VARIABLE: &str = "RAYON_NUM_THREADS";

/// The thread count of [`crate::Options::threads`]` = None`: `RAYON_NUM_THREADS` if it is
/// set (read on every call), else all cores. The variable obeys the bound of an explicit
/// count: `0` (rayon's "all cores"), empty or unset means all cores, `1..=max_threads()`
/// that many threads; anything else (above the bound, negative, not a number) is
/// [`Error::ThreadsVariable`], where rayon would start that many threads or silently
/// ignore the value.
pub fn default_threads() -> Result<usize> {
    threads_from_variable(std::env::var(THREADS_VARIABLE).ok().as_deref(), cores())
}

/// [`default_threads`] for the variable's `value` on `cores` cores.
fn threads_from_variable(value: Option<&str>, cores: usize) -> Result<usize> {
    let max = max_threads();
    let cores = cores.clamp(1, max);
    let Some(text) = value.map(str::trim).filter(|t| !t.is_empty()) else {
        return Ok(cores);
    };
    match text.parse::<usize>() {
        Ok(0) => Ok(cores),
        Ok(k) if k <= max => Ok(k),
        _ => Err(Error::ThreadsVariable { value: text.to_owned(), max }),
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
/// load per item: 5% of a one-shot assembly on validation alone). On the calling pool's
/// threads ([`here`]).
pub(crate) fn position_first<T: Sync>(items: &[T], bad: impl Fn(usize, &T) -> bool + Sync) -> Result<Option<usize>> {
    const CHUNK: usize = 1 << 14;
    here(|| {
        items.par_chunks(CHUNK).enumerate().find_map_first(|(c, chunk)| {
            let start = c * CHUNK;
            chunk.iter().enumerate().position(|(k, x)| bad(start + k, x)).map(|k| start + k)
        })
    })
}

/// Runs `f` on `threads` workers, or on [`default_threads`] for `None`, in their own
/// cached pool (an explicit count is checked before, by [`check_threads`]).
pub(crate) fn run<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    let threads = match threads {
        Some(k) => k,
        None => default_threads()?,
    };
    Ok(pool(threads)?.install(f))
}

/// Runs the parallel step `f` of a function without options (a validation) in the pool of
/// its caller, or in the default pool when called outside any: never in rayon's global
/// pool.
pub(crate) fn here<R: Send>(f: impl FnOnce() -> R + Send) -> Result<R> {
    match rayon::current_thread_index() {
        Some(_) => Ok(f()),
        None => run(None, f),
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
    fn the_variable_obeys_the_bound_of_an_explicit_count() {
        let max = max_threads();
        let from = |value: Option<&str>| threads_from_variable(value, 4);
        assert_eq!(from(None), Ok(4));
        assert_eq!(from(Some("")), Ok(4));
        assert_eq!(from(Some("0")), Ok(4));
        assert_eq!(from(Some(" 3 ")), Ok(3));
        assert_eq!(from(Some(&max.to_string())), Ok(max));
        for bad in [(max + 1).to_string(), "100000".into(), "-3".into(), "abc".into(), "2.5".into()] {
            assert_eq!(from(Some(&bad)), Err(Error::ThreadsVariable { value: bad.clone(), max }));
        }
        assert_eq!(threads_from_variable(None, 10 * max), Ok(max));
    }

    #[test]
    fn steps_without_options_run_in_the_callers_pool() {
        assert_eq!(run(Some(3), || here(rayon::current_num_threads)).unwrap().unwrap(), 3);
        let outside = here(rayon::current_thread_index).unwrap();
        assert!(outside.is_some(), "outside any pool, the default pool runs it");
    }

    #[test]
    fn thread_counts_are_bounded() {
        assert_eq!(check_threads(0), Err(Error::Threads { threads: 0, max: max_threads() }));
        let too_many = max_threads() + 1;
        assert!(matches!(check_threads(too_many), Err(Error::Threads { .. })));
        assert_eq!(check_threads(max_threads()), Ok(()));
    }
}
