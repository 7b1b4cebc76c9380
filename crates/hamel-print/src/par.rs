//! Work over a sheet's entries, on a pool of printing's own when it is large enough to pay for
//! the threads. Printing is CAS-free, and its pool is its own (threads named `hamel-print`),
//! so its threads never run computer-algebra code nor share a pool with it.

use std::sync::OnceLock;

use rayon::prelude::*;

/// Below this many terms in all, a sheet's entries are worked on the calling thread (a small
/// model's sheet prints in a tenth of a millisecond, less than waking the pool costs).
const PARALLEL_FROM: usize = 2000;

/// Whether entries with these numbers of terms are worth the pool.
pub(crate) fn worth_it(terms: impl IntoIterator<Item = usize>) -> bool {
    terms.into_iter().sum::<usize>() >= PARALLEL_FROM
}

/// Printing's pool: one thread per core; None if the threads could not be started (the work
/// then runs on the calling thread).
fn pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("hamel-print-{i}"))
            .build()
            .ok()
    })
    .as_ref()
}

/// `f` over `items`, in order, with a state made by `init` for each run of consecutive items
/// the pool takes (a run's items are given to `f` in order, with one state); on printing's
/// pool when `parallel`, else as one run on the calling thread.
pub(crate) fn map_init_owned<T: Send, S, R: Send>(
    items: Vec<T>,
    parallel: bool,
    init: impl Fn() -> S + Sync + Send,
    f: impl Fn(&mut S, T) -> R + Sync + Send,
) -> Vec<R> {
    match pool().filter(|_| parallel) {
        Some(pool) => pool.install(|| items.into_par_iter().map_init(&init, &f).collect()),
        None => {
            let mut state = init();
            items.into_iter().map(|x| f(&mut state, x)).collect()
        }
    }
}

/// `f` over `items`, results in order; on printing's pool when `parallel`.
pub(crate) fn map_ref<'a, T: Sync, R: Send>(
    items: &'a [T],
    parallel: bool,
    f: impl Fn(&'a T) -> R + Sync + Send,
) -> Vec<R> {
    match pool().filter(|_| parallel) {
        Some(pool) => pool.install(|| items.par_iter().map(&f).collect()),
        None => items.iter().map(f).collect(),
    }
}

/// `f` on each of `items` with its index; on printing's pool when `parallel`.
pub(crate) fn for_each_mut<T: Send>(
    items: &mut [T],
    parallel: bool,
    f: impl Fn(usize, &mut T) + Sync + Send,
) {
    match pool().filter(|_| parallel) {
        Some(pool) => pool.install(|| items.par_iter_mut().enumerate().for_each(|(i, x)| f(i, x))),
        None => items.iter_mut().enumerate().for_each(|(i, x)| f(i, x)),
    }
}
