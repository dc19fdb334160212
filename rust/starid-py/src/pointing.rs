//! Pointing and focal length (`starid.pointing`) and identification with an unknown field of view.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::errors::{InvalidInputError, PyStaridError};
use pyo3::types::{PyDict, PyList};
use starid_core::geometry::{radec_to_unit, unit_to_radec};
use starid_core::pointing::{self, PointingFit, RefineOptions};
use starid_core::{geometry, Camera, IdentifyConfig};

use crate::catalog::PyCatalog;
use crate::outcome::PyIdentification;
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
) -> PyResult<Bound<'py, PyList>> {
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
    let out = PyList::empty(py);
    for s in &sols {
        let d = PyDict::new(py);
        let (ra, dec) = unit_to_radec(&s.boresight);
        d.set_item("ra_deg", ra.to_degrees())?;
        d.set_item("dec_deg", dec.to_degrees())?;
        d.set_item("focal_px", s.focal_length_px)?;
        d.set_item("rms_px", s.rms_px)?;
        d.set_item("residuals_px", s.residuals_px.clone().into_pyarray(py))?;
        d.set_item("iterations", s.iterations)?;
        d.set_item("converged", s.converged)?;
        d.set_item("ambiguous", s.ambiguous)?;
        d.set_item("degenerate", s.degenerate)?;
        d.set_item("condition", s.condition)?;
        d.set_item("inconsistent", s.inconsistent)?;
        d.set_item("boresight_sigma_rad_per_px", s.boresight_sigma_rad(1.0))?;
        match &s.unit_covariance {
            Some(c) => d.set_item("unit_covariance", matrix(py, c))?,
            None => d.set_item("unit_covariance", py.None())?,
        }
        out.append(d)?;
    }
    Ok(out)
}

pub fn fit_dict<'py>(
    py: Python<'py>,
    fit: &PointingFit,
    width_px: f64,
    mirrored: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let (ra, dec, roll) = geometry::radec_roll_from_attitude(&fit.r_icrs_to_cam);
    d.set_item("ra_deg", ra.to_degrees())?;
    d.set_item("dec_deg", dec.to_degrees())?;
    d.set_item("roll_deg", roll.to_degrees())?;
    outcome::put_rotation(&d, &fit.r_icrs_to_cam)?;
    d.set_item("focal_px", fit.camera.focal_length_px)?;
    d.set_item(
        "fov_deg",
        (2.0 * (0.5 * width_px / fit.camera.focal_length_px).atan()).to_degrees(),
    )?;
    d.set_item(
        "principal_point_px",
        (
            fit.camera.principal_point_px[0],
            fit.camera.principal_point_px[1],
        ),
    )?;
    d.set_item("k1", fit.camera.k1)?;
    d.set_item("parameters", fit.parameters.clone())?;
    match &fit.covariance {
        Some(c) => d.set_item("covariance", matrix(py, c))?,
        None => d.set_item("covariance", py.None())?,
    }
    let arcsec = 180.0 / std::f64::consts::PI * 3600.0;
    d.set_item("boresight_sigma_arcsec", fit.boresight_sigma_rad() * arcsec)?;
    d.set_item("roll_sigma_arcsec", fit.roll_sigma_rad() * arcsec)?;
    d.set_item("focal_sigma_px", fit.focal_sigma_px())?;
    d.set_item("sigma_px", fit.sigma_px)?;
    let flat: Vec<f64> = fit.residuals_px.iter().flat_map(|r| [r[0], r[1]]).collect();
    d.set_item(
        "residuals_px",
        Array2::from_shape_vec((fit.residuals_px.len(), 2), flat)
            .expect("shape")
            .into_pyarray(py),
    )?;
    d.set_item("rms_px", fit.rms_px)?;
    d.set_item("iterations", fit.iterations)?;
    d.set_item("converged", fit.converged)?;
    d.set_item("mirrored", mirrored)?;
    Ok(d)
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
) -> PyResult<Bound<'py, PyDict>> {
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
    fit_dict(py, &fit, width_px, mirrored)
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
