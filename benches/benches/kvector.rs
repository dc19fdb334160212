//! k-vector pair index: build time (the pair index alone, and every index a solver keeps for a
//! camera with magnitudes: the target is 100 ms) and range-query throughput.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use starid_bench::bundled_catalog;
use starid_core::{Camera, PairIndex, Solver};

fn kvector(c: &mut Criterion) {
    let cat = bundled_catalog();
    let mut g = c.benchmark_group("kvector");
    g.sample_size(10);
    for fov_deg in [12.0f64, 20.0] {
        let max = (fov_deg * std::f64::consts::SQRT_2).to_radians();
        g.bench_function(format!("build_{fov_deg}deg_diag"), |b| {
            b.iter(|| PairIndex::build(black_box(&cat), max).unwrap())
        });
    }
    // What a first identification with magnitudes builds for a 12°/512 px camera: the pair and
    // bright-pair indexes, the density map and the magnitude-split index.
    let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    g.bench_function("solver_12deg_512px_with_magnitudes", |b| {
        b.iter(|| {
            let solver = Solver::for_camera(black_box(cat.clone()), &cam).unwrap();
            solver.mag_pair_index().memory_bytes()
        })
    });
    let idx = PairIndex::build(&cat, 17f64.to_radians()).unwrap();
    let queries: Vec<f64> = (0..1000)
        .map(|i| (0.5 + 15.0 * i as f64 / 1000.0f64).to_radians())
        .collect();
    g.throughput(Throughput::Elements(queries.len() as u64));
    g.bench_function("query_1000_eps_20arcsec", |b| {
        let eps = (20.0f64 / 3600.0).to_radians();
        b.iter(|| {
            queries
                .iter()
                .map(|&t| idx.range(black_box(t - eps), t + eps).len())
                .sum::<usize>()
        })
    });
    g.finish();
}

criterion_group!(benches, kvector);
criterion_main!(benches);
