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

/// Scene families in the style of ESA's Kelvins "Star Trackers: First Contact" competition and
/// of OpenStarTracker's scene simulator: the camera, what it sees and the catalogue depth each
/// is meant to be identified against. Scenes of odd seed are mirrored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Family {
    /// Kelvins: 1920×1440 px, 10°×7.5° (18.75″/px), stars to magnitude 6.2 after photometric
    /// noise, 0–80 false spots (mean 40) with catalogue-like magnitudes, 0.2 px centroid noise.
    K1,
    /// Narrow: 1392×1080 px, 6°×4.66°, stars to 7.75, 0–10 false spots (a catalogue to 8).
    K2,
    /// Deep: 1392×1040 px at 15.78″/px (6.1°×4.56°), stars to 11 against a catalogue to 11,
    /// 0–2 false spots, plus stars the catalogue lacks (0.3 per catalogued star, 8 to 11 mag).
    K3,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 3] = [Family::K1, Family::K2, Family::K3];

    /// Short name: `K1`, `K2`, `K3`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Family::K2.name(), "K2");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Self::K1 => "K1",
            Self::K2 => "K2",
            Self::K3 => "K3",
        }
    }

    /// The family named `name` (case-insensitive).
    ///
    /// # Errors
    /// `InvalidInput` for an unknown name.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Family::from_name("k1").unwrap(), starid_core::Family::K1);
    /// ```
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                Error::invalid_input(format!("unknown scene family {name:?} (K1, K2 or K3)"))
            })
    }

    /// The family's camera.
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.camera().fov_rad() > 0.0);
    /// ```
    pub fn camera(self) -> Camera {
        let c = match self {
            Self::K1 => Camera::from_fov(10f64.to_radians(), 1920.0, 1440.0),
            Self::K2 => Camera::from_fov(6f64.to_radians(), 1392.0, 1080.0),
            Self::K3 => Camera::from_focal_length(206_264.806 / 15.78, 1392.0, 1040.0),
        };
        c.expect("family cameras are valid")
    }

    /// Faintest catalogue magnitude the family is meant to be identified against (Hp or V).
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.catalog_mag_limit() > 5.0);
    /// ```
    pub fn catalog_mag_limit(self) -> f64 {
        match self {
            Self::K1 => 6.5,
            Self::K2 => 8.0,
            Self::K3 => 11.0,
        }
    }

    /// What scene `seed` of the family simulates (odd seeds mirrored).
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.sim_config(3).false_stars_max.is_some());
    /// ```
    pub fn sim_config(self, seed: u64) -> SimConfig {
        let base = SimConfig {
            noise_px: 0.2,
            mag_noise: 0.02,
            photon_sigma_at_limit: 0.1,
            false_star_mags: FalseStarMags::FromCatalog,
            mirrored: seed % 2 == 1,
            ..Default::default()
        };
        match self {
            Self::K1 => SimConfig {
                mag_limit: Some(6.2),
                false_stars: 0,
                false_stars_max: Some(80),
                ..base
            },
            Self::K2 => SimConfig {
                mag_limit: Some(7.75),
                false_stars: 0,
                false_stars_max: Some(10),
                ..base
            },
            Self::K3 => SimConfig {
                mag_limit: Some(11.0),
                false_stars: 0,
                false_stars_max: Some(2),
                uncatalogued_per_real: 0.3,
                uncatalogued_mag_min: 8.0,
                ..base
            },
        }
    }

    /// Scene `seed` of the family over `catalog` (which should reach
    /// [`Family::catalog_mag_limit`]).
    ///
    /// # Errors
    /// As [`simulate`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(20_000, 1.0, 7.5, 1).unwrap();
    /// let frame = starid_core::Family::K2.simulate(&cat, 5).unwrap();
    /// assert!(!frame.centroids.is_empty());
    /// ```
    pub fn simulate(self, catalog: &Catalog, seed: u64) -> Result<SimFrame> {
        simulate(catalog, &self.camera(), &self.sim_config(seed), seed)
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

/// How [`render`] turns a simulated frame into pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderConfig {
    /// Gaussian PSF σ, pixels (integrated over each pixel).
    pub psf_sigma_px: f64,
    /// Electrons collected from a star of magnitude 0 in the exposure.
    pub zero_point_e: f64,
    /// Sky background, electrons per pixel, at the image centre.
    pub background_e: f64,
    /// Background gradient across the width, electrons per pixel (left to right, a moonlit sky).
    pub gradient_e: f64,
    /// Read noise, electrons (Gaussian); shot noise is Poisson on everything.
    pub read_noise_e: f64,
    /// Hot pixels at random places, each this many electrons above the background.
    pub hot_pixels: usize,
    /// Electrons of a hot pixel.
    pub hot_pixel_e: f64,
    /// A satellite trail from `(x0, y0)` to `(x1, y1)`, electrons per pixel of length; `None`: none.
    pub trail: Option<([f64; 4], f64)>,
    /// Full well: pixels saturate here, electrons.
    pub full_well_e: f64,
    /// Electrons per digital number.
    pub gain_e_per_dn: f64,
    /// Bits of the converter: 8 or 16 (values clip at 2^bits − 1).
    pub bits: u32,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            psf_sigma_px: 1.2,
            zero_point_e: 2.0e6,
            background_e: 200.0,
            gradient_e: 0.0,
            read_noise_e: 5.0,
            hot_pixels: 0,
            hot_pixel_e: 5000.0,
            trail: None,
            full_well_e: 60_000.0,
            gain_e_per_dn: 1.0,
            bits: 16,
        }
    }
}

/// The error function (Abramowitz & Stegun 7.1.26, |error| < 1.5e-7).
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let y = 1.0
        - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736) * t
            + 0.254_829_592)
            * t
            * (-x * x).exp();
    if x >= 0.0 {
        y
    } else {
        -y
    }
}

/// The part of the segment `[x0, y0, x1, y1]` inside `[0, w] × [0, h]` (Liang–Barsky), or
/// `None` when it misses the rectangle.
fn clip_segment([x0, y0, x1, y1]: [f64; 4], w: f64, h: f64) -> Option<[f64; 4]> {
    let (dx, dy) = (x1 - x0, y1 - y0);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, x0), (dx, w - x0), (-dy, y0), (dy, h - y0)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some([x0 + t0 * dx, y0 + t0 * dy, x0 + t1 * dx, y0 + t1 * dy])
}

/// Render a simulated frame's spots (real and false, at their magnitudes) as a pixel image of
/// the camera's size, row-major digital numbers: pixel-integrated Gaussian PSFs, sky with a
/// gradient, hot pixels, an optional trail, Poisson shot noise, read noise, saturation and
/// quantisation. Hot pixels and the trail are not spots of the frame: they are what an
/// extractor must not report.
///
/// # Errors
/// `InvalidInput` for a sensor over 100 megapixels or settings out of their domain.
///
/// # Example
/// ```
/// use starid_core::simulate::{random_catalog, render, simulate, RenderConfig, SimConfig};
/// let cat = random_catalog(8000, 1.0, 6.5, 1).unwrap();
/// let cam = starid_core::Camera::from_fov(12f64.to_radians(), 256.0, 256.0).unwrap();
/// let frame = simulate(&cat, &cam, &SimConfig { mag_limit: Some(6.0), ..Default::default() }, 2).unwrap();
/// let img = render(&frame, &cam, &RenderConfig::default(), 2).unwrap();
/// assert_eq!(img.len(), 256 * 256);
/// ```
pub fn render(
    frame: &SimFrame,
    camera: &Camera,
    config: &RenderConfig,
    seed: u64,
) -> Result<Vec<f32>> {
    let (w, h) = (camera.width_px as usize, camera.height_px as usize);
    if w * h > 100_000_000 {
        return Err(Error::invalid_input("render: at most 100 megapixels"));
    }
    let c = config;
    let finite_pos = |v: f64| v.is_finite() && v >= 0.0;
    let valid = c.psf_sigma_px.is_finite()
        && c.psf_sigma_px > 0.05
        && c.psf_sigma_px < 50.0
        && finite_pos(c.zero_point_e)
        && finite_pos(c.background_e)
        && c.gradient_e.is_finite()
        && finite_pos(c.read_noise_e)
        && finite_pos(c.hot_pixel_e)
        && c.full_well_e.is_finite()
        && c.full_well_e > 0.0
        && c.gain_e_per_dn.is_finite()
        && c.gain_e_per_dn > 0.0
        && (c.bits == 8 || c.bits == 16)
        && c.hot_pixels <= w * h
        && c.trail
            .is_none_or(|(ends, per_px)| ends.iter().all(|v| v.is_finite()) && finite_pos(per_px));
    if !valid {
        return Err(Error::invalid_input(
            "render: PSF σ in (0.05, 50) px, non-negative finite electrons, positive full well and gain, 8 or 16 bits, \
             at most one hot pixel a pixel, a trail with finite ends",
        ));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x1AA6_E5EE);
    let mut e = vec![0.0f64; w * h];
    for j in 0..h {
        for i in 0..w {
            let gx = (i as f64 + 0.5) / w as f64 - 0.5;
            e[j * w + i] = (c.background_e + c.gradient_e * gx).max(0.0);
        }
    }
    let s = c.psf_sigma_px * std::f64::consts::SQRT_2;
    let reach = (5.0 * c.psf_sigma_px).ceil() as isize;
    for (p, &m) in frame.centroids.iter().zip(&frame.magnitudes) {
        let total = c.zero_point_e * 10f64.powf(-0.4 * m);
        let (ci, cj) = (p[0].floor() as isize, p[1].floor() as isize);
        for j in (cj - reach).max(0)..=(cj + reach).min(h as isize - 1) {
            let fy = 0.5 * (erf((j as f64 + 1.0 - p[1]) / s) - erf((j as f64 - p[1]) / s));
            for i in (ci - reach).max(0)..=(ci + reach).min(w as isize - 1) {
                let fx = 0.5 * (erf((i as f64 + 1.0 - p[0]) / s) - erf((i as f64 - p[0]) / s));
                e[j as usize * w + i as usize] += total * fx * fy;
            }
        }
    }
    // The trail's part on the sensor only: ends far off it cost no more than ends on its edge.
    if let Some(([x0, y0, x1, y1], per_px)) = c.trail.and_then(|(ends, per_px)| {
        clip_segment(ends, w as f64, h as f64).map(|ends| (ends, per_px))
    }) {
        let len = (x1 - x0).hypot(y1 - y0);
        let steps = (2.0 * len).ceil().max(1.0) as usize;
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            let (i, j) = (x.floor() as isize, y.floor() as isize);
            if i >= 0 && j >= 0 && (i as usize) < w && (j as usize) < h {
                e[j as usize * w + i as usize] += per_px * len / (steps + 1) as f64;
            }
        }
    }
    for _ in 0..c.hot_pixels {
        let k = rng.random_range(0..w * h);
        e[k] += c.hot_pixel_e;
    }
    let read = Normal::new(0.0, c.read_noise_e.max(1e-12)).expect("finite read noise");
    let max_dn = f64::from((1u32 << c.bits) - 1);
    Ok(e.into_iter()
        .map(|mean| {
            // Poisson shot noise (Gaussian beyond 1000 electrons, where it is one).
            let n = if mean < 1000.0 {
                rand_distr::Poisson::new(mean.max(1e-9)).map_or(mean, |d| d.sample(&mut rng))
            } else {
                let z: f64 = StandardNormal.sample(&mut rng);
                mean + mean.sqrt() * z
            };
            let v = (n.min(c.full_well_e) + read.sample(&mut rng)) / c.gain_e_per_dn;
            v.round().clamp(0.0, max_dn) as f32
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_segment_is_clipped_to_the_sensor() {
        let c = clip_segment([-1e6, 10.0, 1e6, 10.0], 640.0, 480.0).unwrap();
        for (got, want) in c.iter().zip([0.0, 10.0, 640.0, 10.0]) {
            assert!((got - want).abs() < 1e-6, "{c:?}");
        }
        // Ends at the limits of a float: the part on the sensor is what rounding leaves of it.
        assert!(clip_segment([-1e300, 10.0, 1e300, 10.0], 640.0, 480.0).is_some());
        assert_eq!(
            clip_segment([10.0, 20.0, 30.0, 40.0], 640.0, 480.0),
            Some([10.0, 20.0, 30.0, 40.0])
        );
        assert_eq!(clip_segment([-10.0, -5.0, -1.0, 500.0], 640.0, 480.0), None);
    }
}
