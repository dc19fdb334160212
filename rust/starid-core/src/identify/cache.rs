//! The solvers built for one catalogue, shared by every call: each pair index is built once,
//! whichever thread asks first, and reused for every field of view it suits.

use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::Instant;

use super::{stored, PairIndexes, Solver};
use crate::catalog::Catalog;
use crate::error::Result;

/// A cached index serves angles down to 1/`MAX_OVERSIZE` of its own: a larger index is
/// correct but slower to query.
pub const MAX_OVERSIZE: f64 = 1.25;

/// New indexes are built this much wider than asked, so nearby fields of view share one.
pub const BUILD_MARGIN: f64 = 1.02;

/// Solvers of one catalogue, keyed by the largest angle their pair index covers.
///
/// # Example
/// ```
/// use std::sync::Arc;
/// use starid_core::identify::SolverCache;
/// let cat = Arc::new(starid_core::simulate::random_catalog(2000, 1.0, 6.0, 1).unwrap());
/// let cache = SolverCache::new(cat);
/// let a = cache.solver(12f64.to_radians()).unwrap();
/// let b = cache.solver(11.5f64.to_radians()).unwrap();
/// assert!(Arc::ptr_eq(&a, &b));
/// assert_eq!(cache.len(), 1);
/// ```
#[derive(Debug)]
pub struct SolverCache {
    catalog: Arc<Catalog>,
    solvers: Mutex<Vec<Arc<Solver>>>,
    /// Held while an index is built, so that threads asking at once build it once.
    building: Mutex<()>,
    /// The catalogue's content key (see [`super::catalog_key`]), computed on first use.
    key: OnceLock<u64>,
}

impl SolverCache {
    /// An empty cache for `catalog`.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// assert!(cache.is_empty());
    /// ```
    pub fn new(catalog: Arc<Catalog>) -> Self {
        Self {
            catalog,
            solvers: Mutex::new(Vec::new()),
            building: Mutex::new(()),
            key: OnceLock::new(),
        }
    }

    /// The catalogue.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// assert_eq!(cache.catalog().len(), 3000);
    /// ```
    pub fn catalog(&self) -> &Arc<Catalog> {
        &self.catalog
    }

    /// Number of solvers built so far.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// cache.solver(0.2).unwrap();
    /// assert_eq!(cache.len(), 1);
    /// ```
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Whether no solver was built yet.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// assert!(cache.is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Arc<Solver>>> {
        // A panic while holding the lock leaves the vector intact: keep using it.
        self.solvers
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// A cached solver whose pair index covers `max_angle_rad` and is not much larger, if one
    /// is built: never builds (so it never takes long).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// assert!(cache.cached(0.2).is_none());
    /// cache.solver(0.2).unwrap();
    /// assert!(cache.cached(0.2).is_some());
    /// ```
    pub fn cached(&self, max_angle_rad: f64) -> Option<Arc<Solver>> {
        self.lock()
            .iter()
            .find(|s| {
                let m = s.pair_index().max_angle_rad();
                m >= max_angle_rad && m <= MAX_OVERSIZE * max_angle_rad
            })
            .cloned()
    }

    /// A solver whose pair index covers `max_angle_rad` (the camera's diagonal field of view):
    /// a cached one not much larger, or a new one built once however many threads ask.
    ///
    /// # Errors
    /// As [`Solver::new`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cache = starid_core::identify::SolverCache::new(std::sync::Arc::new(cat));
    /// let s = cache.solver(0.2).unwrap();
    /// assert!(s.pair_index().max_angle_rad() >= 0.2);
    /// ```
    pub fn solver(&self, max_angle_rad: f64) -> Result<Arc<Solver>> {
        self.solver_stored(max_angle_rad, None)
    }

    /// As [`SolverCache::solver`], keeping pair indexes on disk in `dir`: an index not in
    /// memory is read from an index file of this catalogue there when one suits, and one built
    /// is written there (when it has at least [`super::MIN_STORED_PAIRS`] pairs), so that the
    /// next process reads it instead of building it. A file that does not read back whole is
    /// rebuilt and replaced; a directory that cannot be written only means nothing is kept.
    ///
    /// # Errors
    /// As [`Solver::new`].
    ///
    /// # Example
    /// ```
    /// use std::sync::Arc;
    /// use starid_core::identify::SolverCache;
    /// let dir = std::env::temp_dir().join(format!("starid-doc-{}", std::process::id()));
    /// let cat = Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.0, 1).unwrap());
    /// let built = SolverCache::new(cat.clone()).solver_stored(0.2, Some(&dir)).unwrap();
    /// // A new cache of the same catalogue (a new process) reads the file.
    /// let read = SolverCache::new(cat).solver_stored(0.2, Some(&dir)).unwrap();
    /// assert_eq!(read.index_file(), built.index_file());
    /// assert_eq!(read.pair_index(), built.pair_index());
    /// std::fs::remove_dir_all(&dir).unwrap();
    /// ```
    pub fn solver_stored(&self, max_angle_rad: f64, dir: Option<&Path>) -> Result<Arc<Solver>> {
        if let Some(s) = self.cached(max_angle_rad) {
            return Ok(s);
        }
        let _building = self
            .building
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(s) = self.cached(max_angle_rad) {
            return Ok(s);
        }
        let t = Instant::now();
        let key = || *self.key.get_or_init(|| super::catalog_key(&self.catalog));
        let read =
            dir.and_then(|d| stored::load(d, &self.catalog, key(), max_angle_rad, MAX_OVERSIZE));
        let (indexes, file) = match read {
            Some((indexes, path)) => (indexes, Some(path)),
            None => {
                let indexes = PairIndexes::build(&self.catalog, max_angle_rad * BUILD_MARGIN)?;
                let file = dir
                    .filter(|_| indexes.pairs.len() >= super::MIN_STORED_PAIRS)
                    .and_then(|d| stored::save(d, key(), self.catalog.len(), &indexes).ok());
                (indexes, file)
            }
        };
        let solver = Arc::new(Solver::with_indexes(
            self.catalog.clone(),
            indexes,
            t.elapsed(),
            file,
        ));
        self.lock().push(solver.clone());
        Ok(solver)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_asking_at_once_build_one_index() {
        let cat = Arc::new(crate::simulate::random_catalog(3000, 1.0, 6.0, 2).unwrap());
        let cache = SolverCache::new(cat);
        let got: Vec<Arc<Solver>> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..8)
                .map(|_| s.spawn(|| cache.solver(10f64.to_radians()).unwrap()))
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(cache.len(), 1);
        assert!(got.iter().all(|s| Arc::ptr_eq(s, &got[0])));
        // A much smaller angle gets an index of its own.
        let small = cache.solver(4f64.to_radians()).unwrap();
        assert!(!Arc::ptr_eq(&small, &got[0]));
        assert_eq!(cache.len(), 2);
    }
}
