//! Frames of a batch run in parallel, each on its own, until a cancel flag is raised: the
//! batches of hinted and unknown-field frames (the batch of a known camera, which learns a zero
//! point across its frames, is [`Solver::identify_batch_until`](super::Solver::identify_batch_until)).

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{Error, Result};

/// `f(0), …, f(n − 1)` in order, on up to `threads` threads (`None`: all cores), or
/// [`ErrorKind::Cancelled`](crate::ErrorKind) once `cancel` is raised: frames not yet begun are
/// skipped, so the call ends within one frame's time of it.
///
/// ```
/// use std::sync::atomic::AtomicBool;
/// let squares = starid_core::identify::map_frames(5, None, &AtomicBool::new(false), |i| i * i).unwrap();
/// assert_eq!(squares, vec![0, 1, 4, 9, 16]);
/// assert!(starid_core::identify::map_frames(5, None, &AtomicBool::new(true), |i| i).is_err());
/// ```
pub fn map_frames<T, F>(
    n: usize,
    threads: Option<usize>,
    cancel: &AtomicBool,
    f: F,
) -> Result<Vec<T>>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    if threads == Some(0) {
        return Err(Error::invalid_input(
            "threads must be at least 1 (or None for all cores)",
        ));
    }
    let one = |i: usize| (!cancel.load(Ordering::Relaxed)).then(|| f(i));
    let all = || -> Vec<Option<T>> {
        #[cfg(feature = "parallel")]
        if threads != Some(1) && n > 1 {
            use rayon::prelude::*;
            // One frame a task: frames of one batch may differ a thousandfold in cost.
            return (0..n).into_par_iter().with_max_len(1).map(one).collect();
        }
        (0..n).map(one).collect()
    };
    #[cfg(feature = "parallel")]
    let out = match threads.filter(|&t| t > 1) {
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::invalid_input(format!("cannot start {t} threads: {e}")))?
            .install(all),
        None => all(),
    };
    #[cfg(not(feature = "parallel"))]
    let out = all();
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::cancelled());
    }
    Ok(out
        .into_iter()
        .map(|r| r.expect("every frame ran"))
        .collect())
}
