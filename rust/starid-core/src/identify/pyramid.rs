//! Pyramid (Mortari et al. 2004): triangles of observed stars in an order that varies all
//! three quickly, catalogue triangles through the k-vector, a fourth star to confirm.

use std::f64::consts::{PI, SQRT_2};

use super::magbins::MagPairIndex;
use super::stats::binomial_tail;
use super::{
    Search, SearchLimit, Status, Verified, CONFIRM_CHANCE, CONFIRM_POOL, LARGE_FRAME,
    MATCH_RADIUS_SIGMAS, STRONG_FALSE_MATCH_PROB, TRIANGLES_AFTER_WEAK,
};
use crate::attitude::{triad, wahba_steps};
use crate::kvector::{AngleWindow, Pairs};

/// Gauss–Newton steps from TRIAD that fit a triangle hypothesis's attitude to its three stars
/// before confirmation (see [`wahba_steps`]).
const TRIANGLE_FIT_STEPS: usize = 1;

impl Search<'_> {
    /// One pass: Pyramid search over the brightest `stars` centroids in `self.pairs` at
    /// centroid noise `sigma_px`, at most `cap` triangles.
    pub(super) fn run(
        &mut self,
        stars: usize,
        sigma_px: f64,
        cap: usize,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let mut angle = std::mem::take(&mut self.scratch.angles);
        let mut known = std::mem::take(&mut self.scratch.angle_known);
        // The step's side ranges: its index and tolerance are fixed, so each pair's is found once.
        let n = self.stride * self.stride;
        let ranges = &mut self.scratch.side_ranges;
        if ranges.0.len() < n {
            ranges.0.resize(n, [0; 2]);
        }
        ranges.1.clear();
        ranges.1.resize(n.div_ceil(64), 0);
        let result = self.run_step(stars, sigma_px, cap, (&mut angle, &mut known));
        self.scratch.angles = angle;
        self.scratch.angle_known = known;
        result
    }

    pub(super) fn run_step(
        &mut self,
        stars: usize,
        sigma_px: f64,
        cap: usize,
        (angle, known): (&mut [[f64; 3]], &mut [u64]),
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let f = self.camera.focal_length_px;
        let sigma_rad = sigma_px / f;
        let eps = 3.0 * SQRT_2 * sigma_rad + 1e-7;
        let eps_trig = [eps.cos(), eps.sin()];
        let r_confirm = 8.0 * sigma_rad + 2e-7;
        // Fourth stars needed to confirm a triangle: enough that chance alone (a centroid landing
        // within r_confirm of some star, at twice the mean sky density) is unlikely to supply them.
        let cat_len = self.solver.catalog.len() as f64;
        let p_chance = (2.0 * cat_len / (4.0 * PI) * PI * r_confirm * r_confirm).min(1.0);
        let others = self.order.len().min(CONFIRM_POOL) - 3;
        let confirmations = self.scratch.tails.get_or(0, others, p_chance, || {
            (1..=others)
                .find(|&c| binomial_tail(others, c, p_chance) <= CONFIRM_CHANCE)
                .unwrap_or(others)
                .max(1) as f64
        }) as usize;
        // What the frame can still prove: even if every centroid matched, the bound of a solution
        // at this step, with the sparsest field's density and the smallest match radius, must
        // stay under the limit; past this many hypotheses it cannot, and the pass ends.
        let n = self.order.len();
        let frac = if self.gate.is_some() {
            self.gate_fraction
        } else {
            1.0
        };
        let r_min = MATCH_RADIUS_SIGMAS * sigma_rad;
        let p_min = (self.solver.min_density_sr() * PI * r_min * r_min * frac).min(1.0);
        let best_tail = self
            .scratch
            .tails
            .get_or(1, n - 3, p_min, || binomial_tail(n - 3, n - 3, p_min));
        let provable_until = self.config.max_false_match_prob / best_tail.max(f64::MIN_POSITIVE);
        let max_angle = self.pairs.max_angle_rad() - eps;
        let stride = self.stride;
        let s = stars.min(stride);
        // What the frame can still prove, as the hypotheses add up: see `RuleOut`.
        // Made once the pass has tried a few triangles (most frames end at their first).
        let mut rule_out: Option<RuleOut> = None;
        let ungated = self.gate.is_none();
        let obs = self.obs[0];
        let order: &[usize] = self.order;
        let search = &order[..s];
        // Angles (with their cosine and sine, for the index's windows) are computed when a
        // triangle first needs them (most frames stop after a few triangles, long before all s²
        // pairs are visited).
        let mut pair_angle = |a: usize, b: usize| -> [f64; 3] {
            let (ab, ba) = (a * stride + b, b * stride + a);
            if known[ab / 64] & (1 << (ab % 64)) != 0 {
                return angle[ab];
            }
            let (u, v) = (&obs[search[a]], &obs[search[b]]);
            let (sin, cos) = (u.cross(v).norm(), u.dot(v));
            // Both near 1 in size (unit vectors): no overflow or underflow for libm's `hypot` to
            // guard against, so the plain square root, at a tenth of its instructions.
            let norm = (sin * sin + cos * cos).sqrt();
            let t = [sin.atan2(cos), cos / norm, sin / norm];
            angle[ab] = t;
            angle[ba] = t;
            known[ab / 64] |= 1 << (ab % 64);
            known[ba / 64] |= 1 << (ba % 64);
            t
        };
        let mut tried = 0usize;
        let mut best: Option<Verified> = None;
        let mut stop_after = usize::MAX;
        // Mortari's Pyramid order: vary all three stars quickly so a false star cannot block.
        for dj in 1..s.saturating_sub(1) {
            for dk in 1..s - dj {
                for a in 0..s - dj - dk {
                    let (b, c) = (a + dj, a + dj + dk);
                    let sides = [pair_angle(a, b), pair_angle(a, c), pair_angle(b, c)];
                    let (t_ij, t_ik, t_jk) = (sides[0][0], sides[1][0], sides[2][0]);
                    let (lo, hi) = (t_ij.min(t_ik).min(t_jk), t_ij.max(t_ik).max(t_jk));
                    if hi > max_angle || lo < 2.0 * eps {
                        continue;
                    }
                    let (i, j, k) = (search[a], search[b], search[c]);
                    let tp_obs = obs[i].dot(&obs[j].cross(&obs[k]));
                    // The handedness must survive the noise, or the triangle cannot tell a mirrored frame.
                    if tp_obs.abs() < 3.0 * sigma_rad * (t_ij + t_ik + t_jk) {
                        continue;
                    }
                    if tried >= cap.min(stop_after) {
                        return Ok(self.accept(best));
                    }
                    if self.hypotheses as f64 > provable_until {
                        return Ok(self.accept(best));
                    }
                    if ungated && tried >= RULE_OUT_FROM_TRIANGLES {
                        let hypotheses = self.hypotheses;
                        let r = rule_out.get_or_insert_with(|| RuleOut::new(self, n, s, p_min));
                        if tried >= r.triangles_after(hypotheses) {
                            return Ok(self.accept(best));
                        }
                    }
                    if self.pairs_visited >= self.pass_pairs_limit {
                        // This pass's own budget is spent; the search goes on with the next.
                        return Ok(self.accept(best));
                    }
                    if let Some(why) = self.spent() {
                        return self
                            .accept(best)
                            .map_or(Err(SearchLimit(why)), |v| Ok(Some(v)));
                    }
                    tried += 1;
                    self.tri_pos = [a, b, c];
                    let windows =
                        sides.map(|t| AngleWindow::around(t[0], [t[1], t[2]], eps, eps_trig));
                    // The longest side: 0 = i–j, 1 = i–k, 2 = j–k.
                    let long_side = if t_ij >= t_ik && t_ij >= t_jk {
                        0
                    } else if t_ik >= t_jk {
                        1
                    } else {
                        2
                    };
                    let found = match self.try_triangle(
                        [i, j, k],
                        windows,
                        (tp_obs, long_side),
                        (r_confirm, confirmations),
                        sigma_rad,
                    ) {
                        Ok(found) => found,
                        Err(limit) => return self.accept(best).map_or(Err(limit), |v| Ok(Some(v))),
                    };
                    if let Some(v) = found {
                        if !v.verified {
                            // A raw answer (verify off): the first confirmed pyramid.
                            return Ok(Some(v));
                        }
                        if v.tail * (self.hypotheses as f64) <= STRONG_FALSE_MATCH_PROB {
                            return Ok(self.accept(Some(v)));
                        }
                        // A weak solution: look a little further for a stronger one.
                        stop_after = stop_after.min(tried + TRIANGLES_AFTER_WEAK);
                        if best.as_ref().is_none_or(|b| v.tail < b.tail) {
                            best = Some(v);
                        }
                    }
                }
            }
        }
        Ok(self.accept(best))
    }

    /// Whether the search must end: its work budget (`max_pairs_visited`, gated passes'
    /// work aside) is spent, or its time is up.
    pub(super) fn spent(&self) -> Option<Status> {
        if self.pairs_visited - self.gated_work >= self.config.max_pairs_visited {
            Some(Status::SearchLimit)
        } else if self.out_of_time() {
            Some(Status::Timeout)
        } else {
            None
        }
    }

    /// The solution, if its bound over every hypothesis tested so far passes.
    pub(super) fn accept(&self, v: Option<Verified>) -> Option<Verified> {
        let mut v = v?;
        if !v.verified {
            return Some(v);
        }
        v.false_prob = (self.hypotheses.max(1) as f64 * v.tail).min(1.0);
        (v.false_prob <= self.config.max_false_match_prob).then_some(v)
    }

    /// Every catalogue triangle whose sides fall in `windows` (the observed sides ± the
    /// tolerance: i–j, i–k, j–k), tried as a hypothesis for centroids `i, j, k`.
    pub(super) fn try_triangle(
        &mut self,
        [i, j, k]: [usize; 3],
        windows: [AngleWindow; 3],
        (tp_obs, long_side): (f64, usize),
        (r_confirm, confirmations): (f64, usize),
        sigma_rad: f64,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let mut triangles = std::mem::take(&mut self.scratch.triangles);
        match self.gen_gate.or(self.gate).map(|g| [g[i], g[j], g[k]]) {
            Some(mags) => {
                let mag_index = self.solver.mag_pair_index();
                self.catalogue_triangles_gated(mag_index, windows, mags, &mut triangles);
            }
            None => self.catalogue_triangles(windows, &mut triangles),
        }
        let cat = self.solver.catalog.vectors();
        let mut result = Ok(None);
        for &[ca, cb, cc] in &triangles {
            let (va, vb, vc) = (&cat[ca as usize], &cat[cb as usize], &cat[cc as usize]);
            let mirrored = (va.dot(&vb.cross(vc)) > 0.0) != (tp_obs > 0.0);
            if mirrored && !self.config.allow_mirrored {
                continue;
            }
            if self.hypotheses >= self.config.max_hypotheses
                || self.pairs_visited - self.gated_work >= self.config.max_pairs_visited
            {
                result = Err(SearchLimit(Status::SearchLimit));
                break;
            }
            if self.pairs_visited >= self.pass_pairs_limit {
                // The pass's own budget: the next triangle ends it.
                break;
            }
            if (self.hypotheses % 64 == 0 || self.obs[0].len() > LARGE_FRAME) && self.out_of_time()
            {
                result = Err(SearchLimit(Status::Timeout));
                break;
            }
            self.hypotheses += 1;
            let obs = self.obs[usize::from(mirrored)];
            // TRIAD along the longest side (its direction the least disturbed by the noise), then
            // one Gauss–Newton step over the three stars.
            let ((p, vp), (q, vq)) = match long_side {
                0 => ((i, va), (j, vb)),
                1 => ((i, va), (k, vc)),
                _ => ((j, vb), (k, vc)),
            };
            let Some(r) = triad(&obs[p], &obs[q], vp, vq).and_then(|start| {
                wahba_steps(
                    &[obs[i], obs[j], obs[k]],
                    &[*va, *vb, *vc],
                    &start,
                    TRIANGLE_FIT_STEPS,
                )
            }) else {
                continue;
            };
            if !self.confirmed(
                &r,
                obs,
                [i, j, k],
                [ca, cb, cc],
                (r_confirm, confirmations),
                sigma_rad,
            ) {
                continue;
            }
            if !self.config.verify {
                // The Pyramid's own answer: the confirmed pyramid's attitude names every
                // centroid near a catalogue star, with no refit and no bound.
                self.match_all(&r, obs, r_confirm, sigma_rad);
                let named: Vec<(usize, u32)> = (self.scratch.matches.iter().enumerate())
                    .filter_map(|(o, m)| m.map(|(s, _)| (o, s)))
                    .collect();
                result = Ok(Some(self.raw(&named)));
                break;
            }
            if let Some(v) = self.verify(r, mirrored, r_confirm, sigma_rad) {
                result = Ok(Some(v));
                break;
            }
        }
        self.scratch.triangles = triangles;
        result
    }

    /// Catalogue triangles `(a, b, c)` with `|a b|`, `|a c|` and `|b c|` in `windows`.
    pub(super) fn catalogue_triangles(
        &mut self,
        windows: [AngleWindow; 3],
        out: &mut Vec<[u32; 3]>,
    ) {
        out.clear();
        let idx = self.pairs;
        let cat = self.solver.catalog.vectors();
        // Each side's range, from the step's cache when a triangle before this one had the side
        // (its centroid pair at search positions `tri_pos`).
        let [a, b, c] = self.tri_pos;
        let stride = self.stride;
        let (store, known) = &mut self.scratch.side_ranges;
        let [r_ij, r_ik, r_jk] = [(a, b, 0), (a, c, 1), (b, c, 2)].map(|(p, q, e)| {
            let key = p * stride + q;
            let (word, bit) = (key / 64, 1u64 << (key % 64));
            if known[word] & bit == 0 {
                let r = idx.range_exact(&windows[e], cat);
                store[key] = [r.start as u32, r.end as u32];
                known[word] |= bit;
            }
            let [lo, hi] = store[key];
            lo as usize..hi as usize
        });
        // The work counted as if each triangle had read its sides afresh: the budget is unchanged.
        self.pairs_visited += r_ij.len() + r_ik.len() + r_jk.len();
        if r_ij.is_empty() || r_ik.is_empty() || r_jk.is_empty() {
            return;
        }
        // Walk the sparser of the two sides at one vertex, look the other up through an adjacency
        // list, and check the third side with one dot product against its cosine bounds: one
        // adjacency fill per triangle instead of two, and no list walk for the closing side.
        let n_cat = self.solver.catalog.len();
        // Sides as (range, vertex pair) with vertices 0 = i, 1 = j, 2 = k.
        let sides = [(r_ij, (0usize, 1usize)), (r_ik, (0, 2)), (r_jk, (1, 2))];
        let closing = (0..3)
            .max_by_key(|&e| sides[e].0.len())
            .expect("three sides");
        let (mut walk, mut look) = match closing {
            0 => (sides[1].clone(), sides[2].clone()),
            1 => (sides[0].clone(), sides[2].clone()),
            _ => (sides[0].clone(), sides[1].clone()),
        };
        if walk.0.len() > look.0.len() {
            std::mem::swap(&mut walk, &mut look);
        }
        // The shared vertex of the walked and looked-up sides, and their other ends.
        let (w0, w1) = walk.1;
        let (l0, l1) = look.1;
        let shared = if w0 == l0 || w0 == l1 { w0 } else { w1 };
        let walk_other = if w0 == shared { w1 } else { w0 };
        let look_other = if l0 == shared { l1 } else { l0 };
        let (cos_lo, cos_hi) = windows[closing].cosines();
        // Lists are needed only at the walked pairs' stars.
        self.scratch.adj_ik.fill_ranges(
            idx.pairs(look.0.clone()),
            idx.pairs(walk.0.clone()),
            n_cat,
        );
        let adj = &self.scratch.adj_ik;
        let geometry = (cat, [cos_lo, cos_hi], [shared, walk_other, look_other]);
        // A byte-marked fill answers from its marks (see `Adjacency::bytes_live`); the walked
        // stars are 16-bit there.
        match adj.live_marks() {
            Some(marks) => walk_pairs(
                idx.pairs(walk.0.clone()),
                adj,
                |x| marks.has_list(x as u16),
                geometry,
                out,
            ),
            None => walk_pairs(
                idx.pairs(walk.0.clone()),
                adj,
                |x| adj.has_partners(x),
                geometry,
                out,
            ),
        }
        self.scratch.adj_ik.clear_marks(idx.pairs(walk.0));
    }
}

/// The walk of [`Search::catalogue_triangles`]: each walked pair `[p, q]`, both ways round as
/// `(x, y)`, meets the partners `z` of `x` in `adj` (the looked-up side); `(x, y, z)` is a
/// triangle when `y·z` lies in the closing side's cosines. `has_partners(x)`: whether `x` holds
/// a list (most walked stars do not).
#[inline(always)]
fn walk_pairs(
    pairs: Pairs<'_>,
    adj: &Adjacency,
    has_partners: impl Fn(u32) -> bool,
    geometry: Geometry<'_>,
    out: &mut Vec<[u32; 3]>,
) {
    for [p, q] in pairs {
        for (x, y) in [(p, q), (q, p)] {
            if has_partners(x) {
                close_at(adj, x, y, geometry, out);
            }
        }
    }
}

/// A join's catalogue vectors, closing side's cosines `[lo, hi]` and vertices `[shared, walk
/// other, look other]`.
type Geometry<'a> = (&'a [nalgebra::Vector3<f64>], [f64; 2], [usize; 3]);

/// The triangles `(x, y, z)` of a walked pair `(x, y)`: `z` among the partners of `x` in `adj`,
/// `y·z` within the closing side's cosines; each written with `x` at vertex `shared`, `y` at
/// `walk_other` and `z` at `look_other`.
#[inline(always)]
fn close_at(
    adj: &Adjacency,
    x: u32,
    y: u32,
    (cat, [cos_lo, cos_hi], [shared, walk_other, look_other]): Geometry<'_>,
    out: &mut Vec<[u32; 3]>,
) {
    let vy = &cat[y as usize];
    for z in adj.partners(x) {
        let c = vy.dot(&cat[z as usize]);
        if c <= cos_hi && c >= cos_lo && z != y {
            let mut t = [0u32; 3];
            t[shared] = x;
            t[walk_other] = y;
            t[look_other] = z;
            out.push(t);
        }
    }
}

impl Search<'_> {
    /// The magnitude-consistent catalogue pairs of the centroids at search positions `pa < pb`
    /// (windows `wa`, `wb`, separation `t`): `[star of pa, star of pb]`, read from the
    /// magnitude-split index once per pass and kept. Returns the entries' range in the cache.
    fn side_candidates(
        &mut self,
        mag_index: &MagPairIndex,
        (pa, pb): (usize, usize),
        (wa, wb): ([f32; 2], [f32; 2]),
        window: &AngleWindow,
    ) -> std::ops::Range<usize> {
        let key = pa * self.stride + pb;
        let cache = &mut self.scratch.side_cache;
        let (start, len) = cache.index[key];
        if start != u32::MAX {
            return start as usize..(start + len) as usize;
        }
        let mags = self.solver.mag_f32();
        let fits = |s: u32, w: [f32; 2]| {
            let m = mags[s as usize];
            m >= w[0] && m <= w[1]
        };
        let start = cache.entries.len();
        let mut scanned = 0usize;
        let cat = self.solver.catalog.vectors();
        mag_index.for_each_sub(mag_index.bins(wa), mag_index.bins(wb), |_, sub| {
            let r = sub.range_exact(window, cat);
            scanned += r.len();
            for [p, q] in sub.pairs(r) {
                if fits(p, wa) && fits(q, wb) {
                    cache.entries.push([p, q]);
                }
                if fits(q, wa) && fits(p, wb) {
                    cache.entries.push([q, p]);
                }
            }
        });
        self.pairs_visited += scanned;
        let len = cache.entries.len() - start;
        cache.index[key] = (start as u32, len as u32);
        start..start + len
    }

    /// Catalogue triangles as [`Search::catalogue_triangles`], from the magnitude-consistent
    /// candidates of each side (vertex `v`'s window `windows[v]`; see `side_candidates`).
    pub(super) fn catalogue_triangles_gated(
        &mut self,
        mag_index: &MagPairIndex,
        sides: [AngleWindow; 3],
        windows: [[f32; 2]; 3],
        out: &mut Vec<[u32; 3]>,
    ) {
        out.clear();
        // Sides as (vertex pair) with vertices 0 = i, 1 = j, 2 = k.
        let verts = [(0usize, 1usize), (0, 2), (1, 2)];
        let pos = self.tri_pos;
        let mut ranges: [std::ops::Range<usize>; 3] = Default::default();
        // Whether a side's entries are stored [second vertex, first vertex].
        let mut flipped = [false; 3];
        for e in 0..3 {
            let (a, b) = verts[e];
            let (lo, hi) = if pos[a] < pos[b] { (a, b) } else { (b, a) };
            flipped[e] = lo != a;
            ranges[e] = self.side_candidates(
                mag_index,
                (pos[lo], pos[hi]),
                (windows[lo], windows[hi]),
                &sides[e],
            );
            if ranges[e].is_empty() {
                return;
            }
        }
        let lens = ranges.clone().map(|r| r.len());
        self.pairs_visited += lens.iter().sum::<usize>();
        let n_cat = self.solver.catalog.len();
        let cat = self.solver.catalog.vectors();
        let closing = (0..3).max_by_key(|&e| lens[e]).expect("three sides");
        let (mut walk, mut look) = match closing {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        if lens[walk] > lens[look] {
            std::mem::swap(&mut walk, &mut look);
        }
        let (w0, w1) = verts[walk];
        let (l0, l1) = verts[look];
        let shared = if w0 == l0 || w0 == l1 { w0 } else { w1 };
        let walk_other = if w0 == shared { w1 } else { w0 };
        let look_other = if l0 == shared { l1 } else { l0 };
        let (cos_lo, cos_hi) = sides[closing].cosines();
        let entries = &self.scratch.side_cache.entries;
        // Entry of a side as (star of its first vertex, star of its second vertex).
        let oriented = |e: usize, p: [u32; 2]| {
            if flipped[e] {
                (p[1], p[0])
            } else {
                (p[0], p[1])
            }
        };
        let adj = &mut self.scratch.adj_ik;
        // Lists are needed only at the walked side's shared vertex.
        adj.start(n_cat);
        for &p in &entries[ranges[walk].clone()] {
            let (u, v) = oriented(walk, p);
            adj.want(if w0 == shared { u } else { v });
        }
        for &p in &entries[ranges[look].clone()] {
            let (u, v) = oriented(look, p);
            let (at_shared, at_other) = if l0 == shared { (u, v) } else { (v, u) };
            adj.push_wanted(at_shared, at_other);
        }
        let geometry = (cat, [cos_lo, cos_hi], [shared, walk_other, look_other]);
        for &p in &entries[ranges[walk].clone()] {
            let (u, v) = oriented(walk, p);
            let (x, y) = if w0 == shared { (u, v) } else { (v, u) };
            close_at(adj, x, y, geometry, out);
        }
    }
}

/// Triangles a pass tries before [`RuleOut`] is consulted.
const RULE_OUT_FROM_TRIANGLES: usize = 4;

/// Chance, for a frame that holds enough real stars to pass the bound, that a pass has tried
/// that many triangles without meeting one of them (see [`RuleOut`]).
pub const RULE_OUT_CHANCE: f64 = 1e-3;

/// When an ungated Pyramid pass gives up (early and cheaply). Every
/// hypothesis tried raises the number of matches `m` a solution needs to pass the false-match
/// bound (with the sparsest fields' density and the step's smallest match radius, so never more
/// than a real solution needs). A frame with that many matches has at least `m − 1` real stars
/// (one match may be a coincidence, or one real star missed), at least `m − 1 − (n − s)` of them
/// among the `s` spots searched. Had it so many, a share `C(r, 3) / C(s, 3)` of the triangles
/// would be all real, and the pass, which varies all three spots quickly, would have met one
/// within `ln(RULE_OUT_CHANCE) / ln(1 − share)` triangles. Past that many, the frame cannot hold
/// a solution the bound would still accept, and the pass ends. On the simulated scenarios and
/// families it changed no identification, and the frames of seven spots that a 1 px noise
/// leaves unidentifiable (S3) end in about two thirds of the time.
struct RuleOut {
    /// Matches a solution needs now, and the hypothesis count past which it needs one more.
    needed: usize,
    next_at: f64,
    /// Triangles after which the pass ends (for `needed`).
    after: usize,
    n: usize,
    s: usize,
    p: f64,
    limit: f64,
}

impl RuleOut {
    fn new(search: &Search<'_>, n: usize, s: usize, p_min: f64) -> Self {
        let mut r = Self {
            needed: search.config.min_matches.max(4),
            next_at: 0.0,
            after: usize::MAX,
            n,
            s,
            p: p_min,
            limit: search.config.max_false_match_prob,
        };
        r.update(search.hypotheses);
        r
    }

    /// Hypotheses a solution of `m` matches can follow and still pass the bound.
    fn hypotheses_allowed(&self, m: usize) -> f64 {
        if m > self.n {
            return f64::INFINITY;
        }
        self.limit / binomial_tail(self.n - 3, m - 3, self.p).max(f64::MIN_POSITIVE)
    }

    fn update(&mut self, hypotheses: usize) {
        let h = hypotheses as f64;
        while self.needed <= self.n && h > self.hypotheses_allowed(self.needed) {
            self.needed += 1;
        }
        self.next_at = self.hypotheses_allowed(self.needed);
        // One match may be a coincidence (or a real star the solution misses).
        let real = (self.needed - 1).saturating_sub(self.n - self.s);
        self.after = if real < 3 {
            usize::MAX
        } else {
            let c3 = |k: usize| (k * (k - 1) * (k - 2)) as f64 / 6.0;
            let share = (c3(real) / c3(self.s)).min(1.0);
            if share >= 1.0 {
                1
            } else {
                (RULE_OUT_CHANCE.ln() / (1.0 - share).ln()).ceil() as usize
            }
        };
    }

    /// Triangles after which the pass ends, `hypotheses` tried so far.
    fn triangles_after(&mut self, hypotheses: usize) -> usize {
        if hypotheses as f64 > self.next_at {
            self.update(hypotheses);
        }
        self.after
    }
}

const NONE: u32 = u32::MAX;

/// Slots of a [`TailMemo`].
const TAIL_MEMO_SLOTS: usize = 512;

/// The last values of a few functions of `(count, probability)` that every pass computes again
/// with the same arguments (the confirmations a step needs, the best tail a frame can reach),
/// remembered per thread: a binomial tail costs about as much as a triangle's join. A slot
/// holds one argument pair; a different one replaces it, so the values are exactly those computed.
pub(super) struct TailMemo {
    slots: Vec<(u64, usize, f64)>,
}

impl Default for TailMemo {
    fn default() -> Self {
        Self {
            slots: vec![(u64::MAX, usize::MAX, 0.0); TAIL_MEMO_SLOTS],
        }
    }
}

impl TailMemo {
    /// `compute()`, the value of function `which` at `(count, p)`, remembered.
    pub(super) fn get_or(
        &mut self,
        which: u64,
        count: usize,
        p: f64,
        compute: impl FnOnce() -> f64,
    ) -> f64 {
        // `which` in the top bit (a probability's bits never set it: p ≥ 0).
        let key = p.to_bits() | (which << 63);
        let h = (key ^ (key >> 29) ^ (count as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let slot = &mut self.slots[(h >> 55) as usize % TAIL_MEMO_SLOTS];
        if slot.0 != key || slot.1 != count {
            *slot = (key, count, compute());
        }
        slot.2
    }
}

/// Stars a 16-bit pair index can name.
const NARROW_STARS: usize = 1 << 16;

/// Largest catalogue whose per-star marks are bytes (16 kB, half the first-level cache); a
/// larger one marks in bits, whose shifts cost instructions but whose kilobytes stay in the
/// cache where 41 kB of bytes (a catalogue to magnitude 8) would not. In callgrind's cache
/// simulation (32 kB first level, 512 kB second), marks alone (before the walk read them),
/// against 32-bit marks: S1 (8 000 stars, 1 000
/// frames) with bytes 1.07 → 0.73 million first-level misses, instructions 35.8 → 35.6
/// million (bits: 0.58 million misses, 37.9 million instructions); K2 (41 000 stars, 300
/// scenes) with bits 10.2 → 5.9 million first-level and 2.4 → 1.8 million second-level
/// misses for 148 → 176 million instructions (bytes: 8.2 and 2.0 million misses, 152 million
/// instructions).
const BYTE_MARKS_MAX_STARS: usize = 16_384;

/// Adjacency lists of a set of catalogue pairs (both orientations) as linked lists indexed by
/// catalogue star: O(1) to look up, O(pairs) to fill and to reset, no sorting.
#[derive(Default)]
pub(super) struct Adjacency {
    head: Vec<u32>,
    next: Vec<u32>,
    partner: Vec<u32>,
    touched: Vec<u32>,
    /// Per catalogue star: the fill that last wanted its list (see `fill_for`).
    wanted: Vec<u32>,
    fills: u32,
    /// A narrow fill's marks of the 16-bit stars it wants, in bytes or bits (see
    /// [`BYTE_MARKS_MAX_STARS`]).
    narrow_bytes: Option<Box<ByteMarks>>,
    narrow_bits: Option<Box<BitMarks>>,
    /// Whether the last fill left its byte marks set, with 2 at the wanted stars that got a
    /// list. The walk asks them which stars hold a list instead of `head` (the walked stars'
    /// marks are in the cache from the fill; `head`'s 32 kB for the bundled catalogue were not:
    /// 100 misses per S1 frame in callgrind's simulation), then clears them with the same pairs
    /// ([`Adjacency::clear_marks`]). (Bit marks keeping a second bit for the lists cost K2 12 %
    /// more instructions for 17 % fewer first-level misses: they are cleared by the fill.)
    bytes_live: bool,
}

/// Per 16-bit star, one byte: 1 wanted, 2 wanted and listed, else 0.
pub(super) struct ByteMarks([u8; NARROW_STARS]);

impl ByteMarks {
    /// Whether `s` is wanted and has a list.
    #[inline]
    pub(super) fn has_list(&self, s: u16) -> bool {
        self.0[usize::from(s)] == 2
    }
}

/// Per 16-bit star, a bit: wanted.
pub(super) struct BitMarks([u64; NARROW_STARS / 64]);

/// The marks of a narrow fill: bytes or bits (see [`BYTE_MARKS_MAX_STARS`]).
trait Marks {
    /// `s` is wanted.
    fn set(&mut self, s: u16);
    /// `s`, wanted, has a list now.
    fn listed(&mut self, s: u16);
    /// Whether `s` is wanted.
    fn get(&self, s: u16) -> bool;
    /// Clear `s` and whatever shares its storage (all of it wanted).
    fn clear(&mut self, s: u16);
}

impl Marks for ByteMarks {
    #[inline]
    fn set(&mut self, s: u16) {
        self.0[usize::from(s)] = 1;
    }
    #[inline]
    fn listed(&mut self, s: u16) {
        self.0[usize::from(s)] = 2;
    }
    #[inline]
    fn get(&self, s: u16) -> bool {
        self.0[usize::from(s)] != 0
    }
    #[inline]
    fn clear(&mut self, s: u16) {
        self.0[usize::from(s)] = 0;
    }
}

impl Marks for BitMarks {
    #[inline]
    fn set(&mut self, s: u16) {
        self.0[usize::from(s >> 6)] |= 1 << (s & 63);
    }
    #[inline]
    fn listed(&mut self, _: u16) {}
    #[inline]
    fn get(&self, s: u16) -> bool {
        (self.0[usize::from(s >> 6)] >> (s & 63)) & 1 != 0
    }
    #[inline]
    fn clear(&mut self, s: u16) {
        self.0[usize::from(s >> 6)] = 0;
    }
}

impl Adjacency {
    /// Empty the lists, sized for a catalogue of `n_cat` stars.
    pub(super) fn reset(&mut self, n_cat: usize) {
        for &s in &self.touched {
            self.head[s as usize] = NONE;
        }
        // Marks no walk cleared: all of them (never on the search's path).
        if self.bytes_live {
            if let Some(m) = self.narrow_bytes.as_mut() {
                m.0.fill(0);
            }
            self.bytes_live = false;
        }
        if self.head.len() != n_cat {
            self.head.clear();
            self.head.resize(n_cat, NONE);
        }
        self.touched.clear();
        self.next.clear();
        self.partner.clear();
    }

    /// Empty the lists for a new fill that keeps only the lists of stars [`Adjacency::want`]ed:
    /// `partners` may be asked only about those (it answers nothing for the others). The lists
    /// held are those a fill of every star would hold, in the same order; the pairs of stars no
    /// one asks about (most of them) are passed over with a look-up and no push.
    pub(super) fn start(&mut self, n_cat: usize) {
        self.reset(n_cat);
        if self.wanted.len() != n_cat || self.fills == u32::MAX {
            self.wanted.clear();
            self.wanted.resize(n_cat, 0);
            self.fills = 0;
        }
        self.fills += 1;
    }

    /// Keep the list of `star` in this fill.
    #[inline]
    pub(super) fn want(&mut self, star: u32) {
        self.wanted[star as usize] = self.fills;
    }

    /// `partner` onto the list of `star`, if that list is kept.
    #[inline]
    pub(super) fn push_wanted(&mut self, star: u32, partner: u32) {
        if self.wanted[star as usize] == self.fills {
            self.push(star, partner);
        }
    }

    /// [`Adjacency::fill_for`] of an index's ranges: a narrow index's (16-bit stars) read as
    /// slices, without a bounds check per pair.
    pub(super) fn fill_ranges(&mut self, pairs: Pairs<'_>, wanted: Pairs<'_>, n_cat: usize) {
        match (pairs, wanted) {
            (Pairs::Narrow(p), Pairs::Narrow(w)) => {
                self.fill_narrow(p.as_slice(), w.as_slice(), n_cat)
            }
            (p, w) => self.fill_for(p, w, n_cat),
        }
    }

    /// [`Adjacency::fill_for`] of 16-bit pairs. The stars wanted are marked in bytes or bits
    /// (see [`BYTE_MARKS_MAX_STARS`]), not by the 32-bit fill numbers of `fill_for`: a pair's
    /// two look-ups are random reads over the catalogue, and over 32 kB of marks (the bundled
    /// catalogue's) they missed the cache about once per pair (callgrind's cache simulation:
    /// 290 misses per S1 frame, a third of all).
    #[inline(never)]
    fn fill_narrow(&mut self, pairs: &[[u16; 2]], wanted: &[[u16; 2]], n_cat: usize) {
        self.start(n_cat);
        if n_cat > BYTE_MARKS_MAX_STARS {
            let mut marks = self
                .narrow_bits
                .take()
                .unwrap_or_else(|| Box::new(BitMarks([0; NARROW_STARS / 64])));
            self.fill_narrow_with(&mut *marks, pairs, wanted);
            // Bit marks are not kept for the walk (see `bytes_live`).
            for &[p, q] in wanted {
                marks.clear(p);
                marks.clear(q);
            }
            self.narrow_bits = Some(marks);
        } else {
            let mut marks = self
                .narrow_bytes
                .take()
                .unwrap_or_else(|| Box::new(ByteMarks([0; NARROW_STARS])));
            self.fill_narrow_with(&mut *marks, pairs, wanted);
            self.narrow_bytes = Some(marks);
            self.bytes_live = true;
        }
    }

    /// `fill_narrow` with its marks.
    #[inline(always)]
    fn fill_narrow_with<M: Marks>(
        &mut self,
        marks: &mut M,
        pairs: &[[u16; 2]],
        wanted: &[[u16; 2]],
    ) {
        let Self {
            head,
            next,
            partner,
            touched,
            ..
        } = self;
        for &[p, q] in wanted {
            marks.set(p);
            marks.set(q);
        }
        // `Adjacency::push`, on the fields borrowed apart from the marks. (Through one function
        // shared with `push`, the S1 search ran 0.4 % more instructions: callgrind.)
        let mut push = |marks: &mut M, star: u16, other: u16| {
            let h = &mut head[usize::from(star)];
            if *h == NONE {
                touched.push(u32::from(star));
                marks.listed(star);
            }
            next.push(*h);
            partner.push(u32::from(other));
            *h = (partner.len() - 1) as u32;
        };
        for &[p, q] in pairs {
            let (wp, wq) = (marks.get(p), marks.get(q));
            if wp {
                push(marks, p, q);
            }
            if wq {
                push(marks, q, p);
            }
        }
    }

    /// The lists of `pairs` (both orientations) at the stars of the pairs `wanted`.
    // Out of line: inlined into the search loop it ran about 1 % more instructions (callgrind).
    #[inline(never)]
    pub(super) fn fill_for(
        &mut self,
        pairs: impl Iterator<Item = [u32; 2]>,
        wanted: impl Iterator<Item = [u32; 2]>,
        n_cat: usize,
    ) {
        self.start(n_cat);
        let fill = self.fills;
        for [p, q] in wanted {
            self.wanted[p as usize] = fill;
            self.wanted[q as usize] = fill;
        }
        for [p, q] in pairs {
            if self.wanted[p as usize] == fill {
                self.push(p, q);
            }
            if self.wanted[q as usize] == fill {
                self.push(q, p);
            }
        }
    }

    #[inline]
    pub(super) fn push(&mut self, star: u32, partner: u32) {
        let h = &mut self.head[star as usize];
        if *h == NONE {
            self.touched.push(star);
        }
        self.next.push(*h);
        self.partner.push(partner);
        *h = (self.partner.len() - 1) as u32;
    }

    /// Whether the list of `star` holds any partner.
    #[inline]
    pub(super) fn has_partners(&self, star: u32) -> bool {
        self.head[star as usize] != NONE
    }

    /// The byte marks the last fill left set, if it was a byte-marked narrow fill that wanted
    /// any star: 2 at a wanted star with a list, 1 at one without, 0 at any other star (which
    /// holds no list to ask about).
    #[inline]
    pub(super) fn live_marks(&self) -> Option<&ByteMarks> {
        if self.bytes_live {
            self.narrow_bytes.as_deref()
        } else {
            None
        }
    }

    /// Clear the marks the last fill left set, given the pairs it wanted.
    pub(super) fn clear_marks(&mut self, wanted: Pairs<'_>) {
        if let (true, Some(m), Pairs::Narrow(w)) =
            (self.bytes_live, self.narrow_bytes.as_mut(), wanted)
        {
            for &[p, q] in w {
                m.clear(p);
                m.clear(q);
            }
            self.bytes_live = false;
        }
    }

    #[inline]
    pub(super) fn partners(&self, star: u32) -> impl Iterator<Item = u32> + '_ {
        let mut at = self.head[star as usize];
        std::iter::from_fn(move || {
            (at != NONE).then(|| {
                let p = self.partner[at as usize];
                at = self.next[at as usize];
                p
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tail_memo_answers_what_it_was_asked_to_compute() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let mut memo = TailMemo::default();
        // Far more argument pairs than slots, each asked twice: collisions must recompute.
        let args: Vec<(u64, usize, f64)> = (0..4 * TAIL_MEMO_SLOTS)
            .map(|_| {
                (
                    rng.random_range(0..2),
                    rng.random_range(0..200),
                    rng.random_range(0.0..1.0),
                )
            })
            .collect();
        let f = |w: u64, c: usize, p: f64| binomial_tail(c, c / 3 + w as usize, p);
        for _ in 0..2 {
            for &(w, c, p) in &args {
                assert_eq!(memo.get_or(w, c, p, || f(w, c, p)), f(w, c, p));
            }
        }
        // The function's tag tells two values at the same arguments apart.
        assert_eq!(memo.get_or(0, 5, 0.25, || 1.0), 1.0);
        assert_eq!(memo.get_or(1, 5, 0.25, || 2.0), 2.0);
    }

    #[test]
    fn a_fill_for_some_stars_holds_their_whole_lists_in_order() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut adj = Adjacency::default();
        // A small catalogue (byte marks on the 16-bit path) and one past BYTE_MARKS_MAX_STARS
        // (bit marks), each with 300 stars in its pairs: neighbours in a word of bits too.
        for trial in 0..400 {
            let n_cat = if trial < 200 { 300 } else { 40_000 };
            let stars: Vec<u32> = if n_cat == 300 {
                (0..300).collect()
            } else {
                (0..300)
                    .map(|i| {
                        if i % 3 == 0 {
                            rng.random_range(0..n_cat as u32)
                        } else {
                            rng.random_range(20_000..20_200)
                        }
                    })
                    .collect()
            };
            let pair = |rng: &mut rand::rngs::StdRng| {
                [
                    stars[rng.random_range(0..stars.len())],
                    stars[rng.random_range(0..stars.len())],
                ]
            };
            let pairs: Vec<[u32; 2]> = (0..rng.random_range(0..400))
                .map(|_| pair(&mut rng))
                .collect();
            let wanted: Vec<[u32; 2]> = (0..rng.random_range(0..20))
                .map(|_| pair(&mut rng))
                .collect();
            // The 16-bit path (every bundled catalogue's) on odd trials: the same lists.
            if trial % 2 == 1 {
                let narrow = |v: &[[u32; 2]]| -> Vec<[u16; 2]> {
                    v.iter().map(|p| p.map(|i| i as u16)).collect()
                };
                let (p16, w16) = (narrow(&pairs), narrow(&wanted));
                adj.fill_ranges(Pairs::Narrow(p16.iter()), Pairs::Narrow(w16.iter()), n_cat);
            } else {
                adj.fill_for(pairs.iter().copied(), wanted.iter().copied(), n_cat);
            }
            for &star in wanted.iter().flatten() {
                // Partners as a fill of every star lists them: the latest pair first.
                let want: Vec<u32> = pairs
                    .iter()
                    .rev()
                    .flat_map(|&[p, q]| {
                        // Pushed (p, q) then (q, p): reversed, (q, p) comes first.
                        [(q == star).then_some(p), (p == star).then_some(q)]
                    })
                    .flatten()
                    .collect();
                let got: Vec<u32> = adj.partners(star).collect();
                assert_eq!(got, want, "trial {trial}, star {star}");
                assert_eq!(adj.has_partners(star), !want.is_empty());
            }
            // The others hold nothing: no mark is left from an earlier fill.
            for &star in &stars {
                if !wanted.iter().flatten().any(|&w| w == star) {
                    assert!(!adj.has_partners(star), "trial {trial}, star {star}");
                }
            }
            // A narrow fill's marks say the same of the wanted stars (what the walk asks).
            if trial % 2 == 1 && !wanted.is_empty() {
                for &star in wanted.iter().flatten() {
                    // Bit marks (the large catalogue) are cleared by the fill.
                    if let Some(m) = adj.live_marks() {
                        assert_eq!(
                            m.has_list(star as u16),
                            adj.has_partners(star),
                            "trial {trial}, star {star}"
                        );
                    } else {
                        assert!(n_cat > BYTE_MARKS_MAX_STARS, "trial {trial}: no marks left");
                    }
                }
                // Cleared by the walk's pairs on some trials, by the next fill's reset on the
                // others: either way the next fill starts clean (checked above).
                if trial % 4 == 1 {
                    let w16: Vec<[u16; 2]> = wanted.iter().map(|p| p.map(|i| i as u16)).collect();
                    adj.clear_marks(Pairs::Narrow(w16.iter()));
                    assert!(adj.live_marks().is_none());
                }
            }
        }
    }
}
