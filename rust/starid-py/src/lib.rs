//! `starid._starid`: Python bindings of starid-core.
//!
//! Conversion, validation, GIL handling and error mapping only; every algorithm lives in
//! starid-core. Long calls release the GIL through [`run_core`].
//!
//! Functions mirror Python signatures with many keyword arguments, hence the allowed lint.
#![allow(clippy::too_many_arguments)]

mod batch;
mod calibration;
mod camera;
mod catalog;
mod convert;
mod errors;
mod guide;
mod images;
mod outcome;
mod pointing;
mod tracking;

use std::sync::Arc;

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use starid_core::{geometry, simulate as sim, Camera, IdentifyConfig};

use crate::camera::PyCamera;
use crate::catalog::PyCatalog;
use crate::errors::{CatalogError, InvalidInputError, PyStaridError, StaridError};
use crate::outcome::PyIdentification;

/// Run core work with the GIL released and turn its error into the matching Python exception.
pub fn run_core<T, F>(py: Python<'_>, f: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> starid_core::Result<T> + Send,
{
    py.detach(f).map_err(|e| PyStaridError(e).into())
}

/// A whole number setting (an int, or a float with an integral value) in [0, 2**32], or an
/// `InvalidInputError` naming it.
fn count(name: &str, value: Option<&Bound<'_, PyAny>>, default: usize) -> PyResult<usize> {
    let Some(v) = value else { return Ok(default) };
    if v.is_none() {
        return Ok(default);
    }
    // (A bool is an int to Python: `min_matches=True` would read as 1.)
    if v.is_instance_of::<pyo3::types::PyBool>() {
        return Err(InvalidInputError::new_err(format!(
            "{name} must be a whole number, not a bool ({v})"
        )));
    }
    let n: Option<i128> = v.extract::<i128>().ok().or_else(|| {
        v.extract::<f64>()
            .ok()
            .filter(|f| f.is_finite() && f.fract() == 0.0 && f.abs() < 1e30)
            .map(|f| f as i128)
    });
    match n {
        Some(n) if (0..=1i128 << 32).contains(&n) => Ok(n as usize),
        _ => Err(InvalidInputError::new_err(format!(
            "{name} must be a whole number in [0, 2**32], got {v}"
        ))),
    }
}

/// Settings of identification: the one place they are written. `starid.identify` and
/// `identify_many` take each as a keyword; the defaults are the core's `IdentifyConfig::default()`.
#[pyclass(frozen, eq, name = "IdentifyConfig", module = "starid._starid")]
#[derive(Clone, PartialEq)]
pub struct PyIdentifyConfig {
    pub inner: IdentifyConfig,
}

/// Names of the settings, in the constructor's order.
const SETTINGS: [&str; 18] = [
    "centroid_sigma_px",
    "max_false_match_prob",
    "min_matches",
    "max_search_stars",
    "max_hypotheses",
    "max_pairs_visited",
    "allow_mirrored",
    "timeout_s",
    "method",
    "mag_offset",
    "mag_tolerance",
    "brightness_order",
    "verify",
    "focal_check",
    "fov_tolerance",
    "learn_zero_point",
    "learn_noise",
    "noise_fallback",
];

#[pymethods]
impl PyIdentifyConfig {
    #[new]
    #[pyo3(signature = (*, centroid_sigma_px=None, max_false_match_prob=None, min_matches=None,
                        max_search_stars=None, max_hypotheses=None, max_pairs_visited=None,
                        allow_mirrored=None, timeout_s=None, method=None, mag_offset=0.0,
                        mag_tolerance=None, brightness_order=None, verify=None,
                        focal_check=None, fov_tolerance=None, learn_zero_point=None,
                        learn_noise=None, noise_fallback=None))]
    fn new(
        centroid_sigma_px: Option<f64>,
        max_false_match_prob: Option<f64>,
        min_matches: Option<&Bound<'_, PyAny>>,
        max_search_stars: Option<&Bound<'_, PyAny>>,
        max_hypotheses: Option<&Bound<'_, PyAny>>,
        max_pairs_visited: Option<&Bound<'_, PyAny>>,
        allow_mirrored: Option<bool>,
        timeout_s: Option<f64>,
        method: Option<&str>,
        mag_offset: Option<f64>,
        mag_tolerance: Option<f64>,
        brightness_order: Option<bool>,
        verify: Option<bool>,
        focal_check: Option<bool>,
        fov_tolerance: Option<f64>,
        learn_zero_point: Option<bool>,
        learn_noise: Option<bool>,
        noise_fallback: Option<bool>,
    ) -> PyResult<Self> {
        let timeout = match timeout_s {
            None => None,
            Some(t) if t.is_finite() && t > 0.0 && t <= 1e9 => {
                Some(std::time::Duration::from_secs_f64(t))
            }
            Some(t) => {
                return Err(InvalidInputError::new_err(format!(
                    "timeout_s must be positive, finite and at most 1e9 seconds, got {t}"
                )))
            }
        };
        let d = IdentifyConfig::default();
        let inner = IdentifyConfig {
            centroid_sigma_px,
            max_false_match_prob: max_false_match_prob.unwrap_or(d.max_false_match_prob),
            min_matches: count("min_matches", min_matches, d.min_matches)?,
            max_search_stars: count("max_search_stars", max_search_stars, d.max_search_stars)?,
            max_hypotheses: count("max_hypotheses", max_hypotheses, d.max_hypotheses)?,
            max_pairs_visited: count("max_pairs_visited", max_pairs_visited, d.max_pairs_visited)?,
            allow_mirrored: allow_mirrored.unwrap_or(d.allow_mirrored),
            timeout,
            cancel: None,
            method: match method {
                None => d.method,
                Some(m) => starid_core::Method::from_name(m).map_err(PyStaridError)?,
            },
            mag_offset,
            mag_tolerance: mag_tolerance.unwrap_or(d.mag_tolerance),
            brightness_order: brightness_order.unwrap_or(d.brightness_order),
            verify: verify.unwrap_or(d.verify),
            focal_check: focal_check.unwrap_or(d.focal_check),
            fov_tolerance: fov_tolerance.unwrap_or(d.fov_tolerance),
            learn_zero_point: learn_zero_point.unwrap_or(d.learn_zero_point),
            learn_noise: learn_noise.unwrap_or(d.learn_noise),
            noise_fallback: noise_fallback.unwrap_or(d.noise_fallback),
        };
        inner.validate().map_err(PyStaridError)?;
        Ok(Self { inner })
    }

    /// The names of the settings.
    #[staticmethod]
    fn names() -> Vec<&'static str> {
        SETTINGS.to_vec()
    }

    /// The settings as a dict (name → value).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = &self.inner;
        let d = PyDict::new(py);
        d.set_item("centroid_sigma_px", c.centroid_sigma_px)?;
        d.set_item("max_false_match_prob", c.max_false_match_prob)?;
        d.set_item("min_matches", c.min_matches)?;
        d.set_item("max_search_stars", c.max_search_stars)?;
        d.set_item("max_hypotheses", c.max_hypotheses)?;
        d.set_item("max_pairs_visited", c.max_pairs_visited)?;
        d.set_item("allow_mirrored", c.allow_mirrored)?;
        d.set_item("timeout_s", c.timeout.map(|t| t.as_secs_f64()))?;
        d.set_item("method", c.method.name())?;
        d.set_item("mag_offset", c.mag_offset)?;
        d.set_item("mag_tolerance", c.mag_tolerance)?;
        d.set_item("brightness_order", c.brightness_order)?;
        d.set_item("verify", c.verify)?;
        d.set_item("focal_check", c.focal_check)?;
        d.set_item("fov_tolerance", c.fov_tolerance)?;
        d.set_item("learn_zero_point", c.learn_zero_point)?;
        d.set_item("learn_noise", c.learn_noise)?;
        d.set_item("noise_fallback", c.noise_fallback)?;
        Ok(d)
    }

    /// A copy with some settings changed.
    #[pyo3(signature = (**changes))]
    fn replace(&self, py: Python<'_>, changes: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Self>> {
        let d = self.to_dict(py)?;
        if let Some(c) = changes {
            d.update(c.as_mapping())?;
        }
        let cls = py.get_type::<Self>();
        Ok(cls.call((), Some(&d))?.cast_into::<Self>()?.unbind())
    }

    /// Pickling: `IdentifyConfig(**self.to_dict())`.
    fn __getnewargs_ex__<'py>(&self, py: Python<'py>) -> PyResult<((), Bound<'py, PyDict>)> {
        Ok(((), self.to_dict(py)?))
    }

    #[getter]
    fn centroid_sigma_px(&self) -> Option<f64> {
        self.inner.centroid_sigma_px
    }
    #[getter]
    fn max_false_match_prob(&self) -> f64 {
        self.inner.max_false_match_prob
    }
    #[getter]
    fn min_matches(&self) -> usize {
        self.inner.min_matches
    }
    #[getter]
    fn max_search_stars(&self) -> usize {
        self.inner.max_search_stars
    }
    #[getter]
    fn max_hypotheses(&self) -> usize {
        self.inner.max_hypotheses
    }
    #[getter]
    fn max_pairs_visited(&self) -> usize {
        self.inner.max_pairs_visited
    }
    #[getter]
    fn allow_mirrored(&self) -> bool {
        self.inner.allow_mirrored
    }
    #[getter]
    fn timeout_s(&self) -> Option<f64> {
        self.inner.timeout.map(|t| t.as_secs_f64())
    }
    #[getter]
    fn method(&self) -> &'static str {
        self.inner.method.name()
    }
    #[getter]
    fn mag_offset(&self) -> Option<f64> {
        self.inner.mag_offset
    }
    #[getter]
    fn mag_tolerance(&self) -> f64 {
        self.inner.mag_tolerance
    }
    #[getter]
    fn brightness_order(&self) -> bool {
        self.inner.brightness_order
    }
    /// Pass every answer through the shared verification; False (benchmarks and research
    /// only) returns a method's raw answer.
    #[getter]
    fn verify(&self) -> bool {
        self.inner.verify
    }
    /// Check a verified solution for a focal length off and search again with the one its
    /// residuals imply; False holds the camera's focal length fixed.
    #[getter]
    fn focal_check(&self) -> bool {
        self.inner.focal_check
    }
    /// How far off the given field of view may be, relative to the true one (0.1: the true field
    /// between `fov / 1.1` and `fov / 0.9`); 0 holds it as given.
    #[getter]
    fn fov_tolerance(&self) -> f64 {
        self.inner.fov_tolerance
    }
    /// In ``identify_many``, learn the magnitude zero point from the frames identified without
    /// it and search the ones nothing identified again with it; False: each frame alone.
    #[getter]
    fn learn_zero_point(&self) -> bool {
        self.inner.learn_zero_point
    }
    /// In ``identify_many``, learn the centroid noise from the frames identified with a wide
    /// margin (when ``centroid_sigma_px`` is None) and search the ones nothing identified again
    /// with it where it is tighter than the default ladder's; False: each frame alone.
    #[getter]
    fn learn_noise(&self) -> bool {
        self.inner.learn_noise
    }
    /// After a stated ``centroid_sigma_px`` that the residuals refuse as too small, try the
    /// default ladder's looser steps; False: the stated noise only.
    #[getter]
    fn noise_fallback(&self) -> bool {
        self.inner.noise_fallback
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let d = self.to_dict(py)?;
        let parts: PyResult<Vec<String>> = SETTINGS
            .iter()
            .map(|k| {
                Ok(format!(
                    "{k}={}",
                    d.get_item(k)?.expect("every setting").repr()?
                ))
            })
            .collect();
        Ok(format!("IdentifyConfig({})", parts?.join(", ")))
    }
}

pub(crate) fn camera(fov_deg: f64, width_px: f64, height_px: f64) -> PyResult<Camera> {
    Camera::from_fov(fov_deg.to_radians(), width_px, height_px).map_err(|e| PyStaridError(e).into())
}

/// What identifying one frame of `camera` needs besides the frame: the camera as the core takes
/// it, the solver for its field and the settings.
pub(crate) fn frame_setup(
    py: Python<'_>,
    catalog: &Bound<'_, PyCatalog>,
    camera: &Bound<'_, PyCamera>,
    config: &Bound<'_, PyIdentifyConfig>,
) -> PyResult<(Camera, Arc<starid_core::Solver>, IdentifyConfig)> {
    let cam = camera.get().inner;
    let solver = catalog.get().solver(py, cam.diagonal_fov_rad())?;
    Ok((cam, solver, config.get().inner.clone()))
}

/// Identify one frame.
#[pyfunction]
#[pyo3(signature = (catalog, xy, magnitudes, camera, config))]
fn identify<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: PyReadonlyArray2<'py, f64>,
    magnitudes: Option<PyReadonlyArray1<'py, f64>>,
    camera: &Bound<'py, PyCamera>,
    config: &Bound<'py, PyIdentifyConfig>,
) -> PyResult<PyIdentification> {
    let (centroids, mags) = convert::frame(&xy, magnitudes.as_ref())?;
    identify_frame_of(py, catalog, centroids, mags, camera, config)
}

/// [`identify`] of centroids and magnitudes already read.
fn identify_frame_of(
    py: Python<'_>,
    catalog: &Bound<'_, PyCatalog>,
    centroids: Vec<[f64; 2]>,
    mags: Option<Vec<f64>>,
    camera: &Bound<'_, PyCamera>,
    config: &Bound<'_, PyIdentifyConfig>,
) -> PyResult<PyIdentification> {
    let (cam, solver, cfg) = frame_setup(py, catalog, camera, config)?;
    let (id, centroids, mags) = run_core(py, move || {
        solver
            .identify(&centroids, mags.as_deref(), &cam, &cfg)
            .map(|id| (id, centroids, mags))
    })?;
    Ok(PyIdentification::new(catalog.get(), id, &cam, f64::NAN).with_spots(centroids, mags))
}

/// `identify`'s common call in one native step: centroids as a float64 (N, 2) array,
/// magnitudes as None or a float64 1-D array, the hint None or a float64 quaternion array of 4.
/// Any other form gives `NotImplemented`, and the Python layer converts and checks it (or reads
/// an image) and calls again.
#[pyfunction]
#[pyo3(signature = (catalog, xy, magnitudes, camera, config, hint, hint_uncertainty_deg, hint_fallback))]
fn identify_frame<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: &Bound<'py, PyAny>,
    magnitudes: &Bound<'py, PyAny>,
    camera: &Bound<'py, PyCamera>,
    config: &Bound<'py, PyIdentifyConfig>,
    hint: &Bound<'py, PyAny>,
    hint_uncertainty_deg: &Bound<'py, PyAny>,
    hint_fallback: &Bound<'py, PyAny>,
) -> PyResult<Py<PyAny>> {
    let not_here = || Ok(py.NotImplemented());
    let Ok(xy) = xy.cast::<PyArray2<f64>>() else {
        return not_here();
    };
    // A wide 2-D array may be an image; an empty one is an empty frame.
    if xy.shape()[1] != 2 && xy.shape()[0] != 0 {
        return not_here();
    }
    let mags = if magnitudes.is_none() {
        None
    } else {
        let Ok(m) = magnitudes.cast::<PyArray1<f64>>() else {
            return not_here();
        };
        Some(m)
    };
    let hint = if hint.is_none() {
        None
    } else {
        let Ok(q) = hint.cast::<PyArray1<f64>>() else {
            return not_here();
        };
        let Some([w, x, y, z]) = q.to_vec().ok().and_then(|q| <[f64; 4]>::try_from(q).ok()) else {
            return not_here();
        };
        let Ok(u) = hint_uncertainty_deg.extract::<f64>() else {
            return not_here();
        };
        Some(([w, x, y, z], u, hint_fallback.is_truthy()?))
    };
    // Read without a borrow (see `convert::centroids_of`); then the same calls the converting
    // path ends in.
    let centroids = convert::centroids_of("xy", xy)?;
    let mags = mags
        .map(|m| convert::magnitudes_of(m, centroids.len()))
        .transpose()?;
    let id = match hint {
        None => identify_frame_of(py, catalog, centroids, mags, camera, config)?,
        Some((q, u, fallback)) => {
            let hint = (tracking::hint(q, u, None)?, tracking::fallback_of(fallback));
            tracking::identify_hinted_of(py, catalog, (centroids, mags), camera, config, hint)?
        }
    };
    Ok(id.into_pyobject(py)?.into_any().unbind())
}

/// Identify many frames of one camera in parallel (GIL released); results in input order.
///
/// `xys` is a list of float64 (N, 2) arrays and `magnitudes` None or a list of None or float64
/// arrays, one value per centroid. Any other form returns `NotImplemented` (the Python layer
/// converts it, or names the frame that cannot be): the common batch is read without a Python
/// loop over its frames. A frame the core refuses (non-finite centroids, say) gets status
/// `invalid_input` and a message that starts with its place, `frame i: `.
#[pyfunction]
#[pyo3(signature = (catalog, xys, magnitudes, camera, config, threads=None))]
#[allow(clippy::too_many_arguments)]
fn identify_many<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xys: &Bound<'py, PyAny>,
    magnitudes: &Bound<'py, PyAny>,
    camera: &Bound<'py, PyCamera>,
    config: &Bound<'py, PyIdentifyConfig>,
    threads: Option<usize>,
) -> PyResult<Py<PyAny>> {
    if threads == Some(0) {
        return Err(InvalidInputError::new_err(
            "threads must be at least 1 (or None for all cores)",
        ));
    }
    let not_here = || Ok(py.NotImplemented());
    let Ok(xys) = xys.cast::<PyList>() else {
        return not_here();
    };
    let mag_list = if magnitudes.is_none() {
        None
    } else {
        match magnitudes.cast::<PyList>() {
            Ok(m) if m.len() == xys.len() => Some(m),
            _ => return not_here(),
        }
    };
    let cam = camera.get().inner;
    let mut frames = Vec::with_capacity(xys.len());
    let mut mags: Vec<Option<Vec<f64>>> = Vec::with_capacity(xys.len());
    for (i, xy) in xys.iter().enumerate() {
        if i % 4096 == 4095 {
            // A million frames take a while to convert: Ctrl-C works here too.
            py.check_signals()?;
        }
        let Ok(xy) = xy.cast::<PyArray2<f64>>() else {
            return not_here();
        };
        if xy.shape()[1] != 2 && xy.shape()[0] != 0 {
            return not_here();
        }
        let centroids = convert::centroids_of("xy", xy)?;
        let m = match mag_list.map(|l| l.get_item(i)).transpose()? {
            Some(m) if !m.is_none() => {
                let Ok(m) = m.cast::<PyArray1<f64>>() else {
                    return not_here();
                };
                if m.len() != centroids.len() {
                    return not_here();
                }
                Some(convert::magnitudes_of(m, centroids.len())?)
            }
            _ => None,
        };
        frames.push(centroids);
        mags.push(m);
    }
    let solver = catalog.get().solver(py, cam.diagonal_fov_rad())?;
    let cfg = config.get().inner.clone();
    let refs: Vec<_> = frames
        .iter()
        .zip(&mags)
        .map(|(f, m)| (f.as_slice(), m.as_deref()))
        .collect();
    // Ctrl-C cancels the frames not yet begun and raises KeyboardInterrupt at once.
    let results = batch::watched(py, |cancel| {
        solver.identify_batch_until(&refs, &cam, &cfg, threads, cancel.flag())
    })?
    .map_err(PyStaridError)?;
    let cat = catalog.get();
    drop(refs);
    let out = results
        .into_iter()
        .zip(frames)
        .zip(mags)
        .enumerate()
        .map(|(i, ((id, xy), m))| {
            let mut r = PyIdentification::new(cat, id, &cam, f64::NAN).with_spots(xy, m);
            r.name_frame(i);
            r
        });
    Ok(PyList::new(py, out)?.into_any().unbind())
}

/// Simulate one frame; returns a dict with the centroids and the truth.
#[pyfunction]
#[pyo3(signature = (catalog, fov_deg, width_px, height_px, seed, attitude_deg=None, mag_limit=None,
                    noise_px=0.0, mag_noise=0.0, false_stars=0, drop_fraction=0.0, mirrored=false,
                    radial_k1=0.0, camera=None))]
#[allow(clippy::too_many_arguments)]
fn simulate<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    fov_deg: f64,
    width_px: f64,
    height_px: f64,
    seed: u64,
    attitude_deg: Option<(f64, f64, f64)>,
    mag_limit: Option<f64>,
    noise_px: f64,
    mag_noise: f64,
    false_stars: usize,
    drop_fraction: f64,
    mirrored: bool,
    radial_k1: f64,
    camera: Option<PyRef<'py, PyCamera>>,
) -> PyResult<Bound<'py, PyDict>> {
    let cam = match camera {
        // A camera given whole (a calibrated one, with its distortion).
        Some(c) => c.inner,
        None => self::camera(fov_deg, width_px, height_px)?
            .with_k1(radial_k1)
            .map_err(|e| InvalidInputError::new_err(format!("radial_k1: {e}")))?,
    };
    let r = match attitude_deg {
        None => None,
        Some((ra, dec, roll)) => {
            if !(ra.is_finite() && roll.is_finite() && (-90.0..=90.0).contains(&dec)) {
                return Err(InvalidInputError::new_err(format!(
                    "attitude_deg must be finite (ra, dec, roll) with dec in [-90, 90], got ({ra}, {dec}, {roll})"
                )));
            }
            Some(geometry::attitude_from_radec_roll(
                ra.to_radians(),
                dec.to_radians(),
                roll.to_radians(),
            ))
        }
    };
    let config = sim::SimConfig {
        r_icrs_to_cam: r,
        mag_limit,
        noise_px,
        mag_noise,
        false_stars,
        drop_fraction,
        mirrored,
        ..Default::default()
    };
    let cat = Arc::clone(&catalog.get().inner);
    let frame = run_core(py, move || sim::simulate(&cat, &cam, &config, seed))?;
    outcome::frame(py, &catalog.get().inner, &frame)
}

/// Simulate scene `seed` of a scene family (`K1`, `K2`, `K3`); returns the frame's dict plus
/// the family's camera (`fov_deg`, `width_px`, `height_px`).
#[pyfunction]
#[pyo3(signature = (catalog, family, seed))]
fn simulate_scene<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    family: &str,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let fam = sim::Family::from_name(family).map_err(PyStaridError)?;
    let cat = Arc::clone(&catalog.get().inner);
    let frame = run_core(py, move || fam.simulate(&cat, seed))?;
    let d = outcome::frame(py, &catalog.get().inner, &frame)?;
    let cam = fam.camera();
    d.set_item("fov_deg", cam.fov_rad().to_degrees())?;
    d.set_item("width_px", cam.width_px)?;
    d.set_item("height_px", cam.height_px)?;
    d.set_item("catalog_mag_limit", fam.catalog_mag_limit())?;
    Ok(d)
}

/// The identification methods: `(name, one-line description)` pairs.
#[pyfunction]
fn methods() -> Vec<(&'static str, &'static str)> {
    starid_core::Method::ALL
        .iter()
        .map(|m| (m.name(), m.description()))
        .collect()
}

#[pymodule(gil_used = false)]
fn _starid(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("GUIDE_MAX_TRIALS", starid_core::guide::MAX_TRIALS)?;
    m.add(
        "CONFIRM_UNSEEN_FRAMES",
        starid_core::tracking::CONFIRM_UNSEEN_FRAMES,
    )?;
    m.add(
        "FOCAL_LEARN_MIN_FRAMES",
        starid_core::identify::FOCAL_LEARN_MIN_FRAMES,
    )?;
    m.add(
        "INCONSISTENT_RMS_PX",
        starid_core::pointing::INCONSISTENT_RMS_PX,
    )?;
    m.add_class::<PyCatalog>()?;
    m.add_class::<PyCamera>()?;
    m.add_class::<calibration::PyCalibration>()?;
    m.add_function(wrap_pyfunction!(calibration::calibrate_camera, m)?)?;
    m.add_class::<tracking::PyTracker>()?;
    m.add_function(wrap_pyfunction!(tracking::identify_hinted, m)?)?;
    m.add_function(wrap_pyfunction!(tracking::simulate_sequence, m)?)?;
    m.add_function(wrap_pyfunction!(tracking::quaternion_from_radec_roll, m)?)?;
    m.add_function(wrap_pyfunction!(outcome::result_columns, m)?)?;
    m.add_function(wrap_pyfunction!(catalog::set_index_cache_dir, m)?)?;
    m.add_function(wrap_pyfunction!(catalog::index_cache_dir, m)?)?;
    m.add_function(wrap_pyfunction!(images::extract_centroids, m)?)?;
    m.add_function(wrap_pyfunction!(images::extract_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(images::luminance, m)?)?;
    m.add_function(wrap_pyfunction!(images::read_png, m)?)?;
    m.add_function(wrap_pyfunction!(images::simulate_image, m)?)?;
    m.add_function(wrap_pyfunction!(images::render_defaults, m)?)?;
    m.add_class::<PyIdentifyConfig>()?;
    m.add_class::<PyIdentification>()?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify_frame, m)?)?;
    m.add_function(wrap_pyfunction!(identify_many, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_scene, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_select, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_nearest_neighbours, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_field_counts, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_fov_for_coverage, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_qtm_triangle_count, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::boresight_from_distances, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::fit_pointing, m)?)?;
    m.add_class::<pointing::PyPointingFit>()?;
    m.add_class::<pointing::PyBoresightSolution>()?;
    m.add_function(wrap_pyfunction!(
        pointing::predicted_distance_covariance,
        m
    )?)?;
    m.add_function(wrap_pyfunction!(pointing::choose_stars, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::monte_carlo_distances, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::identify_unknown_fov, m)?)?;
    m.add_function(wrap_pyfunction!(batch::identify_unknown_fov_many, m)?)?;
    m.add_function(wrap_pyfunction!(batch::identify_unknown_fov_start, m)?)?;
    m.add_class::<batch::PyPendingSearch>()?;
    m.add_function(wrap_pyfunction!(batch::identify_hinted_many, m)?)?;
    m.add("StaridError", m.py().get_type::<StaridError>())?;
    m.add("CatalogError", m.py().get_type::<CatalogError>())?;
    m.add("InvalidInputError", m.py().get_type::<InvalidInputError>())?;
    Ok(())
}
