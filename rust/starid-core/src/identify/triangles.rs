//! Triangles of locally bright stars, found by their side lengths: the Pyramid's bright pass
//! asks for every catalogue triangle whose three sides fall in the windows of a triangle of
//! spots. Walking the pair index answers that by reading every pair of two sides (a hundred or
//! so each for the bundled catalogue at 12°) and linking them; this index answers it from the
//! few triangles stored near the sides' lengths.
//!
//! Every triangle of stars of the bright pair index whose sides are at most `max_side` is stored
//! once, under its sides sorted (smallest `a`, middle `b`, largest `c`), each cut into cells of
//! `max_side / CELLS`. A query sorts the windows' lower ends and their upper ends (a triangle
//! whose sides lie in the windows has sorted sides between them, side by side), reads the cells
//! of that box and keeps the triangles whose sides (dot products against the windows' cosines)
//! fit, in every assignment of their stars to the spots: the answer of the pair-list walk.

use nalgebra::Vector3;

use crate::kvector::{AngleWindow, PairIndex};

/// Cells of the side-length grid along one side, up to the largest indexed side.
const CELLS: usize = 128;

/// Most cells of `(c, b)` a look-up reads (each holds a few triangles); a wider box (the
/// loosest tolerances) is answered by walking the pair lists instead.
const MAX_CELL_ROWS: usize = 32;

/// Rounding allowance between a triangle's stored sides (arc cosines of its dot products) and
/// a window's bounds, radians: far above either's error, far below any tolerance.
const MARGIN_RAD: f64 = 1e-9;

/// The stars of the indexed triangles: 16-bit indices while the catalogue allows.
#[derive(Debug, Clone)]
enum TriStore {
    Narrow(Vec<[u16; 3]>),
    Wide(Vec<[u32; 3]>),
}

/// Triangles of a pair index's stars with every side at most `max_side`, by sorted side
/// lengths (see the module documentation).
#[derive(Debug, Clone)]
pub(crate) struct TriangleIndex {
    max_side_rad: f64,
    cell_rad: f64,
    /// `start[row(c, b)]..start[row(c, b) + 1]`: the triangles whose largest side is in cell
    /// `c` and middle side in cell `b` (b ≤ c), by the cell of their smallest side.
    start: Vec<u32>,
    /// The cell of each triangle's smallest side.
    small: Vec<u8>,
    tris: TriStore,
}

/// Row of cells `(c, b)`, `b ≤ c`, in the triangular table.
#[inline]
fn row(c: usize, b: usize) -> usize {
    c * (c + 1) / 2 + b
}

impl TriangleIndex {
    /// Every triangle of `pairs`' stars (unit vectors `vectors`) whose sides are all at most
    /// `max_side_rad` (at most the index's own largest angle).
    pub(crate) fn build(pairs: &PairIndex, vectors: &[Vector3<f64>], max_side_rad: f64) -> Self {
        let max_side = max_side_rad
            .min(pairs.max_angle_rad())
            .max(f64::MIN_POSITIVE);
        let cell_rad = max_side / CELLS as f64;
        let n = vectors.len();
        // Each star's neighbours of higher index within max_side: a triangle is then met once,
        // from its lowest star.
        let within = pairs.range_exact(&AngleWindow::new(0.0, max_side), vectors);
        let mut first = vec![0u32; n + 1];
        for [p, q] in pairs.pairs(within.clone()) {
            first[p.min(q) as usize + 1] += 1;
        }
        for i in 0..n {
            first[i + 1] += first[i];
        }
        let mut next = first.clone();
        let mut nbr = vec![0u32; first[n] as usize];
        for [p, q] in pairs.pairs(within) {
            let slot = &mut next[p.min(q) as usize];
            nbr[*slot as usize] = p.max(q);
            *slot += 1;
        }
        for p in 0..n {
            nbr[first[p] as usize..first[p + 1] as usize].sort_unstable();
        }
        let cos_max = max_side.cos();
        let cell = |t: f64| ((t / cell_rad) as usize).min(CELLS - 1);
        let side = |d: f64| d.clamp(-1.0, 1.0).acos();
        // The triangles of star p as its lowest star, keyed by their cells.
        let of_star = |p: usize| -> Vec<(u32, [u32; 3])> {
            let list = &nbr[first[p] as usize..first[p + 1] as usize];
            let vp = &vectors[p];
            let mut out = Vec::new();
            for (x, &q) in list.iter().enumerate() {
                let vq = &vectors[q as usize];
                let d_pq = vp.dot(vq);
                for &r in &list[x + 1..] {
                    let vr = &vectors[r as usize];
                    let d_qr = vq.dot(vr);
                    if d_qr < cos_max {
                        continue;
                    }
                    let mut s = [side(d_pq), side(vp.dot(vr)), side(d_qr)];
                    s.sort_unstable_by(f64::total_cmp);
                    let key = (row(cell(s[2]), cell(s[1])) as u32) << 8 | cell(s[0]) as u32;
                    out.push((key, [p as u32, q, r]));
                }
            }
            out
        };
        // (The key and the stars make every entry distinct: the order is the same either way.)
        #[cfg(feature = "parallel")]
        let keyed: Vec<(u32, [u32; 3])> = {
            use rayon::prelude::*;
            let mut keyed: Vec<(u32, [u32; 3])> =
                (0..n).into_par_iter().flat_map_iter(of_star).collect();
            keyed.par_sort_unstable();
            keyed
        };
        #[cfg(not(feature = "parallel"))]
        let keyed: Vec<(u32, [u32; 3])> = {
            let mut keyed: Vec<(u32, [u32; 3])> = (0..n).flat_map(of_star).collect();
            keyed.sort_unstable();
            keyed
        };
        let rows = row(CELLS - 1, CELLS - 1) + 1;
        let mut start = vec![0u32; rows + 1];
        for &(key, _) in &keyed {
            start[(key >> 8) as usize + 1] += 1;
        }
        for i in 0..rows {
            start[i + 1] += start[i];
        }
        let small = keyed.iter().map(|&(key, _)| (key & 0xff) as u8).collect();
        let tris = if n <= usize::from(u16::MAX) + 1 {
            TriStore::Narrow(keyed.iter().map(|&(_, t)| t.map(|s| s as u16)).collect())
        } else {
            TriStore::Wide(keyed.iter().map(|&(_, t)| t).collect())
        };
        Self {
            max_side_rad: max_side,
            cell_rad,
            start,
            small,
            tris,
        }
    }

    /// Number of triangles.
    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.small.len()
    }

    /// Heap memory in bytes.
    pub(crate) fn memory_bytes(&self) -> usize {
        let per = match &self.tris {
            TriStore::Narrow(_) => 6,
            TriStore::Wide(_) => 12,
        };
        self.start.len() * 4 + self.small.len() * (per + 1)
    }

    #[inline]
    fn triangle(&self, slot: usize) -> [u32; 3] {
        match &self.tris {
            TriStore::Narrow(t) => t[slot].map(u32::from),
            TriStore::Wide(t) => t[slot],
        }
    }

    /// The triangles `[a, b, c]` (stars of spots i, j, k) whose sides i–j, i–k and j–k are in
    /// `windows` (as for [`PairIndex::range_exact`]: dot products against the windows'
    /// cosines), appended to `out` in the index's order; `false` (and nothing appended) when
    /// the index cannot answer: a window reaching past its largest side, or a box of more than
    /// [`MAX_CELL_ROWS`] cell rows.
    pub(crate) fn find(
        &self,
        windows: &[AngleWindow; 3],
        vectors: &[Vector3<f64>],
        out: &mut Vec<[u32; 3]>,
    ) -> bool {
        let bounds = windows.map(|w| w.bounds());
        if bounds
            .iter()
            .any(|&(lo, hi)| lo.is_nan() || hi.is_nan() || hi > self.max_side_rad)
        {
            return false;
        }
        let sorted = |mut v: [f64; 3]| {
            v.sort_unstable_by(f64::total_cmp);
            v
        };
        let lo = sorted(bounds.map(|b| b.0));
        let hi = sorted(bounds.map(|b| b.1));
        let cell = |t: f64| ((t.max(0.0) / self.cell_rad) as usize).min(CELLS - 1);
        let span = |k: usize| (cell(lo[k] - MARGIN_RAD), cell(hi[k] + MARGIN_RAD));
        let ((a0, a1), (b0, b1), (c0, c1)) = (span(0), span(1), span(2));
        if (c1 - c0 + 1) * (b1 - b0 + 1) > MAX_CELL_ROWS {
            return false;
        }
        let [w_ij, w_ik, w_jk] = windows.map(|w| w.cosines());
        let inside = |d: f64, (cos_lo, cos_hi): (f64, f64)| d >= cos_lo && d <= cos_hi;
        for c in c0..=c1 {
            for b in b0..=b1.min(c) {
                let t = row(c, b);
                let (s, e) = (self.start[t] as usize, self.start[t + 1] as usize);
                for slot in s..e {
                    let a = usize::from(self.small[slot]);
                    if a < a0 || a > a1 {
                        continue;
                    }
                    let [p, q, r] = self.triangle(slot);
                    let (vp, vq, vr) = (
                        &vectors[p as usize],
                        &vectors[q as usize],
                        &vectors[r as usize],
                    );
                    let (pq, pr, qr) = (vp.dot(vq), vp.dot(vr), vq.dot(vr));
                    // Each assignment of the three stars to spots i, j, k, with its sides
                    // i–j, i–k, j–k.
                    for (t, ij, ik, jk) in [
                        ([p, q, r], pq, pr, qr),
                        ([p, r, q], pr, pq, qr),
                        ([q, p, r], pq, qr, pr),
                        ([q, r, p], qr, pq, pr),
                        ([r, p, q], pr, qr, pq),
                        ([r, q, p], qr, pr, pq),
                    ] {
                        if inside(ij, w_ij) && inside(ik, w_ik) && inside(jk, w_jk) {
                            out.push(t);
                        }
                    }
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::random_catalog;
    use rand::{Rng, SeedableRng};

    /// Every triangle with sides in the windows: each pair of the first window (from the pair
    /// index, both ways round) with every third star of the catalogue.
    fn brute(idx: &PairIndex, v: &[Vector3<f64>], windows: &[AngleWindow; 3]) -> Vec<[u32; 3]> {
        let ok = |a: u32, b: u32, w: &AngleWindow| {
            let (lo, hi) = w.cosines();
            let d = v[a as usize].dot(&v[b as usize]);
            d >= lo && d <= hi
        };
        let mut out = Vec::new();
        for [p, q] in idx.pairs(idx.range_exact(&windows[0], v)) {
            for (a, b) in [(p, q), (q, p)] {
                for c in 0..v.len() as u32 {
                    if c != a && c != b && ok(a, c, &windows[1]) && ok(b, c, &windows[2]) {
                        out.push([a, b, c]);
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }

    #[test]
    fn finds_exactly_the_triangles_in_the_windows() {
        let cat = random_catalog(1000, 1.0, 6.0, 3).unwrap();
        let v = cat.vectors();
        let max_angle = 0.25;
        let idx = PairIndex::build(&cat, max_angle).unwrap();
        let tri = TriangleIndex::build(&idx, v, 0.18);
        assert!(tri.len() > 0 && tri.memory_bytes() > 0);
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let mut found = 0;
        for _ in 0..150 {
            // Windows around the sides of a real triangle of nearby stars (so most queries
            // find something), or anywhere.
            let a = rng.random_range(0..cat.len());
            let near: Vec<usize> = (0..cat.len())
                .filter(|&b| b != a && v[a].dot(&v[b]) > 0.17f64.cos())
                .collect();
            if near.len() < 2 {
                continue;
            }
            let (b, c) = (near[0], near[near.len() - 1]);
            let eps = rng.random_range(1e-5..3e-3);
            let t = |x: usize, y: usize| v[x].dot(&v[y]).clamp(-1.0, 1.0).acos();
            let windows = [t(a, b), t(a, c), t(b, c)].map(|s| AngleWindow::new(s - eps, s + eps));
            let mut got = Vec::new();
            if !tri.find(&windows, v, &mut got) {
                assert!(windows.iter().any(|w| w.bounds().1 > 0.18) || eps > 1e-3);
                continue;
            }
            got.sort_unstable();
            assert_eq!(got, brute(&idx, v, &windows));
            found += got.len();
        }
        assert!(found > 20, "{found}");
    }

    #[test]
    fn declines_windows_past_its_largest_side() {
        let cat = random_catalog(500, 1.0, 6.0, 4).unwrap();
        let idx = PairIndex::build(&cat, 0.3).unwrap();
        let tri = TriangleIndex::build(&idx, cat.vectors(), 0.2);
        let w = [
            AngleWindow::new(0.1, 0.11),
            AngleWindow::new(0.15, 0.16),
            AngleWindow::new(0.19, 0.21),
        ];
        let mut out = Vec::new();
        assert!(!tri.find(&w, cat.vectors(), &mut out) && out.is_empty());
    }
}
