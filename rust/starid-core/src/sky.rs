//! Declination-zone spatial index of the catalogue: cone queries and nearest-star look-ups.
//!
//! The sphere is cut into declination zones of equal height; inside a zone the stars are sorted
//! by right ascension, so a cone query is a handful of binary searches (the classic zone
//! method of astronomical cross-matching). There is no cube-face or pole seam to handle:
//! zones touching a pole are scanned whole.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use nalgebra::Vector3;

use crate::geometry::unit_to_radec;

/// A star found by a query: its index and the cosine of its angle to the query direction.
pub type Hit = (u32, f64);

/// A query radius with its cosine and sine, computed once for many queries of that radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Radius {
    rad: f64,
    cos: f64,
    sin: f64,
}

impl Radius {
    /// A radius in radians (clamped to π).
    pub fn new(rad: f64) -> Self {
        let rad = rad.min(PI);
        let (sin, cos) = rad.sin_cos();
        Self { rad, cos, sin }
    }

    /// Its cosine.
    #[inline]
    pub fn cos(&self) -> f64 {
        self.cos
    }
}

/// Zone index over a set of unit vectors.
#[derive(Debug, Clone)]
pub struct ZoneIndex {
    zone_height_rad: f64,
    /// `zone_start[z]..zone_start[z + 1]` is zone `z` in `order` / `ra_rad`.
    zone_start: Vec<u32>,
    /// Star indices, zone by zone, sorted by RA inside a zone.
    order: Vec<u32>,
    /// RA of `order[i]`.
    ra_rad: Vec<f64>,
}

impl ZoneIndex {
    /// Build over `vectors` (unit vectors) with zones of `zone_height_rad`.
    #[cfg(test)]
    pub fn new(vectors: &[Vector3<f64>], zone_height_rad: f64) -> Self {
        let (ra, dec): (Vec<f64>, Vec<f64>) = vectors.iter().map(unit_to_radec).unzip();
        Self::from_radec(&ra, &dec, zone_height_rad)
    }

    /// Build over the directions whose right ascensions and declinations (radians, as
    /// [`unit_to_radec`] gives them) are `ra_rad` and `dec_rad`.
    pub fn from_radec(ra_rad: &[f64], dec_rad: &[f64], zone_height_rad: f64) -> Self {
        let n_zones = ((PI / zone_height_rad).ceil() as usize).max(1);
        let zone_height_rad = PI / n_zones as f64;
        let mut keyed: Vec<(u32, f64, u32)> = ra_rad
            .iter()
            .zip(dec_rad)
            .enumerate()
            .map(|(i, (&ra, &dec))| (zone_of(dec, zone_height_rad, n_zones) as u32, ra, i as u32))
            .collect();
        keyed.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        let mut zone_start = vec![0u32; n_zones + 1];
        for &(z, _, _) in &keyed {
            zone_start[z as usize + 1] += 1;
        }
        for z in 0..n_zones {
            zone_start[z + 1] += zone_start[z];
        }
        Self {
            zone_height_rad,
            zone_start,
            order: keyed.iter().map(|k| k.2).collect(),
            ra_rad: keyed.iter().map(|k| k.1).collect(),
        }
    }

    /// Number of zones.
    pub fn zone_count(&self) -> usize {
        self.zone_start.len() - 1
    }

    /// Calls `f(index, cos)` for every star within `radius_rad` of `center` (a unit vector);
    /// `vectors` must be the vectors the index was built over.
    pub fn for_each_in_cone(
        &self,
        vectors: &[Vector3<f64>],
        center: &Vector3<f64>,
        radius_rad: f64,
        f: impl FnMut(u32, f64),
    ) {
        self.for_each_within(vectors, center, Radius::new(radius_rad), f);
    }

    /// [`ZoneIndex::for_each_in_cone`] with a precomputed [`Radius`].
    pub fn for_each_within(
        &self,
        vectors: &[Vector3<f64>],
        center: &Vector3<f64>,
        radius: Radius,
        mut f: impl FnMut(u32, f64),
    ) {
        self.for_each_candidate(center, radius, |star| {
            let c = vectors[star as usize].dot(center);
            if c >= radius.cos {
                f(star, c);
            }
        });
    }

    /// The nearest star within `radius` of `center` and the second nearest, as
    /// `(index, cos_angle)`; either may be `None`. With a precomputed [`Radius`].
    pub fn nearest_two_within(
        &self,
        vectors: &[Vector3<f64>],
        center: &Vector3<f64>,
        radius: Radius,
    ) -> (Option<Hit>, Option<Hit>) {
        let mut best: Option<Hit> = None;
        let mut second: Option<Hit> = None;
        self.for_each_within(vectors, center, radius, |star, c| {
            if best.is_none_or(|b| c > b.1) {
                second = best;
                best = Some((star, c));
            } else if second.is_none_or(|s| c > s.1) {
                second = Some((star, c));
            }
        });
        (best, second)
    }

    /// Every star whose zone and RA window may hold points within `radius` of `center`.
    fn for_each_candidate(&self, center: &Vector3<f64>, radius: Radius, mut f: impl FnMut(u32)) {
        let n_zones = self.zone_count();
        let radius_rad = radius.rad;
        let (ra_c, dec_c) = unit_to_radec(center);
        let dec_lo = dec_c - radius_rad;
        let dec_hi = dec_c + radius_rad;
        let z_lo = zone_of(dec_lo.max(-FRAC_PI_2), self.zone_height_rad, n_zones);
        let z_hi = zone_of(dec_hi.min(FRAC_PI_2), self.zone_height_rad, n_zones);
        // Half-width in RA of the cone (exact maximum over the cone), or the whole circle when
        // the cone holds a pole.
        // (A window wider than needed is harmless: candidates are filtered by their exact angle.)
        let half_width = if dec_hi >= FRAC_PI_2 || dec_lo <= -FRAC_PI_2 {
            None
        } else {
            // cos(dec) of the centre without trigonometry.
            let cos_dec = center.x.hypot(center.y) / center.norm();
            let s = radius.sin / cos_dec;
            if s >= 1.0 {
                None
            } else if s < 0.3 {
                // Small cones (every match query): tan(asin s) = s / √(1 − s²) ≥ asin s, a window
                // at most 3 % wider and free of trigonometry.
                Some(s / (1.0 - s * s).sqrt() + 1e-12)
            } else {
                Some(s.asin() + 1e-12)
            }
        };
        for z in z_lo..=z_hi {
            let (a, b) = (self.zone_start[z] as usize, self.zone_start[z + 1] as usize);
            if a == b {
                continue;
            }
            match half_width {
                None => self.order[a..b].iter().for_each(|&s| f(s)),
                Some(w) => {
                    let ras = &self.ra_rad[a..b];
                    let lo = ra_c - w;
                    let hi = ra_c + w;
                    let mut scan = |lo: f64, hi: f64| {
                        let i = ras.partition_point(|&r| r < lo);
                        let j = ras.partition_point(|&r| r <= hi);
                        self.order[a + i..a + j].iter().for_each(|&s| f(s));
                    };
                    if lo < 0.0 {
                        scan(0.0, hi);
                        scan(lo + TAU, TAU);
                    } else if hi >= TAU {
                        scan(lo, TAU);
                        scan(0.0, hi - TAU);
                    } else {
                        scan(lo, hi);
                    }
                }
            }
        }
    }
}

/// Largest radius [`CellIndex::nearest_two_within`] answers (about 2.9°); the bound on the
/// gnomonic stretch below holds up to it.
pub const CELL_QUERY_MAX_RAD: f64 = 0.05;

/// Cube-face grid over a set of unit vectors, for nearest-star queries of small radius without
/// trigonometry: a direction's face is its largest component, its cell the gnomonic coordinates
/// `(u, w) = (b / |a|, c / |a|)` on that face cut into `G × G` squares. Each cell keeps copies of
/// its stars' vectors next to each other, so a query reads a few contiguous entries.
///
/// A query whose search box would leave its face is not answered (`None`): the caller falls
/// back to the [`ZoneIndex`]. That happens only within the radius of a face edge.
#[derive(Debug, Clone)]
pub struct CellIndex {
    cells_per_edge: usize,
    /// `cell_start[c]..cell_start[c + 1]` are the slots of cell `c` in `stars` / `vectors`.
    cell_start: Vec<u32>,
    stars: Vec<u32>,
    vectors: Vec<Vector3<f64>>,
    /// One bit per square of a finer grid ([`FINE_CELLS`] per face edge): set where a star lies
    /// in the square or in one of its eight neighbours on the face. A query whose search box
    /// fits in a fine square and whose square's bit is clear has no star to find: most
    /// look-ups of false spots end there.
    fine: Vec<u64>,
}

/// Squares of [`CellIndex`]'s occupancy grid per face edge (a square is about 0.2° at a face's
/// centre): 196 kB of bits for any catalogue.
pub const FINE_CELLS: usize = 512;

/// Width of a fine square in gnomonic face coordinates (a face spans −1..1).
const FINE_SQUARE: f64 = 2.0 / FINE_CELLS as f64;

/// The fine square (0..FINE_CELLS) of a gnomonic face coordinate in −1..1.
#[inline]
fn fine_square(t: f64) -> usize {
    // A 32-bit conversion (saturating like any `as`): cheaper than one to usize.
    (((t + 1.0) * 0.5 * FINE_CELLS as f64) as u32 as usize).min(FINE_CELLS - 1)
}

/// Face (0..6) of a direction and its gnomonic coordinates on that face.
#[inline]
fn cube_face(v: &Vector3<f64>) -> (usize, f64, f64) {
    let (ax, ay, az) = (v.x.abs(), v.y.abs(), v.z.abs());
    if ax >= ay && ax >= az {
        (usize::from(v.x < 0.0), v.y / ax, v.z / ax)
    } else if ay >= az {
        (2 + usize::from(v.y < 0.0), v.z / ay, v.x / ay)
    } else {
        (4 + usize::from(v.z < 0.0), v.x / az, v.y / az)
    }
}

impl CellIndex {
    /// Build over `vectors` (unit vectors), about two stars per cell.
    pub fn new(vectors: &[Vector3<f64>]) -> Self {
        let g = ((vectors.len() as f64 / 12.0).sqrt().round() as usize).clamp(1, 512);
        let cell_of = |v: &Vector3<f64>| {
            let (face, u, w) = cube_face(v);
            let gi = |t: f64| (((t + 1.0) * 0.5 * g as f64) as usize).min(g - 1);
            (face * g + gi(u)) * g + gi(w)
        };
        let cells: Vec<usize> = vectors.iter().map(cell_of).collect();
        let mut cell_start = vec![0u32; 6 * g * g + 1];
        for &c in &cells {
            cell_start[c + 1] += 1;
        }
        for c in 0..6 * g * g {
            cell_start[c + 1] += cell_start[c];
        }
        let mut fill = cell_start.clone();
        let mut stars = vec![0u32; vectors.len()];
        for (i, &c) in cells.iter().enumerate() {
            stars[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let mut fine = vec![0u64; (6 * FINE_CELLS * FINE_CELLS).div_ceil(64)];
        for v in vectors {
            let (face, u, w) = cube_face(v);
            let (i, j) = (fine_square(u), fine_square(w));
            for a in i.saturating_sub(1)..=(i + 1).min(FINE_CELLS - 1) {
                for b in j.saturating_sub(1)..=(j + 1).min(FINE_CELLS - 1) {
                    let bit = (face * FINE_CELLS + a) * FINE_CELLS + b;
                    fine[bit / 64] |= 1 << (bit % 64);
                }
            }
        }
        let vectors = stars.iter().map(|&s| vectors[s as usize]).collect();
        Self {
            cells_per_edge: g,
            cell_start,
            stars,
            vectors,
            fine,
        }
    }

    /// Calls `f(index, cos)` for every star within `radius` of `center` (a unit vector);
    /// `false` (and no call) when the grid cannot answer (the radius exceeds
    /// [`CELL_QUERY_MAX_RAD`] or the search box leaves the face).
    #[inline]
    pub fn for_each_within(
        &self,
        center: &Vector3<f64>,
        radius: Radius,
        f: impl FnMut(u32, f64, &Vector3<f64>),
    ) -> bool {
        self.scan::<false>(center, radius, f)
    }

    /// [`CellIndex::for_each_within`]; with `SCREEN`, first the occupancy grid (see `fine`),
    /// which answers most queries around no star in a few instructions and costs a few more
    /// on the others: for look-ups that mostly find nothing (false spots).
    #[inline]
    fn scan<const SCREEN: bool>(
        &self,
        center: &Vector3<f64>,
        radius: Radius,
        mut f: impl FnMut(u32, f64, &Vector3<f64>),
    ) -> bool {
        if radius.rad > CELL_QUERY_MAX_RAD {
            return false;
        }
        let (face, u, w) = cube_face(center);
        // A great-circle arc maps to a segment whose length is at most the arc times the largest
        // stretch sec²ρ along it (ρ: angle from the face centre); sec²ρ = 1 + u² + w² at the
        // centre and grows by less than a factor 1 + 4r over an arc r ≤ 0.05 (tan ρ < 1.6).
        let h = radius.rad * (1.0 + u * u + w * w) * (1.0 + 4.0 * radius.rad) + 1e-12;
        if u - h <= -1.0 || u + h >= 1.0 || w - h <= -1.0 || w + h >= 1.0 {
            return false;
        }
        // A search box within one fine square's width of (u, w) (with a margin for rounding)
        // holds only stars of its square or the neighbours: none, where the bit is clear.
        if SCREEN && h <= 0.99 * FINE_SQUARE {
            let bit = (face * FINE_CELLS + fine_square(u)) * FINE_CELLS + fine_square(w);
            if self.fine[bit / 64] & (1 << (bit % 64)) == 0 {
                return true;
            }
        }
        let g = self.cells_per_edge;
        // (t + 1)·g/2 lies in (0, g) here (the box is inside the face): a 32-bit conversion,
        // cheaper than a saturating one to usize, is exact.
        let half = 0.5 * g as f64;
        let gi = |t: f64| (((t + 1.0) * half) as u32 as usize).min(g - 1);
        let (u0, u1, w0, w1) = (gi(u - h), gi(u + h), gi(w - h), gi(w + h));
        for cu in u0..=u1 {
            let row = (face * g + cu) * g;
            let (a, b) = (
                self.cell_start[row + w0] as usize,
                self.cell_start[row + w1 + 1] as usize,
            );
            for slot in a..b {
                let v = &self.vectors[slot];
                let c = v.dot(center);
                if c >= radius.cos {
                    f(self.stars[slot], c, v);
                }
            }
        }
        true
    }

    /// The nearest and second nearest star within `radius` of `center` (a unit vector), as
    /// `(index, cos_angle)`; `None` when the grid cannot answer (see
    /// [`CellIndex::for_each_within`]).
    #[inline]
    pub fn nearest_two_within(
        &self,
        center: &Vector3<f64>,
        radius: Radius,
    ) -> Option<(Option<Hit>, Option<Hit>)> {
        let mut best: Option<Hit> = None;
        let mut second: Option<Hit> = None;
        self.scan::<true>(center, radius, |star, c, _| {
            if best.is_none_or(|b| c > b.1) {
                second = best;
                best = Some((star, c));
            } else if second.is_none_or(|s| c > s.1) {
                second = Some((star, c));
            }
        })
        .then_some((best, second))
    }
}

/// Catalogue stars per steradian around every direction, read in O(1): the count within a cone
/// of fixed radius around the centre of each cell of a cube-face grid (gnomonic coordinates, as
/// [`CellIndex`]), divided by the cone's solid angle. A direction reads its cell's value: the
/// density of a cone whose centre is within half a cell diagonal of its own. Built with cells at
/// most a quarter of the radius wide; for narrower cones [`DensityMap::new`] gives `None`.
#[derive(Debug, Clone, PartialEq)]
pub struct DensityMap {
    cells_per_edge: usize,
    radius_rad: f64,
    per_sr: Vec<f32>,
}

/// Most cells along a face edge of a [`DensityMap`] (6 × 128² cells, 384 kB).
pub const DENSITY_MAP_MAX_CELLS_PER_EDGE: usize = 128;

impl DensityMap {
    /// The map for cones of `radius_rad`, `count(direction)` giving the stars within it; `None`
    /// when cells a quarter of the radius wide would need more than
    /// [`DENSITY_MAP_MAX_CELLS_PER_EDGE`] along a face edge (narrow fields: count directly).
    pub fn new(radius_rad: f64, count: impl Fn(&Vector3<f64>) -> usize + Sync) -> Option<Self> {
        // A face spans 90°; gnomonic cells are at most (π/2)/g wide (at the face centre,
        // narrower elsewhere).
        if radius_rad.is_nan() || radius_rad <= 0.0 {
            return None;
        }
        let g = (FRAC_PI_2 / (0.25 * radius_rad)).ceil() as usize;
        if g > DENSITY_MAP_MAX_CELLS_PER_EDGE {
            return None;
        }
        let g = g.max(1);
        let area = 2.0 * PI * (1.0 - radius_rad.cos());
        let per_cell = |cell: usize| -> f32 {
            let (face, rest) = (cell / (g * g), cell % (g * g));
            let centre = |i: usize| (i as f64 + 0.5) / g as f64 * 2.0 - 1.0;
            let (u, w) = (centre(rest / g), centre(rest % g));
            let v = match face {
                0 => Vector3::new(1.0, u, w),
                1 => Vector3::new(-1.0, u, w),
                2 => Vector3::new(w, 1.0, u),
                3 => Vector3::new(w, -1.0, u),
                4 => Vector3::new(u, w, 1.0),
                _ => Vector3::new(u, w, -1.0),
            }
            .normalize();
            (count(&v) as f64 / area) as f32
        };
        #[cfg(feature = "parallel")]
        let per_sr = {
            use rayon::prelude::*;
            (0..6 * g * g).into_par_iter().map(per_cell).collect()
        };
        #[cfg(not(feature = "parallel"))]
        let per_sr = (0..6 * g * g).map(per_cell).collect();
        Some(Self {
            cells_per_edge: g,
            radius_rad,
            per_sr,
        })
    }

    /// What an index file keeps: cells along a face edge, the cone radius, the densities.
    pub(crate) fn stored_parts(&self) -> (usize, f64, &[f32]) {
        (self.cells_per_edge, self.radius_rad, &self.per_sr)
    }

    /// A map from the parts [`DensityMap::stored_parts`] gave; `None` unless they are
    /// consistent (a cell count within the limit, a density per cell, finite and not negative).
    pub(crate) fn from_stored_parts(
        cells_per_edge: usize,
        radius_rad: f64,
        per_sr: Vec<f32>,
    ) -> Option<Self> {
        let sound = (1..=DENSITY_MAP_MAX_CELLS_PER_EDGE).contains(&cells_per_edge)
            && per_sr.len() == 6 * cells_per_edge * cells_per_edge
            && radius_rad.is_finite()
            && radius_rad > 0.0
            && per_sr.iter().all(|d| d.is_finite() && *d >= 0.0);
        sound.then_some(Self {
            cells_per_edge,
            radius_rad,
            per_sr,
        })
    }

    /// Stars per steradian around `v` (a unit vector).
    #[inline]
    pub fn at(&self, v: &Vector3<f64>) -> f64 {
        let (face, u, w) = cube_face(v);
        let g = self.cells_per_edge;
        // A 32-bit conversion (saturating at 0 like any `as`): cheaper than one to usize.
        let gi = |t: f64| (((t + 1.0) * 0.5 * g as f64) as u32 as usize).min(g - 1);
        f64::from(self.per_sr[(face * g + gi(u)) * g + gi(w)])
    }

    /// The cone radius the densities are counted in.
    pub fn radius_rad(&self) -> f64 {
        self.radius_rad
    }

    /// Heap memory, bytes.
    pub fn memory_bytes(&self) -> usize {
        self.per_sr.len() * std::mem::size_of::<f32>()
    }
}

#[inline]
fn zone_of(dec_rad: f64, zone_height_rad: f64, n_zones: usize) -> usize {
    (((dec_rad + FRAC_PI_2) / zone_height_rad) as u32 as usize).min(n_zones - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::radec_to_unit;
    use rand::{Rng, SeedableRng};

    /// `n` directions uniform on the sphere.
    fn random_sky(rng: &mut impl Rng, n: usize) -> Vec<Vector3<f64>> {
        (0..n)
            .map(|_| {
                radec_to_unit(
                    rng.random_range(0.0..TAU),
                    rng.random_range(-1.0f64..1.0).asin(),
                )
            })
            .collect()
    }

    #[test]
    fn cone_query_matches_brute_force() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let v = random_sky(&mut rng, 3000);
        let idx = ZoneIndex::new(&v, 1f64.to_radians());
        for _ in 0..300 {
            let c = radec_to_unit(
                rng.random_range(0.0..TAU),
                rng.random_range(-1.0f64..1.0).asin(),
            );
            let r = rng.random_range(0.0..0.6);
            let mut got = Vec::new();
            idx.for_each_in_cone(&v, &c, r, |s, _| got.push(s));
            got.sort_unstable();
            let want: Vec<u32> = (0..v.len() as u32)
                .filter(|&i| v[i as usize].dot(&c) >= r.cos())
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn small_cones_at_the_ra_seam_and_near_the_poles() {
        // Dense stars around RA 0 and at high declination; small radii use the trig-free window.
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        let v: Vec<_> = (0..20_000)
            .map(|_| {
                let ra = rng.random_range(-0.05f64..0.05).rem_euclid(TAU);
                let dec = rng.random_range(-1.55f64..1.55);
                radec_to_unit(ra, dec)
            })
            .collect();
        let idx = ZoneIndex::new(&v, 0.5f64.to_radians());
        for _ in 0..500 {
            let c = radec_to_unit(
                rng.random_range(-0.05f64..0.05).rem_euclid(TAU),
                rng.random_range(-1.57f64..1.57),
            );
            let radius = Radius::new(rng.random_range(1e-4..0.02));
            let (best, second) = idx.nearest_two_within(&v, &c, radius);
            let mut all: Vec<(f64, u32)> = (0..v.len() as u32)
                .map(|i| (v[i as usize].dot(&c), i))
                .filter(|&(d, _)| d >= radius.cos)
                .collect();
            all.sort_by(|a, b| b.0.total_cmp(&a.0));
            assert_eq!(best.map(|b| b.0), all.first().map(|a| a.1));
            assert_eq!(second.map(|b| b.0), all.get(1).map(|a| a.1));
        }
    }

    /// The nearest two of `v` within `radius` of `c`, by comparing every one.
    fn nearest_two(
        v: &[Vector3<f64>],
        c: &Vector3<f64>,
        radius: Radius,
    ) -> (Option<u32>, Option<u32>) {
        let mut all: Vec<(f64, u32)> = (0..v.len() as u32)
            .map(|i| (v[i as usize].dot(c), i))
            .filter(|&(d, _)| d >= radius.cos)
            .collect();
        all.sort_by(|a, b| b.0.total_cmp(&a.0));
        (all.first().map(|a| a.1), all.get(1).map(|a| a.1))
    }

    #[test]
    fn cell_queries_match_brute_force_across_faces_and_corners() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let v = random_sky(&mut rng, 8000);
        let cells = CellIndex::new(&v);
        let mut answered = 0;
        for q in 0..20_000 {
            // Half the queries next to a star (a match), half near cube edges and corners.
            let c = if q % 2 == 0 {
                let s = v[rng.random_range(0..v.len())];
                (s + Vector3::from_fn(|_, _| rng.random_range(-1e-3..1e-3))).normalize()
            } else {
                let t = 1.0 + rng.random_range(-0.02f64..0.02);
                Vector3::new(
                    t,
                    rng.random_range(-1.0..1.0),
                    1.0 - rng.random_range(0.0..0.03),
                )
                .normalize()
            };
            let radius = Radius::new(rng.random_range(1e-5..0.06));
            if let Some((best, second)) = cells.nearest_two_within(&c, radius) {
                answered += 1;
                assert_eq!(
                    (best.map(|b| b.0), second.map(|b| b.0)),
                    nearest_two(&v, &c, radius)
                );
            } else {
                assert!(
                    radius.rad > CELL_QUERY_MAX_RAD || {
                        let (_, u, w) = cube_face(&c);
                        1.0 - u.abs().max(w.abs()) < 0.2
                    }
                );
            }
        }
        assert!(answered > 7_000, "{answered}");
    }

    #[test]
    fn screened_queries_of_small_radius_match_brute_force() {
        // Radii the occupancy screen serves; points anywhere (mostly around no star) or at
        // about the radius from a star (its edge), in a sparse and a dense catalogue.
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        for n in [2000, 20_000] {
            let v = random_sky(&mut rng, n);
            let cells = CellIndex::new(&v);
            let mut empty = 0;
            for q in 0..10_000 {
                let radius = Radius::new(rng.random_range(1e-5..4e-3));
                let c = if q % 2 == 0 {
                    random_sky(&mut rng, 1)[0]
                } else {
                    let s = v[rng.random_range(0..v.len())];
                    let off = Vector3::from_fn(|_, _| rng.random_range(-1.0..1.0)).normalize();
                    (s + off * radius.rad * rng.random_range(0.9..1.1)).normalize()
                };
                if let Some((best, second)) = cells.nearest_two_within(&c, radius) {
                    let got = (best.map(|b| b.0), second.map(|b| b.0));
                    assert_eq!(got, nearest_two(&v, &c, radius), "{q}");
                    empty += usize::from(best.is_none());
                }
            }
            assert!(empty > 2_500, "{n}: {empty}");
        }
    }
    #[test]
    fn density_map_reads_the_cell_centre_count() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let v = random_sky(&mut rng, 20_000);
        let zones = ZoneIndex::new(&v, 1f64.to_radians());
        let radius = 8f64.to_radians();
        let count = |c: &Vector3<f64>| {
            let mut n = 0;
            zones.for_each_in_cone(&v, c, radius, |_, _| n += 1);
            n
        };
        let map = DensityMap::new(radius, count).unwrap();
        let area = 2.0 * PI * (1.0 - radius.cos());
        // Uniform stars: every cell near the mean, and any direction near its exact count.
        let mean = v.len() as f64 / (4.0 * PI);
        for _ in 0..500 {
            let d = random_sky(&mut rng, 1)[0];
            let exact = count(&d) as f64 / area;
            assert!(
                (map.at(&d) - exact).abs() < 0.25 * mean,
                "{} {exact}",
                map.at(&d)
            );
        }
        assert!(map.memory_bytes() > 0 && map.radius_rad() == radius);
        // A 6° field's cone (half its diagonal): the grid still serves it, at most
        // DENSITY_MAP_MAX_CELLS_PER_EDGE cells a side, each read near its exact count.
        let narrow = 3.85f64.to_radians();
        let count_narrow = |c: &Vector3<f64>| {
            let mut n = 0;
            zones.for_each_in_cone(&v, c, narrow, |_, _| n += 1);
            n
        };
        let map = DensityMap::new(narrow, count_narrow).unwrap();
        assert!(map.memory_bytes() <= 6 * DENSITY_MAP_MAX_CELLS_PER_EDGE.pow(2) * 4);
        let area = 2.0 * PI * (1.0 - narrow.cos());
        let mut err = 0.0;
        for _ in 0..500 {
            let d = random_sky(&mut rng, 1)[0];
            err += (map.at(&d) - count_narrow(&d) as f64 / area).abs() / 500.0;
        }
        // About 25 stars per cone: the mean error stays well under the Poisson spread (20 %).
        assert!(err < 0.1 * mean, "{err} {mean}");
        // Too narrow a cone for the grid.
        assert!(DensityMap::new(0.001, count).is_none());
    }
}
