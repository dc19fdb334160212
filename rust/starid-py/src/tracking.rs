//! Hinted identification, the `Tracker` and simulated sequences.

use std::sync::{Arc, Mutex};

use nalgebra::Rotation3;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use starid_core::simulate::{simulate_sequence as core_sequence, SequenceConfig};
use starid_core::tracking::{Tracker, TrackerConfig};
use starid_core::{geometry, AttitudeHint, HintFallback, SimConfig, Solver};

use crate::camera::PyCamera;
use crate::catalog::PyCatalog;
use crate::errors::{InvalidInputError, PyStaridError};
use crate::outcome::{self, PyIdentification};
use crate::{convert, run_core, PyIdentifyConfig};

/// A rotation from `[w, x, y, z]`.
fn rotation(q: [f64; 4]) -> PyResult<Rotation3<f64>> {
    geometry::rotation_from_wxyz(q).map_err(|e| PyStaridError(e).into())
}

/// The core's hint from a quaternion `[w, x, y, z]`, an uncertainty in degrees and the
/// handedness if known.
pub(crate) fn hint(
    q: [f64; 4],
    uncertainty_deg: f64,
    mirrored: Option<bool>,
) -> PyResult<AttitudeHint> {
    Ok(AttitudeHint {
        r_icrs_to_cam: rotation(q)?,
        uncertainty_rad: uncertainty_deg.to_radians(),
        mirrored,
    })
}

/// What a hinted search does when the hint explains nothing: lost in space, or no match.
pub(crate) fn fallback_of(lost_in_space: bool) -> HintFallback {
    if lost_in_space {
        HintFallback::LostInSpace
    } else {
        HintFallback::None
    }
}

/// Identify one frame from an attitude hint (quaternion `[w, x, y, z]` ICRS → camera).
#[pyfunction]
#[pyo3(signature = (catalog, xy, magnitudes, camera, config, hint_wxyz, uncertainty_deg, mirrored, fallback))]
pub fn identify_hinted<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: PyReadonlyArray2<'py, f64>,
    magnitudes: Option<PyReadonlyArray1<'py, f64>>,
    camera: &Bound<'py, PyCamera>,
    config: &Bound<'py, PyIdentifyConfig>,
    hint_wxyz: [f64; 4],
    uncertainty_deg: f64,
    mirrored: Option<bool>,
    fallback: bool,
) -> PyResult<PyIdentification> {
    let (centroids, mags) = convert::frame(&xy, magnitudes.as_ref())?;
    let hint = hint(hint_wxyz, uncertainty_deg, mirrored)?;
    let frame = (centroids, mags);
    identify_hinted_of(
        py,
        catalog,
        frame,
        camera,
        config,
        (hint, fallback_of(fallback)),
    )
}

/// [`identify_hinted`] of a frame (centroids and magnitudes) and a hint already read.
pub(crate) fn identify_hinted_of(
    py: Python<'_>,
    catalog: &Bound<'_, PyCatalog>,
    (centroids, mags): (Vec<[f64; 2]>, Option<Vec<f64>>),
    camera: &Bound<'_, PyCamera>,
    config: &Bound<'_, PyIdentifyConfig>,
    (hint, fb): (AttitudeHint, HintFallback),
) -> PyResult<PyIdentification> {
    let (cam, solver, cfg) = crate::frame_setup(py, catalog, camera, config)?;
    let (id, centroids, mags) = run_core(py, move || {
        solver
            .identify_hinted(&centroids, mags.as_deref(), &cam, &cfg, &hint, fb)
            .map(|id| (id, centroids, mags))
    })?;
    Ok(PyIdentification::new(catalog.get(), id, &cam, f64::NAN).with_spots(centroids, mags))
}

/// The core tracker with its solver and camera.
#[pyclass(name = "Tracker", module = "starid._starid")]
pub struct PyTracker {
    tracker: Mutex<Tracker>,
    solver: Arc<Solver>,
    camera: starid_core::Camera,
    catalog: Py<PyCatalog>,
}

#[pymethods]
impl PyTracker {
    #[new]
    #[pyo3(signature = (catalog, camera, config, max_rate_deg_s, min_uncertainty_deg, fallback, confirm_new_stars=false, confirm_unseen_frames=Some(starid_core::tracking::CONFIRM_UNSEEN_FRAMES)))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        catalog: &Bound<'_, PyCatalog>,
        camera: &Bound<'_, PyCamera>,
        config: &Bound<'_, PyIdentifyConfig>,
        max_rate_deg_s: f64,
        min_uncertainty_deg: f64,
        fallback: bool,
        confirm_new_stars: bool,
        confirm_unseen_frames: Option<u32>,
    ) -> PyResult<Self> {
        let cam = camera.get().inner;
        let tracker = Tracker::new(
            TrackerConfig {
                max_rate_rad_s: max_rate_deg_s.to_radians(),
                min_uncertainty_rad: min_uncertainty_deg.to_radians(),
                fallback,
                confirm_new_stars,
                confirm_unseen_frames,
            },
            config.get().inner.clone(),
        )
        .map_err(PyStaridError)?;
        Ok(Self {
            tracker: Mutex::new(tracker),
            solver: catalog.get().solver(py, cam.diagonal_fov_rad())?,
            camera: cam,
            catalog: catalog.clone().unbind(),
        })
    }

    /// Identify the frame at `t_s`; returns `(identification, mode, rate_deg_s or None,
    /// uncertainty_deg, predicted quaternion or None)`.
    #[pyo3(signature = (xy, t_s, magnitudes=None))]
    fn update<'py>(
        &self,
        py: Python<'py>,
        xy: Bound<'py, PyArray2<f64>>,
        t_s: f64,
        magnitudes: Option<Bound<'py, PyArray1<f64>>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let centroids = convert::centroids_of("xy", &xy)?;
        let mags = magnitudes
            .map(|m| convert::vector_of("magnitudes", &m, Some(centroids.len())))
            .transpose()?;
        let solver = self.solver.clone();
        let cam = self.camera;
        let step = py.detach(|| {
            let mut tracker = self
                .tracker
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            tracker.update(&solver, &centroids, mags.as_deref(), &cam, t_s)
        });
        let step = step.map_err(PyStaridError)?;
        let d = PyDict::new(py);
        let catalog = self.catalog.bind(py);
        d.set_item(
            "identification",
            PyIdentification::new(catalog.get(), step.identification, &cam, f64::NAN)
                .with_spots(centroids, mags),
        )?;
        d.set_item("mode", step.mode.as_str())?;
        d.set_item(
            "rate_deg_s",
            step.rate_rad_s.map(|w| {
                vec![w.x.to_degrees(), w.y.to_degrees(), w.z.to_degrees()].into_pyarray(py)
            }),
        )?;
        d.set_item("uncertainty_deg", step.uncertainty_rad.to_degrees())?;
        d.set_item(
            "predicted_quaternion",
            step.predicted
                .map(|r| geometry::quaternion_wxyz(&r).to_vec().into_pyarray(py)),
        )?;
        Ok(d)
    }

    /// Forget the lock.
    fn reset(&self) {
        self.tracker
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .reset();
    }

    /// Whether a solution is held to predict from.
    #[getter]
    fn has_lock(&self) -> bool {
        self.tracker
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .has_lock()
    }
}

/// Simulate a slewing or tumbling sequence; returns a list of frame dicts with `t_s`.
#[pyfunction]
#[pyo3(signature = (catalog, camera, frames, seed, frame_rate_hz=10.0, rate_deg_s=1.0, jitter_deg=0.001,
                    exposure_s=0.02, blank=None, mag_limit=None, noise_px=0.5, mag_noise=0.1,
                    false_stars=0, false_stars_max=None, catalog_false_mags=true))]
pub fn simulate_sequence<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    camera: &Bound<'py, PyCamera>,
    frames: usize,
    seed: u64,
    frame_rate_hz: f64,
    rate_deg_s: f64,
    jitter_deg: f64,
    exposure_s: f64,
    blank: Option<(usize, usize)>,
    mag_limit: Option<f64>,
    noise_px: f64,
    mag_noise: f64,
    false_stars: usize,
    false_stars_max: Option<usize>,
    catalog_false_mags: bool,
) -> PyResult<Bound<'py, PyList>> {
    if frames > 1_000_000 {
        return Err(InvalidInputError::new_err(format!(
            "frames must be at most 1000000, got {frames}"
        )));
    }
    let cfg = SequenceConfig {
        frames,
        frame_rate_hz,
        rate_rad_s: rate_deg_s.to_radians(),
        jitter_rad: jitter_deg.to_radians(),
        exposure_s,
        blank: blank.map_or(0..0, |(a, b)| a..b),
        frame: SimConfig {
            mag_limit,
            noise_px,
            mag_noise,
            false_stars,
            false_stars_max,
            false_star_mags: if catalog_false_mags {
                starid_core::FalseStarMags::FromCatalog
            } else {
                starid_core::FalseStarMags::Uniform
            },
            ..Default::default()
        },
    };
    let cam = camera.get().inner;
    let cat = catalog.get().inner.clone();
    let seq = run_core(py, move || core_sequence(&cat, &cam, &cfg, seed))?;
    let out = PyList::empty(py);
    for f in &seq {
        let d = outcome::frame(py, &catalog.get().inner, &f.frame)?;
        d.set_item("t_s", f.t_s)?;
        out.append(d)?;
    }
    Ok(out)
}

/// `[w, x, y, z]` of the attitude at boresight (ra, dec) and roll, radians (the core's rule).
#[pyfunction]
pub fn quaternion_from_radec_roll(ra_rad: f64, dec_rad: f64, roll_rad: f64) -> [f64; 4] {
    geometry::quaternion_wxyz(&geometry::attitude_from_radec_roll(
        ra_rad, dec_rad, roll_rad,
    ))
}
