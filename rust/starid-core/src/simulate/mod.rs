//! Frame simulator: what a star tracker would see from a given attitude.
//!
//! Catalogue stars inside the field are projected through the pinhole camera, perturbed with
//! Gaussian centroid noise, thinned by random drop-outs, mixed with false stars spread
//! uniformly over the sensor and shuffled, so that input order carries no information.
//! Everything is driven by one seeded RNG: the same seed gives the same frame.

use nalgebra::{Rotation3, Vector3};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal, StandardNormal};

use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::Camera;

mod family;
mod render;
pub use family::Family;
pub use render::{render, RenderConfig};

/// What to simulate. Build with `..Default::default()`.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Attitude ICRS → camera; `None` draws a uniformly random one.
    pub r_icrs_to_cam: Option<Rotation3<f64>>,
    /// Only catalogue stars with `mag <= mag_limit` appear; `None` keeps all.
    pub mag_limit: Option<f64>,
    /// Gaussian centroid noise, 1σ per axis, pixels.
    pub noise_px: f64,
    /// Gaussian noise added to each star's magnitude.
    pub mag_noise: f64,
    /// Number of false stars added uniformly over the sensor.
    pub false_stars: usize,
    /// Probability that a real star is dropped.
    pub drop_fraction: f64,
    /// Reverse the image's x axis (`x → W − x`): a mirrored frame.
    pub mirrored: bool,
    /// When set, the number of false stars is drawn uniformly from `false_stars..=max`.
    pub false_stars_max: Option<usize>,
    /// How false stars get their magnitudes.
    pub false_star_mags: FalseStarMags,
    /// Photon noise: 1σ magnitude error of a star at `mag_limit` (fainter stars more, brighter
    /// less, as `10^(0.2·(m − limit))`), added in quadrature to `mag_noise`. With it, a star is
    /// seen when its *noisy* magnitude is within the limit, as a detector decides.
    pub photon_sigma_at_limit: f64,
    /// Stars the camera sees but the catalogue lacks (a deep field against an incomplete
    /// catalogue): their number is Poisson with this mean per real star, magnitudes uniform in
    /// `[uncatalogued_mag_min, mag_limit]`. They count as false stars in the truth.
    pub uncatalogued_per_real: f64,
    /// See [`SimConfig::uncatalogued_per_real`].
    pub uncatalogued_mag_min: f64,
}

/// How a simulated false star gets its magnitude.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum FalseStarMags {
    /// Uniform in `[limit − 3, limit + 0.5]` (`[4, 7]` without a limit).
    Uniform,
    /// The magnitude of a random catalogue star within the limit: brightness alone cannot tell
    /// a false star from a real one (hot pixels, planets and satellites of every brightness).
    FromCatalog,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            r_icrs_to_cam: None,
            mag_limit: None,
            noise_px: 0.0,
            mag_noise: 0.0,
            false_stars: 0,
            drop_fraction: 0.0,
            mirrored: false,
            false_stars_max: None,
            false_star_mags: FalseStarMags::Uniform,
            photon_sigma_at_limit: 0.0,
            uncatalogued_per_real: 0.0,
            uncatalogued_mag_min: 8.0,
        }
    }
}

/// A simulated frame with its truth.
#[derive(Debug, Clone)]
pub struct SimFrame {
    /// Pixel centroids `(x, y)`.
    pub centroids: Vec<[f64; 2]>,
    /// Instrument magnitude of each centroid.
    pub magnitudes: Vec<f64>,
    /// Catalogue index of each centroid; `None` for a false star.
    pub catalog_index: Vec<Option<u32>>,
    /// The true attitude ICRS → camera (of the un-mirrored frame).
    pub r_icrs_to_cam: Rotation3<f64>,
    /// Whether the frame is mirrored.
    pub mirrored: bool,
}

impl SimFrame {
    /// Number of real (catalogue) stars in the frame.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(8000, 1.0, 6.5, 1).unwrap();
    /// let cam = starid_core::Camera::from_fov(0.2, 512.0, 512.0).unwrap();
    /// let cfg = starid_core::SimConfig { false_stars: 3, ..Default::default() };
    /// let frame = starid_core::simulate(&cat, &cam, &cfg, 1).unwrap();
    /// assert_eq!(frame.real_stars() + 3, frame.centroids.len());
    /// ```
    pub fn real_stars(&self) -> usize {
        self.catalog_index.iter().filter(|c| c.is_some()).count()
    }
}

/// A synthetic sky: `n_stars` directions uniform on the sphere, magnitudes uniform in
/// `[mag_lo, mag_hi]`, ids `1..=n_stars`. For tests, examples and benchmarks.
///
/// # Errors
/// `InvalidInput` for zero stars or a magnitude range that is not finite and ordered.
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(100, 2.0, 5.0, 9).unwrap();
/// assert_eq!(cat.len(), 100);
/// assert!(cat.mag().iter().all(|m| (2.0..=5.0).contains(m)));
/// ```
pub fn random_catalog(n_stars: usize, mag_lo: f64, mag_hi: f64, seed: u64) -> Result<Catalog> {
    if n_stars == 0 || !mag_lo.is_finite() || !mag_hi.is_finite() || mag_lo > mag_hi {
        return Err(Error::invalid_input(
            "random_catalog needs n_stars > 0 and finite mag_lo <= mag_hi",
        ));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut ra = Vec::with_capacity(n_stars);
    let mut dec = Vec::with_capacity(n_stars);
    let mut mag = Vec::with_capacity(n_stars);
    for _ in 0..n_stars {
        ra.push(rng.random_range(0.0..360.0));
        dec.push(rng.random_range(-1.0f64..=1.0).asin().to_degrees());
        mag.push(if mag_lo == mag_hi {
            mag_lo
        } else {
            rng.random_range(mag_lo..mag_hi)
        });
    }
    Catalog::new((1..=n_stars as i64).collect(), &ra, &dec, mag)
}

/// A uniformly distributed random rotation (see [`crate::geometry::random_rotation`]).
pub use crate::geometry::random_rotation;

/// Simulate one frame of `camera` over `catalog`, drawing randomness from `seed`.
///
/// # Errors
/// `InvalidInput` for negative or non-finite noise, a drop fraction outside [0, 1] or more
/// than 100 000 false stars.
///
/// # Example
/// ```
/// let cat = starid_core::simulate::random_catalog(8000, 1.0, 6.5, 1).unwrap();
/// let cam = starid_core::Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
/// let frame = starid_core::simulate(&cat, &cam, &starid_core::SimConfig { noise_px: 0.3, ..Default::default() }, 7).unwrap();
/// assert_eq!(frame.centroids.len(), frame.magnitudes.len());
/// assert!(frame.centroids.iter().all(|p| (0.0..512.0).contains(&p[0]) && (0.0..512.0).contains(&p[1])));
/// ```
pub fn simulate(
    catalog: &Catalog,
    camera: &Camera,
    config: &SimConfig,
    seed: u64,
) -> Result<SimFrame> {
    if !config.noise_px.is_finite() || config.noise_px < 0.0 {
        return Err(Error::invalid_input(format!(
            "noise_px must be finite and >= 0, got {}",
            config.noise_px
        )));
    }
    if !config.mag_noise.is_finite() || config.mag_noise < 0.0 {
        return Err(Error::invalid_input(format!(
            "mag_noise must be finite and >= 0, got {}",
            config.mag_noise
        )));
    }
    if !(0.0..=1.0).contains(&config.drop_fraction) {
        return Err(Error::invalid_input(format!(
            "drop_fraction must be in [0, 1], got {}",
            config.drop_fraction
        )));
    }
    if config.false_stars > 100_000 {
        return Err(Error::invalid_input(format!(
            "false_stars must be at most 100000, got {}",
            config.false_stars
        )));
    }
    if config.mag_limit.is_some_and(f64::is_nan) {
        return Err(Error::invalid_input("mag_limit is NaN"));
    }
    if config
        .false_stars_max
        .is_some_and(|m| m < config.false_stars || m > 100_000)
    {
        return Err(Error::invalid_input(format!(
            "false_stars_max must be within [false_stars, 100000], got {:?}",
            config.false_stars_max
        )));
    }
    for (name, v) in [
        ("photon_sigma_at_limit", config.photon_sigma_at_limit),
        ("uncatalogued_per_real", config.uncatalogued_per_real),
    ] {
        if !v.is_finite() || !(0.0..=100.0).contains(&v) {
            return Err(Error::invalid_input(format!(
                "{name} must be finite and within [0, 100], got {v}"
            )));
        }
    }
    if !config.uncatalogued_mag_min.is_finite() {
        return Err(Error::invalid_input("uncatalogued_mag_min must be finite"));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let r = config
        .r_icrs_to_cam
        .unwrap_or_else(|| random_rotation(&mut rng));
    let noise = Normal::new(0.0, config.noise_px).expect("noise checked above");
    let (w, h) = (camera.width_px, camera.height_px);
    let boresight = r.inverse_transform_vector(&Vector3::z());
    let mut stars = catalog.in_cone(&boresight, 0.5 * camera.diagonal_fov_rad() + 1e-6);
    stars.sort_unstable();
    let mut centroids = Vec::new();
    let mut magnitudes = Vec::new();
    let mut catalog_index = Vec::new();
    let photon = config.photon_sigma_at_limit > 0.0;
    let mag_sigma = |m: f64| -> f64 {
        if photon {
            let lim = config.mag_limit.unwrap_or(m);
            let p = config.photon_sigma_at_limit * 10f64.powf(0.2 * (m - lim));
            p.hypot(config.mag_noise)
        } else {
            config.mag_noise
        }
    };
    for star in stars {
        let m = catalog.mag()[star as usize];
        // With photon noise the detector decides on the noisy magnitude: allow 5σ past the limit.
        let slack = if photon {
            5.0 * mag_sigma(m).min(1.0)
        } else {
            0.0
        };
        if config.mag_limit.is_some_and(|lim| m > lim + slack) {
            continue;
        }
        let Some((x, y)) = camera.cam_to_pixel(&(r * catalog.vectors()[star as usize])) else {
            continue;
        };
        // Draw every random number whatever the outcome, so frames stay comparable across settings.
        let (nx, ny, nm, drop): (f64, f64, f64, f64) = (
            noise.sample(&mut rng),
            noise.sample(&mut rng),
            StandardNormal.sample(&mut rng),
            rng.random(),
        );
        let (x, y) = (x + nx, y + ny);
        if !(0.0..w).contains(&x) || !(0.0..h).contains(&y) || drop < config.drop_fraction {
            continue;
        }
        let seen = m + nm * mag_sigma(m);
        if photon && config.mag_limit.is_some_and(|lim| seen > lim) {
            continue;
        }
        centroids.push([x, y]);
        magnitudes.push(seen);
        catalog_index.push(Some(star));
    }
    let (mag_lo, mag_hi) = match config.mag_limit {
        Some(lim) => (lim - 3.0, lim + 0.5),
        None => (4.0, 7.0),
    };
    // Catalogue magnitudes within the limit, for false stars that look like stars.
    let pool: Vec<f64> = if config.false_star_mags == FalseStarMags::FromCatalog {
        let lim = config.mag_limit.unwrap_or(f64::INFINITY);
        catalog
            .mag()
            .iter()
            .copied()
            .filter(|&m| m <= lim)
            .collect()
    } else {
        Vec::new()
    };
    let n_false = match config.false_stars_max {
        Some(hi) => rng.random_range(config.false_stars..=hi),
        None => config.false_stars,
    };
    for _ in 0..n_false {
        centroids.push([rng.random_range(0.0..w), rng.random_range(0.0..h)]);
        magnitudes.push(if pool.is_empty() {
            rng.random_range(mag_lo..mag_hi)
        } else {
            pool[rng.random_range(0..pool.len())]
        });
        catalog_index.push(None);
    }
    if config.uncatalogued_per_real > 0.0 {
        let real = catalog_index.iter().filter(|c| c.is_some()).count();
        let mean = config.uncatalogued_per_real * real as f64;
        let count = if mean > 0.0 {
            rand_distr::Poisson::new(mean).map_or(0.0, |p| p.sample(&mut rng)) as usize
        } else {
            0
        };
        let hi = config
            .mag_limit
            .unwrap_or(config.uncatalogued_mag_min + 1.0);
        let lo = config.uncatalogued_mag_min.min(hi);
        for _ in 0..count {
            centroids.push([rng.random_range(0.0..w), rng.random_range(0.0..h)]);
            magnitudes.push(if lo < hi {
                rng.random_range(lo..hi)
            } else {
                lo
            });
            catalog_index.push(None);
        }
    }
    let mut perm: Vec<usize> = (0..centroids.len()).collect();
    perm.shuffle(&mut rng);
    let mut frame = SimFrame {
        centroids: perm.iter().map(|&i| centroids[i]).collect(),
        magnitudes: perm.iter().map(|&i| magnitudes[i]).collect(),
        catalog_index: perm.iter().map(|&i| catalog_index[i]).collect(),
        r_icrs_to_cam: r,
        mirrored: config.mirrored,
    };
    if config.mirrored {
        for c in &mut frame.centroids {
            c[0] = w - c[0];
        }
    }
    Ok(frame)
}

/// A spacecraft's slew or tumble for [`simulate_sequence`]: frames at a fixed rate while the
/// camera turns at a constant angular rate about a fixed body axis, with jitter.
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceConfig {
    /// Number of frames.
    pub frames: usize,
    /// Frame rate, Hz.
    pub frame_rate_hz: f64,
    /// Angular rate, radians per second, about a random body axis drawn from the seed.
    pub rate_rad_s: f64,
    /// Attitude jitter per frame, 1σ per axis, radians.
    pub jitter_rad: f64,
    /// Exposure time, seconds: each image smears along its motion, and the centroid noise along
    /// the smear grows with its length (`σ·√(1 + (L/2)²)`, `L` in pixels).
    pub exposure_s: f64,
    /// Frames (indices) that see no star at all: only false spots (a loss of lock).
    pub blank: std::ops::Range<usize>,
    /// Every frame as [`simulate`] makes it (noise, false stars, magnitudes); its attitude is
    /// ignored.
    pub frame: SimConfig,
}

impl Default for SequenceConfig {
    fn default() -> Self {
        Self {
            frames: 100,
            frame_rate_hz: 10.0,
            rate_rad_s: 1f64.to_radians(),
            jitter_rad: 2e-5,
            exposure_s: 0.02,
            blank: 0..0,
            frame: SimConfig::default(),
        }
    }
}

/// One frame of a sequence: its time and the frame with its truth.
#[derive(Debug, Clone)]
pub struct SequenceFrame {
    /// Mid-exposure time, seconds from the first frame.
    pub t_s: f64,
    /// The frame (a blank frame holds only false spots).
    pub frame: SimFrame,
}

/// Simulate a sequence (see [`SequenceConfig`]) drawn from `seed`.
///
/// # Errors
/// `InvalidInput` for a non-positive frame rate, a negative or non-finite rate, jitter or
/// exposure, more than 10 000 000 frames; as [`simulate`] otherwise.
///
/// # Example
/// ```
/// use starid_core::simulate::{random_catalog, simulate_sequence, SequenceConfig};
/// let cat = random_catalog(8000, 1.0, 6.5, 1).unwrap();
/// let cam = starid_core::Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
/// let seq = simulate_sequence(&cat, &cam, &SequenceConfig { frames: 5, ..Default::default() }, 3).unwrap();
/// assert_eq!(seq.len(), 5);
/// assert!((seq[1].t_s - 0.1).abs() < 1e-12);
/// let turned = starid_core::geometry::rotation_angle_between(&seq[0].frame.r_icrs_to_cam, &seq[4].frame.r_icrs_to_cam);
/// assert!((turned.to_degrees() - 0.4).abs() < 0.01);
/// ```
pub fn simulate_sequence(
    catalog: &Catalog,
    camera: &Camera,
    config: &SequenceConfig,
    seed: u64,
) -> Result<Vec<SequenceFrame>> {
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    let valid = config.frame_rate_hz.is_finite()
        && config.frame_rate_hz > 0.0
        && ok(config.rate_rad_s)
        && ok(config.jitter_rad)
        && ok(config.exposure_s);
    if !valid {
        return Err(Error::invalid_input(
            "a sequence needs a positive frame rate and finite, non-negative rate, jitter and exposure",
        ));
    }
    if config.frames > 10_000_000 {
        return Err(Error::invalid_input(format!(
            "a sequence holds at most 10 000 000 frames, got {}",
            config.frames
        )));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x5EC0_E7CE);
    let r0 = config
        .frame
        .r_icrs_to_cam
        .unwrap_or_else(|| random_rotation(&mut rng));
    let axis =
        nalgebra::Unit::new_normalize(Vector3::from_fn(|_, _| StandardNormal.sample(&mut rng)));
    let dt = 1.0 / config.frame_rate_hz;
    let jitter = Normal::new(0.0, config.jitter_rad.max(1e-300)).expect("finite jitter");
    let mut out = Vec::with_capacity(config.frames);
    for k in 0..config.frames {
        let t = k as f64 * dt;
        // The camera turns about its body axis: cam(t) = Rot(axis, −ω t) · cam(0).
        let turn = Rotation3::from_axis_angle(&axis, -config.rate_rad_s * t);
        let shake = Rotation3::new(Vector3::from_fn(|_, _| jitter.sample(&mut rng)));
        let r = shake * turn * r0;
        let mut frame_cfg = SimConfig {
            r_icrs_to_cam: Some(r),
            ..config.frame.clone()
        };
        let blank = config.blank.contains(&k);
        if blank {
            frame_cfg.mag_limit = Some(-100.0);
        }
        let frame_seed = seed.wrapping_mul(0x9E37_79B9).wrapping_add(k as u64);
        let mut frame = simulate(catalog, camera, &frame_cfg, frame_seed)?;
        // Smear: the image moves by the rotation over the exposure; the centroid noise along it
        // grows with its length.
        let half = Rotation3::from_axis_angle(&axis, -0.5 * config.rate_rad_s * config.exposure_s);
        if config.exposure_s > 0.0 && config.rate_rad_s > 0.0 {
            for c in &mut frame.centroids {
                let v = camera.pixel_to_cam(c[0], c[1], frame.mirrored);
                let (Some(a), Some(b)) = (
                    camera.cam_to_pixel(&(half.inverse() * v)),
                    camera.cam_to_pixel(&(half * v)),
                ) else {
                    continue;
                };
                let (mut dx, dy) = (b.0 - a.0, b.1 - a.1);
                if frame.mirrored {
                    dx = -dx;
                }
                let len = dx.hypot(dy);
                if len > 1e-9 {
                    let extra = config.frame.noise_px * (0.25 * len * len).sqrt();
                    let u: f64 = StandardNormal.sample(&mut rng);
                    c[0] += u * extra * dx / len;
                    c[1] += u * extra * dy / len;
                }
            }
        }
        out.push(SequenceFrame { t_s: t, frame });
    }
    Ok(out)
}
