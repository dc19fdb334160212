//! The extractor's noise on frames a pipeline has touched: a background subtracted and clipped
//! at zero, and a noise finer than the converter's step.

use starid_core::extract::{extract, ExtractConfig, Extraction};
use starid_core::simulate::{random_catalog, render, RenderConfig};
use starid_core::{simulate, Camera, SimConfig, SimFrame};

/// A 640 × 480, 12° frame of stars to magnitude 6 rendered with `rc`, and what the extractor
/// finds in it.
fn rendered(rc: &RenderConfig, seed: u64) -> (SimFrame, Vec<f32>, Extraction) {
    let cat = random_catalog(8000, 1.0, 6.5, 3).unwrap();
    let cam = Camera::from_fov(12f64.to_radians(), 640.0, 480.0).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.0),
        ..Default::default()
    };
    let frame = simulate(&cat, &cam, &sim, seed).unwrap();
    let img = render(&frame, &cam, rc, seed).unwrap();
    let ex = extract(&img, 640, 480, &ExtractConfig::default()).unwrap();
    (frame, img, ex)
}

/// Nine in ten of the stars with no other within 8 px and off the border have a spot within
/// 0.5 px, and the spots are in proportion to the stars, not the noise peaks of a threshold
/// at zero.
fn stars_found_without_noise_peaks(frame: &SimFrame, ex: &Extraction) {
    let mut isolated = 0;
    let mut found = 0;
    for p in &frame.centroids {
        let alone = frame
            .centroids
            .iter()
            .all(|q| q == p || (q[0] - p[0]).hypot(q[1] - p[1]) > 8.0);
        if !alone || p[0] < 4.0 || p[1] < 4.0 || p[0] > 636.0 || p[1] > 476.0 {
            continue;
        }
        isolated += 1;
        found += usize::from(
            ex.spots
                .iter()
                .any(|s| (s.x - p[0]).hypot(s.y - p[1]) < 0.5),
        );
    }
    assert!(
        isolated >= 10 && found * 10 >= isolated * 9,
        "{found} of {isolated}"
    );
    assert!(
        ex.spots.len() <= frame.centroids.len() + 10,
        "{} spots for {} stars",
        ex.spots.len(),
        frame.centroids.len()
    );
}

#[test]
fn a_background_clipped_at_zero_is_measured_above_the_clip() {
    // 8 bits, 4 e⁻ a step: sky 400 e⁻ and read noise 10 e⁻ make σ = 22.4 e⁻ = 5.6 DN, and with
    // the sky subtracted before quantisation about half the pixels read 0. The median absolute
    // deviation of such a frame is 0.
    let rc = RenderConfig {
        background_e: 400.0,
        read_noise_e: 10.0,
        gain_e_per_dn: 4.0,
        bits: 8,
        clip_background: true,
        ..Default::default()
    };
    for seed in 0..4 {
        let (frame, img, ex) = rendered(&rc, seed);
        let zeros = img.iter().filter(|&&v| v == 0.0).count() as f64 / img.len() as f64;
        assert!(zeros > 0.4, "{zeros}: the frame is clipped");
        let want = (5.6f64 * 5.6 + 1.0 / 12.0).sqrt();
        assert!(
            (ex.noise_sigma / want - 1.0).abs() < 0.15,
            "σ {} for {want}",
            ex.noise_sigma
        );
        stars_found_without_noise_peaks(&frame, &ex);
    }
}

#[test]
fn a_noise_finer_than_one_step_is_measured_not_rounded_away() {
    // 300 e⁻ a step: sky 9 000 e⁻ (30 DN) with its shot noise of 95 e⁻ is 0.32 DN, so that
    // nearly three pixels in four read the same value and the median absolute deviation is 0.
    let rc = RenderConfig {
        background_e: 9000.0,
        read_noise_e: 1.0,
        gain_e_per_dn: 300.0,
        zero_point_e: 2.0e8,
        full_well_e: 1.0e7,
        ..Default::default()
    };
    for seed in 0..4 {
        let (frame, _, ex) = rendered(&rc, seed);
        // The quantised noise: the sensor's 0.32 DN and the step's 1/12.
        assert!(
            ex.noise_sigma > 0.3 && ex.noise_sigma < 0.55,
            "σ {}",
            ex.noise_sigma
        );
        stars_found_without_noise_peaks(&frame, &ex);
    }
}
