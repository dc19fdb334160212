//! The focal-length check of a verified solution: a field of view given a little off (a lens's
//! nominal focal length, a sensor's nominal pixel pitch) scales every spot about the principal
//! point. The search still finds the stars near the attitude's centre, but the stars farther
//! out miss their places by the scale error times their distance: the solution names a part of
//! the frame, with its boresight pulled off, and may name an edge spot after a neighbour of its
//! star. The residuals of such a solution form a radial pattern; a significant one sends the
//! frame back to the search with the focal length it implies (see [`super::Solver::identify`]).

use nalgebra::{Matrix4, Vector3, Vector4};

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

/// The focal length's relative error `a` (true = camera's × (1 + a)) that the matches of `id`
/// show (`star_vectors`: the catalogue's unit vectors), with its standard error: the
/// least-squares fit of the pixel residuals (observed minus predicted) by a scale about the
/// principal point, a roll and a shift. The roll and shift absorb what the attitude fit left;
/// only the scale is the camera's. `None` with fewer than [`FOCAL_SCALE_MIN_MATCHES`] matches
/// or without an attitude.
pub(crate) fn focal_scale_error(
    centroids: &[[f64; 2]],
    camera: &Camera,
    id: &Identification,
    star_vectors: &[Vector3<f64>],
) -> Option<(f64, f64)> {
    let r = id.r_icrs_to_cam?;
    if id.matched < FOCAL_SCALE_MIN_MATCHES {
        return None;
    }
    let [cx, cy] = camera.principal_point_px;
    // The normal equations of d = a q + θ J q + t, J q = (−q_y, q_x) (the roll's sign follows
    // the handedness; the shift and roll are nuisance parameters either way): with rows
    // (q_x, −q_y, 1, 0) and (q_y, q_x, 0, 1), they need only Σ|q|², Σq and the right-hand
    // side's sums; Σ|d|² gives the residual sum of squares (Σ|d|² − xᵀ Aᵀd at the solution).
    let (mut qq, mut sx, mut sy, mut d_sq) = (0.0, 0.0, 0.0, 0.0);
    let mut rhs = Vector4::<f64>::zeros();
    let mut rows = 0usize;
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
        qq += qx * qx + qy * qy;
        (sx, sy) = (sx + qx, sy + qy);
        rhs += Vector4::new(qx * dx + qy * dy, qx * dy - qy * dx, dx, dy);
        d_sq += dx * dx + dy * dy;
        rows += 1;
    }
    if rows < FOCAL_SCALE_MIN_MATCHES {
        return None;
    }
    let m = rows as f64;
    #[rustfmt::skip]
    let normal = Matrix4::new(
        qq, 0.0, sx, sy,
        0.0, qq, -sy, sx,
        sx, -sy, m, 0.0,
        sy, sx, 0.0, m,
    );
    let chol = normal.cholesky()?;
    let x = chol.solve(&rhs);
    // (N⁻¹)₀₀, the scale's variance per unit noise.
    let var = chol.solve(&Vector4::x())[0];
    let sum_sq = (d_sq - x.dot(&rhs)).max(0.0);
    let sigma = (sum_sq / (2 * rows - 4) as f64).sqrt().max(SIGMA_FLOOR_PX);
    let a = x[0];
    let se = sigma * var.max(0.0).sqrt();
    (a.is_finite() && se.is_finite()).then_some((a, se))
}

/// Whether a scale error `(a, se)` calls for a search with the corrected focal length.
pub(crate) fn significant((a, se): (f64, f64)) -> bool {
    a.abs() > FOCAL_SCALE_MIN && a.abs() > FOCAL_SCALE_SIGMAS * se
}
