//! Pointing: the three-star distance solver (known and unknown focal length), the
//! Levenberg–Marquardt refinement, and identification with an unknown field of view.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector3;
use starid_bench::{bundled_catalog, frames};
use starid_core::geometry::attitude_from_radec_roll;
use starid_core::pointing::{boresight_from_distances, fit_pointing, RefineOptions};
use starid_core::{Camera, IdentifyConfig, SimConfig, Solver};

fn pointing(c: &mut Criterion) {
    let mut g = c.benchmark_group("pointing");
    let f = 256.0 / 6f64.to_radians().tan();
    let r = attitude_from_radec_roll(1.0, 0.3, 0.5);
    let off = [[230.0, 20.0], [-100.0, 200.0], [-120.0, -190.0]];
    let stars: Vec<Vector3<f64>> = off
        .iter()
        .map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize()))
        .collect();
    let a: Vec<f64> = off.iter().map(|o: &[f64; 2]| o[0].hypot(o[1])).collect();
    g.bench_function("three_star_known_focal", |b| {
        b.iter(|| boresight_from_distances(black_box(&stars), &a, Some(f)).unwrap())
    });
    g.bench_function("three_star_unknown_focal", |b| {
        b.iter(|| boresight_from_distances(black_box(&stars), &a, None).unwrap())
    });

    let cat = bundled_catalog();
    let camera = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    let sim = SimConfig {
        noise_px: 0.2,
        ..Default::default()
    };
    let fr = &frames(&cat, &camera, &sim, 1)[0];
    let (stars, xy): (Vec<Vector3<f64>>, Vec<[f64; 2]>) = fr
        .catalog_index
        .iter()
        .zip(&fr.centroids)
        .filter_map(|(c, p)| c.map(|c| (cat.vectors()[c as usize], *p)))
        .unzip();
    g.bench_function("refine_attitude_focal_12deg_frame", |b| {
        b.iter(|| {
            fit_pointing(
                black_box(&stars),
                &xy,
                512.0,
                512.0,
                Some(f * 1.4),
                &RefineOptions::default(),
            )
            .unwrap()
        })
    });
    let all = RefineOptions {
        fit_principal_point: true,
        fit_k1: true,
        ..RefineOptions::default()
    };
    g.bench_function("refine_with_principal_point_k1", |b| {
        b.iter(|| fit_pointing(black_box(&stars), &xy, 512.0, 512.0, Some(f), &all).unwrap())
    });

    // Unknown field of view: 20° frames identified with the range 8°–25°.
    let widest = Camera::from_fov(25f64.to_radians(), 1024.0, 1024.0).unwrap();
    let narrowest = Camera::from_fov(8f64.to_radians(), 1024.0, 1024.0).unwrap();
    let solver = Solver::for_camera(cat.clone(), &widest).unwrap();
    let cam20 = Camera::from_fov(20f64.to_radians(), 1024.0, 1024.0).unwrap();
    let set = frames(&cat, &cam20, &sim, 32);
    let cfg = IdentifyConfig::default();
    let mut i = 0;
    g.sample_size(20);
    g.bench_function("identify_unknown_fov_20deg_in_8_25", |b| {
        b.iter(|| {
            let f = &set[i % set.len()];
            i += 1;
            solver
                .identify_unknown_focal(
                    black_box(&f.centroids),
                    None,
                    1024.0,
                    1024.0,
                    (widest.focal_length_px, narrowest.focal_length_px),
                    &cfg,
                )
                .unwrap()
        })
    });
    g.finish();
}

criterion_group!(benches, pointing);
criterion_main!(benches);
