//! Three-star identification: a lone triangle, named where its own evidence passes the bound.
//!
//! A frame of three real stars among false spots has no fourth star to confirm a Pyramid
//! hypothesis, and the verification's binomial tail has nothing left to count. Its evidence is the
//! triangle itself: three sides within the centroid noise and, with magnitudes in the catalogue's
//! system, three magnitudes.
//!
//! # The test
//! 1. Every triple of the brightest [`LONE_SEARCH_STARS`] spots whose angles are all well open
//!    ([`LONE_MIN_SIN`]) is looked up as the Pyramid looks a triangle up (sides within
//!    `ε = 3·√2·σ` at the noise ladder's first step, magnitude windows where the zero point is
//!    known, both handednesses unless mirrored frames are refused).
//! 2. Each catalogue triangle found gets the statistic `s = Σ (Δd/σ_d)² + Σ (Δm/σ_m)²` over its
//!    three sides (`σ_d = √2·σ`, the noise of an angle between two centroids) and, with
//!    magnitudes, its three magnitudes, at each magnitude scale `σ_m` of a small grid (a twelfth
//!    to a third of `mag_tolerance`; the bound counts each scale tried).
//! 3. Two kinds of wrong triangle can fit, and `Λ`, a candidate's expected rivals over the frame,
//!    adds them:
//!    - *Chance*: a catalogue triangle that happens to fit a triple. At each triple, `D_t` is
//!      the density of catalogue triangles in the space of the statistic at the triple's own
//!      sides and magnitudes: the catalogue pairs per radian at a side's length (counted in the
//!      pair index, both orders) times the stars per steradian around a pair (the catalogue's
//!      pair-weighted density, [`Solver::pair_weighted_density`], doubled for clustering below
//!      its scale) over the sine of the angle opposite (the area element of the other two
//!      sides), times the catalogue's magnitude density at each spot's magnitude; the largest of
//!      the three sides' estimates, doubled where both handednesses are tried. With magnitudes,
//!      a chance triangle must also have its field to itself (step 4), which the catalogue's
//!      own triangles do with the fraction `q(F)` of their faintest magnitude `F` (sampled over
//!      the sky for the camera, see the `empty` module). The expected count at the statistic
//!      `s` or better is `q·D_t·V_k(s)`, `V_k(s)` the volume of `{statistic ≤ s}` (`k` = 3
//!      sides, 6 with magnitudes); `Λ` counts it over every triple searched.
//!    - *A wrong third star*: two real stars whose pair is right, and a false spot that lands on
//!      a catalogue star. Step 4 names a lone triangle only where no fourth spot matches, so a
//!      frame of three real stars or more cannot pass so (its real third star would be matched):
//!      the frame holds one real pair, and its wrong third star comes from the stars of the
//!      candidate's own field (counted around its boresight, plus a Poisson margin) over the
//!      `s − 2` other spots.
//!
//!    Candidates of `Λ ≤ Λ₀` then number at most `Λ₀` of each kind in expectation, and the
//!    reported false-match bound is `2·Λ` times the scales tried.
//! 4. The best candidate is named where its bound is at most `max_false_match_prob`, no other
//!    assignment comes within [`LONE_AMBIGUITY`] of the limit, no fourth spot lands on a catalogue
//!    star under its attitude, and, with magnitudes, no other catalogue star on the sensor is
//!    brighter than its faintest star by more than `mag_tolerance` (a real frame of three stars
//!    has none: the sensor's limit lies beyond the faintest star it imaged).
//!
//! The statistic's scales (`σ`, `σ_m`) only set its shape: a noise stated wrong costs the test
//! its power, not its honesty (a real triangle outside the window is simply not found). On
//! frames made to hold no real star (K1's spots moved at random), the rate of false reports
//! stays under the limit set (0.13 % at 1 %, 1.3 % at 10 %).

use std::f64::consts::{PI, SQRT_2};

use nalgebra::{Rotation3, Vector3};

use super::frame::{magnitude_window, return_scratch, take_prepared, Call};
use super::search::FrameBuffers;

use super::{
    Identification, Search, Solver, Verified, LONE_MIN_MATCHES, MATCH_RADIUS_SIGMAS,
    SIGMA_LADDER_PX,
};
use crate::attitude::{triad, wahba_from};
use crate::geometry::angle_between;
use crate::kvector::AngleWindow;

/// Spots, brightest first, whose triples a lone-triangle search tries.
pub const LONE_SEARCH_STARS: usize = 56;

/// Smallest sine of a triple's angles: a thin triangle fixes its third star along one line only.
pub const LONE_MIN_SIN: f64 = 0.1;

/// Factor on the pair-weighted density for clustering below the scale it is counted at.
pub const LONE_DENSITY_MARGIN: f64 = 2.0;

/// Stars added to a field's catalogue count for the density of its stars (a Poisson margin,
/// and the density of a field with none).
const LOCAL_MARGIN_STARS: f64 = 3.0;

/// A second assignment whose bound is within this factor of the limit makes the answer
/// ambiguous, and nothing is named.
pub const LONE_AMBIGUITY: f64 = 10.0;

/// Half-width (rad) of the window the pair index counts a side's pairs in.
const PAIR_DENSITY_HALF_WIDTH_RAD: f64 = 1e-3;

/// Half-width (mag) of the window the catalogue's magnitude density is counted in.
const MAG_DENSITY_HALF_WIDTH: f64 = 0.25;

/// The statistic's magnitude scales, as fractions of `mag_tolerance`: the test is made at each,
/// and the bound multiplied by their number.
const MAG_SCALE_FRACTIONS: [f64; 3] = [1.0 / 12.0, 1.0 / 6.0, 1.0 / 3.0];

/// Quantile of the statistic a real triangle reaches with this chance at least: where even it
/// would not pass, the frame is not searched.
const PRESCREEN_QUANTILE: f64 = 0.05;

/// Most catalogue stars whose neighbour counts [`Solver::pair_weighted_density`] takes (more: an
/// even sample of them).
const DENSITY_SAMPLE_STARS: usize = 20_000;

impl Solver {
    /// The lone-triangle test of a frame (see the module's notes): the three stars named where
    /// the bound allows, or `None`. Only for the camera as given (a search over focal lengths
    /// would have to count each), with `min_matches` at most 3.
    pub(crate) fn search_lone(&self, call: Call<'_>) -> Option<Identification> {
        let (centroids, magnitudes, _, config, start) = call.parts();
        let n = centroids.len();
        if n < 3 || config.min_matches > LONE_MIN_MATCHES {
            return None;
        }
        let (mut scratch, mut frame) = take_prepared(&call);
        let FrameBuffers {
            obs,
            obs_mirrored,
            order,
            ..
        } = &mut frame;
        let offset = config
            .mag_offset
            .filter(|_| self.magnitudes_fit(magnitudes, config));
        let windows: Option<Vec<[f32; 2]>> = offset.zip(magnitudes).map(|(off, m)| {
            m.iter()
                .map(|&x| magnitude_window(x, off, config.mag_tolerance))
                .collect()
        });
        let sigma_px = config.noise_ladder(&SIGMA_LADDER_PX)[0];
        let stride = n.min(LONE_SEARCH_STARS);
        scratch.forget_side_ranges(stride);
        scratch.side_cache.reset(stride);
        let mut search = Search::of_call(self, call, [obs, obs_mirrored], order, scratch, stride);
        search.gate = windows.as_deref();
        let found = search.lone_triangle(sigma_px, offset);
        let hypotheses = search.hypotheses;
        let mut scratch = search.scratch;
        scratch.frame = frame;
        return_scratch(scratch);
        found.map(|v| {
            let mut id = v.into_identification(hypotheses, start.elapsed());
            id.method = config.method;
            id
        })
    }

    /// Catalogue stars per steradian around a catalogue pair: `∫ρ³ / ∫ρ²`, from each star's
    /// neighbour count `c` within half the index's angle as `Σc² / Σc / area` (an even sample of
    /// at most [`DENSITY_SAMPLE_STARS`] stars), never below the sky's mean. Computed once.
    pub(crate) fn pair_weighted_density(&self) -> f64 {
        *self.pair_density.get_or_init(|| {
            let catalog = &*self.catalog;
            let n = catalog.len().max(1);
            let mean = n as f64 / (4.0 * PI);
            let radius = 0.5 * self.pairs.max_angle_rad();
            let area = 2.0 * PI * (1.0 - radius.cos());
            let step = n.div_ceil(DENSITY_SAMPLE_STARS);
            let (mut s1, mut s2) = (0.0, 0.0);
            for v in catalog.vectors().iter().step_by(step) {
                let c = catalog.count_in_cone(v, radius).saturating_sub(1) as f64;
                s1 += c;
                s2 += c * c;
            }
            if s1 > 0.0 {
                (s2 / s1 / area).max(mean)
            } else {
                mean
            }
        })
    }

    /// Catalogue stars per magnitude at magnitude `m`, as a fraction of the catalogue: the count
    /// within `m ± half_width`, over the window's width.
    pub(crate) fn magnitude_density(&self, m: f64, half_width: f64) -> f64 {
        let sorted = &self.mag_sorted;
        let (lo, hi) = ((m - half_width) as f32, (m + half_width) as f32);
        let count = sorted.count_at_most(hi) - sorted.count_at_most(lo);
        count as f64 / (2.0 * half_width * sorted.len().max(1) as f64)
    }
}

/// A candidate: `λ` (its expected chance rivals at its own triple), centroids, catalogue
/// stars, mirrored.
type Candidate = (f64, [usize; 3], [u32; 3], bool);

impl Search<'_> {
    /// The lone-triangle test over the frame at centroid noise `sigma_px` (see the module's
    /// notes); `mag_offset` the zero point when the search is gated by magnitude.
    pub(super) fn lone_triangle(
        &mut self,
        sigma_px: f64,
        mag_offset: Option<f64>,
    ) -> Option<Verified> {
        let f = self.camera.focal_length_px;
        let sigma = sigma_px / f;
        let sigma_d = SQRT_2 * sigma;
        let eps = 3.0 * sigma_d + 1e-7;
        let eps_trig = [eps.cos(), eps.sin()];
        let mags = self
            .magnitudes
            .zip(mag_offset)
            .filter(|_| self.gate.is_some());
        let handedness = if self.config.allow_mirrored { 2.0 } else { 1.0 };
        let rho = self.solver.pair_weighted_density() * LONE_DENSITY_MARGIN;
        let s = self.order.len().min(LONE_SEARCH_STARS);
        let search: Vec<usize> = self.order[..s].to_vec();
        let obs = self.obs[0];
        let max_angle = self.pairs.max_angle_rad() - eps;
        // Per spot: the catalogue's magnitude density (per magnitude, a fraction of the
        // catalogue) at its catalogue-system magnitude; 1 without magnitudes.
        let g: Vec<f64> = search
            .iter()
            .map(|&o| {
                mags.map_or(1.0, |(m, off)| {
                    self.solver
                        .magnitude_density(m[o] - off, MAG_DENSITY_HALF_WIDTH)
                })
            })
            .collect();
        // Per spot pair (search positions): the angle and the catalogue's unordered pairs per
        // radian at it.
        let mut angle = vec![0.0; s * s];
        let mut pair_density = vec![0.0; s * s];
        for a in 0..s {
            for b in a + 1..s {
                let t = angle_between(&obs[search[a]], &obs[search[b]]);
                let (lo, hi) = (
                    (t - PAIR_DENSITY_HALF_WIDTH_RAD).max(0.0),
                    t + PAIR_DENSITY_HALF_WIDTH_RAD,
                );
                let count = self.pairs.range(lo, hi).len() as f64;
                for k in [a * s + b, b * s + a] {
                    angle[k] = t;
                    pair_density[k] = count / (hi - lo);
                }
            }
        }
        // The triples searched, each with its densities: `[D_t, M_t]`, the catalogue triangles
        // per unit volume of the statistic's space at its sides and magnitudes (chance), and the
        // third stars per unit volume of theirs should one of its pairs be real (two real stars).
        let mut triples: Vec<([usize; 3], [f64; 2])> = Vec::new();
        for c in 2..s {
            for b in 1..c {
                for a in 0..b {
                    let (t_ab, t_ac, t_bc) = (angle[a * s + b], angle[a * s + c], angle[b * s + c]);
                    let (lo, hi) = (t_ab.min(t_ac).min(t_bc), t_ab.max(t_ac).max(t_bc));
                    if hi > max_angle || lo < 2.0 * eps {
                        continue;
                    }
                    // Sines of the angles at a, b and c (the spherical law of cosines).
                    let sin_at = |opp: f64, x: f64, y: f64| {
                        let cos = (opp.cos() - x.cos() * y.cos()) / (x.sin() * y.sin());
                        (1.0 - cos * cos).max(0.0).sqrt()
                    };
                    let sines = [
                        sin_at(t_bc, t_ab, t_ac),
                        sin_at(t_ac, t_ab, t_bc),
                        sin_at(t_ab, t_ac, t_bc),
                    ];
                    if sines.iter().any(|&x| x < LONE_MIN_SIN) {
                        continue;
                    }
                    let (i, j, k) = (search[a], search[b], search[c]);
                    let tp_obs = obs[i].dot(&obs[j].cross(&obs[k]));
                    if tp_obs.abs() < 3.0 * sigma * (t_ab + t_ac + t_bc) {
                        continue;
                    }
                    // Each side (its spots' search positions) with the vertex opposite it, and
                    // that vertex's sine.
                    let sides = [
                        ((a, b), c, sines[2]),
                        ((a, c), b, sines[1]),
                        ((b, c), a, sines[0]),
                    ];
                    let chance = sides
                        .iter()
                        .map(|&((p, q), _, sine)| 2.0 * pair_density[p * s + q] / sine)
                        .fold(0.0, f64::max)
                        * g[a]
                        * g[b]
                        * g[c];
                    let mixed: f64 = sides.iter().map(|&(_, v, sine)| g[v] / sine).sum();
                    triples.push(([a, b, c], [handedness * rho * chance, handedness * mixed]));
                }
            }
        }
        if triples.is_empty() {
            return None;
        }
        let (k_full, k_rest) = if mags.is_some() { (6, 3) } else { (3, 2) };
        // The statistic at each magnitude scale of the grid (one without magnitudes).
        let scales: &[f64] = if mags.is_some() {
            &MAG_SCALE_FRACTIONS
        } else {
            &[1.0]
        };
        let tolerance = self.config.mag_tolerance;
        // With magnitudes, a chance triangle must also have its field to itself.
        let empty = mags.map(|_| self.solver.empty_fields(self.camera, tolerance));
        let least_pass = empty.as_ref().map_or(1.0, |e| e.least());
        // `Λ`: a candidate's expected rivals over the frame, chance triangles of every triple
        // searched (each passing the field check with fraction `pass`) and wrong third stars of
        // a real pair (the one a frame of two real stars holds: see the module's notes).
        let weights = [triples.len() as f64, (s - 2) as f64];
        // (`local`: the stars per steradian in the candidate's own field, where a real pair puts
        // the third star.)
        let rivals = |stat: f64, scale: usize, [chance, mixed]: [f64; 2], pass: f64, local: f64| {
            let sigma_m = scales[scale] * tolerance;
            let (full, rest) = if mags.is_some() {
                (sigma_m.powi(3), sigma_m)
            } else {
                (1.0, 1.0)
            };
            weights[0] * pass * ball_volume(k_full, stat) * sigma_d.powi(3) * full * chance
                + weights[1] * ball_volume(k_rest, stat) * sigma_d.powi(2) * rest * mixed * local
        };
        // Candidates of `Λ ≤ Λ₀` number at most `Λ₀` of each kind in expectation; each scale
        // tried counts.
        let bound = |lam: f64| 2.0 * scales.len() as f64 * lam;
        let limit = self.config.max_false_match_prob;
        let typical = chi_square_quantile(k_full, PRESCREEN_QUANTILE);
        let cone = 0.5 * self.camera.diagonal_fov_rad();
        let cone_area = 2.0 * PI * (1.0 - cone.cos());
        let sparsest = LOCAL_MARGIN_STARS / cone_area;
        let most_favourable = (0..scales.len())
            .flat_map(|k| triples.iter().map(move |t| (k, t.1)))
            .map(|(k, d)| bound(rivals(typical, k, d, least_pass, sparsest)))
            .fold(f64::INFINITY, f64::min);
        if most_favourable > limit {
            return None;
        }
        // The search: every catalogue triangle of every triple that could matter (its bound
        // within LONE_AMBIGUITY of the limit), its `Λ` at each scale, the best and second best.
        let mut best: Vec<Option<Candidate>> = vec![None; scales.len()];
        let mut second = vec![f64::INFINITY; scales.len()];
        let mut found = std::mem::take(&mut self.scratch.triangles);
        let cat = self.solver.catalog.vectors();
        let cat_mag = self.solver.catalog.mag();
        let mag_index = mags.is_some().then(|| self.solver.mag_pair_index());
        let matters = LONE_AMBIGUITY * limit;
        for (visited, &([a, b, c], densities)) in triples.iter().enumerate() {
            if visited % 64 == 0 && self.spent().is_some() {
                self.scratch.triangles = found;
                return None;
            }
            let (i, j, k) = (search[a], search[b], search[c]);
            self.tri_pos = [a, b, c];
            let t = [angle[a * s + b], angle[a * s + c], angle[b * s + c]];
            let windows = t.map(|x| AngleWindow::around(x, [x.cos(), x.sin()], eps, eps_trig));
            match (mag_index, self.gate) {
                (Some(index), Some(gate)) => {
                    let g3 = [gate[i], gate[j], gate[k]];
                    self.catalogue_triangles_gated(index, windows, g3, &mut found);
                }
                _ => self.catalogue_triangles(windows, &mut found),
            }
            let tp_obs = obs[i].dot(&obs[j].cross(&obs[k]));
            for &[ca, cb, cc] in &found {
                let (va, vb, vc) = (&cat[ca as usize], &cat[cb as usize], &cat[cc as usize]);
                let mirrored = (va.dot(&vb.cross(vc)) > 0.0) != (tp_obs > 0.0);
                if mirrored && !self.config.allow_mirrored {
                    continue;
                }
                self.hypotheses += 1;
                let cat_sides = [
                    angle_between(va, vb),
                    angle_between(va, vc),
                    angle_between(vb, vc),
                ];
                let geometric: f64 = t
                    .iter()
                    .zip(cat_sides)
                    .map(|(o, c)| ((o - c) / sigma_d).powi(2))
                    .sum();
                // Squared magnitude differences, in magnitudes².
                let photometric = mags.map_or(0.0, |(m, off)| {
                    [(i, ca), (j, cb), (k, cc)]
                        .iter()
                        .map(|&(o, star)| (m[o] - off - cat_mag[star as usize]).powi(2))
                        .sum::<f64>()
                });
                let stars = [ca, cb, cc];
                let faintest = stars
                    .iter()
                    .map(|&x| cat_mag[x as usize])
                    .fold(f64::NEG_INFINITY, f64::max);
                let pass = empty.as_ref().map_or(1.0, |e| e.pass_fraction(faintest));
                // The field, looked at once per candidate and only where it could matter: with
                // magnitudes it must be the triangle's own, and its star count gives the density
                // a real pair's wrong third star would come from.
                let mut field: Option<Option<f64>> = None;
                for scale in 0..scales.len() {
                    let sigma_m = scales[scale] * tolerance;
                    let stat = geometric + photometric / (sigma_m * sigma_m);
                    if bound(rivals(stat, scale, densities, pass, sparsest)) > matters {
                        continue;
                    }
                    let local = *field.get_or_insert_with(|| {
                        self.field_of([i, j, k], stars, mirrored)
                            .filter(|f| f.0 || mags.is_none())
                            .map(|f| (f.1 as f64 + LOCAL_MARGIN_STARS) / cone_area)
                    });
                    let Some(local) = local else { break };
                    let lam = rivals(stat, scale, densities, pass, local);
                    if bound(lam) > matters {
                        continue;
                    }
                    match &best[scale] {
                        Some(b) if lam >= b.0 => second[scale] = second[scale].min(lam),
                        b => {
                            if let Some(b) = b {
                                second[scale] = second[scale].min(b.0);
                            }
                            best[scale] = Some((lam, [i, j, k], stars, mirrored));
                        }
                    }
                }
            }
        }
        self.scratch.triangles = found;
        // The scale whose best candidate has the smallest bound.
        let (scale, false_prob) = best
            .iter()
            .enumerate()
            .filter_map(|(k, b)| b.map(|b| (k, bound(b.0))))
            .min_by(|x, y| x.1.total_cmp(&y.1))?;
        let (_, spots, stars, mirrored) = best[scale]?;
        let r = self.triangle_attitude(spots, stars, mirrored)?;
        let obs = self.obs[usize::from(mirrored)];
        let matched = self.match_all(&r, obs, MATCH_RADIUS_SIGMAS * sigma, sigma);
        // Exactly the three: a frame of more real stars is the verification's, and a wrong third
        // star of a real pair would leave the real third one matched.
        let named = spots
            .iter()
            .zip(&stars)
            .all(|(&o, &star)| self.scratch.matches[o].is_some_and(|m| m.0 == star));
        if matched != 3 || !named || false_prob > limit || bound(second[scale]) <= matters {
            return None;
        }
        let matches = std::mem::take(&mut self.scratch.matches);
        Some(Verified {
            r,
            mirrored,
            matches,
            matched: 3,
            sigma_px,
            step_sigma_px: sigma_px,
            radius_rad: MATCH_RADIUS_SIGMAS * sigma,
            tail: false_prob,
            false_prob,
            verified: true,
            has_attitude: true,
        })
    }

    /// The attitude of centroids `spots` seen as catalogue stars `stars`.
    fn triangle_attitude(
        &self,
        spots: [usize; 3],
        stars: [u32; 3],
        mirrored: bool,
    ) -> Option<Rotation3<f64>> {
        let obs = self.obs[usize::from(mirrored)];
        let cat = self.solver.catalog.vectors();
        let o3 = spots.map(|o| obs[o]);
        let c3 = stars.map(|c| cat[c as usize]);
        let start = triad(&o3[0], &o3[1], &c3[0], &c3[1])?;
        wahba_from(&o3, &c3, &start)
    }

    /// The field of the triangle of `spots` as `stars`: whether it has the field to itself (no
    /// other catalogue star on the sensor brighter than its faintest by more than
    /// `mag_tolerance`: a real frame of three stars has none, as one imaged would be a fourth
    /// match and the detection limit lies beyond the faintest star imaged), and the catalogue
    /// stars within half the diagonal of its boresight. `None` without an attitude.
    fn field_of(
        &self,
        spots: [usize; 3],
        stars: [u32; 3],
        mirrored: bool,
    ) -> Option<(bool, usize)> {
        let r = self.triangle_attitude(spots, stars, mirrored)?;
        let catalog = &*self.solver.catalog;
        let (cat_mag, cat) = (catalog.mag(), catalog.vectors());
        let cam = self.camera;
        let faintest = stars
            .iter()
            .map(|&c| cat_mag[c as usize])
            .fold(f64::NEG_INFINITY, f64::max);
        let brighter_than = faintest - self.config.mag_tolerance;
        let boresight = r.inverse_transform_vector(&Vector3::z());
        let (mut alone, mut count) = (true, 0);
        catalog.for_each_in_cone(&boresight, 0.5 * cam.diagonal_fov_rad(), |star, _| {
            count += 1;
            if !alone || cat_mag[star as usize] >= brighter_than || stars.contains(&star) {
                return;
            }
            // (The sensor's rectangle is symmetric: a mirrored frame covers the same stars.)
            if let Some((x, y)) = cam.cam_to_pixel(&(r * cat[star as usize])) {
                alone = !((0.0..cam.width_px).contains(&x) && (0.0..cam.height_px).contains(&y));
            }
        });
        Some((alone, count))
    }
}

/// Volume of the unit ball in `k` dimensions times `s^{k/2}`: the volume of `{Σ x² ≤ s}`.
fn ball_volume(k: usize, s: f64) -> f64 {
    let unit = match k {
        2 => PI,
        3 => 4.0 / 3.0 * PI,
        6 => PI.powi(3) / 6.0,
        _ => unreachable!("the statistic has 2, 3 or 6 dimensions"),
    };
    unit * s.max(0.0).powf(0.5 * k as f64)
}

/// The `q` quantile of the χ² distribution with `k` (3 or 6) degrees of freedom, for small `q`.
fn chi_square_quantile(k: usize, q: f64) -> f64 {
    // The lower tail: P(χ²_k ≤ x) = P(k/2, x/2), found by bisection on the series of the
    // regularized lower incomplete gamma function.
    let cdf = |x: f64| {
        let (a, h) = (0.5 * k as f64, 0.5 * x);
        let mut term = 1.0 / a;
        let mut sum = term;
        for n in 1..200 {
            term *= h / (a + n as f64);
            sum += term;
            if term < 1e-15 * sum {
                break;
            }
        }
        (sum * (-h + a * h.ln() - ln_gamma_half(k)).exp()).min(1.0)
    };
    let (mut lo, mut hi) = (0.0, 4.0 * k as f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < q {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// `ln Γ(k/2)` for `k` = 3 or 6.
fn ln_gamma_half(k: usize) -> f64 {
    match k {
        3 => (0.5 * PI.sqrt()).ln(),
        6 => 2f64.ln(),
        _ => unreachable!("the statistic has 3 or 6 dimensions"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_square_quantiles_match_tables() {
        // Tabled: χ²_3 0.05 → 0.352, χ²_6 0.05 → 1.635.
        assert!((chi_square_quantile(3, 0.05) - 0.3518).abs() < 1e-3);
        assert!((chi_square_quantile(6, 0.05) - 1.6354).abs() < 1e-3);
        assert!((chi_square_quantile(6, 0.5) - 5.348).abs() < 1e-2);
    }

    #[test]
    fn ball_volumes() {
        assert!((ball_volume(2, 4.0) - 4.0 * PI).abs() < 1e-12);
        assert!((ball_volume(3, 1.0) - 4.18879).abs() < 1e-5);
    }
}
