//! The focal check: frames identified with a field of view given 1 % off are searched again with
//! the focal length their residuals imply (mirrored frames too); frames given the right one
//! never are.

use starid_core::simulate::{simulate, SimConfig};
use starid_core::{Camera, IdentifyConfig, Solver};

use super::strategies::bundled;

#[test]
fn a_field_of_view_given_one_percent_off_is_corrected_by_the_residuals() {
    let catalog = bundled();
    let size = 1024.0;
    let truth = Camera::from_fov(20f64.to_radians(), size, size).unwrap();
    let given = Camera::from_fov(20.2f64.to_radians(), size, size).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &truth).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        ..Default::default()
    };
    let checked = IdentifyConfig::default();
    let fixed = IdentifyConfig {
        focal_check: false,
        ..Default::default()
    };
    let wrong = |ids: &[Option<u32>], truth: &[Option<u32>]| {
        ids.iter()
            .zip(truth)
            .filter(|(a, b)| a.is_some() && a != b)
            .count()
    };
    let (mut corrected, mut named_fixed, mut named_checked) = (0, 0, 0);
    for seed in 0..40u64 {
        // Odd seeds mirrored: the scale is about the mirrored principal point there.
        let sim = SimConfig {
            mirrored: seed % 2 == 1,
            ..sim.clone()
        };
        let f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let m = Some(f.magnitudes.as_slice());
        // The right field of view: never corrected.
        let exact = solver.identify(&f.centroids, m, &truth, &checked).unwrap();
        assert_eq!(
            (exact.focal_length_px, exact.k1),
            (None, None),
            "seed {seed}"
        );
        assert!(exact.focal_sigma_px.is_nan());
        let a = solver.identify(&f.centroids, m, &given, &fixed).unwrap();
        let b = solver.identify(&f.centroids, m, &given, &checked).unwrap();
        assert_eq!(a.focal_length_px, None);
        named_fixed += a.matched;
        named_checked += b.matched;
        if let Some(focal) = b.focal_length_px {
            corrected += 1;
            let rel = focal / truth.focal_length_px - 1.0;
            assert!(rel.abs() < 2e-3, "seed {seed}: focal {rel:+.2e} off");
            assert!(b.focal_sigma_px > 0.0 && b.focal_sigma_px < 0.002 * focal);
            assert!(b.matched >= a.matched, "seed {seed}");
            assert!(
                wrong(&b.catalog_index, &f.catalog_index)
                    <= wrong(&a.catalog_index, &f.catalog_index)
            );
        } else {
            assert_eq!(a.catalog_index, b.catalog_index, "seed {seed}");
        }
    }
    // 21 of the 40 frames, 934 -> 1455 stars named when this was written.
    assert!(corrected >= 10, "{corrected} frames corrected");
    assert!(
        named_checked > named_fixed + 300,
        "{named_checked} vs {named_fixed}"
    );
}

#[test]
fn an_unknown_radial_distortion_is_found_with_the_focal_length() {
    // A 20° lens with barrel distortion k1 = −0.2 (11 px at the corners), given as ideal.
    let catalog = bundled();
    let size = 1024.0;
    let ideal = Camera::from_fov(20f64.to_radians(), size, size).unwrap();
    let truth = ideal.with_k1(-0.2).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &ideal).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        ..Default::default()
    };
    let fixed = IdentifyConfig {
        focal_check: false,
        ..Default::default()
    };
    let (mut found, mut named_fixed, mut named_checked, mut real) = (0, 0, 0, 0);
    for seed in 0..30u64 {
        let sim = SimConfig {
            mirrored: seed % 2 == 1,
            ..sim.clone()
        };
        let f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let m = Some(f.magnitudes.as_slice());
        let a = solver.identify(&f.centroids, m, &ideal, &fixed).unwrap();
        let b = solver
            .identify(&f.centroids, m, &ideal, &IdentifyConfig::default())
            .unwrap();
        let wrong = |ids: &[Option<u32>]| {
            ids.iter()
                .zip(&f.catalog_index)
                .filter(|(x, y)| x.is_some() && x != y)
                .count()
        };
        assert_eq!(wrong(&b.catalog_index), 0, "seed {seed}");
        (named_fixed, named_checked) = (named_fixed + a.matched, named_checked + b.matched);
        real += f.real_stars();
        if let Some(k1) = b.k1 {
            found += 1;
            assert!((k1 + 0.2).abs() < 0.05, "seed {seed}: k1 {k1}");
            let focal = b.focal_length_px.expect("set with k1");
            assert!(
                (focal / ideal.focal_length_px - 1.0).abs() < 2e-3,
                "seed {seed}"
            );
        }
    }
    // 27 of 30 frames (k1 within 0.035), 1 102 -> 1 310 of 1 321 stars named when this was
    // written.
    assert!(found >= 20, "{found} frames found k1");
    assert!(named_checked > named_fixed + 100 && 100 * named_checked > 97 * real);
}
