//! Camera calibration: recovery of known intrinsics from simulated frames, outlier rejection,
//! the round trip of the full distortion model.

use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use starid_core::calibrate::{calibrate, CalibrationConfig, CalibrationFrame};
use starid_core::{simulate, Camera, ErrorKind, SimConfig};

use super::strategies::{bundled, config};

/// `n` frames of `truth` with 0.2 px noise, matched to their true stars; each starting attitude
/// the truth turned by about 0.1°, as an identification with the nominal camera would give.
fn frames(truth: &Camera, n: u64, seed: u64) -> Vec<CalibrationFrame> {
    let cat = bundled();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let sim = SimConfig {
        noise_px: 0.2,
        ..Default::default()
    };
    (0..n)
        .map(|k| {
            let f = simulate(&cat, truth, &sim, seed * 1000 + k).expect("frame");
            let (pixels, stars) = f
                .centroids
                .iter()
                .zip(&f.catalog_index)
                .filter_map(|(c, i)| i.map(|i| (*c, cat.vectors()[i as usize])))
                .unzip();
            let turn = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            CalibrationFrame {
                pixels,
                stars,
                attitude: Rotation3::new(turn * 2e-3) * f.r_icrs_to_cam,
                mirrored: false,
            }
        })
        .collect()
}

/// The 1σ of a fitted intrinsic by name.
fn sigma(cal: &starid_core::calibrate::Calibration, name: &str) -> f64 {
    let k = cal
        .intrinsics
        .iter()
        .position(|p| p.name() == name)
        .expect("fitted");
    cal.sigmas()[k]
}

fn lens(fov_deg: f64, offset: [f64; 2], k1: f64, k2: f64, p: [f64; 2]) -> (Camera, Camera) {
    let nominal = Camera::from_fov(fov_deg.to_radians(), 1280.0, 1024.0).expect("camera");
    let truth = nominal
        .with_principal_point(640.0 + offset[0], 512.0 + offset[1])
        .and_then(|c| c.with_k1(k1))
        .and_then(|c| c.with_higher_distortion([k2, 0.0, p[0], p[1]]))
        .expect("lens");
    (nominal, truth)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: std::env::var("STARID_PROPTEST_CASES").map_or(8, |_| config().cases), ..config() })]

    /// Any wide lens: the fitted intrinsics lie within a few of their own σ of the truth, and the
    /// residuals are the centroid noise.
    #[test]
    fn recovers_known_intrinsics(
        fov in 20.0..60.0f64,
        dx in -20.0..20.0f64,
        dy in -20.0..20.0f64,
        k1 in -0.2..0.05f64,
        p1 in -1e-3..1e-3f64,
        p2 in -1e-3..1e-3f64,
        seed in 1u64..1000,
    ) {
        let (nominal, truth) = lens(fov, [dx, dy], k1, 0.0, [p1, p2]);
        let fs = frames(&truth, 12, seed);
        let model = CalibrationConfig { radial_terms: Some(1), decentering: Some(true), principal_point: Some(true), ..Default::default() };
        let cal = calibrate(&fs, &nominal, &model).expect("calibration");
        let c = &cal.camera;
        let got = [c.focal_length_px, c.principal_point_px[0], c.principal_point_px[1], c.k1, c.p1, c.p2];
        let want = [truth.focal_length_px, truth.principal_point_px[0], truth.principal_point_px[1], truth.k1, truth.p1, truth.p2];
        for ((g, w), (s, p)) in got.iter().zip(&want).zip(cal.sigmas().iter().zip(&cal.intrinsics)) {
            prop_assert!((g - w).abs() <= 5.0 * s, "{p:?}: {g} vs {w} (1σ {s})");
        }
        prop_assert!((c.focal_length_px / truth.focal_length_px - 1.0).abs() < 2e-4);
        prop_assert!((0.18..0.21).contains(&cal.rms_px), "rms {}", cal.rms_px);
        prop_assert!(cal.rms_before_px >= cal.rms_px);
    }
}

#[test]
fn wrong_matches_are_clipped_and_do_not_bend_the_fit() {
    let (nominal, truth) = lens(40.0, [12.0, -9.0], -0.15, 0.02, [4e-4, -2e-4]);
    let mut fs = frames(&truth, 12, 7);
    // One match in 20 given a wrong star: the next one's.
    let mut planted = 0;
    for f in &mut fs {
        let n = f.stars.len();
        for i in (0..n).step_by(20) {
            f.stars[i] = f.stars[(i + 1) % n];
            planted += 1;
        }
    }
    let cal = calibrate(&fs, &nominal, &CalibrationConfig::default()).expect("calibration");
    let clipped: usize = cal.n_clipped();
    assert!(clipped >= planted, "{clipped} clipped of {planted} planted");
    assert!(
        clipped <= planted + planted / 2 + 10,
        "{clipped} clipped of {planted} planted"
    );
    // Every planted match is among the clipped.
    for f in &cal.inliers {
        for i in (0..f.len()).step_by(20) {
            assert!(!f[i]);
        }
    }
    let c = &cal.camera;
    assert!((c.focal_length_px / truth.focal_length_px - 1.0).abs() < 2e-4);
    assert!((c.k1 - truth.k1).abs() < 5.0 * sigma(&cal, "k1"));
    assert!((cal.rms_px - 0.2).abs() < 0.01, "rms {}", cal.rms_px);
}

#[test]
fn a_narrow_lens_leaves_out_the_terms_it_cannot_fix() {
    let (nominal, truth) = lens(20.0, [5.0, 5.0], -0.1, 0.0, [0.0, 0.0]);
    let fs = frames(&truth, 10, 3);
    let cal = calibrate(&fs, &nominal, &CalibrationConfig::default()).expect("calibration");
    let names: Vec<&str> = cal.intrinsics.iter().map(|p| p.name()).collect();
    assert!(!names.contains(&"k3"), "{names:?}");
    assert_eq!(cal.camera.k3, 0.0);
    assert!((cal.camera.k1 - truth.k1).abs() < 5.0 * sigma(&cal, "k1"));
}

#[test]
fn mirrored_frames_calibrate_like_the_others() {
    let (nominal, truth) = lens(30.0, [10.0, 0.0], -0.1, 0.0, [0.0, 0.0]);
    let mut fs = frames(&truth, 8, 11);
    for f in &mut fs {
        f.mirrored = true;
        for p in &mut f.pixels {
            p[0] = 1280.0 - p[0];
        }
    }
    let model = CalibrationConfig {
        radial_terms: Some(1),
        decentering: Some(false),
        ..Default::default()
    };
    let cal = calibrate(&fs, &nominal, &model).expect("calibration");
    assert!(
        (cal.camera.principal_point_px[0] - truth.principal_point_px[0]).abs()
            < 5.0 * cal.sigmas()[1]
    );
    assert!((cal.rms_px - 0.2).abs() < 0.02);
}

#[test]
fn bad_input_is_refused_by_name() {
    let nominal = Camera::from_fov(0.5, 1000.0, 1000.0).expect("camera");
    let none = calibrate(&[], &nominal, &CalibrationConfig::default()).unwrap_err();
    assert_eq!(none.kind(), &ErrorKind::InvalidInput);
    let short = CalibrationFrame {
        pixels: vec![[1.0, 2.0]],
        stars: vec![],
        attitude: Rotation3::identity(),
        mirrored: false,
    };
    let e = calibrate(&[short], &nominal, &CalibrationConfig::default()).unwrap_err();
    assert!(e.to_string().contains("1 pixels but 0 stars"), "{e}");
    let few = CalibrationFrame {
        pixels: vec![[500.0, 500.0]; 3],
        stars: vec![Vector3::z(); 3],
        attitude: Rotation3::identity(),
        mirrored: false,
    };
    let e = calibrate(&[few], &nominal, &CalibrationConfig::default()).unwrap_err();
    assert!(e.to_string().contains("cannot fix"), "{e}");
    let bad = CalibrationConfig {
        radial_terms: Some(4),
        ..Default::default()
    };
    assert!(calibrate(&[], &nominal, &bad)
        .unwrap_err()
        .to_string()
        .contains("radial_terms"));
}

#[test]
fn the_full_model_round_trips_pixels() {
    let (_, truth) = lens(60.0, [14.0, -14.0], -0.2, 0.04, [-8e-4, 6e-4]);
    let truth = truth
        .with_higher_distortion([0.04, -0.005, -8e-4, 6e-4])
        .expect("lens");
    for &(x, y) in &[(0.0, 0.0), (1280.0, 1024.0), (640.0, 10.0), (3.0, 900.0)] {
        let v = truth.pixel_to_cam(x, y, false);
        let (bx, by) = truth.cam_to_pixel(&v).expect("in front");
        assert!(
            (bx - x).abs() < 1e-8 && (by - y).abs() < 1e-8,
            "{x},{y} -> {bx},{by}"
        );
    }
}
