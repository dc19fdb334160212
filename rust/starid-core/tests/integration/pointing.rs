//! Boresight from distances, refinement, precision and star choice: exactness, the documents'
//! claims about geometry as properties, and the Monte Carlo check of the predicted covariance.

use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;
use starid_core::geometry::angle_between;
use starid_core::pointing::{
    boresight_from_distances, choose_stars, fit_pointing, monte_carlo_distances,
    predicted_distance_covariance, RefineOptions,
};

use super::strategies::{config, rotation};

/// 12° across 512 px.
fn focal_12deg() -> f64 {
    256.0 / 6f64.to_radians().tan()
}

/// Catalogue directions of images at `offsets` (from the principal point) for attitude `r`,
/// and their distances.
fn sky(r: &Rotation3<f64>, offsets: &[[f64; 2]], f: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
    let stars = offsets
        .iter()
        .map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize()))
        .collect();
    (stars, offsets.iter().map(|o| o[0].hypot(o[1])).collect())
}

fn boresight(r: &Rotation3<f64>) -> Vector3<f64> {
    r.inverse_transform_vector(&Vector3::z())
}

fn sigma(offsets: &[[f64; 2]], f: f64, fit_focal: bool) -> f64 {
    predicted_distance_covariance(offsets, f, 1.0, fit_focal)
        .unwrap()
        .map_or(f64::INFINITY, |c| (c[(0, 0)] + c[(1, 1)]).sqrt())
}

/// An image point on the 512 px sensor, away from the principal point.
fn offset() -> impl Strategy<Value = [f64; 2]> {
    (30.0..250.0f64, 0.0..std::f64::consts::TAU).prop_map(|(a, t)| [a * t.cos(), a * t.sin()])
}

/// Three offsets whose triangle is not thin (smallest angle at the principal point > 20°
/// apart in azimuth and not collinear).
fn spread_triple() -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec(offset(), 3).prop_filter("well spread", |v| {
        let az: Vec<f64> = v.iter().map(|o| o[1].atan2(o[0])).collect();
        let gap = |a: f64, b: f64| {
            let d = (a - b).rem_euclid(std::f64::consts::TAU);
            d.min(std::f64::consts::TAU - d)
        };
        let area = ((v[1][0] - v[0][0]) * (v[2][1] - v[0][1])
            - (v[2][0] - v[0][0]) * (v[1][1] - v[0][1]))
            .abs();
        gap(az[0], az[1]) > 0.35
            && gap(az[1], az[2]) > 0.35
            && gap(az[0], az[2]) > 0.35
            && area > 4000.0
    })
}

const ARCSEC: f64 = std::f64::consts::PI / 180.0 / 3600.0;

proptest! {
    #![proptest_config(config())]

    /// Exact distances: the true boresight comes back to 0.01″ (known f) and, with f unknown,
    /// is among the solutions with f to 1e-9.
    #[test]
    fn exact_data_is_solved_exactly(r in rotation(), off in spread_triple()) {
        let f = focal_12deg();
        let (stars, a) = sky(&r, &off, f);
        let truth = boresight(&r);
        let known = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        prop_assert!(angle_between(&known[0].boresight, &truth) < 0.01 * ARCSEC);
        let unknown = boresight_from_distances(&stars, &a, None).unwrap();
        let hit = unknown.iter().find(|s| angle_between(&s.boresight, &truth) < 0.01 * ARCSEC);
        prop_assert!(hit.is_some(), "truth not among {:?}", unknown.iter().map(|s| (s.rms_px, s.focal_length_px)).collect::<Vec<_>>());
        let hit = hit.unwrap();
        prop_assert!(((hit.focal_length_px - f) / f).abs() < 1e-9);
        prop_assert!(hit.rms_px <= unknown[0].rms_px.max(1e-9));
    }

    /// Three stars near the field edge spread about 120° around the centre beat collinear and
    /// clustered choices (predicted boresight error, known and unknown focal length).
    #[test]
    fn spread_edge_stars_beat_collinear_and_clustered(
        turn in 0.0..std::f64::consts::TAU,
        radius in 200.0..250.0f64,
        cluster_at in offset(),
        line_y in 20.0..150.0f64,
    ) {
        let f = focal_12deg();
        let edge: Vec<[f64; 2]> = (0..3)
            .map(|k| { let t = turn + k as f64 * 2.0 * std::f64::consts::FRAC_PI_3; [radius * t.cos(), radius * t.sin()] })
            .collect();
        let clustered: Vec<[f64; 2]> = [[0.0, 0.0], [30.0, 5.0], [10.0, 28.0]]
            .iter()
            .map(|d| [cluster_at[0] * 0.8 + d[0], cluster_at[1] * 0.8 + d[1]])
            .collect();
        let collinear = vec![[-200.0, line_y], [20.0, line_y], [210.0, line_y]];
        for fit_focal in [false, true] {
            let best = sigma(&edge, f, fit_focal);
            prop_assert!(best < sigma(&clustered, f, fit_focal));
            prop_assert!(best < sigma(&collinear, f, fit_focal));
        }
    }

    /// Collinear images (stars on one great circle): with f known, the mirror image of the
    /// boresight across that circle fits exactly as well, so there is no unique answer; the
    /// solver returns both and flags them. Through the principal point the problem is degenerate.
    #[test]
    fn collinear_images_are_ambiguous_or_degenerate(
        r in rotation(), y in 15.0..150.0f64, x0 in -240.0..-60.0f64, g1 in 40.0..170.0f64, g2 in 40.0..170.0f64,
    ) {
        let xs = [x0, x0 + g1, (x0 + g1 + g2).min(240.0)];
        prop_assume!(xs[2] - xs[1] > 30.0);
        let f = focal_12deg();
        let off: Vec<[f64; 2]> = xs.iter().map(|&x| [x, y]).collect();
        let (stars, a) = sky(&r, &off, f);
        let sols = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        prop_assert!(sols.len() >= 2 && sols[0].ambiguous && sols[1].ambiguous);
        prop_assert!(sols[1].rms_px < 1e-6);
        let truth = boresight(&r);
        prop_assert!(sols[..2].iter().any(|s| angle_between(&s.boresight, &truth) < 0.01 * ARCSEC));
        let through: Vec<[f64; 2]> = xs.iter().map(|&x| [x, 0.0]).collect();
        let (stars, a) = sky(&r, &through, f);
        let sols = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        prop_assert!(sols[0].degenerate);
        prop_assert!(predicted_distance_covariance(&through, f, 0.1, false).unwrap().is_none());
    }

    /// Images on one circle through the principal point: with f unknown the problem is
    /// degenerate (a curve of near-exact solutions); with f known it is well posed. Images on
    /// a circle *about* the principal point (equal distances) leave both problems well posed.
    #[test]
    fn circles_and_the_unknown_focal_problem(r in rotation(), radius in 80.0..120.0f64, t0 in 0.0..std::f64::consts::TAU) {
        let f = focal_12deg();
        let angles = [t0, t0 + 1.9, t0 + 4.1];
        let through: Vec<[f64; 2]> = angles.iter().map(|t| [radius + radius * t.cos(), radius * t.sin()]).collect();
        prop_assume!(through.iter().all(|o| o[0].hypot(o[1]) > 20.0));
        prop_assert!(sigma(&through, f, true) > 20.0 * sigma(&through, f, false));
        let (stars, a) = sky(&r, &through, f);
        let sols = boresight_from_distances(&stars, &a, None).unwrap();
        prop_assert!(sols[0].degenerate || sols[0].ambiguous);
        let known = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        prop_assert!(!known[0].degenerate && !known[0].ambiguous);
        let about: Vec<[f64; 2]> = angles.iter().map(|t| [2.0 * radius * t.cos(), 2.0 * radius * t.sin()]).collect();
        for fit_focal in [false, true] {
            prop_assert!(sigma(&about, f, fit_focal) < 5.0 * sigma(&about, f, false));
        }
        let (stars, a) = sky(&r, &about, f);
        let known = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        prop_assert!(!known[0].degenerate && !known[0].ambiguous);
        prop_assert!(angle_between(&known[0].boresight, &boresight(&r)) < 0.01 * ARCSEC);
    }

    /// Gauss–Newton (Levenberg–Marquardt) over attitude and focal length converges from a field
    /// of view guessed 40 % too small or too large.
    #[test]
    fn refinement_converges_from_a_40_percent_fov_error(r in rotation(), off in prop::collection::vec(offset(), 8), wrong in prop::sample::select(vec![0.6, 1.4])) {
        for i in 0..off.len() {
            for k in (i + 1)..off.len() {
                prop_assume!((off[i][0] - off[k][0]).hypot(off[i][1] - off[k][1]) > 10.0);
            }
        }
        let f = focal_12deg();
        let (stars, _) = sky(&r, &off, f);
        let xy: Vec<[f64; 2]> = off.iter().map(|o| [256.0 + o[0], 256.0 + o[1]]).collect();
        let fov_guess = 12f64.to_radians() * wrong;
        let f_guess = 256.0 / (0.5 * fov_guess).tan();
        let fit = fit_pointing(&stars, &xy, 512.0, 512.0, Some(f_guess), &RefineOptions::default()).unwrap();
        prop_assert!(fit.converged);
        prop_assert!(((fit.camera.focal_length_px - f) / f).abs() < 1e-9);
        prop_assert!((fit.r_icrs_to_cam.matrix() - r.matrix()).norm() < 1e-9);
    }
}

/// Monte Carlo at 0.1 px on a 12°/512 px frame: the scatter of the boresight (and f) matches
/// the predicted covariance within 10 %.
#[test]
fn monte_carlo_scatter_matches_prediction() {
    let f = focal_12deg();
    let off = [[230.0, 20.0], [-100.0, 200.0], [-120.0, -190.0]];
    for fit_focal in [false, true] {
        let mc = monte_carlo_distances(&off, f, 0.1, fit_focal, 4000, 11).unwrap();
        assert_eq!(mc.outliers, 0);
        let pred = (mc.predicted[(0, 0)] + mc.predicted[(1, 1)]).sqrt();
        let got = (mc.sample[(0, 0)] + mc.sample[(1, 1)]).sqrt();
        assert!(
            (got / pred - 1.0).abs() < 0.1,
            "fit_focal {fit_focal}: {got} vs {pred}"
        );
        for k in 0..mc.predicted.nrows() {
            let ratio = (mc.sample[(k, k)] / mc.predicted[(k, k)]).sqrt();
            assert!((ratio - 1.0).abs() < 0.1, "parameter {k}: ratio {ratio}");
        }
    }
}

#[test]
fn star_choice_prefers_spread_edge_stars() {
    let f = focal_12deg();
    // A frame: a tight group near the centre, three edge stars ~120° apart, one more.
    let off = [
        [10.0, 5.0],
        [25.0, -12.0],
        [-8.0, 20.0],
        [240.0, 10.0],
        [-115.0, 205.0],
        [-125.0, -200.0],
        [60.0, 60.0],
    ];
    let (chosen, sigma3) = choose_stars(&off, f, 3, false).unwrap();
    assert_eq!(chosen, vec![3, 4, 5]);
    let (chosen5, sigma5) = choose_stars(&off, f, 5, false).unwrap();
    assert!(chosen5.len() == 5 && sigma5 < sigma3);
    assert!(choose_stars(&[[1.0, 0.0], [5.0, 0.0], [-9.0, 0.0]], f, 3, false).is_err());
    assert!(choose_stars(&off, f, 2, false).is_err());
}

#[test]
fn bad_input_is_an_error() {
    let f = focal_12deg();
    let r = Rotation3::identity();
    let (stars, a) = sky(&r, &[[100.0, 0.0], [0.0, 100.0], [-80.0, -60.0]], f);
    assert!(boresight_from_distances(&stars[..2], &a[..2], Some(f)).is_err());
    assert!(boresight_from_distances(&stars, &a[..2], Some(f)).is_err());
    assert!(boresight_from_distances(&stars, &[f64::NAN, 1.0, 2.0], Some(f)).is_err());
    assert!(boresight_from_distances(&stars, &[-1.0, 1.0, 2.0], Some(f)).is_err());
    assert!(boresight_from_distances(&stars, &a, Some(0.0)).is_err());
    assert!(boresight_from_distances(&stars, &a, Some(f64::INFINITY)).is_err());
    assert!(boresight_from_distances(&[stars[0], stars[0], stars[1]], &a, Some(f)).is_err());
    assert!(boresight_from_distances(&stars, &[0.0, 0.0, 0.0], None).is_err());
    let xy = [[1.0, 2.0], [3.0, f64::NAN], [5.0, 6.0]];
    assert!(fit_pointing(
        &stars,
        &xy,
        512.0,
        512.0,
        Some(f),
        &RefineOptions::default()
    )
    .is_err());
}
