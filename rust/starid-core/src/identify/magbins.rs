//! The pair index split by magnitude: one k-vector per pair of magnitude bins, so that the
//! magnitude-gated search reads only the pairs whose two stars can be the two centroids.
//!
//! Stars fall into [`MAG_BINS`] bins of equal count (the faint end, where most stars are, gets
//! narrow bins). A centroid's catalogue-magnitude window covers a run of bins; a centroid pair
//! reads the sub-indexes of every bin pair of the two runs, each once. Built from the full pair
//! index on the first gated pass (it doubles the pair memory, so frames that never need it
//! never pay for it).

use std::ops::Range;

use nalgebra::Vector3;

use crate::geometry::unit_separation;
use crate::kvector::PairIndex;

/// Number of magnitude bins. Each sub-index query trims its two end bins by binary search on
/// dot products (the index keeps no separations), so fewer, fuller sub-indexes pay: 200 K1
/// scenes with magnitudes under callgrind took 1.52 G instructions with 12 bins, 1.41 G with
/// 8, 1.37 G with 6 and 1.36 G with 4 (the candidates are the same: the centroids' magnitude
/// windows decide them, the bins only skip pairs that cannot fit).
pub const MAG_BINS: usize = 6;

/// Sub-indexes of the pairs of each unordered pair of magnitude bins.
#[derive(Debug, Clone)]
pub struct MagPairIndex {
    /// Upper magnitude edge of each bin but the last (ascending).
    edges: Vec<f32>,
    /// Sub-index of bin pair `(a, b)`, `a <= b`, at `a * MAG_BINS + b`.
    subs: Vec<PairIndex>,
}

impl MagPairIndex {
    /// Split `pairs` (over a catalogue with unit vectors `vectors` and magnitudes `mags`) by
    /// the bins of their stars. Each sub-index keeps the pairs' order by separation; the
    /// separations, which the pair index does not store, are recomputed to count its bins.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// use starid_core::{identify::MagPairIndex, PairIndex};
    /// let pairs = PairIndex::build(&cat, 0.2).unwrap();
    /// let mags: Vec<f32> = cat.mag().iter().map(|&m| m as f32).collect();
    /// let idx = MagPairIndex::build(&pairs, cat.vectors(), &mags);
    /// assert!(idx.memory_bytes() > 0);
    /// ```
    pub fn build(pairs: &PairIndex, vectors: &[Vector3<f64>], mags: &[f32]) -> Self {
        let mut sorted = mags.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let n = sorted.len().max(1);
        let mut edges: Vec<f32> = (1..MAG_BINS)
            .map(|k| sorted[(k * n / MAG_BINS).min(n - 1)])
            .collect();
        edges.dedup();
        // Each star's bin, looked up once rather than once per pair.
        let star_bin: Vec<usize> = mags
            .iter()
            .map(|&m| edges.partition_point(|&e| e <= m))
            .collect();
        let mut parts: Vec<Vec<[u32; 2]>> = vec![Vec::new(); MAG_BINS * MAG_BINS];
        for [p, q] in pairs.pairs(0..pairs.len()) {
            let (bp, bq) = (star_bin[p as usize], star_bin[q as usize]);
            parts[bp.min(bq) * MAG_BINS + bp.max(bq)].push([p, q]);
        }
        let sub = |ps: Vec<[u32; 2]>| {
            // The separations as the pair index's build rounded them: the same order.
            let angles: Vec<f32> = ps
                .iter()
                .map(|&[p, q]| unit_separation(&vectors[p as usize], &vectors[q as usize]) as f32)
                .collect();
            PairIndex::from_sorted_pairs(&angles, &ps, mags.len(), pairs.max_angle_rad())
        };
        #[cfg(feature = "parallel")]
        let subs = {
            use rayon::prelude::*;
            parts.into_par_iter().map(sub).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let subs = parts.into_iter().map(sub).collect();
        Self { edges, subs }
    }

    /// Bins overlapping the magnitude window `[lo, hi]`.
    pub(crate) fn bins(&self, window: [f32; 2]) -> Range<usize> {
        let lo = self.edges.partition_point(|&e| e <= window[0]);
        let hi = self.edges.partition_point(|&e| e <= window[1]);
        lo..hi + 1
    }

    /// The ids of the sub-indexes to read for two centroids with bin runs `a` and `b`, each once.
    pub(crate) fn for_each_sub(
        &self,
        a: Range<usize>,
        b: Range<usize>,
        mut f: impl FnMut(usize, &PairIndex),
    ) {
        for x in a.clone() {
            for y in b.clone() {
                let (lo, hi) = (x.min(y), x.max(y));
                // (lo, hi) is reached again from (hi, lo) when both runs hold both bins.
                if x > y && a.contains(&y) && b.contains(&x) {
                    continue;
                }
                let id = lo * MAG_BINS + hi;
                f(id, &self.subs[id]);
            }
        }
    }

    /// Heap memory in bytes.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// use starid_core::{identify::MagPairIndex, PairIndex};
    /// let pairs = PairIndex::build(&cat, 0.2).unwrap();
    /// let mags: Vec<f32> = cat.mag().iter().map(|&m| m as f32).collect();
    /// assert!(MagPairIndex::build(&pairs, cat.vectors(), &mags).memory_bytes() >= pairs.memory_bytes());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        self.subs.iter().map(PairIndex::memory_bytes).sum::<usize>() + self.edges.len() * 4
    }
}
