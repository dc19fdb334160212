//! The focal check: frames identified with a field of view given 1 % off are searched again with
//! the focal length their residuals imply (mirrored frames too); frames given the right one
//! never are.

use starid_core::geometry::rotation_angle_between;
use std::sync::Arc;

use starid_core::simulate::{simulate, SimConfig, SimFrame};
use starid_core::{Camera, Catalog, Identification, IdentifyConfig, Solver};

use super::strategies::bundled;

#[test]
fn a_field_of_view_given_one_percent_off_is_corrected_by_the_residuals() {
    let catalog = bundled();
    let size = 1024.0;
    let truth = Camera::from_fov(20f64.to_radians(), size, size).unwrap();
    let given = Camera::from_fov(20.2f64.to_radians(), size, size).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &truth).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        ..Default::default()
    };
    let checked = IdentifyConfig::default();
    let fixed = IdentifyConfig {
        focal_check: false,
        ..Default::default()
    };
    let wrong = |ids: &[Option<u32>], truth: &[Option<u32>]| {
        ids.iter()
            .zip(truth)
            .filter(|(a, b)| a.is_some() && a != b)
            .count()
    };
    let (mut corrected, mut named_fixed, mut named_checked) = (0, 0, 0);
    for seed in 0..40u64 {
        // Odd seeds mirrored: the scale is about the mirrored principal point there.
        let sim = SimConfig {
            mirrored: seed % 2 == 1,
            ..sim.clone()
        };
        let f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let m = Some(f.magnitudes.as_slice());
        // The right field of view: never corrected.
        let exact = solver.identify(&f.centroids, m, &truth, &checked).unwrap();
        assert_eq!(
            (exact.focal_length_px, exact.k1),
            (None, None),
            "seed {seed}"
        );
        assert!(exact.focal_sigma_px.is_nan());
        let a = solver.identify(&f.centroids, m, &given, &fixed).unwrap();
        let b = solver.identify(&f.centroids, m, &given, &checked).unwrap();
        assert_eq!(a.focal_length_px, None);
        named_fixed += a.matched;
        named_checked += b.matched;
        if let Some(focal) = b.focal_length_px {
            corrected += 1;
            let rel = focal / truth.focal_length_px - 1.0;
            assert!(rel.abs() < 2e-3, "seed {seed}: focal {rel:+.2e} off");
            assert!(b.focal_sigma_px > 0.0 && b.focal_sigma_px < 0.002 * focal);
            // As many spots named, or (a search within the field's tolerance) nearly as many
            // with far tighter residuals: a radius widened for the scale takes in a spot or two.
            assert!(b.matched + 2 >= a.matched, "seed {seed}");
            if b.matched < a.matched {
                assert!(
                    2.0 * b.centroid_sigma_px < a.centroid_sigma_px,
                    "seed {seed}"
                );
            }
            assert!(
                wrong(&b.catalog_index, &f.catalog_index)
                    <= wrong(&a.catalog_index, &f.catalog_index)
            );
        } else {
            assert_eq!(a.catalog_index, b.catalog_index, "seed {seed}");
        }
    }
    // 21 of the 40 frames, 934 -> 1455 stars named when this was written.
    assert!(corrected >= 10, "{corrected} frames corrected");
    assert!(
        named_checked > named_fixed + 300,
        "{named_checked} vs {named_fixed}"
    );
}

#[test]
fn an_unknown_radial_distortion_is_found_with_the_focal_length() {
    // A 20° lens with barrel distortion k1 = −0.2 (11 px at the corners), given as ideal.
    let catalog = bundled();
    let size = 1024.0;
    let ideal = Camera::from_fov(20f64.to_radians(), size, size).unwrap();
    let truth = ideal.with_k1(-0.2).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &ideal).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        ..Default::default()
    };
    let fixed = IdentifyConfig {
        focal_check: false,
        ..Default::default()
    };
    let (mut found, mut named_fixed, mut named_checked, mut real) = (0, 0, 0, 0);
    for seed in 0..30u64 {
        let sim = SimConfig {
            mirrored: seed % 2 == 1,
            ..sim.clone()
        };
        let f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let m = Some(f.magnitudes.as_slice());
        let a = solver.identify(&f.centroids, m, &ideal, &fixed).unwrap();
        let b = solver
            .identify(&f.centroids, m, &ideal, &IdentifyConfig::default())
            .unwrap();
        let wrong = |ids: &[Option<u32>]| {
            ids.iter()
                .zip(&f.catalog_index)
                .filter(|(x, y)| x.is_some() && x != y)
                .count()
        };
        assert_eq!(wrong(&b.catalog_index), 0, "seed {seed}");
        (named_fixed, named_checked) = (named_fixed + a.matched, named_checked + b.matched);
        real += f.real_stars();
        if let Some(k1) = b.k1 {
            found += 1;
            assert!((k1 + 0.2).abs() < 0.05, "seed {seed}: k1 {k1}");
            let focal = b.focal_length_px.expect("set with k1");
            assert!(
                (focal / ideal.focal_length_px - 1.0).abs() < 2e-3,
                "seed {seed}"
            );
        }
    }
    // 27 of 30 frames (k1 within 0.035), 1 102 -> 1 310 of 1 321 stars named when this was
    // written.
    assert!(found >= 20, "{found} frames found k1");
    assert!(named_checked > named_fixed + 100 && 100 * named_checked > 97 * real);
}

/// A field of view is an estimate: given up to 10 % off (either way), frames identify with the
/// focal length found and no wrong id; given 20 % off, beyond the tolerance, they cost
/// identifications but never name a star wrong. Without the tolerance a field 8 % off
/// identifies almost nothing.
#[test]
fn a_field_of_view_within_its_tolerance_identifies_and_one_beyond_it_is_never_wrong() {
    let catalog = bundled();
    let size = 512.0;
    let truth = Camera::from_fov(12f64.to_radians(), size, size).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &truth).unwrap();
    let sim = SimConfig {
        noise_px: 0.2,
        mag_noise: 0.1,
        ..Default::default()
    };
    let frames: Vec<_> = (0..24u64)
        .map(|seed| {
            let sim = SimConfig {
                mirrored: seed % 2 == 1,
                ..sim.clone()
            };
            simulate(&catalog, &truth, &sim, 100 + seed).unwrap()
        })
        .filter(|f| f.real_stars() >= 8)
        .collect();
    let run = |off: f64, config: &IdentifyConfig| {
        let given = Camera::from_fov(12f64.to_radians() * (1.0 + off), size, size).unwrap();
        let (mut identified, mut wrong, mut focal_err) = (0, 0, 0f64);
        for f in &frames {
            let r = solver
                .identify(&f.centroids, Some(&f.magnitudes), &given, config)
                .unwrap();
            wrong += r
                .catalog_index
                .iter()
                .zip(&f.catalog_index)
                .filter(|(a, b)| a.is_some() && a != b)
                .count();
            if r.is_identified() {
                identified += 1;
                // The attitude is right (a focal length kept off by a few percent scales the
                // field about its centre, and the pointing stays), and a focal length found is.
                let turn = rotation_angle_between(&r.r_icrs_to_cam.unwrap(), &f.r_icrs_to_cam);
                assert!(
                    turn.to_degrees() < 0.05,
                    "{off}: attitude off by {turn} rad"
                );
                if let Some(focal) = r.focal_length_px {
                    focal_err = focal_err.max((focal / truth.focal_length_px - 1.0).abs());
                }
            }
        }
        (identified, wrong, focal_err)
    };
    let tolerant = IdentifyConfig::default();
    assert!(tolerant.fov_tolerance >= 0.1);
    for off in [-0.08, -0.04, 0.03, 0.06, 0.1] {
        let (identified, wrong, focal_err) = run(off, &tolerant);
        assert_eq!(wrong, 0, "{off}");
        assert!(
            identified + 1 >= frames.len(),
            "{off}: {identified}/{}",
            frames.len()
        );
        assert!(focal_err < 2e-3, "{off}: focal error {focal_err}");
    }
    for off in [-0.2, 0.2] {
        assert_eq!(run(off, &tolerant).1, 0, "{off}");
    }
    let exact = IdentifyConfig {
        fov_tolerance: 0.0,
        ..Default::default()
    };
    let (identified, wrong, _) = run(0.08, &exact);
    assert_eq!(wrong, 0);
    assert!(identified * 4 < frames.len(), "{identified}");
}

/// The bundled catalogue, a 12° camera of 512 px, that camera with its field given `factor`
/// times too wide, and a solver for it.
fn field_12_given_off(factor: f64) -> (Arc<Catalog>, Camera, Camera, Solver) {
    let (catalog, truth, solver) = sensor(12.0, (512.0, 512.0));
    let given = Camera::from_fov(12f64.to_radians() * factor, 512.0, 512.0).unwrap();
    (catalog, truth, given, solver)
}

/// The bundled catalogue, a camera of `fov_deg` on a sensor of `size` px and its solver.
fn sensor(fov_deg: f64, (w, h): (f64, f64)) -> (Arc<Catalog>, Camera, Solver) {
    let catalog = bundled();
    let truth = Camera::from_fov(fov_deg.to_radians(), w, h).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &truth).unwrap();
    (catalog, truth, solver)
}

/// Whether every spot `id` names is the star the frame put there.
fn names_no_wrong_star(id: &Identification, f: &SimFrame) -> bool {
    id.catalog_index
        .iter()
        .zip(&f.catalog_index)
        .all(|(a, b)| a.is_none() || a == b)
}

#[test]
fn a_field_given_off_is_searched_over_its_range_before_the_given_focal_length_spends_its_budget() {
    // Held exact, a field 5 % off spends the whole budget at the focal length given and finds
    // nothing; as an estimate, the search over the range comes after a short first search and
    // finds the frame with a fraction of those hypotheses.
    let (catalog, truth, given, solver) = field_12_given_off(1.05);
    let held = IdentifyConfig {
        fov_tolerance: 0.0,
        mag_offset: None,
        ..Default::default()
    };
    let estimate = IdentifyConfig {
        mag_offset: None,
        ..Default::default()
    };
    let mut compared = 0;
    for seed in 0..8u64 {
        let sim = SimConfig {
            noise_px: 0.2,
            mag_noise: 0.3,
            ..Default::default()
        };
        let f = simulate(&catalog, &truth, &sim, 300 + seed).unwrap();
        if f.real_stars() < 8 {
            continue;
        }
        let m = Some(&f.magnitudes[..]);
        let spent = solver.identify(&f.centroids, m, &given, &held).unwrap();
        let found = solver.identify(&f.centroids, m, &given, &estimate).unwrap();
        assert!(found.is_identified(), "{seed}");
        assert!(names_no_wrong_star(&found, &f));
        if !spent.is_identified() {
            compared += 1;
            assert!(
                4 * found.hypotheses < spent.hypotheses,
                "{seed}: {} hypotheses against {} held exact",
                found.hypotheses,
                spent.hypotheses
            );
        }
    }
    assert!(compared >= 4, "{compared}");
}

#[test]
fn a_field_a_little_off_is_found_under_a_wide_tolerance_with_a_narrow_ones_bound() {
    // A field 2.5 % off, as a lens's nominal focal length gives it, on frames the focal length
    // given does not identify. The search over focal lengths counts every catalogue triangle it
    // closes in the false-match bound; under the default ±10 % tolerance the near focal lengths
    // come first, so the frame is found with the bound a ±3 % tolerance gives it, not the three
    // to thirteen times larger one of a search over the whole range.
    let (catalog, truth, given, solver) = field_12_given_off(1.025);
    let tolerance = |t: f64| IdentifyConfig {
        fov_tolerance: t,
        mag_offset: None,
        ..Default::default()
    };
    let mut compared = 0;
    for seed in 0..60u64 {
        let sim = SimConfig {
            mag_limit: Some(6.0),
            noise_px: 0.2,
            mag_noise: 0.3,
            ..Default::default()
        };
        let f = simulate(&catalog, &truth, &sim, 500 + seed).unwrap();
        let m = Some(&f.magnitudes[..]);
        let held = solver.identify(&f.centroids, m, &given, &tolerance(0.0));
        if f.real_stars() < 6 || held.unwrap().is_identified() {
            continue;
        }
        let wide = solver
            .identify(&f.centroids, m, &given, &tolerance(0.1))
            .unwrap();
        let narrow = solver
            .identify(&f.centroids, m, &given, &tolerance(0.03))
            .unwrap();
        if !narrow.is_identified() {
            continue;
        }
        assert!(wide.is_identified(), "{seed}");
        assert!(names_no_wrong_star(&wide, &f));
        let (w, n) = (wide.false_match_probability, narrow.false_match_probability);
        assert!(
            w <= 1.5 * n,
            "{seed}: bound {w:e} at ±10 % against {n:e} at ±3 %"
        );
        compared += 1;
    }
    assert!(compared >= 8, "{compared}");
}

#[test]
fn a_field_given_off_is_found_among_noise_peaks() {
    // A 10° sensor of 1400 × 1000 px: stars to 6.5 among 2000 noise peaks as bright as all but
    // the four brightest stars, as an extractor leaves them on a noisy real frame. The search
    // over the range fixes the focal length from triangles of the ten brightest spots, most of
    // them noise here; the grid of focal lengths about the given one finds what the field as
    // given would have, with the focal length refined over the stars.
    use rand::SeedableRng;
    let (catalog, truth, solver) = sensor(10.0, (1400.0, 1000.0));
    let sim = SimConfig {
        mag_limit: Some(6.5),
        noise_px: 0.3,
        mag_noise: 0.2,
        ..Default::default()
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    for off in [0.01, -0.02] {
        let given = Camera::from_fov((10.0f64 * (1.0 + off)).to_radians(), 1400.0, 1000.0).unwrap();
        let frames = (0..20).map(|seed| simulate(&catalog, &truth, &sim, seed).unwrap());
        let found = among_noise_peaks(&solver, &given, frames, (2000, 4), &mut rng);
        let identified = found.len();
        for (seed, id) in found {
            let focal = id.focal_length_px.expect("the focal length found");
            assert!(
                (focal / truth.focal_length_px - 1.0).abs() < 1e-3,
                "seed {seed}, {off:+}: focal {focal}"
            );
        }
        // 18 of 20 each; the search over the range alone names 15 and 13.
        assert!(identified >= 17, "{off:+}: {identified} of 20");
    }
}

#[test]
fn a_batch_learns_the_focal_length_its_frames_agree_on() {
    // One camera whose field is given 6 % wide: beyond the grid about the given focal length
    // (±4 % on 1400 px), so a frame is found by the search over the range from its brightest
    // spots. Half the frames are clean; in the others noise peaks as bright as all but the
    // brightest stars crowd those spots out. The clean frames agree on the focal length, and
    // the batch searches the others again at it.
    use rand::SeedableRng;
    let catalog = bundled();
    let truth = Camera::from_fov(10f64.to_radians(), 1400.0, 1000.0).unwrap();
    let given = Camera::from_fov(10.6f64.to_radians(), 1400.0, 1000.0).unwrap();
    let solver = Solver::for_camera(catalog.clone(), &given).unwrap();
    let sim = SimConfig {
        mag_limit: Some(6.5),
        noise_px: 0.3,
        mag_noise: 0.2,
        ..Default::default()
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(9);
    let mut frames = Vec::new();
    for seed in 0..16u64 {
        let f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let peaks = if seed % 2 == 1 { 300 } else { 0 };
        let (xy, mags) = with_noise_peaks(&f, peaks, 3, &mut rng);
        frames.push((f, xy, mags));
    }
    let config = IdentifyConfig::default();
    let refs: Vec<_> = frames
        .iter()
        .map(|(_, xy, m)| (xy.as_slice(), Some(m.as_slice())))
        .collect();
    let alone: Vec<_> = refs
        .iter()
        .map(|(xy, m)| solver.identify(xy, *m, &given, &config).unwrap())
        .collect();
    let batch = solver
        .identify_batch(&refs, &given, &config, Some(1))
        .unwrap();
    let named =
        |ids: &[starid_core::Identification]| ids.iter().filter(|i| i.is_identified()).count();
    for (id, (f, _, _)) in batch.iter().zip(&frames) {
        for (k, got) in id.catalog_index.iter().enumerate() {
            assert!(got.is_none() || (k < f.catalog_index.len() && *got == f.catalog_index[k]));
        }
        if id.is_identified() {
            let focal = id
                .focal_length_px
                .expect("a focal length other than the given one");
            assert!(
                (focal / truth.focal_length_px - 1.0).abs() < 2e-3,
                "focal {focal}"
            );
        }
    }
    // 9 of 16 alone, 15 as a batch.
    let (a, b) = (named(&alone), named(&batch));
    assert!(b >= a + 4 && b >= 14, "alone {a}, batch {b}");
}

/// A frame's spots with `peaks` noise peaks spread over a 1400 × 1000 px sensor, each as bright
/// as the star of rank `rank` (0: the brightest) or up to 3 magnitudes fainter: the centroids
/// and magnitudes.
fn with_noise_peaks(
    f: &starid_core::simulate::SimFrame,
    peaks: usize,
    rank: usize,
    rng: &mut rand::rngs::StdRng,
) -> (Vec<[f64; 2]>, Vec<f64>) {
    use rand::Rng;
    let mut sorted = f.magnitudes.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[rank.min(sorted.len() - 1)];
    let (mut xy, mut mags) = (f.centroids.clone(), f.magnitudes.clone());
    for _ in 0..peaks {
        xy.push([rng.random_range(0.0..1400.0), rng.random_range(0.0..1000.0)]);
        mags.push(floor + rng.random_range(0.0..3.0));
    }
    (xy, mags)
}

/// Each frame (numbered from 0) identified among `peaks.0` noise peaks as bright as all but its
/// `peaks.1` brightest stars ([`with_noise_peaks`]) with the camera `given`: the frames
/// identified, by number, each checked to name no spot wrong and to pass the default bound.
fn among_noise_peaks(
    solver: &Solver,
    given: &Camera,
    frames: impl IntoIterator<Item = SimFrame>,
    peaks: (usize, usize),
    rng: &mut rand::rngs::StdRng,
) -> Vec<(usize, Identification)> {
    let config = IdentifyConfig::default();
    let mut found = Vec::new();
    for (n, f) in frames.into_iter().enumerate() {
        let (xy, mags) = with_noise_peaks(&f, peaks.0, peaks.1, rng);
        let id = solver.identify(&xy, Some(&mags), given, &config).unwrap();
        let peaks_unnamed = id.catalog_index[f.centroids.len()..]
            .iter()
            .all(Option::is_none);
        assert!(
            names_no_wrong_star(&id, &f) && peaks_unnamed,
            "frame {n}: a spot named wrong"
        );
        if id.is_identified() {
            assert!(id.false_match_probability <= config.max_false_match_prob);
            found.push((n, id));
        }
    }
    found
}

#[test]
fn a_cluster_that_fits_a_field_given_off_does_not_name_far_spots_after_other_stars() {
    // Frames of a 20°/1024 px camera with a tight cluster (the Pleiades) near an edge. Given a
    // field 2 % or 6 % off, the cluster alone fits the focal length given (or one the focal
    // check moved a little), and a spot or two far from it once took the names of stars that
    // the wrong scale carried onto them. The spots' magnitudes as a camera gives them: 0.3 mag
    // of scatter about an unknown zero point.
    use rand::{Rng, SeedableRng};
    let (catalog, truth, solver) = sensor(20.0, (1024.0, 1024.0));
    let sim = SimConfig {
        mag_limit: Some(6.0),
        noise_px: 0.2,
        mag_noise: 0.1,
        ..Default::default()
    };
    let config = IdentifyConfig {
        mag_offset: None,
        ..Default::default()
    };
    for (seed, off) in [(71u64, 0.02), (288, 0.06)] {
        let mut f = simulate(&catalog, &truth, &sim, seed).unwrap();
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x5eed);
        let scatter = rand_distr::Normal::new(0.0, 0.3).unwrap();
        let zero_point = rng.random_range(-8.0..8.0);
        for m in &mut f.magnitudes {
            *m += zero_point + rng.sample(scatter);
        }
        let given = Camera::from_fov(20f64.to_radians() * (1.0 + off), 1024.0, 1024.0).unwrap();
        let id = solver
            .identify(&f.centroids, Some(&f.magnitudes), &given, &config)
            .unwrap();
        assert!(names_no_wrong_star(&id, &f), "seed {seed}");
        // The search over the field's range finds the frame: most of its spots named.
        assert!(
            2 * id.matched > f.centroids.len(),
            "seed {seed}: {} named",
            id.matched
        );
    }
}

#[test]
fn five_stars_among_noise_peaks_a_field_given_slightly_off_are_found_on_the_grid() {
    // Frames of five stars among 60 noise peaks as bright as all but the three brightest, as a
    // narrow camera's faint frames give them, with the field given 0.4 % wide (a nominal value
    // for a measured one). The search over the range works from triangles of the brightest
    // spots, mostly noise here; the grid's focal lengths near the given one share half its
    // bound, so five well-placed stars pass it where a bound shared over the whole grid fails.
    use rand::SeedableRng;
    let (catalog, truth, solver) = sensor(10.0, (1400.0, 1000.0));
    let sim = SimConfig {
        mag_limit: Some(5.2),
        noise_px: 0.15,
        mag_noise: 0.1,
        ..Default::default()
    };
    let given = Camera::from_fov(10.04f64.to_radians(), 1400.0, 1000.0).unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let of_five: Vec<SimFrame> = (0..400)
        .map(|seed| simulate(&catalog, &truth, &sim, seed).unwrap())
        .filter(|f| f.centroids.len() == 5)
        .collect();
    let frames = of_five.len();
    let identified = among_noise_peaks(&solver, &given, of_five, (60, 3), &mut rng).len();
    assert!(frames >= 20, "{frames} frames of five stars");
    // 25 of 25; a bound shared evenly over the grid, with six stars asked of it, names 15.
    assert!(10 * identified >= 9 * frames, "{identified} of {frames}");
}
