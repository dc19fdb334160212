//! Tests of extraction on simulated images.

use super::*;
use crate::simulate::{random_catalog, render, simulate, RenderConfig, SimConfig};
use crate::{Camera, IdentifyConfig, Solver};

#[test]
fn rendered_frames_are_extracted_and_identified() {
    let cat = std::sync::Arc::new(random_catalog(8000, 1.0, 6.5, 4).unwrap());
    let cam = Camera::from_fov(12f64.to_radians(), 640.0, 480.0).unwrap();
    let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    let (mut found, mut truth, mut ok, mut hot_reported) = (0, 0, 0, 0);
    let mut err2 = 0.0;
    for seed in 0..10 {
        let frame = simulate(
            &cat,
            &cam,
            &SimConfig {
                mag_limit: Some(6.0),
                ..Default::default()
            },
            seed,
        )
        .unwrap();
        let rc = RenderConfig {
            gradient_e: 150.0,
            hot_pixels: 20,
            trail: Some(([30.0, 400.0, 600.0, 350.0], 400.0)),
            ..Default::default()
        };
        let img = render(&frame, &cam, &rc, seed).unwrap();
        let ex = extract(&img, 640, 480, &ExtractConfig::default()).unwrap();
        // Each isolated star (no other within 8 px, off the trail and the border) found within
        // 0.3 px; blends are not split (no deblending yet) and a star on the trail goes with it.
        let trail_dist = |p: &[f64; 2]| {
            let (ax, ay, bx, by) = (30.0, 400.0, 600.0, 350.0);
            let t = (((p[0] - ax) * (bx - ax) + (p[1] - ay) * (by - ay))
                / ((bx - ax).powi(2) + (by - ay).powi(2)))
            .clamp(0.0, 1.0);
            (p[0] - ax - t * (bx - ax)).hypot(p[1] - ay - t * (by - ay))
        };
        for p in &frame.centroids {
            let isolated = frame
                .centroids
                .iter()
                .all(|q| q == p || (q[0] - p[0]).hypot(q[1] - p[1]) > 8.0)
                && trail_dist(p) > 6.0
                && p[0] > 3.0
                && p[1] > 3.0
                && p[0] < 637.0
                && p[1] < 477.0;
            if !isolated {
                continue;
            }
            truth += 1;
            let near = ex
                .spots
                .iter()
                .map(|s| (s.x - p[0]).hypot(s.y - p[1]))
                .fold(f64::INFINITY, f64::min);
            if near < 0.3 {
                found += 1;
                err2 += near * near;
            } else if std::env::var("STARID_DEBUG").is_ok() {
                eprintln!(
                    "missed ({:.1}, {:.1}): nearest spot {near:.2} px; dropped {}",
                    p[0], p[1], ex.dropped
                );
            }
        }
        // Spurious spots: far from every star and off the trail (hot pixels, noise).
        hot_reported += ex
            .spots
            .iter()
            .filter(|s| {
                trail_dist(&[s.x, s.y]) > 6.0
                    && frame
                        .centroids
                        .iter()
                        .all(|p| (p[0] - s.x).hypot(p[1] - s.y) > 3.0)
            })
            .count();
        let xy: Vec<[f64; 2]> = ex.spots.iter().map(|s| [s.x, s.y]).collect();
        let mags: Vec<f64> = ex.spots.iter().map(Spot::magnitude).collect();
        let cfg = IdentifyConfig {
            mag_offset: None,
            ..Default::default()
        };
        let id = solver.identify(&xy, Some(&mags), &cam, &cfg).unwrap();
        ok += usize::from(id.is_identified());
    }
    assert!(found as f64 >= 0.99 * truth as f64, "{found} of {truth}");
    assert!(
        (err2 / found as f64).sqrt() < 0.1,
        "rms {}",
        (err2 / found as f64).sqrt()
    );
    // 20 hot pixels a frame, none reported; at most 1 spurious spot per megapixel.
    assert!(
        hot_reported <= 3,
        "{hot_reported} spurious spots in 3.1 megapixels"
    );
    assert_eq!(ok, 10);
}

#[test]
fn spots_on_a_lit_foreground_are_flagged_cluttered_and_stars_on_the_sky_are_not() {
    let cat = random_catalog(20_000, 1.0, 8.0, 5).unwrap();
    let cam = Camera::from_fov(10f64.to_radians(), 800.0, 600.0).unwrap();
    // An 8-bit photograph whose right third is lit branches (the edge wanders between 60 %
    // and 80 % of the width).
    let rc = RenderConfig {
        foreground: 0.3,
        bits: 8,
        gain_e_per_dn: 8.0,
        background_e: 300.0,
        zero_point_e: 2e7,
        ..Default::default()
    };
    let config = ExtractConfig {
        drop_flagged: false,
        ..Default::default()
    };
    let (mut sky, mut branches, mut branches_flagged) = (0, 0, 0);
    for seed in 0..4 {
        let sim = SimConfig {
            mag_limit: Some(7.5),
            ..Default::default()
        };
        let frame = simulate(&cat, &cam, &sim, seed).unwrap();
        let img = render(&frame, &cam, &rc, seed).unwrap();
        let ex = extract(&img, 800, 600, &config).unwrap();
        for s in &ex.spots {
            let cluttered = s.flags & flags::CLUTTERED != 0;
            if s.x < 0.6 * 800.0 {
                assert!(!cluttered, "a spot on the sky flagged: {s:?}");
                sky += 1;
            } else if s.x > 0.85 * 800.0 {
                branches += 1;
                branches_flagged += usize::from(cluttered);
            }
        }
        // Dropped by default.
        let kept = extract(&img, 800, 600, &ExtractConfig::default()).unwrap();
        assert!(kept.spots.iter().all(|s| s.flags & flags::CLUTTERED == 0));
        assert_eq!(kept.dropped + kept.spots.len(), ex.spots.len());
    }
    assert!(sky >= 20, "{sky} stars on the sky");
    assert!(branches >= 100, "{branches} spots on the branches");
    assert!(
        branches_flagged * 100 >= 95 * branches,
        "{branches_flagged} of {branches} flagged"
    );
}

#[test]
fn flat_and_noise_images_give_no_spots() {
    let flat = vec![1000u16; 100 * 80];
    assert!(extract(&flat, 100, 80, &ExtractConfig::default())
        .unwrap()
        .spots
        .is_empty());
    assert!(extract(&flat, 100, 81, &ExtractConfig::default()).is_err());
    let nan = vec![f32::NAN; 9];
    assert!(extract(&nan, 3, 3, &ExtractConfig::default()).is_err());
}

#[test]
fn centroids_of_noise_at_a_low_threshold_stay_on_the_image() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let (w, h) = (400usize, 300usize);
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let noise = Normal::new(1000.0f32, 20.0).unwrap();
    let img: Vec<f32> = (0..w * h).map(|_| noise.sample(&mut rng)).collect();
    for threshold_sigma in [1.0, 1.5, 2.0, 3.0] {
        let cfg = ExtractConfig {
            threshold_sigma,
            max_spots: 1_000_000,
            ..ExtractConfig::default()
        };
        let spots = extract(&img, w, h, &cfg).unwrap().spots;
        assert!(!spots.is_empty());
        for s in &spots {
            assert!(
                (0.0..=w as f64).contains(&s.x) && (0.0..=h as f64).contains(&s.y),
                "{threshold_sigma} sigma: a spot at ({}, {})",
                s.x,
                s.y
            );
        }
    }
}

#[test]
fn a_close_double_is_split() {
    let (w, h) = (60usize, 50usize);
    let mut img = vec![100.0f32; w * h];
    for (k, p) in img.iter_mut().enumerate() {
        *p += ((k * 2654435761) % 7) as f32 * 0.5;
    }
    // Two stars 4.5 px apart (PSF σ 1.1 px): one blob above the threshold, two peaks.
    let stars = [(25.3, 24.6, 2000.0), (29.6, 25.9, 1400.0)];
    for j in 0..h {
        for i in 0..w {
            for &(x, y, a) in &stars {
                let (dx, dy) = (i as f64 + 0.5 - x, j as f64 + 0.5 - y);
                img[j * w + i] += (a * (-(dx * dx + dy * dy) / (2.0 * 1.21)).exp()) as f32;
            }
        }
    }
    let ex = extract(&img, w, h, &ExtractConfig::default()).unwrap();
    assert_eq!(ex.spots.len(), 2, "{:?}", ex.spots);
    for (s, &(x, y, _)) in ex.spots.iter().zip(&stars) {
        assert!(s.flags & flags::DEBLENDED != 0);
        assert!((s.x - x).hypot(s.y - y) < 0.3, "{s:?} vs ({x}, {y})");
    }
    let whole = extract(
        &img,
        w,
        h,
        &ExtractConfig {
            deblend: false,
            drop_flagged: false,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(whole.spots.len(), 1);
}

#[test]
fn flipping_the_image_flips_the_centroids() {
    let (w, h) = (50usize, 40usize);
    let mut img = vec![10.0f32; w * h];
    for (k, p) in img.iter_mut().enumerate() {
        *p += ((k * 2654435761) % 7) as f32 * 0.2;
    }
    for j in 0..h {
        for i in 0..w {
            let (dx, dy) = (i as f64 + 0.5 - 12.7, j as f64 + 0.5 - 25.2);
            img[j * w + i] += (300.0 * (-(dx * dx + dy * dy) / 2.0).exp()) as f32;
        }
    }
    let mut flipped = vec![0.0f32; w * h];
    for j in 0..h {
        for i in 0..w {
            flipped[j * w + (w - 1 - i)] = img[j * w + i];
        }
    }
    let a = extract(&img, w, h, &ExtractConfig::default())
        .unwrap()
        .spots[0];
    let b = extract(&flipped, w, h, &ExtractConfig::default())
        .unwrap()
        .spots[0];
    assert!((a.x + b.x - w as f64).abs() < 1e-3 && (a.y - b.y).abs() < 1e-3);
}
