//! The source documents' methods (`SEEDS.md` §1–6) on the bundled catalogue: verified answers
//! identify clean frames and are never wrong; raw answers come back unverified.

use proptest::prelude::*;
use starid_core::simulate::{simulate, SimConfig};
use starid_core::{Camera, IdentifyConfig, Method, Solver, Status};

use super::strategies::{bundled, config};

const SEEDS: [Method; 5] = [
    Method::AngularDistance,
    Method::StarLineAngle,
    Method::AngleSum,
    Method::DistanceVote,
    Method::RadialVote,
];

fn camera() -> Camera {
    Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap()
}

fn solver() -> &'static Solver {
    static S: std::sync::OnceLock<Solver> = std::sync::OnceLock::new();
    S.get_or_init(|| Solver::for_camera(bundled(), &camera()).unwrap())
}

#[test]
fn each_method_identifies_clean_frames() {
    let cam = camera();
    for method in SEEDS {
        let cfg = IdentifyConfig {
            method,
            ..Default::default()
        };
        let mut ok = 0;
        for seed in 0..10 {
            let f = simulate(
                solver().catalog(),
                &cam,
                &SimConfig {
                    noise_px: 0.1,
                    ..Default::default()
                },
                seed,
            )
            .unwrap();
            let id = solver().identify(&f.centroids, None, &cam, &cfg).unwrap();
            for (got, truth) in id.catalog_index.iter().zip(&f.catalog_index) {
                assert!(got.is_none() || got == truth, "{method:?}: a wrong id");
            }
            if id.is_identified() {
                assert!(id.verified && id.method == method);
                ok += 1;
            }
        }
        assert!(ok >= 8, "{method:?} identified {ok}/10");
    }
}

#[test]
fn raw_answers_are_unverified_and_have_no_bound() {
    let cam = camera();
    let f = simulate(solver().catalog(), &cam, &SimConfig::default(), 4).unwrap();
    for method in SEEDS.into_iter().chain([Method::Pyramid, Method::Voting]) {
        let cfg = IdentifyConfig {
            method,
            verify: false,
            centroid_sigma_px: Some(0.2),
            ..Default::default()
        };
        let id = solver().identify(&f.centroids, None, &cam, &cfg).unwrap();
        assert_eq!(id.catalog_index.len(), f.centroids.len());
        assert!(!id.verified, "{method:?}");
        if id.status == Status::Identified {
            assert_eq!(id.false_match_probability, 1.0);
            assert!(id.centroid_sigma_px.is_nan());
            assert_eq!(id.matched, id.catalog_index.iter().flatten().count());
        }
    }
}

#[test]
fn method_databases_are_reported() {
    let s = solver();
    let (pairs, _) = s.method_database(Method::AngularDistance);
    let (lines, _) = s.method_database(Method::StarLineAngle);
    let (sums, _) = s.method_database(Method::AngleSum);
    let (rings, _) = s.method_database(Method::RadialVote);
    assert_eq!(rings, 3 * s.catalog().len());
    assert!(rings < sums && sums < lines && lines < pairs);
    // 12° across a square field: rings of 1°, neighbours within 6°.
    let t = s.seed_tables();
    assert!((t.ring_width_rad().to_degrees() - 1.0).abs() < 0.01);
    assert!((t.neighbour_radius_rad().to_degrees() - 6.0).abs() < 0.05);
}

proptest! {
    #![proptest_config(config())]

    /// Whatever the method and the frame, a verified id is never wrong.
    #[test]
    fn verified_answers_are_never_wrong(
        m in 0usize..5,
        seed in 0u64..1_000_000,
        noise in prop::sample::select(vec![0.0, 0.5, 1.0]),
        false_stars in 0usize..4,
        mirrored in any::<bool>(),
    ) {
        let cam = camera();
        let sim = SimConfig { noise_px: noise, false_stars, mirrored, drop_fraction: 0.1, ..Default::default() };
        let f = simulate(solver().catalog(), &cam, &sim, seed).unwrap();
        prop_assume!(f.centroids.len() >= 4);
        let cfg = IdentifyConfig { method: SEEDS[m], ..Default::default() };
        let id = solver().identify(&f.centroids, None, &cam, &cfg).unwrap();
        for (got, truth) in id.catalog_index.iter().zip(&f.catalog_index) {
            prop_assert!(got.is_none() || got == truth);
        }
        if id.is_identified() {
            prop_assert_eq!(id.mirrored, mirrored);
        }
    }
}
