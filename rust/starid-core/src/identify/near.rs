//! Spots matched to their nearest catalogue stars: the stars near each spot looked up once per
//! hypothesis (`NearCache`), resolved doubles and contested claims (`Claims`).

use nalgebra::{Rotation3, Vector3};

use super::*;
use crate::catalog::Catalog;
use crate::sky::Radius;

/// What the nearest allowed catalogue stars to a centroid say.
pub(super) enum Nearest {
    /// No allowed star within the radius.
    None,
    /// One star, decisively nearest: `(star, distance)`.
    Unique(u32, f64),
    /// Two stars nearly as likely: `[(star, distance); 2]`.
    Ambiguous([(u32, f64); 2]),
}

/// A catalogue star near a direction: its index and squared distance (the sine of the angle,
/// squared).
pub(super) type Near = (u32, f64);

/// How much wider than asked the stars near each centroid are looked up (see [`NearCache`]).
pub(super) const NEAR_CACHE_GROWTH: f64 = 2.5;

/// The catalogue stars near each centroid under one attitude, looked up within a radius
/// [`NEAR_CACHE_GROWTH`] times the match radius: a later matching pass (the refit attitude, a
/// smaller or slightly larger radius) that moves no centroid by more than the spare radius
/// finds every star it could match among them, and asks the catalogue nothing. A verification
/// so looks each centroid up about once instead of once per pass.
#[derive(Debug, Default)]
pub(super) struct NearCache {
    pub(super) valid: bool,
    /// The observed directions looked up (their address and length: the search's two
    /// handednesses are two slices).
    pub(super) key: (usize, usize),
    pub(super) radius_rad: f64,
    /// Each centroid in ICRS under the attitude looked up, and under the current pass's.
    pub(super) looked_up: Vec<Vector3<f64>>,
    pub(super) w: Vec<Vector3<f64>>,
    /// `start[o]..start[o + 1]`: the stars near centroid `o`, with their ICRS vectors.
    pub(super) start: Vec<u32>,
    pub(super) stars: Vec<(u32, Vector3<f64>)>,
}

impl NearCache {
    /// Forget the stars: the next pass looks every centroid up.
    pub(super) fn clear(&mut self) {
        self.valid = false;
    }

    /// Place every centroid of `obs` under `r` (`self.w`) and make sure the stars within
    /// `radius` of each are held.
    pub(super) fn ensure(
        &mut self,
        catalog: &Catalog,
        r: &Rotation3<f64>,
        obs: &[Vector3<f64>],
        radius: f64,
    ) {
        let key = (obs.as_ptr() as usize, obs.len());
        self.w.clear();
        self.w
            .extend(obs.iter().map(|v| r.inverse_transform_vector(v)));
        if self.valid && self.key == key {
            // The farthest any centroid moved since the look-up, squared.
            let moved = self
                .w
                .iter()
                .zip(&self.looked_up)
                .map(|(a, b)| (a - b).norm_squared())
                .fold(0.0, f64::max);
            // (A chord: the angle exceeds it by a factor 1 + θ²/24 at most, far below 1e-6.)
            let spare = (self.radius_rad - radius) * (1.0 - 1e-6);
            if spare >= 0.0 && moved <= spare * spare {
                return;
            }
        }
        let wide = NEAR_CACHE_GROWTH * radius;
        let around = Radius::new(wide);
        self.start.clear();
        self.stars.clear();
        self.start.push(0);
        for w in &self.w {
            let stars = &mut self.stars;
            catalog.for_each_near(w, around, |star, _, v| stars.push((star, *v)));
            self.start.push(self.stars.len() as u32);
        }
        self.looked_up.clear();
        self.looked_up.extend_from_slice(&self.w);
        (self.valid, self.key, self.radius_rad) = (true, key, wide);
    }

    /// Whether a third held star within `radius` of centroid `o` (as placed by the last
    /// `ensure`) is nearly as likely as the nearest: its squared distance exceeds the nearest's
    /// by less than `decisive`.
    pub(super) fn third_as_likely(&self, o: usize, radius: Radius, decisive: f64) -> bool {
        let (a, b) = (self.start[o] as usize, self.start[o + 1] as usize);
        let w = &self.w[o];
        let mut d2 = [f64::INFINITY; 3];
        for (_, v) in &self.stars[a..b] {
            if v.dot(w) < radius.cos() {
                continue;
            }
            let d = w.cross(v).norm_squared();
            // Keep the three smallest, ascending.
            if d < d2[2] {
                d2[2] = d;
                d2.sort_unstable_by(f64::total_cmp);
            }
        }
        d2[2] - d2[0] < decisive
    }

    /// The nearest two held stars within `radius` of centroid `o` (as placed by the last
    /// `ensure`), as `catalog.nearest_two` would give them, with their squared distances (the
    /// square roots are taken only for the match kept: see [`nearest_match`]).
    #[inline]
    pub(super) fn nearest_two(&self, o: usize, radius: Radius) -> (Option<Near>, Option<Near>) {
        let (a, b) = (self.start[o] as usize, self.start[o + 1] as usize);
        let held = &self.stars[a..b];
        let w = &self.w[o];
        // Most centroids hold one star or none (the cache radius is a few pixels).
        match held {
            [] => return (None, None),
            [(star, v)] => {
                let near = v.dot(w) >= radius.cos();
                return (near.then(|| (*star, w.cross(v).norm_squared())), None);
            }
            _ => {}
        }
        // Cosines (larger is nearer) and positions in `held`; none yet is usize::MAX.
        let floor = radius.cos();
        let (mut best, mut second) = (
            (usize::MAX, f64::NEG_INFINITY),
            (usize::MAX, f64::NEG_INFINITY),
        );
        for (k, (_, v)) in held.iter().enumerate() {
            let c = v.dot(w);
            if c < floor {
                continue;
            }
            if c > best.1 {
                second = best;
                best = (k, c);
            } else if c > second.1 {
                second = (k, c);
            }
        }
        let near = |(k, _): (usize, f64)| {
            (k != usize::MAX).then(|| (held[k].0, w.cross(&held[k].1).norm_squared()))
        };
        (near(best), near(second))
    }
}

/// Which centroid last claimed each catalogue star in this matching pass: the stars claimed
/// twice found in one pass over the claims, with no sort. Stamped by pass, so nothing is cleared
/// between passes.
#[derive(Debug, Default)]
pub(super) struct Claims {
    pub(super) pass: u32,
    /// Per catalogue star: the pass that last claimed it, and the centroid.
    pub(super) stamp: Vec<(u32, u32)>,
    /// The centroids `unmatch_contested` unmatches.
    pub(super) contested: Vec<u32>,
}

impl Claims {
    /// Unmatch every centroid of `claim` (star, centroid, distance) whose star another centroid
    /// also claims.
    pub(super) fn unmatch_shared(
        &mut self,
        claim: &[(u32, u32, f64)],
        matches: &mut [Option<(u32, f64)>],
        n_cat: usize,
    ) {
        if self.stamp.len() != n_cat || self.pass == u32::MAX {
            self.stamp.clear();
            self.stamp.resize(n_cat, (0, 0));
            self.pass = 0;
        }
        self.pass += 1;
        for &(star, o, _) in claim {
            let slot = &mut self.stamp[star as usize];
            if slot.0 == self.pass {
                matches[slot.1 as usize] = None;
                matches[o as usize] = None;
            } else {
                *slot = (self.pass, o);
            }
        }
    }
}

impl Claims {
    /// After [`Self::unmatch_shared`]: unmatch every centroid whose star a centroid with no star
    /// within the radius is nearly as likely to be, by the star-side test of [`nearest_match`]
    /// turned round: its squared distance to the star exceeds the claimant's by less than
    /// `decisive`. Smear can carry a star's own spot just past the radius while a false spot
    /// lies just inside; the nearer of two such spots is no evidence of which is the star.
    /// (A centroid torn between two stars does not contest: a double's two spots would unname
    /// each other.) `allowed(o, star)`: whether centroid `o` may be `star` (the magnitude gate).
    /// The near cache must hold the stars within `√(radius² + decisive)`.
    pub(super) fn unmatch_contested(
        &mut self,
        near: &NearCache,
        matches: &mut [Option<(u32, f64)>],
        radius: Radius,
        decisive: f64,
        allowed: impl Fn(usize, u32) -> bool,
    ) {
        self.contested.clear();
        for (b, m) in matches.iter().enumerate() {
            if m.is_some() {
                continue;
            }
            let w = &near.w[b];
            let (lo, hi) = (near.start[b] as usize, near.start[b + 1] as usize);
            let held = &near.stars[lo..hi];
            // Only a centroid with no star it may be within the radius: one torn between two
            // stars or sharing one is settled by the joint assignment or not at all.
            if held
                .iter()
                .any(|(star, v)| v.dot(w) >= radius.cos() && allowed(b, *star))
            {
                continue;
            }
            for (star, v) in held {
                let Some(&(pass, a)) = self.stamp.get(*star as usize) else {
                    continue;
                };
                if pass != self.pass {
                    continue;
                }
                let Some((claimed, d_a)) = matches[a as usize] else {
                    continue;
                };
                if claimed == *star
                    && w.cross(v).norm_squared() - d_a * d_a < decisive
                    && allowed(b, *star)
                {
                    self.contested.push(a);
                }
            }
        }
        for &a in &self.contested {
            matches[a as usize] = None;
        }
    }
}

/// Whether centroid `o` may be catalogue star `star` in a pass gated by `gate` (always, ungated):
/// a centroid may not be far brighter than its star (one-sided: a saturated or variable star
/// fainter than expected keeps it; `drop_magnitude_outliers` unnames such a match only where
/// another star within the match radius fits the centroid's magnitude).
#[inline]
pub(super) fn gate_allows(gate: Option<&[[f32; 2]]>, mags: &[f32], o: usize, star: u32) -> bool {
    gate.is_none_or(|g| mags[star as usize] <= g[o][1])
}

/// Of the nearest two catalogue stars to a centroid (with squared distances), the nearest that
/// `allowed` admits, and whether a second allowed star is nearly as likely (see
/// [`AMBIGUITY_LOG_ODDS`]); the answer carries distances.
pub(super) fn nearest_match(
    (best, second): (Option<Near>, Option<Near>),
    sigma_rad: f64,
    allowed: impl Fn(u32) -> bool,
) -> Nearest {
    let (best, second) = match (best, second) {
        (Some(b), s) if allowed(b.0) => (b, s.filter(|s| allowed(s.0))),
        (_, Some(s)) if allowed(s.0) => (s, None),
        _ => return Nearest::None,
    };
    if let Some((s2, d2_sq)) = second {
        if d2_sq - best.1 < 2.0 * AMBIGUITY_LOG_ODDS * sigma_rad * sigma_rad {
            return Nearest::Ambiguous([(best.0, best.1.sqrt()), (s2, d2_sq.sqrt())]);
        }
    }
    Nearest::Unique(best.0, best.1.sqrt())
}

/// The nearest catalogue star to `w` within `radius`, unless a second star is nearly as likely
/// (see [`AMBIGUITY_LOG_ODDS`]): an ambiguous match is no match.
pub(super) fn unambiguous_nearest(
    catalog: &Catalog,
    w: &Vector3<f64>,
    radius: Radius,
    sigma_rad: f64,
) -> Option<(u32, f64)> {
    let cat = catalog.vectors();
    let (best, second) = catalog.nearest_two(w, radius);
    let (star, _) = best?;
    // Match radii are far below a degree: the sine of the angle (|w × c|, no libm call) is the
    // angle to better than 1e-5 relative there.
    let d1 = w.cross(&cat[star as usize]).norm();
    if let Some((s2, _)) = second {
        let d2 = w.cross(&cat[s2 as usize]).norm();
        // Decisive only when the nearer star is AMBIGUITY_LOG_ODDS times likelier under
        // Gaussian noise: (d2² − d1²) / 2σ² ≥ ln(odds).
        if d2 * d2 - d1 * d1 < 2.0 * AMBIGUITY_LOG_ODDS * sigma_rad * sigma_rad {
            return None;
        }
    }
    Some((star, d1))
}
