//! The precision the geometry of distance measurements allows: the predicted covariance of a
//! boresight from star-image distances, the choice of the stars that give the best one, and a
//! Monte Carlo check of the prediction.

use nalgebra::{DMatrix, DVector, Vector3};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::distances::*;
use super::{check_focal, MAX_STARS};
use crate::error::{Error, Result};
use crate::lsq;

/// Covariance of the distance solution predicted from the images' offsets from the principal
/// point (pixels), the focal length and the noise on each distance: `σ²(JᵀJ)⁻¹` with parameters
/// (boresight along the camera x axis, along the camera y axis[, focal length px]), the
/// boresight components in radians. `None` when the geometry does not determine them.
///
/// # Errors
/// `InvalidInput` for non-finite offsets, fewer stars than parameters, or a bad focal length or
/// noise.
///
/// # Example
/// ```
/// use starid_core::pointing::predicted_distance_covariance;
/// let spread = [[230.0, 20.0], [-115.0, 199.0], [-120.0, -195.0]];
/// let c = predicted_distance_covariance(&spread, 2435.0, 0.1, false).unwrap().unwrap();
/// assert!(c[(0, 0)] > 0.0 && c[(1, 1)] > 0.0);
/// ```
pub fn predicted_distance_covariance(
    offsets_px: &[[f64; 2]],
    focal_px: f64,
    sigma_px: f64,
    fit_focal: bool,
) -> Result<Option<DMatrix<f64>>> {
    check_focal(focal_px)?;
    if !sigma_px.is_finite() || sigma_px <= 0.0 {
        return Err(Error::invalid_input(format!(
            "sigma_px must be positive and finite, got {sigma_px}"
        )));
    }
    let p = if fit_focal { 3 } else { 2 };
    if offsets_px.len() < 3 {
        return Err(Error::invalid_input(format!(
            "need at least 3 stars, got {}",
            offsets_px.len()
        )));
    }
    if offsets_px.len() > MAX_STARS || offsets_px.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::invalid_input(
            "offsets must be finite and at most 100000",
        ));
    }
    let j = distance_jacobian(offsets_px, focal_px, p);
    Ok(lsq::inverse_normal_matrix(&j).map(|c| c * (sigma_px * sigma_px)))
}

fn distance_jacobian(offsets_px: &[[f64; 2]], f: f64, p: usize) -> DMatrix<f64> {
    let mut j = DMatrix::zeros(offsets_px.len(), p);
    for (i, o) in offsets_px.iter().enumerate() {
        let a = o[0].hypot(o[1]);
        if a > 0.0 {
            let w = f + a * a / f;
            j[(i, 0)] = -w * o[0] / a;
            j[(i, 1)] = -w * o[1] / a;
        }
        if p == 3 {
            j[(i, 2)] = a / f;
        }
    }
    j
}

/// Predicted boresight variance (trace of the 2×2 block) of a set of stars; infinite when
/// undetermined.
fn boresight_variance(offsets_px: &[[f64; 2]], f: f64, p: usize) -> f64 {
    let j = distance_jacobian(offsets_px, f, p);
    match lsq::inverse_normal_matrix(&j) {
        Some(c) => c[(0, 0)] + c[(1, 1)],
        None => f64::INFINITY,
    }
}

/// The `count` stars of a frame (offsets from the principal point, pixels) whose distances give
/// the most precise boresight (smallest predicted variance): the best triple by exhaustive
/// search, then greedily the star that lowers the variance most. Returns the indices (ascending)
/// and the predicted 1σ boresight error for 1 px of noise, radians.
///
/// # Errors
/// `InvalidInput` for `count < 3`, more stars asked than given, more than 300 stars, non-finite
/// offsets, or a bad focal length; and when no triple determines the boresight (all collinear
/// through the principal point).
///
/// # Example
/// ```
/// let offsets = [[10.0, 5.0], [25.0, -12.0], [-8.0, 20.0], [240.0, 10.0], [-115.0, 205.0], [-125.0, -200.0]];
/// let (chosen, _sigma) = starid_core::pointing::choose_stars(&offsets, 2435.0, 3, false).unwrap();
/// assert_eq!(chosen, vec![3, 4, 5]); // the edge stars, spread around the centre
/// ```
pub fn choose_stars(
    offsets_px: &[[f64; 2]],
    focal_px: f64,
    count: usize,
    fit_focal: bool,
) -> Result<(Vec<usize>, f64)> {
    check_focal(focal_px)?;
    let n = offsets_px.len();
    if count < 3 || count > n {
        return Err(Error::invalid_input(format!(
            "choose between 3 and {n} stars, asked for {count}"
        )));
    }
    if n > 300 {
        return Err(Error::invalid_input(format!(
            "star choice searches all triples: at most 300 stars, got {n}"
        )));
    }
    if offsets_px.iter().flatten().any(|v| !v.is_finite()) {
        return Err(Error::invalid_input("offsets must be finite"));
    }
    let p = if fit_focal { 3 } else { 2 };
    let mut best = (f64::INFINITY, [0usize; 3]);
    for i in 0..n {
        for j in (i + 1)..n {
            for k in (j + 1)..n {
                let v =
                    boresight_variance(&[offsets_px[i], offsets_px[j], offsets_px[k]], focal_px, p);
                if v < best.0 {
                    best = (v, [i, j, k]);
                }
            }
        }
    }
    if !best.0.is_finite() {
        return Err(Error::invalid_input(
            "no three of these stars determine the boresight (all on one line through the principal point)",
        ));
    }
    let mut chosen: Vec<usize> = best.1.to_vec();
    let mut variance = best.0;
    while chosen.len() < count {
        let mut pick = (f64::INFINITY, usize::MAX);
        for c in (0..n).filter(|c| !chosen.contains(c)) {
            let set: Vec<[f64; 2]> = chosen
                .iter()
                .chain(std::iter::once(&c))
                .map(|&s| offsets_px[s])
                .collect();
            let v = boresight_variance(&set, focal_px, p);
            if v < pick.0 {
                pick = (v, c);
            }
        }
        chosen.push(pick.1);
        variance = pick.0;
    }
    chosen.sort_unstable();
    Ok((chosen, variance.sqrt()))
}

/// Monte Carlo check of [`predicted_distance_covariance`]: the images at `offsets_px` are
/// placed on a random sky (a random attitude), `trials` sets of distances are perturbed with
/// Gaussian noise of `sigma_px`, each is solved with [`boresight_from_distances`], and the
/// scatter of the best solution around the truth is compared with the prediction.
#[derive(Debug, Clone)]
pub struct MonteCarlo {
    /// Predicted covariance (camera x, camera y[, focal px]), radians² / px².
    pub predicted: DMatrix<f64>,
    /// Sample covariance of the same parameters over the successful trials.
    pub sample: DMatrix<f64>,
    /// Trials whose best solution was another branch (more than 10 predicted σ off), or failed.
    pub outliers: usize,
    /// Trials run.
    pub trials: usize,
}

/// Run the Monte Carlo described at [`MonteCarlo`].
///
/// # Errors
/// As [`predicted_distance_covariance`]; `InvalidInput` when the geometry is degenerate or
/// `trials` is not in `2..=1_000_000`.
///
/// # Example
/// ```
/// let spread = [[230.0, 20.0], [-115.0, 199.0], [-120.0, -195.0]];
/// let mc = starid_core::pointing::monte_carlo_distances(&spread, 2435.0, 0.1, false, 300, 1).unwrap();
/// let ratio = ((mc.sample[(0, 0)] + mc.sample[(1, 1)]) / (mc.predicted[(0, 0)] + mc.predicted[(1, 1)])).sqrt();
/// assert!(ratio > 0.8 && ratio < 1.2);
/// ```
pub fn monte_carlo_distances(
    offsets_px: &[[f64; 2]],
    focal_px: f64,
    sigma_px: f64,
    fit_focal: bool,
    trials: usize,
    seed: u64,
) -> Result<MonteCarlo> {
    if !(2..=1_000_000).contains(&trials) {
        return Err(Error::invalid_input(format!(
            "trials must be in 2..=1000000, got {trials}"
        )));
    }
    let predicted = predicted_distance_covariance(offsets_px, focal_px, sigma_px, fit_focal)?
        .ok_or_else(|| Error::invalid_input("the geometry does not determine the boresight"))?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let r = crate::geometry::random_rotation(&mut rng);
    let stars: Vec<Vector3<f64>> = offsets_px
        .iter()
        .map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], focal_px).normalize()))
        .collect();
    let truth = r.inverse_transform_vector(&Vector3::z());
    let (cx, cy) = (
        r.inverse_transform_vector(&Vector3::x()),
        r.inverse_transform_vector(&Vector3::y()),
    );
    let a0: Vec<f64> = offsets_px.iter().map(|o| o[0].hypot(o[1])).collect();
    let normal = Normal::new(0.0, sigma_px).map_err(|e| Error::invalid_input(e.to_string()))?;
    let p = predicted.nrows();
    let limit = 10.0 * (predicted[(0, 0)] + predicted[(1, 1)]).sqrt();
    let mut samples: Vec<DVector<f64>> = Vec::with_capacity(trials);
    let mut outliers = 0;
    for _ in 0..trials {
        let a: Vec<f64> = a0
            .iter()
            .map(|a| (a + normal.sample(&mut rng)).abs())
            .collect();
        let sols = boresight_from_distances(&stars, &a, (!fit_focal).then_some(focal_px));
        let Some(best) = sols.ok().and_then(|s| s.into_iter().next()) else {
            outliers += 1;
            continue;
        };
        let e = best.boresight - truth;
        let v = if p == 3 {
            DVector::from_vec(vec![
                e.dot(&cx),
                e.dot(&cy),
                best.focal_length_px - focal_px,
            ])
        } else {
            DVector::from_vec(vec![e.dot(&cx), e.dot(&cy)])
        };
        if v[0].hypot(v[1]) > limit {
            outliers += 1;
            continue;
        }
        samples.push(v);
    }
    let m = samples.len().max(2) as f64;
    let mean = samples.iter().fold(DVector::zeros(p), |acc, v| acc + v) / m;
    let sample = samples.iter().fold(DMatrix::zeros(p, p), |acc, v| {
        let d = v - &mean;
        acc + &d * d.transpose()
    }) / (m - 1.0);
    Ok(MonteCarlo {
        predicted,
        sample,
        outliers,
        trials,
    })
}
