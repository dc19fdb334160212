//! The k-vector index over catalogue star pairs (Mortari & Neta 2000).
//!
//! Every pair of catalogue stars closer than `max_angle_rad` is stored with its angular
//! separation, sorted by separation. A straight line `z(j) = m·j + q` through the smallest and
//! largest separation (widened by a hair) maps an angle to a bin in O(1); the k-vector
//! `k[j]` counts the pairs with separation below `z(j)`. A range query `[lo, hi]` then reads
//! `k` at the two bins and trims the few pairs of the end bins by binary search, so its cost is
//! O(1 + answers) whatever the catalogue size.
//!
//! Each bin holds [`PAIRS_PER_BIN`] pairs on average: the k-vector costs a quarter of a word per
//! pair instead of one. Catalogues of at most 65 536 stars store a pair's two stars as 16-bit
//! indices: 9 bytes a pair in all (f32 angle, two u16, a quarter of a u32), 13 beyond that.

use std::ops::Range;

use nalgebra::Vector3;

use crate::catalog::Catalog;
use crate::error::{Error, Result};

/// Average number of pairs per k-vector bin.
pub const PAIRS_PER_BIN: usize = 4;

/// Largest index we agree to build, in pairs (about 1.2 GB).
pub const MAX_PAIRS: usize = 100_000_000;

/// Largest catalogue whose pairs are stored as 16-bit indices.
pub const NARROW_PAIR_STARS: usize = 1 << 16;

/// Catalogue indices of each pair, `[lower, higher]`: 16-bit when the catalogue allows.
#[derive(Debug, Clone)]
enum PairStore {
    Narrow(Vec<[u16; 2]>),
    Wide(Vec<[u32; 2]>),
}

/// The catalogue-index pairs of a range of a [`PairIndex`], as `[lower, higher]`.
#[derive(Debug, Clone)]
pub enum Pairs<'a> {
    /// Pairs stored as 16-bit indices.
    Narrow(std::slice::Iter<'a, [u16; 2]>),
    /// Pairs stored as 32-bit indices.
    Wide(std::slice::Iter<'a, [u32; 2]>),
}

impl Iterator for Pairs<'_> {
    type Item = [u32; 2];

    #[inline]
    fn next(&mut self) -> Option<[u32; 2]> {
        match self {
            Self::Narrow(it) => it.next().map(|p| [u32::from(p[0]), u32::from(p[1])]),
            Self::Wide(it) => it.next().copied(),
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = match self {
            Self::Narrow(it) => it.len(),
            Self::Wide(it) => it.len(),
        };
        (n, Some(n))
    }
}

impl ExactSizeIterator for Pairs<'_> {}

/// Sorted catalogue pairs with their k-vector.
#[derive(Debug, Clone)]
pub struct PairIndex {
    max_angle_rad: f64,
    /// Separations in radians, ascending.
    angles: Vec<f32>,
    pairs: PairStore,
    /// `k[j]` = number of pairs with angle < `q + m·j`.
    k: Vec<u32>,
    slope: f64,
    intercept: f64,
}

impl PairIndex {
    /// Index every pair of `catalog` separated by at most `max_angle_rad`.
    ///
    /// # Errors
    /// `InvalidInput` when the angle is not in (0, π) or the index would exceed [`MAX_PAIRS`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// assert!(idx.len() > 0 && idx.max_angle_rad() >= 0.2);
    /// ```
    pub fn build(catalog: &Catalog, max_angle_rad: f64) -> Result<Self> {
        Self::build_among(catalog, max_angle_rad, None)
    }

    /// Index the pairs of `catalog` separated by at most `max_angle_rad` whose two stars are
    /// both `members` (`None`: every star). Pairs keep the catalogue's star indices.
    ///
    /// # Errors
    /// As [`PairIndex::build`]; `InvalidInput` when `members` does not have one entry per star.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let members: Vec<bool> = cat.mag().iter().map(|&m| m < 4.0).collect();
    /// let some = starid_core::PairIndex::build_among(&cat, 0.2, Some(&members)).unwrap();
    /// let all = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// assert!(some.len() < all.len());
    /// ```
    pub fn build_among(
        catalog: &Catalog,
        max_angle_rad: f64,
        members: Option<&[bool]>,
    ) -> Result<Self> {
        if members.is_some_and(|m| m.len() != catalog.len()) {
            return Err(Error::invalid_input(
                "members must hold one flag per catalogue star",
            ));
        }
        if !max_angle_rad.is_finite()
            || max_angle_rad <= 0.0
            || max_angle_rad >= std::f64::consts::PI
        {
            return Err(Error::invalid_input(format!(
                "the pair index needs a maximum angle in (0, 180) degrees, got {} degrees",
                max_angle_rad.to_degrees()
            )));
        }
        let n = members.map_or(catalog.len(), |m| m.iter().filter(|&&x| x).count()) as f64;
        let expected = 0.25 * n * n * (1.0 - max_angle_rad.cos());
        if expected > MAX_PAIRS as f64 {
            return Err(Error::invalid_input(format!(
                "a pair index of {} stars up to {:.1} degrees would hold about {:.0} pairs (limit {}); \
                 use a smaller field of view or a brighter magnitude limit",
                catalog.len(),
                max_angle_rad.to_degrees(),
                expected,
                MAX_PAIRS
            )));
        }
        let mut entries = neighbour_pairs(catalog, max_angle_rad, members);
        entries.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let angles: Vec<f32> = entries.iter().map(|e| e.0).collect();
        let pairs = if catalog.len() <= NARROW_PAIR_STARS {
            // Indices below 65 536: the cast is exact.
            PairStore::Narrow(entries.iter().map(|e| e.1.map(|i| i as u16)).collect())
        } else {
            PairStore::Wide(entries.into_iter().map(|e| e.1).collect())
        };
        Ok(Self::from_sorted(angles, pairs, max_angle_rad))
    }

    /// An index over pairs already sorted by angle (`angles` ascending, one per pair) of a
    /// catalogue of `n_stars` stars.
    pub(crate) fn from_sorted_pairs(
        angles: Vec<f32>,
        pairs: &[[u32; 2]],
        n_stars: usize,
        max_angle_rad: f64,
    ) -> Self {
        let store = if n_stars <= NARROW_PAIR_STARS {
            // Indices below 65 536: the cast is exact.
            PairStore::Narrow(pairs.iter().map(|p| p.map(|i| i as u16)).collect())
        } else {
            PairStore::Wide(pairs.to_vec())
        };
        Self::from_sorted(angles, store, max_angle_rad)
    }

    fn from_sorted(angles: Vec<f32>, pairs: PairStore, max_angle_rad: f64) -> Self {
        let n = angles.len();
        let bins = (n / PAIRS_PER_BIN).max(2);
        let (lo, hi) = if n == 0 {
            (0.0, max_angle_rad)
        } else {
            (f64::from(angles[0]), f64::from(angles[n - 1]))
        };
        let delta = 1e-9 + (hi - lo) * 1e-9;
        let intercept = lo - delta;
        let slope = (hi - lo + 2.0 * delta) / (bins - 1) as f64;
        let mut k = Vec::with_capacity(bins);
        let mut count = 0usize;
        for j in 0..bins {
            let z = intercept + slope * j as f64;
            while count < n && f64::from(angles[count]) < z {
                count += 1;
            }
            k.push(count as u32);
        }
        k[bins - 1] = n as u32;
        Self {
            max_angle_rad,
            angles,
            pairs,
            k,
            slope,
            intercept,
        }
    }

    /// Positions in [`PairIndex::pairs`] of every pair with separation in `[lo_rad, hi_rad]`.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let r = idx.range(0.10, 0.11);
    /// // The range may hold a few pairs just outside [lo, hi]: check the angles.
    /// assert!(idx.angles(r.clone()).iter().filter(|&&a| (0.10..=0.11).contains(&(a as f64))).count() > 0);
    /// ```
    pub fn range(&self, lo_rad: f64, hi_rad: f64) -> Range<usize> {
        let n = self.angles.len();
        if n == 0 || hi_rad < lo_rad {
            return 0..0;
        }
        let bins = self.k.len();
        // One bin of slack on each side absorbs the f32 rounding of the stored angles.
        let jb = ((lo_rad - self.intercept) / self.slope).floor() - 1.0;
        let jt = ((hi_rad - self.intercept) / self.slope).ceil() + 1.0;
        if jt < 0.0 || jb > (bins - 1) as f64 {
            return 0..0;
        }
        // 32-bit conversions (saturating, as any `as`; the bins number far fewer than 2³²)
        // are cheaper than ones to usize.
        let jb = jb as u32 as usize;
        let jt = (jt as u32 as usize).min(bins - 1);
        let (a, b) = (self.k[jb] as usize, self.k[jt] as usize);
        // k[jb] counts pairs below z(jb) <= lo, so every answer sits at a or later;
        // k[jt] counts pairs below z(jt) >= hi (or all pairs), so every answer sits before b.
        let (lo32, hi32) = (lo_rad as f32, hi_rad as f32);
        let slice = &self.angles[a..b];
        let start = a + slice.partition_point(|&x| x < lo32);
        let end = a + slice.partition_point(|&x| x <= hi32);
        start..end.max(start)
    }

    /// Catalogue indices of the pairs at `range`.
    ///
    /// # Panics
    /// If `range` exceeds the index.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let r = idx.range(0.10, 0.11);
    /// for ([i, j], a) in idx.pairs(r.clone()).zip(idx.angles(r)) {
    ///     let exact = starid_core::geometry::angle_between(&cat.vectors()[i as usize], &cat.vectors()[j as usize]);
    ///     assert!((exact - *a as f64).abs() < 1e-6);
    /// }
    /// ```
    pub fn pairs(&self, range: Range<usize>) -> Pairs<'_> {
        match &self.pairs {
            PairStore::Narrow(p) => Pairs::Narrow(p[range].iter()),
            PairStore::Wide(p) => Pairs::Wide(p[range].iter()),
        }
    }

    /// Separation in radians of the pairs at `range`.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let a = idx.angles(idx.range(0.0, 0.2));
    /// assert!(a.windows(2).all(|w| w[0] <= w[1])); // sorted by angle
    /// ```
    pub fn angles(&self, range: Range<usize>) -> &[f32] {
        &self.angles[range]
    }

    /// Number of pairs.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// assert!(starid_core::PairIndex::build(&cat, 0.1).unwrap().len() < starid_core::PairIndex::build(&cat, 0.2).unwrap().len());
    /// ```
    pub fn len(&self) -> usize {
        self.angles.len()
    }

    /// Whether no pair is indexed.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// assert!(!starid_core::PairIndex::build(&cat, 0.2).unwrap().is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.angles.is_empty()
    }

    /// Largest indexed separation, radians.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// assert_eq!(starid_core::PairIndex::build(&cat, 0.2).unwrap().max_angle_rad(), 0.2);
    /// ```
    pub fn max_angle_rad(&self) -> f64 {
        self.max_angle_rad
    }

    /// Heap memory in bytes.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// assert!(idx.memory_bytes() >= 8 * idx.len());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        let pair_bytes = match &self.pairs {
            PairStore::Narrow(p) => p.len() * 4,
            PairStore::Wide(p) => p.len() * 8,
        };
        self.angles.len() * 4 + pair_bytes + self.k.len() * 4
    }

    /// Heap memory in bytes of an index holding `n_pairs` pairs of a catalogue of `n_stars`
    /// stars, without building it.
    pub(crate) fn memory_bytes_for(n_pairs: usize, n_stars: usize) -> usize {
        let per_pair = if n_stars <= NARROW_PAIR_STARS { 8 } else { 12 };
        n_pairs * per_pair + (n_pairs / PAIRS_PER_BIN).max(2) * 4
    }

    /// Number of pairs of `catalog` separated by at most `max_angle_rad`: the size of the index
    /// [`PairIndex::build`] would make, counted without storing a pair.
    pub(crate) fn count_pairs(catalog: &Catalog, max_angle_rad: f64) -> usize {
        let vectors = catalog.vectors();
        let per_star = |i: usize| -> usize {
            let mut n = 0;
            catalog.for_each_in_cone(&vectors[i], max_angle_rad, |j, _| {
                if (j as usize) > i {
                    n += 1;
                }
            });
            n
        };
        #[cfg(feature = "parallel")]
        {
            use rayon::prelude::*;
            (0..vectors.len()).into_par_iter().map(per_star).sum()
        }
        #[cfg(not(feature = "parallel"))]
        {
            (0..vectors.len()).map(per_star).sum()
        }
    }
}

/// Every pair of members within `max_angle_rad`, found through the catalogue's zone index.
fn neighbour_pairs(
    catalog: &Catalog,
    max_angle_rad: f64,
    members: Option<&[bool]>,
) -> Vec<(f32, [u32; 2])> {
    let vectors = catalog.vectors();
    let member = |i: usize| members.is_none_or(|m| m[i]);
    let per_star = |i: usize| -> Vec<(f32, [u32; 2])> {
        let mut out = Vec::new();
        if !member(i) {
            return out;
        }
        let vi: &Vector3<f64> = &vectors[i];
        catalog.for_each_in_cone(vi, max_angle_rad, |j, _| {
            if (j as usize) > i && member(j as usize) {
                let angle = crate::geometry::angle_between(vi, &vectors[j as usize]);
                if angle <= max_angle_rad {
                    out.push((angle as f32, [i as u32, j]));
                }
            }
        });
        out
    };
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..vectors.len())
            .into_par_iter()
            .flat_map_iter(per_star)
            .collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..vectors.len()).flat_map(per_star).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_handles_edges() {
        let angles = vec![0.1f32, 0.2, 0.2, 0.3, 0.5];
        let pairs = PairStore::Wide((0..5).map(|i| [i, i + 1]).collect());
        let idx = PairIndex::from_sorted(angles, pairs, 1.0);
        assert_eq!(idx.range(0.2, 0.2), 1..3);
        assert_eq!(idx.range(0.0, 1.0), 0..5);
        assert_eq!(idx.range(0.6, 1.0), 5..5);
        assert_eq!(idx.range(-1.0, 0.05), 0..0);
        assert_eq!(idx.range(0.25, 0.31), 3..4);
        assert_eq!(idx.range(0.3, 0.2), 0..0);
    }

    #[test]
    fn narrow_and_wide_storage_hold_the_same_pairs() {
        let small = crate::simulate::random_catalog(3000, 1.0, 6.0, 9).unwrap();
        let narrow = PairIndex::build(&small, 0.1).unwrap();
        assert!(matches!(narrow.pairs, PairStore::Narrow(_)));
        let all: Vec<[u32; 2]> = narrow.pairs(0..narrow.len()).collect();
        let wide = PairIndex::from_sorted(narrow.angles.clone(), PairStore::Wide(all.clone()), 0.1);
        for (lo, hi) in [(0.0, 0.1), (0.03, 0.031), (0.05, 0.2)] {
            let (a, b) = (narrow.range(lo, hi), wide.range(lo, hi));
            assert_eq!(a, b);
            assert!(narrow.pairs(a.clone()).eq(wide.pairs(b)));
            assert_eq!(narrow.pairs(a.clone()).len(), a.len());
        }
        assert_eq!(narrow.memory_bytes() + 4 * all.len(), wide.memory_bytes());
        assert_eq!(
            narrow.memory_bytes(),
            PairIndex::memory_bytes_for(all.len(), 3000)
        );
        // Past 65 536 stars, indices take 32 bits.
        let big = crate::simulate::random_catalog(NARROW_PAIR_STARS + 10, 1.0, 6.0, 9).unwrap();
        let idx = PairIndex::build(&big, 0.004).unwrap();
        assert!(matches!(idx.pairs, PairStore::Wide(_)));
        assert!(idx
            .pairs(0..idx.len())
            .any(|p| p[1] as usize >= NARROW_PAIR_STARS));
        assert_eq!(
            idx.memory_bytes(),
            PairIndex::memory_bytes_for(idx.len(), big.len())
        );
    }
}
