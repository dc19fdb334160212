//! What identification reports: `Status`, `Identification`, and the magnitude zero point a batch learns.

use super::*;

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

/// Where the noise a solution was verified at came from (see
/// [`Identification::noise_step_px`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum NoiseSource {
    /// Unidentified, or a method's raw answer: no noise was tested.
    None,
    /// A step of the default ladder: no noise was stated.
    Ladder,
    /// The stated [`IdentifyConfig::centroid_sigma_px`]: the residuals bore it out.
    Stated,
    /// A looser step than the stated noise: the residuals refused it as too small.
    Widened,
    /// A tighter step of the default ladder than the stated noise, tried first (see
    /// [`IdentifyConfig::search_ladder`]): the noise was stated larger than the frame needed.
    Narrowed,
    /// The noise a batch learned from its frames identified with a wide margin.
    Learned,
}

impl NoiseSource {
    /// Lower-case name: `none`, `ladder`, `stated`, `widened`, `narrowed`, `learned`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::NoiseSource::Widened.as_str(), "widened");
    /// ```
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Ladder => "ladder",
            Self::Stated => "stated",
            Self::Widened => "widened",
            Self::Narrowed => "narrowed",
            Self::Learned => "learned",
        }
    }

    /// The source of a verified solution found with `config` at the noise step `step_px`.
    pub(crate) fn of(config: &IdentifyConfig, id: &Identification) -> Self {
        if !(id.is_identified() && id.verified) {
            return Self::None;
        }
        match config.centroid_sigma_px {
            None => Self::Ladder,
            Some(s) if (id.noise_step_px - s).abs() <= 1e-9 * s => Self::Stated,
            Some(s) if id.noise_step_px < s => Self::Narrowed,
            Some(_) => Self::Widened,
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
    /// The noise hypothesis (1σ per axis, px) the solution was verified at: a step of the
    /// default ladder, the stated [`IdentifyConfig::centroid_sigma_px`] or a looser step after
    /// the residuals refused it, or the noise a batch learned (`learned_sigma_px`). NaN when
    /// unidentified.
    pub noise_step_px: f64,
    /// The centroid noise (px) a batch learned from its frames identified with a wide margin
    /// and searched this frame with, after a first search without it found nothing (see
    /// [`Solver::identify_batch`]); `None` for a frame identified as given.
    pub learned_sigma_px: Option<f64>,
    /// Where `noise_step_px` came from.
    pub noise_source: NoiseSource,
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

    /// The frame's residuals in pixels (focal length `focal_px`), each scaled by
    /// `sqrt(2m / (2m − 3))` for the attitude's three degrees of freedom among its `m` matches:
    /// the sample a centroid noise is learned from. Empty unless the frame is a verified
    /// solution of at least [`NOISE_LEARN_MIN_MATCHES`] matches.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    /// let f = simulate(&cat, &cam, &SimConfig { noise_px: 0.1, ..Default::default() }, 1).unwrap();
    /// let id = solver.identify(&f.centroids, Some(&f.magnitudes), &cam, &IdentifyConfig::default()).unwrap();
    /// let mut d = id.noise_sample_px(cam.focal_length_px);
    /// assert!(d.len() >= 8);
    /// d.sort_by(f64::total_cmp);
    /// let sigma = d[d.len() / 2] / 1.1774; // a Rayleigh distribution's median is 1.1774 sigma
    /// assert!((0.05..0.2).contains(&sigma));
    /// ```
    pub fn noise_sample_px(&self, focal_px: f64) -> Vec<f64> {
        if !(self.is_identified() && self.verified && self.matched >= NOISE_LEARN_MIN_MATCHES) {
            return Vec::new();
        }
        let m = self.matched as f64;
        let dof = (2.0 * m / (2.0 * m - 3.0)).sqrt();
        self.residuals_rad
            .iter()
            .filter(|r| r.is_finite())
            .map(|r| r * focal_px * dof)
            .collect()
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
        let median = stats::median_in_place(&mut d);
        for x in &mut d {
            *x = (*x - median).abs();
        }
        Some((median, 1.4826 * stats::median_in_place(&mut d)))
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
            noise_step_px: f64::NAN,
            learned_sigma_px: None,
            noise_source: NoiseSource::None,
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
    let offset = stats::median_in_place(&mut z.to_vec());
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
    let tolerance = (ZERO_POINT_TOLERANCE_SIGMAS * stats::median_in_place(&mut spread)).clamp(
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
pub(crate) const ZERO_POINT_MAX_DISAGREE: f64 = 1.0 / 3.0;

/// The learned search's magnitude tolerance, in the frames' typical spread of magnitudes about
/// their zero point (never below the configured tolerance, nor above
/// [`ZERO_POINT_MAX_TOLERANCE_MAG`]).
pub const ZERO_POINT_TOLERANCE_SIGMAS: f64 = 2.5;

/// Largest magnitude tolerance of a search with a learned zero point.
pub const ZERO_POINT_MAX_TOLERANCE_MAG: f64 = 1.5;
