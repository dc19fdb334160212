//! Pyramid (Mortari et al. 2004): triangles of observed stars in an order that varies all
//! three quickly, catalogue triangles through the k-vector, a fourth star to confirm.

use std::f64::consts::{PI, SQRT_2};

use super::join::Adjacency;
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
        self.scratch.forget_side_ranges(self.stride);
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
