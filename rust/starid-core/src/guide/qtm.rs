//! The quaternary triangular mesh (QTM) of the sphere: triangles of a level, the triangle of a
//! direction, and guide stars chosen one per triangle.

use nalgebra::Vector3;

use super::{best_per_cell, QTM_MAX_LEVEL};
use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::angle_between;

/// Which star of a QTM triangle [`select_qtm`] keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QtmRule {
    /// The brightest star.
    Brightest,
    /// The star of largest `w = −(m + θ)`, `θ` in degrees from the triangle's incentre.
    Weighted,
}

/// Number of triangles of QTM level `level` (1-based): `8·4^(level−1)`.
///
/// # Example
/// ```
/// assert_eq!(starid_core::guide::qtm_triangle_count(3), 128);
/// ```
pub fn qtm_triangle_count(level: u32) -> u64 {
    8u64 << (2 * level.saturating_sub(1))
}

/// The QTM triangle of level `level` holding direction `v` (any non-zero vector): its id in
/// `0..qtm_triangle_count(level)` and its three vertices (unit vectors). Points on an edge go
/// to one of the triangles sharing it, always the same one.
///
/// # Errors
/// `InvalidInput` when the level is not in `1..=QTM_MAX_LEVEL`.
///
/// # Example
/// ```
/// let (id, corners) = starid_core::guide::qtm_triangle(&nalgebra::Vector3::new(0.3, 0.2, 0.9), 4).unwrap();
/// assert!(id < starid_core::guide::qtm_triangle_count(4));
/// assert!(corners.iter().all(|c| (c.norm() - 1.0).abs() < 1e-12));
/// ```
pub fn qtm_triangle(v: &Vector3<f64>, level: u32) -> Result<(u64, [Vector3<f64>; 3])> {
    check_level(level)?;
    Ok(locate(v, level))
}

fn check_level(level: u32) -> Result<()> {
    if !(1..=QTM_MAX_LEVEL).contains(&level) {
        return Err(Error::invalid_input(format!(
            "the QTM level must be in 1..={QTM_MAX_LEVEL} (level 1 is the octahedron's 8 faces), got {level}"
        )));
    }
    Ok(())
}

fn locate(v: &Vector3<f64>, level: u32) -> (u64, [Vector3<f64>; 3]) {
    let sign = |c: f64| if c < 0.0 { -1.0 } else { 1.0 };
    let mut id = (u64::from(v.x < 0.0) << 2) | (u64::from(v.y < 0.0) << 1) | u64::from(v.z < 0.0);
    let mut t = [
        Vector3::new(sign(v.x), 0.0, 0.0),
        Vector3::new(0.0, sign(v.y), 0.0),
        Vector3::new(0.0, 0.0, sign(v.z)),
    ];
    // The child at corner k is cut off by the great circle through the midpoints of the two
    // edges meeting at k; v belongs to it when it lies on the corner's side of that circle.
    let corner_side = |corner: &Vector3<f64>, m1: &Vector3<f64>, m2: &Vector3<f64>| {
        let normal = m1.cross(m2);
        v.dot(&normal) * corner.dot(&normal) > 0.0
    };
    for _ in 1..level {
        let [a, b, c] = t;
        let ab = (a + b).normalize();
        let bc = (b + c).normalize();
        let ca = (c + a).normalize();
        let (digit, child) = if corner_side(&a, &ab, &ca) {
            (0, [a, ab, ca])
        } else if corner_side(&b, &ab, &bc) {
            (1, [ab, b, bc])
        } else if corner_side(&c, &bc, &ca) {
            (2, [ca, bc, c])
        } else {
            (3, [ab, bc, ca])
        };
        id = (id << 2) | digit;
        t = child;
    }
    (id, t)
}

/// Incentre of the flat triangle `t` (side-length-weighted mean of the vertices), projected
/// onto the sphere.
fn projected_incentre(t: &[Vector3<f64>; 3]) -> Vector3<f64> {
    let [a, b, c] = t;
    let (la, lb, lc) = ((b - c).norm(), (c - a).norm(), (a - b).norm());
    (a * la + b * lb + c * lc).normalize()
}

/// Quaternary-triangular-mesh selection at `level`: one star per non-empty triangle, chosen
/// by `rule` (ties by catalogue order).
///
/// # Errors
/// `InvalidInput` when the level is not in `1..=QTM_MAX_LEVEL`.
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// use starid_core::guide::{select_qtm, QtmRule};
/// let g = select_qtm(&cat, 3, QtmRule::Weighted).unwrap();
/// assert!(g.len() <= 128);
/// ```
pub fn select_qtm(catalog: &Catalog, level: u32, rule: QtmRule) -> Result<Catalog> {
    check_level(level)?;
    let score = |i: usize| -> (u64, f64) {
        let v = &catalog.vectors()[i];
        let (id, t) = locate(v, level);
        let m = catalog.mag()[i];
        match rule {
            QtmRule::Brightest => (id, m),
            QtmRule::Weighted => (
                id,
                m + angle_between(v, &projected_incentre(&t)).to_degrees(),
            ),
        }
    };
    #[cfg(feature = "parallel")]
    let keyed: Vec<(u64, f64)> = {
        use rayon::prelude::*;
        (0..catalog.len()).into_par_iter().map(score).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let keyed: Vec<(u64, f64)> = (0..catalog.len()).map(score).collect();
    Ok(best_per_cell(catalog, keyed))
}
