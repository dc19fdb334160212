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
use std::sync::atomic::{AtomicBool, Ordering};
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
mod hinted;
mod magbins;
mod pyramid;
pub mod scale;
mod seeds;
mod verify;
mod voting;

pub use batch::map_frames;
pub use cache::SolverCache;
pub(crate) use cancel::stop_now;
pub use cancel::Cancel;
pub use hinted::{AttitudeHint, HintFallback, HINT_SEARCH_STARS, MAX_HINT_UNCERTAINTY_RAD};
pub use magbins::MagPairIndex;
pub use seeds::{SeedTables, RING_ORDER, RING_SLACK, SEED_CANDIDATES};
pub(crate) use verify::{binomial_tail, median_in_place, AMBIGUITY_LOG_ODDS};

/// Frames a batch runs between two looks at its cancel flag (and the most results a cancelled
/// batch has allocated beyond the chunks it finished).
pub const BATCH_CHUNK: usize = 16_384;

/// Centroid noise levels (1σ per axis, pixels) tried in turn when none is given.
pub const SIGMA_LADDER_PX: [f64; 3] = [0.2, 0.7, 2.5];

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
/// a false star on the spot of a catalogue star too faint to be seen. One-sided: a star fainter
/// than expected (saturated, variable) keeps its id.
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

/// Most triangles of the magnitude-gated pass at one step of the ladder.
pub const HOSTILE_TRIANGLES: usize = 60_000;

/// Brightest centroids a hypothesis's confirming stars are looked for among.
pub const CONFIRM_POOL: usize = 128;

/// Largest number of centroids accepted in one frame.
pub const MAX_CENTROIDS: usize = 100_000;

/// Frames of more centroids than this check their time at every hypothesis (each verification
/// reads every centroid), smaller ones at every 64th.
pub(crate) const LARGE_FRAME: usize = 1000;

/// Fewest centroids a frame must have: a triangle and a confirming fourth star.
pub const MIN_CENTROIDS: usize = 4;

/// Work budget (catalogue pairs) of the loosest step's bright pass when the gated passes
/// (calibrated magnitudes) have spent the search's budget: that pass still runs, on this much.
/// A field of view given a little off is what it finds there (its scale error carries the sides
/// of wide triangles past the tighter steps' tolerances, and the gated passes search in vain);
/// such a frame takes a few hundred to a few thousand pairs.
pub const CLOSING_LOOSE_PAIRS: usize = 10_000;

/// Settings of [`Solver::identify`]. Build with `..Default::default()`.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyConfig {
    /// Centroid noise, 1σ per axis in pixels. `None`: try [`SIGMA_LADDER_PX`] in turn.
    pub centroid_sigma_px: Option<f64>,
    /// Largest accepted bound on the probability that the solution is a false match.
    pub max_false_match_prob: f64,
    /// Fewest matched stars of a reported solution (at least 4).
    pub min_matches: usize,
    /// How many centroids (brightest first) form search triangles; all are verified.
    pub max_search_stars: usize,
    /// Stop after testing this many catalogue-triangle hypotheses.
    pub max_hypotheses: usize,
    /// Stop after visiting this many catalogue pairs from the k-vector (the search's work,
    /// including triangles that yield no hypothesis); bounds the time of hopeless frames.
    pub max_pairs_visited: usize,
    /// Search mirrored (odd number of reflections) frames too.
    pub allow_mirrored: bool,
    /// Give up after this much time (status [`Status::Timeout`]); `None`: no time limit, and the
    /// result depends only on the input.
    pub timeout: Option<Duration>,
    /// Raised by another thread (Ctrl-C in a caller), it ends the search as `timeout` does. Not
    /// a setting: clones share it, and it does not change what a search finds before it ends.
    pub cancel: Option<Cancel>,
    /// Which method generates hypotheses (all pass the same verification).
    pub method: Method,
    /// Instrument minus catalogue magnitude, when known (`Some(0.0)`: magnitudes in the
    /// catalogue's system). With it and magnitudes, a catalogue star more than `mag_tolerance`
    /// from a centroid's magnitude is no candidate for it: the search that copes with many false
    /// stars. `None`: the zero point is unknown and only the brightness order is used.
    pub mag_offset: Option<f64>,
    /// Largest difference between a centroid's magnitude (less `mag_offset`) and its catalogue
    /// star's for the two to be matched in the magnitude-gated search.
    pub mag_tolerance: f64,
    /// Without magnitudes, the centroids come brightest first (as star extractors list them):
    /// the first few are then searched among the locally bright stars first, as with
    /// magnitudes. Set `false` for centroids in no particular order.
    pub brightness_order: bool,
    /// Pass every hypothesis through the shared verification (the default). `false` is for
    /// benchmarks and research only: the method's own first answer is returned unverified
    /// ([`Identification::verified`] false, no false-match bound), so that its accuracy can
    /// be measured as its authors meant; it may be wrong. Lost in space, known focal length only.
    pub verify: bool,
    /// Check a verified solution for a focal length off (a field of view given a little wrong)
    /// and search the frame again with the one its residuals imply (the default; see
    /// [`scale`] and [`Identification::focal_length_px`]). `false` holds the camera fixed.
    pub focal_check: bool,
    /// In a batch ([`Solver::identify_batch`]), learn the magnitude zero point from the frames
    /// identified without it (the default): when [`ZERO_POINT_MIN_FRAMES`] or more of them
    /// agree on one, the frames with magnitudes that nothing identified (status `no_match` or
    /// `search_limit`) are searched again, magnitude-gated, with it. Only where the given
    /// `mag_offset` is `None` or disagrees with the learned one. `false`: each frame alone.
    pub learn_zero_point: bool,
}

/// How hypotheses are generated. Every method's hypotheses pass the same verification.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Method {
    /// Pyramid over the brightest stars first; with calibrated magnitudes (`mag_offset`), a
    /// magnitude-gated Pyramid over every centroid when false stars crowd the frame.
    Auto,
    /// Pyramid (Mortari et al. 2004) alone, brightest stars first.
    Pyramid,
    /// Geometric voting (Kolomenkin et al. 2008): observed pairs vote for catalogue stars;
    /// the best-voted assignments become hypotheses.
    Voting,
    /// P000 Method 1 (`docs/SEEDS.md` §1): the main star's distances to every other spot, all
    /// matched through the k-vector; catalogue order decides among the passing stars.
    AngularDistance,
    /// P000 Method 2 (§2): the two angles between the lines joining the main star's three
    /// nearest neighbours, against a table of every catalogue star's.
    StarLineAngle,
    /// P000 Method 3 (§3): the summed loop of distances around the main star and its three
    /// nearest neighbours, against a sorted table.
    AngleSum,
    /// P001 Model 1 (§5): every catalogue star votes with its distances for a base star near
    /// the edge; the best voted is it.
    DistanceVote,
    /// P001 Model 2 (§6): neighbour counts in rings around a base star near the centre screen
    /// the catalogue; Model 1's vote runs on the candidates.
    RadialVote,
}

impl Method {
    /// Every method.
    pub const ALL: [Method; 8] = [
        Method::Auto,
        Method::Pyramid,
        Method::Voting,
        Method::AngularDistance,
        Method::StarLineAngle,
        Method::AngleSum,
        Method::DistanceVote,
        Method::RadialVote,
    ];

    /// Whether this is one of the source documents' methods (see [`SeedTables`]).
    ///
    /// # Example
    /// ```
    /// use starid_core::Method;
    /// assert!(Method::AngleSum.is_seed() && !Method::Pyramid.is_seed());
    /// ```
    pub fn is_seed(self) -> bool {
        matches!(
            self,
            Self::AngularDistance
                | Self::StarLineAngle
                | Self::AngleSum
                | Self::DistanceVote
                | Self::RadialVote
        )
    }

    /// Lower-case name: `auto`, `pyramid`, `voting`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Method::Voting.name(), "voting");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Pyramid => "pyramid",
            Self::Voting => "voting",
            Self::AngularDistance => "angular-distance",
            Self::StarLineAngle => "star-line-angle",
            Self::AngleSum => "angle-sum",
            Self::DistanceVote => "distance-vote",
            Self::RadialVote => "radial-vote",
        }
    }

    /// One line on what the method does.
    ///
    /// # Example
    /// ```
    /// assert!(!starid_core::Method::Pyramid.description().is_empty());
    /// ```
    pub fn description(self) -> &'static str {
        match self {
            Self::Auto => "Pyramid, brightest first; magnitude-gated over every spot when false stars crowd the frame",
            Self::Pyramid => "Pyramid (Mortari 2004) over the k-vector, brightest stars first",
            Self::Voting => "geometric voting (Kolomenkin 2008): observed pairs vote for catalogue stars",
            Self::AngularDistance => "P000 method 1: the central star's distances to all others, every one matched (baseline)",
            Self::StarLineAngle => "P000 method 2: angles between the lines joining the central star's 3 neighbours (baseline)",
            Self::AngleSum => "P000 method 3: sum of the distances around the central star and its 3 neighbours (baseline)",
            Self::DistanceVote => "P001 model 1: catalogue stars vote with their distances for an edge star (baseline)",
            Self::RadialVote => "P001 model 2: ring counts around a central star screen, then model 1 votes (baseline)",
        }
    }

    /// The method called `name`.
    ///
    /// # Errors
    /// `InvalidInput` naming the known methods.
    ///
    /// # Example
    /// ```
    /// use starid_core::Method;
    /// assert_eq!(Method::from_name("Pyramid").unwrap(), Method::Pyramid);
    /// assert_eq!(Method::from_name("angle_sum").unwrap(), Method::AngleSum);
    /// assert!(Method::from_name("guess").is_err());
    /// ```
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(&name.replace('_', "-")))
            .ok_or_else(|| {
                Error::invalid_input(format!(
                    "unknown method {name:?}: one of {}",
                    Self::ALL.map(Method::name).join(", ")
                ))
            })
    }
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self {
            centroid_sigma_px: None,
            max_false_match_prob: 1e-3,
            min_matches: 4,
            max_search_stars: 24,
            max_hypotheses: 50_000,
            max_pairs_visited: 3_000_000,
            allow_mirrored: true,
            timeout: None,
            cancel: None,
            method: Method::Auto,
            mag_offset: Some(0.0),
            mag_tolerance: 0.5,
            brightness_order: true,
            verify: true,
            focal_check: true,
            learn_zero_point: true,
        }
    }
}

impl IdentifyConfig {
    /// This configuration searching with a learned zero point `(offset, tolerance)` (see
    /// [`agreed_zero_point`]), or `None` where the configured `mag_offset` already agrees with
    /// it (within `mag_tolerance`): the one rule of a batch and a tracker.
    pub(crate) fn with_learned_zero_point(&self, (offset, tolerance): (f64, f64)) -> Option<Self> {
        self.mag_offset
            .is_none_or(|o| (o - offset).abs() > self.mag_tolerance)
            .then(|| Self {
                mag_offset: Some(offset),
                mag_tolerance: tolerance,
                ..self.clone()
            })
    }

    /// Check every setting.
    ///
    /// # Errors
    /// `InvalidInput` naming the first setting out of its domain.
    ///
    /// # Example
    /// ```
    /// use starid_core::IdentifyConfig;
    /// assert!(IdentifyConfig::default().validate().is_ok());
    /// assert!(IdentifyConfig { min_matches: 2, ..Default::default() }.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<()> {
        if let Some(s) = self.centroid_sigma_px {
            if !s.is_finite() || s <= 0.0 || s > 1000.0 {
                return Err(Error::invalid_input(format!(
                    "centroid_sigma_px must be in (0, 1000] pixels, got {s}"
                )));
            }
        }
        let p = self.max_false_match_prob;
        if !(p > 0.0 && p <= 1.0) {
            return Err(Error::invalid_input(format!(
                "max_false_match_prob must be in (0, 1], got {p}"
            )));
        }
        if self.min_matches < MIN_CENTROIDS {
            return Err(Error::invalid_input(format!(
                "min_matches must be at least {MIN_CENTROIDS}, got {}",
                self.min_matches
            )));
        }
        if let Some(o) = self
            .mag_offset
            .filter(|o| !o.is_finite() || o.abs() > 100.0)
        {
            return Err(Error::invalid_input(format!(
                "mag_offset must be finite and within [-100, 100] (or None: unknown), got {o}"
            )));
        }
        if !(self.mag_tolerance.is_finite()
            && self.mag_tolerance > 0.0
            && self.mag_tolerance <= 100.0)
        {
            return Err(Error::invalid_input(format!(
                "mag_tolerance must be in (0, 100] magnitudes, got {}",
                self.mag_tolerance
            )));
        }
        if self.max_search_stars < 3 {
            return Err(Error::invalid_input(format!(
                "max_search_stars must be at least 3, got {}",
                self.max_search_stars
            )));
        }
        Ok(())
    }
}

/// How an identification ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Status {
    /// A verified solution was found.
    Identified,
    /// The search ended without a verified solution.
    NoMatch,
    /// The search budget (`max_hypotheses` or `max_pairs_visited`) ran out without a verified solution.
    SearchLimit,
    /// The time limit passed without a verified solution.
    Timeout,
    /// Fewer than [`MIN_CENTROIDS`] centroids: nothing to search (not an error).
    TooFewStars,
    /// In a batch, a frame whose input is malformed (see [`Identification::message`]); alone,
    /// [`Solver::identify`] returns the error instead.
    InvalidInput,
}

impl Status {
    /// Lower-case name: `identified`, `no_match`, `search_limit`, `timeout`, `too_few_stars`,
    /// `invalid_input`, `cancelled`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Status::TooFewStars.as_str(), "too_few_stars");
    /// ```
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Identified => "identified",
            Self::NoMatch => "no_match",
            Self::SearchLimit => "search_limit",
            Self::Timeout => "timeout",
            Self::TooFewStars => "too_few_stars",
            Self::InvalidInput => "invalid_input",
        }
    }
}

/// The outcome of identifying one frame.
#[derive(Debug, Clone)]
pub struct Identification {
    /// How the search ended.
    pub status: Status,
    /// Catalogue index of each centroid (input order), `None` where unidentified.
    pub catalog_index: Vec<Option<u32>>,
    /// Rotation ICRS → camera (`v_cam = r · v_icrs`); with `mirrored`, the camera frame is the
    /// one of the image with its x axis reversed (`x → W − x`). `None` unless identified.
    pub r_icrs_to_cam: Option<Rotation3<f64>>,
    /// Whether the frame is mirrored (an odd number of reflections).
    pub mirrored: bool,
    /// Angle between each centroid's direction and its catalogue star, radians; NaN where unidentified.
    pub residuals_rad: Vec<f64>,
    /// Bound on the probability that the solution is a false match (1 when unidentified).
    pub false_match_probability: f64,
    /// Number of identified centroids.
    pub matched: usize,
    /// Centroid noise estimated from the residuals (1σ per axis, px); NaN when unidentified.
    pub centroid_sigma_px: f64,
    /// Radius within which a centroid was matched to a star, radians; NaN when unidentified.
    pub match_radius_rad: f64,
    /// Catalogue-triangle hypotheses tested.
    pub hypotheses: usize,
    /// Time spent in [`Solver::identify`].
    pub elapsed: Duration,
    /// The method whose hypothesis was verified (the configured one when unidentified).
    pub method: Method,
    /// Why a batch frame has status [`Status::InvalidInput`]; `None` otherwise.
    pub message: Option<String>,
    /// Found by the hinted (tracking) search of [`Solver::identify_hinted`]; false for lost in
    /// space, including a hinted call's fallback.
    pub hinted: bool,
    /// The answer passed the shared verification. False when unidentified, and for a method's
    /// raw answer with [`IdentifyConfig::verify`] off: then `false_match_probability` is 1
    /// (no bound), `centroid_sigma_px` and `match_radius_rad` NaN, and the ids may be wrong.
    pub verified: bool,
    /// The focal length (px) the solution was found with when the given one proved off: the
    /// focal check of [`Solver::identify`] saw the matches' residuals scale with their distance
    /// from the principal point (see [`scale`]) and searched the frame again with the focal
    /// length they imply. The attitude, ids and residuals are those of this focal length.
    /// `None`: the camera's own.
    pub focal_length_px: Option<f64>,
    /// 1σ of `focal_length_px` (px); NaN when that is `None`.
    pub focal_sigma_px: f64,
    /// The magnitude zero point a batch learned from its other frames and searched this frame
    /// with, magnitude-gated, after a first search without it found nothing (see
    /// [`Solver::identify_batch`]); `None` for a frame identified as given.
    pub learned_mag_offset: Option<f64>,
    /// The radial distortion (`k1`, see [`Camera`]) the solution was found with when the
    /// camera's proved off: the focal check (see [`scale`]) fits it with the focal length from
    /// [`scale::K1_MIN_MATCHES`] matches on, and a significant error sends the frame back to the
    /// search with both corrected (then `focal_length_px` is set too). `None`: the camera's own.
    pub k1: Option<f64>,
}

impl Identification {
    /// Whether a verified solution was found.
    ///
    /// # Example
    /// ```
    /// use starid_core::{Camera, IdentifyConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap());
    /// let cam = Camera::from_fov(0.2, 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat, &cam).unwrap();
    /// let id = solver.identify(&[[10.0, 10.0]], None, &cam, &IdentifyConfig::default()).unwrap();
    /// assert!(!id.is_identified()); // one spot: too few stars
    /// ```
    pub fn is_identified(&self) -> bool {
        self.status == Status::Identified
    }

    /// The frame's magnitude zero point measured from its matches: the median of the
    /// centroids' magnitudes less their catalogue stars', and the robust spread of those
    /// differences about it (1.4826 × their median absolute deviation). `None` with fewer than
    /// [`ZERO_POINT_MIN_MATCHES`] matches or `magnitudes` not one per centroid.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    /// let f = simulate(&cat, &cam, &SimConfig { mag_noise: 0.0, ..Default::default() }, 1).unwrap();
    /// // An instrument's magnitudes: the catalogue's plus 7.5.
    /// let m: Vec<f64> = f.magnitudes.iter().map(|m| m + 7.5).collect();
    /// let cfg = IdentifyConfig { mag_offset: None, ..Default::default() };
    /// let id = solver.identify(&f.centroids, Some(&m), &cam, &cfg).unwrap();
    /// let (zero_point, spread) = id.zero_point(&m, &cat).unwrap();
    /// assert!((zero_point - 7.5).abs() < 1e-9 && spread < 1e-9);
    /// ```
    pub fn zero_point(&self, magnitudes: &[f64], catalog: &Catalog) -> Option<(f64, f64)> {
        if magnitudes.len() != self.catalog_index.len() {
            return None;
        }
        let cat_mag = catalog.mag();
        let mut d: Vec<f64> = self
            .catalog_index
            .iter()
            .zip(magnitudes)
            .filter_map(|(c, &m)| c.map(|s| m - cat_mag[s as usize]))
            .filter(|d| d.is_finite())
            .collect();
        if d.len() < ZERO_POINT_MIN_MATCHES {
            return None;
        }
        let median = verify::median_in_place(&mut d);
        for x in &mut d {
            *x = (*x - median).abs();
        }
        Some((median, 1.4826 * verify::median_in_place(&mut d)))
    }

    /// The result of a frame of a batch that could not be read or was refused: status
    /// [`Status::InvalidInput`] for `n` centroids, and why.
    pub fn invalid_input(n: usize, message: impl Into<String>) -> Self {
        let mut id = Self::unidentified(Status::InvalidInput, n, 0, Duration::ZERO);
        id.message = Some(message.into());
        id
    }

    /// The outcome of a search that found nothing for `n` centroids.
    pub(crate) fn unidentified(
        status: Status,
        n: usize,
        hypotheses: usize,
        elapsed: Duration,
    ) -> Self {
        Self {
            status,
            catalog_index: vec![None; n],
            r_icrs_to_cam: None,
            mirrored: false,
            residuals_rad: vec![f64::NAN; n],
            false_match_probability: 1.0,
            matched: 0,
            centroid_sigma_px: f64::NAN,
            match_radius_rad: f64::NAN,
            hypotheses,
            elapsed,
            method: Method::Auto,
            message: None,
            hinted: false,
            verified: false,
            focal_length_px: None,
            focal_sigma_px: f64::NAN,
            learned_mag_offset: None,
            k1: None,
        }
    }
}

/// The zero point frames agree on, from each one's zero point `z` and spread `s`, and the
/// magnitude tolerance to search with it: at least [`ZERO_POINT_MIN_FRAMES`] of them, at most a
/// third more than [`ZERO_POINT_AGREE_MAG`] from the median, which is the answer; the tolerance
/// is [`ZERO_POINT_TOLERANCE_SIGMAS`] times the agreeing frames' median spread, at least
/// `min_tolerance` and at most [`ZERO_POINT_MAX_TOLERANCE_MAG`] (or `min_tolerance` if more).
pub(crate) fn agreed_zero_point(z: &[f64], s: &[f64], min_tolerance: f64) -> Option<(f64, f64)> {
    if z.len() < ZERO_POINT_MIN_FRAMES {
        return None;
    }
    let offset = verify::median_in_place(&mut z.to_vec());
    let mut spread: Vec<f64> = z
        .iter()
        .zip(s)
        .filter(|(z, _)| (*z - offset).abs() <= ZERO_POINT_AGREE_MAG)
        .map(|(_, s)| *s)
        .collect();
    let disagree = z.len() - spread.len();
    if spread.len() < ZERO_POINT_MIN_FRAMES
        || disagree as f64 > ZERO_POINT_MAX_DISAGREE * z.len() as f64
    {
        return None;
    }
    let tolerance = (ZERO_POINT_TOLERANCE_SIGMAS * verify::median_in_place(&mut spread)).clamp(
        min_tolerance,
        ZERO_POINT_MAX_TOLERANCE_MAG.max(min_tolerance),
    );
    Some((offset, tolerance))
}

/// Fewest matches from which [`Identification::zero_point`] measures a frame's zero point.
pub const ZERO_POINT_MIN_MATCHES: usize = 4;

/// Fewest identified frames, each with a measured zero point, from which a batch learns its
/// zero point (see [`Solver::identify_batch`]).
pub const ZERO_POINT_MIN_FRAMES: usize = 3;

/// How far (mag) from their median the frames' zero points may lie and still agree on one.
pub const ZERO_POINT_AGREE_MAG: f64 = 0.5;

/// Most of the frames' zero points that may disagree (see [`ZERO_POINT_AGREE_MAG`]) for the
/// batch to learn one: a third.
const ZERO_POINT_MAX_DISAGREE: f64 = 1.0 / 3.0;

/// The learned search's magnitude tolerance, in the frames' typical spread of magnitudes about
/// their zero point (never below the configured tolerance, nor above
/// [`ZERO_POINT_MAX_TOLERANCE_MAG`]).
pub const ZERO_POINT_TOLERANCE_SIGMAS: f64 = 2.5;

/// Largest magnitude tolerance of a search with a learned zero point.
pub const ZERO_POINT_MAX_TOLERANCE_MAG: f64 = 1.5;

/// A catalogue with its pair index: everything identification needs. Immutable and `Sync`:
/// share one across threads.
#[derive(Debug, Clone)]
pub struct Solver {
    catalog: Arc<Catalog>,
    pairs: PairIndex,
    /// Pairs among the locally bright stars; `None` when they are most of the catalogue.
    bright_pairs: Option<PairIndex>,
    /// Catalogue magnitudes as `f32`, for the magnitude gate of the search's inner loops.
    mag32: Vec<f32>,
    /// The same, ascending, with a bin table for counts below a magnitude.
    mag_sorted: SortedMags,
    /// Catalogue stars per steradian in the sparsest field (cones of half the index's angle).
    min_density_sr: f64,
    /// Catalogue stars per steradian around any direction (cones of half the index's angle),
    /// for the false-match bound of every verification; `None` for narrow fields, which count
    /// their cone instead.
    density: Option<DensityMap>,
    /// The pair index split by magnitude, built on the first magnitude-gated pass.
    mag_pairs: std::sync::OnceLock<MagPairIndex>,
    /// The source documents' tables, built on first use.
    seed_tables: std::sync::OnceLock<SeedTables>,
    build_time: Duration,
}

impl Solver {
    /// Index `catalog` for frames whose stars are at most `max_angle_rad` apart (a frame's
    /// diagonal field of view, see [`Camera::diagonal_fov_rad`]).
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.pair_index().len() > 0);
    /// ```
    pub fn new(catalog: Arc<Catalog>, max_angle_rad: f64) -> Result<Self> {
        let t = Instant::now();
        // A deep catalogue: index the brightest stars only (the guide stars); verification
        // still matches every centroid against the whole catalogue.
        let n_cat = catalog.len() as f64;
        let expected = 0.25 * n_cat * n_cat * (1.0 - max_angle_rad.cos());
        let guide: Option<Vec<bool>> = (expected > MAX_INDEX_PAIRS as f64).then(|| {
            let keep =
                (MAX_INDEX_PAIRS as f64 / (0.25 * (1.0 - max_angle_rad.cos()))).sqrt() as usize;
            let mut mags: Vec<f64> = catalog.mag().to_vec();
            mags.sort_unstable_by(f64::total_cmp);
            let limit = mags[keep.clamp(1, mags.len()) - 1];
            catalog.mag().iter().map(|&m| m <= limit).collect()
        });
        let pairs = PairIndex::build_among(&catalog, max_angle_rad, guide.as_deref())?;
        // Half the width of a square field of this diagonal.
        let mut members =
            catalog.locally_bright(max_angle_rad / (2.0 * SQRT_2), BRIGHT_MAX_BRIGHTER);
        if let Some(g) = &guide {
            for (m, &k) in members.iter_mut().zip(g) {
                *m &= k;
            }
        }
        let bright = members.iter().filter(|&&m| m).count();
        let bright_pairs = if 5 * bright < 4 * catalog.len() {
            Some(PairIndex::build_among(
                &catalog,
                max_angle_rad,
                Some(&members),
            )?)
        } else {
            None
        };
        let mag32: Vec<f32> = catalog.mag().iter().map(|&m| m as f32).collect();
        let mag_sorted = SortedMags::new(&mag32);
        let min_density_sr = sparsest_density(&catalog, 0.5 * max_angle_rad);
        let density = DensityMap::new(0.5 * max_angle_rad, |v| {
            catalog.count_in_cone(v, 0.5 * max_angle_rad)
        });
        Ok(Self {
            catalog,
            pairs,
            bright_pairs,
            min_density_sr,
            density,
            mag32,
            mag_sorted,
            mag_pairs: std::sync::OnceLock::new(),
            seed_tables: std::sync::OnceLock::new(),
            build_time: t.elapsed(),
        })
    }

    /// Index `catalog` for frames of `camera`.
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cam = starid_core::Camera::from_fov(0.2, 512.0, 512.0).unwrap();
    /// let solver = starid_core::Solver::for_camera(std::sync::Arc::new(cat), &cam).unwrap();
    /// assert!(solver.pair_index().max_angle_rad() >= cam.diagonal_fov_rad());
    /// ```
    pub fn for_camera(catalog: Arc<Catalog>, camera: &Camera) -> Result<Self> {
        Self::new(catalog, camera.diagonal_fov_rad())
    }

    /// The catalogue.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.catalog().len(), 3000);
    /// ```
    pub fn catalog(&self) -> &Arc<Catalog> {
        &self.catalog
    }

    /// The pair index.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.pair_index().max_angle_rad() >= 0.3);
    /// ```
    pub fn pair_index(&self) -> &PairIndex {
        &self.pairs
    }

    /// The pair index over locally bright stars only, searched first when magnitudes are
    /// given (`None` when those stars are most of the catalogue).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// if let Some(b) = solver.bright_pair_index() {
    ///     assert!(b.len() < solver.pair_index().len());
    /// }
    /// ```
    pub fn bright_pair_index(&self) -> Option<&PairIndex> {
        self.bright_pairs.as_ref()
    }

    /// Heap memory of the indexes in bytes: the pair indexes, the density map, and the
    /// magnitude-split index and the source documents' tables once built.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.memory_bytes() >= solver.pair_index().memory_bytes());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        self.pairs.memory_bytes()
            + self
                .bright_pairs
                .as_ref()
                .map_or(0, PairIndex::memory_bytes)
            + self.mag_pairs.get().map_or(0, MagPairIndex::memory_bytes)
            + self.seed_tables_bytes()
            + self.density.as_ref().map_or(0, DensityMap::memory_bytes)
    }

    /// Memory of the source documents' tables, bytes; 0 until a method of theirs (or
    /// [`Solver::seed_tables`]) builds them.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.seed_tables_bytes(), 0);
    /// solver.seed_tables();
    /// assert!(solver.seed_tables_bytes() > 0);
    /// ```
    pub fn seed_tables_bytes(&self) -> usize {
        self.seed_tables.get().map_or(0, SeedTables::memory_bytes)
    }

    /// Memory of the magnitude-split index, bytes; 0 until a gated search (or
    /// [`Solver::mag_pair_index`]) builds it.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.magnitude_index_bytes(), 0);
    /// solver.mag_pair_index();
    /// assert!(solver.magnitude_index_bytes() > 0);
    /// ```
    pub fn magnitude_index_bytes(&self) -> usize {
        self.mag_pairs.get().map_or(0, MagPairIndex::memory_bytes)
    }

    /// Mean over `windows` of the fraction of catalogue stars no fainter than each window's
    /// faint end: the stars a centroid may match in verification.
    fn window_fraction(&self, windows: &[[f32; 2]]) -> f64 {
        let sorted = &self.mag_sorted;
        let n = sorted.len().max(1) as f64;
        let total: f64 = windows
            .iter()
            .map(|w| sorted.count_at_most(w[1]) as f64 / n)
            .sum();
        (total / windows.len().max(1) as f64).clamp(1.0 / n, 1.0)
    }

    /// The pair index split by magnitude bins, for magnitude-gated searches (built on first use,
    /// once, whichever thread asks first).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.mag_pair_index().memory_bytes() > 0); // built on first use
    /// ```
    pub fn mag_pair_index(&self) -> &MagPairIndex {
        self.mag_pairs
            .get_or_init(|| MagPairIndex::build(&self.pairs, self.catalog.vectors(), &self.mag32))
    }

    /// The tables of the source documents' methods (neighbours, line angles, angle sums, ring
    /// counts) for square fields of the index's diagonal, built on first use, once.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// let t = solver.seed_tables();
    /// assert!(t.ring_bytes() == 3 * 3000 && t.angle_sum_bytes() > 0);
    /// ```
    pub fn seed_tables(&self) -> &SeedTables {
        self.seed_tables
            .get_or_init(|| SeedTables::build(&self.catalog, self.pairs.max_angle_rad() / SQRT_2))
    }

    /// The database `method` searches: `(bytes, build time)`. Pyramid, voting, angular
    /// distance and distance voting search the pair indexes (and the magnitude index once
    /// built); the other source documents' methods their own tables (built now if needed).
    ///
    /// # Example
    /// ```
    /// use starid_core::Method;
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// let (pairs, _) = solver.method_database(Method::AngularDistance);
    /// let (rings, _) = solver.method_database(Method::RadialVote);
    /// assert!(rings < pairs);
    /// ```
    pub fn method_database(&self, method: Method) -> (usize, Duration) {
        match method {
            Method::StarLineAngle => {
                let t = self.seed_tables();
                (t.star_line_angle_bytes(), t.neighbour_build_time())
            }
            Method::AngleSum => {
                let t = self.seed_tables();
                (t.angle_sum_bytes(), t.neighbour_build_time())
            }
            Method::RadialVote => {
                let t = self.seed_tables();
                (t.ring_bytes(), t.ring_build_time())
            }
            Method::AngularDistance | Method::DistanceVote => {
                (self.pairs.memory_bytes(), self.build_time)
            }
            _ => (self.memory_bytes(), self.build_time),
        }
    }

    /// Catalogue stars per steradian in the sparsest field of the sky (cones of half the
    /// index's angle, sampled at 2000 directions): what the search's early stop assumes.
    pub(crate) fn min_density_sr(&self) -> f64 {
        self.min_density_sr
    }

    /// Catalogue magnitudes as `f32`.
    pub(crate) fn mag_f32(&self) -> &[f32] {
        &self.mag32
    }

    /// Time it took to build the pair indexes.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.build_time().as_secs_f64() < 60.0);
    /// ```
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// Identify the stars of one frame.
    ///
    /// `centroids` are pixel `(x, y)`, x right, y down, origin at the sensor's top-left corner;
    /// `magnitudes`, when given, one instrument magnitude per centroid (smaller is brighter), in
    /// any zero point: their order decides which stars are searched first (among the locally
    /// bright catalogue stars, then among all), and a match far brighter than its catalogue
    /// star is dropped ([`MAG_BRIGHTER_LIMIT`]).
    ///
    /// With [`IdentifyConfig::focal_check`] (the default), a verified solution that leaves spots
    /// unnamed is checked for a focal length off; a significant one sends the frame back to the
    /// search with the focal length the residuals imply (see [`scale`]), and the result then
    /// carries it in [`Identification::focal_length_px`].
    ///
    /// # Errors
    /// `InvalidInput` for fewer than [`MIN_CENTROIDS`] or more than [`MAX_CENTROIDS`] centroids,
    /// non-finite or duplicate centroids, centroids off the sensor, magnitudes of the wrong
    /// length or non-finite, or an invalid `config`. A frame that cannot be identified is not
    /// an error: see [`Identification::status`].
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// let frame = simulate(&cat, &cam, &SimConfig { noise_px: 0.2, ..Default::default() }, 3).unwrap();
    /// let id = solver.identify(&frame.centroids, Some(&frame.magnitudes), &cam, &IdentifyConfig::default()).unwrap();
    /// assert!(id.is_identified());
    /// for (got, truth) in id.catalog_index.iter().zip(&frame.catalog_index) {
    ///     assert!(got.is_none() || got == truth); // never a wrong id
    /// }
    /// ```
    pub fn identify(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
    ) -> Result<Identification> {
        let start = Instant::now();
        config.validate()?;
        validate_centroids(centroids, magnitudes, camera)?;
        let mut id = self.search_frame(centroids, magnitudes, camera, config, start)?;
        // A solution that names every spot leaves no star out by a focal error worth a search.
        if config.focal_check && id.verified && id.matched < centroids.len() {
            self.check_focal(centroids, magnitudes, camera, config, start, &mut id)?;
        }
        id.elapsed = start.elapsed();
        Ok(id)
    }

    /// The focal check (see [`scale`]): while a verified solution's residuals show the focal
    /// length (or the radial distortion) off, search the frame again with the camera they imply,
    /// at most [`scale::FOCAL_RETRIES`] times, keeping a new solution that matches at least as
    /// many centroids (more, for a distortion error short of significance: see
    /// [`scale::K1_TRY_SIGMAS`]). Within the configured timeout only.
    pub(crate) fn check_focal(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
        start: Instant,
        id: &mut Identification,
    ) -> Result<()> {
        let vectors = self.catalog.vectors();
        let mut cam = *camera;
        // The camera's errors that the solution kept shows (`id` under `cam`).
        let mut err = scale::camera_error(centroids, &cam, id, vectors);
        for _ in 0..scale::FOCAL_RETRIES {
            let Some(((a, b), strict)) = err.and_then(|e| e.correction()) else {
                break;
            };
            if config.timeout.is_some_and(|t| start.elapsed() >= t) {
                break;
            }
            let mut trial = cam;
            trial.focal_length_px *= 1.0 + a;
            if b != 0.0 {
                let Ok(t) = trial.with_k1(cam.k1 + b) else {
                    break;
                };
                trial = t;
            }
            let again = self.search_frame(centroids, magnitudes, &trial, config, start)?;
            if !(again.verified && again.matched >= id.matched + usize::from(strict)) {
                break;
            }
            let k1_corrected = id.k1.is_some() || b != 0.0;
            (cam, *id) = (trial, again);
            id.focal_length_px = Some(cam.focal_length_px);
            id.k1 = k1_corrected.then_some(cam.k1);
            err = scale::camera_error(centroids, &cam, id, vectors);
        }
        // What the final matches still show (below the search's threshold) refines the camera
        // found: the attitude refitted and the residuals recomputed with it, the matches kept.
        if let (Some(_), Some(e)) = (id.focal_length_px, err) {
            let ((a, b), se) = e.refinement(id.k1.is_some());
            cam.focal_length_px *= 1.0 + a;
            if let Ok(t) = cam.with_k1(cam.k1 + b) {
                cam = t;
            }
            self.refit_matches(centroids, &cam, id);
            id.focal_length_px = Some(cam.focal_length_px);
            id.focal_sigma_px = se * cam.focal_length_px;
            id.k1 = id.k1.map(|_| cam.k1);
        }
        Ok(())
    }

    /// The attitude and residuals of `id`'s matches under `camera`.
    fn refit_matches(&self, centroids: &[[f64; 2]], camera: &Camera, id: &mut Identification) {
        let Some(r0) = id.r_icrs_to_cam else { return };
        let vectors = self.catalog.vectors();
        let obs: Vec<Vector3<f64>> = centroids
            .iter()
            .map(|c| camera.pixel_to_cam(c[0], c[1], id.mirrored))
            .collect();
        let (o, c): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = id
            .catalog_index
            .iter()
            .zip(&obs)
            .filter_map(|(s, v)| s.map(|s| (*v, vectors[s as usize])))
            .unzip();
        let Some(r) = wahba_from(&o, &c, &r0) else {
            return;
        };
        for ((res, s), v) in id.residuals_rad.iter_mut().zip(&id.catalog_index).zip(&obs) {
            if let Some(s) = s {
                // As verification gives them: the sine of the angle.
                *res = v.cross(&(r * vectors[*s as usize])).norm();
            }
        }
        id.r_icrs_to_cam = Some(r);
    }

    /// One search of a validated frame with the camera as given.
    fn search_frame(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
        start: Instant,
    ) -> Result<Identification> {
        let n = centroids.len();
        if n < MIN_CENTROIDS {
            let mut id = Identification::unidentified(Status::TooFewStars, n, 0, start.elapsed());
            id.method = config.method;
            return Ok(id);
        }
        // The frame's buffers come from the thread's scratch and go back to it at the end.
        let mut scratch = take_scratch();
        let mut frame = std::mem::take(&mut scratch.frame);
        let FrameBuffers {
            obs,
            obs_mirrored,
            order,
            passes,
        } = &mut frame;
        obs.clear();
        obs.extend(
            centroids
                .iter()
                .map(|c| camera.pixel_to_cam(c[0], c[1], false)),
        );
        obs_mirrored.clear();
        if camera.is_ideal() {
            obs_mirrored.extend(obs.iter().map(|v| Vector3::new(-v.x, v.y, v.z)));
        } else {
            obs_mirrored.extend(
                centroids
                    .iter()
                    .map(|c| camera.pixel_to_cam(c[0], c[1], true)),
            );
        }
        brightness_order_into(n, magnitudes, order);
        let ladder: &[f64] = match &config.centroid_sigma_px {
            Some(s) => std::slice::from_ref(s),
            None => &SIGMA_LADDER_PX,
        };
        let gated = self.magnitudes_fit(magnitudes, config);
        self.passes(n, ladder, magnitudes.is_some(), gated, config, passes);
        // Catalogue-magnitude windows of each centroid (known zero point): the tight one first
        // (fewer hypotheses compete, so a solution of few stars can pass the bound), then the
        // configured one.
        let windows = |tol: f64| -> Option<Vec<[f32; 2]>> {
            match (magnitudes, config.mag_offset) {
                (Some(m), Some(off)) if gated => Some(
                    m.iter()
                        .map(|&mi| [(mi - off - tol) as f32, (mi - off + tol) as f32])
                        .collect(),
                ),
                _ => None,
            }
        };
        // Made when a gated pass first needs them (most frames end in the bright pass before).
        let gate = std::cell::OnceCell::new();
        let gate_tight = std::cell::OnceCell::new();
        let fraction =
            |g: &Option<Vec<[f32; 2]>>| g.as_deref().map_or(1.0, |g| self.window_fraction(g));
        let mut gated_ran = false;
        let mut fraction_normal = None;
        let stride = passes
            .iter()
            .filter(|p| !p.gated)
            .map(|p| p.stars)
            .max()
            .unwrap_or(3)
            .min(n);
        scratch.forget_angles(stride);
        let mut search = Search::new(
            self,
            camera,
            config,
            [obs, obs_mirrored],
            magnitudes,
            order,
            scratch,
        );
        search.stride = stride;
        search.deadline = config.timeout.map(|t| start + t);
        let mut status = Status::NoMatch;
        // Set when the gated passes spent the budget: only the closing pass runs then.
        let mut closing_only = false;
        for &pass in passes.iter() {
            if closing_only && !pass.closing {
                continue;
            }
            search.pairs = if pass.bright {
                self.bright_pairs.as_ref().unwrap_or(&self.pairs)
            } else {
                &self.pairs
            };
            let (gate, gate_tight) = if pass.gated {
                (
                    gate.get_or_init(|| windows(config.mag_tolerance)),
                    gate_tight.get_or_init(|| windows(TIGHT_MAG_FRACTION * config.mag_tolerance)),
                )
            } else {
                (&None, &None)
            };
            if pass.gated {
                search.gate_fraction = *fraction_normal.get_or_insert_with(|| fraction(gate));
                // Gated passes search more stars: a wider angle cache.
                let wide = pass.stars.min(n);
                if wide > search.stride {
                    search.stride = wide;
                    search.scratch.forget_angles(wide);
                }
            }
            search.gate = if pass.gated { gate.as_deref() } else { None };
            search.gen_gate = if pass.gated && pass.tight {
                gate_tight.as_deref()
            } else {
                None
            };
            if pass.gated {
                let stride = search.stride;
                search.scratch.side_cache.reset(stride);
            }
            // After gated passes (a crowded frame with calibrated magnitudes), the ungated
            // passes that follow, the fallback for magnitudes that mislead, get a budget too.
            search.pass_pairs_limit = if closing_only {
                search.pairs_visited.saturating_add(CLOSING_LOOSE_PAIRS)
            } else if pass.gated {
                gated_ran = true;
                search.pairs_visited.saturating_add(pass.pairs_budget)
            } else if gated_ran {
                // After gated passes (calibrated magnitudes, nothing found), the ungated passes
                // are a short fallback: a frame whose magnitudes mislead should say so
                // (`mag_offset: None`) and is then searched without the gate, in full.
                search.pairs_visited.saturating_add(FALLBACK_PAIRS_PER_STEP)
            } else if n > config.max_search_stars {
                // A crowded frame searched by its brightest spots alone: most are false, and a
                // search that has not found an all-real triangle yet seldom will.
                search
                    .pairs_visited
                    .saturating_add(CROWDED_PAIRS_PER_STEP.min(pass.pairs_budget))
            } else {
                // A pass's own budget (the loosest step's: see LOOSEST_STEP_SHARE), if any.
                search.pairs_visited.saturating_add(pass.pairs_budget)
            };
            search.method = pass.method;
            let work_before = search.pairs_visited;
            let found = match pass.method {
                Method::Voting => search.vote(pass.stars, pass.sigma_px),
                m if m.is_seed() => search.seed(m, pass.stars, pass.sigma_px),
                _ => search.run(pass.stars, pass.sigma_px, pass.cap),
            };
            if pass.gated {
                search.gated_work += search.pairs_visited - work_before;
            }
            match found {
                Ok(Some(v)) => {
                    let hypotheses = search.hypotheses;
                    let method = search.method;
                    let mut scratch = search.scratch;
                    scratch.frame = frame;
                    return_scratch(scratch);
                    let mut id = v.into_identification(hypotheses, start.elapsed());
                    id.method = method;
                    return Ok(id);
                }
                Ok(None) => {}
                Err(SearchLimit(Status::SearchLimit)) if pass.gated && !closing_only => {
                    // The budget, spent by the gated passes (whose work then no longer counts
                    // against it, as above): the closing pass still runs.
                    status = Status::SearchLimit;
                    closing_only = true;
                }
                Err(SearchLimit(why)) => {
                    status = why;
                    break;
                }
            }
        }
        let hypotheses = search.hypotheses;
        let mut scratch = search.scratch;
        scratch.frame = frame;
        return_scratch(scratch);
        let mut id = Identification::unidentified(status, n, hypotheses, start.elapsed());
        id.method = config.method;
        Ok(id)
    }

    /// Whether the centroids' magnitudes fit the catalogue's system (after `mag_offset`): most
    /// centroids' windows hold catalogue stars. An arbitrary instrument zero point (or
    /// magnitudes that mislead) puts them outside, and the frame is searched without the gate.
    fn magnitudes_fit(&self, magnitudes: Option<&[f64]>, config: &IdentifyConfig) -> bool {
        match (magnitudes, config.mag_offset) {
            (Some(m), Some(off)) => {
                let tol = config.mag_tolerance;
                let sorted = &self.mag_sorted;
                // More than half the centroids have a catalogue star in their window: stop
                // counting once that is known.
                let need = m.len() / 2 + 1;
                m.iter()
                    .filter(|&&mi| {
                        let (lo, hi) = ((mi - off - tol) as f32, (mi - off + tol) as f32);
                        sorted.first_at_least(lo).is_some_and(|x| x <= hi)
                    })
                    .take(need)
                    .count()
                    >= need
            }
            _ => false,
        }
    }

    /// The passes of one identification, in order.
    ///
    /// Pyramid passes run in the order of the noise ladder, whose last (loosest) step comes last
    /// for both indexes: its wide tolerances find coincidences and verify with a wide radius, so
    /// it is the last resort. With magnitudes, each earlier step first tries the brightest few
    /// stars against the locally bright stars only: cheap, and it nearly always succeeds. With a
    /// known zero point (`mag_offset`), a magnitude-gated pass over every centroid follows: it
    /// finds the few real stars among many false ones.
    fn passes(
        &self,
        n: usize,
        ladder: &[f64],
        has_mags: bool,
        gated: bool,
        config: &IdentifyConfig,
        passes: &mut Vec<Pass>,
    ) {
        let (last, early) = ladder.split_last().expect("the ladder has a step");
        let pass = |bright: bool, stars: usize, sigma_px: f64, cap: usize| Pass {
            bright,
            gated: false,
            tight: false,
            pairs_budget: usize::MAX,
            stars,
            sigma_px,
            cap,
            method: Method::Pyramid,
            closing: false,
        };
        // The brightest few at the loosest step: cheap, and the last resort of a frame whose
        // gated passes spent the budget (see CLOSING_LOOSE_PAIRS).
        let closing_pass = Pass {
            closing: true,
            ..pass(true, BRIGHT_SEARCH_STARS, *last, usize::MAX)
        };
        passes.clear();
        if config.method == Method::Voting || config.method.is_seed() {
            for &s in ladder {
                passes.push(Pass {
                    gated: gated && config.method == Method::Voting,
                    method: config.method,
                    ..pass(false, n.min(HOSTILE_SEARCH_STARS), s, usize::MAX)
                });
            }
            return;
        }
        // Without magnitudes, the input order is taken as brightness order (extractors list
        // spots brightest first) unless the configuration says it is not: the cheap pass over the
        // first few spots runs then too.
        let bright = self.bright_pairs.is_some() && (has_mags || config.brightness_order);
        // Crowded frames need more triangles before an all-real one comes up: the tighter steps
        // try a fixed share of the search stars' triangles there.
        let s = n.min(config.max_search_stars);
        let triangles_per_step =
            TRIANGLES_PER_STEP.max(s * (s - 1) * (s - 2) / 6 / CROWDED_TRIANGLE_SHARE);
        if bright {
            passes.extend(
                early
                    .iter()
                    .map(|&s| pass(true, BRIGHT_SEARCH_STARS, s, usize::MAX)),
            );
            // Without a magnitude gate (the order alone, or magnitudes of unknown zero point),
            // false spots among the brightest few can hide a sparse field's stars: the locally
            // bright pairs once more, over more spots, before the whole index (see
            // BRIGHT_WIDE_SEARCH_STARS).
            if !gated && n > BRIGHT_SEARCH_STARS && n <= config.max_search_stars {
                let tightest = early.first().copied().unwrap_or(*last);
                passes.push(pass(true, BRIGHT_WIDE_SEARCH_STARS, tightest, usize::MAX));
            }
        }
        if gated && config.method == Method::Auto && n > BRIGHT_SEARCH_STARS {
            // The tightest step over every spot; looser ones over the brightest
            // HOSTILE_LOOSE_STARS only (their wider tolerances multiply the candidates).
            // The gated steps: all but the loosest of the ladder (or the one given).
            let gated_steps: &[f64] = if early.is_empty() { ladder } else { early };
            // First the tight magnitude window at the tightest step, then the configured one.
            passes.push(Pass {
                gated: true,
                tight: true,
                pairs_budget: HOSTILE_PAIRS_PER_STEP / 2,
                method: Method::Auto,
                ..pass(
                    false,
                    n.min(HOSTILE_SEARCH_STARS),
                    gated_steps[0],
                    HOSTILE_TRIANGLES,
                )
            });
            passes.extend(gated_steps.iter().enumerate().map(|(k, &s)| Pass {
                gated: true,
                pairs_budget: if k == 0 {
                    HOSTILE_PAIRS_PER_STEP / 2
                } else {
                    HOSTILE_PAIRS_PER_STEP / 8
                },
                method: Method::Auto,
                ..pass(
                    false,
                    n.min(if k == 0 {
                        HOSTILE_SEARCH_STARS
                    } else {
                        HOSTILE_LOOSE_STARS
                    }),
                    s,
                    HOSTILE_TRIANGLES,
                )
            }));
            // A crowded frame whose calibrated magnitudes found nothing: the ungated passes
            // over its brightest spots, the fallback for magnitudes that mislead, would mostly
            // try false stars; they are left out beyond this many spots.
            // The brightest few at the loosest step still close the search.
            if n > HOSTILE_FALLBACK_MAX_SPOTS {
                if bright && !early.is_empty() {
                    passes.push(closing_pass);
                }
                return;
            }
        }
        passes.extend(
            early
                .iter()
                .map(|&s| pass(false, config.max_search_stars, s, triangles_per_step)),
        );
        if bright {
            passes.push(closing_pass);
        }
        // The loosest step, the last resort, on a share of the budget (see LOOSEST_STEP_SHARE).
        passes.push(Pass {
            pairs_budget: if early.is_empty() {
                usize::MAX
            } else {
                config.max_pairs_visited / LOOSEST_STEP_SHARE
            },
            ..pass(false, config.max_search_stars, *last, usize::MAX)
        });
        for p in passes.iter_mut() {
            p.stars = p.stars.min(n);
        }
    }
}

/// The early stop's density: this quantile (per mille) of the fields' star counts.
const SPARSE_QUANTILE_PERMILLE: usize = 50;

/// Stars per steradian in the sparsest of 2000 cones of `radius_rad` spread evenly over the
/// sky (a Fibonacci lattice), at least one star per cone.
fn sparsest_density(catalog: &Catalog, radius_rad: f64) -> f64 {
    const CONES: usize = 2000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut counts: Vec<usize> = (0..CONES)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / CONES as f64;
            let rho = (1.0 - z * z).sqrt();
            let phi = golden * k as f64;
            let v = Vector3::new(rho * phi.cos(), rho * phi.sin(), z);
            catalog.count_in_cone(&v, radius_rad)
        })
        .collect();
    counts.sort_unstable();
    let least = counts[CONES * SPARSE_QUANTILE_PERMILLE / 1000].max(1);
    least as f64 / (2.0 * std::f64::consts::PI * (1.0 - radius_rad.cos()))
}

/// One pass of the search.
#[derive(Debug, Clone, Copy)]
struct Pass {
    /// Search the pairs of locally bright stars only.
    bright: bool,
    /// Gate catalogue stars by magnitude.
    gated: bool,
    /// With the tight window ([`TIGHT_MAG_FRACTION`] of `mag_tolerance`).
    tight: bool,
    /// Catalogue pairs the pass may visit (gated passes, and the loosest step's full pass).
    pairs_budget: usize,
    /// Brightest centroids that form triangles.
    stars: usize,
    /// Centroid noise of the step, pixels.
    sigma_px: f64,
    /// Most triangles tried.
    cap: usize,
    /// The method the pass runs (and reports).
    method: Method,
    /// The loosest step's bright pass, which still runs when gated passes spent the budget
    /// (see [`CLOSING_LOOSE_PAIRS`]).
    closing: bool,
}

/// One frame of a batch: its centroids and, optionally, their magnitudes.
pub type FrameRef<'a> = (&'a [[f64; 2]], Option<&'a [f64]>);

impl Solver {
    /// The zero point a batch's identified frames agree on, and the magnitude tolerance to
    /// search with it: at least [`ZERO_POINT_MIN_FRAMES`] frames with magnitudes measure one
    /// ([`Identification::zero_point`]), at most a third of them lie more than
    /// [`ZERO_POINT_AGREE_MAG`] from the median, which is the answer; the tolerance is
    /// [`ZERO_POINT_TOLERANCE_SIGMAS`] times the agreeing frames' median spread, within the
    /// configured tolerance and [`ZERO_POINT_MAX_TOLERANCE_MAG`]. `None` when nothing agrees.
    fn learn_zero_point(
        &self,
        frames: &[FrameRef<'_>],
        out: &[Identification],
        config: &IdentifyConfig,
    ) -> Option<(f64, f64)> {
        let (z, s): (Vec<f64>, Vec<f64>) = frames
            .iter()
            .zip(out)
            .filter(|(_, id)| id.is_identified())
            .filter_map(|(f, id)| id.zero_point(f.1?, &self.catalog))
            .unzip();
        agreed_zero_point(&z, &s, config.mag_tolerance)
    }

    /// Identify many frames of one camera, in parallel when the `parallel` feature is on and
    /// `threads` is not 1 (`None`: all cores). Results come in input order and do not depend on
    /// the thread count. A malformed frame does not stop the batch: its result has status
    /// [`Status::InvalidInput`] and the reason in [`Identification::message`].
    ///
    /// # Errors
    /// `InvalidInput` when `config` is invalid or the thread pool cannot start.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// let frames: Vec<_> = (0..4).map(|s| simulate(&cat, &cam, &SimConfig::default(), s).unwrap()).collect();
    /// let refs: Vec<_> = frames.iter().map(|f| (f.centroids.as_slice(), Some(f.magnitudes.as_slice()))).collect();
    /// let ids = solver.identify_batch(&refs, &cam, &IdentifyConfig::default(), None).unwrap();
    /// assert_eq!(ids.len(), 4);
    /// ```
    pub fn identify_batch(
        &self,
        frames: &[FrameRef<'_>],
        camera: &Camera,
        config: &IdentifyConfig,
        threads: Option<usize>,
    ) -> Result<Vec<Identification>> {
        self.identify_batch_until(frames, camera, config, threads, &AtomicBool::new(false))
    }

    /// As [`Solver::identify_batch`], checking `cancel` before each frame: once it is set, the
    /// batch returns `ErrorKind::Cancelled` within about one frame's time per thread (a frame
    /// ends within the search's work budget) plus a chunk's bookkeeping. Frames run in chunks
    /// of [`BATCH_CHUNK`], so a cancelled batch of millions allocates only what it finished.
    ///
    /// # Errors
    /// As [`Solver::identify_batch`]; `Cancelled` once `cancel` is set.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// use std::sync::atomic::AtomicBool;
    /// let frames: Vec<_> = (0..4).map(|s| simulate(&cat, &cam, &SimConfig::default(), s).unwrap()).collect();
    /// let refs: Vec<_> = frames.iter().map(|f| (f.centroids.as_slice(), None)).collect();
    /// let stop = AtomicBool::new(true); // already cancelled
    /// let e = solver.identify_batch_until(&refs, &cam, &IdentifyConfig::default(), None, &stop).unwrap_err();
    /// assert_eq!(e.kind(), &starid_core::ErrorKind::Cancelled);
    /// ```
    pub fn identify_batch_until(
        &self,
        frames: &[FrameRef<'_>],
        camera: &Camera,
        config: &IdentifyConfig,
        threads: Option<usize>,
        cancel: &AtomicBool,
    ) -> Result<Vec<Identification>> {
        config.validate()?;
        // Without the `parallel` feature every batch runs on the calling thread.
        #[cfg(not(feature = "parallel"))]
        let _ = threads;
        let one = |f: &FrameRef<'_>, config: &IdentifyConfig| -> Identification {
            if cancel.load(Ordering::Relaxed) {
                // Nothing is looked at; the chunk's end reports the cancellation.
                return Identification::unidentified(Status::NoMatch, 0, 0, Duration::ZERO);
            }
            self.identify(f.0, f.1, camera, config)
                .unwrap_or_else(|e| Identification::invalid_input(f.0.len(), e.to_string()))
        };
        // The frames `which` picks (all of them: `None`), identified with `config`.
        let run =
            |which: Option<&[usize]>, config: &IdentifyConfig| -> Result<Vec<Identification>> {
                let total = which.map_or(frames.len(), <[usize]>::len);
                let mut out = Vec::with_capacity(total.min(BATCH_CHUNK));
                let mut start = 0;
                while start < total {
                    let end = (start + BATCH_CHUNK).min(total);
                    if cancel.load(Ordering::Relaxed) {
                        return Err(Error::cancelled());
                    }
                    let frame = |k: usize| &frames[which.map_or(k, |w| w[k])];
                    #[cfg(feature = "parallel")]
                    if threads != Some(1) && end - start > 1 {
                        use rayon::prelude::*;
                        out.par_extend((start..end).into_par_iter().map(|k| one(frame(k), config)));
                        start = end;
                        continue;
                    }
                    out.extend((start..end).map(|k| one(frame(k), config)));
                    start = end;
                }
                if cancel.load(Ordering::Relaxed) {
                    return Err(Error::cancelled());
                }
                Ok(out)
            };
        let both = || -> Result<Vec<Identification>> {
            let mut out = run(None, config)?;
            // A zero point the identified frames agree on: the frames nothing identified
            // without it are searched again, magnitude-gated (nothing is measured while every
            // frame with magnitudes is identified).
            let failed = |i: usize| {
                matches!(out[i].status, Status::NoMatch | Status::SearchLimit)
                    && frames[i].1.is_some()
            };
            if !config.learn_zero_point || !(0..frames.len()).any(failed) {
                return Ok(out);
            }
            let Some(learned) = self
                .learn_zero_point(frames, &out, config)
                .and_then(|zp| config.with_learned_zero_point(zp))
            else {
                return Ok(out);
            };
            let offset = learned.mag_offset.unwrap_or_default();
            let redo: Vec<usize> = (0..frames.len()).filter(|&i| failed(i)).collect();
            for (i, mut id) in redo.iter().zip(run(Some(&redo), &learned)?) {
                id.elapsed += out[*i].elapsed;
                id.hypotheses += out[*i].hypotheses;
                if id.is_identified() {
                    id.learned_mag_offset = Some(offset);
                    out[*i] = id;
                } else {
                    out[*i].elapsed = id.elapsed;
                    out[*i].hypotheses = id.hypotheses;
                }
            }
            Ok(out)
        };
        #[cfg(feature = "parallel")]
        if let Some(t) = threads.filter(|&t| t > 1) {
            return rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::invalid_input(format!("cannot start {t} threads: {e}")))?
                .install(both);
        }
        both()
    }
}

/// The centroids brightest first (by magnitude, ties by index), or as given without magnitudes.
/// Into `order` (cleared first): a search keeps the buffer between calls.
pub(crate) fn brightness_order_into(n: usize, magnitudes: Option<&[f64]>, order: &mut Vec<usize>) {
    order.clear();
    let Some(m) = magnitudes else {
        order.extend(0..n);
        return;
    };
    // Each magnitude as an integer in the order of `f64::total_cmp`: sorting (key, index) pairs
    // gives the order with ties by index, each comparison as cheap as one of integers.
    let n = m.len();
    if n <= BRIGHTNESS_INSERTION_MAX {
        // A frame of a few dozen spots: an insertion sort of the indices by key (stable, so
        // ties keep their index order), with no allocation but the answer's.
        let mut keys = [0i64; BRIGHTNESS_INSERTION_MAX];
        for (k, &x) in keys.iter_mut().zip(m) {
            *k = magnitude_key(x);
        }
        let mut idx = [0u8; BRIGHTNESS_INSERTION_MAX];
        for i in 0..n {
            let k = keys[i];
            let mut j = i;
            while j > 0 && keys[usize::from(idx[j - 1])] > k {
                idx[j] = idx[j - 1];
                j -= 1;
            }
            idx[j] = i as u8;
        }
        order.extend(idx[..n].iter().map(|&i| usize::from(i)));
        return;
    }
    let mut keyed: Vec<(i64, usize)> = m
        .iter()
        .enumerate()
        .map(|(i, &x)| (magnitude_key(x), i))
        .collect();
    keyed.sort_unstable();
    order.extend(keyed.into_iter().map(|(_, i)| i));
}

/// The first centroids of [`brightness_order_into`], found as they are asked for: a tracking search,
/// which mostly verifies from its first pair of spots, needs only the brightest two. Frames of
/// more than [`BRIGHTNESS_INSERTION_MAX`] spots are sorted whole at once.
pub(crate) struct BrightnessPrefix<'b> {
    /// The magnitudes as [`brightness_order_into`]'s integer keys, while spots remain to be found.
    keys: [i64; BRIGHTNESS_INSERTION_MAX],
    /// Spots already in `order` (bit per spot).
    taken: u64,
    n: usize,
    order: &'b mut Vec<usize>,
}

impl<'b> BrightnessPrefix<'b> {
    pub(crate) fn new(n: usize, magnitudes: Option<&[f64]>, order: &'b mut Vec<usize>) -> Self {
        let mut keys = [0i64; BRIGHTNESS_INSERTION_MAX];
        match magnitudes {
            Some(m) if n <= BRIGHTNESS_INSERTION_MAX => {
                order.clear();
                for (k, &x) in keys.iter_mut().zip(m) {
                    *k = magnitude_key(x);
                }
            }
            // No magnitudes (the order as given), or many spots: the whole order now.
            _ => brightness_order_into(n, magnitudes, order),
        }
        Self {
            keys,
            taken: 0,
            n,
            order,
        }
    }

    /// The brightest `len` centroids (at most all), brightest first.
    pub(crate) fn first(&mut self, len: usize) -> &[usize] {
        let len = len.min(self.n);
        while self.order.len() < len {
            // The brightest spot not yet taken; ties to the lowest index, as the stable sort.
            let mut best = usize::MAX;
            for i in 0..self.n {
                if self.taken & (1 << i) == 0
                    && (best == usize::MAX || self.keys[i] < self.keys[best])
                {
                    best = i;
                }
            }
            self.taken |= 1 << best;
            self.order.push(best);
        }
        &self.order[..len]
    }
}

/// A magnitude as an integer in the order of `f64::total_cmp`.
#[inline]
fn magnitude_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

/// Most centroids whose duplicates [`validate_centroids`] screens by hashing (more: by sorting).
const DUPLICATE_HASH_MAX: usize = 256;

/// Most centroids [`brightness_order_into`] sorts by insertion.
const BRIGHTNESS_INSERTION_MAX: usize = 64;

pub(crate) fn validate_centroids(
    centroids: &[[f64; 2]],
    magnitudes: Option<&[f64]>,
    camera: &Camera,
) -> Result<()> {
    let n = centroids.len();
    if n > MAX_CENTROIDS {
        return Err(Error::invalid_input(format!(
            "too many centroids: {n} (at most {MAX_CENTROIDS})"
        )));
    }
    let (w, h) = (camera.width_px, camera.height_px);
    for (i, c) in centroids.iter().enumerate() {
        if !c[0].is_finite() || !c[1].is_finite() {
            return Err(Error::invalid_input(format!(
                "centroid {i} has a non-finite coordinate ({}, {})",
                c[0], c[1]
            )));
        }
        // A star cut by the sensor's edge can centroid a little outside it: only a point more than
        // a sensor width (height) away is an error.
        if c[0] < -w || c[0] > 2.0 * w || c[1] < -h || c[1] > 2.0 * h {
            return Err(Error::invalid_input(format!(
                "centroid {i} at ({}, {}) lies more than a sensor size outside the {w} x {h} px sensor (x right, y down, origin top-left)",
                c[0], c[1]
            )));
        }
    }
    // Duplicates: equal coordinates (−0 equals 0, hence `+ 0.0`) are equal bit patterns; up to
    // DUPLICATE_HASH_MAX centroids screened by a hash table on the stack, more sorted as integers.
    let key = |c: &[f64; 2]| ((c[0] + 0.0).to_bits(), (c[1] + 0.0).to_bits());
    let duplicate = if n <= DUPLICATE_HASH_MAX {
        // Each key sets one bit of a 4096-bit table by its hash; only a key whose bit is already
        // set is compared with the centroids before it (a 256-spot frame collides about 8 times).
        let mut seen = [0u64; 64];
        let mut dup = false;
        for (j, c) in centroids.iter().enumerate() {
            let k = key(c);
            let h =
                ((k.0 ^ k.1.rotate_left(29)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 52) as usize;
            let (word, bit) = (h >> 6, 1u64 << (h & 63));
            if seen[word] & bit != 0 && centroids[..j].iter().any(|c| key(c) == k) {
                dup = true;
                break;
            }
            seen[word] |= bit;
        }
        dup
    } else {
        let mut keys: Vec<(u64, u64)> = centroids.iter().map(key).collect();
        keys.sort_unstable();
        keys.windows(2).any(|w| w[0] == w[1])
    };
    // Name the pair (rare: only for the error).
    let mut sorted: Vec<usize> = if duplicate {
        (0..n).collect()
    } else {
        Vec::new()
    };
    sorted.sort_unstable_by_key(|&i| key(&centroids[i]));
    for pair in sorted.windows(2) {
        let (a, b) = (centroids[pair[0]], centroids[pair[1]]);
        if key(&a) == key(&b) {
            let (i, j) = (pair[0].min(pair[1]), pair[0].max(pair[1]));
            return Err(Error::invalid_input(format!(
                "centroids {i} and {j} are duplicates at ({}, {})",
                a[0], a[1]
            )));
        }
    }
    if let Some(m) = magnitudes {
        if m.len() != n {
            return Err(Error::invalid_input(format!(
                "magnitudes has {} values for {n} centroids",
                m.len()
            )));
        }
        if let Some(i) = m.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_input(format!(
                "magnitude {i} is not finite ({})",
                m[i]
            )));
        }
    }
    Ok(())
}

/// This thread's scratch buffers (a new set on its first call, or while another call on the
/// thread holds them).
fn take_scratch() -> Box<Scratch> {
    SCRATCH.with(std::cell::Cell::take).unwrap_or_default()
}

/// Hand the scratch buffers back to this thread for its next call.
fn return_scratch(scratch: Box<Scratch>) {
    SCRATCH.with(|c| c.set(Some(scratch)));
}

thread_local! {
    /// Buffers kept between calls on a thread, so identification allocates almost nothing.
    /// Boxed: a call takes and returns a pointer, not the buffers' headers (moving them in and
    /// out, and dropping the empty set left behind, cost about 1 500 instructions a call).
    static SCRATCH: std::cell::Cell<Option<Box<Scratch>>> = const { std::cell::Cell::new(None) };
}

/// Per centroid pair (search positions `a < b`, at `a * stride + b`): `(first entry, count)`
/// into `entries`, the magnitude-consistent catalogue pairs `[star of a, star of b]`;
/// `u32::MAX` until read.
#[derive(Default)]
struct SideCache {
    index: Vec<(u32, u32)>,
    entries: Vec<[u32; 2]>,
}

impl SideCache {
    fn reset(&mut self, stride: usize) {
        self.index.clear();
        self.index.resize(stride * stride, (u32::MAX, 0));
        self.entries.clear();
    }
}

/// Catalogue magnitudes ascending, with a table of where each of [`MAG_COUNT_BINS`] equal
/// magnitude bins starts: a count below a magnitude (asked per centroid on every call) is a
/// search within one bin, in cache, instead of one over the whole catalogue.
#[derive(Debug, Clone)]
struct SortedMags {
    sorted: Vec<f32>,
    lo: f32,
    scale: f32,
    /// `start[b]`: the stars of bins before `b`; `start[MAG_COUNT_BINS] = len`.
    start: Vec<u32>,
}

/// Bins of [`SortedMags`].
const MAG_COUNT_BINS: usize = 8192;

impl SortedMags {
    fn new(mags: &[f32]) -> Self {
        let mut sorted = mags.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let (lo, hi) = (
            sorted.first().copied().unwrap_or(0.0),
            sorted.last().copied().unwrap_or(0.0),
        );
        let scale = MAG_COUNT_BINS as f32 / (hi - lo).max(1e-3);
        let mut table = Self {
            sorted,
            lo,
            scale,
            start: Vec::new(),
        };
        // The bin of a magnitude never decreases with it, so `start` is a partition of `sorted`.
        let bins: Vec<usize> = table.sorted.iter().map(|&m| table.bin(m)).collect();
        table.start = (0..=MAG_COUNT_BINS)
            .map(|b| bins.partition_point(|&x| x < b) as u32)
            .collect();
        table
    }

    fn len(&self) -> usize {
        self.sorted.len()
    }

    #[inline]
    fn bin(&self, m: f32) -> usize {
        // Saturating at 0 (and NaN at 0), as any `as`; 32 bits convert faster than usize.
        (((m - self.lo) * self.scale) as u32 as usize).min(MAG_COUNT_BINS - 1)
    }

    /// The smallest catalogue magnitude at least `x`, if any.
    #[inline]
    fn first_at_least(&self, x: f32) -> Option<f32> {
        let b = self.bin(x);
        let (a, e) = (self.start[b] as usize, self.start[b + 1] as usize);
        let i = a + self.sorted[a..e].partition_point(|&m| m < x);
        self.sorted.get(i).copied()
    }

    /// Stars with a magnitude at most `x`.
    #[inline]
    fn count_at_most(&self, x: f32) -> usize {
        let b = self.bin(x);
        let (a, e) = (self.start[b] as usize, self.start[b + 1] as usize);
        a + self.sorted[a..e].partition_point(|&m| m <= x)
    }
}

/// The search must stop: the hypothesis budget or the time ran out.
struct SearchLimit(Status);

/// A frame's own buffers in a lost-in-space search: its directions, order and passes.
#[derive(Default)]
struct FrameBuffers {
    obs: Vec<Vector3<f64>>,
    obs_mirrored: Vec<Vector3<f64>>,
    order: Vec<usize>,
    passes: Vec<Pass>,
}

/// Reusable buffers: no allocation per hypothesis.
#[derive(Default)]
struct Scratch {
    /// The frame being searched (taken out of the scratch while the search borrows it).
    frame: FrameBuffers,
    /// Binomial tails each pass needs again.
    tails: pyramid::TailMemo,
    adj_ik: pyramid::Adjacency,
    triangles: Vec<[u32; 3]>,
    matches: Vec<Option<(u32, f64)>>,
    claim: Vec<(u32, u32, f64)>,
    obs_matched: Vec<Vector3<f64>>,
    ref_matched: Vec<Vector3<f64>>,
    /// The star of each centroid in the matches the attitude was last fitted to.
    fitted: Vec<Option<u32>>,
    /// Instrument minus catalogue magnitude of the matches, then their absolute deviations.
    mag_offsets: Vec<f64>,
    /// Angles between the search stars with their cosines and sines (`[t, cos t, sin t]`,
    /// row-major with `Search::stride`, computed when first needed), kept across the passes: the
    /// observed directions do not change between them.
    angles: Vec<[f64; 3]>,
    /// One bit per entry of `angles`: whether it was computed for this frame. (Marking a
    /// frame's entries unknown clears these bits: writing NaN over every entry, 14 kB for 24
    /// search stars, cost 600 instructions and 90 cache misses per S1 frame.)
    angle_known: Vec<u64>,
    /// Each centroid pair's range in the pair index of an ungated Pyramid step (row-major with
    /// `Search::stride`), and one bit per entry: whether the step has found it yet.
    side_ranges: (Vec<[u32; 2]>, Vec<u64>),
    /// Sub-index ranges of each centroid pair of a gated pass, read once per pass.
    side_cache: SideCache,
    /// Centroids torn between two stars in the last matching pass.
    ambiguous: Vec<(u32, [(u32, f64); 2])>,
    /// Voting counters (centroid row × catalogue star) and the cells touched.
    votes: Vec<u16>,
    vote_touched: Vec<u32>,
    /// The catalogue stars near each centroid under the last attitude looked up.
    near: verify::NearCache,
    /// Which centroid claimed each catalogue star in the last matching pass.
    claims: verify::Claims,
}

impl Scratch {
    /// Room for the angles of `stride` search stars, none of them known (the values left from
    /// an earlier frame are never read).
    fn forget_angles(&mut self, stride: usize) {
        let n = stride * stride;
        if self.angles.len() < n {
            self.angles.resize(n, [f64::NAN; 3]);
        }
        self.angle_known.clear();
        self.angle_known.resize(n.div_ceil(64), 0);
    }
}

struct Search<'a> {
    solver: &'a Solver,
    /// The pair index of the current pass.
    pairs: &'a PairIndex,
    camera: &'a Camera,
    config: &'a IdentifyConfig,
    /// Observed directions: `[as seen, x reversed]`.
    obs: [&'a [Vector3<f64>]; 2],
    magnitudes: Option<&'a [f64]>,
    /// Catalogue-magnitude window `[lo, hi]` of each centroid in a gated pass (verification,
    /// and hypotheses unless `gen_gate` is set).
    gate: Option<&'a [[f32; 2]]>,
    /// A tighter window for making hypotheses only.
    gen_gate: Option<&'a [[f32; 2]]>,
    /// Work spent in gated passes, which have budgets of their own: `max_pairs_visited` bounds
    /// the rest.
    gated_work: usize,
    /// Search positions of the current triangle's three centroids.
    tri_pos: [usize; 3],
    /// `pairs_visited` at which the current pass ends (the search goes on with the next).
    pass_pairs_limit: usize,
    /// Mean over the centroids of the fraction of catalogue stars they may match (see
    /// [`Solver::window_fraction`]).
    gate_fraction: f64,
    order: &'a [usize],
    hypotheses: usize,
    pairs_visited: usize,
    deadline: Option<Instant>,
    scratch: Box<Scratch>,
    /// Row length of `scratch.angles`: the most search stars of any pass.
    stride: usize,
    /// The method of the current pass.
    method: Method,
    /// Set in hinted (tracking) identification: what the false-match bound counts instead of
    /// a search of the whole sky.
    hint: Option<hinted::HintPrior>,
    /// Centroids the current hypothesis was built from (3 for a triangle): they match by
    /// construction, so the false-match bound counts only the others as evidence.
    built: usize,
}

impl<'a> Search<'a> {
    /// A search over the whole pair index with no gate, hint or deadline: the passes set
    /// what they need.
    fn new(
        solver: &'a Solver,
        camera: &'a Camera,
        config: &'a IdentifyConfig,
        obs: [&'a [Vector3<f64>]; 2],
        magnitudes: Option<&'a [f64]>,
        order: &'a [usize],
        mut scratch: Box<Scratch>,
    ) -> Self {
        // The stars near centroids are held for one search only.
        scratch.near.clear();
        Self {
            solver,
            pairs: &solver.pairs,
            camera,
            config,
            obs,
            magnitudes,
            gate: None,
            gen_gate: None,
            gate_fraction: 1.0,
            pass_pairs_limit: usize::MAX,
            tri_pos: [0; 3],
            gated_work: 0,
            order,
            hypotheses: 0,
            pairs_visited: 0,
            deadline: None,
            scratch,
            stride: 0,
            method: config.method,
            hint: None,
            built: 3,
        }
    }

    /// Whether the search's time is up or its caller cancelled it.
    fn out_of_time(&self) -> bool {
        stop_now(self.deadline, self.config.cancel.as_ref())
    }
}

/// A verified solution.
struct Verified {
    r: Rotation3<f64>,
    mirrored: bool,
    matches: Vec<Option<(u32, f64)>>,
    matched: usize,
    sigma_px: f64,
    radius_rad: f64,
    /// Binomial tail of the match count under a false hypothesis.
    tail: f64,
    /// `tail` times the hypotheses tested (set by `accept`).
    false_prob: f64,
    /// Passed the shared verification (false: a method's raw answer).
    verified: bool,
    /// Raw answers: whether an attitude could be fitted to the assignment (`r` is the
    /// identity otherwise).
    has_attitude: bool,
}

impl Verified {
    /// A method's raw answer: `matches` as it named them, the attitude fitted to them if any.
    fn raw(matches: Vec<Option<(u32, f64)>>, fit: Option<(Rotation3<f64>, bool)>) -> Self {
        let matched = matches.iter().filter(|m| m.is_some()).count();
        Self {
            r: fit.map_or_else(Rotation3::identity, |f| f.0),
            mirrored: fit.is_some_and(|f| f.1),
            matches,
            matched,
            sigma_px: f64::NAN,
            radius_rad: f64::NAN,
            tail: 1.0,
            false_prob: 1.0,
            verified: false,
            has_attitude: fit.is_some(),
        }
    }

    fn into_identification(self, hypotheses: usize, elapsed: Duration) -> Identification {
        Identification {
            status: Status::Identified,
            catalog_index: self.matches.iter().map(|m| m.map(|(c, _)| c)).collect(),
            residuals_rad: self
                .matches
                .iter()
                .map(|m| m.map_or(f64::NAN, |(_, d)| d))
                .collect(),
            r_icrs_to_cam: self.has_attitude.then_some(self.r),
            mirrored: self.mirrored,
            false_match_probability: self.false_prob,
            matched: self.matched,
            centroid_sigma_px: self.sigma_px,
            match_radius_rad: self.radius_rad,
            hypotheses,
            elapsed,
            method: Method::Auto,
            message: None,
            hinted: false,
            verified: self.verified,
            focal_length_px: None,
            focal_sigma_px: f64::NAN,
            learned_mag_offset: None,
            k1: None,
        }
    }
}

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
                min_matches: 3,
                ..Default::default()
            },
        ];
        for c in bad {
            assert!(c.validate().is_err());
        }
        assert!(IdentifyConfig::default().validate().is_ok());
    }
}
