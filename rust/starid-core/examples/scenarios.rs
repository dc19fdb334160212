//! The peer benchmark's five scenarios in pure Rust: frames simulated from the bundled
//! catalogue with 0.1 mag magnitude noise, identified with their magnitudes, single thread.
//! Same truth rule as `benches/peers/bench_peers.py`: identified = boresight within 0.1° of the
//! truth, wrong = a solution farther off, frames with fewer than 3 real stars count as failures.
//!
//! `cargo run --release --example scenarios -- [FRAMES] [REPEAT] [SCENARIO-SUBSTRING]`
//!
//! `REPEAT` identifies every frame that many times (for profilers); each frame's time is its fastest.
//! Environment: `STARID_FOV_TOLERANCE` sets `fov_tolerance` (0 holds the field as given);
//! `STARID_SIGMA_FACTOR=K` states a centroid noise K times the true one;
//! `STARID_FAST_ONLY` repeats only frames under 150 µs (profile typical frames, not
//! the hopeless ones); `STARID_HYP` prints hypothesis counts; `STARID_FAILS` lists failures and
//! wrong ids; `STARID_SEED=N` runs one frame; `STARID_ORDER_ONLY` gives the centroids brightest
//! first without their magnitudes (what tetra3-style solvers take); `STARID_REALISTIC` gives
//! magnitudes with 0.3 mag more scatter and a zero point drawn from ±8 mag, searched with
//! `mag_offset: None` (the peer benchmark's realistic input).
#![allow(clippy::print_stdout)]

use std::sync::Arc;

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use starid_core::{simulate, Camera, Catalog, IdentifyConfig, SimConfig, Solver};

struct Scenario {
    name: &'static str,
    fov_deg: f64,
    size_px: f64,
    sim: SimConfig,
}

fn scenarios() -> Vec<Scenario> {
    let base = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        mag_noise: 0.1,
        ..Default::default()
    };
    vec![
        Scenario {
            name: "12deg/512px mag6 0.2px",
            fov_deg: 12.0,
            size_px: 512.0,
            sim: base.clone(),
        },
        Scenario {
            name: "20deg/1024px mag6 0.2px",
            fov_deg: 20.0,
            size_px: 1024.0,
            sim: base.clone(),
        },
        Scenario {
            name: "12deg/512px 1px +2 false -10%",
            fov_deg: 12.0,
            size_px: 512.0,
            sim: SimConfig {
                noise_px: 1.0,
                false_stars: 2,
                drop_fraction: 0.1,
                ..base.clone()
            },
        },
        Scenario {
            name: "12deg/512px +5 false",
            fov_deg: 12.0,
            size_px: 512.0,
            sim: SimConfig {
                false_stars: 5,
                ..base.clone()
            },
        },
        Scenario {
            name: "10deg/1024px mag6.5 0.3px",
            fov_deg: 10.0,
            size_px: 1024.0,
            sim: SimConfig {
                mag_limit: Some(6.5),
                noise_px: 0.3,
                ..base
            },
        },
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let frames: u64 = args.get(1).map_or(1000, |a| a.parse().expect("FRAMES"));
    let repeat: usize = args.get(2).map_or(1, |a| a.parse().expect("REPEAT"));
    let filter = args.get(3).cloned().unwrap_or_default();
    let catalog = Arc::new(Catalog::bundled());
    let mut config = IdentifyConfig::default();
    if let Ok(v) = std::env::var("STARID_FOV_TOLERANCE") {
        config.fov_tolerance = v.parse().expect("STARID_FOV_TOLERANCE");
    }
    if let Ok(v) = std::env::var("STARID_MAX_WORK") {
        config.max_pairs_visited = v.parse().expect("STARID_MAX_WORK");
    }
    for sc in scenarios().into_iter().filter(|s| s.name.contains(&filter)) {
        let camera =
            Camera::from_fov(sc.fov_deg.to_radians(), sc.size_px, sc.size_px).expect("camera");
        // STARID_FOV_ERR: the solver is told a field of view this fraction off (frames use the true one).
        let fov_err: f64 =
            std::env::var("STARID_FOV_ERR").map_or(0.0, |v| v.parse().expect("STARID_FOV_ERR"));
        let told = Camera::from_fov(
            sc.fov_deg.to_radians() * (1.0 + fov_err),
            sc.size_px,
            sc.size_px,
        )
        .expect("camera");
        let solver = Solver::for_camera(catalog.clone(), &camera).expect("index");
        // STARID_SIGMA_FACTOR: the solver is told a centroid noise this many times the true one.
        if let Ok(v) = std::env::var("STARID_SIGMA_FACTOR") {
            let k: f64 = v.parse().expect("STARID_SIGMA_FACTOR");
            config.centroid_sigma_px = Some(k * sc.sim.noise_px);
        }
        let order_only = std::env::var("STARID_ORDER_ONLY").is_ok();
        let realistic = std::env::var("STARID_REALISTIC").is_ok();
        if realistic {
            config.mag_offset = None;
        }
        let sims: Vec<_> = (0..frames)
            .map(|seed| {
                let mut f = simulate(&catalog, &camera, &sc.sim, seed).expect("frame");
                if order_only {
                    // Brightest first, as an extractor lists them; the magnitudes withheld.
                    let mut idx: Vec<usize> = (0..f.centroids.len()).collect();
                    idx.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
                    f.centroids = idx.iter().map(|&i| f.centroids[i]).collect();
                    f.catalog_index = idx.iter().map(|&i| f.catalog_index[i]).collect();
                    f.magnitudes = idx.iter().map(|&i| f.magnitudes[i]).collect();
                }
                if realistic {
                    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x5eed);
                    let scatter = rand_distr::Normal::new(0.0, 0.3).expect("normal");
                    let zero_point = rng.random_range(-8.0..8.0);
                    for m in &mut f.magnitudes {
                        *m += zero_point + rng.sample(scatter);
                    }
                }
                f
            })
            .collect();
        let (mut ok, mut wrong, mut none, mut ge4, mut ok_ge4, mut wrong_ids, mut ids) =
            (0, 0, 0, 0, 0, 0, 0);
        let mut times = Vec::new();
        // Times and hypothesis counts of the identified frames, (time, hypotheses).
        let mut ok_times: Vec<(f64, usize)> = Vec::new();
        let mut hyps: Vec<usize> = Vec::new();
        let mut fast = vec![true; sims.len()];
        let fast_only = std::env::var("STARID_FAST_ONLY").is_ok();
        // Where each frame's time is in `times`.
        let mut slot = std::collections::HashMap::new();
        for pass in 0..repeat {
            for (fi, f) in sims.iter().enumerate() {
                if pass > 0 && fast_only && !fast[fi] {
                    continue;
                }
                if std::env::var("STARID_SEED").is_ok_and(|v| v.parse::<usize>().ok() != Some(fi)) {
                    continue;
                }
                let real = f.real_stars();
                if real < 3 || f.centroids.len() < 4 {
                    if pass == 0 {
                        none += 1;
                        ge4 += usize::from(real >= 4);
                    }
                    continue;
                }
                let mags = (!order_only).then_some(f.magnitudes.as_slice());
                let r = solver
                    .identify(&f.centroids, mags, &told, &config)
                    .expect("identify");
                let t = r.elapsed.as_secs_f64();
                if pass > 0 {
                    // Each frame's fastest call (the repeats measure the solver, not the machine).
                    if let Some(&k) = slot.get(&fi) {
                        times[k] = f64::min(times[k], t);
                    }
                    continue;
                }
                fast[fi] = t < 150e-6;
                slot.insert(fi, times.len());
                times.push(t);
                if std::env::var("STARID_SEED").is_ok() {
                    println!(
                        "  seed {fi}: {:?} hypotheses {} matched {} p {:e} time {:?}, method {}, \
                         focal {:?}, noise {} ({:.2} px)",
                        r.status,
                        r.hypotheses,
                        r.matched,
                        r.false_match_probability,
                        r.elapsed,
                        r.method.name(),
                        r.focal_length_px,
                        r.noise_source.as_str(),
                        r.noise_step_px
                    );
                    for (o, s) in r.catalog_index.iter().enumerate() {
                        if let Some(s) = s {
                            println!(
                                "    offset {:.2}",
                                f.magnitudes[o] - catalog.mag()[*s as usize]
                            );
                        }
                    }
                }
                hyps.push(r.hypotheses);
                if std::env::var("STARID_PER_FRAME").is_ok() {
                    println!(
                        "  frame {fi}: matched {} sigma {:.3} radius {:.1}\" hypotheses {}",
                        r.matched,
                        r.centroid_sigma_px,
                        r.match_radius_rad.to_degrees() * 3600.0,
                        r.hypotheses
                    );
                }
                ge4 += usize::from(real >= 4);
                let Some(rot) = r.r_icrs_to_cam else {
                    none += 1;
                    if std::env::var("STARID_FAILS").is_ok() {
                        println!(
                            "  fail seed {fi}: {real} real of {}, {:?}, {} hypotheses",
                            f.centroids.len(),
                            r.status,
                            r.hypotheses
                        );
                    }
                    continue;
                };
                let z = Vector3::z();
                let err = rot
                    .inverse_transform_vector(&z)
                    .angle(&f.r_icrs_to_cam.inverse_transform_vector(&z));
                if err.to_degrees() < 0.1 {
                    if std::env::var("STARID_HYP_OK").is_ok() && r.hypotheses > 200 {
                        println!(
                            "  identified seed {fi} after {} hypotheses, p {:e}, {} matched of {}",
                            r.hypotheses,
                            r.false_match_probability,
                            r.matched,
                            f.centroids.len()
                        );
                    }
                    ok += 1;
                    ok_times.push((r.elapsed.as_secs_f64(), r.hypotheses));
                    ok_ge4 += usize::from(real >= 4);
                } else {
                    wrong += 1;
                    if std::env::var("STARID_FAILS").is_ok() {
                        println!(
                            "  wrong solution seed {fi}: boresight {:.3}° off, {} matched of {}, sigma {:.2} px, p {:e}",
                            err.to_degrees(),
                            r.matched,
                            f.centroids.len(),
                            r.centroid_sigma_px,
                            r.false_match_probability
                        );
                    }
                }
                for (o, (got, want)) in r.catalog_index.iter().zip(&f.catalog_index).enumerate() {
                    if got.is_some() {
                        ids += 1;
                        wrong_ids += usize::from(got != want);
                        if got != want && std::env::var("STARID_FAILS").is_ok() {
                            println!(
                                "  wrong id seed {fi}: got {got:?} want {want:?} at {:.2} px; \
                                 {} matched, noise {:.2} px (step {:.2}), radius {:.2} px; \
                                 magnitude {:.2} against {:.2}",
                                r.residuals_rad[o] * told.focal_length_px,
                                r.matched,
                                r.centroid_sigma_px,
                                r.noise_step_px,
                                r.match_radius_rad * told.focal_length_px,
                                f.magnitudes[o],
                                catalog.mag()[got.unwrap_or_default() as usize]
                            );
                        }
                    }
                }
            }
        }
        times.sort_by(f64::total_cmp);
        hyps.sort();
        if std::env::var("STARID_HYP").is_ok() {
            println!(
                "hypotheses: median {} p90 {} p99 {} mean {:.1}",
                hyps[hyps.len() / 2],
                hyps[hyps.len() * 9 / 10],
                hyps[hyps.len() * 99 / 100],
                hyps.iter().sum::<usize>() as f64 / hyps.len() as f64
            );
        }
        if std::env::var("STARID_HYP").is_ok() && !ok_times.is_empty() {
            ok_times.sort_by(|a, b| a.0.total_cmp(&b.0));
            let at = |p: f64| ok_times[((ok_times.len() as f64 - 1.0) * p).round() as usize];
            println!(
                "identified frames: p99 {:.1} us ({} hypotheses), p99.9 {:.1} us, max {:.1} us ({} hypotheses); most hypotheses {}",
                at(0.99).0 * 1e6,
                at(0.99).1,
                at(0.999).0 * 1e6,
                at(1.0).0 * 1e6,
                at(1.0).1,
                ok_times.iter().map(|t| t.1).max().unwrap_or(0)
            );
        }
        let q = |p: f64| times[((times.len() as f64 - 1.0) * p).round() as usize] * 1e6;
        let pct = |k: usize| 100.0 * k as f64 / frames as f64;
        println!(
            "{:<31} identified {:6.2} %  wrong {:.2} %  none {:6.2} %  (>=4 stars {:6.2} %)  wrong ids {}/{}  \
             median {:7.1} us  mean {:7.1} us  p99 {:8.1} us  max {:8.1} us  index {:.0} ms {:.1} MB",
            sc.name,
            pct(ok),
            pct(wrong),
            pct(none),
            100.0 * ok_ge4 as f64 / ge4.max(1) as f64,
            wrong_ids,
            ids,
            q(0.5),
            times.iter().sum::<f64>() / times.len().max(1) as f64 * 1e6,
            q(0.99),
            q(1.0),
            solver.build_time().as_secs_f64() * 1e3,
            solver.memory_bytes() as f64 / 1e6,
        );
    }
}
