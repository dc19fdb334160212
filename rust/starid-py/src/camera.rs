//! `Camera`: the core's camera model (size, focal length, principal point, Brown–Conrady
//! distortion) in Python.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2};
use pyo3::prelude::*;
use starid_core::Camera;

use crate::errors::{InvalidInputError, PyStaridError};

/// A camera: sensor size, focal length, principal point and Brown–Conrady distortion.
///
/// A direction ``(X, Y, Z)`` in the camera frame (+z along the boresight) is imaged at
/// ``c + f * (u_d, v_d)`` with ``(u, v) = (X/Z, Y/Z)``, ``r2 = u**2 + v**2``,
/// ``u_d = u * (1 + k1 r2 + k2 r2**2 + k3 r2**3) + 2 p1 u v + p2 (r2 + 2 u**2)`` and
/// ``v_d = v * (1 + k1 r2 + k2 r2**2 + k3 r2**3) + p1 (r2 + 2 v**2) + 2 p2 u v``; pixels x
/// right, y down, origin at the sensor's top-left corner. ``starid.calibrate`` fits one from
/// many frames; ``save`` and ``starid.load_camera`` keep it in a small JSON file.
#[pyclass(frozen, eq, name = "Camera", module = "starid._starid")]
#[derive(Clone, PartialEq)]
pub struct PyCamera {
    pub inner: Camera,
}

/// `(args, kwargs)` of `Camera.__new__`, for pickling.
type NewArgs<'py> = (((f64, f64),), Bound<'py, pyo3::types::PyDict>);

#[pymethods]
impl PyCamera {
    #[new]
    #[pyo3(signature = (image_size, fov_deg=None, *, focal_length_px=None, principal_point=None, k1=0.0, k2=0.0, k3=0.0, p1=0.0, p2=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        image_size: (f64, f64),
        fov_deg: Option<f64>,
        focal_length_px: Option<f64>,
        principal_point: Option<(f64, f64)>,
        k1: f64,
        k2: f64,
        k3: f64,
        p1: f64,
        p2: f64,
    ) -> PyResult<Self> {
        let (w, h) = image_size;
        let cam = match (fov_deg, focal_length_px) {
            (Some(fov), None) => Camera::from_fov(fov.to_radians(), w, h),
            (None, Some(f)) => Camera::from_focal_length(f, w, h),
            _ => {
                return Err(InvalidInputError::new_err(
                    "give the camera's fov_deg (full angle across the width) or its focal_length_px, exactly one",
                ))
            }
        }
        .map_err(PyStaridError)?;
        let cam = match principal_point {
            Some((cx, cy)) => cam.with_principal_point(cx, cy).map_err(PyStaridError)?,
            None => cam,
        };
        Ok(Self {
            inner: cam
                .with_k1(k1)
                .and_then(|c| c.with_higher_distortion([k2, k3, p1, p2]))
                .map_err(PyStaridError)?,
        })
    }

    /// ``(width_px, height_px)``.
    #[getter]
    fn image_size(&self) -> (f64, f64) {
        (self.inner.width_px, self.inner.height_px)
    }
    /// Full field of view across the width, degrees (of the pinhole).
    #[getter]
    fn fov_deg(&self) -> f64 {
        self.inner.fov_rad().to_degrees()
    }
    /// Widest angle two pixels of the sensor can span, degrees.
    #[getter]
    fn diagonal_fov_deg(&self) -> f64 {
        self.inner.diagonal_fov_rad().to_degrees()
    }
    /// Focal length, pixels.
    #[getter]
    fn focal_length_px(&self) -> f64 {
        self.inner.focal_length_px
    }
    /// Principal point ``(cx, cy)``, pixels.
    #[getter]
    fn principal_point(&self) -> (f64, f64) {
        (
            self.inner.principal_point_px[0],
            self.inner.principal_point_px[1],
        )
    }
    /// Radial distortion on normalised coordinates (negative: barrel).
    #[getter]
    fn k1(&self) -> f64 {
        self.inner.k1
    }
    /// Radial distortion of order r**4.
    #[getter]
    fn k2(&self) -> f64 {
        self.inner.k2
    }
    /// Radial distortion of order r**6.
    #[getter]
    fn k3(&self) -> f64 {
        self.inner.k3
    }
    /// Decentering distortion ``p1``.
    #[getter]
    fn p1(&self) -> f64 {
        self.inner.p1
    }
    /// Decentering distortion ``p2``.
    #[getter]
    fn p2(&self) -> f64 {
        self.inner.p2
    }

    /// The camera as a dict of plain numbers (``Camera(**d)`` makes it again, with
    /// ``image_size`` a tuple): ``image_size``, ``focal_length_px``, ``principal_point``,
    /// ``k1``, ``k2``, ``k3``, ``p1``, ``p2``.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let d = pyo3::types::PyDict::new(py);
        d.set_item("image_size", self.image_size())?;
        d.set_item("focal_length_px", self.inner.focal_length_px)?;
        d.set_item("principal_point", self.principal_point())?;
        for (name, v) in self.distortion() {
            d.set_item(name, v)?;
        }
        Ok(d)
    }

    /// Save the camera to a small JSON file (see ``starid.save_camera``).
    fn save(slf: &Bound<'_, Self>, path: &Bound<'_, PyAny>) -> PyResult<()> {
        slf.py()
            .import("starid.calibration")?
            .call_method1("save_camera", (slf, path))?;
        Ok(())
    }

    /// Pixels ``(N, 2)`` of camera-frame directions ``(N, 3)``; NaN for directions behind it.
    fn project<'py>(
        &self,
        py: Python<'py>,
        vectors: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = vectors.as_array();
        if v.ncols() != 3 {
            return Err(InvalidInputError::new_err(format!(
                "vectors must have shape (N, 3), got {:?}",
                v.shape()
            )));
        }
        let flat: Vec<f64> = v
            .rows()
            .into_iter()
            .flat_map(|r| {
                let p = self
                    .inner
                    .cam_to_pixel(&nalgebra::Vector3::new(r[0], r[1], r[2]));
                let (x, y) = p.unwrap_or((f64::NAN, f64::NAN));
                [x, y]
            })
            .collect();
        Ok(Array2::from_shape_vec((v.nrows(), 2), flat)
            .expect("2 columns")
            .into_pyarray(py))
    }

    /// Camera-frame unit vectors ``(N, 3)`` of pixels ``(N, 2)``; ``mirrored`` reads pixels of
    /// a mirrored frame (x reversed about the sensor).
    #[pyo3(signature = (xy, mirrored=false))]
    fn unproject<'py>(
        &self,
        py: Python<'py>,
        xy: PyReadonlyArray2<'py, f64>,
        mirrored: bool,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let c = crate::convert::centroids("xy", &xy)?;
        let flat: Vec<f64> = c
            .iter()
            .flat_map(|p| {
                let v = self.inner.pixel_to_cam(p[0], p[1], mirrored);
                [v.x, v.y, v.z]
            })
            .collect();
        Ok(Array2::from_shape_vec((c.len(), 3), flat)
            .expect("3 columns")
            .into_pyarray(py))
    }

    /// Pickling and copying: ``Camera(image_size, focal_length_px=..., principal_point=...,
    /// k1=..., k2=..., k3=..., p1=..., p2=...)``.
    fn __getnewargs_ex__<'py>(&self, py: Python<'py>) -> PyResult<NewArgs<'py>> {
        let d = self.to_dict(py)?;
        d.del_item("image_size")?;
        Ok(((self.image_size(),), d))
    }

    pub(crate) fn __repr__(&self) -> String {
        let c = &self.inner;
        let mut s = format!(
            "Camera(image_size=({}, {}), fov_deg={:.6}, focal_length_px={:.4}",
            c.width_px,
            c.height_px,
            self.fov_deg(),
            c.focal_length_px
        );
        if !c.is_ideal() {
            s += &format!(
                ", principal_point=({}, {})",
                c.principal_point_px[0], c.principal_point_px[1]
            );
            for (name, v) in self.distortion() {
                if v != 0.0 || name == "k1" {
                    s += &format!(", {name}={v}");
                }
            }
        }
        s + ")"
    }
}

impl PyCamera {
    /// The distortion terms by name.
    fn distortion(&self) -> [(&'static str, f64); 5] {
        let c = &self.inner;
        [
            ("k1", c.k1),
            ("k2", c.k2),
            ("k3", c.k3),
            ("p1", c.p1),
            ("p2", c.p2),
        ]
    }
}
