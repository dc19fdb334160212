//! Tracking a sequence of frames: each frame is identified from the attitude the last ones
//! predict (hinted identification), falling back to lost in space when the hint fails.
//!
//! The tracker keeps the last attitude and time and, from the last two solutions, the body
//! rate (a rotation vector in the camera frame, radians per second). A frame at time `t` is
//! searched around the attitude propagated at that rate, within an uncertainty that grows with
//! the time since the last solution and with how much the rate has been changing. Frames the
//! hint cannot explain are identified lost in space (which also catches a wrong prediction:
//! no wrong hint can verify a wrong identification); frames nothing identifies leave the
//! prediction coasting at the last rate.
//!
//! A tracking solution's names then pass rules that need the frames before, or evidence a
//! single verification does not weigh, and that only ever unname: stars unseen by the last
//! solutions, or of a magnitude the camera rarely detects, wait for a second frame in a row
//! ([`TrackerConfig::confirm_unseen_frames`]); a star that the solution fitted without its spot
//! places off the sensor keeps no spot far from it ([`OFF_SENSOR_SIGMAS`]); and with
//! magnitudes (or the brightness order alone), a spot that fits a neighbouring star (or a
//! neighbouring spot its star) decisively better by brightness is not named
//! ([`MAG_RIVAL_LOG_ODDS`], [`ORDER_NEIGHBOURS`]).

use nalgebra::{Rotation3, Vector3};

use crate::error::{Error, Result};
use crate::geometry::Camera;
use crate::identify::{
    AttitudeHint, HintFallback, Identification, IdentifyConfig, Solver, MAG_OUTLIER_SIGMAS,
};

mod rules;

/// Longest span of the solutions the rate is measured across, seconds.
pub const RATE_BASELINE_S: f64 = 1.0;

/// Most solutions kept for the rate.
const RATE_HISTORY: usize = 16;

/// How a frame was identified.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrackMode {
    /// From the predicted attitude (hinted search).
    Tracking,
    /// Lost in space (no lock, or the hint failed).
    LostInSpace,
}

impl TrackMode {
    /// `"tracking"` or `"lost_in_space"`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::tracking::TrackMode::Tracking.as_str(), "tracking");
    /// ```
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Tracking => "tracking",
            Self::LostInSpace => "lost_in_space",
        }
    }
}

/// Settings of a [`Tracker`].
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerConfig {
    /// The fastest the camera may turn, radians per second: bounds the uncertainty of a
    /// prediction without a rate estimate.
    pub max_rate_rad_s: f64,
    /// Smallest search uncertainty, radians (the attitude's own error and jitter).
    pub min_uncertainty_rad: f64,
    /// Identify lost in space when the hint fails (otherwise such frames are unidentified).
    pub fallback: bool,
    /// In tracking mode, a star named for the first time although the last solution had it
    /// well inside the sensor (at least [`CONFIRM_MARGIN_PX`] from the edges) and did not name
    /// it stays unnamed until a second frame in a row names it: a false spot (a hot pixel, a
    /// satellite) on a star too faint to be seen, which no position test can tell from it, does
    /// not return in the next frame; a real star does. Stars entering the field are named at
    /// once. Off by default: on 2 450 simulated frames with 0–40 false spots
    /// (`examples/tracking.rs -- 50 500`) it leaves 2 wrong ids, as the default rules
    /// do, and names 0.46 % fewer of the real stars (96.52 % against 96.98 %); with neither rule,
    /// 9 wrong ids and 97.01 %.
    pub confirm_new_stars: bool,
    /// In tracking mode, a star that the last this many solutions in a row had well inside the
    /// sensor (at least [`CONFIRM_MARGIN_PX`] from the edges) without naming it stays unnamed
    /// until two frames in a row match it: a star too faint for the camera, which a false spot
    /// lands on by chance, is known by the frames that did not see it, and a false spot does not
    /// land on it again in the next frame. A star that no solution named since it came well
    /// inside is held so after [`CONFIRM_NEVER_NAMED_FRAMES`] of them; stars that entered the
    /// field lately, or that were named in the last of those solutions, are named at once.
    /// A star in a magnitude range the camera rarely detects (learned from the solutions: see
    /// [`RARELY_SEEN_FRACTION`]) is held in the same way unless the last solution named it, even
    /// before any solution had it unseen. `None` turns it off; ignored when `confirm_new_stars`
    /// is on. Default [`CONFIRM_UNSEEN_FRAMES`].
    pub confirm_unseen_frames: Option<u32>,
}

/// Default of [`TrackerConfig::confirm_unseen_frames`]. Alone, on 9 950 simulated frames
/// (10 Hz, 0.1–5°/s, 0–40 false spots with catalogue-like magnitudes; `examples/tracking.rs`) it
/// cut wrong ids from 31 to 11 and cost 13 of 176 974 real stars named; on two further sets of
/// sequences 15 → 3 and 23 → 13 (12 and 26 real stars). Shorter streaks caught a few more
/// (3 frames: 8 wrong ids) at several times the cost in real stars, and would hold back real
/// stars that a camera detects only now and then near its limit. With
/// [`CONFIRM_NEVER_NAMED_FRAMES`] and the 4 px [`CONFIRM_MARGIN_PX`] the three sets give 14
/// wrong ids instead of 66, for 78 of 464 470 real stars.
pub const CONFIRM_UNSEEN_FRAMES: u32 = 10;

/// With [`TrackerConfig::confirm_unseen_frames`] on, the solutions in a row after which a star
/// that none of them named since it came well inside the sensor is held in the same way (or
/// `confirm_unseen_frames`, if fewer). At 5°/s a star crosses a 12° field in 24 frames, so the
/// longer streak leaves a faint star open to false spots for the first 10 of them; a real star
/// near the camera's limit that entered unseen is named from its first two frames in a row,
/// and once named, only the longer streak holds it again. On the sequences of
/// `examples/tracking.rs` (three sets, 29 850 frames; 8 px edge margin) it cut wrong ids from 25 to 16 and cost 27
/// of 464 470 real stars named; 2 frames: the same wrong ids at a higher cost, 5: 19.
pub const CONFIRM_NEVER_NAMED_FRAMES: u32 = 3;

/// Distance from the sensor's edges within which a star of the last solution's field counts
/// as entering the field, and is never counted unseen (see
/// [`TrackerConfig::confirm_new_stars`], [`TrackerConfig::confirm_unseen_frames`]): an
/// extractor's window a few pixels wide may miss a star closer to the edge. Against 8 px, on
/// the three sets of sequences of [`CONFIRM_NEVER_NAMED_FRAMES`] 4 px gave 14 wrong
/// ids instead of 16 for 2 fewer real stars named (2 px: 13, for 6), false spots on faint stars
/// that sat between 4 and 8 px from an edge.
pub const CONFIRM_MARGIN_PX: f64 = 4.0;

/// In tracking mode, a name is checked again when the centroid noise along the image motion
/// (the smear of a turning camera) is at least this many times that across it, measured from
/// the named spots' residuals: the verification's ambiguity tests take the noise as the same
/// in every direction, which along a long smear it is not.
pub const SMEAR_MIN_ANISOTROPY: f64 = 1.3;

/// On the brightness order alone, a named spot whose magnitude from the order (see
/// [`ORDER_NEIGHBOURS`]) is more than this many magnitudes (or 5 of the order's spreads) brighter
/// than its star is not named: the verification's check of spots far brighter than their star
/// ([`crate::identify::MAG_BRIGHTER_LIMIT`], 1 mag), which only real magnitudes get there. The
/// order's magnitudes are coarser: on the five sets of sequences of `examples/tracking.rs` a
/// limit of 1 mag cost 195 real stars named, 1.5 mag 17, and 2 mag none, for the one false spot
/// (3 mag brighter than its star) each of them caught.
pub const ORDER_BRIGHTER_LIMIT: f64 = 2.0;

/// In tracking mode, a named spot more than this many magnitudes (or 5 spreads) fainter than its
/// star is not named when at least [`FAINTER_INVERSIONS_MIN`] named spots of stars fainter than
/// that star by half as much are brighter than it. A spot too faint for its star and out of the
/// frame's brightness order is a false spot on a star whose own spot is missing (just off the
/// edge, say). A saturated star reads fainter than its catalogue magnitude but still brighter
/// than the spots of fainter stars, so it keeps its name (the verification's magnitude check is
/// one-sided for it, see [`crate::identify::MAG_BRIGHTER_LIMIT`]). On the brightness order alone
/// the spot's magnitude is the one its place implies (see [`ORDER_NEIGHBOURS`]), and the spots
/// brighter than it are those before it in the order. On the five sets of sequences of
/// `examples/tracking.rs` it took one wrong id each way (seed 300) and no real star.
pub const MAG_FAINTER_LIMIT: f64 = 1.0;

/// See [`MAG_FAINTER_LIMIT`].
pub const FAINTER_INVERSIONS_MIN: usize = 2;

/// Fewest named spots (this solution's and the last ones') from which the two spreads are
/// measured.
const SMEAR_MIN_NAMED: usize = 6;

/// Most named spots' residuals kept for the two spreads: a dozen frames' worth.
const SMEAR_HISTORY: usize = 256;

/// Median of a χ² variable with one degree of freedom.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_8;

/// With [`TrackerConfig::confirm_unseen_frames`] on, a star in a magnitude range the camera has
/// detected in fewer than this fraction of the solutions that had such stars well inside the
/// sensor is held, as an unseen one is, unless the last solution named it: a false spot on a
/// star past the camera's limit, which the first frames after it enters the field cannot yet
/// call unseen. The tracker learns the fractions from its solutions, in
/// [`COMPLETENESS_BIN_MAG`] bins of catalogue magnitude.
pub const RARELY_SEEN_FRACTION: f64 = 0.2;

/// In tracking mode, a spot named after a star whose magnitude (after the frame's zero point)
/// fits another catalogue star within the match radius, one the camera detects, this many
/// natural-log units likelier (under Gaussian scatter of the frame's spread) is not named: the
/// two stars of a close pair swapped by noise, or a false spot beside a brighter star.
pub const MAG_RIVAL_LOG_ODDS: f64 = 2.995_732_273_553_991;

/// How far from a spot, in match radii, the rival test ([`MAG_RIVAL_LOG_ODDS`]) looks for rival
/// stars: a smeared frame's noise along its motion carries spots past the radius.
pub const MAG_RIVAL_REACH: f64 = 2.0;

/// In tracking mode, a star that the solution fitted without its spot places off the sensor is
/// not named when its spot lies more than this many times the frame's centroid noise from it:
/// off the sensor, a star's own spot lies inside only by its noise, near the edge, and the star's
/// own spot is missing more often than not, so that a false spot near the edge takes its place.
pub const OFF_SENSOR_SIGMAS: f64 = 2.0;

/// Without magnitudes, the named spots on either side of a spot in the brightness order whose
/// catalogue magnitudes give it one for the rival test ([`MAG_RIVAL_LOG_ODDS`]).
pub const ORDER_NEIGHBOURS: usize = 2;

/// Fewest named spots whose magnitudes from the order give the rival test a spread.
const ORDER_SPREAD_MIN_NAMED: usize = 5;

/// Fewest kept zero points whose median spread the rival test ([`MAG_RIVAL_LOG_ODDS`]) uses
/// instead of the frame's own.
const TYPICAL_SPREAD_MIN_FRAMES: usize = 3;

/// Smallest magnitude spread the rival test ([`MAG_RIVAL_LOG_ODDS`]) assumes, mag.
pub const MAG_RIVAL_MIN_SPREAD: f64 = 0.05;

/// Stars a magnitude bin must have counted before [`RARELY_SEEN_FRACTION`] applies to it.
pub const RARELY_SEEN_MIN_COUNT: u32 = 50;

/// Width of the tracker's catalogue magnitude bins, mag.
pub const COMPLETENESS_BIN_MAG: f64 = 0.1;

/// The bins cover catalogue magnitudes from this one (brighter stars share the first bin) up
/// [`COMPLETENESS_BINS`] bins (fainter ones share the last).
const COMPLETENESS_MAG_MIN: f64 = -2.0;
const COMPLETENESS_BINS: usize = 150;

/// A bin's counts are halved when it has counted this many stars: recent frames weigh more.
const COMPLETENESS_COUNT_CAP: u32 = 4096;

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            max_rate_rad_s: 5f64.to_radians(),
            min_uncertainty_rad: 0.05f64.to_radians(),
            fallback: true,
            confirm_new_stars: false,
            confirm_unseen_frames: Some(CONFIRM_UNSEEN_FRAMES),
        }
    }
}

/// One frame's outcome.
#[derive(Debug, Clone)]
pub struct TrackStep {
    /// The identification.
    pub identification: Identification,
    /// How it was found (meaningful when identified).
    pub mode: TrackMode,
    /// The predicted attitude the frame was searched around (`None` without lock).
    pub predicted: Option<Rotation3<f64>>,
    /// The hint's uncertainty, radians (NaN without lock).
    pub uncertainty_rad: f64,
    /// The body rate after this frame (camera frame, rad/s), when estimated.
    pub rate_rad_s: Option<Vector3<f64>>,
}

/// A star tracker's identification of a sequence. Not `Sync`: one per sequence.
#[derive(Debug, Clone)]
pub struct Tracker {
    config: TrackerConfig,
    identify: IdentifyConfig,
    /// Last solution: time, attitude, handedness.
    last: Option<(f64, Rotation3<f64>, bool)>,
    /// Recent solutions (time, attitude), oldest first: the rate is measured across them, not
    /// between neighbours, whose attitude errors (roll above all) a short baseline amplifies.
    history: std::collections::VecDeque<(f64, Rotation3<f64>)>,
    /// Body rate from the last two solutions, and the change between the last two estimates.
    rate: Option<Vector3<f64>>,
    rate_change: f64,
    /// Catalogue stars the last solution named (before confirmation), sorted.
    named: Vec<u32>,
    /// Catalogue stars the last solutions had well inside the sensor without naming them:
    /// (star, solutions in a row, whether none named it since it came well inside), sorted by
    /// star (see [`TrackerConfig::confirm_unseen_frames`]).
    unseen: Vec<(u32, u32, bool)>,
    /// Stars the last solution named, after the holds, sorted.
    confirmed: Vec<u32>,
    /// Stars matched in the last frame but held back for a second frame, sorted.
    held: Vec<u32>,
    /// The focal length (and distortion) a lost-in-space solution's focal check found for the
    /// camera given: the frames that follow are identified with it (see
    /// [`crate::Identification::focal_length_px`]). Kept across `reset`: it is the camera's.
    focal: Option<FoundCamera>,
    /// The magnitude zero points (and their spreads) the last solutions measured
    /// ([`Identification::zero_point`]), oldest first: with [`IdentifyConfig::learn_zero_point`]
    /// the frames that follow are searched with the one they agree on, as a batch's are, where
    /// the configured `mag_offset` is `None` or disagrees. Kept across `reset`: it is the camera's.
    zero_points: std::collections::VecDeque<(f64, f64)>,
    /// The residual samples ([`Identification::noise_sample_px`]) of the last solutions of
    /// many matches, oldest first, at most [`NOISE_HISTORY`]: with
    /// [`IdentifyConfig::learn_noise`] and no stated noise, a frame nothing identifies is
    /// searched again with the noise they agree on, where it is tighter than the ladder's first
    /// step (as a batch's failed frames are). Kept across `reset`: it is the camera's.
    noises: std::collections::VecDeque<Vec<f64>>,
    /// Per catalogue magnitude bin ([`COMPLETENESS_BIN_MAG`]), the stars the solutions had well
    /// inside the sensor: how many were matched, and how many in all. Kept across `reset`: it
    /// is the camera's.
    completeness: Vec<[u32; 2]>,
    /// The last tracking solutions' named spots' residuals, squared, along the image motion and
    /// across it (pixels²), oldest first, at most [`SMEAR_HISTORY`]: the two spreads
    /// [`Tracker::smear_rivals`] tests names with. Cleared with the rate.
    smear: std::collections::VecDeque<[f64; 2]>,
}

/// A named spot as [`Tracker::smear_rivals`] weighs it: its index, its pixel and its star's
/// (unmirrored image), and the image motion's unit direction there.
#[derive(Debug, Clone, Copy)]
struct SmearedSpot {
    spot: usize,
    at: [f64; 2],
    star_at: [f64; 2],
    dir: [f64; 2],
}

/// What a focal check found of the camera a [`Tracker`] was given.
#[derive(Debug, Clone, Copy)]
struct FoundCamera {
    /// The given camera's focal length and distortion (px, `k1`): a different camera starts over.
    given_focal_px: f64,
    given_k1: f64,
    /// The focal length found and its 1σ, px.
    focal_px: f64,
    sigma_px: f64,
    /// The distortion found, when it was corrected.
    k1: Option<f64>,
}

/// Most zero points a [`Tracker`] keeps.
const ZERO_POINT_HISTORY: usize = 16;

/// Solutions whose residuals a tracker learns the centroid noise from (the last ones).
const NOISE_HISTORY: usize = 8;

impl Tracker {
    /// A tracker with no lock yet.
    ///
    /// # Errors
    /// `InvalidInput` for a non-positive or non-finite rate bound or uncertainty, or invalid
    /// identification settings.
    ///
    /// # Example
    /// ```
    /// use starid_core::tracking::{Tracker, TrackerConfig};
    /// let t = Tracker::new(TrackerConfig::default(), starid_core::IdentifyConfig::default()).unwrap();
    /// assert!(!t.has_lock());
    /// ```
    pub fn new(config: TrackerConfig, identify: IdentifyConfig) -> Result<Self> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !ok(config.max_rate_rad_s) || config.max_rate_rad_s > 10.0 * std::f64::consts::PI {
            return Err(Error::invalid_input(format!(
                "max_rate_deg_s must be positive and at most 1800 deg/s, got {}",
                config.max_rate_rad_s.to_degrees()
            )));
        }
        if !ok(config.min_uncertainty_rad) || config.min_uncertainty_rad > 0.1 {
            return Err(Error::invalid_input(format!(
                "min_uncertainty_deg must be in (0, 5.7] degrees, got {}",
                config.min_uncertainty_rad.to_degrees()
            )));
        }
        if config.confirm_unseen_frames == Some(0) {
            return Err(Error::invalid_input(
                "confirm_unseen_frames must be at least 1 (or None to turn the rule off)",
            ));
        }
        identify.validate()?;
        Ok(Self {
            config,
            identify,
            last: None,
            history: std::collections::VecDeque::new(),
            rate: None,
            rate_change: 0.0,
            named: Vec::new(),
            unseen: Vec::new(),
            confirmed: Vec::new(),
            held: Vec::new(),
            focal: None,
            zero_points: std::collections::VecDeque::new(),
            noises: std::collections::VecDeque::new(),
            smear: std::collections::VecDeque::new(),
            completeness: vec![[0, 0]; COMPLETENESS_BINS],
        })
    }

    /// Whether a solution is held to predict from.
    pub fn has_lock(&self) -> bool {
        self.last.is_some()
    }

    /// The body rate estimate (camera frame, rad/s).
    pub fn rate_rad_s(&self) -> Option<Vector3<f64>> {
        self.rate
    }

    /// Forget the lock: the next frame is identified lost in space.
    pub fn reset(&mut self) {
        self.last = None;
        self.history.clear();
        self.rate = None;
        self.rate_change = 0.0;
        self.smear.clear();
        self.named.clear();
        self.unseen.clear();
        self.confirmed.clear();
        self.held.clear();
    }

    /// The attitude predicted for time `t_s` and its uncertainty (radians), without a lock `None`.
    pub fn predict(&self, t_s: f64) -> Option<(Rotation3<f64>, f64)> {
        let (t0, r0, _) = self.last?;
        let dt = (t_s - t0).abs();
        let c = &self.config;
        Some(match self.rate {
            Some(w) => {
                let turn = Rotation3::new(w * (t_s - t0));
                // The rate's own change since the last estimate, over this interval, and some
                // room for jitter and for the rate's error.
                let u = c.min_uncertainty_rad + 2.0 * self.rate_change * dt + 0.1 * w.norm() * dt;
                (
                    turn * r0,
                    u.min(c.max_rate_rad_s * dt + c.min_uncertainty_rad),
                )
            }
            None => (r0, c.max_rate_rad_s * dt + c.min_uncertainty_rad),
        })
    }

    /// Identify the frame taken at `t_s` (seconds, any origin; increasing or not) and update the
    /// lock.
    ///
    /// # Errors
    /// As [`Solver::identify_hinted`]; `InvalidInput` for a non-finite time.
    ///
    /// # Example
    /// ```
    /// use starid_core::simulate::{random_catalog, simulate_sequence, SequenceConfig};
    /// use starid_core::tracking::{TrackMode, Tracker, TrackerConfig};
    /// use starid_core::{Camera, IdentifyConfig, Solver};
    /// let cat = std::sync::Arc::new(random_catalog(8000, 1.0, 6.5, 1).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    /// let seq = simulate_sequence(&cat, &cam, &SequenceConfig { frames: 6, ..Default::default() }, 2).unwrap();
    /// let mut tracker = Tracker::new(TrackerConfig::default(), IdentifyConfig::default()).unwrap();
    /// let modes: Vec<TrackMode> = seq.iter()
    ///     .map(|f| tracker.update(&solver, &f.frame.centroids, None, &cam, f.t_s).unwrap().mode)
    ///     .collect();
    /// assert_eq!(modes[0], TrackMode::LostInSpace);
    /// assert!(modes[1..].iter().all(|m| *m == TrackMode::Tracking));
    /// ```
    pub fn update(
        &mut self,
        solver: &Solver,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        t_s: f64,
    ) -> Result<TrackStep> {
        if !t_s.is_finite() {
            return Err(Error::invalid_input(format!(
                "the frame time must be finite, got {t_s}"
            )));
        }
        // The focal length (and distortion) a focal check found for this camera, once it has.
        let given = *camera;
        let adopted = self
            .focal
            .filter(|c| c.given_focal_px == given.focal_length_px && c.given_k1 == given.k1);
        let camera = &Camera {
            focal_length_px: adopted.map_or(given.focal_length_px, |c| c.focal_px),
            k1: adopted.and_then(|c| c.k1).unwrap_or(given.k1),
            ..given
        };
        // The zero point the last solutions agree on, where the configuration has none that fits.
        let learned = magnitudes
            .and(self.learned_zero_point())
            .and_then(|zp| self.identify.with_learned_zero_point(zp));
        let config = learned.as_ref().unwrap_or(&self.identify);
        let prediction = self.predict(t_s);
        let fallback = if self.config.fallback {
            HintFallback::LostInSpace
        } else {
            HintFallback::None
        };
        let search = |config: &IdentifyConfig| match (prediction, self.last) {
            (Some((r, u)), Some((_, _, mirrored))) => {
                let hint = AttitudeHint {
                    r_icrs_to_cam: r,
                    uncertainty_rad: u.min(crate::identify::MAX_HINT_UNCERTAINTY_RAD),
                    mirrored: Some(mirrored),
                };
                solver.identify_hinted(centroids, magnitudes, camera, config, &hint, fallback)
            }
            _ => solver.identify(centroids, magnitudes, camera, config),
        };
        let mut id = search(config)?;
        // Nothing identified: the noise the last solutions agree on, where tighter than the
        // ladder's first step, searches the frame again (a tighter radius lets fewer stars pass).
        let learned_noise = (config.learn_noise && config.centroid_sigma_px.is_none())
            .then(|| crate::identify::agreed_noise(self.noises.iter().cloned()))
            .flatten()
            .filter(|&s| {
                s > 0.0
                    && s < crate::identify::NOISE_LEARN_BELOW_LADDER
                        * crate::identify::SIGMA_LADDER_PX[0]
            });
        if let (false, Some(sigma)) = (id.is_identified(), learned_noise) {
            let tight = IdentifyConfig {
                centroid_sigma_px: Some(sigma),
                noise_fallback: false,
                ..config.clone()
            };
            let mut again = search(&tight)?;
            again.elapsed += id.elapsed;
            again.hypotheses += id.hypotheses;
            if again.is_identified() {
                again.learned_sigma_px = Some(sigma);
                again.noise_source = crate::identify::NoiseSource::Learned;
                id = again;
            } else {
                (id.elapsed, id.hypotheses) = (again.elapsed, again.hypotheses);
            }
        }
        if id.is_identified() {
            let sample = id.noise_sample_px(camera.focal_length_px);
            if self.identify.learn_noise && !sample.is_empty() {
                self.noises.push_back(sample);
                if self.noises.len() > NOISE_HISTORY {
                    self.noises.pop_front();
                }
            }
            id.learned_mag_offset = learned.as_ref().and_then(|c| c.mag_offset);
            // (Measured only for learning: a median per frame on the tracking path.)
            let measured = magnitudes
                .filter(|_| self.identify.learn_zero_point)
                .and_then(|m| id.zero_point(m, solver.catalog()));
            if let Some(zp) = measured {
                self.zero_points.push_back(zp);
                if self.zero_points.len() > ZERO_POINT_HISTORY {
                    self.zero_points.pop_front();
                }
            }
        }
        match (id.focal_length_px, adopted) {
            (Some(f), _) => {
                self.focal = Some(FoundCamera {
                    given_focal_px: given.focal_length_px,
                    given_k1: given.k1,
                    focal_px: f,
                    sigma_px: id.focal_sigma_px,
                    k1: id.k1.or(adopted.and_then(|c| c.k1)),
                });
            }
            (None, Some(c)) if id.is_identified() => {
                (id.focal_length_px, id.focal_sigma_px, id.k1) =
                    (Some(c.focal_px), c.sigma_px, c.k1);
            }
            _ => {}
        }
        let mode = if id.hinted {
            TrackMode::Tracking
        } else {
            TrackMode::LostInSpace
        };
        let named_now: Vec<u32> = {
            let mut v: Vec<u32> = id.catalog_index.iter().flatten().copied().collect();
            v.sort_unstable();
            v
        };
        let continuous = self
            .last
            .is_some_and(|(t0, _, m0)| (t_s - t0).abs() <= RATE_BASELINE_S && m0 == id.mirrored);
        // The doubtful names go first: the holds below then see what the solution matched less
        // those, and a pair whose one star is held is still tested whole.
        let smear = if mode == TrackMode::Tracking {
            self.unname_doubtful(&mut id, solver, camera, centroids, magnitudes)
        } else {
            Vec::new()
        };
        let mut held_now = Vec::new();
        if self.config.confirm_new_stars && mode == TrackMode::Tracking && continuous {
            if let Some((_, r0, _)) = self.last {
                self.confirm(&mut id, solver, camera, &r0);
            }
        } else if let (Some(k), true, true) = (
            self.config.confirm_unseen_frames,
            mode == TrackMode::Tracking,
            continuous,
        ) {
            self.hold_unseen(&mut id, k, solver, &mut held_now);
        }
        if let (true, Some(r)) = (id.is_identified(), id.r_icrs_to_cam) {
            // A lock on the other handedness, or after a long gap, starts a new history.
            let gap = self
                .last
                .is_some_and(|(t0, _, m)| m != id.mirrored || (t_s - t0).abs() > RATE_BASELINE_S);
            if gap {
                self.history.clear();
                self.rate = None;
                self.smear.clear();
            }
            for c in smear {
                self.smear.push_back(c);
                if self.smear.len() > SMEAR_HISTORY {
                    self.smear.pop_front();
                }
            }
            self.history.push_back((t_s, r));
            while self.history.len() > 2 && (t_s - self.history[0].0).abs() > RATE_BASELINE_S {
                self.history.pop_front();
            }
            if self.history.len() > RATE_HISTORY {
                self.history.pop_front();
            }
            if let Some(&(t0, r0)) = self.history.front() {
                let dt = t_s - t0;
                if dt.abs() > 1e-9 {
                    let w = (r * r0.inverse()).scaled_axis() / dt;
                    self.rate_change = self.rate.map_or(0.0, |old| (w - old).norm());
                    self.rate = Some(w);
                }
            }
            self.last = Some((t_s, r, id.mirrored));
            if self.config.confirm_unseen_frames.is_some() {
                if gap {
                    self.unseen.clear();
                }
                self.count_unseen(&id, &named_now, solver, camera, &r);
                self.held = held_now;
            }
            self.named = named_now;
        }
        Ok(TrackStep {
            mode,
            predicted: prediction.map(|p| p.0),
            uncertainty_rad: prediction.map_or(f64::NAN, |p| p.1),
            rate_rad_s: self.rate,
            identification: id,
        })
    }
}
