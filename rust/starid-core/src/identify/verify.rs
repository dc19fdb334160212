//! The shared verification: every centroid matched to its nearest catalogue star, the attitude
//! re-solved from all matches, magnitude consistency, and the bound on the chance of a false match.

use std::f64::consts::PI;

use nalgebra::{Rotation3, Vector3};

use super::near::{gate_allows, nearest_match, unambiguous_nearest, Nearest};
use super::stats::{binomial_tail, kth_in_place, median_in_place};
use super::{
    Search, Verified, CONFIRM_POOL, MAG_BRIGHTER_LIMIT, MAG_CHECK_MIN_MATCHES, MAG_OUTLIER_SIGMAS,
    MATCH_RADIUS_SIGMAS, SIGMA_LADDER_PX,
};
use crate::attitude::wahba_from;
use crate::sky::Radius;

impl Search<'_> {
    /// Whether at least `needed` other centroids land on catalogue stars under attitude `r`
    /// (the Pyramid's fourth star; more of them in crowded frames). Stops as soon as the answer
    /// is known either way.
    pub(super) fn confirmed(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        used: [usize; 3],
        used_cat: [u32; 3],
        (radius, needed): (f64, usize),
        sigma_rad: f64,
    ) -> bool {
        let catalog = &*self.solver.catalog;
        let radius = Radius::new(radius);
        // The brightest CONFIRM_POOL centroids only: a frame of thousands of spots costs no more
        // per hypothesis than one of a hundred.
        let pool = &self.order[..self.order.len().min(CONFIRM_POOL)];
        let mut remaining = pool.iter().filter(|o| !used.contains(o)).count();
        let mut found = 0;
        for &o in pool.iter().filter(|o| !used.contains(o)) {
            if found + remaining < needed {
                return false;
            }
            remaining -= 1;
            self.pairs_visited += LOOKUP_WORK;
            let w = r.inverse_transform_vector(&obs[o]);
            if let Some((star, _)) = unambiguous_nearest(catalog, &w, radius, sigma_rad) {
                if !used_cat.contains(&star) {
                    found += 1;
                    if found >= needed {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// Match all centroids, re-solve the attitude, adapt the radius to the residuals and bound
    /// the false-match probability. `None` if the hypothesis does not verify.
    pub(super) fn verify(
        &mut self,
        r0: Rotation3<f64>,
        mirrored: bool,
        r_confirm: f64,
        sigma_rad: f64,
    ) -> Option<Verified> {
        let obs = self.obs[usize::from(mirrored)];
        let n = obs.len();
        let f = self.camera.focal_length_px;
        let mut r = r0;
        let mut radius = r_confirm;
        let mut sigma = sigma_rad;
        // Match and re-solve; then the radius follows the noise estimated from the residuals
        // (5σ, never below half the ladder's σ, so that four stars cannot talk it down to nothing).
        // When a pass matches exactly the stars the attitude was fitted to, the attitude, the
        // noise and the radius would all come out the same: a fixed point, and its matches are final.
        self.scratch.fitted.clear();
        let mut matched = 0;
        let mut fixed_point = false;
        for _ in 0..4 {
            matched = self.match_all(&r, obs, radius, sigma);
            if matched < self.min_fit() {
                return None;
            }
            if self.matches_fitted() {
                fixed_point = true;
                break;
            }
            let s = &mut self.scratch;
            s.fitted.clear();
            s.fitted.extend(s.matches.iter().map(|m| m.map(|(c, _)| c)));
            self.collect_matched(obs);
            let s = &mut self.scratch;
            let (o_m, r_m) = (&s.obs_matched, &s.ref_matched);
            r = wahba_from(o_m, r_m, &r)?;
            let sum_sq: f64 = o_m
                .iter()
                .zip(r_m)
                .map(|(o, c)| (o - r * c).norm_squared())
                .sum();
            // E|d|² = 2σ² per star, less the three attitude degrees of freedom; with enough
            // matches the median residual instead (|d| is Rayleigh: median 1.1774σ), so that a
            // coincidence far out cannot widen the radius for more of its kind.
            let dof = (2 * matched).saturating_sub(3).max(1) as f64;
            let rms_sigma = (sum_sq / dof).sqrt();
            let est = if matched >= ROBUST_SIGMA_MIN_MATCHES {
                let d = &mut s.mag_offsets;
                d.clear();
                d.extend(o_m.iter().zip(r_m).map(|(o, c)| (o - r * c).norm()));
                let median = median_in_place(d);
                (median / 1.1774).min(rms_sigma)
            } else {
                rms_sigma
            };
            // Nor above MAX_NOISE_GROWTH times it: residuals far beyond the step's noise are a
            // wrong fit widening its own radius, not noise (a noisier frame verifies at a looser step).
            sigma = est.clamp(0.5 * sigma_rad, MAX_NOISE_GROWTH * sigma_rad);
            // Never below the step's own radius: residuals of a (possibly false) fit must not
            // talk the radius down, or the false-match bound would be computed after the fact.
            let new_radius = (4.0 * sigma).max(MATCH_RADIUS_SIGMAS * sigma_rad) + 1e-7;
            let settled = (new_radius - radius).abs() <= 0.05 * radius;
            radius = new_radius;
            if settled {
                break;
            }
        }
        if !fixed_point {
            matched = self.match_all(&r, obs, radius, sigma);
        }
        // A near miss: an attitude a little off (a hypothesis with a wrong star in it) matches
        // the spots near its rotation's centre and holds still there, naming a few of them
        // after their neighbours. Where most spots are unmatched, widen once, refit, and keep
        // the attitude that matches more spots at the same radius. Residuals well above the
        // step's noise say the same of a fit that matched most spots.
        if (2 * matched < n && n >= REGROW_MIN_SPOTS) || sigma > 2.0 * sigma_rad {
            let mut rematch = true;
            for round in 0..2 {
                self.match_all(&r, obs, REGROW_FACTOR * radius, REGROW_FACTOR * sigma);
                // The wide pass names exactly the stars the fixed point's attitude was fitted to:
                // the refit would return that attitude and match as it did, and the matches held
                // now are the fixed point's own (same stars, same attitude, same distances).
                // Frames of many false spots take this way out in most verifications.
                if round == 0 && fixed_point && self.matches_fitted() {
                    rematch = false;
                    break;
                }
                let Some(r2) = self.refit(obs, &r) else {
                    break;
                };
                let m2 = self.match_all(&r2, obs, radius, sigma);
                let r3 = if m2 >= 3 {
                    self.collect_matched(obs);
                    wahba_from(&self.scratch.obs_matched, &self.scratch.ref_matched, &r2)
                        .unwrap_or(r2)
                } else {
                    r2
                };
                let m3 = self.match_all(&r3, obs, radius, sigma);
                if m3 > matched {
                    r = r3;
                    matched = m3;
                } else {
                    break;
                }
            }
            // The matches of the attitude kept.
            if rematch {
                matched = self.match_all(&r, obs, radius, sigma);
            }
        }
        // Tracking names frames of few stars among many spots: there a false spot on a
        // catalogue star too faint to be imaged must not count (see `drop_unseen_magnitudes`).
        // Only where unmatched spots abound: they are what such coincidences are made of, and
        // in a clean frame the check would only cost real stars near a soft detection limit.
        let unmatched = n - self.scratch.matches.iter().filter(|m| m.is_some()).count();
        let unseen = if self.hint.is_some() && unmatched >= UNSEEN_CHECK_MIN_UNMATCHED {
            self.drop_unseen_magnitudes(&r, mirrored)
        } else {
            0
        };
        let dropped = self.drop_magnitude_outliers(radius)
            + self.drop_joint_outliers(&r, obs, sigma)
            + unseen;
        if dropped > 0 {
            // Fewer matches: refit, and the bound below only grows.
            matched = self.collect_matched(obs);
            if matched < self.min_fit() {
                return None;
            }
            r = wahba_from(&self.scratch.obs_matched, &self.scratch.ref_matched, &r)?;
            self.refresh_residuals(&r, obs);
        }
        if matched < self.min_verified() {
            return None;
        }
        // The density map's value decides only where the answer does not hang on it: a bound
        // within DENSITY_RECHECK of the limit either way is recomputed from the field's own count.
        let limit = self.config.max_false_match_prob;
        let mut tail = self.match_tail(&r, n, matched, radius, false);
        let bound = self.hypotheses as f64 * tail;
        if bound > limit / DENSITY_RECHECK && bound < limit * DENSITY_RECHECK {
            tail = self.match_tail(&r, n, matched, radius, true);
        }
        if self.hypotheses as f64 * tail > limit {
            return None;
        }
        // A stated noise is a hypothesis the residuals may refuse: too small, the solution is
        // refused (a looser step finds it with the noise it has); too large, its matches are
        // judged again at the noise measured. So is a loose step of the default ladder (too
        // large for a frame its tighter steps could not solve for want of stars).
        let (mut radius, mut sigma) = (radius, sigma);
        let stated = self.config.centroid_sigma_px.is_some();
        // (Two spots left unmatched at least: fewer cannot refuse it.) A step of the default
        // ladder is not refused so: residuals that grow towards the edges there are often a
        // focal length or distortion that the focal check corrects. Its matches are kept where
        // the wider noise the extra spots show judges them alike (a double is told apart by
        // the noise it is judged with), and the bound is taken again with those left.
        if n >= matched + 2 && self.noise_too_small(&r, obs, (radius, sigma)) {
            if stated {
                return None;
            }
            let kept = self.scratch.matches.clone();
            self.match_all(&r, obs, radius, REGROW_FACTOR * sigma);
            self.keep_only(&kept);
            // (The residuals under the same attitude are the same.)
            matched = self.scratch.matches.iter().filter(|m| m.is_some()).count();
            if matched < self.min_verified() {
                return None;
            }
            tail = self.match_tail(&r, n, matched, radius, true);
            if self.hypotheses as f64 * tail > limit {
                return None;
            }
        }
        if stated || sigma_rad * f > SIGMA_LADDER_PX[0] {
            if let Some((r2, m2, radius2, sigma2)) =
                self.rejudge_at_measured_noise(&r, obs, (radius, sigma), sigma_rad, matched)
            {
                (r, matched, radius, sigma) = (r2, m2, radius2, sigma2);
            }
        }
        Some(Verified {
            r,
            mirrored,
            matches: self.scratch.matches.clone(),
            matched,
            sigma_px: sigma * f,
            step_sigma_px: sigma_rad * f,
            radius_rad: radius,
            tail,
            false_prob: f64::NAN,
            verified: true,
            has_attitude: true,
        })
    }

    /// Nearest-star match of every centroid under `r`, each catalogue star claimed at most once.
    /// Fills `scratch.matches` (per centroid); returns the count. A refit first fills the matched
    /// vector lists ([`Self::collect_matched`]): most passes end in none (the last pass of a
    /// verification confirms its matches, and a failed one ends it).
    pub(super) fn match_all(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        radius: f64,
        sigma_rad: f64,
    ) -> usize {
        let catalog = &*self.solver.catalog;
        let mags = self.solver.mag_f32();
        let gate = self.gate;
        let decisive = 2.0 * AMBIGUITY_LOG_ODDS * sigma_rad * sigma_rad;
        // Held stars reach as far as a rival centroid may lie and still contest a claim (see
        // `Claims::unmatch_contested`).
        let contest_rad = (radius * radius + decisive).sqrt();
        let radius = Radius::new(radius);
        self.pairs_visited += LOOKUP_WORK * obs.len();
        let s = &mut self.scratch;
        s.matches.clear();
        s.claim.clear();
        s.ambiguous.clear();
        s.near.ensure(catalog, r, obs, contest_rad);
        let allowed = |o: usize, star: u32| gate_allows(gate, mags, o, star);
        for o in 0..obs.len() {
            let two = s.near.nearest_two(o, radius);
            let m = match nearest_match(two, sigma_rad, |star| gate_allows(gate, mags, o, star)) {
                Nearest::Unique(star, d) => Some((star, d)),
                Nearest::Ambiguous(a) => {
                    s.ambiguous.push((o as u32, a));
                    None
                }
                Nearest::None => None,
            };
            if let Some((star, d)) = m {
                s.claim.push((star, o as u32, d));
            }
            s.matches.push(m);
        }
        // A centroid torn between two stars of a resolved double, one of which another centroid
        // claims: the joint assignment of the two centroids to the two stars that fits
        // decisively better names both.
        // Only with magnitudes, and only where each centroid's magnitude agrees with its star's
        // both ways after the frame's offset (the median over the unique matches): a false spot
        // beside a star with a faint companion must not be handed the companion.
        let offset =
            match (self.magnitudes, s.ambiguous.is_empty()) {
                (Some(m), false) => {
                    let d = &mut s.mag_offsets;
                    d.clear();
                    d.extend(s.matches.iter().enumerate().filter_map(|(o, x)| {
                        x.map(|(star, _)| m[o] - f64::from(mags[star as usize]))
                    }));
                    (d.len() >= 3).then(|| {
                        let k = d.len() / 2;
                        kth_in_place(d, k)
                    })
                }
                _ => None,
            };
        let tol = self.config.mag_tolerance;
        if !s.ambiguous.is_empty() {
            // With the magnitudes' offset, a decisive joint assignment names both centroids where
            // their magnitudes fit; without, it names none.
            let fits = |o: u32, star: u32| match (offset, self.magnitudes) {
                (Some(off), Some(m)) => {
                    (m[o as usize] - off - f64::from(mags[star as usize])).abs() <= tol
                }
                _ => false,
            };
            let cat = catalog.vectors();
            // A few torn centroids (the usual frame) look their owners up in the claims as they
            // stand; many, in the claims sorted by star.
            let sorted = s.ambiguous.len() > OWNER_SCAN_MAX_AMBIGUOUS;
            if sorted {
                s.claim.sort_unstable_by_key(|c| c.0);
            }
            let mut resolved: Vec<(u32, u32, f64, u32, u32, f64)> = Vec::new();
            // Owners whose claim the joint assignment does not bear out.
            let mut doubted: Vec<u32> = Vec::new();
            for &(ob, cands) in &s.ambiguous {
                let [(s1, _), (s2, _)] = cands;
                let owner = |star: u32| {
                    if sorted {
                        s.claim
                            .binary_search_by_key(&star, |c| c.0)
                            .ok()
                            .map(|i| s.claim[i].1)
                    } else {
                        s.claim.iter().find(|c| c.0 == star).map(|c| c.1)
                    }
                };
                let pair = (s1.min(s2), s1.max(s2));
                let (oa, owned) =
                    match (owner(s1), owner(s2)) {
                        (Some(a), None) => (a, Some(s1)),
                        (None, Some(a)) => (a, Some(s2)),
                        // Both torn between the same two stars: the other one's index is larger,
                        // so the pair is settled once.
                        (None, None) => match s.ambiguous.iter().find(|(o, c)| {
                            *o > ob && (c[0].0.min(c[1].0), c[0].0.max(c[1].0)) == pair
                        }) {
                            Some(&(o, _)) => (o, None),
                            None => continue,
                        },
                        _ => continue,
                    };
                // Two torn centroids with no offset to name them by: nothing to settle.
                if owned.is_none() && offset.is_none() {
                    continue;
                }
                // Two centroids and two stars only: with a third star nearly as likely as the
                // nearest for either centroid, the pair's two assignments are not the only ones.
                if s.near.third_as_likely(oa as usize, radius, decisive)
                    || s.near.third_as_likely(ob as usize, radius, decisive)
                {
                    continue;
                }
                let wa = r.inverse_transform_vector(&obs[oa as usize]);
                let wb = r.inverse_transform_vector(&obs[ob as usize]);
                let d = |w: &Vector3<f64>, star: u32| w.cross(&cat[star as usize]).norm();
                let straight = d(&wa, s1).powi(2) + d(&wb, s2).powi(2);
                let crossed = d(&wa, s2).powi(2) + d(&wb, s1).powi(2);
                // The owner keeps its star only where it, and the torn centroid the other star,
                // fit decisively better than the two swapped: otherwise the torn centroid may be
                // that star's own spot, and the owner the other star's.
                let (kept, swapped) = match owned {
                    Some(k) if k == s1 => (straight, crossed),
                    _ => (crossed, straight),
                };
                // (Only where magnitudes allow the swap, within twice the gate's tolerance: a
                // close double's two magnitudes may be swapped by more than `mag_tolerance` in
                // noisy photometry, but a false spot far off in magnitude is no rival.)
                let loose = |o: u32, star: u32| {
                    gate.is_none_or(|g| {
                        f64::from(mags[star as usize]) <= f64::from(g[o as usize][1]) + tol
                    })
                };
                let doubt = owned.is_some_and(|k| {
                    let other = if k == s1 { s2 } else { s1 };
                    swapped - kept < decisive && loose(oa, other) && loose(ob, k)
                });
                let (for_a, for_b) = if straight < crossed {
                    (s1, s2)
                } else {
                    (s2, s1)
                };
                if (straight - crossed).abs() >= decisive && fits(oa, for_a) && fits(ob, for_b) {
                    resolved.push((oa, for_a, d(&wa, for_a), ob, for_b, d(&wb, for_b)));
                } else if doubt {
                    doubted.push(oa);
                }
            }
            for (oa, sa, da, ob, sb, db) in resolved {
                if s.matches[oa as usize].is_none() {
                    // Both were torn: both are named now.
                    s.matches[oa as usize] = Some((sa, da));
                    s.matches[ob as usize] = Some((sb, db));
                    s.claim.push((sa, oa, da));
                    s.claim.push((sb, ob, db));
                } else if s.matches[oa as usize].map(|m| m.0) == Some(sa) {
                    s.matches[ob as usize] = Some((sb, db));
                    s.claim.push((sb, ob, db));
                } else if s.matches[oa as usize].is_some() {
                    // The claimed star goes to the ambiguous centroid; the owner takes the other.
                    s.matches[oa as usize] = Some((sa, da));
                    s.matches[ob as usize] = Some((sb, db));
                    for c in s.claim.iter_mut() {
                        if c.1 == oa {
                            *c = (sa, oa, da);
                        }
                    }
                    s.claim.push((sb, ob, db));
                }
            }
            for oa in doubted {
                s.matches[oa as usize] = None;
            }
        }
        // A catalogue star claimed by two centroids is ambiguous: neither gets it.
        s.claims
            .unmatch_shared(&s.claim, &mut s.matches, catalog.len());
        s.claims
            .unmatch_contested(&s.near, &mut s.matches, radius, decisive, allowed);
        s.matches.iter().filter(|m| m.is_some()).count()
    }

    /// Whether the last matching pass named, centroid by centroid, the stars the attitude was
    /// last fitted to.
    fn matches_fitted(&self) -> bool {
        let s = &self.scratch;
        s.matches
            .iter()
            .map(|m| m.map(|(c, _)| c))
            .eq(s.fitted.iter().copied())
    }

    /// The attitude fitted to the current matches (from `r`), or `None` with fewer than three.
    pub(super) fn refit(
        &mut self,
        obs: &[Vector3<f64>],
        r: &Rotation3<f64>,
    ) -> Option<Rotation3<f64>> {
        if self.collect_matched(obs) < 3 {
            return None;
        }
        wahba_from(&self.scratch.obs_matched, &self.scratch.ref_matched, r)
    }

    /// Fill the matched vector lists from `scratch.matches`; returns their length.
    pub(super) fn collect_matched(&mut self, obs: &[Vector3<f64>]) -> usize {
        let cat = self.solver.catalog.vectors();
        let s = &mut self.scratch;
        s.obs_matched.clear();
        s.ref_matched.clear();
        for (o, m) in s.matches.iter().enumerate() {
            if let Some((star, _)) = m {
                s.obs_matched.push(obs[o]);
                s.ref_matched.push(cat[*star as usize]);
            }
        }
        s.obs_matched.len()
    }

    /// With magnitudes, unmatch centroids far brighter than their catalogue star (see
    /// [`MAG_BRIGHTER_LIMIT`]), and those as far fainter than their star where another star
    /// within `radius` of the centroid fits its magnitude (a close double whose two spots the
    /// positions alone do not tell apart: the spot may be the fainter star's). Returns how many.
    pub(super) fn drop_magnitude_outliers(&mut self, radius: f64) -> usize {
        let Some(mags) = self.magnitudes else {
            return 0;
        };
        let cat_mag = self.solver.catalog.mag();
        let s = &mut self.scratch;
        s.mag_offsets.clear();
        s.mag_offsets.extend(
            s.matches
                .iter()
                .zip(mags)
                .filter_map(|(m, &obs_mag)| m.map(|(star, _)| obs_mag - cat_mag[star as usize])),
        );
        let n = s.mag_offsets.len();
        if n < MAG_CHECK_MIN_MATCHES {
            return 0;
        }
        // Offsets within MAG_BRIGHTER_LIMIT of each other: none lies farther than that from the
        // median, and the limit is at least that (the usual frame: no medians needed).
        let (lo, hi) = s
            .mag_offsets
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| {
                (lo.min(d), hi.max(d))
            });
        if hi - lo <= MAG_BRIGHTER_LIMIT {
            return 0;
        }
        // Nor where the median is within MAG_BRIGHTER_LIMIT of both the smallest and the
        // largest offset: then none lies that far from it. Fewer than half the offsets above
        // lo + 0.999, and fewer than half below hi − 0.999, say so without a median (the
        // margin far exceeds any rounding of the comparisons below).
        let k = n - n / 2;
        let above = lo + (MAG_BRIGHTER_LIMIT - 1e-3);
        let below = hi - (MAG_BRIGHTER_LIMIT - 1e-3);
        if s.mag_offsets.iter().filter(|&&d| d > above).count() < k
            && s.mag_offsets.iter().filter(|&&d| d < below).count() < k
        {
            return 0;
        }
        let offset = median_in_place(&mut s.mag_offsets);
        for d in &mut s.mag_offsets {
            *d = (*d - offset).abs();
        }
        let spread = 1.4826 * median_in_place(&mut s.mag_offsets);
        let limit = MAG_BRIGHTER_LIMIT.max(MAG_OUTLIER_SIGMAS * spread);
        let radius = Radius::new(radius);
        let mut dropped = 0;
        for (o, (m, &obs_mag)) in s.matches.iter_mut().zip(mags).enumerate() {
            let Some((star, _)) = *m else {
                continue;
            };
            let off = obs_mag - cat_mag[star as usize];
            let too_faint = off > offset + limit && {
                let rival = match s.near.nearest_two(o, radius) {
                    (Some((a, _)), Some((b, _))) => Some(if a == star { b } else { a }),
                    _ => None,
                };
                rival.is_some_and(|c| (obs_mag - offset - cat_mag[c as usize]).abs() <= limit)
            };
            if off < offset - limit || too_faint {
                *m = None;
                dropped += 1;
            }
        }
        dropped
    }

    /// Unmatch centroids whose catalogue star lies in a magnitude range the camera mostly does
    /// not see in this frame: of the catalogue stars on the sensor within
    /// ±[`COMPLETENESS_HALF_WIDTH_MAG`] of the star's magnitude, at least
    /// [`COMPLETENESS_MIN_STARS`] and fewer than [`COMPLETENESS_MIN_FRACTION`] are matched. Such
    /// a match is a false spot on a star too faint to be imaged (the catalogue is deeper than the
    /// camera), not a detection. With fewer than [`BRIGHTER_CHECK_MAX_MATCHES`] matches, also
    /// those whose brighter stars on the sensor are mostly unmatched. Needs no magnitudes of the
    /// spots. Returns how many.
    pub(super) fn drop_unseen_magnitudes(&mut self, r: &Rotation3<f64>, mirrored: bool) -> usize {
        let catalog = &*self.solver.catalog;
        let (cat_mag, cat) = (catalog.mag(), catalog.vectors());
        let cam = self.camera;
        let s = &mut self.scratch;
        // Matched stars, sorted, for look-ups.
        s.fitted.clear();
        s.fitted
            .extend(s.matches.iter().filter_map(|m| m.map(|(c, _)| Some(c))));
        if s.fitted.len() < 2 {
            return 0;
        }
        let few = s.fitted.len() < BRIGHTER_CHECK_MAX_MATCHES;
        let mut matched: Vec<u32> = s.fitted.iter().map(|c| c.unwrap_or(0)).collect();
        matched.sort_unstable();
        // Catalogue stars imaged on the sensor: (magnitude, matched?), by magnitude.
        let mut on_sensor: Vec<(f64, bool)> = Vec::new();
        let boresight = r.inverse_transform_vector(&Vector3::z());
        catalog.for_each_in_cone(&boresight, 0.5 * cam.diagonal_fov_rad(), |star, _| {
            if let Some((mut x, y)) = cam.cam_to_pixel(&(r * cat[star as usize])) {
                if mirrored {
                    x = cam.width_px - x;
                }
                if (0.0..cam.width_px).contains(&x) && (0.0..cam.height_px).contains(&y) {
                    on_sensor.push((cat_mag[star as usize], matched.binary_search(&star).is_ok()));
                }
            }
        });
        on_sensor.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mags: Vec<f64> = on_sensor.iter().map(|x| x.0).collect();
        let mut seen_before = vec![0usize; on_sensor.len() + 1];
        for (k, x) in on_sensor.iter().enumerate() {
            seen_before[k + 1] = seen_before[k] + usize::from(x.1);
        }
        let mut dropped = 0;
        for m in s.matches.iter_mut() {
            let Some((star, _)) = *m else { continue };
            let mag = cat_mag[star as usize];
            let lo = mags.partition_point(|&x| x < mag - COMPLETENESS_HALF_WIDTH_MAG);
            let hi = mags.partition_point(|&x| x <= mag + COMPLETENESS_HALF_WIDTH_MAG);
            let total = hi - lo;
            let seen = seen_before[hi] - seen_before[lo];
            // With a few matches only, the stars brighter than it too: a camera that missed most
            // of those did not see it. (An attitude that a wrong hint let two spots fit by chance
            // names two stars at random, with brighter ones unseen around them.)
            let brighter = mags.partition_point(|&x| x < mag - BRIGHTER_MARGIN_MAG);
            let brighter_seen = seen_before[brighter];
            if (total >= COMPLETENESS_MIN_STARS
                && (seen as f64) < COMPLETENESS_MIN_FRACTION * total as f64)
                || (few
                    && brighter >= BRIGHTER_MIN_STARS
                    && (brighter_seen as f64) < BRIGHTER_MIN_FRACTION * brighter as f64)
            {
                *m = None;
                dropped += 1;
            }
        }
        dropped
    }

    /// `P(Bin(n − b, p) ≥ m − b)` with `p` from the local catalogue density and `b` the
    /// centroids the hypothesis was built from (3 for a triangle).
    pub(super) fn match_tail(
        &self,
        r: &Rotation3<f64>,
        n: usize,
        matched: usize,
        radius: f64,
        exact: bool,
    ) -> f64 {
        let density = self.field_density(r, exact);
        // In a gated pass a chance match must also fall in the centroid's magnitude window: the
        // mean chance over the centroids bounds the tail (Hoeffding 1956, for counts above the mean).
        let frac = if self.gate.is_some() {
            self.gate_fraction
        } else {
            1.0
        };
        let p = (density * PI * radius * radius * frac).min(1.0);
        match &self.hint {
            // Tracking: two spots made the hypothesis inside the hint's region; the chance that
            // they did so by accident is `base`, and the others must land by chance as usual.
            Some(h) => {
                h.base_chance(density * frac, radius)
                    * binomial_tail(n.saturating_sub(2), matched.saturating_sub(2), p)
            }
            None => binomial_tail(
                n.saturating_sub(self.built),
                matched.saturating_sub(self.built),
                p,
            ),
        }
    }

    /// Catalogue stars per steradian in the field the attitude `r` looks at: from the solver's
    /// map (or, tracking, the hint's field), or with `exact` the stars counted in the field's
    /// cone.
    pub(super) fn field_density(&self, r: &Rotation3<f64>, exact: bool) -> f64 {
        if let Some(h) = self.hint.as_ref().filter(|h| h.density > 0.0 && !exact) {
            return h.density;
        }
        let half_diag = 0.5 * self.camera.diagonal_fov_rad();
        // Tracking counts the hint's field: the attitude moves within the uncertainty only.
        let r = self.hint.as_ref().map_or(r, |h| &h.r_hint);
        let boresight = r.inverse_transform_vector(&Vector3::z());
        // The solver's map where its cones are about the field's (the cache serves fields of
        // 0.8 to 1 times its index's angle), else the stars counted in the field's cone.
        if let Some(map) = self.solver.density.as_ref().filter(|m| {
            !exact
                && half_diag <= m.radius_rad()
                && half_diag >= DENSITY_MAP_MIN_FIELD * m.radius_rad()
        }) {
            let cone_sr = 2.0 * PI * (1.0 - map.radius_rad().cos());
            return map.at(&boresight).max(1.0 / cone_sr);
        }
        let in_field = self.solver.catalog.count_in_cone(&boresight, half_diag);
        let cone_sr = 2.0 * PI * (1.0 - half_diag.cos());
        in_field.max(1) as f64 / cone_sr
    }

    /// Fewest matches an attitude is fitted to: 3, or 2 when a hint pins the attitude down.
    pub(super) fn min_fit(&self) -> usize {
        if self.hint.is_some() {
            2
        } else {
            3
        }
    }
}

/// How near the limit (a factor, either way) a false-match bound from the density map is
/// recomputed from the field's own star count.
const DENSITY_RECHECK: f64 = 1e3;

/// Narrowest field, as a fraction of the density map's cone radius, whose density the map gives.
const DENSITY_MAP_MIN_FIELD: f64 = 0.75;

/// Unmatched spots from which tracking checks matches against the frame's magnitude
/// completeness.
pub(super) const UNSEEN_CHECK_MIN_UNMATCHED: usize = 3;

/// Spots from which a solution matching fewer than half of them is checked for a near miss.
pub(super) const REGROW_MIN_SPOTS: usize = 8;

/// How much the near-miss check widens the match radius.
pub(super) const REGROW_FACTOR: f64 = 3.0;

/// Most the noise estimated from a fit's residuals may exceed the search step's noise (the
/// match radius is then at most 4 times this many step σ).
pub(super) const MAX_NOISE_GROWTH: f64 = 4.0;

/// Matches from which the noise is estimated by the median residual rather than the rms.
pub(super) const ROBUST_SIGMA_MIN_MATCHES: usize = 6;

/// Half width of the magnitude range whose completeness judges a match (see
/// `Search::drop_unseen_magnitudes`).
pub(super) const COMPLETENESS_HALF_WIDTH_MAG: f64 = 0.25;

/// Fewest catalogue stars on the sensor in that range for the judgement.
pub(super) const COMPLETENESS_MIN_STARS: usize = 4;

/// A match is dropped when fewer than this fraction of the stars in its range are matched.
pub(super) const COMPLETENESS_MIN_FRACTION: f64 = 0.25;

/// With fewer matches than this, a match is dropped, too, when fewer than
/// [`BRIGHTER_MIN_FRACTION`] of the catalogue stars on the sensor more than
/// [`BRIGHTER_MARGIN_MAG`] brighter than its star are matched, of at least
/// [`BRIGHTER_MIN_STARS`] (see `Search::drop_unseen_magnitudes`). More matches than that
/// verify by themselves.
pub(super) const BRIGHTER_CHECK_MAX_MATCHES: usize = 4;

/// See [`BRIGHTER_CHECK_MAX_MATCHES`].
pub(super) const BRIGHTER_MIN_FRACTION: f64 = 0.5;

/// Fewest brighter stars for that judgement.
pub(super) const BRIGHTER_MIN_STARS: usize = 3;

/// How much brighter, mag, a star must be to count in it: detection is not sharp in magnitude.
pub(super) const BRIGHTER_MARGIN_MAG: f64 = 0.3;

/// Work of one nearest-star look-up, in catalogue pairs visited (about its cost in time): the
/// search's work budget counts matching too, so frames of many spots end as soon.
pub(super) const LOOKUP_WORK: usize = 4;

/// Log-likelihood ratio the nearest catalogue star must win by over the second nearest for a
/// match to count (ln 1000): an unresolved double is left unmatched rather than guessed.
pub(crate) const AMBIGUITY_LOG_ODDS: f64 = 6.907755278982137;

/// Most centroids torn between two stars whose owners `match_all` finds by scanning the claims
/// (more: by a binary search of the claims sorted by star).
const OWNER_SCAN_MAX_AMBIGUOUS: usize = 8;
