//! Identification with an unknown focal length: simulated frames with fields of view drawn in
//! 8°–25°, identified with only that range known.

use rand::{Rng, SeedableRng};
use starid_core::simulate::{simulate, SimConfig};
use starid_core::{Camera, ErrorKind, IdentifyConfig, Solver};

use super::strategies::bundled;

#[test]
fn unknown_fields_of_view_are_identified_with_their_focal_length() {
    let catalog = bundled();
    let size = 1024.0;
    let widest = Camera::from_fov(25f64.to_radians(), size, size).unwrap();
    let narrowest = Camera::from_fov(8f64.to_radians(), size, size).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &widest).unwrap();
    let range = (widest.focal_length_px, narrowest.focal_length_px);
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let (mut frames, mut identified) = (0, 0);
    for seed in 0..40u64 {
        let fov: f64 = rng.random_range(8.0..25.0);
        let camera = Camera::from_fov(fov.to_radians(), size, size).unwrap();
        let sim = SimConfig {
            noise_px: 0.2,
            mirrored: seed % 3 == 0,
            ..Default::default()
        };
        let f = simulate(&catalog, &camera, &sim, seed).unwrap();
        if f.real_stars() < 4 {
            continue;
        }
        frames += 1;
        let r = solver
            .identify_unknown_focal(
                &f.centroids,
                None,
                size,
                size,
                range,
                &IdentifyConfig::default(),
            )
            .unwrap();
        let id = &r.identification;
        if !id.is_identified() {
            continue;
        }
        identified += 1;
        assert_eq!(id.mirrored, sim.mirrored, "seed {seed}");
        for (got, want) in id.catalog_index.iter().zip(&f.catalog_index) {
            if got.is_some() {
                assert_eq!(got, want, "seed {seed}: wrong id");
            }
        }
        let est = r.camera.unwrap().focal_length_px;
        assert!(
            ((est - camera.focal_length_px) / camera.focal_length_px).abs() < 1e-3,
            "seed {seed}: focal {est} vs {}",
            camera.focal_length_px
        );
        let fit = r.fit.unwrap();
        assert!(fit.focal_sigma_px() / est < 5e-4);
        assert!(id.false_match_probability <= 1e-3);
    }
    assert!(identified >= frames - 1, "{identified} of {frames}");
}

#[test]
fn unknown_focal_rejects_bad_ranges() {
    let catalog = bundled();
    let widest = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    let solver = Solver::for_camera(catalog, &widest).unwrap();
    let xy = [[10.0, 10.0], [100.0, 40.0], [300.0, 200.0], [400.0, 500.0]];
    let cfg = IdentifyConfig::default();
    for range in [(0.0, 100.0), (3000.0, 2000.0), (f64::NAN, 3000.0)] {
        let e = solver
            .identify_unknown_focal(&xy, None, 512.0, 512.0, range, &cfg)
            .unwrap_err();
        assert_eq!(e.kind(), &ErrorKind::InvalidInput);
    }
    // A range wider than the index covers is refused, not silently searched in part.
    let f_wide = Camera::from_fov(30f64.to_radians(), 512.0, 512.0)
        .unwrap()
        .focal_length_px;
    assert!(solver
        .identify_unknown_focal(&xy, None, 512.0, 512.0, (f_wide, 3000.0), &cfg)
        .is_err());
}

#[test]
fn a_focal_length_chosen_to_fit_a_triangle_counts_every_triangle_tried() {
    // A field of view known to ±10 % and a handful of random points: the search within the
    // tolerance picks a focal length that fits some catalogue triangle, and its identification
    // there must not count that focal length as one hypothesis. These five points were once
    // named five stars with a bound of 1.7e-6.
    let catalog = bundled();
    let camera = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    let solver = Solver::for_camera(catalog, &camera).unwrap();
    let config = IdentifyConfig::default();
    let points = [
        [0.0, 0.0],
        [0.0, 363.0],
        [18.0, 457.0],
        [231.0, 470.0],
        [305.0, 416.0],
    ];
    let id = solver.identify(&points, None, &camera, &config).unwrap();
    assert!(!id.is_identified(), "P = {}", id.false_match_probability);
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    for _ in 0..60 {
        let n = rng.random_range(4..=12);
        let points: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.random_range(0.0..512.0), rng.random_range(0.0..512.0)])
            .collect();
        let id = solver.identify(&points, None, &camera, &config).unwrap();
        assert!(!id.is_identified(), "{points:?}");
    }
}

#[test]
fn a_frame_whose_brightest_spots_are_stars_is_found_beside_a_cluster_of_false_spots() {
    // A 6° frame whose four brightest spots are stars (two of them within 300 px), and six spots
    // that are not stars crowded within 150 px (a nebula's knots, a planet's glare), as bright as
    // its fifth to eighth stars. The cluster holds the short bases, whose triangles take the
    // budget (4 of these 12 frames found without the four brightest spots' triangles first).
    let catalog =
        std::sync::Arc::new(starid_core::simulate::random_catalog(30_000, 1.0, 7.0, 3).unwrap());
    let (w, h) = (1392.0, 1040.0);
    let widest = Camera::from_fov(8f64.to_radians(), w, h).unwrap();
    let narrowest = Camera::from_fov(4f64.to_radians(), w, h).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &widest).unwrap();
    let range = (widest.focal_length_px, narrowest.focal_length_px);
    let camera = Camera::from_fov(6f64.to_radians(), w, h).unwrap();
    let config = IdentifyConfig {
        max_pairs_visited: 100_000,
        ..IdentifyConfig::default()
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let (mut frames, mut identified) = (0, 0);
    for seed in 0..200u64 {
        if frames == 12 {
            break;
        }
        let sim = SimConfig {
            noise_px: 0.3,
            mag_limit: Some(7.0),
            ..Default::default()
        };
        let f = simulate(&catalog, &camera, &sim, seed).unwrap();
        let mut order: Vec<usize> = (0..f.centroids.len()).collect();
        order.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
        // Two of the four brightest stars within 300 px: a base the budget affords.
        let near = |a: usize, b: usize| {
            let (p, q) = (f.centroids[order[a]], f.centroids[order[b]]);
            (p[0] - q[0]).hypot(p[1] - q[1]) < 300.0
        };
        if order.len() < 5 || !(0..4).any(|a| (a + 1..4).any(|b| near(a, b))) {
            continue;
        }
        frames += 1;
        let (m4, m8) = (
            f.magnitudes[order[3]],
            f.magnitudes[order[7.min(order.len() - 1)]],
        );
        let mut xy = f.centroids.clone();
        let mut mags = f.magnitudes.clone();
        let mut truth = f.catalog_index.clone();
        let centre = [
            rng.random_range(200.0..w - 200.0),
            rng.random_range(200.0..h - 200.0),
        ];
        for k in 0..6 {
            xy.push([
                centre[0] + rng.random_range(-75.0..75.0),
                centre[1] + rng.random_range(-75.0..75.0),
            ]);
            mags.push(m4 + (m8 - m4) * (k as f64 + 0.5) / 6.0);
            truth.push(None);
        }
        let r = solver
            .identify_unknown_focal(&xy, Some(&mags), w, h, range, &config)
            .unwrap();
        let id = &r.identification;
        for (got, want) in id.catalog_index.iter().zip(&truth) {
            assert!(
                got.is_none() || got == want,
                "seed {seed}: {got:?} for {want:?}"
            );
        }
        identified += usize::from(id.is_identified());
    }
    assert!(frames == 12 && identified >= 9, "{identified} of {frames}");
}
