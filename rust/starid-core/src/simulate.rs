//! Frame simulator: what a star tracker would see from a given attitude.
//!
//! Catalogue stars inside the field are projected through the pinhole camera, perturbed with
//! Gaussian centroid noise, thinned by random drop-outs, mixed with false stars spread
//! uniformly over the sensor and shuffled, so that input order carries no information.
//! Everything is driven by one seeded RNG: the same seed gives the same frame.

use nalgebra::{Rotation3, UnitQuaternion, Vector3, Vector4};
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
    /// First radial distortion coefficient on normalised coordinates: a star at `(u, v)`
    /// (camera `x/z`, `y/z`) is imaged at `c + f·(u, v)·(1 + k1·(u² + v²))`.
    pub radial_k1: f64,
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
            radial_k1: 0.0,
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
    pub fn real_stars(&self) -> usize {
        self.catalog_index.iter().filter(|c| c.is_some()).count()
    }
}

/// A synthetic sky: `n_stars` directions uniform on the sphere, magnitudes uniform in
/// `[mag_lo, mag_hi]`, ids `1..=n_stars`. For tests, examples and benchmarks.
///
/// # Errors
/// `InvalidInput` for zero stars or a magnitude range that is not finite and ordered.
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

/// A uniformly distributed random rotation.
pub fn random_rotation(rng: &mut impl Rng) -> Rotation3<f64> {
    let v = Vector4::from_fn(|_, _| StandardNormal.sample(rng));
    let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::from(v));
    q.to_rotation_matrix()
}

/// Simulate one frame of `camera` over `catalog`, drawing randomness from `seed`.
///
/// # Errors
/// `InvalidInput` for negative or non-finite noise, a drop fraction outside [0, 1] or more
/// than 100 000 false stars.
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
    if !config.radial_k1.is_finite() || config.radial_k1.abs() > 10.0 {
        return Err(Error::invalid_input(format!(
            "radial_k1 must be finite and within [-10, 10], got {}",
            config.radial_k1
        )));
    }
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let r = config
        .r_icrs_to_cam
        .unwrap_or_else(|| random_rotation(&mut rng));
    let noise = Normal::new(0.0, config.noise_px).expect("noise checked above");
    let mag_noise = Normal::new(0.0, config.mag_noise).expect("noise checked above");
    let (w, h) = (camera.width_px, camera.height_px);
    let boresight = r.inverse_transform_vector(&Vector3::z());
    let mut stars = catalog.in_cone(&boresight, 0.5 * camera.diagonal_fov_rad() + 1e-6);
    stars.sort_unstable();
    let mut centroids = Vec::new();
    let mut magnitudes = Vec::new();
    let mut catalog_index = Vec::new();
    for star in stars {
        let m = catalog.mag()[star as usize];
        if config.mag_limit.is_some_and(|lim| m > lim) {
            continue;
        }
        let Some((x, y)) = camera.cam_to_pixel(&(r * catalog.vectors()[star as usize])) else {
            continue;
        };
        let (x, y) = if config.radial_k1 == 0.0 {
            (x, y)
        } else {
            let f = camera.focal_length_px;
            let (u, v) = ((x - 0.5 * w) / f, (y - 0.5 * h) / f);
            let g = 1.0 + config.radial_k1 * (u * u + v * v);
            (0.5 * w + f * u * g, 0.5 * h + f * v * g)
        };
        // Draw every random number whatever the outcome, so frames stay comparable across settings.
        let (nx, ny, nm, drop): (f64, f64, f64, f64) = (
            noise.sample(&mut rng),
            noise.sample(&mut rng),
            mag_noise.sample(&mut rng),
            rng.random(),
        );
        let (x, y) = (x + nx, y + ny);
        if !(0.0..w).contains(&x) || !(0.0..h).contains(&y) || drop < config.drop_fraction {
            continue;
        }
        centroids.push([x, y]);
        magnitudes.push(m + nm);
        catalog_index.push(Some(star));
    }
    let (mag_lo, mag_hi) = match config.mag_limit {
        Some(lim) => (lim - 3.0, lim + 0.5),
        None => (4.0, 7.0),
    };
    for _ in 0..config.false_stars {
        centroids.push([rng.random_range(0.0..w), rng.random_range(0.0..h)]);
        magnitudes.push(rng.random_range(mag_lo..mag_hi));
        catalog_index.push(None);
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
