//! Profiling target: hinted identification of 12°/512 px frames, repeated.
#![allow(clippy::print_stdout)]
use std::sync::Arc;
use nalgebra::{Rotation3, Vector3};
use starid_core::{simulate, AttitudeHint, Camera, Catalog, HintFallback, IdentifyConfig, SimConfig, Solver};
fn main() {
    let catalog = Arc::new(Catalog::bundled());
    let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &cam).unwrap();
    let sim = SimConfig { mag_limit: Some(6.0), noise_px: 0.2, mag_noise: 0.1, ..Default::default() };
    let frames: Vec<_> = (0..500).map(|s| simulate(&catalog, &cam, &sim, s).unwrap()).filter(|f| f.real_stars() >= 4).collect();
    let cfg = IdentifyConfig::default();
    let mut n = 0;
    for _ in 0..200 {
        for f in &frames {
            let hint = AttitudeHint { r_icrs_to_cam: Rotation3::new(Vector3::new(0.005, -0.008, 0.003)) * f.r_icrs_to_cam, uncertainty_rad: 0.0175, mirrored: Some(f.mirrored) };
            n += usize::from(solver.identify_hinted(&f.centroids, Some(&f.magnitudes), &cam, &cfg, &hint, HintFallback::None).unwrap().is_identified());
        }
    }
    println!("{n}");
}
