//! Pointing and focal length, in two parts:
//!
//! - [`distances`]: the boresight (and focal length) from the distances of three or more star
//!   images from the principal point, the precision that geometry allows and the choice of the
//!   stars that give the best one (the contest solutions' "boresight from three stars").
//! - [`precision`]: the covariance that geometry predicts, the best stars to measure, and a
//!   Monte Carlo check.
//! - [`refine`]: attitude and camera (focal length, principal point, `k1`) fitted over all
//!   matched stars by Levenberg–Marquardt, with covariance; the focal length from star pairs.
//!
//! Everything is re-exported here: `pointing::boresight_from_distances`, `pointing::refine_pointing`.

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::geometry::angle_between;

pub mod distances;
pub mod precision;
pub mod refine;

pub use distances::*;
pub use precision::*;
pub use refine::*;

/// Largest number of stars the pointing functions accept.
pub const MAX_STARS: usize = 100_000;

pub(crate) fn check_stars(stars: &[Vector3<f64>], what: &str) -> Result<()> {
    if stars.len() > MAX_STARS {
        return Err(Error::invalid_input(format!(
            "at most {MAX_STARS} {what} are accepted, got {}",
            stars.len()
        )));
    }
    for (i, s) in stars.iter().enumerate() {
        if !s.iter().all(|c| c.is_finite()) || (s.norm() - 1.0).abs() > 1e-6 {
            return Err(Error::invalid_input(format!(
                "star {i} is not a finite unit vector"
            )));
        }
    }
    // Repeated stars: sorted by x, a repeat sits within 1e-9 in x of its twin (O(n log n)).
    let mut by_x: Vec<usize> = (0..stars.len()).collect();
    by_x.sort_by(|&a, &b| stars[a].x.total_cmp(&stars[b].x));
    for (pos, &i) in by_x.iter().enumerate() {
        for &k in &by_x[pos + 1..] {
            if stars[k].x - stars[i].x > 1e-9 {
                break;
            }
            if angle_between(&stars[i], &stars[k]) < 1e-9 {
                let (a, b) = (i.min(k), i.max(k));
                return Err(Error::invalid_input(format!(
                    "stars {a} and {b} are the same direction"
                )));
            }
        }
    }
    Ok(())
}

pub(crate) fn check_focal(f: f64) -> Result<()> {
    if !f.is_finite() || f <= 0.0 || f > 1e9 {
        return Err(Error::invalid_input(format!(
            "the focal length must be positive and finite (pixels), got {f}"
        )));
    }
    Ok(())
}
