//! Tracking measurements against their targets, bundled catalogue, single thread:
//!
//! 1. Hinted identification of 12°/512 px frames (mag 6, 0.2 px, magnitudes) from a hint up to
//!    1° off with a 1° uncertainty, against lost in space on the same frames: medians, p99.
//! 2. A deliberately wrong hint (10° off, 1° uncertainty, no fallback): identified, wrong ids.
//! 3. Frames with only 2 or 3 real stars among false spots, hint within its 0.1° uncertainty,
//!    and the same frames with the hint 1° off (outside it): identified, wrong ids.
//! 4. Sequences at 10 Hz, rates 0.1–5°/s, 0.5 px noise (plus smear over 20 ms), 0–40 false spots
//!    with catalogue-like magnitudes: frames identified, in tracking mode, wrong ids, time; and
//!    after 10 blank frames, the frames until lock is regained.
//!
//! `cargo run --release --example tracking -- [FRAMES_PER_CASE] [SEQUENCE_FRAMES_PER_RATE]`
//! (`STARID_CONFIRM=1`: sequences with `TrackerConfig::confirm_new_stars`; `STARID_UNSEEN=K`: with
//! `confirm_unseen_frames` K, 0 for off; `STARID_SEQ_SEED=N`: another set of sequences;
//! `STARID_MAG_ZERO=Z`: the sequences' magnitudes Z mag off the catalogue's system (an
//! instrument's), learned by the tracker unless `STARID_NO_LEARN=1`;
//! `STARID_SEQ_ORDER=1`: the sequences' spots brightest first, without magnitudes;
//! `STARID_WIDE=1`: a 20°/1024 px camera; `STARID_PAIRS=1`: count the stars named that have another
//! of mag ≤ 6 under 0.75 px away, right and wrong;
//! `STARID_WRONG=1`: list the wrong ids; `STARID_MISSED=1`: the real stars left unnamed, with where the
//! solution puts their star; `STARID_REPEAT=R`: part 1 times each frame R more times and keeps its
//! fastest; `STARID_PART1_ONLY=1`: stop after the hinted timing, for
//! profiling).
#![allow(clippy::print_stdout)]

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{Rotation3, Unit, Vector3};
use rand::{Rng, SeedableRng};
use starid_core::simulate::{simulate_sequence, SequenceConfig};
use starid_core::tracking::{TrackMode, Tracker, TrackerConfig};
use starid_core::{
    simulate, AttitudeHint, Camera, Catalog, FalseStarMags, HintFallback, Identification,
    IdentifyConfig, SimConfig, SimFrame, Solver,
};

fn pct(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 - 1.0) * q).round() as usize]
}

/// Wrong ids of an identification against the truth.
fn wrong(id: &Identification, f: &SimFrame) -> usize {
    id.catalog_index
        .iter()
        .zip(&f.catalog_index)
        .filter(|(a, b)| a.is_some() && a != b)
        .count()
}

/// The frame's spots brightest first (its truth in the same order).
fn brightest_first(f: &SimFrame) -> SimFrame {
    let mut order: Vec<usize> = (0..f.centroids.len()).collect();
    order.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
    SimFrame {
        centroids: order.iter().map(|&k| f.centroids[k]).collect(),
        magnitudes: order.iter().map(|&k| f.magnitudes[k]).collect(),
        catalog_index: order.iter().map(|&k| f.catalog_index[k]).collect(),
        ..f.clone()
    }
}

fn offset(rng: &mut impl Rng, angle: f64) -> Rotation3<f64> {
    let axis = Unit::new_normalize(Vector3::from_fn(|_, _| rng.random::<f64>() - 0.5));
    Rotation3::from_axis_angle(&axis, angle)
}

/// `f` identified from `hint` alone (no fallback to lost in space).
fn from_hint(
    solver: &Solver,
    f: &SimFrame,
    cam: &Camera,
    cfg: &IdentifyConfig,
    hint: &AttitudeHint,
) -> Identification {
    solver
        .identify_hinted(
            &f.centroids,
            Some(&f.magnitudes),
            cam,
            cfg,
            hint,
            HintFallback::None,
        )
        .unwrap()
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("N"))
        .collect();
    let n_frames = args.first().copied().unwrap_or(2000);
    let seq_frames = args.get(1).copied().unwrap_or(2000);
    let catalog = Arc::new(Catalog::bundled());
    // STARID_WIDE=1: a 20°/1024 px camera instead of 12°/512 px.
    let cam = if std::env::var("STARID_WIDE").is_ok() {
        Camera::from_fov(20f64.to_radians(), 1024.0, 1024.0)
    } else {
        Camera::from_fov(12f64.to_radians(), 512.0, 512.0)
    }
    .expect("camera");
    let solver = Solver::for_camera(catalog.clone(), &cam).expect("solver");
    let cfg = IdentifyConfig::default();
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);

    // 1. Hinted vs lost in space.
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        mag_noise: 0.1,
        ..Default::default()
    };
    let frames: Vec<SimFrame> = (0..)
        .map(|s| simulate(&catalog, &cam, &sim, s).expect("frame"))
        .filter(|f| f.real_stars() >= 4)
        .take(n_frames)
        .collect();
    // Each frame's hint: up to 1° off, 1° uncertainty.
    let hints: Vec<AttitudeHint> = frames
        .iter()
        .map(|f| {
            let angle = 1f64.to_radians() * rng.random::<f64>();
            AttitudeHint {
                r_icrs_to_cam: offset(&mut rng, angle) * f.r_icrs_to_cam,
                uncertainty_rad: 1f64.to_radians(),
                mirrored: Some(f.mirrored),
            }
        })
        .collect();
    let lis = |f: &SimFrame| {
        solver
            .identify(&f.centroids, Some(&f.magnitudes), &cam, &cfg)
            .unwrap()
    };
    let hinted_call = |f: &SimFrame, hint: &AttitudeHint| {
        solver
            .identify_hinted(
                &f.centroids,
                Some(&f.magnitudes),
                &cam,
                &cfg,
                hint,
                HintFallback::LostInSpace,
            )
            .unwrap()
    };
    let (mut t_lis, mut t_hint) = (Vec::new(), Vec::new());
    let (mut ok_lis, mut ok_hint, mut hinted, mut wrong_hint) = (0, 0, 0, 0);
    for (f, hint) in frames.iter().zip(&hints) {
        let t = Instant::now();
        let a = lis(f);
        t_lis.push(t.elapsed().as_secs_f64());
        ok_lis += usize::from(a.is_identified());
        let t = Instant::now();
        let b = hinted_call(f, hint);
        t_hint.push(t.elapsed().as_secs_f64());
        ok_hint += usize::from(b.is_identified());
        hinted += usize::from(b.hinted);
        wrong_hint += wrong(&b, f);
    }
    // STARID_REPEAT=R: each frame's calls timed R more times, keeping each frame's fastest (a
    // steadier figure of the work than one pass on a shared machine), interleaved.
    let repeat: usize =
        std::env::var("STARID_REPEAT").map_or(0, |v| v.parse().expect("STARID_REPEAT"));
    for _ in 0..repeat {
        for (k, (f, hint)) in frames.iter().zip(&hints).enumerate() {
            let t = Instant::now();
            let _ = lis(f);
            t_lis[k] = t_lis[k].min(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let _ = hinted_call(f, hint);
            t_hint[k] = t_hint[k].min(t.elapsed().as_secs_f64());
        }
    }
    let (ml, mh) = (pct(&mut t_lis, 0.5), pct(&mut t_hint, 0.5));
    println!(
        "1. 12°/512 px, {} frames, hint ≤ 1° off, uncertainty 1°: lost in space {ok_lis} identified, median {:.2} µs p99 {:.1} µs; hinted {ok_hint} identified ({hinted} by the hint), {wrong_hint} wrong ids, median {:.2} µs p99 {:.1} µs; speed-up {:.1}×",
        frames.len(),
        ml * 1e6,
        pct(&mut t_lis, 0.99) * 1e6,
        mh * 1e6,
        pct(&mut t_hint, 0.99) * 1e6,
        ml / mh
    );

    if std::env::var("STARID_PART1_ONLY").is_ok() {
        return;
    }

    // 2. A wrong hint.
    let (mut ok, mut bad) = (0, 0);
    for f in &frames {
        let hint = AttitudeHint {
            r_icrs_to_cam: offset(&mut rng, 10f64.to_radians()) * f.r_icrs_to_cam,
            uncertainty_rad: 1f64.to_radians(),
            mirrored: Some(f.mirrored),
        };
        let b = from_hint(&solver, f, &cam, &cfg, &hint);
        ok += usize::from(b.is_identified());
        bad += wrong(&b, f);
        if b.is_identified() && std::env::var("STARID_DEBUG").is_ok() {
            println!("  wrong-hint solution: matched {} of {} spots, bound {:.2e}, radius {:.1}\", sigma {:.2} px, hypotheses {}, wrong {}", b.matched, f.centroids.len(), b.false_match_probability, b.match_radius_rad.to_degrees() * 3600.0, b.centroid_sigma_px, b.hypotheses, wrong(&b, f));
        }
    }
    println!(
        "2. hint 10° off, uncertainty 1°, no fallback: {ok} of {} identified, {bad} wrong ids",
        frames.len()
    );

    // 3. Two or three real stars among false spots.
    for real in [2usize, 3] {
        let sim = SimConfig {
            mag_limit: Some(6.0),
            noise_px: 0.3,
            mag_noise: 0.1,
            false_stars: 10,
            false_star_mags: FalseStarMags::FromCatalog,
            ..Default::default()
        };
        let mut few: Vec<SimFrame> = Vec::new();
        let mut seed = 1_000_000u64;
        while few.len() < n_frames / 4 {
            let mut f = simulate(&catalog, &cam, &sim, seed).expect("frame");
            seed += 1;
            // Keep `real` real stars (the brightest), drop the others.
            let mut reals: Vec<usize> = (0..f.centroids.len())
                .filter(|&i| f.catalog_index[i].is_some())
                .collect();
            if reals.len() < real {
                continue;
            }
            reals.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
            let keep: Vec<usize> = (0..f.centroids.len())
                .filter(|i| f.catalog_index[*i].is_none() || reals[..real].contains(i))
                .collect();
            f.centroids = keep.iter().map(|&i| f.centroids[i]).collect();
            f.magnitudes = keep.iter().map(|&i| f.magnitudes[i]).collect();
            f.catalog_index = keep.iter().map(|&i| f.catalog_index[i]).collect();
            few.push(f);
        }
        let (mut ok_in, mut bad_in, mut ok_out, mut bad_out) = (0, 0, 0, 0);
        for f in &few {
            let good = AttitudeHint {
                r_icrs_to_cam: offset(&mut rng, 0.05f64.to_radians()) * f.r_icrs_to_cam,
                uncertainty_rad: 0.1f64.to_radians(),
                mirrored: Some(f.mirrored),
            };
            let a = from_hint(&solver, f, &cam, &cfg, &good);
            ok_in += usize::from(a.is_identified());
            bad_in += wrong(&a, f);
            if std::env::var("STARID_WRONG").is_ok() && wrong(&a, f) > 0 {
                for (o, (got, want)) in a.catalog_index.iter().zip(&f.catalog_index).enumerate() {
                    if got.is_some() && got != want {
                        let star = got.unwrap() as usize;
                        let tv = cam.cam_to_pixel(&(f.r_icrs_to_cam * catalog.vectors()[star]));
                        println!("  wrong: {real}-star frame, spot {o} at {:?} truth {want:?} got {star} (mag {:.2}, truly at {tv:?}) spot mag {:.2} residual {:.1}\" radius {:.1}\" matched {} of {} spots, bound {:.1e}", f.centroids[o], catalog.mag()[star], f.magnitudes[o], a.residuals_rad[o].to_degrees() * 3600.0, a.match_radius_rad.to_degrees() * 3600.0, a.matched, f.centroids.len(), a.false_match_probability);
                    }
                }
            }
            let off = AttitudeHint {
                r_icrs_to_cam: offset(&mut rng, 1f64.to_radians()) * f.r_icrs_to_cam,
                ..good
            };
            let b = from_hint(&solver, f, &cam, &cfg, &off);
            ok_out += usize::from(b.is_identified());
            bad_out += wrong(&b, f);
        }
        println!(
            "3. {real} real stars + 10 false, hint ≤ 0.05° off (uncertainty 0.1°): {ok_in}/{} identified, {bad_in} wrong ids; hint 1° off: {ok_out} identified, {bad_out} wrong ids",
            few.len()
        );
    }

    // 4. Sequences.
    let mut all_frames = 0;
    let (mut all_ok, mut all_track, mut all_wrong) = (0, 0, 0);
    let (mut all_right, mut all_real) = (0usize, 0usize);
    let mut times = Vec::new();
    // STARID_SEQ_SEED: the first sequence's seed (default 100), for a second set of sequences.
    let order_only = std::env::var("STARID_SEQ_ORDER").is_ok();
    let count_pairs = std::env::var("STARID_PAIRS").is_ok();
    let seq_seed: u64 =
        std::env::var("STARID_SEQ_SEED").map_or(100, |v| v.parse().expect("STARID_SEQ_SEED"));
    for (k, rate_deg) in [0.1f64, 0.5, 1.0, 2.0, 5.0].into_iter().enumerate() {
        let seq_cfg = SequenceConfig {
            frames: seq_frames,
            rate_rad_s: rate_deg.to_radians(),
            blank: 100..110,
            frame: SimConfig {
                mag_limit: Some(6.0),
                noise_px: 0.5,
                mag_noise: 0.1,
                false_stars: 0,
                false_stars_max: Some(40),
                false_star_mags: FalseStarMags::FromCatalog,
                ..Default::default()
            },
            ..Default::default()
        };
        let seq =
            simulate_sequence(&catalog, &cam, &seq_cfg, seq_seed + k as u64).expect("sequence");
        // STARID_CONFIRM=1: a new star inside the field is named from its second frame on
        // (TrackerConfig::confirm_new_stars).
        let tracker_cfg = TrackerConfig {
            confirm_new_stars: std::env::var("STARID_CONFIRM").is_ok(),
            // STARID_UNSEEN=K: hold stars unseen for K solutions (0: off; default the core's).
            confirm_unseen_frames: std::env::var("STARID_UNSEEN")
                .map_or(Some(starid_core::tracking::CONFIRM_UNSEEN_FRAMES), |v| {
                    v.parse().ok().filter(|&k| k > 0)
                }),
            ..TrackerConfig::default()
        };
        // STARID_MAG_ZERO=Z: the spots' magnitudes in an instrument's system, Z mag off the
        // catalogue's (STARID_NO_LEARN=1: the tracker does not learn it).
        let zero: f64 = std::env::var("STARID_MAG_ZERO").map_or(0.0, |v| v.parse().expect("Z"));
        let seq_id_cfg = IdentifyConfig {
            learn_zero_point: std::env::var("STARID_NO_LEARN").is_err(),
            ..cfg.clone()
        };
        let mut tracker = Tracker::new(tracker_cfg, seq_id_cfg).expect("tracker");
        let (mut ok, mut track, mut bad, mut n, mut unid_real) = (0, 0, 0, 0, 0);
        let (right_before, real_before) = (all_right, all_real);
        let mut regained = None;
        let mut pairs = [0usize; 2];
        for (i, f) in seq.iter().enumerate() {
            // STARID_SEQ_ORDER=1: the spots brightest first, without their magnitudes.
            let sorted;
            let fr: &SimFrame = if order_only {
                sorted = brightest_first(&f.frame);
                &sorted
            } else {
                &f.frame
            };
            let mags: Vec<f64> = fr.magnitudes.iter().map(|m| m + zero).collect();
            let t = Instant::now();
            let step = tracker
                .update(
                    &solver,
                    &fr.centroids,
                    (!order_only).then_some(&mags[..]),
                    &cam,
                    f.t_s,
                )
                .expect("update");
            times.push(t.elapsed().as_secs_f64());
            if seq_cfg.blank.contains(&i) {
                bad += wrong(&step.identification, fr);
                continue;
            }
            n += 1;
            let id = &step.identification;
            ok += usize::from(id.is_identified());
            track += usize::from(id.is_identified() && step.mode == TrackMode::Tracking);
            bad += wrong(id, fr);
            all_right += id
                .catalog_index
                .iter()
                .zip(&fr.catalog_index)
                .filter(|(a, b)| a.is_some() && a == b)
                .count();
            all_real += fr.real_stars();
            if count_pairs {
                // Stars named with another catalogue star of mag ≤ 6 under 0.75 px away.
                let near = 0.75 / cam.focal_length_px;
                for (got, want) in id.catalog_index.iter().zip(&fr.catalog_index) {
                    let Some(s) = *got else { continue };
                    let v = catalog.vectors()[s as usize];
                    let paired = catalog
                        .in_cone(&v, near)
                        .iter()
                        .any(|&k| k != s && catalog.mag()[k as usize] <= 6.0);
                    if paired {
                        pairs[usize::from(*got == *want)] += 1;
                    }
                }
            }
            if !id.is_identified() && fr.real_stars() >= 2 {
                unid_real += 1;
            }
            if std::env::var("STARID_MISSED").is_ok() && id.is_identified() {
                // Real stars left unnamed: where the solution puts their star, in pixels.
                let r = id.r_icrs_to_cam.expect("identified");
                for (o, (got, want)) in id.catalog_index.iter().zip(&fr.catalog_index).enumerate() {
                    if let (None, Some(star)) = (got, want) {
                        let v = r * catalog.vectors()[*star as usize];
                        if let Some((mut x, y)) = cam.cam_to_pixel(&v) {
                            if id.mirrored {
                                x = cam.width_px - x;
                            }
                            let [cx, cy] = fr.centroids[o];
                            println!("  missed: rate {rate_deg} frame {i} star {star} mag {:.2} offset ({:.2}, {:.2}) px |{:.2}| radius {:.2} px sigma {:.2} px at ({cx:.0}, {cy:.0}) matched {} of {}", catalog.mag()[*star as usize], cx - x, cy - y, ((cx - x).powi(2) + (cy - y).powi(2)).sqrt(), id.match_radius_rad * cam.focal_length_px, id.centroid_sigma_px, id.matched, fr.centroids.len());
                        }
                    }
                }
            }
            if std::env::var("STARID_WRONG").is_ok() && wrong(id, fr) > 0 {
                for (o, (a, b)) in id.catalog_index.iter().zip(&fr.catalog_index).enumerate() {
                    if a.is_some() && a != b {
                        let star = a.unwrap() as usize;
                        let imaged = fr.catalog_index.contains(&Some(star as u32));
                        let r = id.r_icrs_to_cam.expect("identified");
                        let pv = cam
                            .cam_to_pixel(&(r * catalog.vectors()[star]))
                            .map(|(x, y)| {
                                if id.mirrored {
                                    (cam.width_px - x, y)
                                } else {
                                    (x, y)
                                }
                            });
                        let [sx, sy] = fr.centroids[o];
                        let tv = cam.cam_to_pixel(&(fr.r_icrs_to_cam * catalog.vectors()[star]));
                        println!("    spot at ({sx:.1}, {sy:.1}) px; the star where the solution puts it {pv:?}, where it truly is {tv:?}");
                        if let Some(q) = fr
                            .catalog_index
                            .iter()
                            .position(|c| *c == Some(star as u32))
                        {
                            println!(
                                "    the star's own spot {q} at {:?} named {:?}, residual {:.1}\"",
                                fr.centroids[q],
                                id.catalog_index[q],
                                id.residuals_rad[q].to_degrees() * 3600.0
                            );
                        }
                        if let Some(t) = b {
                            let tp = cam
                                .cam_to_pixel(&(fr.r_icrs_to_cam * catalog.vectors()[*t as usize]));
                            println!(
                                "    this spot's star {t} truly at {tp:?}, mag {:.2}",
                                catalog.mag()[*t as usize]
                            );
                        }
                        println!("  wrong: frame {i} mode {:?} spot {o} truth {:?} got {star} (mag {:.2}, imaged elsewhere {imaged}) spot mag {:.2} residual {:.1}\" matched {} of {} spots radius {:.1}\" sigma {:.2} px", step.mode, b, catalog.mag()[star], fr.magnitudes[o], id.residuals_rad[o].to_degrees()*3600.0, id.matched, fr.centroids.len(), id.match_radius_rad.to_degrees()*3600.0, id.centroid_sigma_px);
                    }
                }
            }
            if std::env::var("STARID_DEBUG").is_ok()
                && (step.mode != TrackMode::Tracking || wrong(id, fr) > 0)
                && i > 0
                && !(seq_cfg.blank.start..=seq_cfg.blank.end).contains(&i)
            {
                let mut order: Vec<usize> = (0..fr.centroids.len()).collect();
                order.sort_by(|&a, &b| fr.magnitudes[a].total_cmp(&fr.magnitudes[b]));
                let real_top = order
                    .iter()
                    .take(10)
                    .filter(|&&o| fr.catalog_index[o].is_some())
                    .count();
                let err = step.predicted.map(|p| {
                    starid_core::geometry::rotation_angle_between(&p, &fr.r_icrs_to_cam)
                        .to_degrees()
                });
                println!("  frame {i}: mode {:?} ok {} wrong {} spots {} real {} real-in-top10 {real_top} u {:.3}° pred err {:?}°", step.mode, id.is_identified(), wrong(id, fr), fr.centroids.len(), fr.real_stars(), step.uncertainty_rad.to_degrees(), err);
            }
            if i >= seq_cfg.blank.end && regained.is_none() && id.is_identified() {
                regained = Some(i - seq_cfg.blank.end + 1);
            }
        }
        if count_pairs {
            println!(
                "4. {rate_deg}°/s: stars named with a neighbour of mag ≤ 6 under 0.75 px: {} right, {} wrong",
                pairs[1], pairs[0]
            );
        }
        println!(
            "4. {rate_deg}°/s: {ok}/{n} identified ({:.2} %), {track} in tracking mode ({:.2} %), {bad} wrong ids, {:.2} % of real stars named, {unid_real} unidentified with ≥ 2 real stars; lock regained {:?} frame(s) after 10 blank ones",
            100.0 * ok as f64 / n as f64,
            100.0 * track as f64 / n as f64,
            100.0 * (all_right - right_before) as f64 / (all_real - real_before).max(1) as f64,
            regained
        );
        all_frames += n;
        all_ok += ok;
        all_track += track;
        all_wrong += bad;
    }
    println!(
        "4. all rates: {all_ok}/{all_frames} identified ({:.3} %), tracking mode {:.3} %, {all_wrong} wrong ids, {all_right} of {all_real} real stars named ({:.2} %); per frame median {:.2} µs p99 {:.1} µs",
        100.0 * all_ok as f64 / all_frames as f64,
        100.0 * all_track as f64 / all_frames as f64,
        100.0 * all_right as f64 / all_real.max(1) as f64,
        pct(&mut times, 0.5) * 1e6,
        pct(&mut times, 0.99) * 1e6
    );
}
