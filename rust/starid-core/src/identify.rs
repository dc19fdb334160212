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

use std::f64::consts::{PI, SQRT_2};
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::{Rotation3, Vector3};

use crate::attitude::{triad, wahba_from};
use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::Camera;
use crate::kvector::PairIndex;
use crate::sky::Radius;

/// Centroid noise levels (1σ per axis, pixels) tried in turn when none is given.
pub const SIGMA_LADDER_PX: [f64; 3] = [0.2, 0.7, 2.5];

/// Triangles tried at each step of the ladder but the last before moving to a looser step.
pub const TRIANGLES_PER_STEP: usize = 60;

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

/// Largest number of centroids accepted in one frame.
pub const MAX_CENTROIDS: usize = 100_000;

/// Fewest centroids a frame must have: a triangle and a confirming fourth star.
pub const MIN_CENTROIDS: usize = 4;

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
}

impl Default for IdentifyConfig {
    fn default() -> Self {
        Self {
            centroid_sigma_px: None,
            max_false_match_prob: 1e-3,
            min_matches: 4,
            max_search_stars: 24,
            max_hypotheses: 50_000,
            max_pairs_visited: 20_000_000,
            allow_mirrored: true,
            timeout: None,
        }
    }
}

impl IdentifyConfig {
    /// Check every setting.
    ///
    /// # Errors
    /// `InvalidInput` naming the first setting out of its domain.
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
}

impl Status {
    /// Lower-case name: `identified`, `no_match`, `search_limit`, `timeout`.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Identified => "identified",
            Self::NoMatch => "no_match",
            Self::SearchLimit => "search_limit",
            Self::Timeout => "timeout",
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
}

impl Identification {
    /// Whether a verified solution was found.
    pub fn is_identified(&self) -> bool {
        self.status == Status::Identified
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
        }
    }
}

/// A catalogue with its pair index: everything identification needs. Immutable and `Sync`:
/// share one across threads.
#[derive(Debug, Clone)]
pub struct Solver {
    catalog: Arc<Catalog>,
    pairs: PairIndex,
    /// Pairs among the locally bright stars; `None` when they are most of the catalogue.
    bright_pairs: Option<PairIndex>,
    build_time: Duration,
}

impl Solver {
    /// Index `catalog` for frames whose stars are at most `max_angle_rad` apart (a frame's
    /// diagonal field of view, see [`Camera::diagonal_fov_rad`]).
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    pub fn new(catalog: Arc<Catalog>, max_angle_rad: f64) -> Result<Self> {
        let t = Instant::now();
        let pairs = PairIndex::build(&catalog, max_angle_rad)?;
        // Half the width of a square field of this diagonal.
        let members = catalog.locally_bright(max_angle_rad / (2.0 * SQRT_2), BRIGHT_MAX_BRIGHTER);
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
        Ok(Self {
            catalog,
            pairs,
            bright_pairs,
            build_time: t.elapsed(),
        })
    }

    /// Index `catalog` for frames of `camera`.
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    pub fn for_camera(catalog: Arc<Catalog>, camera: &Camera) -> Result<Self> {
        Self::new(catalog, camera.diagonal_fov_rad())
    }

    /// The catalogue.
    pub fn catalog(&self) -> &Arc<Catalog> {
        &self.catalog
    }

    /// The pair index.
    pub fn pair_index(&self) -> &PairIndex {
        &self.pairs
    }

    /// The pair index over locally bright stars only, searched first when magnitudes are
    /// given (`None` when those stars are most of the catalogue).
    pub fn bright_pair_index(&self) -> Option<&PairIndex> {
        self.bright_pairs.as_ref()
    }

    /// Heap memory of both pair indexes in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.pairs.memory_bytes()
            + self
                .bright_pairs
                .as_ref()
                .map_or(0, PairIndex::memory_bytes)
    }

    /// Time it took to build the pair indexes.
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
    /// # Errors
    /// `InvalidInput` for fewer than [`MIN_CENTROIDS`] or more than [`MAX_CENTROIDS`] centroids,
    /// non-finite or duplicate centroids, centroids off the sensor, magnitudes of the wrong
    /// length or non-finite, or an invalid `config`. A frame that cannot be identified is not
    /// an error: see [`Identification::status`].
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
        let n = centroids.len();
        let obs: Vec<Vector3<f64>> = centroids
            .iter()
            .map(|c| camera.pixel_to_cam(c[0], c[1], false))
            .collect();
        let obs_mirrored: Vec<Vector3<f64>> =
            obs.iter().map(|v| Vector3::new(-v.x, v.y, v.z)).collect();
        let mut order: Vec<usize> = (0..n).collect();
        if let Some(m) = magnitudes {
            order.sort_by(|&a, &b| m[a].total_cmp(&m[b]));
        }
        let ladder: &[f64] = match &config.centroid_sigma_px {
            Some(s) => std::slice::from_ref(s),
            None => &SIGMA_LADDER_PX,
        };
        // Passes: (index, search stars, σ, triangle cap), in the order of the ladder, whose last
        // (loosest) step comes last for both indexes: its wide tolerances find coincidences and
        // verify with a wide radius, so it is the last resort. With magnitudes, each earlier
        // step first tries the brightest few stars against the locally bright stars only: cheap,
        // and it nearly always succeeds.
        let bright = self.bright_pairs.as_ref().filter(|_| magnitudes.is_some());
        let (last, early) = ladder.split_last().expect("the ladder has a step");
        let mut passes: Vec<(&PairIndex, usize, f64, usize)> = Vec::with_capacity(6);
        if let Some(b) = bright {
            passes.extend(
                early
                    .iter()
                    .map(|&s| (b, BRIGHT_SEARCH_STARS, s, usize::MAX)),
            );
        }
        passes.extend(
            early
                .iter()
                .map(|&s| (&self.pairs, config.max_search_stars, s, TRIANGLES_PER_STEP)),
        );
        if let Some(b) = bright {
            passes.push((b, BRIGHT_SEARCH_STARS, *last, usize::MAX));
        }
        passes.push((&self.pairs, config.max_search_stars, *last, usize::MAX));
        let stride = n.min(config.max_search_stars.max(BRIGHT_SEARCH_STARS));
        let mut scratch = SCRATCH.with(|c| c.take());
        scratch.angles.clear();
        scratch.angles.resize(stride * stride, f64::NAN);
        let mut search = Search {
            solver: self,
            pairs: &self.pairs,
            camera,
            config,
            obs: [&obs, &obs_mirrored],
            magnitudes,
            order: &order,
            hypotheses: 0,
            pairs_visited: 0,
            deadline: config.timeout.map(|t| start + t),
            scratch,
            stride,
        };
        let mut status = Status::NoMatch;
        for (pairs, stars, sigma_px, cap) in passes {
            search.pairs = pairs;
            match search.run(stars, sigma_px, cap) {
                Ok(Some(v)) => {
                    let hypotheses = search.hypotheses;
                    SCRATCH.with(|c| c.replace(search.scratch));
                    return Ok(v.into_identification(hypotheses, start.elapsed()));
                }
                Ok(None) => {}
                Err(SearchLimit(why)) => {
                    status = why;
                    break;
                }
            }
        }
        let hypotheses = search.hypotheses;
        SCRATCH.with(|c| c.replace(search.scratch));
        Ok(Identification::unidentified(
            status,
            n,
            hypotheses,
            start.elapsed(),
        ))
    }
}

/// One frame of a batch: its centroids and, optionally, their magnitudes.
pub type FrameRef<'a> = (&'a [[f64; 2]], Option<&'a [f64]>);

impl Solver {
    /// Identify many frames of one camera, in parallel when the `parallel` feature is on and
    /// `threads` is not 1 (`None`: all cores). Results come in input order and do not depend on
    /// the thread count.
    ///
    /// # Errors
    /// The first invalid frame's error, as for [`Solver::identify`].
    pub fn identify_batch(
        &self,
        frames: &[FrameRef<'_>],
        camera: &Camera,
        config: &IdentifyConfig,
        threads: Option<usize>,
    ) -> Result<Vec<Identification>> {
        let one = |f: &FrameRef<'_>| self.identify(f.0, f.1, camera, config);
        #[cfg(feature = "parallel")]
        if threads != Some(1) && frames.len() > 1 {
            use rayon::prelude::*;
            let run = || frames.par_iter().map(one).collect::<Result<Vec<_>>>();
            return match threads {
                None => run(),
                Some(t) => rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .map_err(|e| Error::invalid_input(format!("cannot start {t} threads: {e}")))?
                    .install(run),
            };
        }
        let _ = threads;
        frames.iter().map(one).collect()
    }
}

pub(crate) fn validate_centroids(
    centroids: &[[f64; 2]],
    magnitudes: Option<&[f64]>,
    camera: &Camera,
) -> Result<()> {
    let n = centroids.len();
    if n < MIN_CENTROIDS {
        return Err(Error::invalid_input(format!(
            "identification needs at least {MIN_CENTROIDS} centroids (a triangle and a confirming star), got {n}"
        )));
    }
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
        if c[0] < -1.0 || c[0] > w + 1.0 || c[1] < -1.0 || c[1] > h + 1.0 {
            return Err(Error::invalid_input(format!(
                "centroid {i} at ({}, {}) lies outside the {w} x {h} px sensor (x right, y down, origin top-left)",
                c[0], c[1]
            )));
        }
    }
    let mut sorted: Vec<usize> = (0..n).collect();
    sorted.sort_unstable_by(|&a, &b| {
        centroids[a][0]
            .total_cmp(&centroids[b][0])
            .then(centroids[a][1].total_cmp(&centroids[b][1]))
    });
    for pair in sorted.windows(2) {
        let (a, b) = (centroids[pair[0]], centroids[pair[1]]);
        if a == b {
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

thread_local! {
    /// Buffers kept between calls on a thread, so identification allocates almost nothing.
    static SCRATCH: std::cell::Cell<Scratch> = std::cell::Cell::new(Scratch::default());
}

/// The search must stop: the hypothesis budget or the time ran out.
struct SearchLimit(Status);

/// Reusable buffers: no allocation per hypothesis.
#[derive(Default)]
struct Scratch {
    adj_ik: Adjacency,
    triangles: Vec<[u32; 3]>,
    matches: Vec<Option<(u32, f64)>>,
    claim: Vec<(u32, u32, f64)>,
    obs_matched: Vec<Vector3<f64>>,
    ref_matched: Vec<Vector3<f64>>,
    /// The star of each centroid in the matches the attitude was last fitted to.
    fitted: Vec<Option<u32>>,
    /// Instrument minus catalogue magnitude of the matches, then their absolute deviations.
    mag_offsets: Vec<f64>,
    /// Angles between the search stars (row-major with `Search::stride`, NaN until first
    /// needed), kept across the passes: the observed directions do not change between them.
    angles: Vec<f64>,
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
    order: &'a [usize],
    hypotheses: usize,
    pairs_visited: usize,
    deadline: Option<Instant>,
    scratch: Scratch,
    /// Row length of `scratch.angles`: the most search stars of any pass.
    stride: usize,
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
}

impl Verified {
    fn into_identification(self, hypotheses: usize, elapsed: Duration) -> Identification {
        Identification {
            status: Status::Identified,
            catalog_index: self.matches.iter().map(|m| m.map(|(c, _)| c)).collect(),
            residuals_rad: self
                .matches
                .iter()
                .map(|m| m.map_or(f64::NAN, |(_, d)| d))
                .collect(),
            r_icrs_to_cam: Some(self.r),
            mirrored: self.mirrored,
            false_match_probability: self.false_prob,
            matched: self.matched,
            centroid_sigma_px: self.sigma_px,
            match_radius_rad: self.radius_rad,
            hypotheses,
            elapsed,
        }
    }
}

impl Search<'_> {
    /// One pass: Pyramid search over the brightest `stars` centroids in `self.pairs` at
    /// centroid noise `sigma_px`, at most `cap` triangles.
    fn run(
        &mut self,
        stars: usize,
        sigma_px: f64,
        cap: usize,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let mut angle = std::mem::take(&mut self.scratch.angles);
        let result = self.run_step(stars, sigma_px, cap, &mut angle);
        self.scratch.angles = angle;
        result
    }

    fn run_step(
        &mut self,
        stars: usize,
        sigma_px: f64,
        cap: usize,
        angle: &mut [f64],
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let f = self.camera.focal_length_px;
        let sigma_rad = sigma_px / f;
        let eps = 3.0 * SQRT_2 * sigma_rad + 1e-7;
        let r_confirm = 8.0 * sigma_rad + 2e-7;
        // Fourth stars needed to confirm a triangle: enough that chance alone (a centroid landing
        // within r_confirm of some star, at twice the mean sky density) is unlikely to supply them.
        let cat_len = self.solver.catalog.len() as f64;
        let p_chance = (2.0 * cat_len / (4.0 * PI) * PI * r_confirm * r_confirm).min(1.0);
        let others = self.order.len() - 3;
        let confirmations = (1..=others)
            .find(|&c| binomial_tail(others, c, p_chance) <= CONFIRM_CHANCE)
            .unwrap_or(others)
            .max(1);
        let max_angle = self.pairs.max_angle_rad() - eps;
        let stride = self.stride;
        let s = stars.min(stride);
        let obs = self.obs[0];
        let order: &[usize] = self.order;
        let search = &order[..s];
        // Angles are computed when a triangle first needs them (most frames stop after a few
        // triangles, long before all s² pairs are visited).
        let mut pair_angle = |a: usize, b: usize| -> f64 {
            let t = angle[a * stride + b];
            if !t.is_nan() {
                return t;
            }
            let t = crate::geometry::angle_between(&obs[search[a]], &obs[search[b]]);
            angle[a * stride + b] = t;
            angle[b * stride + a] = t;
            t
        };
        let mut tried = 0usize;
        let mut best: Option<Verified> = None;
        let mut stop_after = usize::MAX;
        // Mortari's Pyramid order: vary all three stars quickly so a false star cannot block.
        for dj in 1..s.saturating_sub(1) {
            for dk in 1..s - dj {
                for a in 0..s - dj - dk {
                    let (b, c) = (a + dj, a + dj + dk);
                    let (t_ij, t_ik, t_jk) = (pair_angle(a, b), pair_angle(a, c), pair_angle(b, c));
                    let (lo, hi) = (t_ij.min(t_ik).min(t_jk), t_ij.max(t_ik).max(t_jk));
                    if hi > max_angle || lo < 2.0 * eps {
                        continue;
                    }
                    let (i, j, k) = (search[a], search[b], search[c]);
                    let tp_obs = obs[i].dot(&obs[j].cross(&obs[k]));
                    // The handedness must survive the noise, or the triangle cannot tell a mirrored frame.
                    if tp_obs.abs() < 3.0 * sigma_rad * (t_ij + t_ik + t_jk) {
                        continue;
                    }
                    if tried >= cap.min(stop_after) {
                        return Ok(self.accept(best));
                    }
                    let why = if self.pairs_visited >= self.config.max_pairs_visited {
                        Some(Status::SearchLimit)
                    } else if self.deadline.is_some_and(|d| Instant::now() >= d) {
                        Some(Status::Timeout)
                    } else {
                        None
                    };
                    if let Some(why) = why {
                        return self
                            .accept(best)
                            .map_or(Err(SearchLimit(why)), |v| Ok(Some(v)));
                    }
                    tried += 1;
                    let found = match self.try_triangle(
                        [i, j, k],
                        [t_ij, t_ik, t_jk],
                        tp_obs,
                        eps,
                        (r_confirm, confirmations),
                        sigma_rad,
                    ) {
                        Ok(found) => found,
                        Err(limit) => return self.accept(best).map_or(Err(limit), |v| Ok(Some(v))),
                    };
                    if let Some(v) = found {
                        if v.tail * (self.hypotheses as f64) <= STRONG_FALSE_MATCH_PROB {
                            return Ok(self.accept(Some(v)));
                        }
                        // A weak solution: look a little further for a stronger one.
                        stop_after = stop_after.min(tried + TRIANGLES_AFTER_WEAK);
                        if best.as_ref().is_none_or(|b| v.tail < b.tail) {
                            best = Some(v);
                        }
                    }
                }
            }
        }
        Ok(self.accept(best))
    }

    /// The solution, if its bound over every hypothesis tested so far passes.
    fn accept(&self, v: Option<Verified>) -> Option<Verified> {
        let mut v = v?;
        v.false_prob = (self.hypotheses.max(1) as f64 * v.tail).min(1.0);
        (v.false_prob <= self.config.max_false_match_prob).then_some(v)
    }

    fn try_triangle(
        &mut self,
        [i, j, k]: [usize; 3],
        [t_ij, t_ik, t_jk]: [f64; 3],
        tp_obs: f64,
        eps: f64,
        (r_confirm, confirmations): (f64, usize),
        sigma_rad: f64,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let mut triangles = std::mem::take(&mut self.scratch.triangles);
        self.catalogue_triangles(t_ij, t_ik, t_jk, eps, &mut triangles);
        let cat = self.solver.catalog.vectors();
        let mut result = Ok(None);
        for &[ca, cb, cc] in &triangles {
            let (va, vb, vc) = (&cat[ca as usize], &cat[cb as usize], &cat[cc as usize]);
            let mirrored = (va.dot(&vb.cross(vc)) > 0.0) != (tp_obs > 0.0);
            if mirrored && !self.config.allow_mirrored {
                continue;
            }
            if self.hypotheses >= self.config.max_hypotheses {
                result = Err(SearchLimit(Status::SearchLimit));
                break;
            }
            if self.hypotheses % 64 == 0 && self.deadline.is_some_and(|d| Instant::now() >= d) {
                result = Err(SearchLimit(Status::Timeout));
                break;
            }
            self.hypotheses += 1;
            let obs = self.obs[usize::from(mirrored)];
            let Some(r) = triad(&obs[i], &obs[j], va, vb)
                .and_then(|start| wahba_from(&[obs[i], obs[j], obs[k]], &[*va, *vb, *vc], &start))
            else {
                continue;
            };
            if !self.confirmed(
                &r,
                obs,
                [i, j, k],
                [ca, cb, cc],
                (r_confirm, confirmations),
                sigma_rad,
            ) {
                continue;
            }
            if let Some(v) = self.verify(r, mirrored, r_confirm, sigma_rad) {
                result = Ok(Some(v));
                break;
            }
        }
        self.scratch.triangles = triangles;
        result
    }

    /// Catalogue triangles `(a, b, c)` with `|a b| ≈ t_ij`, `|a c| ≈ t_ik`, `|b c| ≈ t_jk`.
    fn catalogue_triangles(
        &mut self,
        t_ij: f64,
        t_ik: f64,
        t_jk: f64,
        eps: f64,
        out: &mut Vec<[u32; 3]>,
    ) {
        out.clear();
        let idx = self.pairs;
        let (r_ij, r_ik, r_jk) = (
            idx.range(t_ij - eps, t_ij + eps),
            idx.range(t_ik - eps, t_ik + eps),
            idx.range(t_jk - eps, t_jk + eps),
        );
        self.pairs_visited += r_ij.len() + r_ik.len() + r_jk.len();
        if r_ij.is_empty() || r_ik.is_empty() || r_jk.is_empty() {
            return;
        }
        // Walk the sparser of the two sides at one vertex, look the other up through an adjacency
        // list, and check the third side with one dot product against its cosine bounds: one
        // adjacency fill per triangle instead of two, and no list walk for the closing side.
        let n_cat = self.solver.catalog.len();
        let cat = self.solver.catalog.vectors();
        // Sides as (range, vertex pair) with vertices 0 = i, 1 = j, 2 = k.
        let sides = [(r_ij, (0usize, 1usize)), (r_ik, (0, 2)), (r_jk, (1, 2))];
        let closing = (0..3)
            .max_by_key(|&e| sides[e].0.len())
            .expect("three sides");
        let (mut walk, mut look) = match closing {
            0 => (sides[1].clone(), sides[2].clone()),
            1 => (sides[0].clone(), sides[2].clone()),
            _ => (sides[0].clone(), sides[1].clone()),
        };
        if walk.0.len() > look.0.len() {
            std::mem::swap(&mut walk, &mut look);
        }
        // The shared vertex of the walked and looked-up sides, and their other ends.
        let (w0, w1) = walk.1;
        let (l0, l1) = look.1;
        let shared = if w0 == l0 || w0 == l1 { w0 } else { w1 };
        let walk_other = if w0 == shared { w1 } else { w0 };
        let look_other = if l0 == shared { l1 } else { l0 };
        let t_close = [t_ij, t_ik, t_jk][closing];
        let (cos_hi, cos_lo) = ((t_close - eps).max(0.0).cos(), (t_close + eps).cos());
        self.scratch.adj_ik.fill(idx.pairs(look.0.clone()), n_cat);
        let adj = &self.scratch.adj_ik;
        for [p, q] in idx.pairs(walk.0) {
            for (x, y) in [(p, q), (q, p)] {
                let vy = &cat[y as usize];
                for z in adj.partners(x) {
                    let c = vy.dot(&cat[z as usize]);
                    if c <= cos_hi && c >= cos_lo && z != y {
                        let mut t = [0u32; 3];
                        t[shared] = x;
                        t[walk_other] = y;
                        t[look_other] = z;
                        out.push(t);
                    }
                }
            }
        }
    }

    /// Whether at least `needed` other centroids land on catalogue stars under attitude `r`
    /// (the Pyramid's fourth star; more of them in crowded frames). Stops as soon as the answer
    /// is known either way.
    fn confirmed(
        &self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        used: [usize; 3],
        used_cat: [u32; 3],
        (radius, needed): (f64, usize),
        sigma_rad: f64,
    ) -> bool {
        let catalog = &*self.solver.catalog;
        let radius = Radius::new(radius);
        let mut remaining = self.order.len() - 3;
        let mut found = 0;
        for &o in self.order.iter().filter(|o| !used.contains(o)) {
            if found + remaining < needed {
                return false;
            }
            remaining -= 1;
            let w = r.inverse_transform_vector(&obs[o]);
            if let Some((star, _)) = unambiguous_nearest(catalog, &w, radius, sigma_rad) {
                if !used_cat.contains(&star) {
                    found += 1;
                    if found >= needed {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Match all centroids, re-solve the attitude, adapt the radius to the residuals and bound
    /// the false-match probability. `None` if the hypothesis does not verify.
    fn verify(
        &mut self,
        r0: Rotation3<f64>,
        mirrored: bool,
        r_confirm: f64,
        sigma_rad: f64,
    ) -> Option<Verified> {
        let obs = self.obs[usize::from(mirrored)];
        let n = obs.len();
        let f = self.camera.focal_length_px;
        let mut r = r0;
        let mut radius = r_confirm;
        let mut sigma = sigma_rad;
        // Match and re-solve; then the radius follows the noise estimated from the residuals
        // (5σ, never below half the ladder's σ, so that four stars cannot talk it down to nothing).
        // When a pass matches exactly the stars the attitude was fitted to, the attitude, the
        // noise and the radius would all come out the same: a fixed point, and its matches are final.
        self.scratch.fitted.clear();
        let mut matched = 0;
        let mut fixed_point = false;
        for _ in 0..4 {
            matched = self.match_all(&r, obs, radius, sigma);
            if matched < 3 {
                return None;
            }
            let s = &mut self.scratch;
            if s.matches
                .iter()
                .map(|m| m.map(|(c, _)| c))
                .eq(s.fitted.iter().copied())
            {
                fixed_point = true;
                break;
            }
            s.fitted.clear();
            s.fitted.extend(s.matches.iter().map(|m| m.map(|(c, _)| c)));
            let (o_m, r_m) = (&s.obs_matched, &s.ref_matched);
            r = wahba_from(o_m, r_m, &r)?;
            let sum_sq: f64 = o_m
                .iter()
                .zip(r_m)
                .map(|(o, c)| (o - r * c).norm_squared())
                .sum();
            // E|d|² = 2σ² per star, less the three attitude degrees of freedom.
            let dof = (2 * matched).saturating_sub(3).max(1) as f64;
            sigma = (sum_sq / dof).sqrt().max(0.5 * sigma_rad);
            // Never below the step's own radius: residuals of a (possibly false) fit must not
            // talk the radius down, or the false-match bound would be computed after the fact.
            let new_radius = (4.0 * sigma).max(MATCH_RADIUS_SIGMAS * sigma_rad) + 1e-7;
            let settled = (new_radius - radius).abs() <= 0.05 * radius;
            radius = new_radius;
            if settled {
                break;
            }
        }
        if !fixed_point {
            matched = self.match_all(&r, obs, radius, sigma);
        }
        if self.drop_too_bright() > 0 {
            // Fewer matches: refit, and the bound below only grows.
            matched = self.collect_matched(obs);
            if matched < 3 {
                return None;
            }
            r = wahba_from(&self.scratch.obs_matched, &self.scratch.ref_matched, &r)?;
            let cat = self.solver.catalog.vectors();
            for (o, m) in self.scratch.matches.iter_mut().enumerate() {
                if let Some((star, d)) = m {
                    *d = r
                        .inverse_transform_vector(&obs[o])
                        .cross(&cat[*star as usize])
                        .norm();
                }
            }
        }
        if matched < self.config.min_matches {
            return None;
        }
        let tail = self.match_tail(&r, n, matched, radius);
        if self.hypotheses as f64 * tail > self.config.max_false_match_prob {
            return None;
        }
        Some(Verified {
            r,
            mirrored,
            matches: self.scratch.matches.clone(),
            matched,
            sigma_px: sigma * f,
            radius_rad: radius,
            tail,
            false_prob: f64::NAN,
        })
    }

    /// Nearest-star match of every centroid under `r`, each catalogue star claimed at most once.
    /// Fills `scratch.matches` (per centroid) and the matched vector lists; returns the count.
    fn match_all(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        radius: f64,
        sigma_rad: f64,
    ) -> usize {
        let catalog = &*self.solver.catalog;
        let radius = Radius::new(radius);
        let s = &mut self.scratch;
        s.matches.clear();
        s.claim.clear();
        for (o, v) in obs.iter().enumerate() {
            let w = r.inverse_transform_vector(v);
            let m = unambiguous_nearest(catalog, &w, radius, sigma_rad);
            if let Some((star, d)) = m {
                s.claim.push((star, o as u32, d));
            }
            s.matches.push(m);
        }
        // A catalogue star claimed by two centroids is ambiguous: neither gets it.
        s.claim.sort_unstable_by_key(|c| c.0);
        for w in 1..s.claim.len() {
            if s.claim[w].0 == s.claim[w - 1].0 {
                s.matches[s.claim[w].1 as usize] = None;
                s.matches[s.claim[w - 1].1 as usize] = None;
            }
        }
        self.collect_matched(obs)
    }

    /// Fill the matched vector lists from `scratch.matches`; returns their length.
    fn collect_matched(&mut self, obs: &[Vector3<f64>]) -> usize {
        let cat = self.solver.catalog.vectors();
        let s = &mut self.scratch;
        s.obs_matched.clear();
        s.ref_matched.clear();
        for (o, m) in s.matches.iter().enumerate() {
            if let Some((star, _)) = m {
                s.obs_matched.push(obs[o]);
                s.ref_matched.push(cat[*star as usize]);
            }
        }
        s.obs_matched.len()
    }

    /// With magnitudes, unmatch centroids far brighter than their catalogue star (see
    /// [`MAG_BRIGHTER_LIMIT`]); returns how many.
    fn drop_too_bright(&mut self) -> usize {
        let Some(mags) = self.magnitudes else {
            return 0;
        };
        let cat_mag = self.solver.catalog.mag();
        let s = &mut self.scratch;
        s.mag_offsets.clear();
        s.mag_offsets.extend(
            s.matches
                .iter()
                .zip(mags)
                .filter_map(|(m, &obs_mag)| m.map(|(star, _)| obs_mag - cat_mag[star as usize])),
        );
        let n = s.mag_offsets.len();
        if n < MAG_CHECK_MIN_MATCHES {
            return 0;
        }
        let median = |v: &mut [f64]| -> f64 {
            v.sort_unstable_by(f64::total_cmp);
            let k = v.len();
            0.5 * (v[(k - 1) / 2] + v[k / 2])
        };
        let offset = median(&mut s.mag_offsets);
        for d in &mut s.mag_offsets {
            *d = (*d - offset).abs();
        }
        let spread = 1.4826 * median(&mut s.mag_offsets);
        let limit = MAG_BRIGHTER_LIMIT.max(MAG_OUTLIER_SIGMAS * spread);
        let mut dropped = 0;
        for (m, &obs_mag) in s.matches.iter_mut().zip(mags) {
            if let Some((star, _)) = *m {
                if obs_mag - cat_mag[star as usize] < offset - limit {
                    *m = None;
                    dropped += 1;
                }
            }
        }
        dropped
    }

    /// `P(Bin(n − 3, p) ≥ m − 3)` with `p` from the local catalogue density.
    fn match_tail(&self, r: &Rotation3<f64>, n: usize, matched: usize, radius: f64) -> f64 {
        let half_diag = 0.5 * self.camera.diagonal_fov_rad();
        let boresight = r.inverse_transform_vector(&Vector3::z());
        let in_field = self.solver.catalog.count_in_cone(&boresight, half_diag);
        let cone_sr = 2.0 * PI * (1.0 - half_diag.cos());
        let density = in_field.max(1) as f64 / cone_sr;
        let p = (density * PI * radius * radius).min(1.0);
        binomial_tail(n.saturating_sub(3), matched.saturating_sub(3), p)
    }
}

/// Log-likelihood ratio the nearest catalogue star must win by over the second nearest for a
/// match to count (ln 1000): an unresolved double is left unmatched rather than guessed.
const AMBIGUITY_LOG_ODDS: f64 = 6.907755278982137;

/// The nearest catalogue star to `w` within `radius`, unless a second star is nearly as likely
/// (see [`AMBIGUITY_LOG_ODDS`]): an ambiguous match is no match.
fn unambiguous_nearest(
    catalog: &Catalog,
    w: &Vector3<f64>,
    radius: Radius,
    sigma_rad: f64,
) -> Option<(u32, f64)> {
    let cat = catalog.vectors();
    let (best, second) = catalog.nearest_two(w, radius);
    let (star, _) = best?;
    // Match radii are far below a degree: the sine of the angle (|w × c|, no libm call) is the
    // angle to better than 1e-5 relative there.
    let d1 = w.cross(&cat[star as usize]).norm();
    if let Some((s2, _)) = second {
        let d2 = w.cross(&cat[s2 as usize]).norm();
        // Decisive only when the nearer star is AMBIGUITY_LOG_ODDS times likelier under
        // Gaussian noise: (d2² − d1²) / 2σ² ≥ ln(odds).
        if d2 * d2 - d1 * d1 < 2.0 * AMBIGUITY_LOG_ODDS * sigma_rad * sigma_rad {
            return None;
        }
    }
    Some((star, d1))
}

const NONE: u32 = u32::MAX;

/// Adjacency lists of a set of catalogue pairs (both orientations) as linked lists indexed by
/// catalogue star: O(1) to look up, O(pairs) to fill and to reset, no sorting.
#[derive(Default)]
struct Adjacency {
    head: Vec<u32>,
    next: Vec<u32>,
    partner: Vec<u32>,
    touched: Vec<u32>,
}

impl Adjacency {
    fn fill(&mut self, pairs: impl Iterator<Item = [u32; 2]>, n_cat: usize) {
        for &s in &self.touched {
            self.head[s as usize] = NONE;
        }
        if self.head.len() != n_cat {
            self.head.clear();
            self.head.resize(n_cat, NONE);
        }
        self.touched.clear();
        self.next.clear();
        self.partner.clear();
        for [p, q] in pairs {
            self.push(p, q);
            self.push(q, p);
        }
    }

    #[inline]
    fn push(&mut self, star: u32, partner: u32) {
        let h = &mut self.head[star as usize];
        if *h == NONE {
            self.touched.push(star);
        }
        self.next.push(*h);
        self.partner.push(partner);
        *h = (self.partner.len() - 1) as u32;
    }

    #[inline]
    fn partners(&self, star: u32) -> impl Iterator<Item = u32> + '_ {
        let mut at = self.head[star as usize];
        std::iter::from_fn(move || {
            (at != NONE).then(|| {
                let p = self.partner[at as usize];
                at = self.next[at as usize];
                p
            })
        })
    }
}

/// `P(X ≥ m)` for `X ~ Binomial(n, p)`, summed in log space.
pub fn binomial_tail(n: usize, m: usize, p: f64) -> f64 {
    if m == 0 {
        return 1.0;
    }
    if m > n || p <= 0.0 {
        return 0.0;
    }
    if p >= 1.0 {
        return 1.0;
    }
    let (nf, mf) = (n as f64, m as f64);
    // Summing upwards from m loses everything to underflow when m lies far below the mean (the
    // first terms are ~0 while the mass sits near n·p): there, use the complement,
    // P(X ≥ m) = 1 − P(X ≤ m − 1) = 1 − P(n − X ≥ n − m + 1), n − X ~ Bin(n, 1 − p).
    if mf <= nf * p {
        return (1.0 - binomial_tail(n, n - m + 1, 1.0 - p)).clamp(0.0, 1.0);
    }
    let ln_choose: f64 = (1..=m)
        .map(|i| ((nf - mf + i as f64) / i as f64).ln())
        .sum();
    let mut term = (ln_choose + mf * p.ln() + (nf - mf) * (-p).ln_1p()).exp();
    let ratio = p / (1.0 - p);
    let mut sum = 0.0;
    for k in m..=n {
        sum += term;
        let next = term * (nf - k as f64) / (k as f64 + 1.0) * ratio;
        if next < sum * 1e-17 && (nf - k as f64) / (k as f64 + 1.0) * ratio < 1.0 {
            break;
        }
        term = next;
    }
    sum.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

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
