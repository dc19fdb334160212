//! Rendering a simulated frame into pixels: a Gaussian PSF integrated over each pixel, sky,
//! shot and read noise, satellite trails.

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal, StandardNormal};

use super::SimFrame;
use crate::error::{Error, Result};
use crate::geometry::Camera;

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
    /// The sky level (background and gradient, in digital numbers) subtracted before
    /// quantisation, values below it clipped at zero: a frame whose pipeline removed its
    /// background, where about half the pixels read exactly 0.
    pub clip_background: bool,
    /// A lit foreground across the right of the frame (branches against a town-lit sky, a
    /// roof): this share of the width, its edge ragged. Stars behind it are hidden, and it is
    /// textured with blobs of light of many sizes and brightnesses, which an extractor sees
    /// as spots. 0: none.
    pub foreground: f64,
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
            clip_background: false,
            foreground: 0.0,
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
/// quantisation (with `clip_background`, of the image less its sky). Hot pixels and the trail are not spots of the frame: they are what an
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
        && (0.0..1.0).contains(&c.foreground)
        && c.hot_pixels <= w * h
        && c.trail
            .is_none_or(|(ends, per_px)| ends.iter().all(|v| v.is_finite()) && finite_pos(per_px));
    if !valid {
        return Err(Error::invalid_input(
            "render: PSF σ in (0.05, 50) px, non-negative finite electrons, positive full well and gain, 8 or 16 bits, \
             at most one hot pixel a pixel, a trail with finite ends, a foreground share in [0, 1)",
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
    let edge = foreground_edge(c.foreground, w as f64, h as f64, &mut rng);
    for (p, &m) in frame.centroids.iter().zip(&frame.magnitudes) {
        if edge.as_ref().is_some_and(|e| e.hides(p[0], p[1])) {
            continue;
        }
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
    if let Some(edge) = &edge {
        edge.texture(
            &mut e,
            (w, h),
            c.background_e.max(1.0) + c.read_noise_e.powi(2),
            &mut rng,
        );
    }
    for _ in 0..c.hot_pixels {
        let k = rng.random_range(0..w * h);
        e[k] += c.hot_pixel_e;
    }
    let read = Normal::new(0.0, c.read_noise_e.max(1e-12)).expect("finite read noise");
    let max_dn = f64::from((1u32 << c.bits) - 1);
    let sky = |k: usize| {
        if c.clip_background {
            let gx = ((k % w) as f64 + 0.5) / w as f64 - 0.5;
            (c.background_e + c.gradient_e * gx).max(0.0) / c.gain_e_per_dn
        } else {
            0.0
        }
    };
    Ok(e.into_iter()
        .enumerate()
        .map(|(k, mean)| {
            // Poisson shot noise (Gaussian beyond 1000 electrons, where it is one).
            let n = if mean < 1000.0 {
                rand_distr::Poisson::new(mean.max(1e-9)).map_or(mean, |d| d.sample(&mut rng))
            } else {
                let z: f64 = StandardNormal.sample(&mut rng);
                mean + mean.sqrt() * z
            };
            let v = (n.min(c.full_well_e) + read.sample(&mut rng)) / c.gain_e_per_dn;
            (v - sky(k)).round().clamp(0.0, max_dn) as f32
        })
        .collect())
}

/// The edge of a simulated foreground ([`RenderConfig::foreground`]): at row `y`, the
/// foreground begins at `x = base + Σ a sin(y / period + phase)` (two swells and a jagged
/// ripple).
struct ForegroundEdge {
    base: f64,
    waves: [(f64, f64, f64); 3],
}

/// Leaves of a simulated foreground per pixel of it: faint ones, overlapping into a mottled
/// texture, and bright ones, which stand out as spots.
const FOREGROUND_LEAVES_PER_PX: [f64; 2] = [1.0 / 25.0, 1.0 / 400.0];

fn foreground_edge(share: f64, w: f64, h: f64, rng: &mut impl Rng) -> Option<ForegroundEdge> {
    (share > 0.0).then(|| {
        let mut wave = |amp: f64, period: f64| {
            (
                amp * w,
                period * h / std::f64::consts::TAU,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        };
        ForegroundEdge {
            base: w * (1.0 - share),
            waves: [wave(0.06, 0.9), wave(0.03, 0.3), wave(0.01, 0.05)],
        }
    })
}

impl ForegroundEdge {
    fn at(&self, y: f64) -> f64 {
        self.base
            + self
                .waves
                .iter()
                .map(|(a, p, ph)| a * (y / p + ph).sin())
                .sum::<f64>()
    }

    fn hides(&self, x: f64, y: f64) -> bool {
        x >= self.at(y)
    }

    /// Light on the foreground: its pixels a background brighter by half, and Gaussian blobs
    /// (σ 0.6–2.5 px) at random places on it ([`FOREGROUND_LEAVES_PER_PX`]), the faint ones
    /// peaking at 2–12 times the sky's noise (`sky_var`, electrons²), the bright ones at 3–60.
    fn texture(&self, e: &mut [f64], (w, h): (usize, usize), sky_var: f64, rng: &mut impl Rng) {
        let mut area = 0usize;
        for j in 0..h {
            let from = self.at(j as f64 + 0.5).max(0.0).ceil() as usize;
            for v in &mut e[j * w + from.min(w)..(j + 1) * w] {
                *v *= 1.5;
            }
            area += w.saturating_sub(from);
        }
        let noise = sky_var.sqrt();
        let [faint, bright] = FOREGROUND_LEAVES_PER_PX.map(|d| (area as f64 * d) as usize);
        let mut placed = 0;
        // Places drawn over the sensor; those off the foreground drawn again.
        for _ in 0..(faint + bright) * 100 {
            if placed == faint + bright {
                break;
            }
            let (x, y) = (
                rng.random_range(0.0..w as f64),
                rng.random_range(0.0..h as f64),
            );
            if !self.hides(x, y) {
                continue;
            }
            placed += 1;
            let sigma: f64 = rng.random_range(0.6..2.5);
            let (lowest, span): (f64, f64) = if placed <= faint {
                (2.0, 6.0)
            } else {
                (3.0, 20.0)
            };
            let peak = noise * lowest * span.powf(rng.random::<f64>());
            let reach = (3.0 * sigma).ceil() as isize;
            let (ci, cj) = (x as isize, y as isize);
            for j in (cj - reach).max(0)..=(cj + reach).min(h as isize - 1) {
                for i in (ci - reach).max(0)..=(ci + reach).min(w as isize - 1) {
                    let (dx, dy) = (i as f64 + 0.5 - x, j as f64 + 0.5 - y);
                    e[j as usize * w + i as usize] +=
                        peak * (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
                }
            }
        }
    }
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
