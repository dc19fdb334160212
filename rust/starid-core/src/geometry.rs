//! Directions on the sphere, the pinhole camera and the attitude parametrisation.
//!
//! Frames: ICRS (catalogue directions, unit vectors) and the camera frame (+x right,
//! +y down, +z along the boresight; right-handed). A rotation `r_icrs_to_cam` maps an ICRS
//! unit vector to camera coordinates: `v_cam = r_icrs_to_cam * v_icrs`.
//! Pixels: x right, y down, origin at the sensor's top-left corner; the principal point is
//! the sensor centre `(W/2, H/2)`.

use nalgebra::{Matrix3, Rotation3, Vector3};

use crate::error::{Error, Result};

/// Unit vector of a direction given by right ascension and declination in radians.
#[inline]
pub fn radec_to_unit(ra_rad: f64, dec_rad: f64) -> Vector3<f64> {
    let (sd, cd) = dec_rad.sin_cos();
    let (sr, cr) = ra_rad.sin_cos();
    Vector3::new(cd * cr, cd * sr, sd)
}

/// Right ascension in `[0, 2π)` and declination in `[-π/2, π/2]` (radians) of a vector.
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
#[inline]
pub fn angle_between(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// Angle in radians of the rotation taking `a` to `b`, accurate for nearly equal rotations
/// (where an arccos of the trace loses half the digits or returns NaN).
pub fn rotation_angle_between(a: &Rotation3<f64>, b: &Rotation3<f64>) -> f64 {
    let q = nalgebra::UnitQuaternion::from_rotation_matrix(&(a.inverse() * b));
    2.0 * q.imag().norm().atan2(q.w.abs())
}

/// A pinhole camera: sensor size and focal length in pixels, principal point at the centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Sensor width in pixels.
    pub width_px: f64,
    /// Sensor height in pixels.
    pub height_px: f64,
    /// Focal length in pixels.
    pub focal_length_px: f64,
}

impl Camera {
    /// Camera whose full field of view across the width is `fov_rad`.
    ///
    /// # Errors
    /// `InvalidInput` when the size is not positive and finite or the field of view is outside (0, 179°).
    pub fn from_fov(fov_rad: f64, width_px: f64, height_px: f64) -> Result<Self> {
        check_sensor(width_px, height_px)?;
        if !fov_rad.is_finite() || fov_rad <= 0.0 || fov_rad >= 179f64.to_radians() {
            return Err(Error::invalid_input(format!(
                "field of view must be in (0, 179) degrees, got {} degrees",
                fov_rad.to_degrees()
            )));
        }
        let focal_length_px = 0.5 * width_px / (0.5 * fov_rad).tan();
        Ok(Self {
            width_px,
            height_px,
            focal_length_px,
        })
    }

    /// Camera with a given focal length in pixels.
    ///
    /// # Errors
    /// `InvalidInput` when the size or the focal length is not positive and finite.
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
        })
    }

    /// Full field of view across the width, radians.
    pub fn fov_rad(&self) -> f64 {
        2.0 * (0.5 * self.width_px / self.focal_length_px).atan()
    }

    /// Full field of view across the diagonal, radians: the largest angle two stars of one frame can span.
    pub fn diagonal_fov_rad(&self) -> f64 {
        let half_diag = 0.5 * self.width_px.hypot(self.height_px);
        2.0 * (half_diag / self.focal_length_px).atan()
    }

    /// Unit vector in the camera frame of pixel `(x, y)`; `mirrored` reverses the x axis.
    #[inline]
    pub fn pixel_to_cam(&self, x: f64, y: f64, mirrored: bool) -> Vector3<f64> {
        let mut dx = x - 0.5 * self.width_px;
        if mirrored {
            dx = -dx;
        }
        Vector3::new(dx, y - 0.5 * self.height_px, self.focal_length_px).normalize()
    }

    /// Pixel of a camera-frame direction, or `None` behind the camera.
    #[inline]
    pub fn cam_to_pixel(&self, v_cam: &Vector3<f64>) -> Option<(f64, f64)> {
        if v_cam.z <= 0.0 {
            return None;
        }
        let s = self.focal_length_px / v_cam.z;
        Some((
            0.5 * self.width_px + s * v_cam.x,
            0.5 * self.height_px + s * v_cam.y,
        ))
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

/// Camera attitude from boresight RA/Dec and roll (radians).
///
/// At roll 0 the image's up direction (−y) points to celestial north and +x to the west
/// (east is left, as on the sky seen from inside the sphere); increasing roll turns the camera's
/// +x axis toward its +y axis.
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

/// Camera axes (x, y, z) in ICRS at zero roll for a boresight (ra, dec).
fn zero_roll_axes(ra_rad: f64, dec_rad: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let z = radec_to_unit(ra_rad, dec_rad);
    let (sr, cr) = ra_rad.sin_cos();
    let (sd, cd) = dec_rad.sin_cos();
    let east = Vector3::new(-sr, cr, 0.0);
    let north = Vector3::new(-sd * cr, -sd * sr, cd);
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
    fn camera_rejects_absurd_fov() {
        assert!(Camera::from_fov(0.0, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(f64::NAN, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(3.2, 512.0, 512.0).is_err());
        assert!(Camera::from_fov(0.2, 0.0, 512.0).is_err());
        let c = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
        assert!((c.fov_rad() - 12f64.to_radians()).abs() < 1e-12);
    }
}
