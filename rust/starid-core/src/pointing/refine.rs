//! Refinement of attitude and camera over all matched stars.
//!
//! Levenberg–Marquardt over the attitude (3 small rotations), the focal length and optionally
//! the principal point and the first radial distortion coefficient `k1`
//! (`x = cx + f·u·(1 + k1·(u² + v²))`, `u, v` the normalised camera coordinates), minimising
//! pixel residuals of all matched stars, with the covariance `σ²(JᵀJ)⁻¹` of the estimate.

use nalgebra::{DMatrix, DVector, Matrix2, Rotation3, Vector2, Vector3};

use super::{check_focal, check_stars};
use crate::attitude::wahba_svd;
use crate::error::{Error, Result};
use crate::geometry::{angle_between, Camera};
use crate::lsq::{self, Problem};

/// What [`refine_pointing`] fits besides the attitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefineOptions {
    /// Fit the focal length.
    pub fit_focal: bool,
    /// Fit the principal point.
    pub fit_principal_point: bool,
    /// Fit the radial distortion `k1`.
    pub fit_k1: bool,
    /// The image is mirrored (x reversed about the sensor, `x → W − x`).
    pub mirrored: bool,
    /// Centroid noise, 1σ per axis in pixels, for the covariance; `None` estimates it from the
    /// residuals.
    pub sigma_px: Option<f64>,
    /// Iteration limit.
    pub max_iterations: usize,
}

impl Default for RefineOptions {
    fn default() -> Self {
        Self {
            fit_focal: true,
            fit_principal_point: false,
            fit_k1: false,
            mirrored: false,
            sigma_px: None,
            max_iterations: 100,
        }
    }
}

/// The outcome of [`refine_pointing`].
#[derive(Debug, Clone)]
pub struct PointingFit {
    /// Rotation ICRS → camera (of the x-reversed image when `mirrored`).
    pub r_icrs_to_cam: Rotation3<f64>,
    /// The fitted camera (principal point in the input image's coordinates).
    pub camera: Camera,
    /// Parameter names in covariance order: `rot_x`, `rot_y`, `rot_z` (small rotations about
    /// the camera axes, radians), then `focal_px`, `cx_px`, `cy_px`, `k1` as fitted.
    pub parameters: Vec<&'static str>,
    /// Covariance of the parameters; `None` when the fit does not determine them.
    pub covariance: Option<DMatrix<f64>>,
    /// Noise used for the covariance (given or estimated), pixels.
    pub sigma_px: f64,
    /// Residual (observed − model) per star, pixels, in input image coordinates.
    pub residuals_px: Vec<[f64; 2]>,
    /// Root mean square residual per axis, pixels.
    pub rms_px: f64,
    /// Iterations taken.
    pub iterations: usize,
    /// Whether the iteration converged.
    pub converged: bool,
}

impl PointingFit {
    fn var(&self, name: &str) -> f64 {
        match (
            &self.covariance,
            self.parameters.iter().position(|p| *p == name),
        ) {
            (Some(c), Some(k)) => c[(k, k)],
            (None, _) => f64::INFINITY,
            (_, None) => 0.0,
        }
    }

    /// 1σ angular error of the boresight, radians (√ of var rot_x + var rot_y).
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// use starid_core::{geometry::attitude_from_radec_roll, pointing::{fit_pointing, RefineOptions}, Camera};
    /// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
    /// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
    /// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
    /// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
    /// let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(2000.0), &RefineOptions { sigma_px: Some(0.1), ..Default::default() }).unwrap();
    /// assert!(fit.boresight_sigma_rad() > 0.0 && fit.boresight_sigma_rad() < 1e-4);
    /// ```
    pub fn boresight_sigma_rad(&self) -> f64 {
        (self.var("rot_x") + self.var("rot_y")).sqrt()
    }

    /// 1σ error of the roll about the boresight, radians.
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// use starid_core::{geometry::attitude_from_radec_roll, pointing::{fit_pointing, RefineOptions}, Camera};
    /// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
    /// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
    /// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
    /// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
    /// let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(2000.0), &RefineOptions { sigma_px: Some(0.1), ..Default::default() }).unwrap();
    /// assert!(fit.roll_sigma_rad() > fit.boresight_sigma_rad() * 0.1);
    /// ```
    pub fn roll_sigma_rad(&self) -> f64 {
        self.var("rot_z").sqrt()
    }

    /// 1σ error of the focal length, pixels (0 when it was not fitted).
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// use starid_core::{geometry::attitude_from_radec_roll, pointing::{fit_pointing, RefineOptions}, Camera};
    /// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
    /// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
    /// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
    /// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
    /// let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(2000.0), &RefineOptions { sigma_px: Some(0.1), ..Default::default() }).unwrap();
    /// assert!(fit.focal_sigma_px() > 0.0 && fit.focal_sigma_px() < 1.0);
    /// ```
    pub fn focal_sigma_px(&self) -> f64 {
        self.var("focal_px").sqrt()
    }

    /// 2×2 covariance of the boresight along the camera x and y axes, radians².
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// use starid_core::{geometry::attitude_from_radec_roll, pointing::{fit_pointing, RefineOptions}, Camera};
    /// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
    /// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
    /// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
    /// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
    /// let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(2000.0), &RefineOptions { sigma_px: Some(0.1), ..Default::default() }).unwrap();
    /// let c = fit.boresight_covariance().unwrap();
    /// assert!(c[(0, 0)] > 0.0 && c[(1, 1)] > 0.0);
    /// ```
    pub fn boresight_covariance(&self) -> Option<Matrix2<f64>> {
        let c = self.covariance.as_ref()?;
        // Rotating by φ moves the boresight by (φy, −φx) in camera x, y.
        Some(Matrix2::new(c[(1, 1)], -c[(0, 1)], -c[(1, 0)], c[(0, 0)]))
    }
}

struct Reprojection<'a> {
    stars: &'a [Vector3<f64>],
    /// Observed pixels, x already reversed for mirrored frames.
    xy: Vec<[f64; 2]>,
    options: RefineOptions,
}

#[derive(Clone)]
struct ReprojectionState {
    r: Rotation3<f64>,
    model: Camera,
}

impl Reprojection<'_> {
    fn n_params(&self) -> usize {
        3 + usize::from(self.options.fit_focal)
            + 2 * usize::from(self.options.fit_principal_point)
            + usize::from(self.options.fit_k1)
    }

    fn names(&self) -> Vec<&'static str> {
        let mut v = vec!["rot_x", "rot_y", "rot_z"];
        if self.options.fit_focal {
            v.push("focal_px");
        }
        if self.options.fit_principal_point {
            v.extend(["cx_px", "cy_px"]);
        }
        if self.options.fit_k1 {
            v.push("k1");
        }
        v
    }
}

impl Problem for Reprojection<'_> {
    type State = ReprojectionState;

    fn evaluate(&self, s: &ReprojectionState) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let n = self.stars.len();
        let p = self.n_params();
        let m = &s.model;
        let f = m.focal_length_px;
        let mut r = DVector::zeros(2 * n);
        let mut j = DMatrix::zeros(2 * n, p);
        for (i, star) in self.stars.iter().enumerate() {
            let w = s.r * star;
            if w.z <= 1e-6 {
                return None;
            }
            let (u, v) = (w.x / w.z, w.y / w.z);
            let rho2 = u * u + v * v;
            let g = 1.0 + m.k1 * rho2;
            let (px, py) = m.normalized_to_pixel(u, v);
            r[2 * i] = px - self.xy[i][0];
            r[2 * i + 1] = py - self.xy[i][1];
            // d(px, py)/d(u, v).
            let dxu = f * (g + 2.0 * m.k1 * u * u);
            let dxv = f * 2.0 * m.k1 * u * v;
            let dyu = dxv;
            let dyv = f * (g + 2.0 * m.k1 * v * v);
            // d(u, v)/dw and dw/dφ = −[w]×.
            let du = Vector3::new(1.0 / w.z, 0.0, -w.x / (w.z * w.z));
            let dv = Vector3::new(0.0, 1.0 / w.z, -w.y / (w.z * w.z));
            for k in 0..3 {
                let e = Vector3::ith(k, 1.0);
                let dw = e.cross(&w); // ∂w/∂φ_k = e_k × w
                let (du_k, dv_k) = (du.dot(&dw), dv.dot(&dw));
                j[(2 * i, k)] = dxu * du_k + dxv * dv_k;
                j[(2 * i + 1, k)] = dyu * du_k + dyv * dv_k;
            }
            let mut c = 3;
            if self.options.fit_focal {
                j[(2 * i, c)] = u * g;
                j[(2 * i + 1, c)] = v * g;
                c += 1;
            }
            if self.options.fit_principal_point {
                j[(2 * i, c)] = 1.0;
                j[(2 * i + 1, c + 1)] = 1.0;
                c += 2;
            }
            if self.options.fit_k1 {
                j[(2 * i, c)] = f * u * rho2;
                j[(2 * i + 1, c)] = f * v * rho2;
            }
        }
        Some((r, j))
    }

    fn step(&self, s: &ReprojectionState, delta: &DVector<f64>) -> ReprojectionState {
        let phi = Vector3::new(delta[0], delta[1], delta[2]);
        let r = Rotation3::new(phi) * s.r;
        let mut model = s.model;
        let mut c = 3;
        if self.options.fit_focal {
            // Keep f positive: never shrink it by more than half in one step.
            model.focal_length_px =
                (model.focal_length_px + delta[c]).max(0.5 * model.focal_length_px);
            c += 1;
        }
        if self.options.fit_principal_point {
            model.principal_point_px[0] += delta[c];
            model.principal_point_px[1] += delta[c + 1];
            c += 2;
        }
        if self.options.fit_k1 {
            model.k1 += delta[c];
        }
        ReprojectionState { r, model }
    }
}

fn check_xy(stars: &[Vector3<f64>], xy: &[[f64; 2]]) -> Result<()> {
    if stars.len() != xy.len() {
        return Err(Error::invalid_input(format!(
            "{} stars but {} image positions",
            stars.len(),
            xy.len()
        )));
    }
    check_stars(stars, "stars")?;
    if let Some(i) = xy
        .iter()
        .position(|p| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(Error::invalid_input(format!(
            "image position {i} is not finite"
        )));
    }
    Ok(())
}

/// Refine attitude and camera over matched stars (`stars[i]` imaged at `xy[i]`, pixels) by
/// Levenberg–Marquardt from `start_r` and the camera `start`, fitting what `options` asks
/// (the sensor size stays that of `start`).
///
/// # Errors
/// `InvalidInput` for mismatched or non-finite input, a bad starting model, or fewer equations
/// than unknowns plus one (at least 3 stars).
///
/// # Example
/// ```
/// use nalgebra::{Rotation3, Vector3};
/// use starid_core::{geometry::{attitude_from_radec_roll, rotation_angle_between}, pointing::{refine_pointing, RefineOptions}, Camera};
/// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
/// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
/// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
/// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
/// let start = Camera::from_focal_length(2300.0, 1024.0, 1024.0).unwrap();
/// let fit = refine_pointing(&stars, &xy, &(r * Rotation3::from_euler_angles(0.002, 0.0, 0.01)), &start, &RefineOptions::default()).unwrap();
/// assert!((fit.camera.focal_length_px - 2400.0).abs() < 1e-6 && rotation_angle_between(&fit.r_icrs_to_cam, &r) < 1e-9);
/// ```
pub fn refine_pointing(
    stars: &[Vector3<f64>],
    xy: &[[f64; 2]],
    start_r: &Rotation3<f64>,
    start: &Camera,
    options: &RefineOptions,
) -> Result<PointingFit> {
    check_xy(stars, xy)?;
    check_focal(start.focal_length_px)?;
    if !start.principal_point_px.iter().all(|c| c.is_finite()) || !start.k1.is_finite() {
        return Err(Error::invalid_input(
            "the starting principal point and k1 must be finite",
        ));
    }
    let width_px = start.width_px;
    if let Some(s) = options.sigma_px {
        if !s.is_finite() || s <= 0.0 {
            return Err(Error::invalid_input(format!(
                "sigma_px must be positive and finite, got {s}"
            )));
        }
    }
    let mirror = |x: f64| if options.mirrored { width_px - x } else { x };
    let problem = Reprojection {
        stars,
        xy: xy.iter().map(|p| [mirror(p[0]), p[1]]).collect(),
        options: *options,
    };
    let p = problem.n_params();
    if stars.len() < 3 || 2 * stars.len() < p + 1 {
        return Err(Error::invalid_input(format!(
            "fitting {p} parameters needs at least {} stars, got {}",
            (p + 2) / 2 + 1,
            stars.len()
        )));
    }
    let mut model = *start;
    model.principal_point_px[0] = mirror(model.principal_point_px[0]);
    let start = ReprojectionState { r: *start_r, model };
    let sol = lsq::solve(&problem, start, options.max_iterations.max(1)).ok_or_else(|| {
        Error::invalid_input("a star lies behind the camera at the starting attitude")
    })?;
    let dof = 2 * stars.len() - p;
    let sigma = options
        .sigma_px
        .unwrap_or_else(|| (sol.cost() / dof as f64).sqrt());
    let covariance = lsq::inverse_normal_matrix(&sol.jacobian).map(|c| c * (sigma * sigma));
    let mut model = sol.state.model;
    model.principal_point_px[0] = mirror(model.principal_point_px[0]);
    let residuals_px: Vec<[f64; 2]> = (0..stars.len())
        .map(|i| {
            let sign = if options.mirrored { 1.0 } else { -1.0 };
            // residual = observed − model; in mirrored frames x flips back.
            [sign * sol.residuals[2 * i], -sol.residuals[2 * i + 1]]
        })
        .collect();
    Ok(PointingFit {
        r_icrs_to_cam: sol.state.r,
        camera: model,
        parameters: problem.names(),
        covariance,
        sigma_px: sigma,
        rms_px: (sol.cost() / (2 * stars.len()) as f64).sqrt(),
        residuals_px,
        iterations: sol.iterations,
        converged: sol.converged,
    })
}

/// Focal length from pairs of matched stars with the principal point at the sensor centre:
/// for every pair the `f` at which the angle between the two pixel rays equals the catalogue
/// angle (a quadratic in `f²`), the median over pairs weighted towards wide ones (the widest
/// 64). `None` when no pair gives one.
///
/// # Example
/// ```
/// use starid_core::Camera;
/// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
/// let xy = [[100.0, 120.0], [900.0, 200.0], [500.0, 950.0], [300.0, 600.0]];
/// let stars: Vec<_> = xy.iter().map(|p| cam.pixel_to_cam(p[0], p[1], false)).collect();
/// let f = starid_core::pointing::focal_from_pairs(&stars, &xy, [512.0, 512.0]).unwrap();
/// assert!((f - 2400.0).abs() < 1e-6);
/// ```
pub fn focal_from_pairs(
    stars: &[Vector3<f64>],
    xy: &[[f64; 2]],
    principal_point_px: [f64; 2],
) -> Option<f64> {
    let n = stars.len().min(xy.len());
    let off: Vec<Vector2<f64>> = xy[..n]
        .iter()
        .map(|p| Vector2::new(p[0] - principal_point_px[0], p[1] - principal_point_px[1]))
        .collect();
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for i in 0..n {
        for k in (i + 1)..n {
            pairs.push(((off[i] - off[k]).norm(), i, k));
        }
    }
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
    pairs.truncate(64);
    let mut estimates: Vec<f64> = pairs
        .iter()
        .filter_map(|&(_, i, k)| {
            focal_for_angle(&off[i], &off[k], angle_between(&stars[i], &stars[k]))
        })
        .collect();
    if estimates.is_empty() {
        return None;
    }
    estimates.sort_by(f64::total_cmp);
    Some(estimates[estimates.len() / 2])
}

/// The focal length at which pixel offsets `p`, `q` (from the principal point) subtend `alpha`.
///
/// # Example
/// ```
/// use nalgebra::Vector2;
/// let (p, q) = (Vector2::new(100.0, 0.0), Vector2::new(-50.0, 80.0));
/// let f = 1500.0f64;
/// let alpha = {
///     let (a, b) = (nalgebra::Vector3::new(p.x, p.y, f), nalgebra::Vector3::new(q.x, q.y, f));
///     starid_core::geometry::angle_between(&a, &b)
/// };
/// assert!((starid_core::pointing::focal_for_angle(&p, &q, alpha).unwrap() - f).abs() < 1e-6);
/// ```
pub fn focal_for_angle(p: &Vector2<f64>, q: &Vector2<f64>, alpha: f64) -> Option<f64> {
    if !(alpha > 0.0 && alpha < std::f64::consts::FRAC_PI_2) {
        return None;
    }
    // cos α = (p·q + F) / √((|p|² + F)(|q|² + F)), F = f²:
    // (1 − c²)F² + (2P − c²(a + b))F + P² − c²ab = 0.
    let c2 = alpha.cos().powi(2);
    let (pq, a, b) = (p.dot(q), p.norm_squared(), q.norm_squared());
    let qa = 1.0 - c2;
    let qb = 2.0 * pq - c2 * (a + b);
    let qc = pq * pq - c2 * a * b;
    let disc = qb * qb - 4.0 * qa * qc;
    if disc < 0.0 {
        return None;
    }
    let roots = [
        (-qb + disc.sqrt()) / (2.0 * qa),
        (-qb - disc.sqrt()) / (2.0 * qa),
    ];
    roots
        .into_iter()
        .filter(|&ff| ff > 0.0 && pq + ff > 0.0)
        .map(f64::sqrt)
        .find(|f| {
            let u = nalgebra::Vector3::new(p.x, p.y, *f);
            let v = nalgebra::Vector3::new(q.x, q.y, *f);
            (angle_between(&u, &v) - alpha).abs() < 1e-6 * alpha.max(1e-3)
        })
}

/// Attitude and camera from matched stars with no attitude guess: the focal length from
/// `focal_guess_px` (or [`focal_from_pairs`] when `None`), the attitude by Wahba/SVD from the
/// pixel rays, then [`refine_pointing`].
///
/// # Errors
/// As [`refine_pointing`]; `InvalidInput` when no focal length can be derived or the stars do
/// not fix an attitude.
///
/// # Example
/// ```
/// use nalgebra::Vector3;
/// use starid_core::{geometry::attitude_from_radec_roll, pointing::{fit_pointing, RefineOptions}, Camera};
/// let cam = Camera::from_focal_length(2400.0, 1024.0, 1024.0).unwrap();
/// let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
/// let xy: Vec<[f64; 2]> = (0..8).map(|i| [100.0 + 110.0 * i as f64, 900.0 - 95.0 * i as f64 + (i % 3) as f64 * 200.0]).collect();
/// let stars: Vec<_> = xy.iter().map(|p| r.inverse_transform_vector(&cam.pixel_to_cam(p[0], p[1], false))).collect();
/// let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(2000.0), &RefineOptions { sigma_px: Some(0.1), ..Default::default() }).unwrap();
/// assert!(fit.converged && (fit.camera.focal_length_px - 2400.0).abs() < 1e-6);
/// ```
pub fn fit_pointing(
    stars: &[Vector3<f64>],
    xy: &[[f64; 2]],
    width_px: f64,
    height_px: f64,
    focal_guess_px: Option<f64>,
    options: &RefineOptions,
) -> Result<PointingFit> {
    check_xy(stars, xy)?;
    if !(1.0..=1e6).contains(&width_px) || !(1.0..=1e6).contains(&height_px) {
        return Err(Error::invalid_input(format!(
            "image size must be between 1 and 1e6 pixels on each side, got {width_px} x {height_px}"
        )));
    }
    let centre = [0.5 * width_px, 0.5 * height_px];
    let f0 = match focal_guess_px {
        Some(f) => {
            check_focal(f)?;
            f
        }
        None => focal_from_pairs(stars, xy, centre).ok_or_else(|| {
            Error::invalid_input("no pair of stars gives a focal length; pass a guess")
        })?,
    };
    let start = Camera::from_focal_length(f0, width_px, height_px)?;
    let rays: Vec<Vector3<f64>> = xy
        .iter()
        .map(|p| start.pixel_to_cam(p[0], p[1], options.mirrored))
        .collect();
    let r0 = wahba_svd(&rays, stars)
        .ok_or_else(|| Error::invalid_input("these stars do not fix an attitude"))?;
    refine_pointing(stars, xy, &r0, &start, options)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::attitude_from_radec_roll;

    #[test]
    fn refinement_recovers_focal_and_distortion() {
        let f = 2400.0;
        let r = attitude_from_radec_roll(0.3, -0.7, 2.0);
        let mut stars = Vec::new();
        let mut xy = Vec::new();
        let k1 = -0.02;
        let truth = Camera::from_focal_length(f, 1024.0, 1024.0)
            .and_then(|c| c.with_principal_point(515.0, 510.0))
            .and_then(|c| c.with_k1(k1))
            .unwrap();
        for i in 0..12 {
            let ang = i as f64 * 0.52;
            let rad = 60.0 + 35.0 * i as f64;
            let (u, v) = (rad * ang.cos() / f, rad * ang.sin() / f);
            let (x, y) = truth.normalized_to_pixel(u, v);
            xy.push([x, y]);
            stars.push(r.inverse_transform_vector(&Vector3::new(u, v, 1.0).normalize()));
        }
        let opts = RefineOptions {
            fit_principal_point: true,
            fit_k1: true,
            ..Default::default()
        };
        let fit = fit_pointing(&stars, &xy, 1024.0, 1024.0, Some(f * 1.3), &opts).unwrap();
        assert!(fit.converged);
        assert!((fit.camera.focal_length_px - f).abs() < 1e-6 * f);
        assert!((fit.camera.k1 - k1).abs() < 1e-6);
        assert!((fit.camera.principal_point_px[0] - 515.0).abs() < 1e-6);
        assert!(crate::geometry::rotation_angle_between(&fit.r_icrs_to_cam, &r) < 1e-9);
    }
}
