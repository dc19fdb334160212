//! Shared fixtures of the benchmarks: the bundled catalogue and seeded simulated frames.

use std::sync::Arc;

use starid_core::simulate::{simulate, SimConfig, SimFrame};
use starid_core::{Camera, Catalog};

/// The bundled Hipparcos catalogue (Hp <= 6.5, 7982 stars).
pub fn bundled_catalog() -> Arc<Catalog> {
    Arc::new(Catalog::bundled())
}

/// `n` frames with at least 4 centroids, from seeds 0, 1, 2, ...
pub fn frames(catalog: &Catalog, camera: &Camera, sim: &SimConfig, n: usize) -> Vec<SimFrame> {
    (0..)
        .map(|seed| simulate(catalog, camera, sim, seed).expect("frame"))
        .filter(|f| f.centroids.len() >= 4)
        .take(n)
        .collect()
}
