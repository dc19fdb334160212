//! Worst cases of allowed input: frames of many random centroids (`cargo run --release --example
//! stress -- [N...]`), with and without magnitudes; prints the time and the work of each.
#![allow(clippy::print_stdout)]

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use starid_core::{Camera, Catalog, IdentifyConfig, Solver};

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("N"))
        .collect();
    let sizes = if args.is_empty() {
        vec![100, 1_000, 10_000, 100_000]
    } else {
        args
    };
    let catalog = Arc::new(Catalog::bundled());
    let camera = Camera::from_fov(12f64.to_radians(), 1024.0, 1024.0).expect("camera");
    let solver = Solver::for_camera(catalog, &camera).expect("index");
    let mut rng = rand::rngs::StdRng::seed_from_u64(1);
    for n in sizes {
        let xy: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.random_range(0.0..1024.0), rng.random_range(0.0..1024.0)])
            .collect();
        let mags: Vec<f64> = (0..n).map(|_| rng.random_range(1.0..6.5)).collect();
        for m in [None, Some(mags.as_slice())] {
            let r = solver
                .identify(&xy, m, &camera, &IdentifyConfig::default())
                .expect("identify");
            println!(
                "{n:>7} centroids, magnitudes {:<5}: {:?} after {} hypotheses in {:.1} ms",
                m.is_some(),
                r.status,
                r.hypotheses,
                r.elapsed.as_secs_f64() * 1e3
            );
        }
    }
}
