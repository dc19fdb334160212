//! Pointing and focal length (`starid.pointing`) and identification with an unknown field of view.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::errors::{InvalidInputError, PyStaridError};
use pyo3::types::PyDict;
use starid_core::geometry::{radec_to_unit, unit_to_radec};
use starid_core::pointing::{self, PointingFit, RefineOptions};
use starid_core::{geometry, Camera, IdentifyConfig};

use crate::catalog::PyCatalog;
use crate::outcome::PyIdentification;
use crate::outcome::{py_bool, ARCSEC_PER_RAD};
use crate::{convert, outcome, run_core, PyIdentifyConfig};

fn matrix<'py>(py: Python<'py>, m: &nalgebra::DMatrix<f64>) -> Bound<'py, numpy::PyArray2<f64>> {
    let flat: Vec<f64> = (0..m.nrows())
        .flat_map(|i| (0..m.ncols()).map(move |j| m[(i, j)]))
        .collect();
    Array2::from_shape_vec((m.nrows(), m.ncols()), flat)
        .expect("shape")
        .into_pyarray(py)
}

fn directions(
    name: &str,
    radec_deg: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Vec<nalgebra::Vector3<f64>>> {
    let rows = convert::centroids(name, radec_deg).map_err(|_| {
        InvalidInputError::new_err(format!(
            "{name} must have shape (N, 2) holding (ra_deg, dec_deg)"
        ))
    })?;
    rows.iter()
        .enumerate()
        .map(|(i, r)| {
            if !r[0].is_finite() || !r[1].is_finite() || r[1].abs() > 90.0 {
                Err(InvalidInputError::new_err(format!(
                    "{name} row {i} must be a finite RA and a declination in [-90, 90] degrees, got ({}, {})",
                    r[0], r[1]
                )))
            } else {
                Ok(radec_to_unit(r[0].to_radians(), r[1].to_radians()))
            }
        })
        .collect()
}

/// Boresight from three (or more) stars' RA/Dec and their distances from the principal point.
#[pyfunction]
#[pyo3(signature = (radec_deg, distances_px, focal_px=None, focal_range_px=None))]
pub fn boresight_from_distances<'py>(
    py: Python<'py>,
    radec_deg: PyReadonlyArray2<'py, f64>,
    distances_px: PyReadonlyArray1<'py, f64>,
    focal_px: Option<f64>,
    focal_range_px: Option<(f64, f64)>,
) -> PyResult<Vec<PyBoresightSolution>> {
    let stars = directions("radec_deg", &radec_deg)?;
    let a = convert::vector("distances_px", &distances_px, Some(stars.len()))?;
    if focal_px.is_some() && focal_range_px.is_some() {
        return Err(InvalidInputError::new_err(
            "focal_range_px only applies when focal_px is not given",
        ));
    }
    let sols = run_core(py, move || match focal_range_px {
        Some(range) => pointing::boresight_from_distances_in_range(&stars, &a, range),
        None => pointing::boresight_from_distances(&stars, &a, focal_px),
    })?;
    Ok(sols
        .into_iter()
        .enumerate()
        .map(|(i, solution)| PyBoresightSolution {
            solution,
            best: i == 0,
        })
        .collect())
}

/// One solution of ``starid.pointing.boresight_from_distances``; immutable.
///
/// Attributes
/// ----------
/// ra_deg, dec_deg : float
///     The boresight.
/// focal_px : float
///     The focal length: the given one, or the estimate.
/// rms_px, residuals_px :
///     Misfit of each star's distance (``f·tan(angle) − a``), pixels: the support of the solution.
/// best : bool
///     The best supported solution (smallest rms); the list is sorted so it comes first.
/// ambiguous : bool
///     Another solution fits as well: distances alone cannot tell them apart.
/// degenerate : bool
///     The geometry leaves a direction (nearly) undetermined; do not trust this solution.
/// inconsistent : bool
///     The distances cannot all be met: the best fit still misses them by more than
///     ``INCONSISTENT_RMS_PX`` (rms). The solution is the least-squares compromise of
///     distances that do not belong together (a wrong star, a wrong focal length).
/// condition : float
///     Reciprocal condition of the problem at the solution (1 ideal, 0 singular).
/// unit_covariance : ndarray or None
///     Covariance for 1 px of distance noise: boresight east and north (radians) and, when
///     estimated, the focal length (pixels). Scale by ``sigma_px**2``.
#[pyclass(frozen, name = "BoresightSolution", module = "starid.pointing")]
pub struct PyBoresightSolution {
    solution: pointing::DistanceSolution,
    best: bool,
}

#[pymethods]
impl PyBoresightSolution {
    #[getter]
    fn ra_deg(&self) -> f64 {
        unit_to_radec(&self.solution.boresight).0.to_degrees()
    }
    #[getter]
    fn dec_deg(&self) -> f64 {
        unit_to_radec(&self.solution.boresight).1.to_degrees()
    }
    #[getter]
    fn focal_px(&self) -> f64 {
        self.solution.focal_length_px
    }
    #[getter]
    fn rms_px(&self) -> f64 {
        self.solution.rms_px
    }
    #[getter]
    fn residuals_px<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        self.solution.residuals_px.clone().into_pyarray(py)
    }
    #[getter]
    fn best(&self) -> bool {
        self.best
    }
    #[getter]
    fn ambiguous(&self) -> bool {
        self.solution.ambiguous
    }
    #[getter]
    fn degenerate(&self) -> bool {
        self.solution.degenerate
    }
    #[getter]
    fn condition(&self) -> f64 {
        self.solution.condition
    }
    #[getter]
    fn converged(&self) -> bool {
        self.solution.converged
    }
    #[getter]
    fn iterations(&self) -> usize {
        self.solution.iterations
    }
    #[getter]
    fn unit_covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, numpy::PyArray2<f64>>> {
        self.solution
            .unit_covariance
            .as_ref()
            .map(|c| matrix(py, c))
    }
    #[getter]
    fn inconsistent(&self) -> bool {
        self.solution.inconsistent
    }
    /// The core's 1σ boresight error for 1 px of noise on each distance, radians.
    #[getter]
    fn boresight_sigma_rad_per_px(&self) -> f64 {
        self.solution.boresight_sigma_rad(1.0)
    }
    /// Predicted 1σ boresight error (arcsec) for ``sigma_px`` of noise on each distance
    /// (infinite when degenerate).
    fn boresight_sigma_arcsec(&self, sigma_px: f64) -> f64 {
        self.solution.boresight_sigma_rad(sigma_px) * ARCSEC_PER_RAD
    }

    fn __repr__(&self) -> String {
        format!(
            "BoresightSolution(ra_deg={:.6}, dec_deg={:.6}, focal_px={:.3}, rms_px={:.4}, best={}, ambiguous={}, degenerate={})",
            self.ra_deg(),
            self.dec_deg(),
            self.solution.focal_length_px,
            self.solution.rms_px,
            py_bool(self.best),
            py_bool(self.solution.ambiguous),
            py_bool(self.solution.degenerate)
        )
    }
}

/// Attitude and camera fitted to matched stars (``starid.pointing.fit_pointing``,
/// ``starid.pointing.refine``); immutable.
///
/// ``covariance`` is over ``parameters``: ``rot_x, rot_y, rot_z`` (small rotations about the
/// camera axes, radians), then as fitted ``focal_px``, ``cx_px``, ``cy_px``, ``k1``;
/// ``sigma_px`` is the centroid noise it assumes (given, or estimated from the residuals).
#[pyclass(frozen, name = "PointingFit", module = "starid.pointing")]
pub struct PyPointingFit {
    fit: PointingFit,
    mirrored: bool,
}

#[pymethods]
impl PyPointingFit {
    /// Right ascension of the boresight, degrees.
    #[getter]
    fn ra_deg(&self) -> f64 {
        geometry::radec_roll_from_attitude(&self.fit.r_icrs_to_cam)
            .0
            .to_degrees()
    }
    /// Declination of the boresight, degrees.
    #[getter]
    fn dec_deg(&self) -> f64 {
        geometry::radec_roll_from_attitude(&self.fit.r_icrs_to_cam)
            .1
            .to_degrees()
    }
    /// Roll about the boresight, degrees.
    #[getter]
    fn roll_deg(&self) -> f64 {
        geometry::radec_roll_from_attitude(&self.fit.r_icrs_to_cam)
            .2
            .to_degrees()
    }
    /// The attitude ICRS → camera as a unit quaternion ``[w, x, y, z]``.
    #[getter]
    fn quaternion<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray1<f64>> {
        geometry::quaternion_wxyz(&self.fit.r_icrs_to_cam)
            .to_vec()
            .into_pyarray(py)
    }
    /// The attitude ICRS → camera as a 3 × 3 rotation matrix.
    #[getter]
    fn rotation_matrix<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        outcome::matrix3(&self.fit.r_icrs_to_cam).into_pyarray(py)
    }
    /// Focal length, pixels.
    #[getter]
    fn focal_px(&self) -> f64 {
        self.fit.camera.focal_length_px
    }
    /// Field of view across the width, degrees.
    #[getter]
    fn fov_deg(&self) -> f64 {
        self.fit.camera.fov_rad().to_degrees()
    }
    /// Principal point ``(x, y)``, pixels.
    #[getter]
    fn principal_point_px(&self) -> (f64, f64) {
        let [x, y] = self.fit.camera.principal_point_px;
        (x, y)
    }
    /// Radial distortion coefficient.
    #[getter]
    fn k1(&self) -> f64 {
        self.fit.camera.k1
    }
    /// The fitted parameters' names, in ``covariance`` order.
    #[getter]
    fn parameters(&self) -> Vec<&'static str> {
        self.fit.parameters.clone()
    }
    /// Covariance of ``parameters`` (None where the fit does not determine them).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Option<Bound<'py, numpy::PyArray2<f64>>> {
        self.fit.covariance.as_ref().map(|c| matrix(py, c))
    }
    /// 1σ error of the boresight, arcseconds.
    #[getter]
    fn boresight_sigma_arcsec(&self) -> f64 {
        self.fit.boresight_sigma_rad() * ARCSEC_PER_RAD
    }
    /// 1σ error of the roll, arcseconds.
    #[getter]
    fn roll_sigma_arcsec(&self) -> f64 {
        self.fit.roll_sigma_rad() * ARCSEC_PER_RAD
    }
    /// 1σ error of the focal length, pixels.
    #[getter]
    fn focal_sigma_px(&self) -> f64 {
        self.fit.focal_sigma_px()
    }
    /// The centroid noise the covariance assumes, pixels.
    #[getter]
    fn sigma_px(&self) -> f64 {
        self.fit.sigma_px
    }
    /// Residuals (observed − model) per star, pixels, shape (N, 2).
    #[getter]
    fn residuals_px<'py>(&self, py: Python<'py>) -> Bound<'py, numpy::PyArray2<f64>> {
        let r = &self.fit.residuals_px;
        Array2::from_shape_fn((r.len(), 2), |(i, k)| r[i][k]).into_pyarray(py)
    }
    /// Root mean square residual per axis, pixels.
    #[getter]
    fn rms_px(&self) -> f64 {
        self.fit.rms_px
    }
    /// Iterations taken.
    #[getter]
    fn iterations(&self) -> usize {
        self.fit.iterations
    }
    /// Whether the iteration converged.
    #[getter]
    fn converged(&self) -> bool {
        self.fit.converged
    }
    /// Whether the image was fitted x-reversed.
    #[getter]
    fn mirrored(&self) -> bool {
        self.mirrored
    }

    fn __repr__(&self) -> String {
        format!(
            "PointingFit(ra_deg={:.6}, dec_deg={:.6}, roll_deg={:.6}, fov_deg={:.6}, rms_px={:.4}, converged={})",
            self.ra_deg(),
            self.dec_deg(),
            self.roll_deg(),
            self.fov_deg(),
            self.fit.rms_px,
            py_bool(self.fit.converged)
        )
    }
}

/// Attitude and camera from matched stars (RA/Dec and pixel positions), by Levenberg–Marquardt.
#[pyfunction]
#[pyo3(signature = (radec_deg, xy, width_px, height_px, focal_px, fit_focal, fit_principal_point,
                    fit_k1, mirrored, sigma_px))]
pub fn fit_pointing<'py>(
    py: Python<'py>,
    radec_deg: PyReadonlyArray2<'py, f64>,
    xy: PyReadonlyArray2<'py, f64>,
    width_px: f64,
    height_px: f64,
    focal_px: Option<f64>,
    fit_focal: bool,
    fit_principal_point: bool,
    fit_k1: bool,
    mirrored: bool,
    sigma_px: Option<f64>,
) -> PyResult<PyPointingFit> {
    let stars = directions("radec_deg", &radec_deg)?;
    let xy = convert::centroids("xy", &xy)?;
    let options = RefineOptions {
        fit_focal,
        fit_principal_point,
        fit_k1,
        mirrored,
        sigma_px,
        ..RefineOptions::default()
    };
    let fit = run_core(py, move || {
        pointing::fit_pointing(&stars, &xy, width_px, height_px, focal_px, &options)
    })?;
    Ok(PyPointingFit { fit, mirrored })
}

/// Predicted covariance of the distance solution for image offsets from the principal point.
#[pyfunction]
pub fn predicted_distance_covariance<'py>(
    py: Python<'py>,
    offsets_px: PyReadonlyArray2<'py, f64>,
    focal_px: f64,
    sigma_px: f64,
    fit_focal: bool,
) -> PyResult<Option<Bound<'py, numpy::PyArray2<f64>>>> {
    let off = convert::centroids("offsets", &offsets_px)?;
    let c = run_core(py, move || {
        pointing::predicted_distance_covariance(&off, focal_px, sigma_px, fit_focal)
    })?;
    Ok(c.map(|c| matrix(py, &c)))
}

/// The stars giving the most precise boresight; returns (indices, sigma rad per px).
#[pyfunction]
pub fn choose_stars(
    py: Python<'_>,
    offsets_px: PyReadonlyArray2<'_, f64>,
    focal_px: f64,
    count: usize,
    fit_focal: bool,
) -> PyResult<(Vec<usize>, f64)> {
    let off = convert::centroids("offsets", &offsets_px)?;
    run_core(py, move || {
        pointing::choose_stars(&off, focal_px, count, fit_focal)
    })
}

/// Monte Carlo check of the predicted covariance.
#[pyfunction]
pub fn monte_carlo_distances<'py>(
    py: Python<'py>,
    offsets_px: PyReadonlyArray2<'py, f64>,
    focal_px: f64,
    sigma_px: f64,
    fit_focal: bool,
    trials: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let off = convert::centroids("offsets", &offsets_px)?;
    let mc = run_core(py, move || {
        pointing::monte_carlo_distances(&off, focal_px, sigma_px, fit_focal, trials, seed)
    })?;
    let d = PyDict::new(py);
    d.set_item("predicted", matrix(py, &mc.predicted))?;
    d.set_item("sample", matrix(py, &mc.sample))?;
    d.set_item("outliers", mc.outliers)?;
    d.set_item("trials", mc.trials)?;
    Ok(d)
}

/// Identify a frame whose field of view lies in [fov_lo_deg, fov_hi_deg]. Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (catalog, xy, magnitudes, width_px, height_px, fov_lo_deg, fov_hi_deg, config))]
pub fn identify_unknown_fov<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: PyReadonlyArray2<'py, f64>,
    magnitudes: Option<PyReadonlyArray1<'py, f64>>,
    width_px: f64,
    height_px: f64,
    fov_lo_deg: f64,
    fov_hi_deg: f64,
    config: &Bound<'py, PyIdentifyConfig>,
) -> PyResult<PyIdentification> {
    let (solver, range, widest) =
        unknown_fov_setup(py, catalog, width_px, height_px, fov_lo_deg, fov_hi_deg)?;
    let centroids = convert::centroids("xy", &xy)?;
    let mags = magnitudes
        .map(|m| convert::vector("magnitudes", &m, Some(centroids.len())))
        .transpose()?;
    let cfg = config.get().inner.clone();
    let r = crate::batch::watched(py, |cancel| {
        let cfg = IdentifyConfig {
            cancel: Some(cancel.clone()),
            ..cfg
        };
        solver.identify_unknown_focal(
            &centroids,
            mags.as_deref(),
            width_px,
            height_px,
            range,
            &cfg,
        )
    })?
    .map_err(PyStaridError)?;
    let (id, cam, sigma) = unknown_fov_result(r, &widest);
    Ok(PyIdentification::new(catalog.get(), id, &cam, sigma).with_spots(centroids, mags))
}

/// What a frame of an unknown field of view in `[fov_lo_deg, fov_hi_deg]` needs: the solver for
/// the widest field, the focal-length range (widest first) and the widest camera.
pub(crate) fn unknown_fov_setup(
    py: Python<'_>,
    catalog: &Bound<'_, PyCatalog>,
    width_px: f64,
    height_px: f64,
    fov_lo_deg: f64,
    fov_hi_deg: f64,
) -> PyResult<(std::sync::Arc<starid_core::Solver>, (f64, f64), Camera)> {
    if !(fov_lo_deg.is_finite()
        && fov_hi_deg.is_finite()
        && 0.0 < fov_lo_deg
        && fov_lo_deg <= fov_hi_deg
        && fov_hi_deg < 179.0)
    {
        return Err(InvalidInputError::new_err(format!(
            "fov_range_deg must be (lo, hi) with 0 < lo <= hi < 179 degrees, got ({fov_lo_deg}, {fov_hi_deg})"
        )));
    }
    let widest = crate::camera(fov_hi_deg, width_px, height_px)?;
    let narrowest = crate::camera(fov_lo_deg, width_px, height_px)?;
    let solver = catalog.get().solver(py, widest.diagonal_fov_rad())?;
    Ok((
        solver,
        (widest.focal_length_px, narrowest.focal_length_px),
        widest,
    ))
}

/// The sensor of `widest` with its focal length unknown (NaN): the camera of a frame nothing
/// identified.
pub(crate) fn focal_unknown(widest: &Camera) -> Camera {
    Camera {
        focal_length_px: f64::NAN,
        ..*widest
    }
}

/// A result of an unknown field: the identification, the camera found (or [`focal_unknown`])
/// and the focal length's 1σ.
pub(crate) fn unknown_fov_result(
    r: starid_core::FocalIdentification,
    widest: &Camera,
) -> (starid_core::Identification, Camera, f64) {
    let sigma = r.fit.as_ref().map_or(f64::NAN, PointingFit::focal_sigma_px);
    let cam = r.camera.unwrap_or_else(|| focal_unknown(widest));
    (r.identification, cam, sigma)
}
