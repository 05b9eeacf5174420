//! One-time preparation spread over the machine's cores: independent chunks of work handed out to
//! scoped threads, their results kept in chunk order, so that the outcome is the same whatever
//! the number of threads.
//!
//! The [`Cancel`] hook may only be polled from the calling thread (the Python binding's looks
//! for Ctrl-C, which needs the interpreter): the calling thread works on chunks too, polls the
//! hook between them, and tells the other threads to stop through a flag they read before each
//! chunk.

use crate::cancel::{self, Cancel};
use crate::error::{IcpError, Result};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Most threads one preparation uses (the calling one included).
pub const MAX_THREADS: usize = 8;

/// How many threads a preparation of `chunks` chunks uses: one per core (at most
/// [`MAX_THREADS`]), never more than there are chunks, and at least one.
pub fn threads_for(chunks: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores.min(MAX_THREADS).min(chunks).max(1)
}

/// `work(k)` for every chunk `k` in `0..chunks`, in chunk order, computed on up to
/// [`threads_for`]`(chunks)` threads. `cancel` is polled by the calling thread before each chunk
/// it takes; when it asks to stop, no thread starts another chunk and the result is
/// [`IcpError::Interrupted`]. The first error a chunk returns is returned (the others still
/// finish the chunk they are in). A panic in a chunk is raised again on the calling thread.
pub fn map_chunks<R, F>(chunks: usize, cancel: Cancel<'_>, work: F) -> Result<Vec<R>>
where
    R: Send,
    F: Fn(usize) -> Result<R> + Sync,
{
    let threads = threads_for(chunks);
    if threads == 1 {
        return (0..chunks)
            .map(|k| {
                cancel::check(cancel)?;
                work(k)
            })
            .collect();
    }
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let done: Mutex<Vec<(usize, Result<R>)>> = Mutex::new(Vec::with_capacity(chunks));
    // Takes chunks until none is left or a stop is asked; false when it stopped early.
    let run = |poll: Option<Cancel<'_>>| {
        let mut mine = Vec::new();
        loop {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            if poll.is_some_and(|c| c()) {
                stop.store(true, Ordering::Relaxed);
                break;
            }
            let k = next.fetch_add(1, Ordering::Relaxed);
            if k >= chunks {
                break;
            }
            let outcome = work(k);
            if outcome.is_err() {
                stop.store(true, Ordering::Relaxed);
            }
            mine.push((k, outcome));
        }
        done.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).extend(mine);
    };
    std::thread::scope(|scope| {
        for _ in 1..threads {
            scope.spawn(|| run(None));
        }
        run(Some(cancel));
    });
    let mut done = done.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner());
    done.sort_unstable_by_key(|(k, _)| *k);
    if let Some(position) = done.iter().position(|(_, outcome)| outcome.is_err()) {
        return Err(done.swap_remove(position).1.err().unwrap_or(IcpError::Interrupted));
    }
    if done.len() < chunks {
        return Err(IcpError::Interrupted);
    }
    Ok(done.into_iter().filter_map(|(_, outcome)| outcome.ok()).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::invalid;
    use std::cell::Cell;

    #[test]
    fn chunks_come_back_in_order_whatever_the_threads() {
        let squares = map_chunks(1000, cancel::NEVER, |k| Ok(k * k)).unwrap();
        assert_eq!(squares, (0..1000).map(|k| k * k).collect::<Vec<_>>());
        assert_eq!(map_chunks(0, cancel::NEVER, Ok).unwrap(), Vec::<usize>::new());
    }

    #[test]
    fn a_stop_asked_by_the_caller_interrupts_every_thread() {
        let polls = Cell::new(0);
        let after_three = || {
            polls.set(polls.get() + 1);
            polls.get() > 3
        };
        let started = AtomicUsize::new(0);
        let outcome = map_chunks(100_000, &after_three, |k| {
            started.fetch_add(1, Ordering::Relaxed);
            std::thread::sleep(std::time::Duration::from_micros(50));
            Ok(k)
        });
        assert_eq!(outcome, Err(IcpError::Interrupted));
        assert!(started.load(Ordering::Relaxed) < 100_000);
    }

    #[test]
    fn the_first_failing_chunk_is_the_error() {
        let outcome = map_chunks(50, cancel::NEVER, |k| {
            if k == 7 || k == 30 {
                Err(invalid("chunk", k, "fails"))
            } else {
                Ok(k)
            }
        });
        // Chunk 7 fails before chunk 30 is taken on one thread; on several, either may have run.
        assert!(matches!(outcome, Err(IcpError::InvalidParameter { .. })), "{outcome:?}");
    }
}
