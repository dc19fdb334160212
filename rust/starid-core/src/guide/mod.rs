//! Guide-star selection and the metrics that judge a guide catalogue.
//!
//! A star tracker carries a guide catalogue, not the whole sky: few stars, spread evenly, at
//! least three in every field. The selections here all pick, per region of the sky, the one
//! star that scores best:
//!
//! - [`select_magnitude`]: every star brighter than a limit (no spatial balancing).
//! - [`thin_doubles`]: of stars closer than a separation, keep the brighter (or merge them into
//!   one photocentre), so that no guide star is an unresolved double.
//! - [`select_rectangle`]: the spherical-rectangle grid, RA/Dec cells of equal angular size
//!   (5° cells give 72 × 36 = 2592 cells), brightest star per cell.
//! - [`select_qtm`]: the quaternary triangular mesh. The octahedron's 8 faces, projected on the
//!   sphere, are split recursively at their edge midpoints (great-circle arcs) into 4 children;
//!   level `n` has `8·4ⁿ⁻¹` triangles (level 1 is the octahedron). Per triangle either the
//!   brightest star ([`QtmRule::Brightest`]) or the star of largest weight `w = −(m + θ)`,
//!   `θ` being its angular distance in degrees from the triangle's incentre projected onto the
//!   sphere ([`QtmRule::Weighted`]): a star near the middle of its triangle beats a slightly
//!   brighter one on its edge, which evens out the spacing across triangle borders.
//!
//! Selections keep the input's order and ids. [`metrics`] measures the result: count,
//! nearest-neighbour distances, the distribution of the number of stars per field over uniform
//! random pointings (Monte Carlo) and the size of the pair index the catalogue would need.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::Vector3;
use rand::SeedableRng;

use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::random_rotation;
use crate::geometry::{angle_between, unit_to_radec};
use crate::kvector::PairIndex;

mod qtm;
pub use qtm::{qtm_triangle, qtm_triangle_count, select_qtm, QtmRule};

/// Deepest supported QTM level (`8·4¹⁹` triangles, about 0.6″ across).
pub const QTM_MAX_LEVEL: u32 = 20;

/// Most Monte Carlo fields [`field_star_counts`] accepts in one call.
pub const MAX_TRIALS: usize = 10_000_000;

/// Every star with `mag <= mag_limit`.
///
/// # Errors
/// `InvalidInput` when the limit is NaN or keeps no star.
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// let g = starid_core::guide::select_magnitude(&cat, 4.0).unwrap();
/// assert!(g.mag().iter().all(|&m| m <= 4.0));
/// ```
pub fn select_magnitude(catalog: &Catalog, mag_limit: f64) -> Result<Catalog> {
    catalog.filter_mag(mag_limit)
}

/// What [`thin_doubles`] does with a star too close to a brighter one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DoubleRule {
    /// Drop the fainter star.
    KeepBrighter,
    /// Merge the fainter stars into the brighter one: one star at the flux-weighted mean
    /// direction with the summed flux (`m = −2.5 log₁₀ Σ 10^(−0.4 mᵢ)`) and the brighter's id,
    /// which is what a tracker that cannot resolve the pair measures.
    Merge,
}

/// Remove close doubles. Stars are taken brightest first (ties by catalogue order); a star
/// is kept unless a brighter kept star lies within `min_separation_rad`, in which case it is
/// dropped or merged into that star (the first such one in brightness order) per `rule`.
///
/// # Errors
/// `InvalidInput` when the separation is not in (0, π).
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// use starid_core::guide::{thin_doubles, DoubleRule};
/// let g = thin_doubles(&cat, 0.5f64.to_radians(), DoubleRule::KeepBrighter).unwrap();
/// assert!(g.len() <= cat.len());
/// ```
pub fn thin_doubles(
    catalog: &Catalog,
    min_separation_rad: f64,
    rule: DoubleRule,
) -> Result<Catalog> {
    if !min_separation_rad.is_finite() || min_separation_rad <= 0.0 || min_separation_rad >= PI {
        return Err(Error::invalid_input(format!(
            "the double-star separation must be in (0, 180) degrees, got {} degrees",
            min_separation_rad.to_degrees()
        )));
    }
    let n = catalog.len();
    let vectors = catalog.vectors();
    let mag = catalog.mag();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| mag[a].total_cmp(&mag[b]).then(a.cmp(&b)));
    // owner[i]: the kept star that absorbs star i (itself when kept).
    let mut owner: Vec<Option<usize>> = vec![None; n];
    for &i in &order {
        if owner[i].is_some() {
            continue;
        }
        owner[i] = Some(i);
        catalog.for_each_in_cone(&vectors[i], min_separation_rad, |j, _| {
            let j = j as usize;
            if owner[j].is_none() {
                owner[j] = Some(i);
            }
        });
    }
    let mut kept: Vec<usize> = (0..n).filter(|&i| owner[i] == Some(i)).collect();
    kept.sort_unstable();
    let mut out = catalog.subset(&kept);
    if rule == DoubleRule::Merge && kept.len() < n {
        let slot: std::collections::HashMap<usize, usize> =
            kept.iter().enumerate().map(|(s, &i)| (i, s)).collect();
        let mut flux = vec![0.0f64; kept.len()];
        let mut direction = vec![Vector3::zeros(); kept.len()];
        for i in 0..n {
            let s = slot[&owner[i].expect("every star has an owner")];
            let f = 10f64.powf(-0.4 * mag[i]);
            flux[s] += f;
            direction[s] += vectors[i] * f;
        }
        let mut ra = Vec::with_capacity(kept.len());
        let mut dec = Vec::with_capacity(kept.len());
        for d in &direction {
            let (r, de) = unit_to_radec(&d.normalize());
            ra.push(r.to_degrees());
            dec.push(de.to_degrees());
        }
        let merged_mag = flux.iter().map(|f| -2.5 * f.log10()).collect();
        out = Catalog::new(out.ids().to_vec(), &ra, &dec, merged_mag)?;
    }
    Ok(out)
}

/// The spherical-rectangle grid: cells `cell_rad` wide in right ascension and `cell_rad` high
/// in declination (the last row and column may be narrower when `cell_rad` does not divide
/// the sphere), brightest star per cell (ties by catalogue order).
///
/// # Errors
/// `InvalidInput` when the cell size is not in (0, π].
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// let g = starid_core::guide::select_rectangle(&cat, 10f64.to_radians()).unwrap();
/// assert!(g.len() < cat.len());
/// ```
pub fn select_rectangle(catalog: &Catalog, cell_rad: f64) -> Result<Catalog> {
    if !cell_rad.is_finite() || cell_rad <= 0.0 || cell_rad > PI {
        return Err(Error::invalid_input(format!(
            "the rectangle cell size must be in (0, 180] degrees, got {} degrees",
            cell_rad.to_degrees()
        )));
    }
    let n_ra = (std::f64::consts::TAU / cell_rad).ceil() as u64;
    let n_dec = (PI / cell_rad).ceil() as u64;
    if n_ra.saturating_mul(n_dec) > 1u64 << 40 {
        return Err(Error::invalid_input(format!(
            "a {} degree grid has too many cells",
            cell_rad.to_degrees()
        )));
    }
    let cells = (0..catalog.len()).map(|i| {
        let ra_cell = ((catalog.ra_rad()[i] / cell_rad) as u64).min(n_ra - 1);
        let dec_cell = (((catalog.dec_rad()[i] + FRAC_PI_2) / cell_rad) as u64).min(n_dec - 1);
        (dec_cell * n_ra + ra_cell, catalog.mag()[i])
    });
    Ok(best_per_cell(catalog, cells))
}

/// Keep, per cell, the star of smallest score; `cells[i] = (cell, score)` of star `i`.
pub(super) fn best_per_cell(
    catalog: &Catalog,
    cells: impl IntoIterator<Item = (u64, f64)>,
) -> Catalog {
    let mut keyed: Vec<(u64, f64, usize)> = cells
        .into_iter()
        .enumerate()
        .map(|(i, (cell, score))| (cell, score, i))
        .collect();
    keyed.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut keep: Vec<usize> = Vec::new();
    let mut last: Option<u64> = None;
    for &(cell, _, i) in &keyed {
        if last != Some(cell) {
            keep.push(i);
            last = Some(cell);
        }
    }
    keep.sort_unstable();
    catalog.subset(&keep)
}

/// Angular distance in radians from each star to its nearest neighbour.
///
/// # Errors
/// `InvalidInput` for a catalogue of fewer than two stars.
///
/// # Example
/// ```
/// let cat = starid_core::Catalog::new(vec![1, 2, 3], &[0.0, 1.0, 10.0], &[0.0; 3], vec![1.0; 3]).unwrap();
/// let nn = starid_core::guide::nearest_neighbour_angles(&cat).unwrap();
/// assert!((nn[2].to_degrees() - 9.0).abs() < 1e-9);
/// ```
pub fn nearest_neighbour_angles(catalog: &Catalog) -> Result<Vec<f64>> {
    let n = catalog.len();
    if n < 2 {
        return Err(Error::invalid_input(
            "nearest-neighbour distances need at least two stars",
        ));
    }
    let vectors = catalog.vectors();
    // Start at twice the mean spacing and widen until a neighbour shows up.
    let start = 2.0 * (4.0 * PI / n as f64).sqrt();
    let nearest = |i: usize| -> f64 {
        let mut radius = start.min(PI);
        loop {
            let mut best: Option<(u32, f64)> = None;
            catalog.for_each_in_cone(&vectors[i], radius, |j, c| {
                if j as usize != i && best.is_none_or(|b| c > b.1) {
                    best = Some((j, c));
                }
            });
            if let Some((j, _)) = best {
                return angle_between(&vectors[i], &vectors[j as usize]);
            }
            if radius >= PI {
                return PI;
            }
            radius = (2.0 * radius).min(PI);
        }
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        Ok((0..n).into_par_iter().map(nearest).collect())
    }
    #[cfg(not(feature = "parallel"))]
    {
        Ok((0..n).map(nearest).collect())
    }
}

/// The shape of a star-tracker field for [`field_star_counts`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Field {
    /// A circular field whose full cone angle is the given angle (radians).
    Circle {
        /// Full cone angle.
        fov_rad: f64,
    },
    /// A square sensor whose full angle across one side is the given angle (radians), at a
    /// uniformly random roll.
    Square {
        /// Full angle across a side.
        fov_rad: f64,
    },
}

impl Field {
    /// Validate the field.
    fn check(&self) -> Result<()> {
        let (fov, limit) = match *self {
            Field::Circle { fov_rad } => (fov_rad, PI),
            Field::Square { fov_rad } => (fov_rad, 179f64.to_radians()),
        };
        if !fov.is_finite() || fov <= 0.0 || fov >= limit {
            return Err(Error::invalid_input(format!(
                "field of view must be in (0, {:.0}) degrees, got {} degrees",
                limit.to_degrees(),
                fov.to_degrees()
            )));
        }
        Ok(())
    }

    /// The same shape with another field of view.
    ///
    /// # Example
    /// ```
    /// use starid_core::guide::Field;
    /// assert_eq!(Field::Square { fov_rad: 0.1 }.with_fov(0.2), Field::Square { fov_rad: 0.2 });
    /// ```
    pub fn with_fov(self, fov_rad: f64) -> Self {
        match self {
            Field::Circle { .. } => Field::Circle { fov_rad },
            Field::Square { .. } => Field::Square { fov_rad },
        }
    }

    /// The largest angle between two stars of one field, radians.
    ///
    /// # Example
    /// ```
    /// use starid_core::guide::Field;
    /// let square = Field::Square { fov_rad: 10f64.to_radians() };
    /// assert!(square.max_pair_angle_rad() > 10f64.to_radians()); // the diagonal
    /// ```
    pub fn max_pair_angle_rad(&self) -> f64 {
        match *self {
            Field::Circle { fov_rad } => fov_rad,
            Field::Square { fov_rad } => 2.0 * (2f64.sqrt() * (0.5 * fov_rad).tan()).atan(),
        }
    }
}

/// Monte Carlo over `trials` uniformly random pointings (and rolls) of `field`: entry `k` of
/// the result is the number of fields holding exactly `k` stars. Deterministic for a seed,
/// whatever the number of threads.
///
/// # Errors
/// `InvalidInput` for an invalid field or `trials` not in `1..=MAX_TRIALS`.
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// use starid_core::guide::{field_star_counts, Field};
/// let hist = field_star_counts(&cat, Field::Circle { fov_rad: 0.2 }, 1000, 7).unwrap();
/// assert_eq!(hist.iter().sum::<u64>(), 1000);
/// ```
pub fn field_star_counts(
    catalog: &Catalog,
    field: Field,
    trials: usize,
    seed: u64,
) -> Result<Vec<u64>> {
    field.check()?;
    if trials == 0 || trials > MAX_TRIALS {
        return Err(Error::invalid_input(format!(
            "trials must be in 1..={MAX_TRIALS}, got {trials}"
        )));
    }
    const CHUNK: usize = 4096;
    let vectors = catalog.vectors();
    let radius = 0.5 * field.max_pair_angle_rad();
    let chunk = |c: usize| -> Vec<u64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(
            seed ^ (c as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        let mut hist = Vec::new();
        for _ in (c * CHUNK)..((c + 1) * CHUNK).min(trials) {
            // Rows of the ICRS → camera rotation are the camera axes in ICRS.
            let r = random_rotation(&mut rng);
            let m = r.matrix();
            let (x_axis, y_axis, z_axis) = (
                m.row(0).transpose(),
                m.row(1).transpose(),
                m.row(2).transpose(),
            );
            let mut count = 0usize;
            match field {
                Field::Circle { .. } => {
                    catalog.for_each_in_cone(&z_axis, radius, |_, _| count += 1);
                }
                Field::Square { fov_rad } => {
                    let half = (0.5 * fov_rad).tan();
                    catalog.for_each_in_cone(&z_axis, radius, |j, c| {
                        let v = &vectors[j as usize];
                        if c > 0.0
                            && v.dot(&x_axis).abs() <= half * c
                            && v.dot(&y_axis).abs() <= half * c
                        {
                            count += 1;
                        }
                    });
                }
            }
            if hist.len() <= count {
                hist.resize(count + 1, 0);
            }
            hist[count] += 1;
        }
        hist
    };
    let chunks = trials.div_ceil(CHUNK);
    #[cfg(feature = "parallel")]
    let parts: Vec<Vec<u64>> = {
        use rayon::prelude::*;
        (0..chunks).into_par_iter().map(chunk).collect()
    };
    #[cfg(not(feature = "parallel"))]
    let parts: Vec<Vec<u64>> = (0..chunks).map(chunk).collect();
    let mut hist: Vec<u64> = Vec::new();
    for part in parts {
        if hist.len() < part.len() {
            hist.resize(part.len(), 0);
        }
        for (h, p) in hist.iter_mut().zip(part) {
            *h += p;
        }
    }
    Ok(hist)
}

/// The figures that judge a guide catalogue for one field.
#[derive(Debug, Clone, PartialEq)]
pub struct GuideMetrics {
    /// Number of guide stars.
    pub count: usize,
    /// Smallest nearest-neighbour distance, radians.
    pub nn_min_rad: f64,
    /// Mean nearest-neighbour distance, radians.
    pub nn_mean_rad: f64,
    /// Standard deviation of the nearest-neighbour distance (population, `1/n`), radians.
    pub nn_std_rad: f64,
    /// `stars_per_field[k]`: Monte Carlo fields holding exactly `k` stars.
    pub stars_per_field: Vec<u64>,
    /// Pairs within one field's largest pair angle: the size of the pair index.
    pub pairs: usize,
    /// Memory of that pair index, bytes.
    pub index_bytes: usize,
}

impl GuideMetrics {
    /// Number of Monte Carlo fields.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let m = starid_core::guide::metrics(&cat, starid_core::guide::Field::Circle { fov_rad: 0.2 }, 500, 1).unwrap();
    /// assert_eq!(m.trials(), 500);
    /// ```
    pub fn trials(&self) -> u64 {
        self.stars_per_field.iter().sum()
    }

    /// Fraction of fields holding at least `k` stars.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let m = starid_core::guide::metrics(&cat, starid_core::guide::Field::Circle { fov_rad: 0.2 }, 500, 1).unwrap();
    /// assert!(m.p_at_least(0) == 1.0 && m.p_at_least(1) <= 1.0);
    /// ```
    pub fn p_at_least(&self, k: usize) -> f64 {
        let hit: u64 = self.stars_per_field.iter().skip(k).sum();
        hit as f64 / self.trials() as f64
    }

    /// Mean number of stars per field.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let m = starid_core::guide::metrics(&cat, starid_core::guide::Field::Circle { fov_rad: 0.2 }, 500, 1).unwrap();
    /// assert!(m.mean_stars_per_field() > 0.0);
    /// ```
    pub fn mean_stars_per_field(&self) -> f64 {
        let total: u64 = self
            .stars_per_field
            .iter()
            .enumerate()
            .map(|(k, &n)| k as u64 * n)
            .sum();
        total as f64 / self.trials() as f64
    }
}

/// All metrics of `catalog` for `field`: nearest-neighbour statistics, `trials` Monte Carlo
/// fields drawn from `seed`, and the pair-index size.
///
/// # Errors
/// As [`nearest_neighbour_angles`] and [`field_star_counts`].
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
/// let m = starid_core::guide::metrics(&cat, starid_core::guide::Field::Circle { fov_rad: 0.2 }, 500, 1).unwrap();
/// assert_eq!(m.count, 3000);
/// assert!(m.nn_min_rad <= m.nn_mean_rad && m.pairs > 0);
/// ```
pub fn metrics(catalog: &Catalog, field: Field, trials: usize, seed: u64) -> Result<GuideMetrics> {
    let nn = nearest_neighbour_angles(catalog)?;
    let stars_per_field = field_star_counts(catalog, field, trials, seed)?;
    let n = nn.len() as f64;
    let mean = nn.iter().sum::<f64>() / n;
    let var = nn.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / n;
    let pairs = PairIndex::count_pairs(catalog, field.max_pair_angle_rad());
    Ok(GuideMetrics {
        count: catalog.len(),
        nn_min_rad: nn.iter().copied().fold(f64::INFINITY, f64::min),
        nn_mean_rad: mean,
        nn_std_rad: var.sqrt(),
        stars_per_field,
        pairs,
        index_bytes: PairIndex::memory_bytes_for(pairs, catalog.len()),
    })
}

/// Smallest tolerance of [`fov_for_coverage`], radians (1e-6 degrees): the bisection halves
/// its bracket each step, and a smaller one would never end in floating point.
pub const MIN_COVERAGE_TOL_RAD: f64 = 1e-6 * std::f64::consts::PI / 180.0;

/// The smallest field of `field`'s shape, within `[lo_rad, hi_rad]` and to `tol_rad`, in
/// which a fraction `p` of `trials` random pointings holds at least `k` stars: bisection over
/// the Monte Carlo of [`field_star_counts`] with the same pointings (`seed`) at every step.
///
/// # Errors
/// `InvalidInput` for `p` outside (0, 1], `k` = 0, a bracket not `0 < lo < hi`, a tolerance
/// below [`MIN_COVERAGE_TOL_RAD`], or when even `hi_rad` does not reach `p`; as
/// [`field_star_counts`] otherwise.
///
/// # Example
/// ```
/// use starid_core::guide::{fov_for_coverage, Field};
/// let cat = starid_core::simulate::random_catalog(5000, 1.0, 6.0, 1).unwrap();
/// let shape = Field::Circle { fov_rad: 0.0 };
/// let fov = fov_for_coverage(&cat, shape, 0.99, 3, 2000, 0, 1e-3, 1.0, 1e-4).unwrap();
/// assert!(fov > 0.0 && fov < 1.0);
/// ```
#[allow(clippy::too_many_arguments)]
pub fn fov_for_coverage(
    catalog: &Catalog,
    field: Field,
    p: f64,
    k: usize,
    trials: usize,
    seed: u64,
    lo_rad: f64,
    hi_rad: f64,
    tol_rad: f64,
) -> Result<f64> {
    if !(p > 0.0 && p <= 1.0) {
        return Err(Error::invalid_input(format!(
            "p must be in (0, 1], got {p}"
        )));
    }
    if k == 0 {
        return Err(Error::invalid_input("k must be >= 1"));
    }
    if !(lo_rad > 0.0 && lo_rad < hi_rad && hi_rad.is_finite()) {
        return Err(Error::invalid_input(format!(
            "need 0 < lo_deg < hi_deg, got lo_deg={} hi_deg={}",
            lo_rad.to_degrees(),
            hi_rad.to_degrees()
        )));
    }
    if tol_rad.is_nan() || tol_rad < MIN_COVERAGE_TOL_RAD {
        return Err(Error::invalid_input(format!(
            "the tolerance (tol_deg) must be at least 1e-6 degrees, got {} degrees",
            tol_rad.to_degrees()
        )));
    }
    let coverage = |fov: f64| -> Result<f64> {
        let hist = field_star_counts(catalog, field.with_fov(fov), trials, seed)?;
        Ok(hist.iter().skip(k).sum::<u64>() as f64 / trials as f64)
    };
    if coverage(hi_rad)? < p {
        return Err(Error::invalid_input(format!(
            "even a {} degree field holds {k} stars in less than {:.4}% of pointings",
            hi_rad.to_degrees(),
            100.0 * p
        )));
    }
    let (mut lo, mut hi) = (lo_rad, hi_rad);
    while hi - lo > tol_rad {
        let mid = 0.5 * (lo + hi);
        if coverage(mid)? >= p {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::radec_to_unit;
    use crate::simulate::random_catalog;

    #[test]
    fn qtm_counts_and_partition() {
        assert_eq!(qtm_triangle_count(1), 8);
        assert_eq!(qtm_triangle_count(5), 2048);
        // Every triangle of level 3 is hit by some direction and ids stay in range.
        let cat = random_catalog(20_000, 1.0, 6.0, 3).unwrap();
        let mut seen = vec![false; qtm_triangle_count(3) as usize];
        for v in cat.vectors() {
            let (id, t) = qtm_triangle(v, 3).unwrap();
            seen[id as usize] = true;
            // The point lies inside its triangle: on the inner side of all three edges.
            for k in 0..3 {
                let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                let n = p.cross(&q);
                assert!(v.dot(&n) * r.dot(&n) >= -1e-12);
            }
        }
        assert!(seen.iter().all(|&s| s));
        assert!(qtm_triangle(&Vector3::x(), 0).is_err());
        assert!(qtm_triangle(&Vector3::x(), 21).is_err());
    }

    #[test]
    fn doubles_are_thinned_or_merged() {
        let cat = Catalog::new(
            vec![1, 2, 3],
            &[10.0, 10.01, 20.0],
            &[0.0, 0.0, 0.0],
            vec![3.0, 3.0, 4.0],
        )
        .unwrap();
        let sep = 0.05f64.to_radians();
        let thin = thin_doubles(&cat, sep, DoubleRule::KeepBrighter).unwrap();
        assert_eq!(thin.ids(), &[1, 3]);
        let merged = thin_doubles(&cat, sep, DoubleRule::Merge).unwrap();
        assert_eq!(merged.ids(), &[1, 3]);
        // Two equal stars: 0.75 mag brighter, halfway between.
        assert!((merged.mag()[0] - (3.0 - 2.5 * 2f64.log10())).abs() < 1e-12);
        assert!((merged.ra_rad()[0].to_degrees() - 10.005).abs() < 1e-9);
        assert_eq!(merged.mag()[1], 4.0);
    }

    #[test]
    fn rectangle_grid_keeps_brightest_per_cell() {
        let cat = Catalog::new(
            vec![1, 2, 3, 4],
            &[1.0, 2.0, 6.0, 359.0],
            &[1.0, 2.0, 1.0, -89.0],
            vec![5.0, 4.0, 5.0, 3.0],
        )
        .unwrap();
        let sel = select_rectangle(&cat, 5f64.to_radians()).unwrap();
        assert_eq!(sel.ids(), &[2, 3, 4]);
    }

    #[test]
    fn nearest_neighbours_match_brute_force() {
        let cat = random_catalog(500, 1.0, 6.0, 9).unwrap();
        let nn = nearest_neighbour_angles(&cat).unwrap();
        let v = cat.vectors();
        for i in 0..cat.len() {
            let want = (0..cat.len())
                .filter(|&j| j != i)
                .map(|j| angle_between(&v[i], &v[j]))
                .fold(f64::INFINITY, f64::min);
            assert!(
                (nn[i] - want).abs() < 1e-12,
                "star {i}: {} vs {want}",
                nn[i]
            );
        }
    }

    #[test]
    fn monte_carlo_matches_area_fraction() {
        // Uniform sky of 4000 stars, 10° circular field: mean count = N (1 - cos 5°) / 2.
        let cat = random_catalog(4000, 1.0, 6.0, 1).unwrap();
        let m = metrics(
            &cat,
            Field::Circle {
                fov_rad: 10f64.to_radians(),
            },
            20_000,
            5,
        )
        .unwrap();
        let expect = 4000.0 * (1.0 - 5f64.to_radians().cos()) / 2.0;
        assert!((m.mean_stars_per_field() - expect).abs() < 0.05 * expect);
        assert_eq!(m.trials(), 20_000);
        // A square field of the same side holds 4/π times as many.
        let sq = field_star_counts(
            &cat,
            Field::Square {
                fov_rad: 10f64.to_radians(),
            },
            20_000,
            5,
        )
        .unwrap();
        let mean_sq: f64 = sq
            .iter()
            .enumerate()
            .map(|(k, &n)| (k as u64 * n) as f64)
            .sum::<f64>()
            / 20_000.0;
        assert!((mean_sq / m.mean_stars_per_field() - 4.0 / PI).abs() < 0.05);
        // Pair count equals the index that would be built.
        let built = PairIndex::build(&cat, 10f64.to_radians()).unwrap();
        assert_eq!(m.pairs, built.len());
        assert_eq!(m.index_bytes, built.memory_bytes());
        // Same seed, same answer.
        let again = field_star_counts(
            &cat,
            Field::Circle {
                fov_rad: 10f64.to_radians(),
            },
            20_000,
            5,
        )
        .unwrap();
        assert_eq!(again, m.stars_per_field);
    }

    #[test]
    fn weighted_qtm_prefers_the_centre() {
        // Two stars in one level-1 triangle (the +x+y+z octant): a bright one near a vertex and
        // a slightly fainter one at the centre.
        let centre = radec_to_unit(45f64.to_radians(), 35.26f64.to_radians());
        let (ra_c, dec_c) = unit_to_radec(&centre);
        let cat = Catalog::new(
            vec![1, 2],
            &[1.0, ra_c.to_degrees()],
            &[1.0, dec_c.to_degrees()],
            vec![4.0, 4.5],
        )
        .unwrap();
        assert_eq!(select_qtm(&cat, 1, QtmRule::Brightest).unwrap().ids(), &[1]);
        assert_eq!(select_qtm(&cat, 1, QtmRule::Weighted).unwrap().ids(), &[2]);
    }
}
