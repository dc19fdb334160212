//! A field of view is an estimate ([`IdentifyConfig::fov_tolerance`]): where the given camera
//! leaves the field in doubt, the frame is searched with the focal length unknown within the
//! tolerance, and the solution that names more spots kept.

use super::*;

/// A scale fitted to a solution's residuals at this many of its σ counts as a hint of a field
/// given off (below the focal check's own threshold, which acts on it).
const SCALE_HINT_SIGMAS: f64 = 3.0;

/// Focal lengths of the grid searched about the given one ([`Solver::search_scale_grid`]):
/// ±10 % on a 512-pixel sensor, ±4 % on a 1400-pixel one.
const SCALE_GRID_STEPS: usize = 48;

/// The grid's half step: how far (pixels) a focal-length error may move a star at the half
/// diagonal for the fixed-focal search to find the frame all the same (its first noise step
/// takes in a side about that much off).
const SCALE_GRID_EDGE_PX: f64 = 0.75;

/// Catalogue pairs each focal length of the grid may visit: the brightest spots' passes, so
/// that a frame with nothing to find spends about a millisecond a focal length.
const SCALE_GRID_PAIRS: usize = 20_000;

/// The most catalogue pairs a focal length of the grid may visit: [`SCALE_GRID_PAIRS`] for each
/// spot beyond the [`SCALE_GRID_MIN_MATCHES`] a solution there needs. A frame of more spots
/// (false ones among its brightest, where the search over the range failed) has more
/// triangles to try before an all-real one comes up; one of barely enough spots has few.
const SCALE_GRID_MAX_PAIRS: usize = 60_000;

/// How far (a fraction of the given focal length) the first search over focal lengths looks,
/// before the whole tolerance: a lens's nominal focal length, a sensor's crop or the focus is
/// mostly off by less. On the peer scenarios with the field given 0.3-3 % off, it cuts the
/// median time two to four times; 4.5-10 % off, it adds about 3 ms.
const NEAR_FOCAL_TOLERANCE: f64 = 0.03;

/// Catalogue pairs that first search may visit: a frame within its range is found among the
/// first few thousand.
const NEAR_FOCAL_PAIRS: usize = 5_000;

/// How far (a fraction of the given focal length) the grid's near focal lengths lie: they share
/// half its false-match bound, the rest the other half ([`Solver::search_scale_grid`]).
const SCALE_GRID_NEAR: f64 = 0.01;

/// Fewest spots a solution of the grid names, with magnitudes: one more than a known field
/// asks, as a handful of spots shaped like a catalogue pattern at some scale is what a search
/// over scales finds. A narrow camera's faint frames name five stars among 70-90 noise peaks;
/// sets of random points with magnitudes (6-24 on 12° and 10° sensors, 6-100 on a 6° one) are
/// named at none of the grid's focal lengths.
const SCALE_GRID_MIN_MATCHES: usize = 5;

/// Fewest spots a solution of the grid names from positions alone: the shape of five points
/// is too little to tell a catalogue pattern at some scale from chance (five random points on
/// a 12° sensor were named five stars at a focal length near the given one).
const SCALE_GRID_MIN_MATCHES_UNORDERED: usize = 6;

/// How far (radians) the roll of a solution matched at the centre only may be off, for the
/// scale scan of [`Solver::field_in_doubt`].
const ROLL_SLACK_RAD: f64 = 5e-3;

impl Solver {
    /// A solution of the given camera that needed a widened match radius and that the focal
    /// check did not confirm may owe its matches to a scale within the
    /// tolerance rather than to the field given: its false-match bound is multiplied by the
    /// number of scales the tolerance holds that the match radius tells apart (a union bound,
    /// as the search over the range has), and a solution that then fails the bound is
    /// withdrawn (the search within the tolerance may find it again, or another).
    pub(crate) fn count_scale_freedom(&self, id: &mut Identification, call: Call<'_>) {
        let (centroids, _, camera, config, _) = call.parts();
        let n = centroids.len();
        let (shortest, longest) = config.focal_range_px(camera);
        let loose = id.centroid_sigma_px >= DOUBT_SIGMA_PX;
        if !(id.verified && shortest < longest && id.focal_length_px.is_none() && loose) {
            return;
        }
        // Residuals that grow with the distance from the centre show a scale; noise alone does
        // not call for the count (a camera whose centroids are noisy is not a field in doubt).
        if !self.scale_shows(id, centroids, camera) {
            return;
        }
        let half_diagonal = 0.5 * camera.width_px.hypot(camera.height_px);
        let span = (longest - shortest) / camera.focal_length_px * half_diagonal;
        let scales = (span / (3.0 * id.centroid_sigma_px)).max(1.0);
        id.false_match_probability = (id.false_match_probability * scales).min(1.0);
        if id.false_match_probability > config.max_false_match_prob {
            *id = Identification::unidentified(Status::NoMatch, n, id.hypotheses, id.elapsed);
        }
    }

    /// Whether a solution of the given camera leaves its field of view in doubt: none was found,
    /// or one that the focal check did not confirm and that either needed a widened match
    /// radius for residuals that grow with the distance from the centre, or (found with a
    /// widened radius or naming few stars) names fewer than four spots in five while another
    /// focal length lines up decisively more spots with stars at its attitude, or the stars it
    /// puts on the sensor go unmatched (a field a few percent off matches the centre and loses
    /// the edges; a star there may fall on another's spot). Only with a tolerance ([`IdentifyConfig::focal_range_px`]), and time
    /// left.
    pub(crate) fn field_in_doubt(&self, id: &Identification, call: Call<'_>) -> bool {
        let (centroids, _, camera, config, start) = call.parts();
        let (shortest, longest) = config.focal_range_px(camera);
        let n = centroids.len();
        if shortest >= longest || n < crate::identify::MIN_CENTROIDS {
            return false;
        }
        let timed_out = config.timeout.is_some_and(|t| start.elapsed() >= t);
        if timed_out || config.cancel.as_ref().is_some_and(Cancel::is_cancelled) {
            return false;
        }
        if !id.verified {
            return true;
        }
        let loose = id.centroid_sigma_px >= DOUBT_SIGMA_PX;
        // A camera the focal check corrected: the residuals fitted it, but a solution of a
        // tight group of stars (a cluster) fits a scale well off the truth as well as the right
        // one, and the correction may only have carried an edge spot onto another star. The
        // spots it leaves unnamed and the stars it leaves unmatched still say so.
        let corrected = id.focal_length_px.map(|f| Camera {
            focal_length_px: f,
            k1: id.k1.unwrap_or(camera.k1),
            ..*camera
        });
        if corrected.is_none() && loose && self.scale_shows(id, centroids, camera) {
            return true;
        }
        let camera = corrected.as_ref().unwrap_or(camera);
        5 * id.matched < 4 * n
            && (loose || id.matched < DOUBT_MATCHES || clustered(id, centroids, camera))
            && (self.another_scale_fits(id, centroids, camera, (shortest, longest))
                || self.bright_stars_missing(id, camera))
    }

    /// Whether the solution's residuals grow with the distance from the centre by more than
    /// [`SCALE_HINT_SIGMAS`] of their σ (too few matches to tell: yes).
    fn scale_shows(&self, id: &Identification, centroids: &[[f64; 2]], camera: &Camera) -> bool {
        scale::camera_error(centroids, camera, id, self.catalog.vectors())
            .is_none_or(|f| f.scale.0.abs() > SCALE_HINT_SIGMAS * f.scale.1)
    }

    /// Whether the solution leaves decisively many stars unmatched (as many as the scale scan
    /// asks) among the catalogue stars it puts on the sensor that are no fainter than its
    /// faintest match: a field matched
    /// over one cluster at a wrong scale (which a shift of the pointing absorbs there) predicts
    /// the rest of the sky where the image has none of it.
    fn bright_stars_missing(&self, id: &Identification, camera: &Camera) -> bool {
        let Some(r) = id.r_icrs_to_cam else {
            return false;
        };
        let mags = self.catalog.mag();
        let faintest = id
            .catalog_index
            .iter()
            .flatten()
            .map(|&s| mags[s as usize])
            .fold(f64::NEG_INFINITY, f64::max);
        let half_diagonal = 0.5 * camera.width_px.hypot(camera.height_px);
        let radius = (half_diagonal / camera.focal_length_px).atan() * 1.01;
        let boresight = r.inverse() * Vector3::z();
        let mut predicted = 0usize;
        self.catalog
            .for_each_in_cone(&boresight, radius, |star, _| {
                if mags[star as usize] > faintest {
                    return;
                }
                let v = r * self.catalog.vectors()[star as usize];
                if let Some((x, y)) = camera.cam_to_pixel(&v) {
                    if (0.0..camera.width_px).contains(&x) && (0.0..camera.height_px).contains(&y) {
                        predicted += 1;
                    }
                }
            });
        predicted >= id.matched + (id.matched / 4).max(DOUBT_MORE_SPOTS)
    }

    /// Whether, at the solution's attitude, another focal length within `range` lines up
    /// decisively more spots with catalogue stars than the given one: each spot and star seen
    /// from the principal point along one direction (within the match radius across it) gives
    /// the scale that would put the star on the spot, and the scales are counted in windows
    /// as wide as the match radius allows at that star's distance from the centre. Cheap (the
    /// stars in the field against the spots), where the search over the range is not.
    fn another_scale_fits(
        &self,
        id: &Identification,
        centroids: &[[f64; 2]],
        camera: &Camera,
        (shortest, longest): (f64, f64),
    ) -> bool {
        let Some(r) = id.r_icrs_to_cam else {
            return false;
        };
        let f = camera.focal_length_px;
        let [cx, cy] = camera.principal_point_px;
        let sign = if id.mirrored { -1.0 } else { 1.0 };
        let spots: Vec<[f64; 2]> = centroids
            .iter()
            .map(|c| [sign * (c[0] - cx), c[1] - cy])
            .collect();
        let half_diagonal = 0.5 * camera.width_px.hypot(camera.height_px);
        let radius = (half_diagonal / shortest).atan();
        let boresight = r.inverse() * Vector3::z();
        let across = 3.0 * id.centroid_sigma_px.max(SIGMA_LADDER_PX[0]);
        let (lo, hi) = (shortest / f, longest / f);
        // (scale, half-width of its window, spot) for each spot along a star's direction.
        let mut votes: Vec<(f64, f64, usize)> = Vec::new();
        self.catalog
            .for_each_in_cone(&boresight, radius, |star, _| {
                let v = r * self.catalog.vectors()[star as usize];
                if v.z <= 0.0 {
                    return;
                }
                let p = [f * v.x / v.z, f * v.y / v.z];
                let p2 = p[0] * p[0] + p[1] * p[1];
                if p2 < (0.1 * half_diagonal).powi(2) {
                    return; // too near the centre to tell one scale from another
                }
                let norm = p2.sqrt();
                // Across the direction, the noise and what a roll fitted to the centre alone
                // may be off by (ROLL_SLACK_RAD) at this distance.
                let width = across + ROLL_SLACK_RAD * norm;
                for (i, q) in spots.iter().enumerate() {
                    let perpendicular = (q[0] * p[1] - q[1] * p[0]).abs() / norm;
                    let scale = (q[0] * p[0] + q[1] * p[1]) / p2;
                    if perpendicular <= width && (lo..=hi).contains(&scale) {
                        votes.push((scale, across / norm, i));
                    }
                }
            });
        let lined_up = |centre: f64| {
            let mut seen: Vec<usize> = votes
                .iter()
                .filter(|(s, w, _)| (s - centre).abs() <= *w)
                .map(|v| v.2)
                .collect();
            seen.sort_unstable();
            seen.dedup();
            seen.len()
        };
        let given = lined_up(1.0);
        let best = votes.iter().map(|v| lined_up(v.0)).max().unwrap_or(0);
        best >= given + (given / 4).max(DOUBT_MORE_SPOTS)
    }

    /// Search the frame with its focal length unknown within the tolerance (unless `ranged`
    /// holds that search's outcome already) and, with `grid`, where that finds nothing, at the
    /// focal lengths of a grid about the given one; keep that solution where it names more
    /// spots, or nearly as many with far tighter residuals. Returns the search over the range
    /// where it found nothing and the grid did not run, for a later call to go on from.
    pub(crate) fn search_within_tolerance(
        &self,
        call: Call<'_>,
        id: &mut Identification,
        ranged: Option<super::unknown_focal::FocalIdentification>,
        grid: bool,
    ) -> Result<Option<super::unknown_focal::FocalIdentification>> {
        let (centroids, magnitudes, camera, config, _) = call.parts();
        let (shortest, longest) = config.focal_range_px(camera);
        // A range a few percent wide needs a fraction of the work of a field unknown across
        // 8°–25°, and most frames searched here (hostile ones, a few stars among false spots)
        // have no solution to find.
        let narrow = IdentifyConfig {
            max_pairs_visited: config.max_pairs_visited.min(TOLERANCE_MAX_PAIRS),
            ..config.clone()
        };
        // More spots named, or nearly as many with residuals far tighter (a match radius widened
        // for a scale error takes in a spot or two more by chance).
        let better = |f: &Identification| {
            !id.verified
                || f.matched > id.matched
                || (f.matched + DOUBT_MORE_SPOTS > id.matched
                    && 2.0 * f.centroid_sigma_px < id.centroid_sigma_px)
        };
        // The pair index stays the given camera's: the wider fields of the range lack only
        // their longest pairs.
        let mut found = match ranged {
            Some(found) => found,
            // A field a little off first: a narrow range closes few catalogue triangles, so it
            // costs little and its bound counts few of them. What it finds must be better than
            // the solution in doubt (a cluster of stars fits any focal length near the given one).
            None => match self.search_near_focal(call, (shortest, longest), &narrow)? {
                Some(near) if better(&near.identification) => near,
                _ => self.search_focal_range(
                    centroids,
                    magnitudes,
                    (camera.width_px, camera.height_px),
                    (shortest, longest),
                    &narrow,
                    false,
                )?,
            },
        };
        if !found.identification.verified && !grid {
            return Ok(Some(found));
        }
        if !found.identification.verified {
            if let Some(grid) = self.search_scale_grid(call, &found)? {
                found = grid;
            }
        }
        let better = better(&found.identification);
        let (true, true, Some(cam)) = (found.identification.verified, better, found.camera) else {
            return Ok(None);
        };
        let hypotheses = id.hypotheses + found.identification.hypotheses;
        *id = found.identification;
        id.focal_length_px = Some(cam.focal_length_px);
        id.focal_sigma_px = found
            .fit
            .as_ref()
            .map_or(f64::NAN, crate::pointing::PointingFit::focal_sigma_px);
        id.k1 = (cam.k1 != 0.0).then_some(cam.k1);
        // The focal length refined over the stars matched so far may stop short where the
        // edges were not matched yet: the frame searched again with it, and the focal check's
        // correction, named more spots or not at all.
        let held = IdentifyConfig {
            fov_tolerance: 0.0,
            ..config.clone()
        };
        let again = self.identify_with(centroids, magnitudes, &cam, &held, false)?;
        if again.verified && again.matched > id.matched {
            let focal = again.focal_length_px.unwrap_or(cam.focal_length_px);
            let sigma = if again.focal_length_px.is_some() {
                again.focal_sigma_px
            } else {
                id.focal_sigma_px
            };
            *id = again;
            id.focal_length_px = Some(focal);
            id.focal_sigma_px = sigma;
            id.k1 = id.k1.or((cam.k1 != 0.0).then_some(cam.k1));
        }
        id.hypotheses += hypotheses;
        Ok(None)
    }

    /// The frame searched with its focal length unknown within [`NEAR_FOCAL_TOLERANCE`] of the
    /// given one, with [`NEAR_FOCAL_PAIRS`] catalogue pairs: its identification where it finds
    /// one (None where it does not, or where the tolerance's range, `(shortest, longest)`, is
    /// no wider than that).
    fn search_near_focal(
        &self,
        call: Call<'_>,
        (shortest, longest): (f64, f64),
        config: &IdentifyConfig,
    ) -> Result<Option<super::unknown_focal::FocalIdentification>> {
        let (centroids, magnitudes, camera, _, _) = call.parts();
        let f0 = camera.focal_length_px;
        let range = (
            (f0 * (1.0 - NEAR_FOCAL_TOLERANCE)).max(shortest),
            (f0 * (1.0 + NEAR_FOCAL_TOLERANCE)).min(longest),
        );
        if range.0 <= shortest && range.1 >= longest {
            return Ok(None);
        }
        // Held to half the bound: the search over the whole tolerance may follow it.
        let near = IdentifyConfig {
            max_pairs_visited: config.max_pairs_visited.min(NEAR_FOCAL_PAIRS),
            max_false_match_prob: 0.5 * config.max_false_match_prob,
            ..config.clone()
        };
        let found = self.search_focal_range(
            centroids,
            magnitudes,
            (camera.width_px, camera.height_px),
            range,
            &near,
            false,
        )?;
        Ok(found.identification.verified.then_some(found))
    }

    /// The frame searched with the camera as given at the focal lengths of a grid about it,
    /// nearest first: steps that move a star at the half diagonal by `2 SCALE_GRID_EDGE_PX`,
    /// within the tolerance, at most [`SCALE_GRID_STEPS`] of them, each with a small budget
    /// ([`SCALE_GRID_PAIRS`] a spot beyond the five a solution needs, six from positions
    /// alone, at most [`SCALE_GRID_MAX_PAIRS`]). The search over the range finds a focal
    /// length from triangles of the brightest spots and fails where those are half false; the
    /// fixed-focal search absorbs a scale error of a pixel or so at the edge and finds stars
    /// among false spots.
    /// Each solution's false-match bound is multiplied by the number of focal lengths in its
    /// half of the grid, and by two (a union bound over each half, see [`SCALE_GRID_NEAR`]);
    /// `before` is the search over the range, whose work the result adds to. The frame's time
    /// limit, counted from `start`, holds for the whole grid.
    fn search_scale_grid(
        &self,
        call: Call<'_>,
        before: &super::unknown_focal::FocalIdentification,
    ) -> Result<Option<super::unknown_focal::FocalIdentification>> {
        let (centroids, magnitudes, camera, config, start) = call.parts();
        let (shortest, longest) = config.focal_range_px(camera);
        let f0 = camera.focal_length_px;
        let half_diagonal = 0.5 * camera.width_px.hypot(camera.height_px);
        let step = 2.0 * SCALE_GRID_EDGE_PX / half_diagonal;
        let grid: Vec<f64> = (1..=SCALE_GRID_STEPS / 2)
            .flat_map(|k| [1.0 + k as f64 * step, 1.0 - k as f64 * step])
            .map(|s| f0 * s)
            .filter(|f| (shortest..=longest).contains(f))
            .collect();
        // The given focal length was tried already: it counts among the grid's. A field is more
        // often a little off than far off, so the bound is shared out in two halves: one over
        // the focal lengths within [`SCALE_GRID_NEAR`] of the given one (the given one among
        // them), one over the rest (a union bound over each half).
        let is_near = |f: f64| (f / f0 - 1.0).abs() <= SCALE_GRID_NEAR;
        let near = grid.iter().filter(|&&f| is_near(f)).count() + 1;
        let far = grid.len() + 1 - near;
        let halves = if far == 0 { 1.0 } else { 2.0 };
        let scales_at = |f: f64| halves * (if is_near(f) { near } else { far }) as f64;
        let needed = if magnitudes.is_some() {
            SCALE_GRID_MIN_MATCHES
        } else {
            SCALE_GRID_MIN_MATCHES_UNORDERED
        };
        // A frame of fewer spots than a solution of the grid names has none to find there.
        if centroids.len() < needed {
            return Ok(None);
        }
        let beyond_needed = centroids.len().saturating_sub(needed).max(1);
        let pairs = (SCALE_GRID_PAIRS * beyond_needed).min(SCALE_GRID_MAX_PAIRS);
        let each = IdentifyConfig {
            fov_tolerance: 0.0,
            max_pairs_visited: config.max_pairs_visited.min(pairs),
            // The focal length is refined over the matches instead.
            focal_check: false,
            ..config.clone()
        };
        let mut hypotheses = before.identification.hypotheses;
        let deadline = config.timeout.map(|t| start + t);
        for f in grid {
            let scales = scales_at(f);
            if stop_now(deadline, config.cancel.as_ref()) {
                break;
            }
            let each = IdentifyConfig {
                timeout: deadline.map(|d| d.saturating_duration_since(Instant::now())),
                max_false_match_prob: config.max_false_match_prob / scales,
                ..each.clone()
            };
            // Identified at the grid's focal length, chosen before the frame was seen: its bound
            // is the one that counts (a focal length refined over the matches fits them, and
            // its identification's bound would count the fit as evidence).
            let mut cam = *camera;
            cam.focal_length_px = f;
            let first = self.identify_with(centroids, magnitudes, &cam, &each, false)?;
            hypotheses += first.hypotheses;
            let bound = first.false_match_probability * scales;
            if !first.verified || first.matched < needed || bound > config.max_false_match_prob {
                continue;
            }
            // Then with the focal length refined over the stars matched, until it settles (the
            // grid's may lie a step off the truth).
            let (done, hyps) = self.finish(centroids, magnitudes, cam, Some(first), &each)?;
            hypotheses += hyps;
            let Some((mut id, cam, fit)) = done else {
                continue;
            };
            id.false_match_probability = (id.false_match_probability * scales).max(bound).min(1.0);
            if !id.verified || id.false_match_probability > config.max_false_match_prob {
                continue;
            }
            id.hypotheses = hypotheses;
            return Ok(Some(super::unknown_focal::FocalIdentification {
                identification: id,
                camera: Some(cam),
                fit: Some(fit),
                focal_hypotheses: before.focal_hypotheses,
                base_pairs: before.base_pairs,
            }));
        }
        Ok(None)
    }
}

/// A solution whose matched spots lie this close together (the median distance from their
/// median, as a fraction of the sensor's half diagonal) fixes its attitude but not the scale:
/// a tight cluster of stars fits a focal length well off the truth, and the spots it names far
/// from the cluster may be stars that a wrong scale carried onto other spots.
const CLUSTER_FRACTION: f64 = 0.15;

/// Whether the spots `id` names are clustered (see [`CLUSTER_FRACTION`]).
fn clustered(id: &Identification, centroids: &[[f64; 2]], camera: &Camera) -> bool {
    let named: Vec<[f64; 2]> = (id.catalog_index.iter().zip(centroids))
        .filter_map(|(s, c)| s.map(|_| *c))
        .collect();
    if named.is_empty() {
        return false;
    }
    let median = |k: usize| {
        let mut v: Vec<f64> = named.iter().map(|p| p[k]).collect();
        median_in_place(&mut v)
    };
    let (mx, my) = (median(0), median(1));
    let mut d: Vec<f64> = named.iter().map(|p| (p[0] - mx).hypot(p[1] - my)).collect();
    let half_diagonal = 0.5 * camera.width_px.hypot(camera.height_px);
    median_in_place(&mut d) < CLUSTER_FRACTION * half_diagonal
}
