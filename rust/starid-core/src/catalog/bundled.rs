//! The catalogues compiled into the core: Hipparcos to Hp 6.5 (the default) and the deep table
//! to Hp 11 that narrow fields draw from.

use super::Catalog;
use crate::error::{Error, Result};

/// The bundled deep table: Hipparcos 2 stars to Hp 11 at J2000.0 (114 825 stars), made by
/// `catalog/make_hipparcos_catalog.py --mag-limit 11`: the magic `STARIDHP`, the star count
/// (u32), then four little-endian columns in HIP order: id (i32), RA and Dec (i32,
/// milliarcseconds) and Hp (i16, millimagnitudes).
const DEEP_TABLE: &[u8] = include_bytes!("../../data/hipparcos_hp11_j2000.bin");

/// Faintest magnitude the bundled deep table holds.
pub const BUNDLED_DEEP_LIMIT: f64 = 11.0;

/// Brightest magnitude limit [`Catalog::bundled_deep`] takes.
pub const BUNDLED_DEEP_FLOOR: f64 = -2.0;

const MAGIC: &[u8; 8] = b"STARIDHP";

/// The deep table's columns, borrowed from the compiled-in bytes.
struct DeepColumns {
    n: usize,
}

impl DeepColumns {
    fn get() -> Self {
        assert_eq!(&DEEP_TABLE[..8], MAGIC, "the bundled deep table's magic");
        let n = u32::from_le_bytes(DEEP_TABLE[8..12].try_into().expect("4 bytes")) as usize;
        assert_eq!(
            DEEP_TABLE.len(),
            12 + 14 * n,
            "the bundled deep table's length"
        );
        Self { n }
    }

    fn i32_at(&self, column: usize, row: usize) -> i32 {
        let at = 12 + 4 * (column * self.n + row);
        i32::from_le_bytes(DEEP_TABLE[at..at + 4].try_into().expect("4 bytes"))
    }

    fn mmag(&self, row: usize) -> i16 {
        let at = 12 + 12 * self.n + 2 * row;
        i16::from_le_bytes(DEEP_TABLE[at..at + 2].try_into().expect("2 bytes"))
    }

    /// Rows at or brighter than `mag_limit`, checked against the table's range.
    fn rows(&self, mag_limit: f64) -> Result<impl Iterator<Item = usize> + '_> {
        if !(BUNDLED_DEEP_FLOOR..=BUNDLED_DEEP_LIMIT).contains(&mag_limit) {
            return Err(Error::invalid_input(format!(
                "the bundled catalogue goes to Hp {BUNDLED_DEEP_LIMIT}: mag_limit must be in \
                 [{BUNDLED_DEEP_FLOOR}, {BUNDLED_DEEP_LIMIT}], got {mag_limit}"
            )));
        }
        let limit = (mag_limit * 1000.0).round_ties_even() as i32;
        Ok((0..self.n).filter(move |&r| i32::from(self.mmag(r)) <= limit))
    }
}

impl Catalog {
    /// The Hipparcos stars to `mag_limit` (at most [`BUNDLED_DEEP_LIMIT`]) at J2000.0 from the
    /// compiled-in deep table, in HIP order: for fields too narrow for [`Catalog::bundled`].
    ///
    /// # Errors
    /// `InvalidInput` for a limit outside [−2, 11], `Catalog` when it leaves no star.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::Catalog::bundled_deep(8.0).unwrap();
    /// assert_eq!(cat.len(), 37_635);
    /// ```
    pub fn bundled_deep(mag_limit: f64) -> Result<Self> {
        let t = DeepColumns::get();
        let rows: Vec<usize> = t.rows(mag_limit)?.collect();
        let ids = rows.iter().map(|&r| i64::from(t.i32_at(0, r))).collect();
        let ra: Vec<f64> = rows
            .iter()
            .map(|&r| f64::from(t.i32_at(1, r)) / 3.6e6)
            .collect();
        let dec: Vec<f64> = rows
            .iter()
            .map(|&r| f64::from(t.i32_at(2, r)) / 3.6e6)
            .collect();
        let mag = rows
            .iter()
            .map(|&r| f64::from(t.mmag(r)) / 1000.0)
            .collect();
        Self::new(ids, &ra, &dec, mag)
    }

    /// How many stars [`Catalog::bundled_deep`] holds at `mag_limit`, without building it.
    ///
    /// # Errors
    /// `InvalidInput` for a limit outside [−2, 11].
    pub fn bundled_deep_len(mag_limit: f64) -> Result<usize> {
        Ok(DeepColumns::get().rows(mag_limit)?.count())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_deep_table_holds_its_depths() {
        assert_eq!(Catalog::bundled_deep_len(11.0).unwrap(), 114_825);
        assert_eq!(Catalog::bundled_deep_len(8.0).unwrap(), 37_635);
        let cat = Catalog::bundled_deep(6.5).unwrap();
        // The default catalogue's stars, and one more that millimagnitudes round to 6.5.
        let default = Catalog::bundled();
        assert_eq!(cat.len(), default.len() + 1);
        let ids: std::collections::HashSet<i64> = cat.ids().iter().copied().collect();
        assert!(default.ids().iter().all(|id| ids.contains(id)));
        assert!(Catalog::bundled_deep(11.5).is_err());
        assert!(Catalog::bundled_deep(f64::NAN).is_err());
    }
}
