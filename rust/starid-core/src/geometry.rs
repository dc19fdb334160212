//! Directions on the sphere, the pinhole camera and the attitude parametrisation.
//!
//! Frames: ICRS (catalogue directions, unit vectors) and the camera frame (+x right,
//! +y down, +z along the boresight; right-handed). A rotation `r_icrs_to_cam` maps an ICRS
//! unit vector to camera coordinates: `v_cam = r_icrs_to_cam * v_icrs`.
//! Pixels: x right, y down, origin at the sensor's top-left corner; the principal point is
//! the sensor centre `(W/2, H/2)`.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3, Vector4};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::error::{Error, Result};

/// A uniformly distributed random rotation: a quaternion of four normal components, normalised
/// (the sampling that the guide stars' and the pointing's Monte Carlo draws use, and the
/// simulator's attitudes).
///
/// # Example
/// ```
/// use rand::SeedableRng;
/// let r = starid_core::geometry::random_rotation(&mut rand::rngs::StdRng::seed_from_u64(1));
/// assert!((r.matrix().determinant() - 1.0).abs() < 1e-12);
/// ```
pub fn random_rotation(rng: &mut impl Rng) -> Rotation3<f64> {
    let v = Vector4::from_fn(|_, _| StandardNormal.sample(rng));
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(v));
    q.to_rotation_matrix()
}

/// Unit vector of a direction given by right ascension and declination in radians.
///
/// # Example
/// ```
/// let v = starid_core::geometry::radec_to_unit(0.0, std::f64::consts::FRAC_PI_2);
/// assert!((v.z - 1.0).abs() < 1e-12);
/// ```
#[inline]
pub fn radec_to_unit(ra_rad: f64, dec_rad: f64) -> Vector3<f64> {
    let (sd, cd) = dec_rad.sin_cos();
    let (sr, cr) = ra_rad.sin_cos();
    Vector3::new(cd * cr, cd * sr, sd)
}

/// Right ascension in `[0, 2π)` and declination in `[-π/2, π/2]` (radians) of a vector.
///
/// # Example
/// ```
/// use starid_core::geometry::{radec_to_unit, unit_to_radec};
/// let (ra, dec) = unit_to_radec(&radec_to_unit(1.0, -0.5));
/// assert!((ra - 1.0).abs() < 1e-12 && (dec + 0.5).abs() < 1e-12);
/// ```
#[inline]
pub fn unit_to_radec(v: &Vector3<f64>) -> (f64, f64) {
    let n = v.norm();
    let dec = (v.z / n).clamp(-1.0, 1.0).asin();
    let mut ra = v.y.atan2(v.x);
    if ra < 0.0 {
        ra += std::f64::consts::TAU;
    }
    if ra >= std::f64::consts::TAU {
        ra -= std::f64::consts::TAU;
    }
    (ra, dec)
}

/// Angle between two vectors in radians, accurate at all angles (atan2 form).
///
/// # Example
/// ```
/// use nalgebra::Vector3;
/// let a = starid_core::geometry::angle_between(&Vector3::x(), &Vector3::y());
/// assert!((a - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
/// ```
#[inline]
pub fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Angle in radians between two unit vectors from their chord, `2·asin(|a − b| / 2)`: as
/// accurate as [`angle_between`] up to 81° (it falls back to it beyond) and about twice as
/// fast, for the index builds that measure every pair of a catalogue.
///
/// # Example
/// ```
/// use nalgebra::Vector3;
/// use starid_core::geometry::{angle_between, unit_separation};
/// let a = Vector3::new(1.0, 0.02, -0.01).normalize();
/// let b = Vector3::new(0.99, -0.03, 0.05).normalize();
/// assert!((unit_separation(&a, &b) - angle_between(&a, &b)).abs() < 1e-15);
/// assert!((unit_separation(&a, &-a) - std::f64::consts::PI).abs() < 1e-15);
/// ```
#[inline]
pub fn unit_separation(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    // Chord 1.3 is 81°: beyond it asin's slope grows and the atan2 form keeps the digits.
    let chord = (a - b).norm();
    if chord < 1.3 {
        2.0 * (0.5 * chord).asin()
    } else {
        angle_between(a, b)
    }
}

/// Angle in radians of the rotation taking `a` to `b`, accurate for nearly equal rotations
/// (where an arccos of the trace loses half the digits or returns NaN).
///
/// # Example
/// ```
/// use nalgebra::{Rotation3, Vector3};
/// let a = Rotation3::identity();
/// let b = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.25);
/// assert!((starid_core::geometry::rotation_angle_between(&a, &b) - 0.25).abs() < 1e-12);
/// ```
pub fn rotation_angle_between(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&(a.inverse() * b));
    2.0 * q.imag().norm().atan2(q.w.abs())
}

/// The camera model every part of starid uses (identification, refinement, calibration, the
/// simulator, WCS): a pinhole of focal length `f` (pixels) with principal point `c` and
/// Brown–Conrady distortion (radial `k1, k2, k3`, decentering `p1, p2`). A direction
/// `(X, Y, Z)` in the camera frame (+z along the boresight, +x along the pixel rows, +y down the
/// columns) is imaged at `c + f · (u_d, v_d)`, with `(u, v) = (X / Z, Y / Z)`, `r² = u² + v²`,
///
/// `u_d = u (1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 u v + p2 (r² + 2 u²)`,
/// `v_d = v (1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2 v²) + 2 p2 u v`.
///
/// With only `k1` (the common case) this is `c + f · (u, v) · (1 + k1 · r²)`.
///
/// Pixels follow the project's convention: x right, y down, origin at the sensor's top-left
/// corner, so the default principal point of a W×H sensor is `(W/2, H/2)`.
///
/// # Example
/// ```
/// use starid_core::Camera;
/// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
/// assert!((cam.focal_length_px - 2435.677).abs() < 0.001);
/// let v = cam.pixel_to_cam(100.0, 300.0, false);
/// let (x, y) = cam.cam_to_pixel(&v).unwrap();
/// assert!((x - 100.0).abs() < 1e-9 && (y - 300.0).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Sensor width in pixels.
    pub width_px: f64,
    /// Sensor height in pixels.
    pub height_px: f64,
    /// Focal length in pixels.
    pub focal_length_px: f64,
    /// Principal point `(cx, cy)` in pixels; the sensor centre by default.
    pub principal_point_px: [f64; 2],
    /// Radial distortion on normalised coordinates (negative: barrel); 0 by default.
    pub k1: f64,
    /// Radial distortion of order r⁴; 0 by default.
    pub k2: f64,
    /// Radial distortion of order r⁶; 0 by default.
    pub k3: f64,
    /// Decentering (tangential) distortion along y; 0 by default.
    pub p1: f64,
    /// Decentering (tangential) distortion along x; 0 by default.
    pub p2: f64,
}

/// Largest |k1| (and |k2|, |k3|) a camera accepts.
pub const MAX_ABS_K1: f64 = 10.0;
/// Largest |p1|, |p2| a camera accepts.
pub const MAX_ABS_P: f64 = 1.0;

/// The distortion terms of a [`Camera`] beyond `k1`: `[k2, k3, p1, p2]`.
pub type HigherDistortion = [f64; 4];

impl Camera {
    /// Camera whose full field of view across the width is `fov_rad`.
    ///
    /// # Errors
    /// `InvalidInput` when the size is not positive and finite or the field of view is outside (0, 179°).
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_fov(20f64.to_radians(), 1024.0, 1024.0).unwrap();
    /// assert!((cam.fov_rad().to_degrees() - 20.0).abs() < 1e-12);
    /// ```
    pub fn from_fov(fov_rad: f64, width_px: f64, height_px: f64) -> Result<Self> {
        check_sensor(width_px, height_px)?;
        if !fov_rad.is_finite() || fov_rad <= 0.0 || fov_rad >= 179f64.to_radians() {
            return Err(Error::invalid_input(format!(
                "field of view must be in (0, 179) degrees, got {} degrees",
                fov_rad.to_degrees()
            )));
        }
        Self::from_focal_length(0.5 * width_px / (0.5 * fov_rad).tan(), width_px, height_px)
    }

    /// Camera with a given focal length in pixels.
    ///
    /// # Errors
    /// `InvalidInput` when the size or the focal length is not positive and finite.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(2000.0, 640.0, 480.0).unwrap();
    /// assert_eq!(cam.principal_point_px, [320.0, 240.0]);
    /// ```
    pub fn from_focal_length(focal_length_px: f64, width_px: f64, height_px: f64) -> Result<Self> {
        check_sensor(width_px, height_px)?;
        if !focal_length_px.is_finite() || focal_length_px <= 0.0 {
            return Err(Error::invalid_input(format!(
                "focal length must be positive and finite, got {focal_length_px} px"
            )));
        }
        Ok(Self {
            width_px,
            height_px,
            focal_length_px,
            principal_point_px: [0.5 * width_px, 0.5 * height_px],
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        })
    }

    /// The same camera with another principal point (pixels).
    ///
    /// # Errors
    /// `InvalidInput` when a coordinate is not finite or lies farther than one sensor size
    /// outside the sensor.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(2000.0, 640.0, 480.0).unwrap();
    /// let off = cam.with_principal_point(330.0, 236.5).unwrap();
    /// let (x, y) = off.cam_to_pixel(&nalgebra::Vector3::z()).unwrap();
    /// assert_eq!((x, y), (330.0, 236.5));
    /// ```
    pub fn with_principal_point(mut self, cx: f64, cy: f64) -> Result<Self> {
        let ok = |c: f64, size: f64| c.is_finite() && (-size..=2.0 * size).contains(&c);
        if !ok(cx, self.width_px) || !ok(cy, self.height_px) {
            return Err(Error::invalid_input(format!(
                "principal point ({cx}, {cy}) must be finite and within one sensor size of the {} x {} sensor",
                self.width_px, self.height_px
            )));
        }
        self.principal_point_px = [cx, cy];
        Ok(self)
    }

    /// The same camera with radial distortion `k1` (see [`Camera`]).
    ///
    /// # Errors
    /// `InvalidInput` when `k1` is not finite or |k1| > 10.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap();
    /// let barrel = cam.with_k1(-0.05).unwrap();
    /// let v = barrel.pixel_to_cam(950.0, 900.0, false);
    /// let (x, y) = barrel.cam_to_pixel(&v).unwrap();
    /// assert!((x - 950.0).abs() < 1e-9 && (y - 900.0).abs() < 1e-9);
    /// ```
    pub fn with_k1(mut self, k1: f64) -> Result<Self> {
        if !k1.is_finite() || k1.abs() > MAX_ABS_K1 {
            return Err(Error::invalid_input(format!(
                "k1 must be finite and within [-{MAX_ABS_K1}, {MAX_ABS_K1}], got {k1}"
            )));
        }
        self.k1 = k1;
        Ok(self)
    }

    /// The same camera with the distortion terms beyond `k1`: `[k2, k3, p1, p2]` (see
    /// [`Camera`]).
    ///
    /// # Errors
    /// `InvalidInput` when a term is not finite, |k2| or |k3| > 10, or |p1| or |p2| > 1.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap();
    /// let lens = cam.with_k1(-0.1).unwrap().with_higher_distortion([0.02, 0.0, 1e-3, -5e-4]).unwrap();
    /// let v = lens.pixel_to_cam(950.0, 900.0, false);
    /// let (x, y) = lens.cam_to_pixel(&v).unwrap();
    /// assert!((x - 950.0).abs() < 1e-9 && (y - 900.0).abs() < 1e-9);
    /// ```
    pub fn with_higher_distortion(mut self, terms: HigherDistortion) -> Result<Self> {
        let [k2, k3, p1, p2] = terms;
        let radial_ok = |k: f64| k.is_finite() && k.abs() <= MAX_ABS_K1;
        let decentering_ok = |p: f64| p.is_finite() && p.abs() <= MAX_ABS_P;
        if !(radial_ok(k2) && radial_ok(k3) && decentering_ok(p1) && decentering_ok(p2)) {
            return Err(Error::invalid_input(format!(
                "distortion must be finite with |k2|, |k3| <= {MAX_ABS_K1} and |p1|, |p2| <= {MAX_ABS_P}, \
                 got k2={k2}, k3={k3}, p1={p1}, p2={p2}"
            )));
        }
        (self.k2, self.k3, self.p1, self.p2) = (k2, k3, p1, p2);
        Ok(self)
    }

    /// The distortion terms beyond `k1`: `[k2, k3, p1, p2]`.
    pub fn higher_distortion(&self) -> HigherDistortion {
        [self.k2, self.k3, self.p1, self.p2]
    }

    /// Whether the camera's only distortion (if any) is `k1`.
    #[inline]
    pub fn is_k1_only(&self) -> bool {
        self.k2 == 0.0 && self.k3 == 0.0 && self.p1 == 0.0 && self.p2 == 0.0
    }

    /// Distorted normalised coordinates `(u_d, v_d)` of ideal ones `(u, v)` and the Jacobian
    /// `[[∂u_d/∂u, ∂u_d/∂v], [∂v_d/∂u, ∂v_d/∂v]]` (see [`Camera`]).
    #[inline]
    pub fn distort(&self, u: f64, v: f64) -> ((f64, f64), [[f64; 2]; 2]) {
        let r2 = u * u + v * v;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        let d_radial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * r2 * self.k3);
        let (p1, p2) = (self.p1, self.p2);
        let ud = u * radial + 2.0 * p1 * u * v + p2 * (r2 + 2.0 * u * u);
        let vd = v * radial + p1 * (r2 + 2.0 * v * v) + 2.0 * p2 * u * v;
        let j = [
            [
                radial + 2.0 * u * u * d_radial + 2.0 * p1 * v + 6.0 * p2 * u,
                2.0 * u * v * d_radial + 2.0 * p1 * u + 2.0 * p2 * v,
            ],
            [
                2.0 * u * v * d_radial + 2.0 * p1 * u + 2.0 * p2 * v,
                radial + 2.0 * v * v * d_radial + 6.0 * p1 * v + 2.0 * p2 * u,
            ],
        ];
        ((ud, vd), j)
    }

    /// Whether the principal point is the sensor centre and there is no distortion: the case
    /// the identification's fast paths assume.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_fov(0.2, 512.0, 512.0).unwrap();
    /// assert!(cam.is_ideal() && !cam.with_k1(0.01).unwrap().is_ideal());
    /// ```
    pub fn is_ideal(&self) -> bool {
        self.k1 == 0.0
            && self.is_k1_only()
            && self.principal_point_px == [0.5 * self.width_px, 0.5 * self.height_px]
    }

    /// Full field of view across the width, radians (of the pinhole, ignoring distortion).
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 2000.0, 1000.0).unwrap();
    /// assert!((cam.fov_rad() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    /// ```
    pub fn fov_rad(&self) -> f64 {
        2.0 * (0.5 * self.width_px / self.focal_length_px).atan()
    }

    /// Full field of view across the diagonal, radians: the largest angle two stars of one
    /// frame can span (of the pinhole; with barrel distortion, of the sensor's farther corner
    /// from the principal point, whichever is larger).
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// assert!((cam.diagonal_fov_rad().to_degrees() - 16.9).abs() < 0.1);
    /// ```
    pub fn diagonal_fov_rad(&self) -> f64 {
        let half_diag = 0.5 * self.width_px.hypot(self.height_px);
        let pinhole = 2.0 * (half_diag / self.focal_length_px).atan();
        if self.is_ideal() {
            return pinhole;
        }
        // Widest angle between two corners' rays.
        let (w, h) = (self.width_px, self.height_px);
        let corners =
            [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)].map(|(x, y)| self.pixel_to_cam(x, y, false));
        let mut widest = pinhole;
        for a in 0..4 {
            for b in a + 1..4 {
                widest = widest.max(angle_between(&corners[a], &corners[b]));
            }
        }
        widest
    }

    /// Pixel of normalised camera coordinates `(u, v) = (X/Z, Y/Z)`.
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap();
    /// assert_eq!(cam.normalized_to_pixel(0.1, -0.2), (600.0, 300.0));
    /// ```
    #[inline]
    pub fn normalized_to_pixel(&self, u: f64, v: f64) -> (f64, f64) {
        if !self.is_k1_only() {
            let ((ud, vd), _) = self.distort(u, v);
            return (
                self.principal_point_px[0] + self.focal_length_px * ud,
                self.principal_point_px[1] + self.focal_length_px * vd,
            );
        }
        let g = 1.0 + self.k1 * (u * u + v * v);
        let f = self.focal_length_px * g;
        (
            self.principal_point_px[0] + f * u,
            self.principal_point_px[1] + f * v,
        )
    }

    /// Normalised camera coordinates `(u, v)` of a pixel (inverting the distortion by Newton's
    /// method; exact without distortion).
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap().with_k1(0.1).unwrap();
    /// let (x, y) = cam.normalized_to_pixel(0.3, 0.2);
    /// let (u, v) = cam.pixel_to_normalized(x, y);
    /// assert!((u - 0.3).abs() < 1e-12 && (v - 0.2).abs() < 1e-12);
    /// ```
    #[inline]
    pub fn pixel_to_normalized(&self, x: f64, y: f64) -> (f64, f64) {
        let (du, dv) = (
            (x - self.principal_point_px[0]) / self.focal_length_px,
            (y - self.principal_point_px[1]) / self.focal_length_px,
        );
        if !self.is_k1_only() {
            return self.undistort(du, dv);
        }
        if self.k1 == 0.0 {
            return (du, dv);
        }
        // Solve r·(1 + k1 r²) = d for the undistorted radius r, then scale.
        let d = du.hypot(dv);
        if d == 0.0 {
            return (0.0, 0.0);
        }
        let mut r = d;
        for _ in 0..20 {
            let f = r * (1.0 + self.k1 * r * r) - d;
            let fp = 1.0 + 3.0 * self.k1 * r * r;
            if fp.abs() < 1e-12 {
                break;
            }
            let step = f / fp;
            r -= step;
            if step.abs() < 1e-15 * (1.0 + r.abs()) {
                break;
            }
        }
        let s = r / d;
        (du * s, dv * s)
    }

    /// Ideal normalised coordinates of distorted ones, by Newton's method on the full model.
    fn undistort(&self, ud: f64, vd: f64) -> (f64, f64) {
        let (mut u, mut v) = (ud, vd);
        for _ in 0..30 {
            let ((fu, fv), j) = self.distort(u, v);
            let (ru, rv) = (fu - ud, fv - vd);
            let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
            if det.abs() < 1e-12 {
                break;
            }
            let su = (j[1][1] * ru - j[0][1] * rv) / det;
            let sv = (j[0][0] * rv - j[1][0] * ru) / det;
            u -= su;
            v -= sv;
            if su.abs().max(sv.abs()) < 1e-15 * (1.0 + u.abs().max(v.abs())) {
                break;
            }
        }
        (u, v)
    }

    /// Unit vector in the camera frame of pixel `(x, y)`. `mirrored` reads the pixel of a
    /// mirrored frame: the camera's image with x reversed about the sensor (`x → W − x`).
    ///
    /// # Example
    /// ```
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap();
    /// let v = cam.pixel_to_cam(500.0, 500.0, false);
    /// assert!((v.z - 1.0).abs() < 1e-12);
    /// let m = cam.pixel_to_cam(600.0, 500.0, true);
    /// assert!(m.x < 0.0); // a mirrored frame reads x from the other side
    /// ```
    #[inline]
    pub fn pixel_to_cam(&self, x: f64, y: f64, mirrored: bool) -> Vector3<f64> {
        let x = if mirrored { self.width_px - x } else { x };
        let (u, v) = self.pixel_to_normalized(x, y);
        Vector3::new(u, v, 1.0).normalize()
    }

    /// Pixel of a camera-frame direction, or `None` behind the camera.
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// let cam = starid_core::Camera::from_focal_length(1000.0, 1000.0, 1000.0).unwrap();
    /// assert_eq!(cam.cam_to_pixel(&Vector3::new(0.1, 0.0, 1.0)), Some((600.0, 500.0)));
    /// assert_eq!(cam.cam_to_pixel(&Vector3::new(0.0, 0.0, -1.0)), None);
    /// ```
    #[inline]
    pub fn cam_to_pixel(&self, v_cam: &Vector3<f64>) -> Option<(f64, f64)> {
        if v_cam.z <= 0.0 {
            return None;
        }
        Some(self.normalized_to_pixel(v_cam.x / v_cam.z, v_cam.y / v_cam.z))
    }
}

fn check_sensor(width_px: f64, height_px: f64) -> Result<()> {
    let ok = |v: f64| (1.0..=1.0e6).contains(&v);
    if !ok(width_px) || !ok(height_px) {
        return Err(Error::invalid_input(format!(
            "image size must be between 1 and 1e6 pixels on each side, got {width_px} x {height_px}"
        )));
    }
    Ok(())
}

/// The quaternion `[w, x, y, z]` (scalar first) of a rotation, with the sign rule every
/// output of starid follows: `w >= 0` (of `q` and `−q`, which are the same rotation).
///
/// # Example
/// ```
/// use nalgebra::{Rotation3, Vector3};
/// let r = Rotation3::from_axis_angle(&Vector3::z_axis(), 3.0);
/// let q = starid_core::geometry::quaternion_wxyz(&r);
/// assert!(q[0] >= 0.0 && (q[3] - 1.5f64.sin()).abs() < 1e-12);
/// ```
pub fn quaternion_wxyz(r: &Rotation3<f64>) -> [f64; 4] {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(r);
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    [s * q.w, s * q.i, s * q.j, s * q.k]
}

/// The rotation of a quaternion `[w, x, y, z]` (either sign), normalised.
///
/// # Errors
/// `InvalidInput` when a component is not finite or the norm is not within 1e-3 of 1.
///
/// # Example
/// ```
/// use starid_core::geometry::{quaternion_wxyz, rotation_from_wxyz, attitude_from_radec_roll};
/// let r = attitude_from_radec_roll(1.0, 0.5, 0.25);
/// let back = rotation_from_wxyz(quaternion_wxyz(&r)).unwrap();
/// assert!(starid_core::geometry::rotation_angle_between(&r, &back) < 1e-12);
/// ```
pub fn rotation_from_wxyz(q: [f64; 4]) -> Result<Rotation3<f64>> {
    let n = q.iter().map(|c| c * c).sum::<f64>().sqrt();
    if !n.is_finite() || (n - 1.0).abs() > 1e-3 {
        return Err(Error::invalid_input(format!(
            "a quaternion [w, x, y, z] must be finite with norm 1 (within 1e-3), got {q:?}"
        )));
    }
    let uq = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
        q[0], q[1], q[2], q[3],
    ));
    Ok(uq.to_rotation_matrix())
}

/// Camera attitude from boresight RA/Dec and roll (radians).
///
/// At roll 0 the image's up direction (−y) points to celestial north and +x to the west
/// (east is left, as on the sky seen from inside the sphere); increasing roll turns the camera's
/// +x axis toward its +y axis.
///
/// # Example
/// ```
/// use starid_core::geometry::{attitude_from_radec_roll, radec_to_unit};
/// let r = attitude_from_radec_roll(1.0, 0.5, 0.0);
/// // The boresight direction maps to the camera's +z.
/// let z = r * radec_to_unit(1.0, 0.5);
/// assert!((z.z - 1.0).abs() < 1e-12);
/// ```
pub fn attitude_from_radec_roll(ra_rad: f64, dec_rad: f64, roll_rad: f64) -> Rotation3<f64> {
    let (x0, y0, z) = zero_roll_axes(ra_rad, dec_rad);
    let (s, c) = roll_rad.sin_cos();
    let x = c * x0 + s * y0;
    let y = -s * x0 + c * y0;
    Rotation3::from_matrix_unchecked(Matrix3::from_rows(&[
        x.transpose(),
        y.transpose(),
        z.transpose(),
    ]))
}

/// Boresight RA, Dec and roll (radians, RA and roll in `[0, 2π)`) of an attitude; inverse of
/// [`attitude_from_radec_roll`].
///
/// # Example
/// ```
/// use starid_core::geometry::{attitude_from_radec_roll, radec_roll_from_attitude};
/// let (ra, dec, roll) = radec_roll_from_attitude(&attitude_from_radec_roll(1.0, 0.5, 2.0));
/// assert!((ra - 1.0).abs() < 1e-12 && (dec - 0.5).abs() < 1e-12 && (roll - 2.0).abs() < 1e-12);
/// ```
pub fn radec_roll_from_attitude(r_icrs_to_cam: &Rotation3<f64>) -> (f64, f64, f64) {
    let m = r_icrs_to_cam.matrix();
    let z: Vector3<f64> = m.row(2).transpose();
    let x: Vector3<f64> = m.row(0).transpose();
    let (ra, dec) = unit_to_radec(&z);
    let (x0, y0, _) = zero_roll_axes(ra, dec);
    let mut roll = x.dot(&y0).atan2(x.dot(&x0));
    if roll < 0.0 {
        roll += std::f64::consts::TAU;
    }
    (ra, dec, roll)
}

/// Local east and north unit vectors on the sky at (ra, dec), radians: the directions of
/// increasing RA and Dec. At a pole "east" is the direction of RA + 90°.
///
/// # Example
/// ```
/// let (e, n) = starid_core::geometry::east_north(0.0, 0.0);
/// assert_eq!((e.y, n.z), (1.0, 1.0));
/// ```
pub fn east_north(ra_rad: f64, dec_rad: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (sr, cr) = ra_rad.sin_cos();
    let (sd, cd) = dec_rad.sin_cos();
    (
        Vector3::new(-sr, cr, 0.0),
        Vector3::new(-sd * cr, -sd * sr, cd),
    )
}

/// Local east and north at the direction `d` (unit vector), as [`east_north`] of its RA/Dec.
///
/// # Example
/// ```
/// use starid_core::geometry::{east_north_at, radec_to_unit};
/// let (e, n) = east_north_at(&radec_to_unit(0.0, 0.0));
/// assert!((e.y - 1.0).abs() < 1e-12 && (n.z - 1.0).abs() < 1e-12);
/// ```
pub fn east_north_at(d: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let (ra, dec) = unit_to_radec(d);
    east_north(ra, dec)
}

/// Camera axes (x, y, z) in ICRS at zero roll for a boresight (ra, dec).
fn zero_roll_axes(ra_rad: f64, dec_rad: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let z = radec_to_unit(ra_rad, dec_rad);
    let (east, north) = east_north(ra_rad, dec_rad);
    // x = -east (west), y = -north (image down = celestial south); x × y = east × north = z.
    (-east, -north, z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radec_round_trip() {
        for &(ra, dec) in &[(0.1, 0.2), (3.0, -1.2), (6.2, 1.5), (0.0, 0.0)] {
            let (r, d) = unit_to_radec(&radec_to_unit(ra, dec));
            assert!((r - ra).abs() < 1e-12 && (d - dec).abs() < 1e-12);
        }
    }

    #[test]
    fn attitude_round_trip_and_right_handed() {
        let r = attitude_from_radec_roll(1.0, 0.5, 0.7);
        assert!((r.matrix().determinant() - 1.0).abs() < 1e-12);
        let (ra, dec, roll) = radec_roll_from_attitude(&r);
        assert!(
            (ra - 1.0).abs() < 1e-12 && (dec - 0.5).abs() < 1e-12 && (roll - 0.7).abs() < 1e-12
        );
        // The boresight maps to +z.
        let z = r * radec_to_unit(1.0, 0.5);
        assert!((z - Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn north_is_up_at_zero_roll() {
        let r = attitude_from_radec_roll(0.3, 0.2, 0.0);
        let cam = Camera::from_fov(10f64.to_radians(), 100.0, 100.0).unwrap();
        let (_, y) = cam.cam_to_pixel(&(r * radec_to_unit(0.3, 0.21))).unwrap();
        assert!(
            y < 50.0,
            "a star north of the boresight is above the centre"
        );
        let (x, _) = cam.cam_to_pixel(&(r * radec_to_unit(0.31, 0.2))).unwrap();
        assert!(
            x < 50.0,
            "a star east of the boresight is left of the centre"
        );
    }

    #[test]
    fn chord_separation_matches_the_atan2_form_at_every_angle() {
        // From a microradian to opposite vectors, across the switch between the two forms.
        let a = radec_to_unit(0.7, -0.3);
        for k in 0..=4000 {
            let angle = 1e-6 + (std::f64::consts::PI - 1e-6) * f64::from(k) / 4000.0;
            let axis = a.cross(&Vector3::z()).normalize();
            let b =
                nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), angle)
                    * a;
            let (fast, exact) = (unit_separation(&a, &b), angle_between(&a, &b));
            assert!(
                (fast - exact).abs() < 2e-15,
                "{angle}: {fast} against {exact}"
            );
        }
    }

    #[test]
    fn camera_rejects_absurd_fov() {
        assert!(Camera::from_fov(0.0, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(f64::NAN, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(3.2, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(0.2, 0.0, 512.0).is_err());
        let c = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
        assert!((c.fov_rad() - 12f64.to_radians()).abs() < 1e-12);
    }
}
