//! Identification per frame for the peer benchmark's scenarios, and batch throughput.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use starid_bench::{bundled_catalog, frames};
use starid_core::simulate::SimConfig;
use starid_core::{Camera, IdentifyConfig, Solver};

/// The peer benchmark's scenarios (frames to magnitude 6, or 6.5, with 0.1 mag of magnitude
/// noise, identified with their magnitudes), one with radial distortion, the first again with
/// the spots brightest first and no magnitudes (the order alone, as tetra3-style solvers take
/// them) and shuffled without magnitudes (geometry alone), and K1 Kelvins-style scenes.
fn identify(c: &mut Criterion) {
    let cat = bundled_catalog();
    let cfg = IdentifyConfig::default();
    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    let base = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        mag_noise: 0.1,
        ..Default::default()
    };
    let scenarios = [
        ("12deg_512px_0.2px", 12.0, 512.0, base.clone(), true),
        ("20deg_1024px_0.2px", 20.0, 1024.0, base.clone(), true),
        (
            "12deg_512px_1px_2false_10pctdrop",
            12.0,
            512.0,
            SimConfig {
                noise_px: 1.0,
                false_stars: 2,
                drop_fraction: 0.1,
                ..base.clone()
            },
            true,
        ),
        (
            "12deg_512px_0.2px_5false",
            12.0,
            512.0,
            SimConfig {
                false_stars: 5,
                ..base.clone()
            },
            true,
        ),
        (
            "10deg_1024px_mag6.5_0.3px",
            10.0,
            1024.0,
            SimConfig {
                mag_limit: Some(6.5),
                noise_px: 0.3,
                ..base.clone()
            },
            true,
        ),
        (
            "12deg_512px_0.2px_k1_-0.02",
            12.0,
            512.0,
            base.clone(),
            true,
        ),
        (
            "12deg_512px_0.2px_order_only",
            12.0,
            512.0,
            base.clone(),
            false,
        ),
        (
            "12deg_512px_0.2px_shuffled_no_magnitudes",
            12.0,
            512.0,
            base,
            false,
        ),
    ];
    let shuffled = IdentifyConfig {
        brightness_order: false,
        ..Default::default()
    };
    for (name, fov, size, sim, with_magnitudes) in scenarios {
        let camera = Camera::from_fov(f64::to_radians(fov), size, size).unwrap();
        let solver = Solver::for_camera(cat.clone(), &camera).unwrap();
        // The distorted scenario images through k1 = -0.02 and identifies with the pinhole.
        let imaged = if name.contains("_k1_") {
            camera.with_k1(-0.02).unwrap()
        } else {
            camera
        };
        let mut fs = frames(&cat, &imaged, &sim, 200);
        if name.ends_with("order_only") {
            for f in &mut fs {
                let mut idx: Vec<usize> = (0..f.centroids.len()).collect();
                idx.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
                f.centroids = idx.iter().map(|&i| f.centroids[i]).collect();
            }
        }
        let cfg = if name.ends_with("shuffled_no_magnitudes") {
            &shuffled
        } else {
            &cfg
        };
        let refs: Vec<_> = fs
            .iter()
            .map(|f| {
                (
                    f.centroids.as_slice(),
                    with_magnitudes.then_some(f.magnitudes.as_slice()),
                )
            })
            .collect();
        g.throughput(Throughput::Elements(fs.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                refs.iter()
                    .filter(|(xy, m)| {
                        solver
                            .identify(black_box(xy), *m, &camera, cfg)
                            .unwrap()
                            .is_identified()
                    })
                    .count()
            })
        });
        if name == "12deg_512px_0.2px" {
            // Tracking: the same frames from a hint up to 1° off, 1° uncertainty.
            let hints: Vec<starid_core::AttitudeHint> = fs
                .iter()
                .enumerate()
                .map(|(k, f)| {
                    let a = 0.0174 * ((k * 7919) % 1000) as f64 / 1000.0;
                    let axis = nalgebra::Vector3::new(1.0, (k % 5) as f64 - 2.0, 0.5).normalize();
                    starid_core::AttitudeHint {
                        r_icrs_to_cam: nalgebra::Rotation3::new(axis * a) * f.r_icrs_to_cam,
                        uncertainty_rad: 1f64.to_radians(),
                        mirrored: Some(f.mirrored),
                    }
                })
                .collect();
            g.bench_function(format!("{name}_hinted_1deg"), |b| {
                b.iter(|| {
                    refs.iter()
                        .zip(&hints)
                        .filter(|((xy, m), h)| {
                            solver
                                .identify_hinted(
                                    black_box(xy),
                                    *m,
                                    &camera,
                                    cfg,
                                    h,
                                    starid_core::HintFallback::None,
                                )
                                .unwrap()
                                .is_identified()
                        })
                        .count()
                })
            });
            g.bench_function(format!("{name}_batch"), |b| {
                b.iter(|| {
                    solver
                        .identify_batch(black_box(&refs), &camera, cfg, None)
                        .unwrap()
                        .len()
                })
            });
        }
    }
    // K1 scenes (Kelvins style: a few stars among up to 80 false spots, magnitudes given).
    let family = starid_core::Family::K1;
    let camera = family.camera();
    let solver = Solver::for_camera(cat.clone(), &camera).unwrap();
    solver.mag_pair_index();
    let fs: Vec<_> = (0..200)
        .map(|seed| family.simulate(&cat, seed).unwrap())
        .collect();
    g.throughput(Throughput::Elements(fs.len() as u64));
    g.bench_function("k1_kelvins", |b| {
        b.iter(|| {
            fs.iter()
                .filter(|f| {
                    solver
                        .identify(black_box(&f.centroids), Some(&f.magnitudes), &camera, &cfg)
                        .unwrap()
                        .is_identified()
                })
                .count()
        })
    });
    g.finish();
}

/// Attitude from matched stars over 20 pairs: Wahba by SVD, and by Gauss–Newton from a
/// rotation 1e-4 rad off (as in verification, where the previous fit is the start).
fn attitude(c: &mut Criterion) {
    use starid_core::attitude::{wahba_from, wahba_svd};
    use starid_core::geometry::{attitude_from_radec_roll, radec_to_unit};
    let r = attitude_from_radec_roll(1.0, 0.4, 2.0);
    let refs: Vec<_> = (0..20)
        .map(|i| radec_to_unit(1.0 + 0.01 * i as f64, 0.4 + 0.007 * (i % 7) as f64))
        .collect();
    let obs: Vec<_> = refs.iter().map(|v| r * v).collect();
    c.bench_function("attitude/wahba_svd_20_stars", |b| {
        b.iter(|| wahba_svd(black_box(&obs), &refs).unwrap())
    });
    let start = nalgebra::Rotation3::new(nalgebra::Vector3::new(1e-4, -5e-5, 8e-5)) * r;
    c.bench_function("attitude/wahba_gauss_newton_20_stars", |b| {
        b.iter(|| wahba_from(black_box(&obs), &refs, &start).unwrap())
    });
}

criterion_group!(benches, identify, attitude);
criterion_main!(benches);
