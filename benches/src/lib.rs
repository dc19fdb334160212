//! Shared fixtures of the benchmarks: the bundled catalogue and seeded simulated frames.

use std::path::PathBuf;
use std::sync::Arc;

use starid_core::simulate::{simulate, SimConfig, SimFrame};
use starid_core::{Camera, Catalog};

/// The bundled Hipparcos catalogue (Hp <= 6.5, 7982 stars).
pub fn bundled_catalog() -> Arc<Catalog> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../python/starid/data/hipparcos_hp6.5_j2000.csv");
    Arc::new(Catalog::from_path(path).expect("bundled catalogue"))
}

/// `n` frames with at least 4 centroids, from seeds 0, 1, 2, ...
pub fn frames(catalog: &Catalog, camera: &Camera, sim: &SimConfig, n: usize) -> Vec<SimFrame> {
    (0..)
        .map(|seed| simulate(catalog, camera, sim, seed).expect("frame"))
        .filter(|f| f.centroids.len() >= 4)
        .take(n)
        .collect()
}
