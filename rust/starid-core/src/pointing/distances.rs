//! Boresight from distances, its precision and the choice of stars.
//!
//! # Boresight from distances ([`boresight_from_distances`])
//! A star at distance `aᵢ` (pixels) from the principal point of a pinhole camera of focal length
//! `f` lies at angle `θᵢ = atan(aᵢ/f)` from the boresight `D`: each star gives a cone around it.
//! With `f` known, two cones meet in at most two points (closed form) and the third star picks
//! one; with `f` unknown, the feasible focal lengths are bounded by the triangle inequalities
//! (`θᵢ + θⱼ ≥ αᵢⱼ`), the profile of the best cone fit over a log-spaced scan of that interval
//! gives the starting points, and Levenberg–Marquardt refines `(D, f)` from each. Residuals are
//! in pixels (`f·tan∠(D, sᵢ) − aᵢ`), so the least-squares solution is the maximum-likelihood one
//! for Gaussian centroid noise. Every distinct solution is returned, best first, with flags:
//! - `ambiguous`: another solution fits as well. Three stars on one great circle (collinear
//!   images) have a mirror solution across that circle with the very same distances; with `f`
//!   unknown, three stars can have several exact solutions.
//! - `degenerate`: the Jacobian is rank-deficient at the solution, so a direction of parameter
//!   space is not determined to first order (collinear images through the principal point).
//!
//! # Precision and star choice ([`super::precision`]: `predicted_distance_covariance`, `choose_stars`)
//! The covariance of the distance solution depends only on the images' positions relative to
//! the principal point and on `f`: a star at offset `aᵢ·uᵢ` contributes the row
//! `[−(f + aᵢ²/f)·uᵢ, aᵢ/f]` to the Jacobian (boresight, focal length). Edge stars weigh more
//! (`f + a²/f` grows with `a`) and directions spread around the centre constrain both
//! boresight axes; collinear or clustered images do not.

use nalgebra::{DMatrix, DVector, Vector3};

use super::{check_focal, check_stars};
use crate::error::{Error, Result};
use crate::geometry::angle_between;
use crate::lsq::{self, Problem};

/// Largest number of stars [`boresight_from_distances`] accepts (its focal scan visits every
/// star at each of its starting focal lengths).
pub const MAX_DISTANCE_STARS: usize = 1_000;

/// Reciprocal condition (scaled Jacobian) below which a solution is flagged degenerate: some
/// direction of the parameters is determined about 100 times worse than by a well-spread set of
/// stars (well-spread triples score 0.1–1).
pub const DEGENERATE_RCOND: f64 = 1e-2;

/// Angle below which two boresight solutions are the same one, radians (0.02″).
const SAME_SOLUTION_RAD: f64 = 1e-7;

/// One boresight solution of [`boresight_from_distances`].
#[derive(Debug, Clone)]
pub struct DistanceSolution {
    /// Boresight, ICRS unit vector.
    pub boresight: Vector3<f64>,
    /// Focal length, pixels (the given one when it was known).
    pub focal_length_px: f64,
    /// `f·tan∠(D, sᵢ) − aᵢ` per star, pixels.
    pub residuals_px: Vec<f64>,
    /// Root mean square of the residuals, pixels.
    pub rms_px: f64,
    /// Levenberg–Marquardt iterations.
    pub iterations: usize,
    /// Whether the iteration converged.
    pub converged: bool,
    /// Another solution fits as well (within a factor 2 in rms, or both exact).
    pub ambiguous: bool,
    /// Reciprocal condition of the scaled Jacobian at the solution (1: ideal, 0: singular).
    pub condition: f64,
    /// `condition` below [`DEGENERATE_RCOND`]: some direction of the parameters is (nearly)
    /// undetermined, so the solution should not be trusted.
    pub degenerate: bool,
    /// `(JᵀJ)⁻¹` for 1 px of distance noise, parameters (east, north[, focal px]) with the
    /// boresight components in radians along the local east and north; `None` when degenerate.
    pub unit_covariance: Option<DMatrix<f64>>,
    /// The distances cannot all be met: the best fit misses them by more than
    /// [`INCONSISTENT_RMS_PX`] rms, far beyond centroid noise (a wrong star, a wrong focal length).
    pub inconsistent: bool,
}

/// A boresight solution whose distances are missed by more than this (rms, pixels) is
/// flagged `inconsistent`.
pub const INCONSISTENT_RMS_PX: f64 = 5.0;

impl DistanceSolution {
    /// 1σ angular error of the boresight (√ of the trace of its 2×2 block), radians, for
    /// `sigma_px` of noise on each distance; infinite when degenerate.
    ///
    /// # Example
    /// ```
    /// use nalgebra::Vector3;
    /// use starid_core::{geometry::attitude_from_radec_roll, pointing::boresight_from_distances};
    /// let (f, r) = (2000.0, attitude_from_radec_roll(1.0, 0.3, 0.2));
    /// let offsets = [[200.0, 30.0], [-120.0, 170.0], [-90.0, -210.0]];
    /// let stars: Vec<_> = offsets.iter().map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize())).collect();
    /// let a: Vec<f64> = offsets.iter().map(|o| f64::hypot(o[0], o[1])).collect();
    /// let best = &boresight_from_distances(&stars, &a, Some(f)).unwrap()[0];
    /// assert!(best.boresight_sigma_rad(0.1) < best.boresight_sigma_rad(1.0));
    /// ```
    pub fn boresight_sigma_rad(&self, sigma_px: f64) -> f64 {
        self.unit_covariance
            .as_ref()
            .map_or(f64::INFINITY, |c| sigma_px * (c[(0, 0)] + c[(1, 1)]).sqrt())
    }
}

struct Distances<'a> {
    stars: &'a [Vector3<f64>],
    distances_px: &'a [f64],
    /// `Some(f)` for a known focal length.
    known_focal_px: Option<f64>,
}

#[derive(Clone)]
struct DistanceState {
    d: Vector3<f64>,
    ln_f: f64,
}

impl Problem for Distances<'_> {
    type State = DistanceState;

    fn evaluate(&self, s: &DistanceState) -> Option<(DVector<f64>, DMatrix<f64>)> {
        let n = self.stars.len();
        let p = if self.known_focal_px.is_some() { 2 } else { 3 };
        let f = s.ln_f.exp();
        let (e1, e2) = crate::geometry::east_north_at(&s.d);
        let mut r = DVector::zeros(n);
        let mut j = DMatrix::zeros(n, p);
        for (i, star) in self.stars.iter().enumerate() {
            let phi = angle_between(&s.d, star);
            if phi >= 89.5f64.to_radians() {
                return None;
            }
            let (sin, cos) = phi.sin_cos();
            r[i] = f * phi.tan() - self.distances_px[i];
            if sin > 1e-15 {
                // Moving D by δ along e changes φ by −δ·(t·e), t the unit tangent towards the star.
                let t = (star - s.d * cos) / sin;
                let dr_dphi = f / (cos * cos);
                j[(i, 0)] = -dr_dphi * t.dot(&e1);
                j[(i, 1)] = -dr_dphi * t.dot(&e2);
            }
            if p == 3 {
                j[(i, 2)] = f * phi.tan();
            }
        }
        Some((r, j))
    }

    fn step(&self, s: &DistanceState, delta: &DVector<f64>) -> DistanceState {
        let (e1, e2) = crate::geometry::east_north_at(&s.d);
        DistanceState {
            d: (s.d + e1 * delta[0] + e2 * delta[1]).normalize(),
            ln_f: if delta.len() > 2 {
                s.ln_f + delta[2].clamp(-1.0, 1.0)
            } else {
                s.ln_f
            },
        }
    }
}

/// Boresight (and, when `focal_px` is `None`, focal length) from catalogue directions `stars`
/// and the distances of their images from the principal point, pixels. Returns every distinct
/// solution, best supported (smallest rms residual) first; see the module documentation.
///
/// # Errors
/// `InvalidInput` for fewer than three stars, mismatched lengths, non-finite or negative
/// distances, repeated stars, a focal length that is not positive and finite, or stars more
/// than 179° apart.
///
/// # Example
/// ```
/// use nalgebra::Vector3;
/// use starid_core::{geometry::{angle_between, attitude_from_radec_roll}, pointing::boresight_from_distances};
/// let (f, r) = (2000.0, attitude_from_radec_roll(1.0, 0.3, 0.2));
/// let offsets = [[200.0, 30.0], [-120.0, 170.0], [-90.0, -210.0]];
/// let stars: Vec<_> = offsets.iter().map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize())).collect();
/// let a: Vec<f64> = offsets.iter().map(|o| f64::hypot(o[0], o[1])).collect();
/// let sols = boresight_from_distances(&stars, &a, Some(f)).unwrap();
/// let truth = r.inverse_transform_vector(&Vector3::z());
/// assert!(angle_between(&sols[0].boresight, &truth) < 1e-10 && !sols[0].ambiguous);
/// ```
pub fn boresight_from_distances(
    stars: &[Vector3<f64>],
    distances_px: &[f64],
    focal_px: Option<f64>,
) -> Result<Vec<DistanceSolution>> {
    if stars.len() < 3 {
        return Err(Error::invalid_input(format!(
            "the boresight from distances needs at least 3 stars, got {}",
            stars.len()
        )));
    }
    if stars.len() > MAX_DISTANCE_STARS {
        return Err(Error::invalid_input(format!(
            "the boresight from distances takes at most {MAX_DISTANCE_STARS} stars, got {}",
            stars.len()
        )));
    }
    if stars.len() != distances_px.len() {
        return Err(Error::invalid_input(format!(
            "{} stars but {} distances",
            stars.len(),
            distances_px.len()
        )));
    }
    check_stars(stars, "stars")?;
    if let Some((i, a)) = distances_px
        .iter()
        .enumerate()
        .find(|(_, a)| !a.is_finite() || **a < 0.0 || **a > 1e9)
    {
        return Err(Error::invalid_input(format!(
            "distance {i} must be finite and >= 0 pixels, got {a}"
        )));
    }
    if let Some(f) = focal_px {
        check_focal(f)?;
    }
    if distances_px.iter().all(|&a| a == 0.0) {
        return Err(Error::invalid_input(
            "all distances are zero: the stars cannot all sit at the principal point",
        ));
    }
    let problem = Distances {
        stars,
        distances_px,
        known_focal_px: focal_px,
    };
    let starts: Vec<DistanceState> = match focal_px {
        Some(f) => cone_candidates(stars, distances_px, f)
            .into_iter()
            .map(|d| DistanceState { d, ln_f: f.ln() })
            .collect(),
        None => {
            let mut starts = unknown_focal_starts(stars, distances_px);
            if stars.len() == 3 {
                starts.extend(three_star_roots(stars, distances_px));
            }
            starts
        }
    };
    let mut found: Vec<DistanceSolution> = Vec::new();
    for start in starts {
        let Some(sol) = lsq::solve(&problem, start, 200) else {
            continue;
        };
        let f = sol.state.ln_f.exp();
        let d = sol.state.d;
        if found.iter().any(|s| {
            angle_between(&s.boresight, &d) < SAME_SOLUTION_RAD
                && (s.focal_length_px - f).abs() <= 1e-6 * f
        }) {
            continue;
        }
        let n = stars.len() as f64;
        let rms = (sol.cost() / n).sqrt();
        // Scale the boresight columns by the full sensitivity of the distances to the angle
        // from the axis, and the focal column by its own norm: a boresight direction that no
        // distance depends on (stars on one line through the principal point) then shows.
        let row_scale: f64 = stars
            .iter()
            .map(|s| {
                let c = s.dot(&d).clamp(-1.0, 1.0);
                (f / (c * c)).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let mut scales = vec![row_scale, row_scale];
        if focal_px.is_none() {
            scales.push(sol.jacobian.column(2).norm().max(1e-300));
        }
        let rcond = lsq::reciprocal_condition_scaled(&sol.jacobian, &scales);
        let degenerate = rcond < DEGENERATE_RCOND;
        let unit_covariance = if degenerate {
            None
        } else {
            lsq::inverse_normal_matrix(&sol.jacobian).map(|mut c| {
                // ln f → f.
                if c.nrows() == 3 {
                    for k in 0..3 {
                        c[(2, k)] *= f;
                        c[(k, 2)] *= f;
                    }
                }
                c
            })
        };
        found.push(DistanceSolution {
            boresight: d,
            focal_length_px: f,
            residuals_px: sol.residuals.iter().copied().collect(),
            rms_px: rms,
            iterations: sol.iterations,
            converged: sol.converged,
            ambiguous: false,
            condition: rcond,
            degenerate,
            unit_covariance,
            inconsistent: rms > INCONSISTENT_RMS_PX,
        });
    }
    found.sort_by(|a, b| a.rms_px.total_cmp(&b.rms_px));
    mark_ambiguous(&mut found, distances_px);
    if found.is_empty() {
        return Err(Error::invalid_input(
            "no boresight puts every star within 89.5 degrees of the axis at these distances",
        ));
    }
    Ok(found)
}

/// The ambiguity rule: a second solution is as good when it fits within twice the best rms,
/// or both are exact to rounding (1e-9 of the largest distance). `found` is sorted best first.
fn mark_ambiguous(found: &mut [DistanceSolution], distances_px: &[f64]) {
    let scale = distances_px.iter().copied().fold(0.0f64, f64::max);
    let Some(best) = found.first().map(|s| s.rms_px) else {
        return;
    };
    let limit = 2.0 * best + 1e-9 * scale;
    let rivals = found.iter().filter(|s| s.rms_px <= limit).count();
    for s in found.iter_mut() {
        s.ambiguous = rivals > 1 && s.rms_px <= limit;
    }
}

/// [`boresight_from_distances`] with the focal length unknown but within `focal_range_px`
/// (what the optics allow): only solutions in the range are kept, and `ambiguous` is judged
/// among those. An empty list means no solution lies in the range.
///
/// # Errors
/// As [`boresight_from_distances`]; `InvalidInput` for a range that is not `0 < lo <= hi`.
///
/// # Example
/// ```
/// use nalgebra::Vector3;
/// use starid_core::geometry::{attitude_from_radec_roll, radec_to_unit};
/// use starid_core::pointing::boresight_from_distances_in_range;
/// let (f, r) = (2000.0, attitude_from_radec_roll(1.0, 0.3, 0.2));
/// let offsets = [[200.0, 30.0], [-120.0, 170.0], [-90.0, -210.0]];
/// let stars: Vec<_> = offsets.iter()
///     .map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize())).collect();
/// let a: Vec<f64> = offsets.iter().map(|o| f64::hypot(o[0], o[1])).collect();
/// let sols = boresight_from_distances_in_range(&stars, &a, (1800.0, 2200.0)).unwrap();
/// assert!((sols[0].focal_length_px - f).abs() < 1e-6);
/// ```
pub fn boresight_from_distances_in_range(
    stars: &[Vector3<f64>],
    distances_px: &[f64],
    focal_range_px: (f64, f64),
) -> Result<Vec<DistanceSolution>> {
    let (lo, hi) = focal_range_px;
    if !(lo > 0.0 && lo <= hi && hi.is_finite()) {
        return Err(Error::invalid_input(format!(
            "focal_range_px must be (lo, hi) with 0 < lo <= hi, got ({lo}, {hi})"
        )));
    }
    let mut found: Vec<DistanceSolution> = boresight_from_distances(stars, distances_px, None)?
        .into_iter()
        .filter(|s| (lo..=hi).contains(&s.focal_length_px))
        .collect();
    mark_ambiguous(&mut found, distances_px);
    Ok(found)
}

/// Starting boresights for a known focal length: both intersections of every pair of cones
/// (the closest approach when two cones miss) and the linear solution of `S·D = cos θ`.
fn cone_candidates(stars: &[Vector3<f64>], distances_px: &[f64], f: f64) -> Vec<Vector3<f64>> {
    let cos_t: Vec<f64> = distances_px
        .iter()
        .map(|a| f / (a * a + f * f).sqrt())
        .collect();
    let mut out = Vec::new();
    // Use the pairs of the (up to) 6 stars farthest from the boresight: their cones are sharpest.
    let mut order: Vec<usize> = (0..stars.len()).collect();
    order.sort_by(|&a, &b| distances_px[b].total_cmp(&distances_px[a]));
    order.truncate(6);
    for (x, &i) in order.iter().enumerate() {
        for &k in &order[x + 1..] {
            pair_intersections(&stars[i], &stars[k], cos_t[i], cos_t[k], &mut out);
        }
    }
    // Linear least squares: rows sᵢᵀ, right side cos θᵢ.
    let n = stars.len();
    let s = DMatrix::from_fn(n, 3, |r, c| stars[r][c]);
    let b = DVector::from_vec(cos_t);
    if let Ok(x) = s.svd(true, true).solve(&b, 1e-10) {
        let v = Vector3::new(x[0], x[1], x[2]);
        if v.norm() > 1e-9 {
            out.push(v.normalize());
        }
    }
    out.retain(|d| stars.iter().all(|s| s.dot(d) > 0.0087));
    out
}

fn pair_intersections(
    si: &Vector3<f64>,
    sk: &Vector3<f64>,
    ci: f64,
    ck: f64,
    out: &mut Vec<Vector3<f64>>,
) {
    let g = si.dot(sk);
    let n = si.cross(sk);
    let nn = n.norm_squared();
    if nn < 1e-18 {
        return;
    }
    let x = (ci - g * ck) / (1.0 - g * g);
    let y = (ck - g * ci) / (1.0 - g * g);
    let in_plane = x * x + y * y + 2.0 * x * y * g;
    let z2 = (1.0 - in_plane) / nn;
    let base = si * x + sk * y;
    if z2 > 0.0 {
        let z = z2.sqrt();
        out.push((base + n * z).normalize());
        out.push((base - n * z).normalize());
    } else if base.norm() > 1e-12 {
        out.push(base.normalize());
    }
}

/// Largest focal length at which the cones of stars `i`, `k` still meet: `θᵢ + θₖ = αᵢₖ`.
fn focal_upper_bound(ai: f64, ak: f64, alpha: f64) -> f64 {
    // tan(θᵢ + θₖ) = (aᵢ + aₖ)·f / (f² − aᵢaₖ) = tan α  ⇒  f² − b·f − aᵢaₖ = 0, b = (aᵢ + aₖ)/tan α
    // (valid on both sides of 90°).
    let (sin, cos) = alpha.sin_cos();
    if sin <= 0.0 {
        return f64::INFINITY;
    }
    let b = (ai + ak) * cos / sin;
    0.5 * (b + (b * b + 4.0 * ai * ak).sqrt())
}

/// A focal length of the scan and its cone candidates with their misfits.
type ScanPoint = (f64, Vec<(f64, Vector3<f64>)>);

/// The feasible focal interval `[f_lo, f_hi]` of [`unknown_focal_starts`].
fn focal_interval(stars: &[Vector3<f64>], distances_px: &[f64]) -> Option<(f64, f64)> {
    let n = stars.len();
    let mut f_hi = f64::INFINITY;
    for i in 0..n {
        for k in (i + 1)..n.min(i + 50) {
            let alpha = angle_between(&stars[i], &stars[k]);
            f_hi = f_hi.min(focal_upper_bound(distances_px[i], distances_px[k], alpha));
        }
    }
    let a_max = distances_px.iter().copied().fold(0.0f64, f64::max);
    if !f_hi.is_finite() || f_hi <= 0.0 {
        return None;
    }
    Some(((a_max / 89f64.to_radians().tan()).min(f_hi * 0.999), f_hi))
}

/// Every exact solution of the three-star problem with unknown focal length. The cones of the
/// two stars farthest from the axis meet in two points `D±(f)` for each feasible `f`; the
/// solutions are the roots of the third star's misfit `g±(f) = ∠(D±(f), s₃) − atan(a₃/f)`.
/// Each branch is scanned on a fine log grid; sign changes are bisected, and local minima of
/// `|g|` that dip through zero between grid points (two close roots) are split and bisected too.
fn three_star_roots(stars: &[Vector3<f64>], distances_px: &[f64]) -> Vec<DistanceState> {
    let Some((f_lo, f_hi)) = focal_interval(stars, distances_px) else {
        return Vec::new();
    };
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| distances_px[b].total_cmp(&distances_px[a]));
    let [p, q, t] = idx;
    let branch = |f: f64, sign: f64| -> Option<(f64, Vector3<f64>)> {
        let cp = f / distances_px[p].hypot(f);
        let cq = f / distances_px[q].hypot(f);
        let (sp, sq) = (&stars[p], &stars[q]);
        let g = sp.dot(sq);
        let n = sp.cross(sq);
        let nn = n.norm_squared();
        if nn < 1e-18 {
            return None;
        }
        let x = (cp - g * cq) / (1.0 - g * g);
        let y = (cq - g * cp) / (1.0 - g * g);
        let z2 = (1.0 - (x * x + y * y + 2.0 * x * y * g)) / nn;
        if z2 < 0.0 {
            return None;
        }
        let d = (sp * x + sq * y + n * (sign * z2.sqrt())).normalize();
        Some((
            angle_between(&d, &stars[t]) - (distances_px[t] / f).atan(),
            d,
        ))
    };
    const GRID: usize = 2000;
    let ratio = (f_hi / f_lo).ln();
    let at = |k: f64| f_lo * (ratio * k / (GRID - 1) as f64).exp();
    let mut out = Vec::new();
    for sign in [1.0, -1.0] {
        let vals: Vec<Option<f64>> = (0..GRID)
            .map(|k| branch(at(k as f64), sign).map(|v| v.0))
            .collect();
        let bisect = |mut lo: f64, mut hi: f64| -> Option<DistanceState> {
            let g_lo = branch(at(lo), sign)?.0;
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                let g_mid = branch(at(mid), sign)?.0;
                if (g_mid < 0.0) == (g_lo < 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let f = at(0.5 * (lo + hi));
            branch(f, sign).map(|(_, d)| DistanceState { d, ln_f: f.ln() })
        };
        for k in 0..GRID - 1 {
            let (Some(a), Some(b)) = (vals[k], vals[k + 1]) else {
                continue;
            };
            if (a < 0.0) != (b < 0.0) {
                out.extend(bisect(k as f64, (k + 1) as f64));
            }
        }
        for k in 1..GRID - 1 {
            let (Some(a), Some(b), Some(c)) = (vals[k - 1], vals[k], vals[k + 1]) else {
                continue;
            };
            let same_sign = (a < 0.0) == (b < 0.0) && (b < 0.0) == (c < 0.0);
            if !(same_sign && b.abs() <= a.abs() && b.abs() <= c.abs()) {
                continue;
            }
            // Golden-section search for the extremum of |g| in [k−1, k+1].
            let (mut lo, mut hi) = ((k - 1) as f64, (k + 1) as f64);
            let gold = 0.5 * (5f64.sqrt() - 1.0);
            let absg = |x: f64| {
                branch(at(x), sign).map_or(f64::INFINITY, |v| {
                    v.0.abs() * if (v.0 < 0.0) == (b < 0.0) { 1.0 } else { -1.0 }
                })
            };
            for _ in 0..80 {
                let m1 = hi - gold * (hi - lo);
                let m2 = lo + gold * (hi - lo);
                if absg(m1) < absg(m2) {
                    hi = m2;
                } else {
                    lo = m1;
                }
            }
            let m = 0.5 * (lo + hi);
            let Some((gm, d)) = branch(at(m), sign) else {
                continue;
            };
            if (gm < 0.0) != (b < 0.0) {
                out.extend(bisect((k - 1) as f64, m));
                out.extend(bisect(m, (k + 1) as f64));
            } else if gm.abs() < 1e-12 {
                out.push(DistanceState {
                    d,
                    ln_f: at(m).ln(),
                });
            }
        }
    }
    out
}

/// Starting points for an unknown focal length from the geometry: the interval of focal lengths
/// at which every pair of cones meets, scanned on a log grid; at each focal length the best
/// closed-form cone intersection is scored by its angular misfit, and the local minima of that
/// profile (the best few) start the full fit.
fn unknown_focal_starts(stars: &[Vector3<f64>], distances_px: &[f64]) -> Vec<DistanceState> {
    let Some((f_lo, f_hi)) = focal_interval(stars, distances_px) else {
        return Vec::new();
    };
    const SCAN: usize = 1000;
    let ratio = (f_hi / f_lo).ln();
    // Per scan point: focal length and every cone candidate with its angular misfit.
    let mut profile: Vec<ScanPoint> = Vec::with_capacity(SCAN);
    for s in 0..SCAN {
        let f = f_lo * (ratio * (s as f64 + 0.5) / SCAN as f64).exp();
        let theta: Vec<f64> = distances_px.iter().map(|a| (a / f).atan()).collect();
        let mut cands: Vec<(f64, Vector3<f64>)> = cone_candidates(stars, distances_px, f)
            .into_iter()
            .map(|d| {
                let misfit: f64 = stars
                    .iter()
                    .zip(&theta)
                    .map(|(st, t)| (angle_between(&d, st) - t).powi(2))
                    .sum();
                (misfit, d)
            })
            .collect();
        cands.sort_by(|a, b| a.0.total_cmp(&b.0));
        profile.push((f, cands));
    }
    let best = |s: usize| profile[s].1.first().map_or(f64::INFINITY, |c| c.0);
    let mut minima: Vec<usize> = (0..SCAN)
        .filter(|&s| {
            let c = best(s);
            c.is_finite() && (s == 0 || c <= best(s - 1)) && (s + 1 == SCAN || c <= best(s + 1))
        })
        .collect();
    minima.sort_by(|&a, &b| best(a).total_cmp(&best(b)));
    minima.truncate(8);
    let mut starts = Vec::new();
    for s in minima {
        let (f, cands) = &profile[s];
        let floor = cands[0].0;
        // Near-equal candidates at one focal length (mirror images) each get a start.
        let mut taken: Vec<Vector3<f64>> = Vec::new();
        for (misfit, d) in cands {
            if *misfit > 4.0 * floor + 1e-20 || taken.len() == 3 {
                break;
            }
            if taken.iter().all(|t| angle_between(t, d) > 1e-6) {
                taken.push(*d);
                starts.push(DistanceState {
                    d: *d,
                    ln_f: f.ln(),
                });
            }
        }
    }
    starts
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::attitude_from_radec_roll;
    use nalgebra::Rotation3;

    fn sky(offsets: &[[f64; 2]], f: f64) -> (Rotation3<f64>, Vec<Vector3<f64>>, Vec<f64>) {
        let r = attitude_from_radec_roll(1.1, 0.4, 0.3);
        let stars = offsets
            .iter()
            .map(|o| r.inverse_transform_vector(&Vector3::new(o[0], o[1], f).normalize()))
            .collect();
        (r, stars, offsets.iter().map(|o| o[0].hypot(o[1])).collect())
    }

    #[test]
    fn exact_distances_known_and_unknown_focal() {
        let f = 0.5 * 512.0 / 6f64.to_radians().tan();
        let offsets = [[200.0, 30.0], [-120.0, 170.0], [-90.0, -210.0]];
        let (r, stars, a) = sky(&offsets, f);
        let truth = r.inverse_transform_vector(&Vector3::z());
        let known = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        assert!(angle_between(&known[0].boresight, &truth) < 1e-12);
        assert!(!known[0].ambiguous && !known[0].degenerate);
        let unknown = boresight_from_distances(&stars, &a, None).unwrap();
        let hit = unknown
            .iter()
            .find(|s| angle_between(&s.boresight, &truth) < 1e-10)
            .expect("the true solution is among the solutions");
        assert!((hit.focal_length_px - f).abs() < 1e-9 * f);
        assert!(hit.rms_px < 1e-9);
    }

    #[test]
    fn collinear_images_have_a_mirror_solution() {
        let f = 2000.0;
        let offsets = [[-200.0, 50.0], [0.0, 50.0], [180.0, 50.0]];
        let (_, stars, a) = sky(&offsets, f);
        let sols = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        assert!(sols.len() >= 2 && sols[0].ambiguous && sols[1].ambiguous);
        // Through the principal point: degenerate.
        let offsets = [[-200.0, 0.0], [30.0, 0.0], [180.0, 0.0]];
        let (_, stars, a) = sky(&offsets, f);
        let sols = boresight_from_distances(&stars, &a, Some(f)).unwrap();
        assert!(sols[0].degenerate);
    }
}
