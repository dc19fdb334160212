//! The noise a solution is judged with, tested against its residuals: refused as too small when
//! a wider radius brings in more spots than chance explains, judged again at the noise measured
//! when that lies below it, and a far outlier tested against the other matches.

use std::f64::consts::PI;

use nalgebra::{Rotation3, Vector3};

use super::near::{gate_allows, unambiguous_nearest};
use super::stats::{binomial_tail, median_in_place};
use super::verify::{LOOKUP_WORK, REGROW_FACTOR};
use super::{Search, CONFIRM_POOL, MATCH_RADIUS_SIGMAS};
use crate::attitude::wahba_from;
use crate::sky::Radius;

impl Search<'_> {
    /// Whether the noise the matches were judged with is refused as too small: matched again at
    /// [`REGROW_FACTOR`] times the radius under the same attitude, more spots find a star than
    /// chance coincidences explain (a Poisson tail below [`NOISE_REFUSE_TAIL`]; at least two).
    /// Under the right noise the radius holds all but a few in 10⁴ of the real stars, so the
    /// spots that come in are stars the noise left out. Among the brightest [`CONFIRM_POOL`]
    /// spots.
    pub(super) fn noise_too_small(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        (radius, sigma): (f64, f64),
    ) -> bool {
        let catalog = &*self.solver.catalog;
        let wide = REGROW_FACTOR * radius;
        let within = Radius::new(wide);
        // The stars already named, sorted, for look-ups; the brightest CONFIRM_POOL spots only,
        // so that a frame of thousands of spots costs no more than one of a hundred.
        let mut named: Vec<u32> = self.scratch.matches.iter().flatten().map(|m| m.0).collect();
        named.sort_unstable();
        let pool = &self.order[..self.order.len().min(CONFIRM_POOL)];
        let (mut unmatched, mut extra) = (0, 0);
        for &o in pool {
            if self.scratch.matches[o].is_some() {
                continue;
            }
            unmatched += 1;
            self.pairs_visited += LOOKUP_WORK;
            let w = r.inverse_transform_vector(&obs[o]);
            if let Some((star, _)) = unambiguous_nearest(catalog, &w, within, REGROW_FACTOR * sigma)
            {
                let allowed = gate_allows(self.gate, self.solver.mag_f32(), o, star);
                extra += usize::from(named.binary_search(&star).is_err() && allowed);
            }
        }
        if extra < 2 {
            return false;
        }
        let frac = if self.gate.is_some() {
            self.gate_fraction
        } else {
            1.0
        };
        let p = (self.field_density(r, false) * PI * wide * wide * frac).min(1.0);
        binomial_tail(unmatched, extra, p) < NOISE_REFUSE_TAIL
    }

    /// Where the residuals of at least [`NOISE_MEASURE_MIN_MATCHES`] matches put the noise
    /// below [`NOISE_REJUDGE_BELOW`] times the step's `sigma_rad`, the matches judged again at
    /// that noise (radius [`MATCH_RADIUS_SIGMAS`] of it) and the attitude refitted: a radius
    /// wider than the noise lets false spots near faint stars in. Far outliers go first (see
    /// `drop_far_outlier`). Returns the attitude, matches, radius and noise,
    /// or `None` where the noise fits (or the matches fall below `min_matches`, and the matches
    /// are left as they were).
    pub(super) fn rejudge_at_measured_noise(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        (radius0, sigma0): (f64, f64),
        sigma_rad: f64,
        matched: usize,
    ) -> Option<(Rotation3<f64>, usize, f64, f64)> {
        let kept = self.scratch.matches.clone();
        let (mut r, mut matched, mut sigma) = (*r, matched, sigma_rad);
        let mut judged = None;
        while matched > NOISE_MEASURE_MIN_MATCHES {
            let Some(r2) = self.drop_far_outlier(&r, obs) else {
                break;
            };
            r = r2;
            matched -= 1;
            judged = Some((r, matched, f64::NAN, f64::NAN));
        }
        // What judging again may keep: the matches less the far outliers.
        let base = self.scratch.matches.clone();
        // A false match far out pulls the attitude of a few stars and so the others' residuals:
        // measured again once it is gone, the noise comes out lower.
        for _ in 0..NOISE_REJUDGE_ROUNDS {
            if matched < NOISE_MEASURE_MIN_MATCHES {
                break;
            }
            let s = &mut self.scratch;
            let d = &mut s.mag_offsets;
            d.clear();
            d.extend(s.matches.iter().filter_map(|m| m.map(|(_, d)| d)));
            // The median residual of a Rayleigh distribution is 1.1774σ; the attitude's three
            // degrees of freedom shrink the residuals by about sqrt((2m − 3) / 2m).
            let dof = (2 * matched) as f64 / (2 * matched - 3) as f64;
            let measured = median_in_place(d) / 1.1774 * dof.sqrt();
            if measured >= NOISE_REJUDGE_BELOW * sigma {
                break;
            }
            let radius = MATCH_RADIUS_SIGMAS * measured + 1e-9;
            self.match_all(&r, obs, radius, measured);
            let Some(r2) = self.refit(obs, &r) else {
                break;
            };
            self.match_all(&r2, obs, radius, measured);
            // Judging again only unnames: a spot the checks of the verification dropped stays
            // dropped.
            self.keep_only(&base);
            // The joint test again, at the noise measured.
            self.drop_joint_outliers(&r2, obs, measured);
            let m2 = self.scratch.matches.iter().filter(|m| m.is_some()).count();
            if m2 < self.min_verified() {
                break;
            }
            (r, matched, sigma) = (r2, m2, measured);
            judged = Some((r, matched, radius, measured));
        }
        if judged.is_none() {
            self.scratch.matches = kept;
        } else if let Some((_, _, radius, measured)) = judged.filter(|j| j.2.is_finite()) {
            // The matches of the last attitude kept.
            self.match_all(&r, obs, radius, measured);
            self.keep_only(&base);
            self.drop_joint_outliers(&r, obs, measured);
            let m = self.scratch.matches.iter().filter(|m| m.is_some()).count();
            if m < self.min_verified() {
                self.scratch.matches = kept;
                return None;
            }
            return Some((r, m, radius, measured));
        } else if matched >= self.min_verified() {
            // Only far outliers dropped: the radius and noise stay as they were.
            self.refresh_residuals(&r, obs);
            return Some((r, matched, radius0, sigma0));
        } else {
            self.scratch.matches = kept;
        }
        None
    }

    /// Unmatch every spot whose star is not the one it had in `before` (the residuals are the
    /// new ones).
    pub(super) fn keep_only(&mut self, before: &[Option<(u32, f64)>]) {
        for (m, b) in self.scratch.matches.iter_mut().zip(before) {
            if m.map(|x| x.0) != b.map(|x| x.0) {
                *m = None;
            }
        }
    }

    /// Each match's residual under the attitude `r`.
    pub(super) fn refresh_residuals(&mut self, r: &Rotation3<f64>, obs: &[Vector3<f64>]) {
        let cat = self.solver.catalog.vectors();
        for (o, m) in self.scratch.matches.iter_mut().enumerate() {
            if let Some((star, d)) = m {
                *d = r
                    .inverse_transform_vector(&obs[o])
                    .cross(&cat[*star as usize])
                    .norm();
            }
        }
    }

    /// The match of the largest residual, tested against the others: the attitude fitted to
    /// the others, its residual under it beyond [`OUTLIER_SIGMAS`] times their noise (the
    /// smaller of their rms and their median-based estimate) unmatches it. Returns that
    /// attitude, or `None` where the match stays.
    pub(super) fn drop_far_outlier(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
    ) -> Option<Rotation3<f64>> {
        let k = self
            .scratch
            .matches
            .iter()
            .enumerate()
            .filter_map(|(o, m)| m.map(|(_, d)| (o, d)))
            .max_by(|a, b| a.1.total_cmp(&b.1))?
            .0;
        let (r2, far, noise) = self.without(k, r, obs)?;
        (far > OUTLIER_SIGMAS * noise).then(|| {
            self.scratch.matches[k] = None;
            r2
        })
    }

    /// Match `k` judged by the others: the attitude fitted to them, `k`'s residual under it, and
    /// their noise (the smaller of their rms and their median-based estimate). The matches are
    /// left as they were.
    fn without(
        &mut self,
        k: usize,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
    ) -> Option<(Rotation3<f64>, f64, f64)> {
        let cat = self.solver.catalog.vectors();
        let held = self.scratch.matches[k].take();
        let star = held?.0;
        let m = self.collect_matched(obs);
        self.scratch.matches[k] = held;
        if m < 3 {
            return None;
        }
        let r2 = wahba_from(&self.scratch.obs_matched, &self.scratch.ref_matched, r)?;
        let s = &mut self.scratch;
        let d = &mut s.mag_offsets;
        d.clear();
        d.extend(
            s.obs_matched
                .iter()
                .zip(&s.ref_matched)
                .map(|(o, c)| (o - r2 * c).norm()),
        );
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / (2 * m - 3).max(1) as f64).sqrt();
        let dof = (2 * m) as f64 / (2 * m - 3).max(1) as f64;
        let noise = (median_in_place(d) / 1.1774 * dof.sqrt()).min(rms);
        let far = r2
            .inverse_transform_vector(&obs[k])
            .cross(&cat[star as usize])
            .norm();
        Some((r2, far, noise))
    }

    /// With magnitudes, unmatch centroids both far from their star and brighter than it: the
    /// chance of a real star being as far out (Rayleigh tail at noise `sigma_rad`) and as
    /// bright (a normal tail at the matches' robust magnitude spread, at least
    /// [`JOINT_MIN_SPREAD_MAG`]), combined by Fisher's method, below [`JOINT_OUTLIER_TAIL`].
    /// Each alone may be unremarkable (3σ); together they are a false spot on a faint star's
    /// place. Returns how many.
    pub(super) fn drop_joint_outliers(
        &mut self,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        sigma_rad: f64,
    ) -> usize {
        let Some(mags) = self.magnitudes else {
            return 0;
        };
        // Most frames have no match far enough out to test: no magnitudes are looked at.
        let screen = JOINT_SCREEN_POS_SIGMAS * sigma_rad;
        if !self.scratch.matches.iter().flatten().any(|m| m.1 > screen) {
            return 0;
        }
        let cat_mag = self.solver.catalog.mag();
        // Nor, in most of the rest, a match that far out and bright enough: a candidate's
        // offset lies at least JOINT_SCREEN_SIGMAS spreads (never under JOINT_MIN_SPREAD_MAG)
        // below the median, which needs more than half the offsets above the lowest
        // candidate's by that much (one pass, no median).
        let offsets = || {
            self.scratch
                .matches
                .iter()
                .zip(mags)
                .filter_map(|(m, &obs_mag)| {
                    m.map(|(star, d)| (obs_mag - cat_mag[star as usize], d))
                })
        };
        let lowest = offsets()
            .filter(|&(_, d)| d > screen)
            .fold(f64::INFINITY, |lo, (x, _)| lo.min(x));
        let bar = lowest + JOINT_SCREEN_SIGMAS * JOINT_MIN_SPREAD_MAG;
        let (n, above) = offsets().fold((0, 0), |(n, a), (x, _)| (n + 1, a + usize::from(x > bar)));
        if above < n - n / 2 {
            return 0;
        }
        // The offsets' median and robust spread, less the match at `skip` (a test must not count
        // the value it tests).
        let centre =
            |s: &mut super::search::Scratch, skip: Option<usize>| -> Option<(f64, f64)> {
                let d = &mut s.mag_offsets;
                d.clear();
                d.extend(s.matches.iter().zip(mags).enumerate().filter_map(
                    |(o, (m, &obs_mag))| {
                        m.filter(|_| Some(o) != skip)
                            .map(|(star, _)| obs_mag - cat_mag[star as usize])
                    },
                ));
                if d.len() < super::MAG_CHECK_MIN_MATCHES - usize::from(skip.is_some()) {
                    return None;
                }
                let offset = median_in_place(d);
                for x in d.iter_mut() {
                    *x = (*x - offset).abs();
                }
                Some((
                    offset,
                    (1.4826 * median_in_place(d)).max(JOINT_MIN_SPREAD_MAG),
                ))
            };
        let Some((offset, spread)) = centre(&mut self.scratch, None) else {
            return 0;
        };
        let off = |o: usize, star: u32| mags[o] - cat_mag[star as usize];
        // Screened with all matches (rare: no allocation otherwise).
        let candidates: Vec<(usize, f64)> = self
            .scratch
            .matches
            .iter()
            .enumerate()
            .filter_map(|(o, m)| m.map(|(star, d)| (o, star, d)))
            .filter(|&(o, star, d)| {
                d > screen && (offset - off(o, star)) / spread > JOINT_SCREEN_SIGMAS
            })
            .map(|(o, star, _)| (o, off(o, star)))
            .collect();
        let mut drop = Vec::new();
        for &(o, off) in &candidates {
            // Brighter than its star by z spreads, and z_pos noise out: judged by the others
            // (their offset and spread; their attitude and noise).
            let Some((offset, spread)) = centre(&mut self.scratch, Some(o)) else {
                continue;
            };
            let z = (offset - off) / spread;
            let Some((_, far, noise)) = self.without(o, r, obs) else {
                continue;
            };
            let z_pos = far / noise.max(1e-12);
            if z <= 2.0 || z_pos <= 2.0 {
                continue;
            }
            // ln of the two tails: Rayleigh exp(−z²/2), and the normal tail's Mills-ratio
            // bound φ(z)/z (an upper bound: the test errs towards keeping).
            let ln_pos = -0.5 * z_pos * z_pos;
            let ln_mag = -0.5 * z * z - (z * (2.0 * PI).sqrt()).ln();
            // Fisher: −2 Σ ln p is χ² with 4 degrees of freedom, whose tail at 2L is e^−L (1 + L).
            let l = -(ln_pos + ln_mag);
            if (-l).exp() * (1.0 + l) < JOINT_OUTLIER_TAIL {
                drop.push(o);
            }
        }
        for &o in &drop {
            self.scratch.matches[o] = None;
        }
        drop.len()
    }
}

/// A match whose residual exceeds this many times the noise of the others (under their own
/// attitude) is a coincidence, not its star: a Rayleigh tail of 1.5e-8.
pub(super) const OUTLIER_SIGMAS: f64 = 6.0;

/// Most rounds of judging a solution's matches again at the noise measured.
pub(super) const NOISE_REJUDGE_ROUNDS: usize = 3;

/// A measured noise below this fraction of the step's has a solution's matches judged again.
pub(super) const NOISE_REJUDGE_BELOW: f64 = 1.0;

/// Chance, under the noise a solution was judged with, of the spots a wider radius adds: below
/// it the noise is refused as too small (see `Search::noise_too_small`).
pub(super) const NOISE_REFUSE_TAIL: f64 = 1e-3;

/// Fewest matches whose residuals judge a stated noise too large.
pub(super) const NOISE_MEASURE_MIN_MATCHES: usize = 6;

/// Combined chance (Fisher's method over position and brightness) below which a match is a
/// false spot on a star's place (see `Search::drop_joint_outliers`): a real star is lost once
/// in 10⁴.
pub(super) const JOINT_OUTLIER_TAIL: f64 = 1e-4;

/// Spreads brighter than the frame's offset (all matches counted) from which a match is tested
/// jointly (see `Search::drop_joint_outliers`).
pub(super) const JOINT_SCREEN_SIGMAS: f64 = 1.5;

/// Noise σ out (judged with all matches) from which a match is tested jointly: judged by the
/// others, whose attitude it no longer pulls, it may lie further out.
pub(super) const JOINT_SCREEN_POS_SIGMAS: f64 = 1.5;

/// Least magnitude spread the joint test assumes: a few matches of nearly equal offsets must
/// not make a 0.1 mag difference remarkable.
pub(super) const JOINT_MIN_SPREAD_MAG: f64 = 0.1;
