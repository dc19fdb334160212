//! The focal-length check of a verified solution: a field of view given a little off (a lens's
//! nominal focal length, a sensor's nominal pixel pitch) scales every spot about the principal
//! point. The search still finds the stars near the attitude's centre, but the stars farther
//! out miss their places by the scale error times their distance: the solution names a part of
//! the frame, with its boresight pulled off, and may name an edge spot after a neighbour of its
//! star. The residuals of such a solution form a radial pattern; a significant one sends the
//! frame back to the search with the focal length it implies (see [`super::Solver::identify`]).
//! An unknown radial distortion (`k1`) does the same with the cube of the distance; with enough
//! matches it is fitted too, and a significant one is corrected with the scale.

use nalgebra::{Matrix4, Matrix5, Vector3, Vector4, Vector5};

use super::Identification;
use crate::geometry::Camera;

/// A relative focal-length error is acted on when it exceeds this many of its standard errors.
pub const FOCAL_SCALE_SIGMAS: f64 = 6.0;

/// Nor when it is below this (relative): at 1e-3 a spot at the sensor's corner moves by 0.7 px on
/// a 1024 px sensor, within any match radius.
pub const FOCAL_SCALE_MIN: f64 = 1e-3;

/// Fewest matches from which the scale is estimated (four parameters are fitted).
pub const FOCAL_SCALE_MIN_MATCHES: usize = 6;

/// Most times a frame is searched again with a corrected focal length.
pub const FOCAL_RETRIES: usize = 4;

/// Floor of the centroid noise (px) in the scale's standard error: a fit of few stars can show
/// residuals far below the true noise.
const SIGMA_FLOOR_PX: f64 = 0.05;

/// A radial distortion error is acted on when it exceeds this many of its standard errors.
pub const K1_SIGMAS: f64 = 6.0;

/// A distortion error beyond this many standard errors (but not [`K1_SIGMAS`]) is tried too,
/// and its solution kept only if it matches more spots: a few edge stars leave the fit
/// uncertain exactly where the error hides them.
pub const K1_TRY_SIGMAS: f64 = 3.0;

/// Nor when it moves a spot at the sensor's corner by less than this (px), as
/// [`FOCAL_SCALE_MIN`] does for the scale.
pub const K1_MIN_CORNER_PX: f64 = 0.7;

/// Fewest matches from which the radial distortion is estimated with the scale (five
/// parameters are fitted).
pub const K1_MIN_MATCHES: usize = 8;

/// What the residuals of a solution say of its camera: the focal length's relative error `a`
/// (true = camera's × (1 + a)) fitted alone, and fitted jointly with the error of the radial
/// distortion `k1` (true = camera's + b), each `(value, standard error)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CameraFit {
    /// `(a, se)` with the distortion held.
    pub scale: (f64, f64),
    /// `[(a, se), (b, se)]` fitted together; `None` with fewer than [`K1_MIN_MATCHES`] matches.
    pub joint: Option<[(f64, f64); 2]>,
    /// A spot's displacement at the sensor's corner per unit `b`, px.
    corner_px: f64,
}

impl CameraFit {
    /// The correction `(a, b)` a search should try, and whether its solution must match more
    /// spots to be kept (rather than as many): with a significant distortion error both fitted
    /// together, else a significant scale alone, else a distortion error beyond
    /// [`K1_TRY_SIGMAS`] (only for more matches); `None` when none is.
    pub fn correction(&self) -> Option<((f64, f64), bool)> {
        let joint = |sigmas: f64| {
            self.joint.filter(|&[_, (b, se)]| {
                b.abs() * self.corner_px > K1_MIN_CORNER_PX && b.abs() > sigmas * se
            })
        };
        if let Some([(a, _), (b, _)]) = joint(K1_SIGMAS) {
            Some(((a, b), false))
        } else if significant(self.scale) {
            Some(((self.scale.0, 0.0), false))
        } else {
            joint(K1_TRY_SIGMAS).map(|[(a, _), (b, _)]| ((a, b), true))
        }
    }

    /// The correction `(a, b)` and the focal length's relative standard error, to refine a
    /// camera found: with `k1` (the distortion was corrected) the joint fit's, else the scale's.
    pub fn refinement(&self, k1: bool) -> ((f64, f64), f64) {
        match self.joint {
            Some([(a, se), (b, _)]) if k1 => ((a, b), se),
            _ => ((self.scale.0, 0.0), self.scale.1),
        }
    }
}

/// The camera's errors that the matches of `id` show (`star_vectors`: the catalogue's unit
/// vectors): the least-squares fit of the pixel residuals (observed minus predicted) by a scale
/// about the principal point, a roll and a shift, and the same with a radial term
/// `q |q|² / f²` (the error of `k1`). The roll and shift absorb what the attitude fit left;
/// only the scale and the radial term are the camera's. `None` with fewer than
/// [`FOCAL_SCALE_MIN_MATCHES`] matches or without an attitude.
pub(crate) fn camera_error(
    centroids: &[[f64; 2]],
    camera: &Camera,
    id: &Identification,
    star_vectors: &[Vector3<f64>],
) -> Option<CameraFit> {
    let r = id.r_icrs_to_cam?;
    if id.matched < FOCAL_SCALE_MIN_MATCHES {
        return None;
    }
    let [cx, cy] = camera.principal_point_px;
    let f2 = camera.focal_length_px * camera.focal_length_px;
    // The normal equations of d = a q + b q |q|²/f² + θ J q + t, J q = (−q_y, q_x) (the roll's
    // sign follows the handedness; the shift and roll are nuisance parameters either way), from
    // the rows (q_x, q_x s, −q_y, 1, 0) and (q_y, q_y s, q_x, 0, 1), s = |q|²/f²: they need only
    // the sums below; Σ|d|² gives the residual sum of squares (Σ|d|² − xᵀ Aᵀd at the solution).
    let (mut qq, mut qqs, mut qqss, mut sx, mut sy, mut sxs, mut sys) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    let mut rhs = Vector5::<f64>::zeros();
    let (mut d_sq, mut rows) = (0.0, 0usize);
    for (c, star) in centroids.iter().zip(&id.catalog_index) {
        let Some(star) = star else { continue };
        let v = r * star_vectors[*star as usize];
        let Some((mut x, y)) = camera.cam_to_pixel(&v) else {
            continue;
        };
        // The prediction about the principal point (mirrored with the image), and the residual.
        let qx = if id.mirrored {
            x = camera.width_px - x;
            x - (camera.width_px - cx)
        } else {
            x - cx
        };
        let (qy, dx, dy) = (y - cy, c[0] - x, c[1] - y);
        let q2 = qx * qx + qy * qy;
        let s = q2 / f2;
        (qq, qqs, qqss) = (qq + q2, qqs + q2 * s, qqss + q2 * s * s);
        (sx, sy, sxs, sys) = (sx + qx, sy + qy, sxs + qx * s, sys + qy * s);
        let radial = qx * dx + qy * dy;
        rhs += Vector5::new(radial, radial * s, qx * dy - qy * dx, dx, dy);
        d_sq += dx * dx + dy * dy;
        rows += 1;
    }
    if rows < FOCAL_SCALE_MIN_MATCHES {
        return None;
    }
    let m = rows as f64;
    #[rustfmt::skip]
    let normal = Matrix5::new(
        qq, qqs, 0.0, sx, sy,
        qqs, qqss, 0.0, sxs, sys,
        0.0, 0.0, qq, -sy, sx,
        sx, sxs, -sy, m, 0.0,
        sy, sys, sx, 0.0, m,
    );
    // The scale alone: the radial term's row and column left out.
    let keep = [0usize, 2, 3, 4];
    let n4 = Matrix4::from_fn(|i, j| normal[(keep[i], keep[j])]);
    let r4 = Vector4::from_fn(|i, _| rhs[keep[i]]);
    let chol = n4.cholesky()?;
    let x = chol.solve(&r4);
    // (N⁻¹)₀₀, the scale's variance per unit noise.
    let var = chol.solve(&Vector4::x())[0];
    let sigma = ((d_sq - x.dot(&r4)).max(0.0) / (2 * rows - 4) as f64)
        .sqrt()
        .max(SIGMA_FLOOR_PX);
    let scale = (x[0], sigma * var.max(0.0).sqrt());
    if !(scale.0.is_finite() && scale.1.is_finite()) {
        return None;
    }
    let joint = (rows >= K1_MIN_MATCHES)
        .then(|| normal.cholesky())
        .flatten()
        .and_then(|chol| {
            let x = chol.solve(&rhs);
            let sigma = ((d_sq - x.dot(&rhs)).max(0.0) / (2 * rows - 5) as f64)
                .sqrt()
                .max(SIGMA_FLOOR_PX);
            // (N⁻¹)₀₀ and (N⁻¹)₁₁: the variances per unit noise.
            let (v0, v1) = (chol.solve(&Vector5::x())[0], chol.solve(&Vector5::y())[1]);
            let fit = [
                (x[0], sigma * v0.max(0.0).sqrt()),
                (x[1], sigma * v1.max(0.0).sqrt()),
            ];
            fit.iter()
                .all(|(v, se)| v.is_finite() && se.is_finite())
                .then_some(fit)
        });
    let corner = 0.5 * camera.width_px.hypot(camera.height_px);
    Some(CameraFit {
        scale,
        joint,
        corner_px: corner * corner * corner / f2,
    })
}

/// Whether a scale error `(a, se)` calls for a search with the corrected focal length.
pub(crate) fn significant((a, se): (f64, f64)) -> bool {
    a.abs() > FOCAL_SCALE_MIN && a.abs() > FOCAL_SCALE_SIGMAS * se
}
