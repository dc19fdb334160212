//! Proptest strategies and shared fixtures.

use std::sync::{Arc, OnceLock};

use nalgebra::{Rotation3, Unit, Vector3};
use proptest::prelude::*;
use starid_core::Catalog;

/// Cases per property: `STARID_PROPTEST_CASES`, else 24.
pub fn cases() -> u32 {
    std::env::var("STARID_PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24)
}

/// Cases from [`cases`]; the RNG seed is fixed (reproducible CI) unless `STARID_PROPTEST_SEED`
/// gives another number or says `random`.
pub fn config() -> ProptestConfig {
    let rng_seed = match std::env::var("STARID_PROPTEST_SEED").ok().as_deref() {
        Some("random") => proptest::test_runner::RngSeed::Random,
        Some(v) => proptest::test_runner::RngSeed::Fixed(v.parse().unwrap_or(20_261_123)),
        None => proptest::test_runner::RngSeed::Fixed(20_261_123),
    };
    ProptestConfig {
        cases: cases(),
        rng_seed,
        ..ProptestConfig::default()
    }
}

/// A unit vector, uniform on the sphere.
pub fn unit_vector() -> impl Strategy<Value = Vector3<f64>> {
    (0.0..std::f64::consts::TAU, -1.0f64..1.0).prop_map(|(ra, z)| {
        let r = (1.0 - z * z).sqrt();
        Vector3::new(r * ra.cos(), r * ra.sin(), z)
    })
}

/// A rotation: uniform axis, angle in [0, π].
pub fn rotation() -> impl Strategy<Value = Rotation3<f64>> {
    (unit_vector(), 0.0..std::f64::consts::PI)
        .prop_map(|(axis, angle)| Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle))
}

/// The bundled Hipparcos catalogue (Hp <= 6.5), loaded once.
pub fn bundled() -> Arc<Catalog> {
    static CAT: OnceLock<Arc<Catalog>> = OnceLock::new();
    CAT.get_or_init(|| Arc::new(Catalog::bundled())).clone()
}
