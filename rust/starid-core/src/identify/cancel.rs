//! A flag another thread raises to end a search early (Ctrl-C in a caller), shared by every
//! clone of the settings that carry it.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Raised once, read by every search that holds a clone: the search ends as at its time limit.
///
/// ```
/// use starid_core::Cancel;
/// let c = Cancel::new();
/// let seen_by_worker = c.clone();
/// assert!(!seen_by_worker.is_cancelled());
/// c.cancel();
/// assert!(seen_by_worker.is_cancelled());
/// ```
#[derive(Clone, Default)]
pub struct Cancel(Arc<AtomicBool>);

impl Cancel {
    /// A flag not yet raised.
    pub fn new() -> Self {
        Self::default()
    }

    /// Raise the flag: searches holding it end at their next check.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether the flag was raised.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// The flag itself, for APIs that take an `&AtomicBool`.
    pub fn flag(&self) -> &AtomicBool {
        &self.0
    }
}

/// Two settings are equal whatever their flags' states when they hold the same flag (or none).
impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

impl fmt::Debug for Cancel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Cancel({})", self.is_cancelled())
    }
}

/// Whether a search must end now: its deadline passed or its flag was raised.
pub(crate) fn stop_now(deadline: Option<Instant>, cancel: Option<&Cancel>) -> bool {
    cancel.is_some_and(Cancel::is_cancelled) || deadline.is_some_and(|d| Instant::now() >= d)
}
