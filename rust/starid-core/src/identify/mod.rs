//! Lost-in-space identification: Pyramid search over the k-vector, verification of every
//! hypothesis against the catalogue, attitude from all matched stars.
//!
//! # Algorithm
//! 1. Centroids become camera-frame unit vectors (and their mirror images, x reversed).
//! 2. Triangles of observed stars are visited in Mortari's Pyramid order over the brightest
//!    `max_search_stars` (brightness order when magnitudes are given, input order otherwise),
//!    so that one false star cannot block the search.
//! 3. For a triangle, the k-vector returns the catalogue pairs matching each side within
//!    `ε = 3·√2·σ/f`; catalogue triangles are the closed loops of the three pair sets.
//!    The sign of the triple product of the observed and the catalogue triangle says whether
//!    the frame is mirrored: both handednesses are searched without being told.
//! 4. Each catalogue triangle is a *hypothesis*: an attitude is solved from its three stars and
//!    must be confirmed by a fourth observed star landing on a catalogue star (the Pyramid's
//!    fourth star, found through the catalogue's zone index). In crowded frames, where a chance
//!    fourth star is likely, more confirming stars are required (chance below [`CONFIRM_CHANCE`]).
//! 5. A confirmed hypothesis is verified: every centroid is matched to its nearest catalogue star,
//!    the attitude is re-solved from all matches (Wahba/SVD), the centroid noise is estimated
//!    from the residuals and the match radius widened to 4σ of it (never narrowed below 5σ of
//!    the step), and the *false-match bound* is
//!    computed (below). Only a solution with at least `min_matches` stars and a bound below
//!    `max_false_match_prob` is reported; otherwise the search goes on. With magnitudes, a match
//!    whose centroid is far brighter than its catalogue star is dropped first
//!    ([`MAG_BRIGHTER_LIMIT`]).
//!
//! # The false-match bound
//! Under a wrong hypothesis, each of the `n − 3` centroids outside the triangle lands within the
//! match radius `r` of some catalogue star with probability `p = ρ·π·r²`, with `ρ` the local
//! catalogue density (stars per steradian in the field). The chance that at least `m − 3` of them
//! do is the binomial tail `T = P(Bin(n − 3, p) ≥ m − 3)`. A union bound over the `H` hypotheses
//! tested so far gives `P(false) ≤ H·T`, which is what [`Identification::false_match_probability`]
//! reports.
//!
//! # Tolerances that adapt
//! When the centroid noise is not given, the search runs a ladder of noise levels
//! ([`SIGMA_LADDER_PX`]): tight first (strong verification, fast), then looser. All but the last
//! step try at most [`TRIANGLES_PER_STEP`] triangles.

use std::f64::consts::SQRT_2;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::{Rotation3, Vector3};

use crate::attitude::wahba_from;
use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::Camera;
use crate::kvector::PairIndex;
use crate::sky::DensityMap;

mod batch;
mod cache;
mod cancel;
mod config;
mod empty;
mod focal;
mod frame;
mod hinted;
mod join;
mod lone;
mod magbins;
mod near;
mod noise;
mod plan;
mod pyramid;
mod result;
pub mod scale;
mod search;
mod seeds;
mod solver;
mod stats;
mod stored;
mod tolerance;
pub mod unknown_focal;
mod verify;
mod voting;

pub(crate) use batch::agreed_noise;
pub use batch::{map_frames, FrameRef};
pub use cache::SolverCache;
pub(crate) use cancel::stop_now;
pub use cancel::Cancel;
pub use config::*;
use frame::*;
pub(crate) use frame::{validate_centroids, Call};
pub use hinted::{AttitudeHint, HintFallback, HINT_SEARCH_STARS, MAX_HINT_UNCERTAINTY_RAD};
pub use magbins::MagPairIndex;
pub(crate) use plan::Pass;
pub use result::*;
use search::*;
pub use seeds::{SeedTables, RING_ORDER, RING_SLACK, SEED_CANDIDATES};
pub use solver::*;
pub(crate) use stats::{binomial_tail, median_in_place};
pub use stored::{catalog_key, INDEX_FILE_FORMAT, MIN_STORED_PAIRS};
pub(crate) use verify::AMBIGUITY_LOG_ODDS;

/// Frames a batch runs between two looks at its cancel flag (and the most results a cancelled
/// batch has allocated beyond the chunks it finished).
pub const BATCH_CHUNK: usize = 16_384;

/// Centroid noise levels (1σ per axis, pixels) tried in turn when none is given.
pub const SIGMA_LADDER_PX: [f64; 3] = [0.2, 0.7, 2.5];

/// How far above a stated noise the default ladder's next step lies (see
/// [`IdentifyConfig::noise_ladder`]).
pub const NOISE_LADDER_GAP: f64 = 2.5;

/// Fewest matches of a frame whose residuals a batch learns the centroid noise from.
pub const NOISE_LEARN_MIN_MATCHES: usize = 8;

/// Fewest such frames for a batch to learn the noise.
pub const NOISE_LEARN_MIN_FRAMES: usize = 3;

/// A learned noise below this fraction of the ladder's first step has a batch's failed frames
/// searched again with it (above, the ladder has tried as tight a noise already).
pub const NOISE_LEARN_BELOW_LADDER: f64 = 0.75;

/// Fewest frames of a batch, identified with a focal length other than the given camera's (the
/// focal check's or the search within the tolerance's), from which the batch learns the focal
/// length.
pub const FOCAL_LEARN_MIN_FRAMES: usize = 3;

/// A solution whose noise estimate reached this (pixels), found with a given field of view that
/// the focal check did not confirm, leaves the field in doubt (see
/// [`IdentifyConfig::fov_tolerance`]).
pub const DOUBT_SIGMA_PX: f64 = 0.5;
/// So does a solution naming fewer stars than this (too few for the focal check to see a scale).
pub const DOUBT_MATCHES: usize = 12;
/// How many more spots (at least; a quarter more where that is more) another focal length must
/// line up with stars to put a given one in doubt.
pub const DOUBT_MORE_SPOTS: usize = 3;
/// Catalogue pairs the search within the field's tolerance may visit (triangle bases, and each
/// focal length's identification).
pub const TOLERANCE_MAX_PAIRS: usize = 100_000;

/// Catalogue pairs the first search at a focal length given as an estimate may visit before
/// the search within the tolerance ([`IdentifyConfig::fov_tolerance`]) runs; the rest of the
/// budget is spent at the focal length given only where that finds nothing.
pub const QUICK_FIRST_PAIRS: usize = 100_000;

/// Triangles tried at each step of the ladder but the last before moving to a looser step.
pub const TRIANGLES_PER_STEP: usize = 60;

/// The full pass at the loosest step of the noise ladder may visit this share of
/// `max_pairs_visited` (500 000 catalogue pairs by default). Its tolerances are the widest, so
/// each triangle of spots meets tens to hundreds of catalogue triangles, and a solution needs
/// many matches to pass the bound: the frames only it identifies have many stars and are found
/// within its first triangles. On the simulated families (S1–S5 and K1 with magnitudes and
/// with the order alone, fields of view 1–2 % off, the contest catalogue with 1.5–2 px noise)
/// the budget changed no identification, and frames of a dozen spots with four or five real
/// stars among false ones stop after about 18 ms instead of 40.
pub const LOOSEST_STEP_SHARE: usize = 6;

/// Catalogue pairs each ungated pass of a crowded frame (more than twice `max_search_stars`
/// spots) may visit.
pub const CROWDED_PAIRS_PER_STEP: usize = 500_000;

/// In crowded frames the tighter steps try at least 1/this of the search stars' triangles.
pub const CROWDED_TRIANGLE_SHARE: usize = 4;

/// Match radius in units of the ladder step's σ; the false-match bound is computed with it.
pub const MATCH_RADIUS_SIGMAS: f64 = 5.0;

/// A solution whose false-match bound is below this is reported at once; a weaker one only
/// after [`TRIANGLES_AFTER_WEAK`] more triangles found nothing stronger.
pub const STRONG_FALSE_MATCH_PROB: f64 = 1e-9;

/// Triangles tried after a weak solution in search of a stronger one.
pub const TRIANGLES_AFTER_WEAK: usize = 40;

/// Chance, under a false hypothesis, of meeting the confirmation count; more confirmations
/// are required until it is below this.
pub const CONFIRM_CHANCE: f64 = 1e-2;

/// A catalogue star is *locally bright* when fewer than this many stars brighter than it lie
/// within half the width of a square field (see [`Catalog::locally_bright`]).
pub const BRIGHT_MAX_BRIGHTER: usize = 6;

/// With magnitudes, triangles of this many brightest centroids are first searched among the
/// pairs of locally bright stars only (a small fraction of all pairs), then the whole index.
pub const BRIGHT_SEARCH_STARS: usize = 6;

/// Without a magnitude gate, after the bright passes over [`BRIGHT_SEARCH_STARS`] spots, one more
/// over this many brightest spots against the locally bright pairs (a sixteenth of the index:
/// each triangle's join costs that much less) at the tightest step, for frames of at most
/// `max_search_stars` spots. With the order alone it cut the p99 of 12°/512 px frames with 5
/// false spots from 2.8 to 0.57 ms, and it identifies 7 more of 1000 K1 scenes, at no cost in
/// the other scenarios (`examples/scenarios.rs`, `examples/families.rs`).
pub const BRIGHT_WIDE_SEARCH_STARS: usize = 12;

/// With magnitudes, a matched centroid brighter than its catalogue star (after the frame's
/// instrument offset, the median over the matches) by more than this many magnitudes, or by
/// [`MAG_OUTLIER_SIGMAS`] robust standard deviations if that is more, is not that star: usually
/// a false star on the spot of a catalogue star too faint to be seen. A star fainter than
/// expected (saturated, variable) keeps its id, unless another star within the match radius
/// fits the centroid's magnitude: a close double whose spots the positions do not tell apart.
pub const MAG_BRIGHTER_LIMIT: f64 = 1.0;

/// See [`MAG_BRIGHTER_LIMIT`].
pub const MAG_OUTLIER_SIGMAS: f64 = 5.0;

/// Fewest matches from which the instrument offset is estimated for [`MAG_BRIGHTER_LIMIT`].
pub const MAG_CHECK_MIN_MATCHES: usize = 5;

/// A catalogue whose pair index would hold more pairs than this is indexed over its brightest
/// stars only (as many as keep the index to about this size); verification uses every star.
pub const MAX_INDEX_PAIRS: usize = 6_000_000;

/// Most centroids (brightest first) searched by the magnitude-gated pass and by voting.
pub const HOSTILE_SEARCH_STARS: usize = 100;

/// Catalogue pairs the magnitude-gated pass may visit at one step of the ladder before the
/// search moves on (its work budget: hopeless frames end in bounded time).
pub const HOSTILE_PAIRS_PER_STEP: usize = 8_000_000;

/// Catalogue pairs each ungated pass may visit after the gated passes found nothing.
pub const FALLBACK_PAIRS_PER_STEP: usize = 300_000;

/// Beyond this many centroids, a frame whose gated passes found nothing is not searched again
/// without the magnitude gate.
pub const HOSTILE_FALLBACK_MAX_SPOTS: usize = 40;

/// Most centroids (brightest first) of the gated passes at the looser steps of the ladder.
pub const HOSTILE_LOOSE_STARS: usize = 30;

/// The first gated pass's magnitude window, as a fraction of `mag_tolerance`: real stars with
/// good photometry pass it, and the fewer hypotheses it makes let a solution of few stars pass
/// the false-match bound.
pub const TIGHT_MAG_FRACTION: f64 = 0.25;

/// Most triangles of the magnitude-gated pass at one step of the ladder: every triangle of its
/// [`HOSTILE_SEARCH_STARS`] (its pairs budget bounds the work). A frame of a handful of faint
/// stars among 80 brighter false spots has its first all-real triangle beyond the first 60 000.
pub const HOSTILE_TRIANGLES: usize =
    HOSTILE_SEARCH_STARS * (HOSTILE_SEARCH_STARS - 1) * (HOSTILE_SEARCH_STARS - 2) / 6;

/// Brightest centroids a hypothesis's confirming stars are looked for among.
pub const CONFIRM_POOL: usize = 128;

/// Largest number of centroids accepted in one frame.
pub const MAX_CENTROIDS: usize = 100_000;

/// Frames of more centroids than this check their time at every hypothesis (each verification
/// reads every centroid), smaller ones at every 64th.
pub(crate) const LARGE_FRAME: usize = 1000;

/// Fewest centroids a frame must have for the Pyramid: a triangle and a confirming fourth star.
/// (Fewer matches than this come only from the lone-triangle test.)
pub const MIN_CENTROIDS: usize = 4;

/// The least `min_matches`: a lone triangle (see the `lone` module).
pub const LONE_MIN_MATCHES: usize = 3;

/// Work budget (catalogue pairs) of the loosest step's bright pass when the gated passes
/// (calibrated magnitudes) have spent the search's budget: that pass still runs, on this much.
/// A field of view given a little off is what it finds there (its scale error carries the sides
/// of wide triangles past the tighter steps' tolerances, and the gated passes search in vain);
/// such a frame takes a few hundred to a few thousand pairs.
pub const CLOSING_LOOSE_PAIRS: usize = 10_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_are_found_as_by_comparing_every_pair() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let cam = Camera::from_fov(0.2, 1000.0, 1000.0).unwrap();
        for trial in 0..3000 {
            // Both sides of DUPLICATE_HASH_MAX now and then.
            let n = rng.random_range(0..if trial % 8 == 7 { 320 } else { 80usize });
            // Integer pixels (few mantissa bits), signed zeros, or random coordinates.
            let mut c: Vec<[f64; 2]> = (0..n)
                .map(|_| match trial % 3 {
                    0 => [
                        f64::from(rng.random_range(0..40u8)),
                        f64::from(rng.random_range(0..3u8)),
                    ],
                    1 => [
                        if rng.random::<bool>() { 0.0 } else { -0.0 },
                        rng.random_range(0..200u8).into(),
                    ],
                    _ => [rng.random_range(0.0..1000.0), rng.random_range(0.0..1000.0)],
                })
                .collect();
            if n > 1 && trial % 2 == 0 {
                let (a, b) = (rng.random_range(0..n), rng.random_range(0..n));
                c[b] = c[a];
            }
            let same = |p: &[f64; 2], q: &[f64; 2]| p[0] == q[0] && p[1] == q[1];
            let want = (0..n).any(|j| (0..j).any(|i| same(&c[i], &c[j])));
            let got = validate_centroids(&c, None, &cam);
            assert_eq!(got.is_err(), want, "trial {trial}: {got:?}");
            if want {
                assert!(got.unwrap_err().to_string().contains("duplicates"));
            }
        }
    }

    #[test]
    fn brightness_order_is_the_stable_order_by_magnitude() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        for n in [0, 1, 2, 5, 19, 20, 21, 64, 65, 300] {
            // Ties, negative magnitudes and signed zeros.
            let m: Vec<f64> = (0..n)
                .map(|k| match k % 7 {
                    0 => 0.0,
                    1 => -0.0,
                    _ => (rng.random_range(-3.0..9.0f64) * 4.0).round() / 4.0,
                })
                .collect();
            let mut want: Vec<usize> = (0..n).collect();
            want.sort_by(|&a, &b| m[a].total_cmp(&m[b]));
            let mut got = vec![7; 3];
            brightness_order_into(n, Some(&m), &mut got);
            assert_eq!(got, want, "n = {n}");
            brightness_order_into(n, None, &mut got);
            assert_eq!(got, (0..n).collect::<Vec<_>>());
            // Found one at a time, the same order, asked for in any steps.
            for mags in [Some(&m[..]), None] {
                let mut buf = vec![7; 2];
                let mut prefix = BrightnessPrefix::new(n, mags, &mut buf);
                let full: Vec<usize> = match mags {
                    Some(_) => want.clone(),
                    None => (0..n).collect(),
                };
                let mut len = 0;
                while len <= n {
                    assert_eq!(prefix.first(len), &full[..len], "n = {n}, len = {len}");
                    len += 1 + len % 3;
                }
                assert_eq!(prefix.first(n + 5), &full[..], "n = {n}");
            }
        }
    }

    #[test]
    fn sorted_magnitudes_answer_as_a_search_of_the_whole_list() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(4);
        // Rounded magnitudes: many ties, some on bin edges.
        let mags: Vec<f32> = (0..5000)
            .map(|_| (rng.random_range(-1.5f32..8.0) * 100.0).round() / 100.0)
            .collect();
        let table = SortedMags::new(&mags);
        let mut sorted = mags.clone();
        sorted.sort_unstable_by(f32::total_cmp);
        for q in 0..4000 {
            let x = if q % 2 == 0 {
                sorted[rng.random_range(0..sorted.len())]
            } else {
                rng.random_range(-3.0f32..10.0)
            };
            let first = sorted.iter().copied().find(|&m| m >= x);
            assert_eq!(table.first_at_least(x), first, "{x}");
            let at_most = sorted.iter().filter(|&&m| m <= x).count();
            assert_eq!(table.count_at_most(x), at_most, "{x}");
        }
        assert_eq!(table.len(), mags.len());
        assert_eq!(table.first_at_least(f32::INFINITY), None);
        assert_eq!(table.count_at_most(f32::INFINITY), mags.len());
        assert_eq!(table.count_at_most(f32::NEG_INFINITY), 0);
    }

    #[test]
    fn binomial_tail_matches_direct_sums() {
        assert!((binomial_tail(1, 1, 0.3) - 0.3).abs() < 1e-15);
        assert!((binomial_tail(2, 1, 0.5) - 0.75).abs() < 1e-15);
        assert!((binomial_tail(3, 2, 0.1) - (3.0 * 0.01 * 0.9 + 0.001)).abs() < 1e-15);
        assert_eq!(binomial_tail(5, 0, 0.1), 1.0);
        assert_eq!(binomial_tail(5, 6, 0.1), 0.0);
        // m far below the mean: the tail is ~1, not lost to underflow (a false-match bound of 0
        // for a hopeless fit was the bug this guards).
        assert!(binomial_tail(122, 8, 0.99994) > 0.999_999);
        assert!((binomial_tail(4, 1, 0.9) - (1.0 - 0.1f64.powi(4))).abs() < 1e-15);
        assert!((binomial_tail(10, 5, 0.5) - 0.623046875).abs() < 1e-12);
        for (n, m, p) in [
            (30usize, 3usize, 0.2f64),
            (30, 10, 0.3),
            (50, 40, 0.9),
            (7, 7, 0.5),
        ] {
            let direct: f64 = (m..=n)
                .map(|k| {
                    let c: f64 = (1..=k).map(|i| (n - k + i) as f64 / i as f64).product();
                    c * p.powi(k as i32) * (1.0 - p).powi((n - k) as i32)
                })
                .sum();
            assert!(
                (binomial_tail(n, m, p) - direct).abs() < 1e-12 * direct.max(1e-300) + 1e-15,
                "{n} {m} {p}"
            );
        }
        // C(40, 20) = 137846528820; the first term dominates.
        let t = binomial_tail(40, 20, 1e-4);
        let first = 137_846_528_820.0 * 1e-80 * (1.0f64 - 1e-4).powi(20);
        assert!((t / first - 1.0).abs() < 1e-3, "{t:e} vs {first:e}");
    }

    #[test]
    fn config_rejects_nonsense() {
        let bad = [
            IdentifyConfig {
                centroid_sigma_px: Some(f64::NAN),
                ..Default::default()
            },
            IdentifyConfig {
                max_false_match_prob: 0.0,
                ..Default::default()
            },
            IdentifyConfig {
                min_matches: 2,
                ..Default::default()
            },
        ];
        for c in bad {
            assert!(c.validate().is_err());
        }
        assert!(IdentifyConfig::default().validate().is_ok());
    }

    #[test]
    fn the_tolerance_reaches_every_field_the_given_one_is_within_it_of() {
        let camera = Camera::from_fov(10f64.to_radians(), 1000.0, 800.0).unwrap();
        let focal = |fov_deg: f64| 500.0 / (0.5 * fov_deg.to_radians()).tan();
        let (shortest, longest) = IdentifyConfig::default().focal_range_px(&camera);
        // Given 10 % too small, the field is 10 / 0.9 degrees (not 11); 10 % too large, 10 / 1.1.
        assert!((shortest / focal(10.0 / 0.9) - 1.0).abs() < 1e-12);
        assert!((longest / focal(10.0 / 1.1) - 1.0).abs() < 1e-12);
        assert!(shortest < focal(11.0));
        let held = IdentifyConfig {
            fov_tolerance: 0.0,
            ..Default::default()
        };
        let f = camera.focal_length_px;
        assert_eq!(held.focal_range_px(&camera), (f, f));
    }
}
