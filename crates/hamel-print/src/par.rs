//! Work over a sheet's entries, on a pool of printing's own when it is large enough to pay for
//! the threads. Printing is CAS-free, and its pool is its own (threads named `hamel-print`),
//! so its threads never run computer-algebra code nor share a pool with it.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock, PoisonError};

use rayon::prelude::*;

/// Below this many terms in all, a sheet's entries are worked on the calling thread (a small
/// model's sheet prints in a tenth of a millisecond, less than waking the pool costs).
const PARALLEL_FROM: usize = 2000;

/// Whether entries with these numbers of terms are worth the pool.
pub(crate) fn worth_it(terms: impl IntoIterator<Item = usize>) -> bool {
    terms.into_iter().sum::<usize>() >= PARALLEL_FROM
}

/// Printing's pool: one thread per core, started the first time a sheet is large enough;
/// None if the threads could not be started (the work then runs on the calling thread).
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

/// `f` over `items`, results in order, with a state made by `init` for each thread that works
/// on them. On printing's pool when `parallel`: each thread takes the next item from a shared
/// counter, the largest (by `size`) first, so that a run of large items does not fall to one
/// thread (rayon deals out runs of consecutive items: the unicycle's six largest momenta
/// entries fell to one thread, which did 95 % of the work). Else in order on the calling
/// thread, with one state.
pub(crate) fn map_init_owned<T: Send, S, R: Send>(
    items: Vec<T>,
    size: impl Fn(&T) -> usize,
    parallel: bool,
    init: impl Fn() -> S + Sync,
    f: impl Fn(&mut S, T) -> R + Sync,
) -> Vec<R> {
    let Some(pool) = parallel.then(pool).flatten() else {
        let mut state = init();
        return items.into_iter().map(|x| f(&mut state, x)).collect();
    };
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(size(&items[i])));
    let slots: Vec<Mutex<Option<T>>> = items.into_iter().map(|x| Mutex::new(Some(x))).collect();
    let next = AtomicUsize::new(0);
    let taken: Vec<Vec<(usize, R)>> = pool.broadcast(|_| {
        let mut state = init();
        let mut out = Vec::new();
        while let Some(&i) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
            let item = slots[i]
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .take();
            out.push((i, f(&mut state, item.expect("each item taken once"))));
        }
        out
    });
    let mut results: Vec<Option<R>> = std::iter::repeat_with(|| None).take(slots.len()).collect();
    for (i, r) in taken.into_iter().flatten() {
        results[i] = Some(r);
    }
    results
        .into_iter()
        .map(|r| r.expect("every item taken"))
        .collect()
}

/// `f` over `items`, results in order; on printing's pool when `parallel`.
pub(crate) fn map_ref<'a, T: Sync, R: Send>(
    items: &'a [T],
    parallel: bool,
    f: impl Fn(&'a T) -> R + Sync + Send,
) -> Vec<R> {
    match parallel.then(pool).flatten() {
        Some(pool) => pool.install(|| items.par_iter().with_max_len(1).map(&f).collect()),
        None => items.iter().map(f).collect(),
    }
}

/// `f` on each of `items` with its index; on printing's pool when `parallel`.
pub(crate) fn for_each_mut<T: Send>(
    items: &mut [T],
    parallel: bool,
    f: impl Fn(usize, &mut T) + Sync + Send,
) {
    match parallel.then(pool).flatten() {
        Some(pool) => pool.install(|| {
            items
                .par_iter_mut()
                .with_max_len(1)
                .enumerate()
                .for_each(|(i, x)| f(i, x));
        }),
        None => items.iter_mut().enumerate().for_each(|(i, x)| f(i, x)),
    }
}
