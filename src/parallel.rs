//! Work spread over threads, at the side of the pipeline: indices `0..n` handed out from a
//! shared counter, each result kept in its own slot, so the output is in order whatever the
//! threads' timing (and reports stay byte-identical).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// `f(i)` for every `i` in `0..n` on up to `threads` threads (at least one), `progress(done, n)`
/// after each; results in index order, `None` where a result was lost (a worker that panicked).
pub fn map_ordered<R: Send>(
    n: usize,
    threads: usize,
    f: &(dyn Fn(usize) -> R + Sync),
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Vec<Option<R>> {
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<R>>> = (0..n).map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, n.max(1)) {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                let r = f(i);
                if let Ok(mut slot) = slots[i].lock() {
                    *slot = Some(r);
                }
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, n);
            });
        }
    });
    slots
        .into_iter()
        .map(|m| m.into_inner().ok().flatten())
        .collect()
}

#[cfg(test)]
mod tests {
    /// The results come back in index order, whatever the thread count.
    #[test]
    fn results_are_in_order() {
        for threads in [1, 2, 5] {
            let out = super::map_ordered(37, threads, &|i| i * i, &|_, _| {});
            let expect: Vec<Option<usize>> = (0..37).map(|i| Some(i * i)).collect();
            assert_eq!(out, expect);
        }
    }
}
