//! Reading catalogues: star tables (CSV, TSV, whitespace; a header naming the columns) and the
//! Hipparcos 2 main catalogue (`hip2.dat`, ESA I/311).

use std::io::BufRead;
use std::path::Path;

use super::Catalog;
use crate::error::{Error, Result};
use crate::geometry::radec_to_unit;

impl Catalog {
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
