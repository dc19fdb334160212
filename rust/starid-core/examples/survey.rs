//! Identify simulated frames from random attitudes and print the success and error rates.
//!
//! `cargo run --release --example survey -- CATALOG FOV_DEG WIDTH HEIGHT NOISE_PX FALSE_STARS DROP FRAMES [MIRRORED]`
#![allow(clippy::print_stdout)]

use std::sync::Arc;
use std::time::Instant;

use starid_core::{simulate, Camera, Catalog, IdentifyConfig, SimConfig, Solver};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 9 {
        eprintln!("usage: survey CATALOG FOV_DEG WIDTH HEIGHT NOISE_PX FALSE_STARS DROP FRAMES [mirrored]");
        std::process::exit(2);
    }
    let num = |i: usize| a[i].parse::<f64>().expect("a number");
    let catalog = Arc::new(Catalog::from_path(&a[1]).expect("catalogue"));
    let camera = Camera::from_fov(num(2).to_radians(), num(3), num(4)).expect("camera");
    let t = Instant::now();
    let solver = Solver::for_camera(catalog.clone(), &camera).expect("index");
    println!(
        "index: {} pairs (+ {} among locally bright stars), {:.2} MB, built in {:.1} ms",
        solver.pair_index().len(),
        solver.bright_pair_index().map_or(0, |b| b.len()),
        solver.memory_bytes() as f64 / 1e6,
        t.elapsed().as_secs_f64() * 1e3
    );
    let sim = SimConfig {
        noise_px: num(5),
        false_stars: num(6) as usize,
        drop_fraction: num(7),
        mirrored: a.get(9).is_some_and(|s| s == "mirrored"),
        ..Default::default()
    };
    let frames = num(8) as usize;
    let config = IdentifyConfig {
        max_false_match_prob: std::env::var("STARID_MAXP")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1e-3),
        // Simulated centroids come in random order: no brightness information in it.
        brightness_order: false,
        ..Default::default()
    };
    let mut ok_probs: Vec<f64> = Vec::new();
    let (mut ok, mut wrong_frames, mut wrong_ids, mut ids, mut ge4, mut ok_ge4, mut stars) =
        (0, 0, 0, 0, 0, 0, 0);
    let mut times = Vec::new();
    let mut fails = Vec::new();
    for seed in 0..frames as u64 {
        let f = simulate(&catalog, &camera, &sim, seed).expect("frame");
        let real = f.real_stars();
        stars += real;
        if real >= 4 {
            ge4 += 1;
        }
        if f.centroids.len() < 4 {
            fails.push((seed, real, f.centroids.len(), "too few".to_string()));
            continue;
        }
        let r = solver
            .identify(&f.centroids, None, &camera, &config)
            .expect("identify");
        times.push(r.elapsed.as_secs_f64());
        if r.is_identified() {
            ok += 1;
            if real >= 4 {
                ok_ge4 += 1;
            }
            ok_probs.push(r.false_match_probability);
            let mut bad = 0;
            for (got, want) in r.catalog_index.iter().zip(&f.catalog_index) {
                if let Some(g) = got {
                    ids += 1;
                    if Some(*g) != *want {
                        bad += 1;
                    }
                }
            }
            wrong_ids += bad;
            if bad > 0 || r.mirrored != sim.mirrored {
                wrong_frames += 1;
                if std::env::var("STARID_DEBUG").is_ok() {
                    let rt = f.r_icrs_to_cam;
                    for (o, (got, want)) in r.catalog_index.iter().zip(&f.catalog_index).enumerate()
                    {
                        if got.is_some() && got != want {
                            let g = got.unwrap() as usize;
                            let pg = camera.cam_to_pixel(&(rt * catalog.vectors()[g])).unwrap();
                            let wpos = want.map(|w| {
                                camera
                                    .cam_to_pixel(&(rt * catalog.vectors()[w as usize]))
                                    .unwrap()
                            });
                            let present = f.catalog_index.contains(&Some(g as u32));
                            println!("  centroid {o} at {:?} got star {g} (true pos {pg:?}, its image present: {present}), truth {want:?} at {wpos:?}, resid {:.2} px, sigma {:.2}, radius {:.2} px",
                                f.centroids[o], r.residuals_rad[o] * camera.focal_length_px, r.centroid_sigma_px, r.match_radius_rad * camera.focal_length_px);
                        }
                    }
                }
                println!(
                    "WRONG seed {seed}: {bad} wrong ids, p={:e}, matched {}",
                    r.false_match_probability, r.matched
                );
            }
        } else {
            fails.push((
                seed,
                real,
                f.centroids.len(),
                format!("{:?} hyp={}", r.status, r.hypotheses),
            ));
        }
    }
    times.sort_by(f64::total_cmp);
    let pct = |q: f64| times[((times.len() as f64 - 1.0) * q) as usize] * 1e6;
    println!(
        "frames {frames}: identified {ok} ({:.3}%), among >=4 real stars {ok_ge4}/{ge4} ({:.3}%), wrong frames {wrong_frames}, wrong ids {wrong_ids}/{ids}, mean real stars {:.1}",
        100.0 * ok as f64 / frames as f64,
        100.0 * ok_ge4 as f64 / ge4.max(1) as f64,
        stars as f64 / frames as f64
    );
    println!(
        "time per frame: median {:.1} us, p90 {:.1} us, p99 {:.1} us, max {:.1} us",
        pct(0.5),
        pct(0.9),
        pct(0.99),
        pct(1.0)
    );
    for lim in [1e-9, 1e-7, 1e-5, 1e-4] {
        println!(
            "  solutions with bound > {lim:e}: {}",
            ok_probs.iter().filter(|&&p| p > lim).count()
        );
    }
    for f in fails.iter().take(15) {
        println!("fail {f:?}");
    }
}
