//! The k-vector index over catalogue star pairs (Mortari & Neta 2000).
//!
//! Every pair of catalogue stars closer than `max_angle_rad` is stored, sorted by separation. A
//! straight line `z(j) = m·j + q` through the smallest and largest separation (widened by a hair)
//! maps an angle to a bin in O(1); the k-vector `k[j]` counts the pairs with separation below
//! `z(j)`. A range query `[lo, hi]` reads `k` at the two bins that hold `lo` and `hi`: O(1)
//! whatever the catalogue size.
//!
//! The separations themselves are not stored. A range answers with whole bins, so it may hold
//! pairs up to one bin's width ([`PairIndex::slack_rad`]) outside `[lo, hi]`; at the bundled
//! catalogue's 12° index that is 0.6″, a hundredth of a pixel, far inside any search's tolerance.
//! A caller that needs the exact set ([`PairIndex::range_parts`]) checks the pairs of the two end
//! bins against the catalogue's vectors, which it holds anyway. Without the separations a pair
//! costs its two star indices and an eighth of a k-vector word: 4.5 bytes for catalogues of at
//! most 65 536 stars (16-bit indices), 8.5 beyond (it was 9 with an f32 separation and bins of
//! four pairs), so that the pair index and the magnitude-split index of the bundled catalogue
//! fit in 8 MB together at 12°.

use std::ops::Range;

use nalgebra::Vector3;

use crate::catalog::Catalog;
use crate::error::{Error, Result};

/// Average number of pairs per k-vector bin.
pub const PAIRS_PER_BIN: usize = 8;

/// Allowance for the f32 rounding of the separations the bins were counted from, radians (an
/// f32 holds a separation of 0.6 rad to 3.6·10⁻⁸ rad).
const ROUNDING_RAD: f64 = 1e-7;

/// Largest index we agree to build, in pairs (about 1.2 GB).
pub const MAX_PAIRS: usize = 100_000_000;

/// Largest catalogue whose pairs are stored as 16-bit indices.
pub const NARROW_PAIR_STARS: usize = 1 << 16;

/// Catalogue indices of each pair, `[lower, higher]`: 16-bit when the catalogue allows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum PairStore {
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

/// A separation interval `[lo, hi]` and the cosines of its ends, for
/// [`PairIndex::range_exact`].
#[derive(Debug, Clone, Copy)]
pub struct AngleWindow {
    lo_rad: f64,
    hi_rad: f64,
    /// `cos(hi)`: a pair inside has a dot product at least this.
    cos_lo: f64,
    /// `cos(max(lo, 0))`: a pair inside has a dot product at most this.
    cos_hi: f64,
}

impl AngleWindow {
    /// The interval `[lo_rad, hi_rad]` (empty when `hi_rad < lo_rad`).
    ///
    /// # Example
    /// ```
    /// let w = starid_core::kvector::AngleWindow::new(0.1, 0.2);
    /// assert_eq!(w.bounds(), (0.1, 0.2));
    /// ```
    pub fn new(lo_rad: f64, hi_rad: f64) -> Self {
        Self {
            lo_rad,
            hi_rad,
            cos_lo: hi_rad.min(std::f64::consts::PI).cos(),
            cos_hi: lo_rad.max(0.0).cos(),
        }
    }

    /// `[t − eps, t + eps]` from the cosines and sines of `t` and `eps` (`[cos, sin]`), without
    /// a trigonometric call: the search knows them for every side it tries.
    ///
    /// # Example
    /// ```
    /// use starid_core::kvector::AngleWindow;
    /// let (t, eps) = (0.1f64, 0.001f64);
    /// let a = AngleWindow::around(t, [t.cos(), t.sin()], eps, [eps.cos(), eps.sin()]);
    /// let b = AngleWindow::new(t - eps, t + eps);
    /// assert_eq!(a.bounds(), b.bounds());
    /// assert!((a.cosines().0 - b.cosines().0).abs() < 1e-15 && (a.cosines().1 - b.cosines().1).abs() < 1e-15);
    /// ```
    #[inline]
    pub fn around(t: f64, [cos_t, sin_t]: [f64; 2], eps: f64, [cos_e, sin_e]: [f64; 2]) -> Self {
        let (lo_rad, hi_rad) = (t - eps, t + eps);
        Self {
            lo_rad,
            hi_rad,
            cos_lo: if hi_rad >= std::f64::consts::PI {
                -1.0
            } else {
                cos_t * cos_e - sin_t * sin_e
            },
            cos_hi: if lo_rad <= 0.0 {
                1.0
            } else {
                cos_t * cos_e + sin_t * sin_e
            },
        }
    }

    /// `(lo, hi)`, radians.
    pub fn bounds(&self) -> (f64, f64) {
        (self.lo_rad, self.hi_rad)
    }

    /// `(cos(hi), cos(max(lo, 0)))`: a pair inside the window has a dot product between them.
    pub fn cosines(&self) -> (f64, f64) {
        (self.cos_lo, self.cos_hi)
    }
}

/// Sorted catalogue pairs with their k-vector.
#[derive(Debug, Clone, PartialEq)]
pub struct PairIndex {
    max_angle_rad: f64,
    /// How many pairs.
    len: usize,
    /// The pairs, by ascending separation.
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
        // Up to 65 536 stars, each pair packs into one integer whose order is the index's
        // (separation, then the two stars: the bits of a sign-positive f32 order as
        // `total_cmp` does), and integers sort several times faster than compared tuples.
        if catalog.len() <= NARROW_PAIR_STARS {
            let mut keys = neighbour_pairs(catalog, max_angle_rad, members, |a, i, j| {
                (u64::from(a.to_bits()) << 32) | (u64::from(i) << 16) | u64::from(j)
            });
            // Separations are never negative, so every key has a clear sign bit.
            debug_assert!(keys.iter().all(|k| k >> 63 == 0));
            sort_keys(&mut keys, max_angle_rad);
            let angles: Vec<f32> = keys
                .iter()
                .map(|&k| f32::from_bits((k >> 32) as u32))
                .collect();
            // Indices below 65 536: the casts are exact.
            let pairs =
                PairStore::Narrow(keys.iter().map(|&k| [(k >> 16) as u16, k as u16]).collect());
            return Ok(Self::from_sorted(&angles, pairs, max_angle_rad));
        }
        let mut entries = neighbour_pairs(catalog, max_angle_rad, members, |a, i, j| (a, [i, j]));
        let by_angle =
            |a: &(f32, [u32; 2]), b: &(f32, [u32; 2])| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
        #[cfg(feature = "parallel")]
        {
            use rayon::slice::ParallelSliceMut;
            entries.par_sort_unstable_by(by_angle);
        }
        #[cfg(not(feature = "parallel"))]
        entries.sort_unstable_by(by_angle);
        let angles: Vec<f32> = entries.iter().map(|e| e.0).collect();
        let pairs = PairStore::Wide(entries.into_iter().map(|e| e.1).collect());
        Ok(Self::from_sorted(&angles, pairs, max_angle_rad))
    }

    /// An index over pairs of a catalogue of `n_stars` stars already sorted by separation, with
    /// `angles` their separations as f32 (ascending, one per pair): they count the bins and are
    /// not kept.
    pub(crate) fn from_sorted_pairs(
        angles: &[f32],
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

    fn from_sorted(angles: &[f32], pairs: PairStore, max_angle_rad: f64) -> Self {
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
            len: n,
            pairs,
            k,
            slope,
            intercept,
        }
    }

    /// Positions in [`PairIndex::pairs`] of every pair with separation in `[lo_rad, hi_rad]`,
    /// and of the pairs that share their end bins: those lie at most [`PairIndex::slack_rad`]
    /// outside the interval.
    ///
    /// # Example
    /// ```
    /// use starid_core::geometry::angle_between;
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let v = cat.vectors();
    /// let (lo, hi) = (0.10, 0.11);
    /// let inside = |[i, j]: [u32; 2]| (lo..=hi).contains(&angle_between(&v[i as usize], &v[j as usize]));
    /// let n = idx.pairs(idx.range(lo, hi)).filter(|&p| inside(p)).count();
    /// assert!(n > 0 && n <= idx.range(lo, hi).len());
    /// ```
    #[inline]
    pub fn range(&self, lo_rad: f64, hi_rad: f64) -> Range<usize> {
        self.range_parts(lo_rad, hi_rad).0
    }

    /// [`PairIndex::range`] and, inside it, the pairs of the bins wholly within
    /// `[lo_rad, hi_rad]` (to within the f32 rounding of the separations the bins were counted
    /// from, 10⁻⁷ rad): only the pairs of the first range outside the second need checking
    /// against the interval.
    ///
    /// # Example
    /// ```
    /// use starid_core::geometry::angle_between;
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let v = cat.vectors();
    /// let (all, sure) = idx.range_parts(0.10, 0.12);
    /// assert!(all.start <= sure.start && sure.end <= all.end && !sure.is_empty());
    /// for [i, j] in idx.pairs(sure) {
    ///     let a = angle_between(&v[i as usize], &v[j as usize]);
    ///     assert!(a >= 0.10 - 1e-7 && a <= 0.12 + 1e-7);
    /// }
    /// ```
    #[inline]
    pub fn range_parts(&self, lo_rad: f64, hi_rad: f64) -> (Range<usize>, Range<usize>) {
        let n = self.len;
        // Also refuses NaN bounds (no ordering).
        if n == 0 || hi_rad.partial_cmp(&lo_rad).is_none_or(|o| o.is_lt()) {
            return (0..0, 0..0);
        }
        let bins = self.k.len();
        // The bins holding lo and hi: z(jb) <= lo < z(jb + 1) and z(jt - 1) <= hi < z(jt).
        // Truncating conversions, not floor (a library call on baseline x86-64): below zero, lo
        // reads bin 0 (saturating) and hi lies below every pair.
        let xb = (lo_rad - ROUNDING_RAD - self.intercept) / self.slope;
        let xt = (hi_rad + ROUNDING_RAD - self.intercept) / self.slope;
        if xt < 0.0 || xb >= (bins - 1) as f64 {
            return (0..0, 0..0);
        }
        // 32-bit conversions (the bins number far fewer than 2³²) are cheaper than ones to usize.
        let jb = xb as u32 as usize;
        let jt = (xt as u32 as usize + 1).min(bins - 1);
        // k[jb] counts pairs below z(jb) <= lo, so every answer sits at a or later;
        // k[jt] counts pairs below z(jt) > hi (or all pairs), so every answer sits before b.
        let (a, b) = (self.k[jb] as usize, self.k[jt] as usize);
        // The bins between hold pairs in [z(jb + 1), z(jt - 1)), inside [lo, hi].
        let sure = if jb + 2 <= jt {
            let (c, d) = (self.k[jb + 1] as usize, self.k[jt - 1] as usize);
            c..d.max(c)
        } else {
            a..a
        };
        (a..b, sure)
    }

    /// Positions of the pairs with separation in `window`: [`PairIndex::range_parts`], its two
    /// end bins trimmed by binary search on the separations of their pairs, recomputed from the
    /// catalogue's unit vectors `vectors` (dot products against the window's cosines). The bins
    /// between are taken whole, which is exact to within the f32 rounding of the separations
    /// they were counted from (10⁻⁷ rad).
    ///
    /// # Example
    /// ```
    /// use starid_core::geometry::angle_between;
    /// use starid_core::kvector::AngleWindow;
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// let v = cat.vectors();
    /// let r = idx.range_exact(&AngleWindow::new(0.10, 0.11), v);
    /// let inside = |[i, j]: [u32; 2]| (0.10..=0.11).contains(&angle_between(&v[i as usize], &v[j as usize]));
    /// assert!(!r.is_empty() && idx.pairs(r.clone()).all(inside));
    /// assert_eq!(idx.pairs(idx.range(0.10, 0.11)).filter(|&p| inside(p)).count(), r.len());
    /// ```
    pub fn range_exact(&self, window: &AngleWindow, vectors: &[Vector3<f64>]) -> Range<usize> {
        let (all, sure) = self.range_parts(window.lo_rad, window.hi_rad);
        match &self.pairs {
            PairStore::Narrow(ps) => trim(ps, all, sure, window, vectors),
            PairStore::Wide(ps) => trim(ps, all, sure, window, vectors),
        }
    }

    /// How far outside a query's interval the pairs of [`PairIndex::range`] may lie, radians:
    /// one bin's width and the rounding allowance.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let idx = starid_core::PairIndex::build(&cat, 0.2).unwrap();
    /// assert!(idx.slack_rad() < 1e-4);
    /// ```
    pub fn slack_rad(&self) -> f64 {
        self.slope + 2.0 * ROUNDING_RAD
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
    /// for [i, j] in idx.pairs(r) {
    ///     let a = starid_core::geometry::angle_between(&cat.vectors()[i as usize], &cat.vectors()[j as usize]);
    ///     assert!(i < j && a >= 0.10 - idx.slack_rad() && a <= 0.11 + idx.slack_rad());
    /// }
    /// ```
    pub fn pairs(&self, range: Range<usize>) -> Pairs<'_> {
        match &self.pairs {
            PairStore::Narrow(p) => Pairs::Narrow(p[range].iter()),
            PairStore::Wide(p) => Pairs::Wide(p[range].iter()),
        }
    }

    /// Number of pairs.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// assert!(starid_core::PairIndex::build(&cat, 0.1).unwrap().len() < starid_core::PairIndex::build(&cat, 0.2).unwrap().len());
    /// ```
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether no pair is indexed.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// assert!(!starid_core::PairIndex::build(&cat, 0.2).unwrap().is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len == 0
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
    /// assert!(idx.memory_bytes() >= 4 * idx.len());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        let pair_bytes = match &self.pairs {
            PairStore::Narrow(p) => p.len() * 4,
            PairStore::Wide(p) => p.len() * 8,
        };
        pair_bytes + self.k.len() * 4
    }

    /// What an index file keeps: the pairs, the k-vector, its slope and intercept.
    pub(crate) fn stored_parts(&self) -> (&PairStore, &[u32], f64, f64) {
        (&self.pairs, &self.k, self.slope, self.intercept)
    }

    /// An index from the parts [`PairIndex::stored_parts`] gave, for a catalogue of `n_stars`
    /// stars; `None` unless they are consistent (indices in the catalogue, a k-vector that
    /// rises to the number of pairs, the storage width the catalogue implies).
    pub(crate) fn from_stored_parts(
        max_angle_rad: f64,
        pairs: PairStore,
        k: Vec<u32>,
        [slope, intercept]: [f64; 2],
        n_stars: usize,
    ) -> Option<Self> {
        let len = match &pairs {
            // (Every pair checked without a branch: a file of millions reads in a millisecond.)
            PairStore::Narrow(p) if n_stars <= NARROW_PAIR_STARS => {
                let n = n_stars as u32;
                p.iter()
                    .fold(true, |ok, &[a, b]| ok & (a < b) & (u32::from(b) < n))
                    .then_some(p.len())?
            }
            PairStore::Wide(p) if n_stars > NARROW_PAIR_STARS => {
                let n = u32::try_from(n_stars).ok()?;
                p.iter()
                    .fold(true, |ok, &[a, b]| ok & (a < b) & (b < n))
                    .then_some(p.len())?
            }
            _ => return None,
        };
        let sound = max_angle_rad.is_finite()
            && max_angle_rad > 0.0
            && max_angle_rad < std::f64::consts::PI
            && slope.is_finite()
            && slope > 0.0
            && intercept.is_finite()
            && k.len() >= 2
            && k.windows(2).fold(true, |ok, w| ok & (w[0] <= w[1]))
            && k.last().is_some_and(|&n| n as usize == len);
        sound.then_some(Self {
            max_angle_rad,
            len,
            pairs,
            k,
            slope,
            intercept,
        })
    }

    /// Heap memory in bytes of an index holding `n_pairs` pairs of a catalogue of `n_stars`
    /// stars, without building it.
    pub(crate) fn memory_bytes_for(n_pairs: usize, n_stars: usize) -> usize {
        let per_pair = if n_stars <= NARROW_PAIR_STARS { 4 } else { 8 };
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

/// `all` less the pairs of its end bins (outside `sure`) that lie outside `window`, by binary
/// search: separations ascend, so the pairs' dot products descend (up to the f32 rounding the
/// order came from).
fn trim<T: Copy + Into<u32>>(
    pairs: &[[T; 2]],
    all: Range<usize>,
    sure: Range<usize>,
    window: &AngleWindow,
    vectors: &[Vector3<f64>],
) -> Range<usize> {
    let dot = |p: &[T; 2]| vectors[p[0].into() as usize].dot(&vectors[p[1].into() as usize]);
    // Still below lo: the first pair at or above lo lies after it.
    let below = |p: &[T; 2]| dot(p) > window.cos_hi;
    // At or below hi: the first pair above hi lies after it.
    let not_above = |p: &[T; 2]| dot(p) >= window.cos_lo;
    if sure.is_empty() {
        let start = all.start + pairs[all.clone()].partition_point(below);
        let end = start + pairs[start..all.end].partition_point(not_above);
        return start..end;
    }
    let start = all.start + pairs[all.start..sure.start].partition_point(below);
    let end = sure.end + pairs[sure.end..all.end].partition_point(not_above);
    start..end
}

/// Every pair of members within `max_angle_rad`, found through the catalogue's zone index,
/// as `make(separation, i, j)` with `i < j`.
fn neighbour_pairs<T: Send>(
    catalog: &Catalog,
    max_angle_rad: f64,
    members: Option<&[bool]>,
    make: impl Fn(f32, u32, u32) -> T + Sync,
) -> Vec<T> {
    let vectors = catalog.vectors();
    let member = |i: usize| members.is_none_or(|m| m[i]);
    let per_star = |i: usize| -> Vec<T> {
        let mut out = Vec::new();
        if !member(i) {
            return out;
        }
        let vi: &Vector3<f64> = &vectors[i];
        catalog.for_each_in_cone(vi, max_angle_rad, |j, _| {
            if (j as usize) > i && member(j as usize) {
                let angle = crate::geometry::unit_separation(vi, &vectors[j as usize]);
                if angle <= max_angle_rad {
                    out.push(make(angle as f32, i as u32, j));
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

/// Sort packed pair keys (separation bits, then the two stars) whose separations lie in
/// `[0, max_angle_rad]`: a bucket pass on the squared separation (pairs are about uniform in
/// it, the sky's area growing with the radius), then each bucket on its own. The order is the
/// keys' own, as a comparison sort gives (instrumented builds of the bundled catalogue at 12°:
/// about 11 ms against 21 ms for `par_sort_unstable`).
fn sort_keys(keys: &mut Vec<u64>, max_angle_rad: f64) {
    const PER_BUCKET: usize = 32;
    let buckets = (keys.len() / PER_BUCKET).max(1);
    let scale = buckets as f64 / (max_angle_rad * max_angle_rad);
    // Monotone in the key: a larger separation never lands in an earlier bucket.
    let bucket = |k: u64| {
        let a = f64::from(f32::from_bits((k >> 32) as u32));
        ((a * a * scale) as usize).min(buckets - 1)
    };
    let mut starts = vec![0usize; buckets + 1];
    for &k in keys.iter() {
        starts[bucket(k) + 1] += 1;
    }
    for b in 0..buckets {
        starts[b + 1] += starts[b];
    }
    let mut next = starts.clone();
    let mut out = vec![0u64; keys.len()];
    for &k in keys.iter() {
        let b = bucket(k);
        out[next[b]] = k;
        next[b] += 1;
    }
    let mut parts: Vec<&mut [u64]> = Vec::with_capacity(buckets);
    let mut rest = out.as_mut_slice();
    for b in 0..buckets {
        let (part, tail) = rest.split_at_mut(starts[b + 1] - starts[b]);
        parts.push(part);
        rest = tail;
    }
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        parts
            .into_par_iter()
            .with_min_len(256)
            .for_each(|p| p.sort_unstable());
    }
    #[cfg(not(feature = "parallel"))]
    parts.into_iter().for_each(|p| p.sort_unstable());
    *keys = out;
}

#[cfg(test)]
mod tests;
