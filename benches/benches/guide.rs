//! Guide-star selection and metrics: QTM-weighted selection over a Hipparcos-sized sky
//! (118 218 stars, the size of the full Hipparcos catalogue) and 100 000 Monte Carlo fields.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use starid_core::guide::{self, Field, QtmRule};
use starid_core::simulate::random_catalog;

fn guide_bench(c: &mut Criterion) {
    let sky = random_catalog(118_218, -1.5, 12.0, 1).expect("catalogue");
    let mut g = c.benchmark_group("guide");
    g.sample_size(10);
    g.bench_function("qtm_weighted_level5_118k", |b| {
        b.iter(|| guide::select_qtm(black_box(&sky), 5, QtmRule::Weighted).unwrap())
    });
    g.bench_function("qtm_level8_118k", |b| {
        b.iter(|| guide::select_qtm(black_box(&sky), 8, QtmRule::Brightest).unwrap())
    });
    g.bench_function("rectangle_5deg_118k", |b| {
        b.iter(|| guide::select_rectangle(black_box(&sky), 5f64.to_radians()).unwrap())
    });
    let guide_cat = guide::select_qtm(&sky, 5, QtmRule::Weighted).unwrap();
    let field = Field::Circle {
        fov_rad: 10f64.to_radians(),
    };
    g.bench_function("monte_carlo_100k_fields_10deg", |b| {
        b.iter(|| guide::field_star_counts(black_box(&guide_cat), field, 100_000, 7).unwrap())
    });
    g.bench_function("metrics_10deg_100k_fields", |b| {
        b.iter(|| guide::metrics(black_box(&guide_cat), field, 100_000, 7).unwrap())
    });
    g.bench_function("nearest_neighbours_118k", |b| {
        b.iter(|| guide::nearest_neighbour_angles(black_box(&sky)).unwrap())
    });
    g.finish();
}

criterion_group!(benches, guide_bench);
criterion_main!(benches);
