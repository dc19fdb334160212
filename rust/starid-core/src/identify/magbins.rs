//! The pair index split by magnitude: one k-vector per pair of magnitude bins, so that the
//! magnitude-gated search reads only the pairs whose two stars can be the two centroids.
//!
//! Stars fall into [`MAG_BINS`] bins of equal count (the faint end, where most stars are, gets
//! narrow bins). A centroid's catalogue-magnitude window covers a run of bins; a centroid pair
//! reads the sub-indexes of every bin pair of the two runs, each once. Built from the full pair
//! index on the first gated pass (it doubles the pair memory, so frames that never need it
//! never pay for it).

use std::ops::Range;

use crate::kvector::PairIndex;

/// Number of magnitude bins.
pub const MAG_BINS: usize = 12;

/// Sub-indexes of the pairs of each unordered pair of magnitude bins.
#[derive(Debug, Clone)]
pub struct MagPairIndex {
    /// Upper magnitude edge of each bin but the last (ascending).
    edges: Vec<f32>,
    /// Sub-index of bin pair `(a, b)`, `a <= b`, at `a * MAG_BINS + b`.
    subs: Vec<PairIndex>,
}

impl MagPairIndex {
    /// Split `pairs` (over a catalogue with magnitudes `mags`) by the bins of their stars.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// use starid_core::{identify::MagPairIndex, PairIndex};
    /// let pairs = PairIndex::build(&cat, 0.2).unwrap();
    /// let mags: Vec<f32> = cat.mag().iter().map(|&m| m as f32).collect();
    /// let idx = MagPairIndex::build(&pairs, &mags);
    /// assert!(idx.memory_bytes() > 0);
    /// ```
    pub fn build(pairs: &PairIndex, mags: &[f32]) -> Self {
        let mut sorted = mags.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let n = sorted.len().max(1);
        let mut edges: Vec<f32> = (1..MAG_BINS)
            .map(|k| sorted[(k * n / MAG_BINS).min(n - 1)])
            .collect();
        edges.dedup();
        let bins = edges.len() + 1;
        let bin = |m: f32| edges.partition_point(|&e| e <= m);
        let mut parts: Vec<(Vec<f32>, Vec<[u32; 2]>)> =
            vec![(Vec::new(), Vec::new()); MAG_BINS * MAG_BINS];
        let all = 0..pairs.len();
        for (angle, [p, q]) in pairs.angles(all.clone()).iter().zip(pairs.pairs(all)) {
            let (bp, bq) = (bin(mags[p as usize]), bin(mags[q as usize]));
            let (a, b) = (bp.min(bq), bp.max(bq));
            let part = &mut parts[a * MAG_BINS + b];
            part.0.push(*angle);
            part.1.push([p, q]);
        }
        let _ = bins;
        let subs = parts
            .into_iter()
            .map(|(angles, ps)| {
                PairIndex::from_sorted_pairs(angles, &ps, mags.len(), pairs.max_angle_rad())
            })
            .collect();
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
    /// assert!(MagPairIndex::build(&pairs, &mags).memory_bytes() >= pairs.memory_bytes());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        self.subs.iter().map(PairIndex::memory_bytes).sum::<usize>() + self.edges.len() * 4
    }
}
