//! A batch learns the magnitude zero point: Kelvins-style scenes (3–20 stars among 40–80 false
//! spots) with instrument magnitudes (the catalogue's plus an unknown constant) are identified
//! from the brightness order alone where they can be; the zero point those frames agree on then
//! gates a second search of the rest. Frames whose zero points disagree teach nothing.

use starid_core::simulate::Family;
use starid_core::{Camera, FrameRef, IdentifyConfig, SimFrame, Solver, Status};

use super::strategies::bundled;

const ZERO_POINT: f64 = 4.2;

/// `n` K1 scenes, their camera and solver, and their magnitudes with frame `k`'s zero point
/// `zero(k)`.
fn scenes(n: u64, zero: impl Fn(usize) -> f64) -> (Solver, Camera, Vec<SimFrame>, Vec<Vec<f64>>) {
    let catalog = bundled();
    let camera = Family::K1.camera();
    let solver = Solver::for_camera(catalog.clone(), &camera).unwrap();
    let scenes: Vec<_> = (0..n)
        .map(|s| Family::K1.simulate(&catalog, s).unwrap())
        .collect();
    let mags = scenes
        .iter()
        .enumerate()
        .map(|(k, f)| f.magnitudes.iter().map(|m| m + zero(k)).collect())
        .collect();
    (solver, camera, scenes, mags)
}

/// The frames as a batch takes them.
fn refs<'a>(scenes: &'a [SimFrame], mags: &'a [Vec<f64>]) -> Vec<FrameRef<'a>> {
    scenes
        .iter()
        .zip(mags)
        .map(|(f, m)| (f.centroids.as_slice(), Some(m.as_slice())))
        .collect()
}

#[test]
fn a_batch_learns_its_zero_point_and_identifies_more_hostile_scenes_with_it() {
    let (solver, camera, scenes, mags) = scenes(40, |_| ZERO_POINT);
    let refs = refs(&scenes, &mags);
    let alone = IdentifyConfig {
        mag_offset: None,
        learn_zero_point: false,
        ..Default::default()
    };
    let learning = IdentifyConfig {
        learn_zero_point: true,
        ..alone.clone()
    };
    let first = solver.identify_batch(&refs, &camera, &alone, None).unwrap();
    let ids = solver
        .identify_batch(&refs, &camera, &learning, None)
        .unwrap();
    let wrong = |ids: &[Option<u32>], truth: &[Option<u32>]| {
        ids.iter()
            .zip(truth)
            .filter(|(a, b)| a.is_some() && a != b)
            .count()
    };
    let (mut before, mut after, mut relearned) = (0, 0, 0);
    for ((f, a), b) in scenes.iter().zip(&first).zip(&ids) {
        assert_eq!(wrong(&a.catalog_index, &f.catalog_index), 0);
        assert_eq!(wrong(&b.catalog_index, &f.catalog_index), 0);
        assert!(a.learned_mag_offset.is_none());
        before += usize::from(a.is_identified());
        after += usize::from(b.is_identified());
        match b.learned_mag_offset {
            // Only frames the first search left unidentified are searched again.
            Some(z) => {
                assert!(!a.is_identified() && b.is_identified());
                assert!((z - ZERO_POINT).abs() < 0.1, "learned {z}");
                relearned += 1;
            }
            None => assert_eq!(a.catalog_index, b.catalog_index),
        }
    }
    // Measured: 19 of 40 alone, 37 with the learned zero point.
    assert!(
        relearned >= 10,
        "{before} -> {after}, {relearned} by the zero point"
    );
    assert_eq!(after, before + relearned);
}

#[test]
fn frames_whose_zero_points_disagree_teach_the_batch_nothing() {
    // Every frame its own zero point, two magnitudes apart.
    let (solver, camera, scenes, mags) = scenes(16, |k| 2.0 * k as f64);
    let refs = refs(&scenes, &mags);
    let cfg = IdentifyConfig {
        mag_offset: None,
        ..Default::default()
    };
    let ids = solver.identify_batch(&refs, &camera, &cfg, None).unwrap();
    let alone = IdentifyConfig {
        learn_zero_point: false,
        ..cfg
    };
    let first = solver.identify_batch(&refs, &camera, &alone, None).unwrap();
    // Enough frames measured a zero point to learn one, had they agreed.
    let measured = ids
        .iter()
        .zip(&mags)
        .filter(|(id, m)| id.is_identified() && id.zero_point(m, solver.catalog()).is_some())
        .count();
    assert!(measured >= 3, "{measured} frames measured a zero point");
    for (a, b) in first.iter().zip(&ids) {
        assert!(b.learned_mag_offset.is_none());
        assert_eq!((a.status, &a.catalog_index), (b.status, &b.catalog_index));
    }
    assert!(ids.iter().any(|id| id.status != Status::Identified));
}
