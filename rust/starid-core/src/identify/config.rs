//! Settings of identification: `IdentifyConfig` and the `Method` that makes hypotheses.

use super::*;

/// Settings of [`Solver::identify`]. Build with `..Default::default()`.
#[derive(Debug, Clone, PartialEq)]
pub struct IdentifyConfig {
    /// Centroid noise, 1σ per axis in pixels: tried first, as a hypothesis the residuals may
    /// refuse (then the default ladder's steps well above it follow; see
    /// [`IdentifyConfig::noise_ladder`]). `None`: try [`SIGMA_LADDER_PX`] in turn.
    pub centroid_sigma_px: Option<f64>,
    /// Largest accepted bound on the probability that the solution is a false match.
    pub max_false_match_prob: f64,
    /// Fewest matched stars of a reported solution (at least 3). Three stars are named only by
    /// the lone-triangle test, where the triangle's own sides and magnitudes pass the
    /// false-match bound; a solution from the Pyramid's verification has at least 4.
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
    /// How far off the given field of view may be, relative to the true one (0.1: the given
    /// field within ±10 % of it, so the true one between `fov / 1.1` and `fov / 0.9`): a
    /// field of view is an estimate (a lens's nominal focal length, a crop, focus). Where the
    /// given camera finds no solution, or only one whose residuals needed a widened match radius
    /// and that leaves many spots unnamed, the frame is searched again with the focal length
    /// unknown within this tolerance ([`Solver::identify_unknown_focal`]), and the solution that
    /// names more spots kept, with the focal length found. 0, or `focal_check` false, holds the
    /// field as given. Only for cameras with the principal point at the centre and no
    /// distortion (a calibrated camera is known better than this).
    pub fov_tolerance: f64,
    /// In a batch ([`Solver::identify_batch`]), learn the magnitude zero point from the frames
    /// identified without it (the default): when [`ZERO_POINT_MIN_FRAMES`] or more of them
    /// agree on one, the frames with magnitudes that nothing identified (status `no_match` or
    /// `search_limit`) are searched again, magnitude-gated, with it. Only where the given
    /// `mag_offset` is `None` or disagrees with the learned one. `false`: each frame alone.
    pub learn_zero_point: bool,
    /// In a batch, learn the centroid noise from the frames identified with a wide margin
    /// (at least [`NOISE_LEARN_MIN_MATCHES`] matches each, [`NOISE_LEARN_MIN_FRAMES`] frames)
    /// when none is stated (the default): where it is tighter than the ladder's first step, the
    /// frames nothing identified are searched again with it (as a stated noise the residuals
    /// may refuse). `false`: each frame alone.
    pub learn_noise: bool,
    /// After a stated `centroid_sigma_px`, try the default ladder's steps well above it
    /// (see [`IdentifyConfig::noise_ladder`]; the default). `false`: the stated noise only.
    pub noise_fallback: bool,
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
            min_matches: 3,
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
            fov_tolerance: DEFAULT_FOV_TOLERANCE,
            learn_zero_point: true,
            learn_noise: true,
            noise_fallback: true,
        }
    }
}

/// Default of [`IdentifyConfig::fov_tolerance`]: a field of view known to ±10 %.
pub const DEFAULT_FOV_TOLERANCE: f64 = 0.1;
/// Largest [`IdentifyConfig::fov_tolerance`].
pub const MAX_FOV_TOLERANCE: f64 = 0.5;

impl IdentifyConfig {
    /// The focal lengths `(shortest, longest)` a given camera's field of view allows within
    /// [`IdentifyConfig::fov_tolerance`] (the camera's own for a tolerance of 0, for a camera
    /// that is not ideal, without the focal check, or for raw answers without verification).
    pub fn focal_range_px(&self, camera: &Camera) -> (f64, f64) {
        let f = camera.focal_length_px;
        if !(self.focal_check && self.verify && self.fov_tolerance > 0.0 && camera.is_ideal()) {
            return (f, f);
        }
        // The fields of which the given one is within the tolerance: given 10 % too small, the
        // field is 1/0.9 of it, not 1.1.
        let fov = camera.fov_rad();
        let focal = |field: f64| 0.5 * camera.width_px / (0.5 * field).tan();
        let widest = (fov / (1.0 - self.fov_tolerance)).min(170f64.to_radians());
        (
            focal(widest).min(f),
            focal(fov / (1.0 + self.fov_tolerance)).max(f),
        )
    }

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

    /// The noise steps (px) a search tries in turn: `default` without a stated noise; with
    /// one, the stated noise and then (with `noise_fallback`) the steps of `default` at least
    /// [`NOISE_LADDER_GAP`] times it, so that a noise stated too small costs a looser search,
    /// not the frame.
    ///
    /// # Example
    /// ```
    /// use starid_core::{identify::SIGMA_LADDER_PX, IdentifyConfig};
    /// let stated = IdentifyConfig { centroid_sigma_px: Some(0.1), ..Default::default() };
    /// assert_eq!(stated.noise_ladder(&SIGMA_LADDER_PX), vec![0.1, 0.7, 2.5]);
    /// assert_eq!(IdentifyConfig::default().noise_ladder(&SIGMA_LADDER_PX), SIGMA_LADDER_PX.to_vec());
    /// ```
    pub fn noise_ladder(&self, default: &[f64]) -> Vec<f64> {
        match self.centroid_sigma_px {
            Some(s) => std::iter::once(s)
                .chain(
                    default
                        .iter()
                        .copied()
                        .filter(|&d| self.noise_fallback && d >= NOISE_LADDER_GAP * s),
                )
                .collect(),
            None => default.to_vec(),
        }
    }

    /// The noise steps (px) of a lost-in-space search: [`IdentifyConfig::noise_ladder`], and with
    /// a stated noise and `noise_fallback`, first the steps of `default` at most
    /// 1/[`NOISE_LADDER_GAP`] of it: a noise stated too large costs a few tight triangles, not
    /// the frame (a loose step's tolerances match so many catalogue triangles that the bound
    /// seldom passes before the budget is spent).
    ///
    /// # Example
    /// ```
    /// use starid_core::{identify::SIGMA_LADDER_PX, IdentifyConfig};
    /// let stated = IdentifyConfig { centroid_sigma_px: Some(4.0), ..Default::default() };
    /// assert_eq!(stated.search_ladder(&SIGMA_LADDER_PX), vec![0.2, 0.7, 4.0]);
    /// let small = IdentifyConfig { centroid_sigma_px: Some(0.1), ..Default::default() };
    /// assert_eq!(small.search_ladder(&SIGMA_LADDER_PX), vec![0.1, 0.7, 2.5]);
    /// ```
    pub fn search_ladder(&self, default: &[f64]) -> Vec<f64> {
        let tighter = self
            .centroid_sigma_px
            .filter(|_| self.noise_fallback)
            .map_or(0, |s| {
                default
                    .iter()
                    .take_while(|&&d| d * NOISE_LADDER_GAP <= s)
                    .count()
            });
        default[..tighter]
            .iter()
            .copied()
            .chain(self.noise_ladder(default))
            .collect()
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
        if self.min_matches < LONE_MIN_MATCHES {
            return Err(Error::invalid_input(format!(
                "min_matches must be at least {LONE_MIN_MATCHES}, got {}",
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
        if !(0.0..=MAX_FOV_TOLERANCE).contains(&self.fov_tolerance) {
            return Err(Error::invalid_input(format!(
                "fov_tolerance must be in [0, {MAX_FOV_TOLERANCE}] (relative), got {}",
                self.fov_tolerance
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
