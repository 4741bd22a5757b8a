//! Progress bars on stderr, shown only when stderr is a terminal, and the one parallel
//! map that counts its items on a bar ([`par_map`], [`par_map_shown`]): every stage that
//! computes items in parallel with a progress bar goes through it.
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

/// A bar when `enabled` and [`crate::verbosity::progress_bars`] allows it (not under
/// `-q`, and only on a terminal), else a hidden one.
pub fn bar(enabled: bool, len: u64, message: &str) -> ProgressBar {
    if !enabled || !crate::verbosity::progress_bars() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    bar.set_style(
        ProgressStyle::with_template("{msg:>20} [{elapsed_precise}] {wide_bar} {pos}/{len} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(message.to_string());
    // Appear only for work longer than a second.
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

/// `f` of every item, in parallel on the current rayon pool, each counted on `bar` when
/// done; the results come back in item order whatever the number of threads. `bar` may
/// be shared by several calls (one bar for all the fibres of several webs).
pub fn par_map<I, T, F>(bar: &ProgressBar, items: I, f: F) -> Vec<T>
where
    I: IntoParallelIterator,
    I::Iter: IndexedParallelIterator,
    T: Send,
    F: Fn(I::Item) -> T + Sync + Send,
{
    items
        .into_par_iter()
        .map(|item| {
            let out = f(item);
            bar.inc(1);
            out
        })
        .collect()
}

/// [`par_map`] on a bar of its own, labelled `label`, shown when `show` (a stage passes
/// [`crate::stages::RunContext::progress`]) and cleared when done.
pub fn par_map_shown<I, T, F>(show: bool, label: &str, items: I, f: F) -> Vec<T>
where
    I: IntoParallelIterator,
    I::Iter: IndexedParallelIterator,
    T: Send,
    F: Fn(I::Item) -> T + Sync + Send,
{
    let items = items.into_par_iter();
    let bar = bar(show, items.len() as u64, label);
    let out = par_map(&bar, items, f);
    bar.finish_and_clear();
    out
}


#[cfg(test)]
mod tests {
    /// Results in item order, every item counted, for any thread count.
    #[test]
    fn par_map_keeps_item_order_and_counts_every_item() {
        for threads in [1, 3] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let bar = indicatif::ProgressBar::hidden();
            let out = pool.install(|| super::par_map(&bar, 0..1000usize, |i| i * i));
            assert_eq!(out, (0..1000usize).map(|i| i * i).collect::<Vec<_>>(), "{threads} threads");
            assert_eq!(bar.position(), 1000, "{threads} threads");
        }
    }
}
