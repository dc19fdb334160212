//! `calibrate_camera` and the native `Calibration` result: the core's joint fit of one camera
//! to many identified frames.

use nalgebra::{Matrix3, Rotation3, Vector3};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use starid_core::calibrate::{self, CalibrationConfig, CalibrationFrame};
use starid_core::geometry::quaternion_wxyz;

use crate::camera::PyCamera;
use crate::errors::InvalidInputError;

/// One frame as Python hands it: spots ``(N, 2)``, their stars' ICRS unit vectors ``(N, 3)``,
/// the rotation ICRS → camera ``(3, 3)`` and whether the frame is mirrored.
type FrameArgs<'py> = (
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    bool,
);

fn frame(i: usize, (xy, stars, rotation, mirrored): FrameArgs<'_>) -> PyResult<CalibrationFrame> {
    let pixels = crate::convert::centroids(&format!("frame {i}: xy"), &xy)?;
    let s = stars.as_array();
    if s.ncols() != 3 || s.nrows() != pixels.len() {
        return Err(InvalidInputError::new_err(format!(
            "frame {i}: stars must have shape ({}, 3), got {:?}",
            pixels.len(),
            s.shape()
        )));
    }
    let r = rotation.as_array();
    if r.shape() != [3, 3] || r.iter().any(|v| !v.is_finite()) {
        return Err(InvalidInputError::new_err(format!(
            "frame {i}: the rotation must be a finite 3 x 3 matrix, got shape {:?}",
            r.shape()
        )));
    }
    let m = Matrix3::from_fn(|a, b| r[[a, b]]);
    Ok(CalibrationFrame {
        pixels,
        stars: s
            .rows()
            .into_iter()
            .map(|v| Vector3::new(v[0], v[1], v[2]))
            .collect(),
        attitude: Rotation3::from_matrix(&m),
        mirrored,
    })
}

/// Fit one camera to many identified frames (see ``starid.calibrate``, which gathers the frames
/// from identifications).
#[pyfunction]
#[pyo3(signature = (frames, camera, *, focal_length=true, principal_point=None, radial_terms=None, decentering=None, clip_sigma=3.0, max_iterations=100))]
#[allow(clippy::too_many_arguments)]
pub fn calibrate_camera(
    py: Python<'_>,
    frames: Vec<FrameArgs<'_>>,
    camera: &PyCamera,
    focal_length: bool,
    principal_point: Option<bool>,
    radial_terms: Option<usize>,
    decentering: Option<bool>,
    clip_sigma: f64,
    max_iterations: usize,
) -> PyResult<PyCalibration> {
    let frames: Vec<CalibrationFrame> = frames
        .into_iter()
        .enumerate()
        .map(|(i, f)| frame(i, f))
        .collect::<PyResult<_>>()?;
    let config = CalibrationConfig {
        focal_length,
        principal_point,
        radial_terms,
        decentering,
        clip_sigma,
        max_iterations,
    };
    let start = camera.inner;
    let t = std::time::Instant::now();
    let inner = crate::run_core(py, move || calibrate::calibrate(&frames, &start, &config))?;
    Ok(PyCalibration {
        time_s: t.elapsed().as_secs_f64(),
        start,
        inner,
        identified: None,
    })
}

/// The camera fitted to many frames (``starid.calibrate``), with its uncertainty and residuals.
#[pyclass(frozen, name = "Calibration", module = "starid._starid")]
#[derive(Clone)]
pub struct PyCalibration {
    inner: calibrate::Calibration,
    start: starid_core::Camera,
    time_s: f64,
    identified: Option<(usize, usize, usize)>,
}

#[pymethods]
impl PyCalibration {
    /// The fitted camera (pass it to ``identify``, ``Tracker``, ``simulate``, ``wcs``).
    #[getter]
    fn camera(&self) -> PyCamera {
        PyCamera {
            inner: self.inner.camera,
        }
    }
    /// The camera the fit started from.
    #[getter]
    fn start_camera(&self) -> PyCamera {
        PyCamera { inner: self.start }
    }
    /// Names of the fitted intrinsics, in the order of ``covariance``.
    #[getter]
    fn parameters(&self) -> Vec<&'static str> {
        self.inner.intrinsics.iter().map(|p| p.name()).collect()
    }
    /// Covariance of the fitted intrinsics (``parameters`` order), pixels and unitless terms.
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let n = self.inner.intrinsics.len();
        Array2::from_shape_vec((n, n), self.inner.covariance.clone())
            .expect("n x n")
            .into_pyarray(py)
    }
    /// 1 sigma of each fitted intrinsic, by name.
    #[getter]
    fn sigmas<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (p, s) in self.inner.intrinsics.iter().zip(self.inner.sigmas()) {
            d.set_item(p.name(), s)?;
        }
        Ok(d)
    }
    /// RMS residual per axis of the kept matches with the starting camera (each frame's
    /// attitude fitted alone), pixels.
    #[getter]
    fn rms_before_px(&self) -> f64 {
        self.inner.rms_before_px
    }
    /// RMS residual per axis of the kept matches after calibration, pixels.
    #[getter]
    fn rms_px(&self) -> f64 {
        self.inner.rms_px
    }
    /// Each frame's RMS residual per axis after calibration, pixels.
    #[getter]
    fn frame_rms_px<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        Array1::from(self.inner.frame_rms_px.clone()).into_pyarray(py)
    }
    /// Each frame's residuals ``(observed - predicted)`` after calibration, ``(N, 2)`` pixels.
    #[getter]
    fn residuals_px<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray2<f64>>> {
        self.inner
            .residuals_px
            .iter()
            .map(|rs| {
                Array2::from_shape_vec((rs.len(), 2), rs.iter().flatten().copied().collect())
                    .expect("2 columns")
                    .into_pyarray(py)
            })
            .collect()
    }
    /// Each frame's matches kept (False: clipped as an outlier).
    #[getter]
    fn inliers<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyArray1<bool>>> {
        self.inner
            .inliers
            .iter()
            .map(|m| Array1::from(m.clone()).into_pyarray(py))
            .collect()
    }
    /// The clipped matches as ``(frame, match)`` index pairs.
    #[getter]
    fn clipped(&self) -> Vec<(usize, usize)> {
        self.inner
            .inliers
            .iter()
            .enumerate()
            .flat_map(|(f, m)| {
                m.iter()
                    .enumerate()
                    .filter(|(_, &k)| !k)
                    .map(move |(i, _)| (f, i))
            })
            .collect()
    }
    /// Number of matches kept.
    #[getter]
    fn n_inliers(&self) -> usize {
        self.inner.n_inliers()
    }
    /// Number of matches clipped.
    #[getter]
    fn n_clipped(&self) -> usize {
        self.inner.n_clipped()
    }
    /// Number of frames fitted.
    #[getter]
    fn n_frames(&self) -> usize {
        self.inner.attitudes.len()
    }
    /// Each frame's fitted attitude ICRS → camera as quaternions ``[w, x, y, z]``, ``(F, 4)``.
    #[getter]
    fn quaternions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self
            .inner
            .attitudes
            .iter()
            .flat_map(quaternion_wxyz)
            .collect();
        Array2::from_shape_vec((self.inner.attitudes.len(), 4), flat)
            .expect("4 columns")
            .into_pyarray(py)
    }
    /// Each frame's fitted rotation matrix ICRS → camera, ``(F, 3, 3)``.
    #[getter]
    fn rotation_matrices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let flat: Vec<f64> = self
            .inner
            .attitudes
            .iter()
            .flat_map(|r| {
                let m = r.matrix();
                (0..9).map(move |k| m[(k / 3, k % 3)])
            })
            .collect();
        Array3::from_shape_vec((self.inner.attitudes.len(), 3, 3), flat)
            .expect("3 x 3")
            .into_pyarray(py)
    }
    /// Levenberg–Marquardt steps taken over all fits.
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }
    /// Seconds the fit took.
    #[getter]
    fn time_s(&self) -> f64 {
        self.time_s
    }
    /// ``(identified before, identified after, frames)`` where ``starid.calibrate`` identified
    /// the frames itself, before and after calibration; None for identifications given.
    #[getter]
    fn identified(&self) -> Option<(usize, usize, usize)> {
        self.identified
    }

    /// The same calibration with the frames identified before and after it.
    fn _with_identified(&self, identified: (usize, usize, usize)) -> Self {
        Self {
            identified: Some(identified),
            ..self.clone()
        }
    }

    /// Save the fitted camera, its 1 sigma and the fit's summary to a small JSON file
    /// (``starid.load_camera`` reads it back).
    fn save(slf: &Bound<'_, Self>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        slf.py()
            .import("starid.calibration")?
            .call_method1("save_camera", (slf.get().camera(), path, slf))?;
        Ok(())
    }

    /// The summary as a dict of plain values (for JSON).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("parameters", self.parameters())?;
        d.set_item("sigmas", self.sigmas(py)?)?;
        d.set_item("rms_before_px", self.inner.rms_before_px)?;
        d.set_item("rms_px", self.inner.rms_px)?;
        d.set_item("n_frames", self.n_frames())?;
        d.set_item("n_inliers", self.n_inliers())?;
        d.set_item("n_clipped", self.n_clipped())?;
        d.set_item("identified", self.identified)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let c = &self.inner;
        format!(
            "Calibration(frames={}, matches={}, clipped={}, rms_before_px={:.3}, rms_px={:.3}, camera={})",
            c.attitudes.len(),
            c.n_inliers(),
            c.n_clipped(),
            c.rms_before_px,
            c.rms_px,
            self.camera().__repr__()
        )
    }
}
