//! Hinted identification, the tracking mode: the attitude is roughly known (the last frame's,
//! propagated), so each spot's star lies within the hint's uncertainty of where the hint puts
//! it. Two spots and their candidate stars make a hypothesis (TRIAD), which must stay within the
//! uncertainty and then passes the shared verification. The false-match bound counts the hint's
//! region instead of the whole sky: the chance that two spots find stars near their predicted
//! places and at the right distance by accident, times the chance that the other matches are
//! coincidences, times the hypotheses tried. A tight hint can so name a frame of two or three
//! stars; a wrong hint finds nothing it can verify, and the search falls back to lost in space.

use std::cell::Cell;
use std::f64::consts::PI;
use std::time::{Duration, Instant};

use nalgebra::{Rotation3, Vector3};

use super::frame::Call;
use super::{
    directions_into, magnitude_window, return_scratch, take_scratch, BrightnessPrefix,
    Identification, IdentifyConfig, Method, Search, Solver, Status,
};
use crate::attitude::triad;
use crate::error::{Error, Result};
use crate::geometry::{angle_between, Camera};
use crate::sky::Radius;

/// Spots (brightest first) whose pairs make tracking hypotheses. A pair costs little here (a
/// false spot finds no star within the hint's reach of where it falls), and frames whose few
/// real stars are faint among bright false spots need the deeper pairs: with 24, 0.14 % of the
/// simulated sequence frames (0–40 false spots) fell back to lost in space; with 64, none did
/// but the first of each sequence.
pub const HINT_SEARCH_STARS: usize = 64;

/// Centroid noise levels (1σ per axis, pixels) tried in turn when none is given.
pub const HINT_SIGMA_LADDER_PX: [f64; 7] = [0.2, 0.35, 0.5, 0.7, 1.0, 1.5, 2.5];

/// Largest hint uncertainty, radians (20°): beyond it, lost in space is the better search.
pub const MAX_HINT_UNCERTAINTY_RAD: f64 = 20.0 * PI / 180.0;

/// Most candidate stars kept per spot (the nearest to its predicted place).
const HINT_MAX_CANDIDATES: usize = 24;

/// The hinted search's own buffers, kept between calls on a thread (see [`HINT_BUFFERS`]).
#[derive(Debug, Default)]
struct HintBuffers {
    /// Each spot's direction in the camera frame, as seen and mirrored.
    obs: Vec<Vector3<f64>>,
    obs_mirrored: Vec<Vector3<f64>>,
    /// Each spot's catalogue-magnitude window (magnitude-gated calls).
    windows: Vec<[f32; 2]>,
    /// The candidate stars of the spots looked up, and each spot's range of them.
    cand: Vec<u32>,
    near: Vec<(f64, u32)>,
    ranges: Vec<Option<(u32, u32)>>,
    /// The spots brightest first, as far as the search asked.
    order: Vec<usize>,
}

thread_local! {
    /// Boxed, as the search's scratch: a call takes and returns a pointer.
    static HINT_BUFFERS: Cell<Option<Box<HintBuffers>>> = const { Cell::new(None) };
}

/// A prior attitude for [`Solver::identify_hinted`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AttitudeHint {
    /// The expected rotation ICRS → camera.
    pub r_icrs_to_cam: Rotation3<f64>,
    /// How far (radians, 1 rotation angle) the true attitude may be from it: the search region.
    pub uncertainty_rad: f64,
    /// The frame's handedness when known (the last frame's); `None` tries both as
    /// `allow_mirrored` says.
    pub mirrored: Option<bool>,
}

/// What [`Solver::identify_hinted`] does when no hypothesis within the hint verifies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HintFallback {
    /// Identify the frame lost in space (the result's `hinted` is then false).
    LostInSpace,
    /// Report the frame unidentified (status `NoMatch`).
    None,
}

/// The false-match accounting of a hinted search (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub(super) struct HintPrior {
    uncertainty_rad: f64,
    pair_tol_rad: f64,
    /// Catalogue stars per steradian in the hinted field (the attitude moves within the
    /// uncertainty only: read once per call, from the solver's density map).
    pub(super) density: f64,
    /// The hint's attitude, where a bound near its limit counts the field's stars exactly.
    pub(super) r_hint: Rotation3<f64>,
}

impl HintPrior {
    /// The chance that a pair of unrelated spots finds a pair of catalogue stars, each within
    /// the hint's reach of its spot's predicted place (`density` stars per steradian, match
    /// `radius`), at a distance that agrees with theirs within the pair tolerance: the expected
    /// number of such star pairs (candidates per spot, squared, times the chance that a
    /// distance agrees), at most 1. The search multiplies it by the spot pairs it examined.
    pub(super) fn base_chance(&self, density: f64, radius: f64) -> f64 {
        let reach = self.uncertainty_rad + radius;
        let per_spot = density * PI * reach * reach;
        let p_pair = (self.pair_tol_rad / self.uncertainty_rad.max(self.pair_tol_rad)).min(1.0);
        (per_spot * per_spot * p_pair).min(1.0)
    }
}

impl AttitudeHint {
    fn check(&self) -> Result<()> {
        let u = self.uncertainty_rad;
        if !(u.is_finite() && u > 0.0 && u <= MAX_HINT_UNCERTAINTY_RAD) {
            // Degrees to 12 significant digits: the radians' round trip shows 30 as 29.999…
            let deg = |r: f64| {
                format!(
                    "{}",
                    format!("{:.12e}", r.to_degrees())
                        .parse::<f64>()
                        .unwrap_or(f64::NAN)
                )
            };
            return Err(Error::invalid_input(format!(
                "hint_uncertainty_deg must be in (0, {}] degrees, got {}",
                deg(MAX_HINT_UNCERTAINTY_RAD),
                deg(u)
            )));
        }
        let m = self.r_icrs_to_cam.matrix();
        if !m.iter().all(|v| v.is_finite()) || (m.determinant() - 1.0).abs() > 1e-6 {
            return Err(Error::invalid_input(
                "the attitude hint must be a finite rotation",
            ));
        }
        Ok(())
    }
}

impl Solver {
    /// Identify a frame whose attitude is roughly known: tracking. See the module
    /// documentation. Results carry `hinted: true` when the hint found them; with
    /// [`HintFallback::LostInSpace`] a frame the hint cannot explain is identified as by
    /// [`Solver::identify`] (`hinted: false`). Frames of two or three stars can be named when
    /// the hint is tight enough for the bound; lost in space needs four.
    ///
    /// The search keeps lost in space's limits: `max_pairs_visited` (each verification counts a
    /// look-up per spot) ends it with [`Status::SearchLimit`], after which the fallback still
    /// runs, and `timeout` covers the whole call, fallback included ([`Status::Timeout`]).
    ///
    /// # Errors
    /// As [`Solver::identify`]; `InvalidInput` for an uncertainty outside (0, 20°] or a
    /// non-finite hint.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, AttitudeHint, Camera, HintFallback, IdentifyConfig, SimConfig, Solver};
    /// use nalgebra::Rotation3;
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    /// let frame = simulate(&cat, &cam, &SimConfig { noise_px: 0.3, ..Default::default() }, 3).unwrap();
    /// // The true attitude, 0.5° off.
    /// let hint = AttitudeHint {
    ///     r_icrs_to_cam: Rotation3::from_euler_angles(0.006, -0.005, 0.004) * frame.r_icrs_to_cam,
    ///     uncertainty_rad: 1f64.to_radians(),
    ///     mirrored: Some(false),
    /// };
    /// let cfg = IdentifyConfig::default();
    /// let id = solver.identify_hinted(&frame.centroids, None, &cam, &cfg, &hint, HintFallback::None).unwrap();
    /// assert!(id.is_identified() && id.hinted);
    /// assert!(id.catalog_index.iter().zip(&frame.catalog_index).all(|(a, b)| a.is_none() || a == b));
    /// ```
    pub fn identify_hinted(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
        hint: &AttitudeHint,
        fallback: HintFallback,
    ) -> Result<Identification> {
        let call = Call::checked(centroids, magnitudes, camera, config)?;
        if !config.verify {
            return Err(Error::invalid_input(
                "verify=false (raw method answers) is for lost-in-space identification only, not with an attitude hint",
            ));
        }
        hint.check()?;
        let start = call.start;
        let n = centroids.len();
        let deadline = config.timeout.map(|t| start + t);
        let status = if n >= 2 {
            match self.search_hinted(call, hint, deadline) {
                Ok(mut id) => {
                    id.elapsed = start.elapsed();
                    return Ok(id);
                }
                Err(status) => status,
            }
        } else {
            Status::TooFewStars
        };
        match fallback {
            // The call's time limit holds for the hinted search and the fallback together.
            HintFallback::LostInSpace if status != Status::Timeout => {
                let mut id = match config.timeout {
                    Some(t) => {
                        let rest = IdentifyConfig {
                            timeout: Some(t.saturating_sub(start.elapsed())),
                            ..config.clone()
                        };
                        self.identify(centroids, magnitudes, camera, &rest)?
                    }
                    None => self.identify(centroids, magnitudes, camera, config)?,
                };
                id.elapsed = start.elapsed();
                Ok(id)
            }
            _ => {
                let mut id = Identification::unidentified(status, n, 0, start.elapsed());
                id.method = config.method;
                id.hinted = true;
                Ok(id)
            }
        }
    }

    fn search_hinted(
        &self,
        call: Call<'_>,
        hint: &AttitudeHint,
        deadline: Option<Instant>,
    ) -> std::result::Result<Identification, Status> {
        let (centroids, magnitudes, camera, config, _) = call.parts();
        let n = centroids.len();
        // This thread's buffers from the last call: a tracking call allocates only its answer.
        let mut bufs = HINT_BUFFERS.with(Cell::take).unwrap_or_default();
        let HintBuffers {
            obs,
            obs_mirrored,
            windows,
            cand,
            near,
            ranges,
            order,
        } = &mut *bufs;
        // The mirrored directions only when that handedness is searched.
        let mirrored_too = hint.mirrored != Some(false);
        directions_into(centroids, camera, mirrored_too, (obs, obs_mirrored));
        let mut order = BrightnessPrefix::new(n, magnitudes, order);
        let handedness: &[bool] = match hint.mirrored {
            Some(false) => &[false],
            Some(true) => &[true],
            None if config.allow_mirrored => &[false, true],
            None => &[false],
        };
        // A finer noise ladder than lost in space's: each step is cheap here, and the match
        // radius follows the step, so a step near the true noise keeps coincidences out.
        let ladder = config.noise_ladder(&HINT_SIGMA_LADDER_PX);
        // With calibrated magnitudes a centroid matches only stars its brightness allows (as
        // lost in space's gated passes do), and the bound counts only those.
        windows.clear();
        let gated = self.magnitudes_fit(magnitudes, config);
        if gated {
            let (m, off, tol) = (
                magnitudes.unwrap_or_default(),
                config.mag_offset.unwrap_or(0.0),
                config.mag_tolerance,
            );
            windows.extend(m.iter().map(|&mi| magnitude_window(mi, off, tol)));
        }
        let windows: Option<&[[f32; 2]]> = gated.then_some(&windows[..]);
        // Tracking names frames of two or three stars when the bound allows.
        let cfg = IdentifyConfig {
            min_matches: 2,
            ..config.clone()
        };
        let mut search = Search::new(
            self,
            camera,
            &cfg,
            [&obs[..], &obs_mirrored[..]],
            magnitudes,
            // Only lost in space's passes read the search's order.
            &[],
            take_scratch(),
        );
        search.method = Method::Auto;
        search.deadline = deadline;
        if let Some(w) = windows {
            search.gate = Some(w);
            search.gate_fraction = self.window_fraction(w);
        }
        let mags32 = self.mag_f32();
        let f = camera.focal_length_px;
        let k = n.min(HINT_SEARCH_STARS);
        let catalog = &*self.catalog;
        let cat = catalog.vectors();
        let mut found = None;
        // Set when the work budget or the time runs out (a frame of thousands of spots, a wide
        // hint): the search ends there, as lost in space's does.
        let mut limit = None;
        let density = search.field_density(&hint.r_icrs_to_cam, false);
        let mut found_step = 0;
        'passes: for (step, &sigma_px) in ladder.iter().enumerate() {
            let sigma_rad = sigma_px / f;
            let tol = 3.0 * std::f64::consts::SQRT_2 * sigma_rad + 1e-6;
            search.hint = Some(HintPrior {
                uncertainty_rad: hint.uncertainty_rad,
                pair_tol_rad: tol,
                density,
                r_hint: hint.r_icrs_to_cam,
            });
            let reach = hint.uncertainty_rad + 3.0 * sigma_rad;
            let r_confirm = 8.0 * sigma_rad + 2e-7;
            // An attitude is within `reach + tol` of the hint when the cosine of the rotation
            // angle between them, (tr(r·hintᵀ) − 1) / 2, is at least that angle's cosine.
            let cos_allowed = (reach + tol).min(PI).cos();
            let h = hint.r_icrs_to_cam;
            let within = |r: &Rotation3<f64>| {
                let t: f64 = r
                    .matrix()
                    .iter()
                    .zip(h.matrix().iter())
                    .map(|(a, b)| a * b)
                    .sum();
                0.5 * (t - 1.0) >= cos_allowed
            };
            for &mirrored in handedness {
                let o = search.obs[usize::from(mirrored)];
                let reach_r = Radius::new(reach);
                // Each spot's candidates (the catalogue stars within reach of its predicted place,
                // nearest first), looked up when a pair first needs them: `cand[ranges[s]]`.
                cand.clear();
                ranges.clear();
                ranges.resize(k, None);
                let mut lookup = |s: usize, cand: &mut Vec<u32>| -> (u32, u32) {
                    let w = h.inverse_transform_vector(&o[s]);
                    near.clear();
                    let allowed =
                        |star: u32| windows.is_none_or(|g| mags32[star as usize] <= g[s][1]);
                    catalog.for_each_near(&w, reach_r, |star, cos, _| {
                        if allowed(star) {
                            near.push((-cos, star));
                        }
                    });
                    if near.len() > HINT_MAX_CANDIDATES {
                        near.select_nth_unstable_by(HINT_MAX_CANDIDATES, |a, b| {
                            a.0.total_cmp(&b.0)
                        });
                        near.truncate(HINT_MAX_CANDIDATES);
                    }
                    near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
                    let start = cand.len() as u32;
                    cand.extend(near.iter().map(|&(_, s)| s));
                    (start, cand.len() as u32)
                };
                search.pairs_visited += k;
                // Pairs of spots, brightest first: by the sum of their brightness ranks.
                let pairs = (1..2 * k.max(1) - 2)
                    .flat_map(|sum| (0..=sum / 2).map(move |i| (i, sum - i)))
                    .filter(|&(i, j)| i < j && j < k);
                for (i, j) in pairs {
                    let top = order.first(j + 1);
                    let (a_obs, b_obs) = (o[top[i]], o[top[j]]);
                    let theta = angle_between(&a_obs, &b_obs);
                    if theta < 10.0 * tol {
                        continue;
                    }
                    // |angle(a, b) − θ| ≤ tol, as cosines.
                    let (cos_lo, cos_hi) =
                        ((theta + tol).min(PI).cos(), (theta - tol).max(0.0).cos());
                    for idx in [i, j] {
                        if ranges[idx].is_none() {
                            ranges[idx] = Some(lookup(top[idx], cand));
                        }
                    }
                    let span = |idx: usize| {
                        let (a, b) = ranges[idx].unwrap_or_default();
                        a as usize..b as usize
                    };
                    let (ci, cj) = (&cand[span(i)], &cand[span(j)]);
                    if ci.is_empty() || cj.is_empty() {
                        continue;
                    }
                    // A spot pair is one trial: the bound's chance of a coincidence is per pair
                    // of spots (all their candidate pairs together), times the pairs examined.
                    search.hypotheses += 1;
                    search.pairs_visited += ci.len() * cj.len();
                    for &a in ci {
                        for &b in cj {
                            if a == b {
                                continue;
                            }
                            let (va, vb) = (cat[a as usize], cat[b as usize]);
                            let c = va.dot(&vb);
                            if c < cos_lo || c > cos_hi {
                                continue;
                            }
                            let Some(r) = triad(&a_obs, &b_obs, &va, &vb) else {
                                continue;
                            };
                            if !within(&r) {
                                continue;
                            }
                            // Each verification looks every spot up: the work the budget counts.
                            if let Some(why) = search.spent() {
                                limit = Some(why);
                                break 'passes;
                            }
                            let v = search.verify(r, mirrored, r_confirm, sigma_rad);
                            if let Some(v) = search.accept(v) {
                                // The verified attitude must still be one the hint allows.
                                if within(&v.r) {
                                    found = Some(v);
                                    found_step = step;
                                    break 'passes;
                                }
                            }
                        }
                    }
                }
            }
        }
        // A tight step can verify with the stars its radius reaches while noisier ones (a smeared
        // frame) stay out: while spots are left, the looser steps re-verify from the solution,
        // and the one that names more stars (within the bound) wins.
        let Some(mut found) = found else {
            return_scratch(search.scratch);
            HINT_BUFFERS.with(|c| c.set(Some(bufs)));
            return Err(limit.unwrap_or(Status::NoMatch));
        };
        let mut step_sigma = ladder[found_step];
        for &sigma_px in ladder.iter().skip(found_step + 1) {
            // Only when spots are left and the residuals say the noise reaches the step's.
            if found.matched >= n || found.sigma_px < 0.75 * step_sigma {
                break;
            }
            step_sigma = sigma_px;
            let sigma_rad = sigma_px / f;
            search.hint = Some(HintPrior {
                uncertainty_rad: hint.uncertainty_rad,
                pair_tol_rad: 3.0 * std::f64::consts::SQRT_2 * sigma_rad + 1e-6,
                density,
                r_hint: hint.r_icrs_to_cam,
            });
            let v = search.verify(found.r, found.mirrored, 8.0 * sigma_rad + 2e-7, sigma_rad);
            match search.accept(v) {
                Some(v) if v.matched > found.matched => found = v,
                _ => break,
            }
        }
        let hypotheses = search.hypotheses;
        return_scratch(search.scratch);
        HINT_BUFFERS.with(|c| c.set(Some(bufs)));
        let mut id = found.into_identification(hypotheses, Duration::ZERO);
        id.method = config.method;
        id.hinted = true;
        id.noise_source = super::NoiseSource::of(config, &id);
        Ok(id)
    }
}
