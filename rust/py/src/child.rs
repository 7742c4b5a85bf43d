//! Work that Ctrl-C can abandon (Linux): a computation run in a forked child process,
//! writing its result into memory shared with this process, and killed (SIGKILL) when the
//! call is cancelled, so that no CPU is spent on it after the KeyboardInterrupt and nothing
//! delays the interpreter's exit. A thread could not be stopped: faer's factorization does
//! not poll a flag.
//!
//! The child runs Rust only, on memory prepared before the fork (no Python, no thread pool:
//! the factorization is sequential), ignores SIGINT (its parent answers it), dies with the
//! thread that forked it (`PR_SET_PDEATHSIG`, so a killed parent leaves no orphan) and ends
//! with `_exit`. Its outcome is two words written after the result.

use std::ops::{Deref, DerefMut};
use std::ptr::NonNull;
use std::time::Duration;
use tetlap::{Error, Result};

/// `len` f64 values (and two status words after them) in a `MAP_SHARED | MAP_ANONYMOUS`
/// mapping: what a forked child writes there, this process reads.
#[derive(Debug)]
pub struct Shared {
    ptr: NonNull<f64>,
    len: usize,
}

// SAFETY: the mapping is owned by this value alone (like a Box<[f64]>).
unsafe impl Send for Shared {}
unsafe impl Sync for Shared {}

impl Shared {
    /// A zeroed mapping of `len` values, or [`Error::OutOfMemory`].
    pub fn new(len: usize) -> Result<Self> {
        let oom = Error::OutOfMemory { what: "the factor (shared memory)" };
        let bytes = len.checked_add(2).and_then(|words| words.checked_mul(8)).ok_or(oom.clone())?;
        // SAFETY: a fresh anonymous mapping, checked below.
        let ptr = unsafe {
            libc::mmap(
                std::ptr::null_mut(),
                bytes,
                libc::PROT_READ | libc::PROT_WRITE,
                libc::MAP_SHARED | libc::MAP_ANONYMOUS,
                -1,
                0,
            )
        };
        if ptr == libc::MAP_FAILED {
            return Err(oom);
        }
        Ok(Shared { ptr: NonNull::new(ptr.cast()).ok_or(oom)?, len })
    }

    fn status(&mut self) -> &mut [u64; 2] {
        // SAFETY: the two words after the values belong to the mapping; f64 and u64 share
        // size and alignment.
        unsafe { &mut *self.ptr.as_ptr().add(self.len).cast::<[u64; 2]>() }
    }
}

impl Deref for Shared {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        // SAFETY: `len` initialised (zero-filled) values.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl DerefMut for Shared {
    fn deref_mut(&mut self) -> &mut [f64] {
        // SAFETY: as above, borrowed mutably through `self`.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl Drop for Shared {
    fn drop(&mut self) {
        // SAFETY: the mapping made in `new`, unmapped once.
        unsafe { libc::munmap(self.ptr.as_ptr().cast(), (self.len + 2) * 8) };
    }
}

/// The status words: not written (the child died first), done, or an error.
const UNFINISHED: u64 = 0;
const DONE: u64 = 1;
const NOT_POSITIVE_DEFINITE: u64 = 2;
const SINGULAR: u64 = 3;
const OUT_OF_MEMORY: u64 = 4;
const OTHER: u64 = 5;
const PANICKED: u64 = 6;

/// `work(out)` in a forked child process while this thread waits, checking `cancelled`
/// every few milliseconds: once it is true the child is killed and reaped and
/// [`Error::Cancelled`] returned. The errors `work` may return are the numeric
/// factorization's (a row with them); a panic of `work` panics here. Where the fork fails
/// (no memory for the child's page tables), `work` runs in this thread.
pub fn run(out: &mut Shared, cancelled: impl Fn() -> bool, work: impl FnOnce(&mut [f64]) -> Result<()>) -> Result<()> {
    *out.status() = [UNFINISHED, 0];
    // SAFETY: getpid and fork have no preconditions; the child below calls only
    // async-signal-safe functions before running `work` on memory that exists in it, and
    // leaves by `_exit` (no destructors, no atexit handlers, no Python).
    let parent = unsafe { libc::getpid() };
    let pid = unsafe { libc::fork() };
    if pid < 0 {
        return work(out);
    }
    if pid == 0 {
        unsafe {
            libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL);
            if libc::getppid() != parent {
                libc::_exit(1);
            }
            libc::signal(libc::SIGINT, libc::SIG_IGN);
            libc::signal(libc::SIGTERM, libc::SIG_DFL);
        }
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(&mut *out)));
        *out.status() = match outcome {
            Ok(Ok(())) => [DONE, 0],
            Ok(Err(Error::NotPositiveDefinite { row })) => [NOT_POSITIVE_DEFINITE, row as u64],
            Ok(Err(Error::Singular { row })) => [SINGULAR, row as u64],
            Ok(Err(Error::OutOfMemory { .. })) => [OUT_OF_MEMORY, 0],
            Ok(Err(_)) => [OTHER, 0],
            Err(_) => [PANICKED, 0],
        };
        unsafe { libc::_exit(0) };
    }
    let mut pause = Duration::from_millis(1);
    let mut status = 0;
    loop {
        // SAFETY: waits for our own child.
        let reaped = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
        if reaped == pid || (reaped < 0 && std::io::Error::last_os_error().raw_os_error() != Some(libc::EINTR)) {
            break; // exited, or reaped by someone else (ECHILD): the status words tell
        }
        if cancelled() {
            // SAFETY: our own child, not yet reaped.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
                while libc::waitpid(pid, &mut status, 0) < 0
                    && std::io::Error::last_os_error().raw_os_error() == Some(libc::EINTR)
                {}
            }
            return Err(Error::Cancelled);
        }
        std::thread::sleep(pause);
        pause = (pause * 2).min(Duration::from_millis(10));
    }
    match *out.status() {
        [DONE, _] => Ok(()),
        [NOT_POSITIVE_DEFINITE, row] => Err(Error::NotPositiveDefinite { row: row as usize }),
        [SINGULAR, row] => Err(Error::Singular { row: row as usize }),
        [OUT_OF_MEMORY, _] => Err(Error::OutOfMemory { what: "the factorization (in its child process)" }),
        [PANICKED, _] => panic!("the factorization panicked in its child process"),
        [OTHER, _] => panic!("the factorization failed in its child process with an unexpected error"),
        _ => Err(Error::OutOfMemory {
            what: "the factorization: its child process was killed (as by the system's out-of-memory killer)",
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::{run, Shared};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::time::{Duration, Instant};
    use tetlap::Error;

    /// This process's children that are still alive (from /proc).
    fn children() -> usize {
        let me = std::process::id().to_string();
        std::fs::read_dir("/proc")
            .unwrap()
            .filter_map(|e| std::fs::read_to_string(e.ok()?.path().join("stat")).ok())
            .filter(|stat| {
                // pid (comm) state ppid ...
                let rest = stat.rsplit_once(") ").map_or("", |(_, r)| r);
                let fields: Vec<&str> = rest.split(' ').collect();
                fields.len() > 1 && fields[1] == me && fields[0] != "Z"
            })
            .count()
    }

    #[test]
    fn the_child_writes_the_result_its_errors_come_back_and_cancelling_kills_it() {
        let mut out = Shared::new(5).unwrap();
        let parent = std::process::id();
        let r = run(&mut out, || false, |v| {
            // runs elsewhere: its process id differs
            v.iter_mut().enumerate().for_each(|(i, x)| *x = i as f64 + if std::process::id() != parent { 0.5 } else { 0.0 });
            Ok(())
        });
        assert_eq!(r, Ok(()));
        assert_eq!(&out[..], &[0.5, 1.5, 2.5, 3.5, 4.5]);
        let r = run(&mut out, || false, |_| Err(Error::NotPositiveDefinite { row: 7 }));
        assert_eq!(r, Err(Error::NotPositiveDefinite { row: 7 }));
        let r = run(&mut out, || false, |_| Err(Error::Singular { row: 3 }));
        assert_eq!(r, Err(Error::Singular { row: 3 }));
        // (one test: the tests' threads would see each other's children)
        let cancel = AtomicBool::new(false);
        let start = Instant::now();
        std::thread::scope(|s| {
            s.spawn(|| {
                std::thread::sleep(Duration::from_millis(200));
                cancel.store(true, Ordering::Relaxed);
            });
            let r = run(&mut out, || cancel.load(Ordering::Relaxed), |_| loop {
                std::hint::spin_loop();
            });
            assert_eq!(r, Err(Error::Cancelled));
        });
        assert!(start.elapsed() < Duration::from_secs(5));
        assert_eq!(children(), 0);
    }
}
