//! The worker threads of the agent groups: on the CPU each group (one agent
//! by default, see [`crate::Stacking`]) runs on one of `networks.threads` OS
//! threads, each driving a single-thread rayon pool so that burn's kernels do
//! not oversubscribe the cores.

use crate::error::NnError;

/// One single-thread rayon pool per worker thread (none for one thread).
pub(crate) fn worker_pools(workers: usize) -> Result<Vec<rayon::ThreadPool>, NnError> {
    if workers <= 1 {
        return Ok(Vec::new());
    }
    (0..workers)
        .map(|k| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .thread_name(move |_| format!("fmsr-nn-group-worker-{k}"))
                .build()
                .map_err(|e| NnError::InvalidConfig {
                    key: "networks.threads",
                    reason: format!("cannot start worker {k}: {e}"),
                })
        })
        .collect()
}

/// `f(g, item_g)` for every item: with no pools in order on the calling
/// thread, otherwise round robin over the single-thread `pools`, one scoped OS
/// thread driving each, so items run in parallel and each item's kernels run
/// on one core. Each item's result depends only on its own state, so results
/// are the same for any number of threads.
pub(crate) fn par_each<I: Send, T: Send>(
    pools: &[rayon::ThreadPool],
    items: &mut [I],
    f: impl Fn(usize, &mut I) -> Result<T, NnError> + Sync,
) -> Result<Vec<T>, NnError> {
    let n = items.len();
    let t = pools.len().min(n);
    if t <= 1 {
        return items.iter_mut().enumerate().map(|(i, a)| f(i, a)).collect();
    }
    let mut buckets: Vec<Vec<(usize, &mut I)>> = (0..t).map(|_| Vec::new()).collect();
    for (i, a) in items.iter_mut().enumerate() {
        buckets[i % t].push((i, a));
    }
    let f = &f;
    let mut slots: Vec<Option<Result<T, NnError>>> = (0..n).map(|_| None).collect();
    std::thread::scope(|s| {
        let handles: Vec<_> = pools[..t]
            .iter()
            .zip(buckets)
            .map(|(pool, bucket)| {
                s.spawn(move || pool.install(|| bucket.into_iter().map(|(i, a)| (i, f(i, a))).collect::<Vec<_>>()))
            })
            .collect();
        for h in handles {
            if let Ok(done) = h.join() {
                for (i, r) in done {
                    slots[i] = Some(r);
                }
            }
        }
    });
    slots
        .into_iter()
        .map(|s| s.unwrap_or(Err(NnError::Backend { what: "group update", reason: "a worker thread panicked".into() })))
        .collect()
}
