//! The tracker's rules that unname: stars unseen lately or of magnitudes the camera rarely
//! detects wait for a second frame; a star placed off the sensor keeps no far spot; brightness
//! rivals and pairs swapped along the smear are not named.

use super::*;

impl Tracker {
    /// The zero point the kept ones agree on and the tolerance to search with it, as a batch
    /// learns it (see [`Solver::identify_batch`]); `None` with
    /// [`IdentifyConfig::learn_zero_point`] off.
    pub(super) fn learned_zero_point(&self) -> Option<(f64, f64)> {
        if !self.identify.learn_zero_point {
            return None;
        }
        let (z, s): (Vec<f64>, Vec<f64>) = self.zero_points.iter().copied().unzip();
        crate::identify::agreed_zero_point(&z, &s, self.identify.mag_tolerance)
    }

    /// Unname the stars `id` names that the last `k` solutions in a row had well inside the
    /// sensor without naming them (the last [`CONFIRM_NEVER_NAMED_FRAMES`], when none named
    /// them since they came well inside), unless the last frame matched them too (they are in
    /// `self.held`); the ones unnamed go to `held_now` (see
    /// [`TrackerConfig::confirm_unseen_frames`]).
    pub(super) fn hold_unseen(
        &self,
        id: &mut Identification,
        k: u32,
        solver: &Solver,
        held_now: &mut Vec<u32>,
    ) {
        let mag = solver.catalog().mag();
        let mut dropped = 0;
        for (o, m) in id.catalog_index.iter_mut().enumerate() {
            let Some(star) = *m else { continue };
            let (streak, fresh) = self.entry(star).unwrap_or((0, false));
            let suspect = streak >= k
                || (fresh && streak >= k.min(CONFIRM_NEVER_NAMED_FRAMES))
                || (self.rarely_seen(mag[star as usize])
                    && self.confirmed.binary_search(&star).is_err());
            if suspect && self.held.binary_search(&star).is_err() {
                *m = None;
                id.residuals_rad[o] = f64::NAN;
                dropped += 1;
                held_now.push(star);
            }
        }
        id.matched -= dropped;
        held_now.sort_unstable();
    }

    /// The stars the solution `r` has well inside the sensor without naming them, with the
    /// solutions in a row that did so and whether any named them since they came well inside
    /// (a star not in the list was either named by the last solution or is new there).
    /// Also counts the field's stars in [`Self::completeness`] (`matched`: the stars matched
    /// before any hold, sorted).
    pub(super) fn count_unseen(
        &mut self,
        id: &Identification,
        matched: &[u32],
        solver: &Solver,
        camera: &Camera,
        r: &Rotation3<f64>,
    ) {
        let catalog = solver.catalog();
        let (cat, mag) = (catalog.vectors(), catalog.mag());
        let mut named: Vec<u32> = id.catalog_index.iter().flatten().copied().collect();
        named.sort_unstable();
        let mut unseen = Vec::new();
        let boresight = r.inverse_transform_vector(&Vector3::z());
        let mut completeness = std::mem::take(&mut self.completeness);
        catalog.for_each_in_cone(&boresight, 0.5 * camera.diagonal_fov_rad(), |star, _| {
            if !well_inside(camera, &(r * cat[star as usize])) {
                return;
            }
            count_bin(
                &mut completeness,
                mag[star as usize],
                matched.binary_search(&star).is_ok(),
            );
            if named.binary_search(&star).is_err() {
                let (streak, fresh) = self
                    .entry(star)
                    .unwrap_or_else(|| (0, self.confirmed.binary_search(&star).is_err()));
                unseen.push((star, streak.saturating_add(1), fresh));
            }
        });
        self.completeness = completeness;
        unseen.sort_unstable_by_key(|u| u.0);
        self.unseen = unseen;
        self.confirmed = named;
    }

    /// The median magnitude spread of the kept zero points ([`Identification::zero_point`]),
    /// when there are at least [`TYPICAL_SPREAD_MIN_FRAMES`].
    pub(super) fn typical_spread(&self) -> Option<f64> {
        if self.zero_points.len() < TYPICAL_SPREAD_MIN_FRAMES {
            return None;
        }
        let mut s: Vec<f64> = self.zero_points.iter().map(|z| z.1).collect();
        Some(crate::identify::median_in_place(&mut s))
    }

    /// Whether stars of catalogue magnitude `mag` are ones the camera rarely detects (see
    /// [`RARELY_SEEN_FRACTION`]); `false` while their bin has counted too few.
    pub(super) fn rarely_seen(&self, mag: f64) -> bool {
        let [seen, total] = self.completeness[completeness_bin(mag)];
        total >= RARELY_SEEN_MIN_COUNT && f64::from(seen) < RARELY_SEEN_FRACTION * f64::from(total)
    }

    /// Unname, in a tracking solution, the matches of stars the solution places off the sensor
    /// (see [`OFF_SENSOR_SIGMAS`]), and with magnitudes or the brightness order, those whose
    /// spot's magnitude fits a rival decisively better (see [`MAG_RIVAL_LOG_ODDS`]).
    pub(super) fn unname_doubtful(
        &self,
        id: &mut Identification,
        solver: &Solver,
        camera: &Camera,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
    ) -> Vec<[f64; 2]> {
        let Some(r) = id.r_icrs_to_cam else {
            return Vec::new();
        };
        let dirs: Vec<Vector3<f64>> = centroids
            .iter()
            .map(|&[x, y]| camera.pixel_to_cam(x, y, id.mirrored))
            .collect();
        let mut drop = vec![false; id.catalog_index.len()];
        let named = Solution {
            id,
            solver,
            camera,
            r: &r,
            dirs: &dirs,
        };
        off_sensor(&named, &mut drop);
        self.brightness_rivals(&named, magnitudes, &mut drop);
        let smear = self.smear_rivals(&named, &mut drop);
        for (o, d) in drop.into_iter().enumerate() {
            if d && id.catalog_index[o].take().is_some() {
                id.residuals_rad[o] = f64::NAN;
                id.matched -= 1;
            }
        }
        smear
    }

    /// Mark in `drop` the spots of a solution whose magnitude, or the one their place in the
    /// brightness order implies (see [`order_magnitudes`]), fits a rival star or spot decisively
    /// better (see [`MAG_RIVAL_LOG_ODDS`]).
    fn brightness_rivals(
        &self,
        named: &Solution<'_>,
        magnitudes: Option<&[f64]>,
        drop: &mut [bool],
    ) {
        let (id, solver, r, dirs) = (named.id, named.solver, named.r, named.dirs);
        let catalog = solver.catalog();
        let (cat, mag) = (catalog.vectors(), catalog.mag());
        let n = id.catalog_index.len();
        // The spots' magnitudes, or from the brightness order alone, the magnitudes their places
        // in it imply (see `order_magnitudes`); and the zero point and spread, for the rival tests.
        let from_order = match magnitudes {
            None if self.identify.brightness_order => Some(order_magnitudes(id, mag)),
            _ => None,
        };
        let (mags, zero) = match (&from_order, magnitudes.filter(|m| m.len() == n)) {
            (Some((m, spread)), _) => (Some(&m[..]), spread.map(|s| (0.0, s))),
            (None, Some(m)) => (
                Some(m),
                id.zero_point(m, catalog).map(|(z, s)| {
                    // The spread the last solutions measured, where there are enough of them: a
                    // frame's own, from a dozen stars, is rough.
                    (z, self.typical_spread().unwrap_or(s))
                }),
            ),
            _ => (None, None),
        };
        let zero = zero.filter(|_| id.match_radius_rad.is_finite() && id.match_radius_rad > 0.0);
        if let (Some((z, spread)), Some(mags)) = (zero, mags) {
            let spread = spread.max(MAG_RIVAL_MIN_SPREAD);
            // On the order alone, the verification's check of spots far brighter than their
            // star (a false spot on a star too faint to be seen), which real magnitudes get
            // there, with the magnitudes the order implies (see [`ORDER_BRIGHTER_LIMIT`]).
            if from_order.is_some() {
                let limit = ORDER_BRIGHTER_LIMIT.max(MAG_OUTLIER_SIGMAS * spread);
                for (o, m) in id.catalog_index.iter().enumerate() {
                    if let Some(star) = *m {
                        drop[o] |= mags[o] - z < mag[star as usize] - limit;
                    }
                }
            }
            // Spots far fainter than their star and out of the brightness order: with magnitudes,
            // by their own; on the order alone, by the ones the order implies, but counting the
            // spots before them in the order (the magnitudes it implies for the brightest spots
            // are those of the stars below them, far fainter than theirs).
            let fainter = MAG_FAINTER_LIMIT.max(MAG_OUTLIER_SIGMAS * spread);
            let brighter = |p: usize, o: usize| match from_order {
                Some(_) => p < o,
                None => mags[p] < mags[o],
            };
            for (o, m) in id.catalog_index.iter().enumerate() {
                let Some(star) = *m else { continue };
                let m_star = mag[star as usize];
                // (A spot with no magnitude, NaN, is not judged.)
                let excess = mags[o] - z - m_star;
                if excess.is_nan() || excess <= fainter {
                    continue;
                }
                // Named spots of stars fainter by half the limit that are brighter.
                let inversions = (id.catalog_index.iter().enumerate())
                    .filter(|&(p, q)| {
                        q.is_some_and(|s| mag[s as usize] > m_star + 0.5 * fainter)
                            && brighter(p, o)
                    })
                    .count();
                drop[o] |= inversions >= FAINTER_INVERSIONS_MIN;
            }
            // (A spot with no magnitude, NaN, fits nothing better.)
            let chi = |o: usize, k: u32| {
                let d = (mags[o] - z - mag[k as usize]) / spread;
                if d.is_nan() {
                    0.0
                } else {
                    d * d
                }
            };
            let decisive = 2.0 * MAG_RIVAL_LOG_ODDS;
            let reach = MAG_RIVAL_REACH * id.match_radius_rad;
            let reach_r = crate::sky::Radius::new(reach);
            let mut named: Vec<(u32, usize)> = id
                .catalog_index
                .iter()
                .enumerate()
                .filter_map(|(o, m)| m.map(|s| (s, o)))
                .collect();
            named.sort_unstable();
            let spot_of = |star: u32| {
                named
                    .binary_search_by_key(&star, |x| x.0)
                    .ok()
                    .map(|i| named[i].1)
            };
            let dirs: Vec<Vector3<f64>> =
                dirs.iter().map(|d| r.inverse_transform_vector(d)).collect();
            for &(star, o) in &named {
                let own = chi(o, star);
                // A swap's two misfits add up to the margin: one of them is half of it.
                if own < 0.5 * decisive {
                    continue;
                }
                // A rival star nearby that the spot fits better; when another spot holds it,
                // the two spots' names swapped.
                catalog.for_each_near(&dirs[o], reach_r, |other, _, _| {
                    if other == star || self.rarely_seen(mag[other as usize]) {
                        return;
                    }
                    match spot_of(other) {
                        Some(p) => {
                            if own + chi(p, other) - chi(o, other) - chi(p, star) >= decisive {
                                drop[o] = true;
                                drop[p] = true;
                            }
                        }
                        None => drop[o] |= own - chi(o, other) >= decisive,
                    }
                });
                // A rival spot, unnamed, about as near the star, that fits it better.
                if own >= decisive {
                    let v = cat[star as usize];
                    drop[o] |= (0..n).any(|p| {
                        id.catalog_index[p].is_none()
                            && dirs[p].dot(&v) >= reach_r.cos()
                            && own - chi(p, star) >= decisive
                    });
                }
            }
        }
    }

    /// Mark in `drop` the spots of `id` (attitude `r`, camera-frame directions `dirs`) whose
    /// names are not decisive once the centroid noise is measured along the image motion and
    /// across it (see [`SMEAR_MIN_ANISOTROPY`]): two named spots whose stars, swapped, fit about
    /// as well are both dropped. The test is the verification's joint assignment
    /// (the same ln 1000 margin) under Gaussian noise of the two spreads, measured over this
    /// solution's and the last ones' named spots. Returns this solution's named spots' squared
    /// residuals along and across the motion, for the spreads of the frames that follow.
    fn smear_rivals(&self, named: &Solution<'_>, drop: &mut [bool]) -> Vec<[f64; 2]> {
        let (id, solver, camera, r, dirs) =
            (named.id, named.solver, named.camera, named.r, named.dirs);
        let Some(rate) = self.rate.filter(|w| w.norm() > 0.0) else {
            return Vec::new();
        };
        let cat = solver.catalog().vectors();
        // Each named spot with its star's pixel and the image motion's direction there (pixels
        // of the unmirrored image, as the attitude projects them).
        let step = 1e-4 / rate.norm();
        let mut named: Vec<SmearedSpot> = Vec::new();
        for (o, m) in id.catalog_index.iter().enumerate() {
            let Some(star) = *m else { continue };
            let (Some(at), Some(star_at), Some(moved)) = (
                camera.cam_to_pixel(&dirs[o]),
                camera.cam_to_pixel(&(r * cat[star as usize])),
                camera.cam_to_pixel(&(dirs[o] + step * rate.cross(&dirs[o]))),
            ) else {
                continue;
            };
            let (ux, uy) = (moved.0 - at.0, moved.1 - at.1);
            let len = ux.hypot(uy);
            if len > 0.0 {
                named.push(SmearedSpot {
                    spot: o,
                    at: [at.0, at.1],
                    star_at: [star_at.0, star_at.1],
                    dir: [ux / len, uy / len],
                });
            }
        }
        let this: Vec<[f64; 2]> = named
            .iter()
            .map(|n| {
                let (e, u) = ([n.at[0] - n.star_at[0], n.at[1] - n.star_at[1]], n.dir);
                [
                    (e[0] * u[0] + e[1] * u[1]).powi(2),
                    (e[0] * u[1] - e[1] * u[0]).powi(2),
                ]
            })
            .collect();
        // The spreads along and across the motion: robust (the median of the squared
        // components over that of a χ² with one degree of freedom).
        let pooled = || self.smear.iter().chain(&this);
        if pooled().count() < SMEAR_MIN_NAMED {
            return this;
        }
        let spread = |k: usize| {
            let mut v: Vec<f64> = pooled().map(|c| c[k]).collect();
            crate::identify::median_in_place(&mut v) / CHI2_1_MEDIAN
        };
        let (var_along, var_across) = (spread(0), spread(1));
        if !(var_across > 0.0 && var_along >= SMEAR_MIN_ANISOTROPY.powi(2) * var_across) {
            return this;
        }
        // Twice the log-likelihood ratio the name must win by, in units of the spreads.
        let decisive = 2.0 * crate::identify::AMBIGUITY_LOG_ODDS;
        let cost = |at: &[f64; 2], star_at: &[f64; 2], u: &[f64; 2]| {
            let e = [at[0] - star_at[0], at[1] - star_at[1]];
            (e[0] * u[0] + e[1] * u[1]).powi(2) / var_along
                + (e[0] * u[1] - e[1] * u[0]).powi(2) / var_across
        };
        // Stars farther apart than this (pixels) are never so confused.
        let reach_px = 2.0 * (decisive * var_along).sqrt();
        // Named pairs whose stars lie within reach: by the stars' x, a window each.
        named.sort_unstable_by(|a, b| a.star_at[0].total_cmp(&b.star_at[0]));
        for (i, na) in named.iter().enumerate() {
            let (oa, pa, sa, ua) = (na.spot, na.at, na.star_at, na.dir);
            for nb in &named[i + 1..] {
                let (ob, pb, sb, ub) = (nb.spot, nb.at, nb.star_at, nb.dir);
                if sb[0] - sa[0] > reach_px {
                    break;
                }
                if (sb[1] - sa[1]).abs() > reach_px {
                    continue;
                }
                let straight = cost(&pa, &sa, &ua) + cost(&pb, &sb, &ub);
                let crossed = cost(&pa, &sb, &ua) + cost(&pb, &sa, &ub);
                if crossed - straight < decisive {
                    drop[oa] = true;
                    drop[ob] = true;
                }
            }
        }
        this
    }

    /// `star`'s entry in `self.unseen`: the solutions in a row that had it well inside the sensor
    /// without naming it, and whether none named it since it came well inside.
    pub(super) fn entry(&self, star: u32) -> Option<(u32, bool)> {
        self.unseen
            .binary_search_by_key(&star, |u| u.0)
            .ok()
            .map(|i| (self.unseen[i].1, self.unseen[i].2))
    }

    /// Unname the stars `id` names for the first time although the last solution (attitude
    /// `r0`) had them well inside the sensor (see [`TrackerConfig::confirm_new_stars`]).
    pub(super) fn confirm(
        &self,
        id: &mut Identification,
        solver: &Solver,
        camera: &Camera,
        r0: &Rotation3<f64>,
    ) {
        let cat = solver.catalog().vectors();
        let mut dropped = 0;
        for (k, m) in id.catalog_index.iter_mut().enumerate() {
            let Some(star) = *m else { continue };
            if self.named.binary_search(&star).is_ok() {
                continue;
            }
            // Where the last solution saw it.
            if well_inside(camera, &(r0 * cat[star as usize])) {
                *m = None;
                id.residuals_rad[k] = f64::NAN;
                dropped += 1;
            }
        }
        id.matched -= dropped;
    }
}

/// A tracking solution as the rules that unname its doubtful matches see it.
#[derive(Clone, Copy)]
struct Solution<'a> {
    id: &'a Identification,
    solver: &'a Solver,
    camera: &'a Camera,
    /// Its attitude.
    r: &'a Rotation3<f64>,
    /// The spots' camera-frame directions.
    dirs: &'a [Vector3<f64>],
}

/// Mark in `drop` the spots of a solution whose star the attitude fitted without the spot
/// places off the sensor, more than [`OFF_SENSOR_SIGMAS`] from the spot.
fn off_sensor(named: &Solution<'_>, drop: &mut [bool]) {
    let (id, solver, camera, r, dirs) = (named.id, named.solver, named.camera, named.r, named.dirs);
    let cat = solver.catalog().vectors();
    let sigma = id.centroid_sigma_px / camera.focal_length_px;
    let (w, h) = (camera.width_px, camera.height_px);
    let off = |p: Option<(f64, f64)>| {
        p.is_none_or(|(x, y)| !(0.0..=w).contains(&x) || !(0.0..=h).contains(&y))
    };
    let near_edge = |p: Option<(f64, f64)>, margin: f64| {
        p.is_none_or(|(x, y)| x.min(y).min(w - x).min(h - y) < margin)
    };
    let edge_margin = OFF_SENSOR_SIGMAS * id.centroid_sigma_px;
    let (mut obs, mut refs) = (Vec::new(), Vec::new());
    for (o, m) in id.catalog_index.iter().enumerate() {
        let Some(star) = *m else { continue };
        let v = cat[star as usize];
        if !near_edge(camera.cam_to_pixel(&(r * v)), edge_margin) {
            continue;
        }
        // Off the sensor, a star's own spot lies inside only by its noise, near the edge. The
        // attitude is fitted without the spot: a false one pulls the fit its way.
        obs.clear();
        refs.clear();
        for (p, q) in id.catalog_index.iter().enumerate() {
            if let (Some(s), true) = (*q, p != o) {
                obs.push(dirs[p]);
                refs.push(cat[s as usize]);
            }
        }
        let Some(r_without) = (obs.len() >= 3)
            .then(|| crate::attitude::wahba_from(&obs, &refs, r))
            .flatten()
        else {
            continue;
        };
        let predicted = r_without * v;
        drop[o] = off(camera.cam_to_pixel(&predicted))
            && dirs[o].angle(&predicted) > OFF_SENSOR_SIGMAS * sigma;
    }
}

/// Magnitudes for a frame's spots from their brightness order (spots brightest first): each spot
/// gets the median catalogue magnitude of the named spots nearest it in the order,
/// [`ORDER_NEIGHBOURS`] on either side, itself left out (NaN where fewer than 2 are); and the
/// spread of the named spots' catalogue magnitudes about theirs (1.4826 × the median absolute
/// difference), `None` with fewer than [`ORDER_SPREAD_MIN_NAMED`] named.
pub(super) fn order_magnitudes(id: &Identification, cat_mag: &[f64]) -> (Vec<f64>, Option<f64>) {
    let named: Vec<(usize, f64)> = id
        .catalog_index
        .iter()
        .enumerate()
        .filter_map(|(o, m)| m.map(|s| (o, cat_mag[s as usize])))
        .collect();
    let mut near = Vec::with_capacity(2 * ORDER_NEIGHBOURS);
    let estimate: Vec<f64> = (0..id.catalog_index.len())
        .map(|o| {
            // Named spots before `o` (its own place excluded), then after it.
            let k = named.partition_point(|x| x.0 < o);
            let after = if named.get(k).is_some_and(|x| x.0 == o) {
                k + 1
            } else {
                k
            };
            near.clear();
            near.extend(
                named[k.saturating_sub(ORDER_NEIGHBOURS)..k]
                    .iter()
                    .map(|x| x.1),
            );
            near.extend(
                named[after..(after + ORDER_NEIGHBOURS).min(named.len())]
                    .iter()
                    .map(|x| x.1),
            );
            if near.len() < 2 {
                f64::NAN
            } else {
                crate::identify::median_in_place(&mut near)
            }
        })
        .collect();
    let mut d: Vec<f64> = named
        .iter()
        .map(|&(o, m)| m - estimate[o])
        .filter(|d| d.is_finite())
        .collect();
    let spread = (d.len() >= ORDER_SPREAD_MIN_NAMED).then(|| {
        let centre = crate::identify::median_in_place(&mut d);
        for x in &mut d {
            *x = (*x - centre).abs();
        }
        1.4826 * crate::identify::median_in_place(&mut d)
    });
    (estimate, spread)
}

/// The [`Tracker::completeness`] bin of catalogue magnitude `mag`.
pub(super) fn completeness_bin(mag: f64) -> usize {
    let k = ((mag - COMPLETENESS_MAG_MIN) / COMPLETENESS_BIN_MAG).floor();
    if k.is_nan() {
        return 0;
    }
    (k.max(0.0) as usize).min(COMPLETENESS_BINS - 1)
}

/// Count a star of catalogue magnitude `mag`, `matched` or not, in its bin.
pub(super) fn count_bin(completeness: &mut [[u32; 2]], mag: f64, matched: bool) {
    let bin = &mut completeness[completeness_bin(mag)];
    if bin[1] >= COMPLETENESS_COUNT_CAP {
        *bin = [bin[0] / 2, bin[1] / 2];
    }
    bin[0] += u32::from(matched);
    bin[1] += 1;
}

/// Whether the camera-frame direction `v` falls on the sensor at least [`CONFIRM_MARGIN_PX`] from
/// its edges (a test symmetric in x, so the same in a mirrored frame).
pub(super) fn well_inside(camera: &Camera, v: &Vector3<f64>) -> bool {
    camera.cam_to_pixel(v).is_some_and(|(x, y)| {
        x >= CONFIRM_MARGIN_PX
            && y >= CONFIRM_MARGIN_PX
            && x <= camera.width_px - CONFIRM_MARGIN_PX
            && y <= camera.height_px - CONFIRM_MARGIN_PX
    })
}
