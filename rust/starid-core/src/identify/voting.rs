//! Geometric voting (Kolomenkin, Pollak, Shimshoni & Lindenbaum 2008).
//!
//! Every pair of observed stars closer than the index's largest angle looks up the catalogue
//! pairs of the same separation (within the step's tolerance) through the k-vector, and each
//! catalogue pair votes for its two stars as the identities of the two observed stars (both
//! ways round; with a known zero point only the way the magnitudes allow). A real star collects
//! one vote from each real partner for its true identity, while chance votes spread over the
//! catalogue. The best-voted identity of each centroid becomes a candidate; triangles of
//! candidates whose catalogue separations agree with the observed ones are hypotheses, and each
//! passes the shared verification like any other method's.

use std::f64::consts::SQRT_2;

use super::{Search, SearchLimit, Status, Verified};
use crate::attitude::{triad, wahba_from};
use crate::kvector::AngleWindow;

/// Candidates (best-voted centroids) whose triangles become hypotheses.
const VOTE_CANDIDATES: usize = 24;

/// Fewest votes a candidate needs: two partners agreeing, as a triangle would.
const MIN_VOTES: u16 = 2;

impl Search<'_> {
    /// One voting pass over the brightest `stars` centroids at centroid noise `sigma_px`.
    pub(super) fn vote(
        &mut self,
        stars: usize,
        sigma_px: f64,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let f = self.camera.focal_length_px;
        let sigma_rad = sigma_px / f;
        let eps = 3.0 * SQRT_2 * sigma_rad + 1e-7;
        let r_confirm = 8.0 * sigma_rad + 2e-7;
        let n_cat = self.solver.catalog.len();
        // Dense counters, one row per voting centroid; rows shrink for very large catalogues.
        let s = stars
            .min(self.order.len())
            .min((16_000_000 / n_cat.max(1)).max(3));
        let search: Vec<usize> = self.order[..s].to_vec();
        let obs = self.obs[0];
        let idx = self.pairs;
        let cat = self.solver.catalog.vectors();
        let max_angle = idx.max_angle_rad() - eps;
        let mags = self.solver.mag_f32();
        let gate = self.gate;
        let fits = |star: u32, centroid: usize| -> bool {
            gate.is_none_or(|g| {
                let m = mags[star as usize];
                m >= g[centroid][0] && m <= g[centroid][1]
            })
        };
        let mut votes = std::mem::take(&mut self.scratch.votes);
        let mut touched = std::mem::take(&mut self.scratch.vote_touched);
        votes.clear();
        votes.resize(s * n_cat, 0);
        touched.clear();
        let mut add = |row: usize, star: u32, touched: &mut Vec<u32>| {
            let at = row * n_cat + star as usize;
            if votes[at] == 0 {
                touched.push(at as u32);
            }
            votes[at] = votes[at].saturating_add(1);
        };
        for a in 0..s {
            for b in a + 1..s {
                let (i, j) = (search[a], search[b]);
                let t = crate::geometry::angle_between(&obs[i], &obs[j]);
                if t > max_angle || t < 2.0 * eps {
                    continue;
                }
                let range = idx.range_exact(&AngleWindow::new(t - eps, t + eps), cat);
                self.pairs_visited += range.len();
                for [p, q] in idx.pairs(range) {
                    if fits(p, i) && fits(q, j) {
                        add(a, p, &mut touched);
                        add(b, q, &mut touched);
                    }
                    if fits(q, i) && fits(p, j) {
                        add(a, q, &mut touched);
                        add(b, p, &mut touched);
                    }
                }
            }
            if self.pairs_visited - self.gated_work >= self.config.max_pairs_visited {
                break;
            }
        }
        // Best identity of each centroid.
        let mut best = vec![(0u16, u32::MAX); s];
        for &at in &touched {
            let at = at as usize;
            let (row, star) = (at / n_cat, (at % n_cat) as u32);
            if votes[at] > best[row].0 {
                best[row] = (votes[at], star);
            }
        }
        self.scratch.votes = votes;
        self.scratch.vote_touched = touched;
        let mut cand: Vec<(usize, u32, u16)> = best
            .iter()
            .enumerate()
            .filter(|(_, b)| b.0 >= MIN_VOTES)
            .map(|(row, b)| (search[row], b.1, b.0))
            .collect();
        cand.sort_by_key(|c| std::cmp::Reverse(c.2));
        if !self.config.verify {
            // The vote's own answer: each centroid's best-voted star (a star voted best for two
            // centroids names neither), before any triangle or verification.
            let mut stars: Vec<u32> = cand.iter().map(|c| c.1).collect();
            stars.sort_unstable();
            let named: Vec<(usize, u32)> = cand
                .iter()
                .filter(|c| stars.iter().filter(|&&s| s == c.1).count() == 1)
                .map(|c| (c.0, c.1))
                .collect();
            if named.len() < 2 {
                return Ok(None);
            }
            self.hypotheses += 1;
            return Ok(Some(self.raw(&named)));
        }
        cand.truncate(VOTE_CANDIDATES);
        // Pairs of candidates whose catalogue separation agrees with the observed one.
        let cat = self.solver.catalog.vectors();
        let m = cand.len();
        let mut agree = vec![false; m * m];
        for x in 0..m {
            for y in x + 1..m {
                let (ox, oy) = (&obs[cand[x].0], &obs[cand[y].0]);
                let (cx, cy) = (&cat[cand[x].1 as usize], &cat[cand[y].1 as usize]);
                let ok = cand[x].1 != cand[y].1
                    && (crate::geometry::angle_between(ox, oy)
                        - crate::geometry::angle_between(cx, cy))
                    .abs()
                        <= eps;
                agree[x * m + y] = ok;
                agree[y * m + x] = ok;
            }
        }
        let mut best_v: Option<Verified> = None;
        for x in 0..m {
            for y in x + 1..m {
                if !agree[x * m + y] {
                    continue;
                }
                for z in y + 1..m {
                    if !(agree[x * m + z] && agree[y * m + z]) {
                        continue;
                    }
                    let (i, j, k) = (cand[x].0, cand[y].0, cand[z].0);
                    let (ca, cb, cc) = (cand[x].1, cand[y].1, cand[z].1);
                    let (va, vb, vc) = (&cat[ca as usize], &cat[cb as usize], &cat[cc as usize]);
                    let tp_obs = obs[i].dot(&obs[j].cross(&obs[k]));
                    let mirrored = (va.dot(&vb.cross(vc)) > 0.0) != (tp_obs > 0.0);
                    if mirrored && !self.config.allow_mirrored {
                        continue;
                    }
                    if self.hypotheses >= self.config.max_hypotheses {
                        return Err(SearchLimit(Status::SearchLimit));
                    }
                    self.hypotheses += 1;
                    let o = self.obs[usize::from(mirrored)];
                    let Some(r) = triad(&o[i], &o[j], va, vb).and_then(|start| {
                        wahba_from(&[o[i], o[j], o[k]], &[*va, *vb, *vc], &start)
                    }) else {
                        continue;
                    };
                    if let Some(v) = self.verify(r, mirrored, r_confirm, sigma_rad) {
                        if best_v.as_ref().is_none_or(|b| v.tail < b.tail) {
                            best_v = Some(v);
                        }
                        // The best-voted triangle that verifies: the assignment is settled.
                        return Ok(self.accept(best_v));
                    }
                }
            }
        }
        Ok(self.accept(best_v))
    }
}
