//! Identify simulated frames whose field of view is unknown (drawn uniformly in a range) and
//! print the success rate, wrong ids, focal-length error and time per frame.
//!
//! `cargo run --release --example unknown_fov -- CATALOG FOV_LO FOV_HI SIZE NOISE_PX FALSE_STARS FRAMES [mags]`
#![allow(clippy::print_stdout)]

use std::sync::Arc;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use starid_core::{simulate, Camera, Catalog, IdentifyConfig, SimConfig, Solver};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 8 {
        eprintln!(
            "usage: unknown_fov CATALOG FOV_LO FOV_HI SIZE NOISE_PX FALSE_STARS FRAMES [mags]"
        );
        std::process::exit(2);
    }
    let num = |i: usize| a[i].parse::<f64>().expect("a number");
    let catalog = Arc::new(Catalog::from_path(&a[1]).expect("catalogue"));
    let (fov_lo, fov_hi, size) = (num(2), num(3), num(4));
    let widest = Camera::from_fov(fov_hi.to_radians(), size, size).expect("camera");
    let narrowest = Camera::from_fov(fov_lo.to_radians(), size, size).expect("camera");
    let t = Instant::now();
    let solver = Solver::for_camera(catalog.clone(), &widest).expect("index");
    println!(
        "index: {} pairs, {:.2} MB, built in {:.1} ms",
        solver.pair_index().len(),
        solver.pair_index().memory_bytes() as f64 / 1e6,
        t.elapsed().as_secs_f64() * 1e3
    );
    let use_mags = a.get(8).is_some_and(|s| s == "mags");
    let config = IdentifyConfig::default();
    let frames = num(7) as usize;
    let mut rng = rand::rngs::StdRng::seed_from_u64(99);
    let (mut ok, mut ge4, mut ok_ge4, mut wrong_ids, mut ids, mut wrong_frames) =
        (0, 0, 0, 0, 0, 0);
    let mut f_err: Vec<f64> = Vec::new();
    let mut times = Vec::new();
    let mut fails = Vec::new();
    let only: Option<u64> = std::env::var("STARID_SEED")
        .ok()
        .and_then(|v| v.parse().ok());
    for seed in 0..frames as u64 {
        let fov: f64 = rng.random_range(fov_lo..fov_hi);
        if only.is_some_and(|o| o != seed) {
            continue;
        }
        let camera = Camera::from_fov(fov.to_radians(), size, size).expect("camera");
        let sim = SimConfig {
            noise_px: num(5),
            false_stars: num(6) as usize,
            mag_noise: 0.1,
            mirrored: seed % 2 == 1,
            ..Default::default()
        };
        let f = simulate(&catalog, &camera, &sim, seed).expect("frame");
        let real = f.real_stars();
        if real >= 4 {
            ge4 += 1;
        }
        if f.centroids.len() < 4 {
            fails.push((seed, fov, real, "too few".to_string()));
            continue;
        }
        let mags = use_mags.then_some(f.magnitudes.as_slice());
        if only.is_some() {
            println!("true focal {}", camera.focal_length_px);
        }
        let r = solver
            .identify_unknown_focal(
                &f.centroids,
                mags,
                size,
                size,
                (widest.focal_length_px, narrowest.focal_length_px),
                &config,
            )
            .expect("identify");
        let id = &r.identification;
        times.push(id.elapsed.as_secs_f64());
        if id.is_identified() {
            ok += 1;
            if real >= 4 {
                ok_ge4 += 1;
            }
            let est = r.camera.expect("camera").focal_length_px;
            f_err.push(((est - camera.focal_length_px) / camera.focal_length_px).abs());
            let mut bad = 0;
            for (got, want) in id.catalog_index.iter().zip(&f.catalog_index) {
                if let Some(g) = got {
                    ids += 1;
                    if Some(*g) != *want {
                        bad += 1;
                    }
                }
            }
            wrong_ids += bad;
            if bad > 0 || id.mirrored != sim.mirrored {
                wrong_frames += 1;
                println!(
                    "WRONG seed {seed}: fov {fov:.2}, {bad} wrong ids, p={:e}",
                    id.false_match_probability
                );
            }
        } else {
            fails.push((
                seed,
                fov,
                real,
                format!(
                    "{:?} tried {} pairs {}",
                    id.status, r.focal_hypotheses, r.base_pairs
                ),
            ));
        }
    }
    times.sort_by(f64::total_cmp);
    f_err.sort_by(f64::total_cmp);
    let pct = |v: &[f64], q: f64| v[((v.len() as f64 - 1.0) * q) as usize];
    println!(
        "frames {frames} (fov {fov_lo}-{fov_hi} deg, {size} px): identified {ok} ({:.2}%), among >=4 real stars {ok_ge4}/{ge4} ({:.2}%), wrong frames {wrong_frames}, wrong ids {wrong_ids}/{ids}",
        100.0 * ok as f64 / frames as f64,
        100.0 * ok_ge4 as f64 / ge4.max(1) as f64,
    );
    if !f_err.is_empty() {
        println!(
            "focal error: median {:.2e}, p99 {:.2e}, max {:.2e}; within 0.1 %: {:.2}%",
            pct(&f_err, 0.5),
            pct(&f_err, 0.99),
            pct(&f_err, 1.0),
            100.0 * f_err.iter().filter(|&&e| e < 1e-3).count() as f64 / f_err.len() as f64
        );
    }
    println!(
        "time per frame: median {:.2} ms, p90 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        pct(&times, 0.5) * 1e3,
        pct(&times, 0.9) * 1e3,
        pct(&times, 0.99) * 1e3,
        pct(&times, 1.0) * 1e3
    );
    for f in fails.iter().take(15) {
        println!("fail {f:?}");
    }
}
