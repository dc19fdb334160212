//! `starid._starid`: Python bindings of starid-core.
//!
//! Conversion, validation, GIL handling and error mapping only; every algorithm lives in
//! starid-core. Long calls release the GIL through [`run_core`].
//!
//! Functions mirror Python signatures with many keyword arguments, hence the allowed lint.
#![allow(clippy::too_many_arguments)]

mod catalog;
mod convert;
mod errors;
mod guide;
mod outcome;
mod pointing;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use starid_core::{geometry, simulate as sim, Camera, IdentifyConfig};

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

/// Settings of identification (see `starid.identify`).
#[pyclass(frozen, name = "IdentifyConfig", module = "starid._starid")]
#[derive(Clone)]
pub struct PyIdentifyConfig {
    pub inner: IdentifyConfig,
}

#[pymethods]
impl PyIdentifyConfig {
    #[new]
    #[pyo3(signature = (*, centroid_sigma_px=None, max_false_match_prob=None, min_matches=None,
                        max_search_stars=None, max_hypotheses=None, allow_mirrored=None, timeout_s=None,
                        method=None, mag_offset=0.0, mag_tolerance=None, brightness_order=None))]
    fn new(
        centroid_sigma_px: Option<f64>,
        max_false_match_prob: Option<f64>,
        min_matches: Option<usize>,
        max_search_stars: Option<usize>,
        max_hypotheses: Option<usize>,
        allow_mirrored: Option<bool>,
        timeout_s: Option<f64>,
        method: Option<&str>,
        mag_offset: Option<f64>,
        mag_tolerance: Option<f64>,
        brightness_order: Option<bool>,
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
            min_matches: min_matches.unwrap_or(d.min_matches),
            max_search_stars: max_search_stars.unwrap_or(d.max_search_stars),
            max_hypotheses: max_hypotheses.unwrap_or(d.max_hypotheses),
            allow_mirrored: allow_mirrored.unwrap_or(d.allow_mirrored),
            timeout,
            method: match method {
                None => d.method,
                Some(m) => starid_core::Method::from_name(m).map_err(PyStaridError)?,
            },
            mag_offset,
            mag_tolerance: mag_tolerance.unwrap_or(d.mag_tolerance),
            brightness_order: brightness_order.unwrap_or(d.brightness_order),
            ..d
        };
        inner.validate().map_err(PyStaridError)?;
        Ok(Self { inner })
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
    fn allow_mirrored(&self) -> bool {
        self.inner.allow_mirrored
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

    fn __repr__(&self) -> String {
        let c = &self.inner;
        format!(
            "IdentifyConfig(centroid_sigma_px={}, max_false_match_prob={:e}, min_matches={}, max_search_stars={}, \
             max_hypotheses={}, allow_mirrored={}, method={:?}, mag_offset={}, mag_tolerance={})",
            c.centroid_sigma_px.map_or("None".to_string(), |s| s.to_string()),
            c.max_false_match_prob,
            c.min_matches,
            c.max_search_stars,
            c.max_hypotheses,
            if c.allow_mirrored { "True" } else { "False" },
            c.method.name(),
            c.mag_offset.map_or("None".to_string(), |s| s.to_string()),
            c.mag_tolerance
        )
    }
}

pub(crate) fn camera(fov_deg: f64, width_px: f64, height_px: f64) -> PyResult<Camera> {
    Camera::from_fov(fov_deg.to_radians(), width_px, height_px).map_err(|e| PyStaridError(e).into())
}

/// Identify one frame.
#[pyfunction]
#[pyo3(signature = (catalog, xy, magnitudes, width_px, height_px, fov_deg, config))]
fn identify<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: PyReadonlyArray2<'py, f64>,
    magnitudes: Option<PyReadonlyArray1<'py, f64>>,
    width_px: f64,
    height_px: f64,
    fov_deg: f64,
    config: &Bound<'py, PyIdentifyConfig>,
) -> PyResult<PyIdentification> {
    let cam = camera(fov_deg, width_px, height_px)?;
    let centroids = convert::centroids("xy", &xy)?;
    let mags = magnitudes
        .map(|m| convert::vector("magnitudes", &m, Some(centroids.len())))
        .transpose()?;
    let solver = catalog.get().solver(py, cam.diagonal_fov_rad())?;
    let cfg = config.get().inner.clone();
    let id = run_core(py, move || {
        solver.identify(&centroids, mags.as_deref(), &cam, &cfg)
    })?;
    Ok(PyIdentification::new(
        &catalog.get().inner,
        &id,
        &cam,
        f64::NAN,
    ))
}

/// Identify many frames of one camera in parallel (GIL released); results in input order.
#[pyfunction]
#[pyo3(signature = (catalog, xys, magnitudes, width_px, height_px, fov_deg, config, threads=None))]
#[allow(clippy::too_many_arguments)]
fn identify_many<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xys: Vec<PyReadonlyArray2<'py, f64>>,
    magnitudes: Option<Vec<Option<PyReadonlyArray1<'py, f64>>>>,
    width_px: f64,
    height_px: f64,
    fov_deg: f64,
    config: &Bound<'py, PyIdentifyConfig>,
    threads: Option<usize>,
) -> PyResult<Vec<PyIdentification>> {
    if threads == Some(0) {
        return Err(InvalidInputError::new_err(
            "threads must be at least 1 (or None for all cores)",
        ));
    }
    let cam = camera(fov_deg, width_px, height_px)?;
    let mut frames = Vec::with_capacity(xys.len());
    for (i, xy) in xys.iter().enumerate() {
        if i % 4096 == 4095 {
            // A million frames take a while to convert: Ctrl-C works here too.
            py.check_signals()?;
        }
        frames.push(convert::centroids(&format!("frame {i}"), xy)?);
    }
    let mags: Vec<Option<Vec<f64>>> = match magnitudes {
        None => vec![None; frames.len()],
        Some(m) => {
            if m.len() != frames.len() {
                return Err(InvalidInputError::new_err(format!(
                    "magnitudes has {} entries for {} frames",
                    m.len(),
                    frames.len()
                )));
            }
            m.iter()
                .zip(&frames)
                .enumerate()
                .map(|(i, (m, f))| {
                    m.as_ref()
                        .map(|m| {
                            convert::vector(&format!("magnitudes of frame {i}"), m, Some(f.len()))
                        })
                        .transpose()
                })
                .collect::<PyResult<_>>()?
        }
    };
    let solver = catalog.get().solver(py, cam.diagonal_fov_rad())?;
    let cfg = config.get().inner.clone();
    let refs: Vec<_> = frames
        .iter()
        .zip(&mags)
        .map(|(f, m)| (f.as_slice(), m.as_deref()))
        .collect();
    // The batch runs on a thread of its own while this one, every 20 ms, lets Python handle
    // signals: Ctrl-C cancels the frames not yet begun and raises KeyboardInterrupt at once.
    let cancel = AtomicBool::new(false);
    let results = std::thread::scope(|scope| -> PyResult<Vec<starid_core::Identification>> {
        let batch = scope.spawn(|| solver.identify_batch_until(&refs, &cam, &cfg, threads, &cancel));
        while !batch.is_finished() {
            if let Err(interrupt) = py.check_signals() {
                cancel.store(true, Ordering::Relaxed);
                let _ = py.detach(move || batch.join());
                return Err(interrupt);
            }
            py.detach(|| std::thread::sleep(std::time::Duration::from_millis(20)));
        }
        batch
            .join()
            .map_err(|_| InvalidInputError::new_err("identification thread panicked"))?
            .map_err(|e| PyStaridError(e).into())
    })?;
    let cat = &catalog.get().inner;
    Ok(results
        .iter()
        .map(|id| PyIdentification::new(cat, id, &cam, f64::NAN))
        .collect())
}

/// Simulate one frame; returns a dict with the centroids and the truth.
#[pyfunction]
#[pyo3(signature = (catalog, fov_deg, width_px, height_px, seed, attitude_deg=None, mag_limit=None,
                    noise_px=0.0, mag_noise=0.0, false_stars=0, drop_fraction=0.0, mirrored=false,
                    radial_k1=0.0))]
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
) -> PyResult<Bound<'py, PyDict>> {
    let cam = camera(fov_deg, width_px, height_px)?;
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
        radial_k1,
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
    m.add_class::<PyCatalog>()?;
    m.add_class::<PyIdentifyConfig>()?;
    m.add_class::<PyIdentification>()?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(identify_many, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(simulate_scene, m)?)?;
    m.add_function(wrap_pyfunction!(methods, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_select, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_metrics, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_nearest_neighbours, m)?)?;
    m.add_function(wrap_pyfunction!(guide::guide_field_counts, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::boresight_from_distances, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::fit_pointing, m)?)?;
    m.add_function(wrap_pyfunction!(
        pointing::predicted_distance_covariance,
        m
    )?)?;
    m.add_function(wrap_pyfunction!(pointing::choose_stars, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::monte_carlo_distances, m)?)?;
    m.add_function(wrap_pyfunction!(pointing::identify_unknown_fov, m)?)?;
    m.add("StaridError", m.py().get_type::<StaridError>())?;
    m.add("CatalogError", m.py().get_type::<CatalogError>())?;
    m.add("InvalidInputError", m.py().get_type::<InvalidInputError>())?;
    Ok(())
}
