//! The source documents' identification methods (restated in `docs/SEEDS.md`,
//! sections 1–6), as methods of the shared search: each makes hypotheses in its own way, and
//! by default every hypothesis passes the shared verification like Pyramid's and voting's.
//! With `IdentifyConfig::verify` off (benchmarks and research only) a method's own first
//! answer is returned unverified, so that its accuracy can be measured as the documents meant.
//!
//! - [`Method::AngularDistance`] (P000 Method 1): the spot nearest the optical axis is the main
//!   star; its angular distances to the other spots are looked up in the k-vector, and a
//!   catalogue star is a candidate main star when *every* distance matches one of its own
//!   (P000's rule); candidates are taken in catalogue order, the first passing is the answer.
//! - [`Method::StarLineAngle`] (P000 Method 2): the main star's three nearest spots `A, B, C`
//!   (nearest first); the angles `∠ABC` and `∠BCA` between the lines joining them, against a
//!   table of the same two angles for each catalogue star's three nearest neighbours.
//! - [`Method::AngleSum`] (P000 Method 3): the closed loop `θ(M,N1) + θ(N1,N2) + θ(N2,N3) +
//!   θ(N3,M)` of the main star and its three nearest spots, against a sorted table of the same
//!   sum per catalogue star.
//! - [`Method::DistanceVote`] (P001 Model 1): a base spot near the frame's edge whose distances
//!   are distinct; every catalogue star gets a vote for each of the base's distances one of its
//!   own matches; the best voted is the base star.
//! - [`Method::RadialVote`] (P001 Model 2): the neighbour counts in [`RING_ORDER`] rings around
//!   a base spot near the centre screen the catalogue (ring width `FOV/2 · 1/n · 1/2`, the
//!   field being the square one of the index's diagonal); Model 1's vote runs on the
//!   candidates only.
//!
//! In every method the other spots are then named from the winner: through the table's
//! neighbours (methods 2 and 3) or through the catalogue star's own distances (1, 4 and 5),
//! each spot taking the partner at its distance when exactly one is.
//!
//! Tolerances follow the centroid noise of the search step (3σ of each feature, propagated
//! from the centroids), not the documents' fixed values (0.1/f, 0.015 rad, 0.0024°), which
//! were set for their noiseless frames. Their databases come from the k-vector (methods 1 and
//! 4, instead of a 4908 × 4908 matrix) and from [`SeedTables`] (2, 3 and 5), built once per
//! solver on first use.

use std::time::{Duration, Instant};

use nalgebra::{Rotation3, Vector3};

use super::{Method, Search, SearchLimit, Status, Verified};
use crate::attitude::wahba_svd;
use crate::catalog::Catalog;
use crate::geometry::angle_between;
use crate::kvector::AngleWindow;

/// Rings of the radial feature: P001's feature order `n`.
pub const RING_ORDER: usize = 3;

/// Largest summed difference of the ring counts for a catalogue star to remain a candidate of
/// the radial screen (a neighbour near a ring's edge crossing it, or one false or missing).
pub const RING_SLACK: u32 = 1;

/// Candidates (in the method's own order) whose hypotheses are verified per search step.
pub const SEED_CANDIDATES: usize = 64;

/// A catalogue star with fewer neighbours within the field than this has no entry in the
/// neighbour tables.
const NEIGHBOURS: usize = 3;

/// The tables of the source documents' methods for one field (P000's neighbour tables and
/// P001's ring counts). Built by [`super::Solver::seed_tables`] on first use.
#[derive(Debug, Clone)]
pub struct SeedTables {
    /// Each catalogue star's three nearest neighbours within half the field's width, nearest
    /// first (`u32::MAX` rows when it has fewer).
    neighbours: Vec<[u32; NEIGHBOURS]>,
    /// `(∠ABC, ∠BCA, star)` in radians, sorted by the first angle.
    line_angles: Vec<(f32, f32, u32)>,
    /// `(angle sum in degrees, star)`, sorted.
    sums: Vec<(f32, u32)>,
    /// Neighbour counts per ring, per catalogue star.
    rings: Vec<[u8; RING_ORDER]>,
    ring_width_rad: f64,
    neighbour_radius_rad: f64,
    neighbour_time: Duration,
    ring_time: Duration,
}

/// Angle at `q` between the lines `q → p` and `q → r` (unsigned, radians).
fn corner(p: &Vector3<f64>, q: &Vector3<f64>, r: &Vector3<f64>) -> f64 {
    angle_between(&(p - q), &(r - q))
}

/// The three features of a main star `m` and its neighbours `a, b, c` (nearest first):
/// `∠ABC`, `∠BCA` (radians) and the loop sum (degrees).
fn features(m: &Vector3<f64>, [a, b, c]: [&Vector3<f64>; 3]) -> (f64, f64, f64) {
    let sum = angle_between(m, a) + angle_between(a, b) + angle_between(b, c) + angle_between(c, m);
    (corner(a, b, c), corner(b, c, a), sum.to_degrees())
}

impl SeedTables {
    /// Tables for square fields `field_width_rad` wide.
    pub(crate) fn build(catalog: &Catalog, field_width_rad: f64) -> Self {
        let t = Instant::now();
        let vecs = catalog.vectors();
        let radius = 0.5 * field_width_rad;
        let per_star = |i: usize| -> [u32; NEIGHBOURS] {
            let mut near: Vec<(f64, u32)> = Vec::new();
            catalog.for_each_in_cone(&vecs[i], radius, |s, cos| {
                if s as usize != i {
                    near.push((cos, s));
                }
            });
            if near.len() < NEIGHBOURS {
                return [u32::MAX; NEIGHBOURS];
            }
            near.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            [near[0].1, near[1].1, near[2].1]
        };
        let neighbours: Vec<[u32; NEIGHBOURS]> = map_stars(catalog.len(), per_star);
        let mut line_angles = Vec::with_capacity(neighbours.len());
        let mut sums = Vec::with_capacity(neighbours.len());
        for (i, nb) in neighbours.iter().enumerate() {
            if nb[0] == u32::MAX {
                continue;
            }
            let [a, b, c] = nb.map(|s| &vecs[s as usize]);
            let (ab, bc, sum) = features(&vecs[i], [a, b, c]);
            line_angles.push((ab as f32, bc as f32, i as u32));
            sums.push((sum as f32, i as u32));
        }
        line_angles.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        sums.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let neighbour_time = t.elapsed();
        let t = Instant::now();
        // P001: r = (r1 / 2) · (1 / n) · (1 / 2), r1 the field of view, n the feature order.
        let ring_width_rad = 0.5 * field_width_rad / RING_ORDER as f64 * 0.5;
        let rings = map_stars(catalog.len(), |i| {
            let mut counts = [0u8; RING_ORDER];
            catalog.for_each_in_cone(&vecs[i], ring_width_rad * RING_ORDER as f64, |s, _| {
                if s as usize != i {
                    let ring = ring_of(angle_between(&vecs[i], &vecs[s as usize]), ring_width_rad);
                    if let Some(r) = ring {
                        counts[r] = counts[r].saturating_add(1);
                    }
                }
            });
            counts
        });
        Self {
            neighbours,
            line_angles,
            sums,
            rings,
            ring_width_rad,
            neighbour_radius_rad: radius,
            neighbour_time,
            ring_time: t.elapsed(),
        }
    }

    /// Memory of the star-line-angle tables (angles and neighbour rows), bytes.
    pub fn star_line_angle_bytes(&self) -> usize {
        self.line_angles.len() * std::mem::size_of::<(f32, f32, u32)>() + self.neighbour_bytes()
    }

    /// Memory of the angle-sum tables (sums and neighbour rows), bytes.
    pub fn angle_sum_bytes(&self) -> usize {
        self.sums.len() * std::mem::size_of::<(f32, u32)>() + self.neighbour_bytes()
    }

    /// Memory of the ring-count table, bytes.
    pub fn ring_bytes(&self) -> usize {
        self.rings.len() * RING_ORDER
    }

    /// Memory of all the tables, bytes (the neighbour rows counted once).
    pub fn memory_bytes(&self) -> usize {
        self.star_line_angle_bytes() + self.angle_sum_bytes() - self.neighbour_bytes()
            + self.ring_bytes()
    }

    fn neighbour_bytes(&self) -> usize {
        self.neighbours.len() * std::mem::size_of::<[u32; NEIGHBOURS]>()
    }

    /// Time to build the neighbour tables (shared by star-line-angle and angle-sum).
    pub fn neighbour_build_time(&self) -> Duration {
        self.neighbour_time
    }

    /// Time to build the ring-count table.
    pub fn ring_build_time(&self) -> Duration {
        self.ring_time
    }

    /// Width of one ring of the radial feature, radians.
    pub fn ring_width_rad(&self) -> f64 {
        self.ring_width_rad
    }

    /// Radius within which the neighbour tables look for neighbours, radians.
    pub fn neighbour_radius_rad(&self) -> f64 {
        self.neighbour_radius_rad
    }
}

/// The entries of `table` (sorted by `key`) whose key is within `tol` of `value`.
fn within<T>(table: &[T], key: impl Fn(&T) -> f32, value: f64, tol: f64) -> &[T] {
    let lo = table.partition_point(|e| f64::from(key(e)) < value - tol);
    let hi = table.partition_point(|e| f64::from(key(e)) <= value + tol);
    &table[lo..hi.max(lo)]
}

/// The ring (0-based) an angle falls in, `None` beyond the last.
fn ring_of(angle: f64, width: f64) -> Option<usize> {
    let r = (angle / width).ceil() as usize;
    (1..=RING_ORDER).contains(&r).then(|| r - 1)
}

fn map_stars<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    #[cfg(feature = "parallel")]
    {
        use rayon::prelude::*;
        (0..n).into_par_iter().map(f).collect()
    }
    #[cfg(not(feature = "parallel"))]
    {
        (0..n).map(f).collect()
    }
}

/// How the other spots are named once a candidate main (base) star is chosen.
enum Naming<'t> {
    /// Main spot and its three nearest spots, to the catalogue star and its table neighbours.
    Neighbours(usize, [usize; NEIGHBOURS], &'t [[u32; NEIGHBOURS]]),
    /// Base spot and `(spot, angle)` of the others, through the catalogue star's own distances.
    Distances(usize, Vec<(usize, f64)>),
}

impl Search<'_> {
    /// One step of a source document's method at centroid noise `sigma_px`, over the first
    /// `stars` centroids (in brightness or input order).
    pub(super) fn seed(
        &mut self,
        method: Method,
        stars: usize,
        sigma_px: f64,
    ) -> std::result::Result<Option<Verified>, SearchLimit> {
        let f = self.camera.focal_length_px;
        let sigma_rad = sigma_px / f;
        let eps = 3.0 * std::f64::consts::SQRT_2 * sigma_rad + 1e-7;
        let spots: Vec<usize> = self.order[..stars.min(self.order.len())].to_vec();
        if spots.len() < 2 {
            return Ok(None);
        }
        let obs = self.obs[0];
        let max_angle = self.pairs.max_angle_rad() - eps;
        let solver = self.solver;
        // The spot nearest the optical axis.
        let central = *spots
            .iter()
            .max_by(|&&a, &&b| obs[a].z.total_cmp(&obs[b].z).then(b.cmp(&a)))
            .expect("two spots");
        let distances_from = |base: usize| -> Vec<(usize, f64)> {
            spots
                .iter()
                .filter(|&&k| k != base)
                .map(|&k| (k, angle_between(&obs[base], &obs[k])))
                .filter(|&(_, t)| t >= eps && t <= max_angle)
                .collect()
        };
        let (candidates, naming): (Vec<u32>, Naming<'_>) = match method {
            Method::AngularDistance => {
                let d = distances_from(central);
                if d.is_empty() {
                    return Ok(None);
                }
                let counts = self.distance_counts(&d, eps);
                let all = d.len() as u16;
                let c = (0..counts.len() as u32)
                    .filter(|&s| counts[s as usize] >= all)
                    .collect();
                self.scratch.votes = counts;
                (c, Naming::Distances(central, d))
            }
            Method::DistanceVote => {
                let base = self.edge_base(&spots, eps, max_angle);
                let d = distances_from(base);
                if d.is_empty() {
                    return Ok(None);
                }
                let counts = self.distance_counts(&d, eps);
                let mut c: Vec<u32> = (0..counts.len() as u32)
                    .filter(|&s| counts[s as usize] >= 2)
                    .collect();
                c.sort_by_key(|&s| (std::cmp::Reverse(counts[s as usize]), s));
                self.scratch.votes = counts;
                (c, Naming::Distances(base, d))
            }
            Method::RadialVote => {
                let tables = solver.seed_tables();
                let width = tables.ring_width_rad;
                let base = self.ring_base(&spots, width);
                let mut observed = [0u32; RING_ORDER];
                for &k in spots.iter().filter(|&&k| k != base) {
                    if let Some(r) = ring_of(angle_between(&obs[base], &obs[k]), width) {
                        observed[r] += 1;
                    }
                }
                let screened: Vec<u32> = tables
                    .rings
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| {
                        c.iter()
                            .zip(&observed)
                            .map(|(&a, &b)| u32::from(a).abs_diff(b))
                            .sum::<u32>()
                            <= RING_SLACK
                    })
                    .map(|(s, _)| s as u32)
                    .collect();
                self.pairs_visited += tables.rings.len();
                // Model 1 on the screened candidates only.
                let d = distances_from(base);
                if d.is_empty() {
                    return Ok(None);
                }
                let mut voted: Vec<(u32, usize)> = screened
                    .into_iter()
                    .map(|s| (s, self.partner_matches(s, &d, eps).0))
                    .filter(|&(_, v)| v >= 2)
                    .collect();
                voted.sort_by_key(|&(s, v)| (std::cmp::Reverse(v), s));
                (
                    voted.into_iter().map(|(s, _)| s).collect(),
                    Naming::Distances(base, d),
                )
            }
            Method::StarLineAngle | Method::AngleSum => {
                let tables = solver.seed_tables();
                let mut near: Vec<(f64, usize)> = spots
                    .iter()
                    .filter(|&&k| k != central)
                    .map(|&k| (angle_between(&obs[central], &obs[k]), k))
                    .collect();
                if near.len() < NEIGHBOURS {
                    return Ok(None);
                }
                near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
                let nb = [near[0].1, near[1].1, near[2].1];
                let [a, b, c] = nb.map(|k| &obs[k]);
                let (ab, bc, sum) = features(&obs[central], [a, b, c]);
                let mut scored: Vec<(f64, u32)> = if method == Method::StarLineAngle {
                    // A line's direction moves by √2·σ/|side|: each angle by the two lines' sum.
                    let line = |p: &Vector3<f64>, q: &Vector3<f64>| {
                        std::f64::consts::SQRT_2 * sigma_rad / (p - q).norm().max(1e-12)
                    };
                    let tol_b = 3.0 * (line(a, b).powi(2) + line(c, b).powi(2)).sqrt() + 1e-6;
                    let tol_c = 3.0 * (line(b, c).powi(2) + line(a, c).powi(2)).sqrt() + 1e-6;
                    let near = within(&tables.line_angles, |e| e.0, ab, tol_b);
                    self.pairs_visited += near.len();
                    near.iter()
                        .filter(|e| (f64::from(e.1) - bc).abs() <= tol_c)
                        .map(|e| {
                            let err = (f64::from(e.0) - ab).abs() / tol_b
                                + (f64::from(e.1) - bc).abs() / tol_c;
                            (err, e.2)
                        })
                        .collect()
                } else {
                    // Four edges, each moved by √2·σ.
                    let tol =
                        (3.0 * 2.0 * std::f64::consts::SQRT_2 * sigma_rad).to_degrees() + 1e-6;
                    let near = within(&tables.sums, |e| e.0, sum, tol);
                    self.pairs_visited += near.len();
                    near.iter()
                        .map(|e| ((f64::from(e.0) - sum).abs(), e.1))
                        .collect()
                };
                scored.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                (
                    scored.into_iter().map(|(_, s)| s).collect(),
                    Naming::Neighbours(central, nb, &tables.neighbours),
                )
            }
            _ => unreachable!("seed() runs the source documents' methods only"),
        };
        if !self.config.verify {
            for &c in &candidates {
                let assignment = self.name_from(c, &naming, eps);
                if assignment.len() >= 2 {
                    self.hypotheses += 1;
                    return Ok(Some(self.raw(&assignment)));
                }
            }
            return Ok(None);
        }
        // Every candidate the feature let through is a hypothesis, verified or not (in either
        // handedness): the false-match bound's union runs over all of them, as over Pyramid's
        // catalogue triangles, so that picking the best of many cannot pass off a coincidence.
        let handedness = if self.config.allow_mirrored { 2 } else { 1 };
        self.hypotheses = self
            .hypotheses
            .saturating_add(candidates.len() * handedness);
        let r_confirm = 8.0 * sigma_rad + 2e-7;
        let mut best: Option<Verified> = None;
        let found =
            self.verify_candidates(&candidates, &naming, eps, r_confirm, sigma_rad, &mut best);
        self.built = 3;
        match found {
            Err(limit) => self.accept(best).map_or(Err(limit), |v| Ok(Some(v))),
            Ok(()) => Ok(self.accept(best)),
        }
    }

    /// Verify the candidates in the method's order: a strong solution (bound below
    /// [`super::STRONG_FALSE_MATCH_PROB`]) ends the search; otherwise the strongest of the first
    /// [`SEED_CANDIDATES`] is kept in `best`, as Pyramid looks further after a weak one.
    fn verify_candidates(
        &mut self,
        candidates: &[u32],
        naming: &Naming<'_>,
        eps: f64,
        r_confirm: f64,
        sigma_rad: f64,
        best: &mut Option<Verified>,
    ) -> std::result::Result<(), SearchLimit> {
        for &c in candidates.iter().take(SEED_CANDIDATES) {
            let assignment = self.name_from(c, naming, eps);
            if assignment.len() < 2 {
                continue;
            }
            // A four-star feature (main star and three neighbours) matches its four stars by
            // construction; a distance names a partner's radius only, its azimuth is evidence.
            self.built = if matches!(naming, Naming::Neighbours(..)) {
                4
            } else {
                3
            };
            for (r, mirrored) in self.fit_assignment(&assignment) {
                if self.pairs_visited - self.gated_work >= self.config.max_pairs_visited {
                    return Err(SearchLimit(Status::SearchLimit));
                }
                if self.out_of_time() {
                    return Err(SearchLimit(Status::Timeout));
                }
                if let Some(v) = self.verify(r, mirrored, r_confirm, sigma_rad) {
                    if v.tail * self.hypotheses as f64 <= super::STRONG_FALSE_MATCH_PROB {
                        *best = Some(v);
                        return Ok(());
                    }
                    if best.as_ref().is_none_or(|b| v.tail < b.tail) {
                        *best = Some(v);
                    }
                }
            }
        }
        Ok(())
    }

    /// For every catalogue star, how many of the distances `d` one of its pairs matches
    /// (each distance counted once per star), through the k-vector.
    fn distance_counts(&mut self, d: &[(usize, f64)], eps: f64) -> Vec<u16> {
        let n_cat = self.solver.catalog.len();
        let mut counts = std::mem::take(&mut self.scratch.votes);
        counts.clear();
        counts.resize(n_cat, 0);
        let mut stamp = vec![u32::MAX; n_cat];
        let idx = self.pairs;
        let cat = self.solver.catalog.vectors();
        for (k, &(_, t)) in d.iter().enumerate() {
            let range = idx.range_exact(&AngleWindow::new(t - eps, t + eps), cat);
            self.pairs_visited += range.len();
            for [p, q] in idx.pairs(range) {
                for s in [p, q] {
                    if stamp[s as usize] != k as u32 {
                        stamp[s as usize] = k as u32;
                        counts[s as usize] = counts[s as usize].saturating_add(1);
                    }
                }
            }
        }
        counts
    }

    /// P001's base star: near the frame's edge, with distances to the others as distinct as
    /// possible: the farthest spot from the optical axis whose sorted distances are all more
    /// than `2·eps` apart (the farthest of all when none is).
    fn edge_base(&self, spots: &[usize], eps: f64, max_angle: f64) -> usize {
        let obs = self.obs[0];
        let mut by_edge: Vec<usize> = spots.to_vec();
        by_edge.sort_by(|&a, &b| obs[a].z.total_cmp(&obs[b].z).then(a.cmp(&b)));
        let distinct = |base: usize| {
            let mut d: Vec<f64> = spots
                .iter()
                .filter(|&&k| k != base)
                .map(|&k| angle_between(&obs[base], &obs[k]))
                .filter(|&t| t <= max_angle)
                .collect();
            d.sort_unstable_by(f64::total_cmp);
            d.len() >= 2 && d.windows(2).all(|w| w[1] - w[0] > 2.0 * eps)
        };
        by_edge
            .iter()
            .copied()
            .find(|&b| distinct(b))
            .unwrap_or(by_edge[0])
    }

    /// P001 Model 2's base star: near the centre, its rings inside the frame, with the most
    /// neighbours within them (the nearest the axis among equals); the spot nearest the axis
    /// when no ring pattern fits inside the frame.
    fn ring_base(&self, spots: &[usize], width: f64) -> usize {
        let obs = self.obs[0];
        let radius = width * RING_ORDER as f64;
        let cam = self.camera;
        let inside = |k: usize| {
            let v = &obs[k];
            let (x, y) = (v.x / v.z, v.y / v.z);
            let half_w = 0.5 * cam.width_px / cam.focal_length_px;
            let half_h = 0.5 * cam.height_px / cam.focal_length_px;
            let r = radius.tan();
            x.abs() + r <= half_w && y.abs() + r <= half_h
        };
        let neighbours = |b: usize| {
            spots
                .iter()
                .filter(|&&k| k != b && angle_between(&obs[b], &obs[k]) <= radius)
                .count()
        };
        spots
            .iter()
            .copied()
            .filter(|&k| inside(k))
            .max_by(|&a, &b| {
                neighbours(a)
                    .cmp(&neighbours(b))
                    .then(obs[a].z.total_cmp(&obs[b].z))
                    .then(b.cmp(&a))
            })
            .unwrap_or_else(|| {
                *spots
                    .iter()
                    .max_by(|&&a, &&b| obs[a].z.total_cmp(&obs[b].z).then(b.cmp(&a)))
                    .expect("spots")
            })
    }

    /// The partners of catalogue star `c` within `radius`, `(angle, star)` sorted.
    fn partners(&mut self, c: u32, radius: f64) -> Vec<(f64, u32)> {
        let catalog = &*self.solver.catalog;
        let vecs = catalog.vectors();
        let centre = vecs[c as usize];
        let mut out = Vec::new();
        catalog.for_each_in_cone(&centre, radius, |s, _| {
            if s != c {
                out.push((angle_between(&centre, &vecs[s as usize]), s));
            }
        });
        self.pairs_visited += out.len();
        out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// How many distances `d` catalogue star `c` matches, and the spot → star names: each spot
    /// takes the partner at its distance when exactly one is within `eps`.
    fn partner_matches(
        &mut self,
        c: u32,
        d: &[(usize, f64)],
        eps: f64,
    ) -> (usize, Vec<(usize, u32)>) {
        // Only as far as the farthest distance: a base near the centre needs half the field.
        let reach = d.iter().map(|x| x.1).fold(0.0, f64::max) + eps;
        let partners = self.partners(c, reach);
        let mut matched = 0;
        let mut named = Vec::new();
        for &(k, t) in d {
            let lo = partners.partition_point(|p| p.0 < t - eps);
            let hi = partners.partition_point(|p| p.0 <= t + eps);
            if hi > lo {
                matched += 1;
            }
            if hi == lo + 1 {
                named.push((k, partners[lo].1));
            }
        }
        (matched, named)
    }

    /// The assignment `(spot, star)` of a candidate main star `c`, main first; a star named
    /// twice names neither spot.
    fn name_from(&mut self, c: u32, naming: &Naming<'_>, eps: f64) -> Vec<(usize, u32)> {
        let mut a = match naming {
            Naming::Neighbours(main, nb, table) => {
                let stars = table[c as usize];
                if stars[0] == u32::MAX {
                    return Vec::new();
                }
                let mut a = vec![(*main, c)];
                a.extend(nb.iter().copied().zip(stars));
                a
            }
            Naming::Distances(base, d) => {
                let mut a = vec![(*base, c)];
                a.extend(self.partner_matches(c, d, eps).1);
                a
            }
        };
        let mut stars: Vec<u32> = a.iter().map(|x| x.1).collect();
        stars.sort_unstable();
        let twice: Vec<u32> = stars
            .windows(2)
            .filter(|w| w[0] == w[1])
            .map(|w| w[0])
            .collect();
        a.retain(|x| !twice.contains(&x.1));
        a
    }

    /// Attitudes fitted to an assignment, the better handedness first: both when fewer than
    /// three stars cannot tell them apart.
    fn fit_assignment(&self, a: &[(usize, u32)]) -> Vec<(Rotation3<f64>, bool)> {
        let cat = self.solver.catalog.vectors();
        let refs: Vec<Vector3<f64>> = a.iter().map(|&(_, s)| cat[s as usize]).collect();
        let mut fits: Vec<(f64, Rotation3<f64>, bool)> = [false, true]
            .into_iter()
            .filter(|&m| !m || self.config.allow_mirrored)
            .filter_map(|m| {
                let o: Vec<Vector3<f64>> = a
                    .iter()
                    .map(|&(k, _)| self.obs[usize::from(m)][k])
                    .collect();
                let r = wahba_svd(&o, &refs)?;
                let err: f64 = o
                    .iter()
                    .zip(&refs)
                    .map(|(o, c)| (o - r * c).norm_squared())
                    .sum();
                Some((err, r, m))
            })
            .collect();
        fits.sort_by(|x, y| x.0.total_cmp(&y.0));
        if a.len() >= 3 {
            fits.truncate(1);
        }
        fits.into_iter().map(|(_, r, m)| (r, m)).collect()
    }

    /// A method's own answer, unverified: the assignment as it stands, with the attitude of
    /// the better-fitting handedness and the residuals under it.
    pub(super) fn raw(&self, a: &[(usize, u32)]) -> Verified {
        let n = self.obs[0].len();
        let fit = self.fit_assignment(a).into_iter().next();
        let cat = self.solver.catalog.vectors();
        let mut matches = vec![None; n];
        for &(k, s) in a {
            let d = fit.map_or(f64::NAN, |(r, m)| {
                r.inverse_transform_vector(&self.obs[usize::from(m)][k])
                    .cross(&cat[s as usize])
                    .norm()
                    .asin()
            });
            matches[k] = Some((s, d));
        }
        Verified::raw(matches, fit)
    }
}
