//! Camera calibration from many identified frames: one joint least-squares problem over one
//! attitude per frame and the intrinsics every frame shares (focal length, principal point,
//! Brown–Conrady distortion `k1..k3`, `p1, p2`; see [`Camera`]).
//!
//! The residuals are pixel offsets between each spot and its star imaged by the camera. The
//! normal equations are block-sparse: each frame's 3×3 attitude block couples to the others
//! only through the shared columns. Each Levenberg–Marquardt step therefore eliminates the
//! attitude blocks (the Schur complement `S = C − Σ Bᵢᵀ Aᵢ⁻¹ Bᵢ`), solves the small shared
//! system with faer's Cholesky factorisation, and recovers each frame's step from its own block.
//! The covariance of the intrinsics is `σ² S⁻¹` at the solution (`σ²` the residual variance per
//! axis). Matches whose residual lies beyond the clipping threshold are dropped and the fit
//! repeated until the set of inliers no longer changes (a clipped match may come back).

use nalgebra::{Rotation3, Vector3};

use crate::error::{Error, Result};
use crate::geometry::Camera;

mod solve;

use solve::{as_weights, covariance, fit, residuals, State};

/// One identified frame: its spots, the stars they were matched to, and a starting attitude.
#[derive(Debug, Clone)]
pub struct CalibrationFrame {
    /// Observed pixels `(x, y)` of the matched spots (as the frame reports them; a mirrored
    /// frame's x is reversed about the sensor before fitting).
    pub pixels: Vec<[f64; 2]>,
    /// ICRS unit vectors of the stars, one per pixel.
    pub stars: Vec<Vector3<f64>>,
    /// Starting attitude ICRS → camera (the identification's).
    pub attitude: Rotation3<f64>,
    /// Whether the frame is mirrored (x reversed).
    pub mirrored: bool,
}

/// What a calibration fits (the rest of the starting camera is held).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationConfig {
    /// Fit the focal length.
    pub focal_length: bool,
    /// Fit the principal point; `None` chooses (see [`calibrate`]).
    pub principal_point: Option<bool>,
    /// Radial terms fitted: 0 to 3 (`k1`, `k1..k2`, `k1..k3`); `None` chooses (see
    /// [`calibrate`]).
    pub radial_terms: Option<usize>,
    /// Fit the decentering terms `p1, p2`; `None` chooses (see [`calibrate`]).
    pub decentering: Option<bool>,
    /// Clip matches whose residual is less likely than a `clip_sigma`-σ deviation of a normal
    /// variable (two-sided); 0 or infinity keeps every match.
    pub clip_sigma: f64,
    /// Levenberg–Marquardt steps per fit at most.
    pub max_iterations: usize,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        Self {
            focal_length: true,
            principal_point: None,
            radial_terms: None,
            decentering: None,
            clip_sigma: 3.0,
            max_iterations: 100,
        }
    }
}

/// A shared intrinsic parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Intrinsic {
    /// Focal length, pixels.
    FocalLength,
    /// Principal point x, pixels.
    Cx,
    /// Principal point y, pixels.
    Cy,
    /// Radial `k1`.
    K1,
    /// Radial `k2`.
    K2,
    /// Radial `k3`.
    K3,
    /// Decentering `p1`.
    P1,
    /// Decentering `p2`.
    P2,
}

impl Intrinsic {
    /// The parameter's name (`focal_length_px`, `cx`, `cy`, `k1`, ..., `p2`).
    pub fn name(self) -> &'static str {
        match self {
            Self::FocalLength => "focal_length_px",
            Self::Cx => "cx",
            Self::Cy => "cy",
            Self::K1 => "k1",
            Self::K2 => "k2",
            Self::K3 => "k3",
            Self::P1 => "p1",
            Self::P2 => "p2",
        }
    }

    pub(crate) fn value(self, c: &Camera) -> f64 {
        match self {
            Self::FocalLength => c.focal_length_px,
            Self::Cx => c.principal_point_px[0],
            Self::Cy => c.principal_point_px[1],
            Self::K1 => c.k1,
            Self::K2 => c.k2,
            Self::K3 => c.k3,
            Self::P1 => c.p1,
            Self::P2 => c.p2,
        }
    }

    pub(crate) fn set(self, c: &mut Camera, v: f64) {
        match self {
            Self::FocalLength => c.focal_length_px = v,
            Self::Cx => c.principal_point_px[0] = v,
            Self::Cy => c.principal_point_px[1] = v,
            Self::K1 => c.k1 = v,
            Self::K2 => c.k2 = v,
            Self::K3 => c.k3 = v,
            Self::P1 => c.p1 = v,
            Self::P2 => c.p2 = v,
        }
    }
}

impl CalibrationConfig {
    /// The intrinsics this configuration fits, in order (with the most terms where it
    /// chooses).
    pub fn intrinsics(&self) -> Vec<Intrinsic> {
        let mut out = Vec::with_capacity(8);
        if self.focal_length {
            out.push(Intrinsic::FocalLength);
        }
        if self.principal_point.unwrap_or(true) {
            out.extend([Intrinsic::Cx, Intrinsic::Cy]);
        }
        out.extend(
            [Intrinsic::K1, Intrinsic::K2, Intrinsic::K3]
                .into_iter()
                .take(self.radial_terms.unwrap_or(3)),
        );
        if self.decentering.unwrap_or(true) {
            out.extend([Intrinsic::P1, Intrinsic::P2]);
        }
        out
    }

    fn validate(&self) -> Result<()> {
        if let Some(n) = self.radial_terms.filter(|&n| n > 3) {
            return Err(Error::invalid_input(format!(
                "radial_terms must be 0 to 3, got {n}"
            )));
        }
        if self.clip_sigma.is_nan() || self.clip_sigma < 0.0 {
            return Err(Error::invalid_input(format!(
                "clip_sigma must be 0 or more (0: no clipping), got {}",
                self.clip_sigma
            )));
        }
        if self.max_iterations == 0 {
            return Err(Error::invalid_input("max_iterations must be at least 1"));
        }
        Ok(())
    }
}

/// The outcome of [`calibrate`].
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The fitted camera.
    pub camera: Camera,
    /// Each frame's fitted attitude ICRS → camera.
    pub attitudes: Vec<Rotation3<f64>>,
    /// The intrinsics fitted, in the order of `covariance`.
    pub intrinsics: Vec<Intrinsic>,
    /// Covariance of the fitted intrinsics (row-major, `intrinsics.len()²`); NaN where the
    /// shared system is singular.
    pub covariance: Vec<f64>,
    /// RMS residual per axis of the inliers, pixels, with the starting camera (each frame's
    /// attitude fitted alone).
    pub rms_before_px: f64,
    /// RMS residual per axis of the inliers, pixels, after calibration.
    pub rms_px: f64,
    /// Each frame's RMS residual per axis of its inliers after calibration (NaN without any).
    pub frame_rms_px: Vec<f64>,
    /// Each frame's residuals `(observed − predicted)` after calibration, pixels, one per match.
    pub residuals_px: Vec<Vec<[f64; 2]>>,
    /// Whether each match was kept (false: clipped as an outlier).
    pub inliers: Vec<Vec<bool>>,
    /// Levenberg–Marquardt steps taken over all fits.
    pub iterations: usize,
    /// Rounds of clipping and refitting.
    pub rounds: usize,
}

impl Calibration {
    /// Number of matches kept.
    pub fn n_inliers(&self) -> usize {
        self.inliers.iter().flatten().filter(|&&k| k).count()
    }

    /// Number of matches clipped.
    pub fn n_clipped(&self) -> usize {
        self.inliers.iter().flatten().filter(|&&k| !k).count()
    }

    /// 1σ of each fitted intrinsic (the square roots of the covariance's diagonal).
    pub fn sigmas(&self) -> Vec<f64> {
        let n = self.intrinsics.len();
        (0..n).map(|i| self.covariance[i * n + i].sqrt()).collect()
    }
}

/// Fit one camera to many identified frames (see the module documentation).
///
/// Where the configuration leaves the number of radial terms, the decentering or the principal
/// point open, the richest such model is fitted first (robust start, clipping); every model is
/// then fitted on its inliers and the one with the least Hannan–Quinn information criterion
/// (cost in units of the richest model's residual variance, plus `2 ln ln n` per parameter)
/// refitted with clipping and kept.
/// Terms the data cannot fix (`k3` on a narrow field, the principal point of a few frames of
/// few stars) are so left out.
///
/// # Errors
/// `InvalidInput` when the configuration is out of range, a frame's pixels and stars differ in
/// number or are not finite, there are fewer matches than parameters, the solution leaves the
/// camera model's range, or the fit fails (stars behind the camera throughout).
pub fn calibrate(
    frames: &[CalibrationFrame],
    start: &Camera,
    config: &CalibrationConfig,
) -> Result<Calibration> {
    config.validate()?;
    let frames = prepared(frames, start)?;
    let radial: Vec<usize> = config.radial_terms.map_or(vec![3, 2, 1], |n| vec![n]);
    let decentering: Vec<bool> = config.decentering.map_or(vec![true, false], |d| vec![d]);
    let centre: Vec<bool> = config
        .principal_point
        .map_or(vec![true, false], |c| vec![c]);
    let mut models: Vec<CalibrationConfig> = Vec::new();
    for &c in &centre {
        for &d in &decentering {
            for &n in &radial {
                models.push(CalibrationConfig {
                    principal_point: Some(c),
                    radial_terms: Some(n),
                    decentering: Some(d),
                    ..*config
                });
            }
        }
    }
    if models.len() == 1 {
        let cal = fit_model(&frames, start, &models[0], None)?;
        return with_rms_before(&frames, start, config, cal);
    }
    // The richest model, fitted robustly, gives the inliers and a starting state; each candidate
    // is then fitted on those inliers from that state (the terms it lacks set back to the
    // starting camera's), so that all are compared on the same matches.
    let rich = match fit_model(&frames, start, &models[0], None) {
        Ok(rich) => rich,
        // A rich model the data cannot fix: each candidate fitted on its own.
        Err(_) => return choose_among_fits(&frames, start, config, &models),
    };
    let weights = as_weights(&rich.inliers);
    let screen = |m: &CalibrationConfig| -> Option<(f64, State)> {
        let intrinsics = m.intrinsics();
        let mut camera = rich.camera;
        for p in models[0].intrinsics() {
            if !intrinsics.contains(&p) {
                p.set(&mut camera, p.value(start));
            }
        }
        let state = State {
            camera,
            attitudes: rich.attitudes.clone(),
        };
        let fitted = fit(&frames, &weights, state, &intrinsics, m.max_iterations).ok()?;
        let cost: f64 = residuals(&frames, &fitted.state)
            .iter()
            .zip(&rich.inliers)
            .flat_map(|(rs, k)| {
                rs.iter()
                    .zip(k)
                    .filter(|(_, &k)| k)
                    .map(|(r, _)| r[0] * r[0] + r[1] * r[1])
            })
            .sum();
        Some((cost, fitted.state))
    };
    #[cfg(feature = "parallel")]
    let screened: Vec<Option<(f64, State)>> = {
        use rayon::prelude::*;
        models.par_iter().map(screen).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let screened: Vec<Option<(f64, State)>> = models.iter().map(screen).collect();
    let kept = rich.n_inliers();
    let n_params = rich.intrinsics.len() + 3 * frames.len();
    let sigma2 = screened[0].as_ref().map_or(f64::NAN, |(cost, _)| {
        cost / (2 * kept).saturating_sub(n_params).max(1) as f64
    });
    let penalty = 2.0 * ((2 * kept) as f64).ln().ln();
    let best = screened
        .into_iter()
        .zip(&models)
        .filter_map(|(s, m)| {
            s.map(|(cost, state)| {
                (
                    cost / sigma2 + penalty * m.intrinsics().len() as f64,
                    state,
                    m,
                )
            })
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let cal = match best {
        Some((_, state, m)) if *m != models[0] => {
            fit_model(&frames, start, m, Some((state, rich.inliers.clone()))).or(Ok::<
                Calibration,
                Error,
            >(
                rich
            ))?
        }
        _ => rich,
    };
    with_rms_before(&frames, start, config, cal)
}

/// Each candidate model fitted on its own (robust start, clipping), the one of least
/// Hannan–Quinn criterion kept, on costs scaled by the richest fit's robust variance with each
/// match capped at the clipping threshold.
fn choose_among_fits(
    frames: &[CalibrationFrame],
    start: &Camera,
    config: &CalibrationConfig,
    models: &[CalibrationConfig],
) -> Result<Calibration> {
    #[cfg(feature = "parallel")]
    let outcomes: Vec<Result<Calibration>> = {
        use rayon::prelude::*;
        models
            .par_iter()
            .map(|m| fit_model(frames, start, m, None))
            .collect()
    };
    #[cfg(not(feature = "parallel"))]
    let outcomes: Vec<Result<Calibration>> = models
        .iter()
        .map(|m| fit_model(frames, start, m, None))
        .collect();
    let mut fitted: Vec<Calibration> = Vec::new();
    let mut first_error = None;
    for outcome in outcomes {
        match outcome {
            Ok(c) => fitted.push(c),
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    if fitted.len() <= 1 {
        let chosen = fitted
            .pop()
            .ok_or_else(|| first_error.expect("a model was tried"))?;
        return with_rms_before(frames, start, config, chosen);
    }
    let richest = fitted
        .iter()
        .max_by_key(|c| c.intrinsics.len())
        .expect("models");
    let sigma2 = robust_variance(&richest.residuals_px, &richest.inliers);
    let cap = clip_threshold(config.clip_sigma).unwrap_or(f64::INFINITY);
    let n_obs = 2 * fitted[0].residuals_px.iter().map(Vec::len).sum::<usize>();
    let criterion = |c: &Calibration| {
        let cost: f64 = c
            .residuals_px
            .iter()
            .flatten()
            .map(|r| ((r[0] * r[0] + r[1] * r[1]) / sigma2).min(cap))
            .sum();
        cost + c.intrinsics.len() as f64 * 2.0 * (n_obs as f64).ln().ln()
    };
    let chosen = fitted
        .into_iter()
        .min_by(|a, b| criterion(a).total_cmp(&criterion(b)))
        .expect("models");
    with_rms_before(frames, start, config, chosen)
}

/// The calibration with its RMS before: the same inliers with the starting camera, each frame's
/// attitude fitted alone.
fn with_rms_before(
    frames: &[CalibrationFrame],
    start: &Camera,
    config: &CalibrationConfig,
    mut cal: Calibration,
) -> Result<Calibration> {
    let before = fit(
        frames,
        &as_weights(&cal.inliers),
        State {
            camera: *start,
            attitudes: frames.iter().map(|f| f.attitude).collect(),
        },
        &[],
        config.max_iterations,
    )?;
    cal.iterations += before.iterations;
    cal.rms_before_px = rms(&residuals(frames, &before.state), &cal.inliers);
    Ok(cal)
}

/// One model's fit: the robust start (or the state and inliers `from` gives), clipping rounds,
/// the covariance.
fn fit_model(
    frames: &[CalibrationFrame],
    start: &Camera,
    config: &CalibrationConfig,
    from: Option<(State, Vec<Vec<bool>>)>,
) -> Result<Calibration> {
    let frames = frames.to_vec();
    let intrinsics = config.intrinsics();
    let n_matches: usize = frames.iter().map(|f| f.pixels.len()).sum();
    let n_params = intrinsics.len() + 3 * frames.len();
    if 2 * n_matches <= n_params {
        return Err(Error::invalid_input(format!(
            "{n_matches} matches over {} frames cannot fix {n_params} parameters",
            frames.len()
        )));
    }
    let robust_start = from.is_none();
    let (mut state, mut masks) = from.unwrap_or_else(|| {
        let state = State {
            camera: *start,
            attitudes: frames.iter().map(|f| f.attitude).collect(),
        };
        (
            state,
            frames.iter().map(|f| vec![true; f.pixels.len()]).collect(),
        )
    });
    let clip = clip_threshold(config.clip_sigma);
    let (mut iterations, mut rounds) = (0, 0);
    if clip.is_some() && robust_start {
        // A robust start: wrong matches (a wrong neighbour at the edge of a distorted field) sit
        // many σ out and would bend a plain least-squares fit before clipping could see them,
        // so the fit is first reweighted by a Cauchy loss at the robust σ.
        let mut weights: Vec<Vec<f64>> = frames.iter().map(|f| vec![1.0; f.pixels.len()]).collect();
        for _ in 0..ROBUST_ROUNDS {
            // The weights change from round to round: no round needs to converge fully.
            let steps = config.max_iterations.min(ROBUST_STEPS);
            let fit = fit(&frames, &weights, state, &intrinsics, steps)?;
            iterations += fit.iterations;
            state = fit.state;
            let residuals = residuals(&frames, &state);
            let scale2 = CAUCHY_SCALE * CAUCHY_SCALE * robust_variance(&residuals, &masks);
            weights = residuals
                .iter()
                .map(|rs| {
                    rs.iter()
                        .map(|r| 1.0 / (1.0 + (r[0] * r[0] + r[1] * r[1]) / scale2))
                        .collect()
                })
                .collect();
        }
    }
    loop {
        rounds += 1;
        let fit = fit(
            &frames,
            &as_weights(&masks),
            state,
            &intrinsics,
            config.max_iterations,
        )?;
        iterations += fit.iterations;
        state = fit.state;
        let Some(threshold) = clip else { break };
        let residuals = residuals(&frames, &state);
        let sigma2 = robust_variance(&residuals, &masks);
        let next: Vec<Vec<bool>> = residuals
            .iter()
            .map(|rs| {
                rs.iter()
                    .map(|r| r[0] * r[0] + r[1] * r[1] <= threshold * sigma2)
                    .collect()
            })
            .collect();
        let kept: usize = next.iter().flatten().filter(|&&k| k).count();
        if next == masks || rounds >= 20 || 2 * kept <= n_params {
            break;
        }
        masks = next;
    }
    let camera = checked(&state.camera)?;
    let residuals_px = residuals(&frames, &state);
    let covariance = covariance(&frames, &masks, &state, &intrinsics, n_params);
    let n = intrinsics.len();
    if (0..n).any(|i| !(covariance[i * n + i] > 0.0 && covariance[i * n + i].is_finite())) {
        let names: Vec<&str> = intrinsics.iter().map(|p| p.name()).collect();
        return Err(Error::invalid_input(format!(
            "the matches of {} frames cannot fix {}: their stars are too few or too close together",
            frames.len(),
            names.join(", ")
        )));
    }
    let frame_rms_px = residuals_px
        .iter()
        .zip(&masks)
        .map(|(rs, m)| rms(std::slice::from_ref(rs), std::slice::from_ref(m)))
        .collect();
    Ok(Calibration {
        camera,
        attitudes: state.attitudes,
        intrinsics,
        covariance,
        rms_before_px: f64::NAN,
        rms_px: rms(&residuals_px, &masks),
        frame_rms_px,
        residuals_px,
        inliers: masks,
        iterations,
        rounds,
    })
}

/// Rounds of the Cauchy-weighted start.
const ROBUST_ROUNDS: usize = 6;
/// Levenberg–Marquardt steps per round of the weighted start at most.
const ROBUST_STEPS: usize = 12;
/// The Cauchy loss's scale in robust σ.
const CAUCHY_SCALE: f64 = 2.0;

/// The frames checked, with mirrored frames' x reversed into the camera's own pixels.
fn prepared(frames: &[CalibrationFrame], camera: &Camera) -> Result<Vec<CalibrationFrame>> {
    if frames.is_empty() {
        return Err(Error::invalid_input("calibration needs at least one frame"));
    }
    frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            if f.pixels.len() != f.stars.len() {
                return Err(Error::invalid_input(format!(
                    "frame {i}: {} pixels but {} stars",
                    f.pixels.len(),
                    f.stars.len()
                )));
            }
            let finite = f.pixels.iter().flatten().all(|v| v.is_finite())
                && f.stars.iter().all(|s| s.iter().all(|v| v.is_finite()));
            if !finite {
                return Err(Error::invalid_input(format!(
                    "frame {i}: pixels and stars must be finite"
                )));
            }
            let pixels = if f.mirrored {
                f.pixels
                    .iter()
                    .map(|p| [camera.width_px - p[0], p[1]])
                    .collect()
            } else {
                f.pixels.clone()
            };
            let stars = f.stars.iter().map(|s| s.normalize()).collect();
            Ok(CalibrationFrame {
                pixels,
                stars,
                ..f.clone()
            })
        })
        .collect()
}

/// The fitted camera, checked against the model's range.
fn checked(c: &Camera) -> Result<Camera> {
    let fitted = Camera::from_focal_length(c.focal_length_px, c.width_px, c.height_px)
        .and_then(|cam| cam.with_principal_point(c.principal_point_px[0], c.principal_point_px[1]))
        .and_then(|cam| cam.with_k1(c.k1))
        .and_then(|cam| cam.with_higher_distortion(c.higher_distortion()));
    fitted.map_err(|e| {
        Error::invalid_input(format!(
            "the calibration left the camera model's range ({e}): too few or badly spread stars?"
        ))
    })
}

/// `|r|²/σ²` beyond which a 2-D residual is clipped: the χ²₂ quantile whose tail equals a
/// normal variable's two-sided tail beyond `clip_sigma`; `None` for no clipping.
fn clip_threshold(clip_sigma: f64) -> Option<f64> {
    if clip_sigma == 0.0 || !clip_sigma.is_finite() {
        return None;
    }
    // P(χ²₂ > t) = exp(−t/2) = erfc(s/√2).
    let tail = erfc(clip_sigma / std::f64::consts::SQRT_2);
    Some(-2.0 * tail.max(f64::MIN_POSITIVE).ln())
}

/// The complementary error function (Numerical Recipes' Chebyshev fit, relative error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Per-axis variance from the median squared residual of the kept matches (`χ²₂`'s median is
/// `2 ln 2`), robust to the outliers the clipping is looking for.
fn robust_variance(residuals: &[Vec<[f64; 2]>], masks: &[Vec<bool>]) -> f64 {
    let mut sq: Vec<f64> = residuals
        .iter()
        .zip(masks)
        .flat_map(|(rs, m)| {
            rs.iter()
                .zip(m)
                .filter(|(_, &k)| k)
                .map(|(r, _)| r[0] * r[0] + r[1] * r[1])
        })
        .collect();
    if sq.is_empty() {
        return f64::INFINITY;
    }
    let mid = sq.len() / 2;
    let (_, median, _) = sq.select_nth_unstable_by(mid, f64::total_cmp);
    *median / (2.0 * std::f64::consts::LN_2)
}

fn rms(residuals: &[Vec<[f64; 2]>], masks: &[Vec<bool>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for (rs, m) in residuals.iter().zip(masks) {
        for (r, _) in rs.iter().zip(m).filter(|(_, &k)| k) {
            sum += r[0] * r[0] + r[1] * r[1];
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        (sum / (2 * n) as f64).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::solve::linearised;
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn clip_threshold_matches_the_normal_tail() {
        // 3σ two-sided: tail 0.0027, so exp(−t/2) = 0.0027.
        let t = clip_threshold(3.0).unwrap();
        assert!((t - 11.829).abs() < 0.01, "{t}");
        assert!(clip_threshold(0.0).is_none());
        assert!((erfc(0.0) - 1.0).abs() < 1e-7 && (erfc(-1.0) - 1.842_700_8).abs() < 1e-6);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let cam = Camera::from_focal_length(900.0, 1000.0, 800.0)
            .unwrap()
            .with_principal_point(510.0, 395.0)
            .unwrap()
            .with_k1(-0.12)
            .unwrap()
            .with_higher_distortion([0.03, -0.01, 2e-3, -1e-3])
            .unwrap();
        let all = CalibrationConfig::default().intrinsics();
        let w = Vector3::new(0.21, -0.17, 1.0).normalize();
        let mut js = vec![[0.0; 2]; all.len()];
        let (p0, ja) = linearised(&cam, &w, &all, &mut js).unwrap();
        for (k, p) in all.iter().enumerate() {
            let h = 1e-6 * p.value(&cam).abs().max(1e-3);
            let mut c = cam;
            p.set(&mut c, p.value(&cam) + h);
            let (x, y) = c.cam_to_pixel(&w).unwrap();
            let num = [(x - p0[0]) / h, (y - p0[1]) / h];
            for a in 0..2 {
                assert!(
                    (num[a] - js[k][a]).abs() < 1e-4 * (1.0 + num[a].abs()),
                    "{p:?} {num:?} {:?}",
                    js[k]
                );
            }
        }
        for i in 0..3 {
            let mut d = Vector3::zeros();
            d[i] = 1e-7;
            let (x, y) = cam.cam_to_pixel(&(Rotation3::new(d) * w)).unwrap();
            let num = [(x - p0[0]) / 1e-7, (y - p0[1]) / 1e-7];
            for a in 0..2 {
                assert!(
                    (num[a] - ja[a][i]).abs() < 1e-3 * (1.0 + num[a].abs()),
                    "{i} {num:?} {ja:?}"
                );
            }
        }
    }
}
