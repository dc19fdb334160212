//! Identification when the focal length (field of view) is known only to lie in a range.
//!
//! # Algorithm
//! 1. Triangles of the brightest observed stars are visited by their *base*, their shortest
//!    side, shortest first: over the focal range a base subtends an interval of angles, and the
//!    k-vector returns every catalogue pair in that interval, visited once for all the
//!    triangles the base is the shortest side of. The triangles of the four brightest stars
//!    come first where their bases are cheap enough: where spots that are not stars lie close
//!    together, the short bases are theirs.
//! 2. A catalogue pair `(A, B)` for the base fixes the focal length: the `f` at which the two
//!    pixel rays subtend `∠AB` (a quadratic in `f²`, [`focal_for_angle`]). With `f` and the two
//!    stars the attitude follows (TRIAD), which predicts where the triangle's third star is on
//!    the sky; the catalogue's zone index says whether a star is there (within a radius that
//!    grows with the noise and with how far the base's focal error carries). Both assignments of
//!    the base and both handednesses are tried.
//! 3. A triangle that closes gives a better focal length (least squares over its three stars);
//!    one of the next observed stars must then land on a catalogue star too.
//! 4. The confirmed focal length goes to the fixed-focal [`Solver::identify`], which searches
//!    and verifies the frame on its own (false-match bound included). The focal length is then
//!    refined over all matched stars by Levenberg–Marquardt ([`refine_pointing`]) and the frame
//!    identified once more with it, so the final matches and residuals use the refined camera.
//!
//! At most [`MAX_FOCAL_HYPOTHESES`] focal lengths reach step 4; each is held to
//! `max_false_match_prob / MAX_FOCAL_HYPOTHESES`, and the reported bound is multiplied by the
//! number tried (a union bound over the attempts).

use std::time::Instant;

use nalgebra::{Vector2, Vector3};

use super::{
    binomial_tail, stop_now, validate_centroids, Call, Identification, IdentifyConfig, Solver,
    Status,
};
use crate::error::{Error, Result};
use crate::geometry::Camera;
use crate::kvector::AngleWindow;
use crate::pointing::{focal_for_angle, refine_pointing, PointingFit, RefineOptions};
use crate::sky::Radius;

/// Most focal-length hypotheses handed to the fixed-focal identification per frame.
pub const MAX_FOCAL_HYPOTHESES: usize = 8;

/// Hypothesis and pair budgets of one fixed-focal identification inside the search.
const PER_FOCAL_HYPOTHESES: usize = 3000;
const PER_FOCAL_PAIRS: usize = 2_000_000;

/// Catalogue pairs of one triangle between checks of the time limit and the cancel flag.
const STOP_CHECK_PAIRS: usize = 1024;

/// The noise ladder of a search with the focal length unknown (px).
const UNKNOWN_FOCAL_SIGMA_LADDER_PX: [f64; 2] = [0.3, 1.0];

/// Brightest stars whose triangles are searched.
const SEARCH_STARS: usize = 10;

/// Largest relative 1σ of the focal length accepted from the matched stars (with
/// [`FOCAL_LEVER`], what keeps a tight cluster from verifying at a wrong scale): eight stars of
/// 1 px centroids spread over a 512-pixel field fix it to about 0.2 %.
const MAX_FOCAL_SIGMA: f64 = 3e-3;

/// Largest focal-length error, carried to the field's corner, in units of the centroid noise.
const FOCAL_LEVER: f64 = 2.0;

/// Largest chance probability of a triangle's confirming hits.
const CONFIRM_CHANCE: f64 = 1e-3;

/// Catalogue pairs examined for triangle bases before the search gives up (about a second).
const MAX_BASE_PAIRS: usize = 1_000_000;

/// Brightest stars whose triangles are tried first.
const PRELUDE_STARS: usize = 4;

/// Catalogue pairs those triangles' bases may take (at most half the search's budget).
const PRELUDE_PAIRS: usize = 50_000;

/// Brightest stars that may confirm a triangle.
const CONFIRM_STARS: usize = 24;

/// Stars beyond the triangle that must land on catalogue stars before a focal length goes to
/// the full identification (fewer when the frame has fewer).
const CONFIRMING_MATCHES: usize = 2;

/// The outcome of [`Solver::identify_unknown_focal`].
#[derive(Debug, Clone)]
pub struct FocalIdentification {
    /// The identification, made with the estimated camera; its `false_match_probability` already
    /// covers the focal-length hypotheses tried, and `elapsed` the whole search.
    pub identification: Identification,
    /// The estimated camera (focal length refined over all matched stars); `None` unless identified.
    pub camera: Option<Camera>,
    /// The refinement over all matched stars (focal length with its 1σ, attitude).
    pub fit: Option<PointingFit>,
    /// Focal-length hypotheses that reached the fixed-focal identification.
    pub focal_hypotheses: usize,
    /// Catalogue pairs examined for triangle bases.
    pub base_pairs: usize,
}

impl Solver {
    /// Identify a frame whose focal length is only known to lie in
    /// `[focal_range_px.0, focal_range_px.1]` (pixels), and estimate it. See the module
    /// documentation.
    ///
    /// # Errors
    /// As [`Solver::identify`]; `InvalidInput` for a focal range that is not positive, finite
    /// and ordered, or wider in field than the pair index covers.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let truth = Camera::from_fov(15f64.to_radians(), 1024.0, 1024.0).unwrap();
    /// let frame = simulate(&cat, &truth, &SimConfig { noise_px: 0.2, ..Default::default() }, 4).unwrap();
    /// let widest = Camera::from_fov(20f64.to_radians(), 1024.0, 1024.0).unwrap();
    /// let narrowest = Camera::from_fov(10f64.to_radians(), 1024.0, 1024.0).unwrap();
    /// let solver = Solver::for_camera(cat, &widest).unwrap();
    /// let range = (widest.focal_length_px, narrowest.focal_length_px);
    /// let r = solver.identify_unknown_focal(&frame.centroids, None, 1024.0, 1024.0, range, &IdentifyConfig::default()).unwrap();
    /// if let Some(cam) = r.camera {
    ///     assert!((cam.fov_rad().to_degrees() - 15.0).abs() < 0.1);
    /// }
    /// ```
    pub fn identify_unknown_focal(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        width_px: f64,
        height_px: f64,
        focal_range_px: (f64, f64),
        config: &IdentifyConfig,
    ) -> Result<FocalIdentification> {
        self.search_focal_range(
            centroids,
            magnitudes,
            (width_px, height_px),
            focal_range_px,
            config,
            true,
        )
    }

    /// [`Solver::identify_unknown_focal`]; `index_checked` false lets the range's widest field
    /// span more than the pair index covers (a field given within a tolerance: the triangles
    /// searched rarely span the diagonal, and pairs longer than the index are never found).
    pub(crate) fn search_focal_range(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        (width_px, height_px): (f64, f64),
        focal_range_px: (f64, f64),
        config: &IdentifyConfig,
        index_checked: bool,
    ) -> Result<FocalIdentification> {
        let start = Instant::now();
        let (f_lo, f_hi) = focal_range_px;
        if !(f_lo.is_finite() && f_hi.is_finite() && f_lo > 0.0 && f_lo <= f_hi) {
            return Err(Error::invalid_input(format!(
                "the focal range must be positive, finite and ordered, got [{f_lo}, {f_hi}] px"
            )));
        }
        let widest = Camera::from_focal_length(f_lo, width_px, height_px)?;
        config.validate()?;
        if !config.verify {
            return Err(Error::invalid_input(
                "verify=false (raw method answers) needs a known field of view: the focal length is fitted to verified matches",
            ));
        }
        validate_centroids(centroids, magnitudes, &widest)?;
        if index_checked && widest.diagonal_fov_rad() > self.pair_index().max_angle_rad() * 1.0001 {
            return Err(Error::invalid_input(format!(
                "the pair index covers {:.2} degrees but the widest field of the range spans {:.2} degrees \
                 across the diagonal; build the index for the widest field",
                self.pair_index().max_angle_rad().to_degrees(),
                widest.diagonal_fov_rad().to_degrees()
            )));
        }
        let n = centroids.len();
        if n < super::MIN_CENTROIDS {
            return Ok(FocalIdentification {
                identification: Identification::unidentified(
                    Status::TooFewStars,
                    n,
                    0,
                    start.elapsed(),
                ),
                camera: None,
                fit: None,
                focal_hypotheses: 0,
                base_pairs: 0,
            });
        }
        let centre = Vector2::new(0.5 * width_px, 0.5 * height_px);
        let off: Vec<Vector2<f64>> = centroids
            .iter()
            .map(|c| Vector2::new(c[0], c[1]) - centre)
            .collect();
        let mut order: Vec<usize> = (0..n).collect();
        if let Some(m) = magnitudes {
            order.sort_by(|&a, &b| m[a].total_cmp(&m[b]));
        }
        let top = &order[..n.min(SEARCH_STARS)];
        let confirm_pool = &order[..n.min(CONFIRM_STARS)];
        let ladder = config.search_ladder(&UNKNOWN_FOCAL_SIGMA_LADDER_PX);
        let deadline = config.timeout.map(|t| start + t);
        // A right focal length identifies in a few hundred hypotheses; a wrong one should not
        // cost the full budget.
        let per_call = IdentifyConfig {
            max_false_match_prob: config.max_false_match_prob / MAX_FOCAL_HYPOTHESES as f64,
            max_hypotheses: config.max_hypotheses.min(PER_FOCAL_HYPOTHESES),
            max_pairs_visited: config.max_pairs_visited.min(PER_FOCAL_PAIRS),
            timeout: None,
            // The focal length is refined here, over all matches (step 4).
            focal_check: false,
            ..config.clone()
        };
        let mut search = FocalSearch {
            solver: self,
            off: &off,
            centre,
            f_range: (f_lo * 0.99, f_hi * 1.01),
            sigma: ladder[0],
            mirror_too: config.allow_mirrored,
            base_pairs: 0,
            tried: Vec::new(),
            closed: 0,
            stop: (deadline, config.cancel.as_ref()),
        };
        let mut hypotheses_total = 0usize;
        let mut status = Status::NoMatch;
        // Bases (pairs of the brightest stars), shortest first: a short base has few catalogue
        // pairs in its angle interval, so it costs little to try. Each base's catalogue pairs are
        // visited once for every triangle it is the shortest side of.
        let m = top.len();
        let dist = |x: usize, y: usize| (off[x] - off[y]).norm();
        let mut bases: Vec<(f64, usize, usize, Vec<usize>)> = Vec::new();
        for b in 1..m {
            for a in 0..b {
                let (p, q) = (top[a], top[b]);
                let base = dist(p, q);
                let thirds: Vec<usize> = top
                    .iter()
                    .copied()
                    .filter(|&r| r != p && r != q && dist(p, r) >= base && dist(q, r) >= base)
                    .collect();
                if !thirds.is_empty() {
                    bases.push((base, p, q, thirds));
                }
            }
        }
        bases.sort_by(|x, y| x.0.total_cmp(&y.0));
        let bases: Vec<(usize, usize, Vec<usize>, bool)> = bases
            .into_iter()
            .map(|(_, p, q, thirds)| (p, q, thirds, true))
            .collect();
        let budget = config.max_pairs_visited.min(MAX_BASE_PAIRS);
        'search: for &sigma in &ladder {
            search.sigma = sigma;
            let prelude = search.prelude(&top[..m.min(PRELUDE_STARS)], budget);
            for (p, q, thirds, charge) in prelude.iter().chain(&bases) {
                if stop_now(deadline, config.cancel.as_ref()) {
                    status = Status::Timeout;
                    break 'search;
                }
                if search.base_pairs > budget {
                    status = Status::SearchLimit;
                    break 'search;
                }
                let mut from = Some(0);
                while let Some(at) = from {
                    let (found, next) = search.base((*p, *q), thirds, confirm_pool, at, *charge);
                    from = next;
                    for f in found {
                        if search.tried.len() >= MAX_FOCAL_HYPOTHESES {
                            status = Status::SearchLimit;
                            break 'search;
                        }
                        if search.tried.iter().any(|&t| (t - f).abs() < 2e-3 * f) {
                            continue;
                        }
                        search.tried.push(f);
                        if stop_now(deadline, config.cancel.as_ref()) {
                            status = Status::Timeout;
                            break 'search;
                        }
                        // Each focal length's search within what is left of the time.
                        let per_call = IdentifyConfig {
                            timeout: deadline.map(|d| d.saturating_duration_since(Instant::now())),
                            ..per_call.clone()
                        };
                        let camera = Camera::from_focal_length(f, width_px, height_px)?;
                        let (done, hyps) =
                            self.finish(centroids, magnitudes, camera, None, &per_call)?;
                        hypotheses_total += hyps;
                        if let Some((mut id, mut camera, fit)) = done {
                            // The focal check of a known camera, on the camera found: an
                            // unknown radial distortion leaves a pattern the focal length
                            // alone cannot fit (see `identify::scale`), even where every
                            // spot is named (the focal length then absorbs what it can).
                            if config.focal_check && id.verified {
                                let call = Call {
                                    centroids,
                                    magnitudes,
                                    camera: &camera,
                                    config,
                                    start,
                                };
                                self.check_focal(call, &mut id)?;
                                if let Some(f) = id.focal_length_px {
                                    camera.focal_length_px = f;
                                    camera = camera.with_k1(id.k1.unwrap_or(camera.k1))?;
                                }
                            }
                            // The union bound over every hypothesis of the search: the
                            // catalogue triangles closed at some focal length as well as
                            // those of each focal length's identification (a focal length
                            // chosen to fit a triangle makes its own identification's
                            // count of one no bound at all).
                            let tail = id.false_match_probability / id.hypotheses.max(1) as f64;
                            let counted = (search.closed + hypotheses_total)
                                .max(search.tried.len())
                                .max(1);
                            id.hypotheses = hypotheses_total;
                            id.false_match_probability = (tail * counted as f64).min(1.0);
                            if id.false_match_probability > config.max_false_match_prob {
                                continue;
                            }
                            id.elapsed = start.elapsed();
                            id.noise_source = super::NoiseSource::of(config, &id);
                            return Ok(FocalIdentification {
                                identification: id,
                                camera: Some(camera),
                                fit: Some(fit),
                                focal_hypotheses: search.tried.len(),
                                base_pairs: search.base_pairs,
                            });
                        }
                    }
                }
            }
        }
        Ok(FocalIdentification {
            identification: Identification::unidentified(
                status,
                n,
                hypotheses_total,
                start.elapsed(),
            ),
            camera: None,
            fit: None,
            focal_hypotheses: search.tried.len(),
            base_pairs: search.base_pairs,
        })
    }

    /// Identify with `camera` (or take `first`, its identification made already); on success
    /// refine the focal length over all matches and identify again with the refined camera.
    /// Returns the identification, the camera, the fit and the hypotheses spent (`first`'s not
    /// counted again).
    pub(crate) fn finish(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        mut camera: Camera,
        mut first: Option<Identification>,
        config: &IdentifyConfig,
    ) -> Result<(Option<Solved>, usize)> {
        let mut hyps = 0;
        let mut last: Option<(Identification, PointingFit)> = None;
        for _round in 0..3 {
            let id = match first.take() {
                Some(id) => id,
                None => {
                    let id = self.identify_with(centroids, magnitudes, &camera, config, false)?;
                    hyps += id.hypotheses;
                    id
                }
            };
            let Some(r) = id.r_icrs_to_cam.filter(|_| id.is_identified()) else {
                return Ok((last.map(|(id, fit)| (id, camera, fit)), hyps));
            };
            let (stars, xy): (Vec<Vector3<f64>>, Vec<[f64; 2]>) = id
                .catalog_index
                .iter()
                .zip(centroids)
                .filter_map(|(c, p)| c.map(|c| (self.catalog().vectors()[c as usize], *p)))
                .unzip();
            let fit = refine_pointing(
                &stars,
                &xy,
                &r,
                &camera,
                &RefineOptions {
                    mirrored: id.mirrored,
                    sigma_px: None,
                    ..RefineOptions::default()
                },
            )?;
            let f_new = fit.camera.focal_length_px;
            // The matched stars must pin the focal length down: well enough (relative 1σ at most
            // MAX_FOCAL_SIGMA) and with enough leverage that the scale error at the field's
            // corner stays within FOCAL_LEVER noise σ. A tight cluster of stars (the Pleiades)
            // can verify at a wrong scale; this sends the search on instead.
            let half_diag = 0.5 * camera.width_px.hypot(camera.height_px);
            let rel = fit.focal_sigma_px() / f_new;
            let lever = rel * half_diag / fit.sigma_px.max(1e-3);
            if !(rel <= MAX_FOCAL_SIGMA && lever <= FOCAL_LEVER) {
                return Ok((None, hyps));
            }
            let settled = (f_new - camera.focal_length_px).abs() < 1e-5 * f_new;
            last = Some((id, fit));
            if settled {
                break;
            }
            camera.focal_length_px = f_new;
        }
        Ok((last.map(|(id, fit)| (id, camera, fit)), hyps))
    }
}

/// An identification with its refined camera and fit.
type Solved = (Identification, Camera, PointingFit);

struct FocalSearch<'a> {
    solver: &'a Solver,
    off: &'a [Vector2<f64>],
    /// Principal point (sensor centre), pixels.
    centre: Vector2<f64>,
    f_range: (f64, f64),
    sigma: f64,
    mirror_too: bool,
    base_pairs: usize,
    tried: Vec<f64>,
    /// Catalogue triangles that closed on an observed one at some focal length and were looked
    /// for a fourth star: the hypotheses of the scale search, which the bound counts.
    closed: usize,
    /// When the search must stop (time limit, cancel flag): checked within a triangle too,
    /// whose catalogue pairs may number hundreds of thousands at a long base.
    stop: (Option<Instant>, Option<&'a super::Cancel>),
}

impl FocalSearch<'_> {
    fn ray(&self, s: usize, f: f64, mirrored: bool) -> Vector3<f64> {
        let o = self.off[s];
        let x = if mirrored { -o.x } else { o.x };
        Vector3::new(x, o.y, f).normalize()
    }

    fn angle_at(&self, p: usize, q: usize, f: f64) -> f64 {
        let (a, b) = (self.off[p], self.off[q]);
        crate::geometry::angle_between(&Vector3::new(a.x, a.y, f), &Vector3::new(b.x, b.y, f))
    }

    /// The catalogue pairs (index positions) whose angle base `(p, q)` may subtend at a focal
    /// length of the range.
    fn base_range(&self, p: usize, q: usize) -> std::ops::Range<usize> {
        let (f_lo, f_hi) = self.f_range;
        let eps = 3.0 * std::f64::consts::SQRT_2 * self.sigma / f_lo;
        let lo = self.angle_at(p, q, f_hi) - eps;
        let hi = self.angle_at(p, q, f_lo) + eps;
        let vectors = self.solver.catalog().vectors();
        (self.solver.pair_index()).range_exact(&AngleWindow::new(lo.max(0.0), hi), vectors)
    }

    /// The triangles of the `brightest` spots, by their bases, cheapest first, as many as
    /// [`PRELUDE_PAIRS`] (at most half of `budget`) scans once (charged to the search): a frame
    /// whose few brightest spots are stars is found from them even where spots that are not
    /// stars lie close together and hold the short bases.
    fn prelude(
        &mut self,
        brightest: &[usize],
        budget: usize,
    ) -> Vec<(usize, usize, Vec<usize>, bool)> {
        let mut bases: Vec<(usize, usize, usize)> = Vec::new();
        for (i, &p) in brightest.iter().enumerate() {
            for &q in &brightest[i + 1..] {
                if (self.off[p] - self.off[q]).norm() >= 3.0 * self.sigma {
                    bases.push((self.base_range(p, q).len(), p, q));
                }
            }
        }
        bases.sort_unstable();
        let cap = PRELUDE_PAIRS.min(budget / 2);
        let mut spent = 0;
        let mut out = Vec::new();
        for (cost, p, q) in bases {
            if spent + cost > cap {
                break;
            }
            spent += cost;
            let thirds = brightest
                .iter()
                .copied()
                .filter(|&r| r != p && r != q)
                .collect();
            out.push((p, q, thirds, false));
        }
        self.base_pairs += spent;
        out
    }

    /// Focal lengths confirmed by a triangle of base `(p, q)` and a third star among `thirds`,
    /// and a fourth among the other spots of `pool`: the base's catalogue pairs from the
    /// `from`-th on, up to the first that confirms some focal length. Returns those focal
    /// lengths and where to go on from (None: the base is done).
    fn base(
        &mut self,
        (p, q): (usize, usize),
        thirds: &[usize],
        pool: &[usize],
        from: usize,
        charge: bool,
    ) -> (Vec<f64>, Option<usize>) {
        let d = |a: usize, b: usize| (self.off[a] - self.off[b]).norm();
        let base = d(p, q);
        if base < 3.0 * self.sigma {
            return (Vec::new(), None);
        }
        let (f_lo, f_hi) = self.f_range;
        let index = self.solver.pair_index();
        let catalog = self.solver.catalog();
        let vectors = catalog.vectors();
        let range = self.base_range(p, q);
        if from == 0 && charge {
            // The budget counts a catalogue pair once for each triangle it is tried in.
            self.base_pairs += range.len() * thirds.len();
        }
        // Per third star: how far the base's focal error carries, and the spots that may confirm.
        let thirds: Vec<(usize, f64, Vec<usize>)> = thirds
            .iter()
            .map(|&r| {
                let others = pool
                    .iter()
                    .copied()
                    .filter(|&s| s != p && s != q && s != r)
                    .collect();
                (r, (d(p, r) + d(q, r)) / base, others)
            })
            .collect();
        let mut found = Vec::new();
        let first = (range.start + from).min(range.end);
        for (k, pair) in (from..).zip(index.pairs(first..range.end)) {
            // (The search's loop reports the stop.)
            if k % STOP_CHECK_PAIRS == STOP_CHECK_PAIRS - 1 && stop_now(self.stop.0, self.stop.1) {
                break;
            }
            // The index keeps no separations: the pair's own.
            let angle = crate::geometry::angle_between(
                &vectors[pair[0] as usize],
                &vectors[pair[1] as usize],
            );
            let Some(f) = focal_for_angle(&self.off[p], &self.off[q], angle) else {
                continue;
            };
            if f < f_lo || f > f_hi {
                continue;
            }
            for (ca, cb) in [(pair[0], pair[1]), (pair[1], pair[0])] {
                let (va, vb) = (&vectors[ca as usize], &vectors[cb as usize]);
                for mirrored in [false, true] {
                    if mirrored && !self.mirror_too {
                        continue;
                    }
                    let (rp, rq) = (self.ray(p, f, mirrored), self.ray(q, f, mirrored));
                    let Some(rot) = crate::attitude::triad(&rp, &rq, va, vb) else {
                        continue;
                    };
                    for (r, reach, others) in &thirds {
                        // Predicted third star: noise on three stars plus the base's focal
                        // error carried out.
                        let radius =
                            3.0 * std::f64::consts::SQRT_2 * self.sigma * (1.0 + reach) / f;
                        let predicted = rot.inverse_transform_vector(&self.ray(*r, f, mirrored));
                        let (Some((cc, _)), _) =
                            catalog.nearest_two(&predicted, Radius::new(radius))
                        else {
                            continue;
                        };
                        if cc == ca || cc == cb {
                            continue;
                        }
                        self.closed += 1;
                        if let Some(f3) =
                            self.confirm([p, q, *r], [ca, cb, cc], f, mirrored, others)
                        {
                            found.push(f3);
                        }
                    }
                }
            }
            if !found.is_empty() {
                return (found, Some(k + 1));
            }
        }
        (found, None)
    }

    /// Refine `f` over the closed triangle and look for a fourth star among `others`.
    fn confirm(
        &self,
        obs: [usize; 3],
        cat: [u32; 3],
        f: f64,
        mirrored: bool,
        others: &[usize],
    ) -> Option<f64> {
        let vectors = self.solver.catalog().vectors();
        // Focal length from the triangle's longest side (the most precise one).
        let sides = [(0, 1), (1, 2), (0, 2)];
        let &(a, b) = sides.iter().max_by(|x, y| {
            (self.off[obs[x.0]] - self.off[obs[x.1]])
                .norm()
                .total_cmp(&(self.off[obs[y.0]] - self.off[obs[y.1]]).norm())
        })?;
        let alpha =
            crate::geometry::angle_between(&vectors[cat[a] as usize], &vectors[cat[b] as usize]);
        let f3 = focal_for_angle(&self.off[obs[a]], &self.off[obs[b]], alpha).unwrap_or(f);
        let rays: Vec<Vector3<f64>> = obs.iter().map(|&s| self.ray(s, f3, mirrored)).collect();
        let refs: Vec<Vector3<f64>> = cat.iter().map(|&c| vectors[c as usize]).collect();
        // The least-squares attitude (the SVD's optimum), by Gauss-Newton from TRIAD along the
        // longest side: a few 3×3 products where the SVD of every closed triangle cost most of
        // the search.
        let rot = match crate::attitude::triad(&rays[a], &rays[b], &refs[a], &refs[b]) {
            Some(start) => crate::attitude::wahba_from(&rays, &refs, &start)?,
            None => crate::attitude::wahba_svd(&rays, &refs)?,
        };
        // The triangle itself must fit at this focal length.
        let tol = 4.0 * std::f64::consts::SQRT_2 * self.sigma / f3;
        if rays
            .iter()
            .zip(&refs)
            .any(|(o, r)| crate::geometry::angle_between(&(rot * r), o) > tol)
        {
            return None;
        }
        let longest = (self.off[obs[a]] - self.off[obs[b]]).norm().max(1.0);
        let needed = CONFIRMING_MATCHES.min(others.len());
        if needed == 0 {
            return Some(f3);
        }
        let catalog = self.solver.catalog();
        let mut hits: Vec<(usize, u32)> = Vec::new();
        let mut misses = 0;
        for &l in others {
            let reach = obs
                .iter()
                .map(|&s| (self.off[l] - self.off[s]).norm())
                .fold(0.0, f64::max);
            let radius = 3.0 * std::f64::consts::SQRT_2 * self.sigma * (1.0 + reach / longest) / f3;
            let predicted = rot.inverse_transform_vector(&self.ray(l, f3, mirrored));
            match catalog.nearest_two(&predicted, Radius::new(radius)) {
                (Some((c, _)), _) if !cat.contains(&c) && hits.iter().all(|h| h.1 != c) => {
                    hits.push((l, c));
                }
                _ => misses += 1,
            }
            // Give up once the needed hits can no longer come from the first few stars.
            if hits.len() < needed && misses > 4 + hits.len() {
                return None;
            }
        }
        if hits.len() < needed {
            return None;
        }
        // The hits must not be chance: with the catalogue's density around the field, a star
        // lands within the (largest) radius of some catalogue star with probability p; the
        // binomial tail of the hits over the stars tried must be small.
        let boresight = rot.inverse_transform_vector(&Vector3::z());
        let half_diag = (self.centre.norm() / f3).atan();
        let in_field = catalog.count_in_cone(&boresight, half_diag);
        let cone_sr = 2.0 * std::f64::consts::PI * (1.0 - half_diag.cos());
        let density = in_field.max(1) as f64 / cone_sr;
        let widest = others
            .iter()
            .take(hits.len() + misses)
            .map(|&l| {
                let reach = obs
                    .iter()
                    .map(|&s| (self.off[l] - self.off[s]).norm())
                    .fold(0.0, f64::max);
                3.0 * std::f64::consts::SQRT_2 * self.sigma * (1.0 + reach / longest) / f3
            })
            .fold(0.0, f64::max);
        let p_chance = (density * std::f64::consts::PI * widest * widest).min(1.0);
        // A sparse frame (at most two stars beyond the triangle) cannot reach that significance;
        // there every one of them must hit.
        let tried = hits.len() + misses;
        let all_hit = tried <= 2 && misses == 0;
        if !all_hit && binomial_tail(tried, hits.len(), p_chance) > CONFIRM_CHANCE {
            return None;
        }
        // The focal length from every star found so far (least squares, attitude and f).
        let (stars, xy): (Vec<Vector3<f64>>, Vec<[f64; 2]>) = obs
            .iter()
            .zip(cat)
            .chain(hits.iter().map(|(l, c)| (l, *c)))
            .map(|(&o, c)| {
                let p = self.off[o] + self.centre;
                (vectors[c as usize], [p.x, p.y])
            })
            .unzip();
        let start = Camera::from_focal_length(f3, 2.0 * self.centre.x, 2.0 * self.centre.y).ok()?;
        let options = RefineOptions {
            mirrored,
            max_iterations: 30,
            ..RefineOptions::default()
        };
        match refine_pointing(&stars, &xy, &rot, &start, &options) {
            Ok(fit) if fit.converged && fit.rms_px <= 4.0 * self.sigma => {
                Some(fit.camera.focal_length_px)
            }
            _ => Some(f3),
        }
    }
}
