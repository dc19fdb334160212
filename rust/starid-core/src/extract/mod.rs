//! Centroid extraction: the star spots of a pixel image, brightest first.
//!
//! 1. Background: the median of each block of `background_block` × `background_block` pixels
//!    (a sixteenth of them sampled), interpolated bilinearly between block centres (copes with
//!    gradients, vignetting and moonlight). Noise: the robust σ of the image less its background
//!    over a sparse grid of pixels, from its quartiles read between quantisation levels (from
//!    two quantiles above the clipped pixels where the background was clipped at zero), and a
//!    local σ per block (interquartile
//!    range, then the median over the block and its neighbours), which raises the threshold
//!    where a bright background brings more shot noise (it never lowers it).
//! 2. One pass over the pixels, in parallel bands of rows for large images: the image less
//!    its background (into a buffer kept between calls on a thread), checked finite, and the
//!    sparse list of pixels more than `threshold_sigma` σ above it. Hot pixels among them (one
//!    pixel far above all its neighbours) are replaced by their neighbours' median.
//! 3. Detection: the image smoothed by a Gaussian of `filter_sigma_px` (a matched filter, its
//!    noise and level measured on it, the edges scaled to keep that noise), the pixels above
//!    the threshold there, and 8-connected components grown from them (without the filter,
//!    from the pixels listed in step 2).
//! 4. Measurement (in parallel over spots): the centroid by intensity-weighted moments over a
//!    window around the peak, refined by a Gaussian-windowed fit; the flux over the component,
//!    the peak, the size, and the elongation from the second moments.
//! 5. Flags: single hot pixels, saturated spots, elongated spots (trails, satellites), spots
//!    touching the border, spots on a cluttered background (the noise about them, measured as
//!    the frame's, over twice its median across the image: branches, a roof).
//!
//! Pixels follow the project's convention: pixel `(i, j)` (column, row) covers
//! `[i, i + 1) × [j, j + 1)`, so its centre is at `(i + 0.5, j + 0.5)`, x right, y down, origin at
//! the top-left corner of the sensor.

use crate::error::{Error, Result};

mod background;
mod calibration;
mod centroid;
mod deblend;
mod filter;
use background::*;
use centroid::*;
use deblend::{clean_hot_pixels, deblend, nearest_peak};
use filter::gaussian_filter;

pub use calibration::apply_calibration;

/// Spot flags (bits of [`Spot::flags`]).
pub mod flags {
    /// A single pixel far above all its neighbours: a hot pixel or a cosmic ray, not a star.
    pub const HOT_PIXEL: u8 = 1;
    /// The peak reaches the saturation level: the centroid and flux are less accurate.
    pub const SATURATED: u8 = 2;
    /// Much longer than wide: a trail (satellite, aircraft) or a blend.
    pub const ELONGATED: u8 = 4;
    /// Touches the image border: cut off, the centroid is biased.
    pub const BORDER: u8 = 8;
    /// Split from a blend of two or three stars (see [`super::ExtractConfig::deblend`]).
    pub const DEBLENDED: u8 = 16;
    /// On a cluttered background: the noise around the spot is more than
    /// [`super::CLUTTER_NOISE_RATIO`] times the image's typical surroundings (foliage, a lit
    /// roof). What stands out there is mostly texture, not stars.
    pub const CLUTTERED: u8 = 32;
}

/// Settings of [`extract`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExtractConfig {
    /// Detection threshold above the background, in noise σ.
    pub threshold_sigma: f64,
    /// Side of the background blocks, pixels.
    pub background_block: usize,
    /// Fewest pixels above the threshold a spot needs (a lone pixel can still be a star on a
    /// sharp optic: it is flagged `HOT_PIXEL` when nothing around it rises).
    pub min_pixels: usize,
    /// Most spots reported (the brightest).
    pub max_spots: usize,
    /// Pixel value at which the sensor saturates; `None`: not flagged.
    pub saturation: Option<f64>,
    /// Elongation (ratio of the second moments' axes) above which a spot is flagged `ELONGATED`.
    pub max_elongation: f64,
    /// Flagged spots (hot pixels, elongated, cluttered) are left out of the result.
    pub drop_flagged: bool,
    /// A pixel above the threshold whose brightest neighbour holds less than this fraction of
    /// its signal is a hot pixel: it is replaced by its neighbours' median before detection,
    /// so that it neither makes a spot nor shifts a star beside it. A star's peak pixel keeps
    /// more than half its signal in its brightest neighbour down to a PSF σ of 0.6 px; 0
    /// turns the cleaning off (for undersampled optics).
    pub hot_pixel_ratio: f64,
    /// Split a component with two or three distinct peaks (each [`DEBLEND_MIN_PEAK_SIGMAS`] σ
    /// above the threshold, the light between them dipping below [`DEBLEND_MAX_SADDLE`] of
    /// the fainter) into one spot per peak, each pixel going to its nearest peak: a close
    /// double is two stars, not one elongated spot at their midpoint. Components larger than
    /// [`DEBLEND_MAX_PIXELS`] (trails) are left whole.
    pub deblend: bool,
    /// Detect on the image smoothed by a Gaussian of this σ, pixels (a matched filter, as
    /// SExtractor's): a star spreads over several pixels and keeps its height where a noise
    /// spike of one pixel sinks, so the threshold holds on heavy-tailed and clipped noise
    /// that would otherwise make thousands of single-pixel spots. The threshold is in σ of
    /// the smoothed image, measured on it; centroids and fluxes are measured on the image
    /// itself. 0 detects on the image itself.
    pub filter_sigma_px: f64,
}

/// Height of a peak above the detection threshold, in noise σ, for it to count in deblending.
pub const DEBLEND_MIN_PEAK_SIGMAS: f64 = 3.0;

/// The light along the line between two peaks must dip below this fraction of the fainter
/// peak for the pair to be split.
pub const DEBLEND_MAX_SADDLE: f64 = 0.7;

/// Components with more pixels than this are not deblended.
pub const DEBLEND_MAX_PIXELS: usize = 400;

/// A spot whose surroundings (a window of `background_block` pixels about it, the spot itself
/// left out) are noisier than this many times the image's typical surroundings (the same
/// measure's median across the image) is flagged
/// [`flags::CLUTTERED`]. Shot noise alone needs a background four times the frame's typical
/// one to get there; texture (branches against a lit sky, a roof, JPEG blocks on them) gets
/// there at once.
pub const CLUTTER_NOISE_RATIO: f64 = 2.0;

/// Flags that [`ExtractConfig::drop_flagged`] leaves out.
const DROPPED_FLAGS: u8 = flags::HOT_PIXEL | flags::ELONGATED | flags::CLUTTERED;

impl Default for ExtractConfig {
    fn default() -> Self {
        Self {
            threshold_sigma: 5.0,
            background_block: 32,
            min_pixels: 1,
            max_spots: 2000,
            saturation: None,
            max_elongation: 3.0,
            drop_flagged: true,
            hot_pixel_ratio: 0.25,
            deblend: true,
            filter_sigma_px: 1.0,
        }
    }
}

/// One spot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spot {
    /// Centroid, pixels (the project's convention).
    pub x: f64,
    /// Centroid, pixels.
    pub y: f64,
    /// Background-subtracted sum over the spot's pixels.
    pub flux: f64,
    /// Highest background-subtracted pixel.
    pub peak: f64,
    /// Pixels above the threshold.
    pub pixels: u32,
    /// Ratio of the long to the short axis of the second moments.
    pub elongation: f64,
    /// [`flags`] bits.
    pub flags: u8,
}

impl Spot {
    /// The instrumental magnitude, `-2.5 log10 flux`: infinite where the flux is not positive.
    pub fn magnitude(&self) -> f64 {
        if self.flux > 0.0 {
            -2.5 * self.flux.log10()
        } else {
            f64::INFINITY
        }
    }
}

/// What [`extract`] found.
#[derive(Debug, Clone)]
pub struct Extraction {
    /// Spots, brightest (largest flux) first.
    pub spots: Vec<Spot>,
    /// Median of the background map.
    pub background: f64,
    /// Noise σ of the image, pixel units.
    pub noise_sigma: f64,
    /// Spots left out because they were flagged (with `drop_flagged`).
    pub dropped: usize,
    /// Hot pixels cleaned before detection.
    pub hot_pixels: usize,
}

/// A pixel type [`extract`] reads: unsigned and signed integers, `f32`, `f64`.
pub trait Pixel: Copy + Send + Sync {
    /// Whether a value may be other than finite (a floating-point type).
    const FLOAT: bool;
    /// The value as `f32`.
    fn to_f32(self) -> f32;
}

macro_rules! pixel {
    ($float:literal: $($t:ty),*) => {$(
        impl Pixel for $t {
            const FLOAT: bool = $float;
            #[inline]
            fn to_f32(self) -> f32 {
                self as f32
            }
        }
    )*};
}
pixel!(false: u8, u16, u32, i8, i16, i32);
pixel!(true: f32, f64);

/// Luminance weights of red, green and blue (ITU-R 601, as image libraries convert colour to
/// grey).
pub const LUMA_WEIGHTS: [f32; 3] = [0.299, 0.587, 0.114];

/// The luminance of a colour image whose pixels hold `channels` values each (3: RGB, 4: RGB and
/// alpha, which is ignored), interleaved row-major: one `f32` a pixel, in one pass.
///
/// # Errors
/// `InvalidInput` when `channels` is not 3 or 4 or the buffer is not whole pixels.
///
/// # Example
/// ```
/// let rgba = [10u8, 20, 30, 255, 0, 0, 0, 0];
/// let grey = starid_core::extract::luminance(&rgba, 4).unwrap();
/// assert_eq!(grey.len(), 2);
/// assert!((grey[0] - (0.299 * 10.0 + 0.587 * 20.0 + 0.114 * 30.0)).abs() < 1e-4);
/// ```
pub fn luminance<T: Pixel>(pixels: &[T], channels: usize) -> Result<Vec<f32>> {
    if !(channels == 3 || channels == 4) || pixels.len() % channels != 0 {
        return Err(Error::invalid_input(format!(
            "a colour image has 3 or 4 values a pixel, got {channels} and {} values",
            pixels.len()
        )));
    }
    let [r, g, b] = LUMA_WEIGHTS;
    Ok(pixels
        .chunks_exact(channels)
        .map(|p| r * p[0].to_f32() + g * p[1].to_f32() + b * p[2].to_f32())
        .collect())
}

/// The spots of an image of `width` × `height` pixels, row-major, of any [`Pixel`] type (u8,
/// u16, f32...): read in place, no converted copy is made.
///
/// # Errors
/// `InvalidInput` when the buffer does not hold `width × height` pixels, the image is smaller
/// than 3 × 3, a pixel is not finite, or a setting is out of its domain.
///
/// # Example
/// ```
/// use starid_core::extract::{extract, ExtractConfig};
/// let (w, h) = (64usize, 48usize);
/// let mut img = vec![100.0f32; w * h];
/// // A star centred at (20.3, 30.6): Gaussian PSF of σ 1.2 px.
/// for j in 0..h {
///     for i in 0..w {
///         let (dx, dy) = (i as f64 + 0.5 - 20.3, j as f64 + 0.5 - 30.6);
///         img[j * w + i] += (500.0 * (-(dx * dx + dy * dy) / (2.0 * 1.44)).exp()) as f32;
///     }
/// }
/// // A little noise so that the noise estimate is not zero.
/// for (k, p) in img.iter_mut().enumerate() { *p += ((k * 7919) % 13) as f32 * 0.3; }
/// let found = extract(&img, w, h, &ExtractConfig::default()).unwrap();
/// assert_eq!(found.spots.len(), 1);
/// assert!((found.spots[0].x - 20.3).abs() < 0.05 && (found.spots[0].y - 30.6).abs() < 0.05);
/// ```
pub fn extract<T: Pixel>(
    pixels: &[T],
    width: usize,
    height: usize,
    config: &ExtractConfig,
) -> Result<Extraction> {
    check(pixels.len(), width, height, config)?;
    let grid = Background::new(pixels, width, height, config.background_block);
    // The noise from a subsample of the image less its background, before the full pass.
    let sigma = grid.robust_sigma(pixels, width, height);
    let background_level = grid.level();
    // A flat, noiseless image has σ 0: nothing rises above it by chance.
    let floor = if sigma > 0.0 {
        config.threshold_sigma * sigma
    } else {
        f64::from(f32::EPSILON) * background_level.abs().max(1.0)
    };
    // One pass over the pixels: the image less its background (no background image is kept),
    // checked finite, and the sparse list of pixels above the threshold.
    let floor32 = floor as f32;
    let thr = grid.thresholds(config.threshold_sigma as f32, floor32);
    // The residual buffer is kept between calls on a thread: a fresh one would cost a page
    // fault per 4 kB on first touch, as much again as the pass itself.
    let mut resid: Vec<f32> = RESID.with(|c| c.take());
    if resid.len() != width * height {
        // Every value is written by the pass: a buffer of the right size is reused as it is.
        resid.clear();
        resid.resize(width * height, 0.0);
    }
    let (mut above_list, finite) = for_row_bands(&mut resid, width, |j, row, list| {
        grid.subtract_row(pixels, &thr, j, row, list)
    });
    if !finite {
        let k = pixels
            .iter()
            .position(|p| !p.to_f32().is_finite())
            .or_else(|| resid.iter().position(|v| !v.is_finite()))
            .unwrap_or(0);
        return Err(Error::invalid_input(format!(
            "pixel {k} (x {}, y {}) is not finite",
            k % width,
            k / width
        )));
    }
    let hot_pixels = clean_hot_pixels(
        &mut resid,
        width,
        height,
        &above_list,
        f64::from(floor32),
        config.hot_pixel_ratio,
    );
    // Detection on the image smoothed by the matched filter, its threshold scaled by the
    // smoothed image's own noise; or on the image itself.
    let mut smoothed: Option<Vec<f32>> = (config.filter_sigma_px > 0.0 && sigma > 0.0).then(|| {
        let mut out = SMOOTHED.with(|c| c.take());
        gaussian_filter(&resid, width, height, config.filter_sigma_px, &mut out);
        out
    });
    let filtered = smoothed.is_some();
    let (detect, thr): (&[f32], _) = match &mut smoothed {
        Some(f) => {
            let (level, sigma_f) = grid.sample_level_sigma(f, width, height);
            let ratio = (sigma_f / sigma) as f32;
            // Thresholds above the smoothed image's own level (a clipped background's noise
            // has a positive mean, which smoothing keeps).
            let thr: Vec<Vec<f32>> = grid
                .thresholds(config.threshold_sigma as f32 * ratio, floor32 * ratio)
                .into_iter()
                .map(|row| row.into_iter().map(|t| t + level as f32).collect())
                .collect();
            (above_list, _) = for_row_bands(f, width, |j, row, list| {
                let th = &grid.threshold_row(&thr, j)[..width];
                let over: u32 = row.iter().zip(th).map(|(v, t)| u32::from(v > t)).sum();
                if over > 0 {
                    list_above(row, th, j, list);
                }
                true
            });
            (&f[..], thr)
        }
        None => (&resid[..], thr),
    };
    let above = |k: usize| detect[k] > grid.threshold_at(&thr, k % width, k / width);
    if hot_pixels > 0 && !filtered {
        above_list.retain(|&k| above(k));
    }
    // Components (8-connected) grown from the listed pixels; the label map is touched only
    // around them.
    let mut label = vec![false; width * height];
    let mut stack: Vec<usize> = Vec::new();
    let mut comps: Vec<Vec<usize>> = Vec::new();
    for &start in &above_list {
        if label[start] {
            continue;
        }
        let mut comp = Vec::new();
        stack.push(start);
        label[start] = true;
        while let Some(k) = stack.pop() {
            comp.push(k);
            let (i, j) = ((k % width) as isize, (k / width) as isize);
            for dj in -1..=1isize {
                for di in -1..=1isize {
                    let (ni, nj) = (i + di, j + dj);
                    if ni < 0 || nj < 0 || ni >= width as isize || nj >= height as isize {
                        continue;
                    }
                    let nk = nj as usize * width + ni as usize;
                    if !label[nk] && above(nk) {
                        label[nk] = true;
                        stack.push(nk);
                    }
                }
            }
        }
        if comp.len() >= config.min_pixels {
            comps.push(comp);
        }
    }
    let min_peak = f64::from(floor32) + DEBLEND_MIN_PEAK_SIGMAS * sigma.max(f64::MIN_POSITIVE);
    let measured: Vec<Spot> = map_items(&comps, |comp| {
        let (parts, peaks) = if config.deblend {
            deblend(&resid, width, height, comp, min_peak)
        } else {
            (Vec::new(), Vec::new())
        };
        if parts.len() < 2 {
            return vec![measure(
                pixels,
                &resid,
                width,
                height,
                comp,
                config,
                &|_| true,
            )];
        }
        // Each part's centroid from the pixels nearer its own peak than any other, so that
        // the other star's light does not pull it.
        parts
            .iter()
            .enumerate()
            .map(|(p, part)| {
                let owns = |k: usize| nearest_peak(&peaks, k, width) == p;
                let mut s = measure(pixels, &resid, width, height, part, config, &owns);
                s.flags |= flags::DEBLENDED;
                s
            })
            .collect()
    })
    .into_iter()
    .flatten()
    .collect();
    let mut spots = Vec::with_capacity(measured.len());
    let mut dropped = 0;
    let block = config.background_block;
    let typical = if measured.is_empty() {
        0.0
    } else {
        typical_local_sigma(pixels, (width, height), block)
    };
    let around = map_items(&measured, |s| {
        local_sigma(
            pixels,
            (width, height),
            block,
            (s.x, s.y),
            SPOT_EXCLUSION_PX,
        )
    });
    for (mut spot, around) in measured.into_iter().zip(around) {
        if typical > 0.0 && around > CLUTTER_NOISE_RATIO * typical {
            spot.flags |= flags::CLUTTERED;
        }
        if config.drop_flagged && spot.flags & DROPPED_FLAGS != 0 {
            dropped += 1;
        } else {
            spots.push(spot);
        }
    }
    spots.sort_by(|a, b| b.flux.total_cmp(&a.flux));
    spots.truncate(config.max_spots);
    if resid.capacity() <= KEEP_BUFFER_PIXELS {
        RESID.with(|c| c.replace(resid));
    }
    if let Some(f) = smoothed.filter(|f| f.capacity() <= KEEP_BUFFER_PIXELS) {
        SMOOTHED.with(|c| c.replace(f));
    }
    Ok(Extraction {
        spots,
        background: background_level,
        noise_sigma: sigma,
        dropped,
        hot_pixels,
    })
}

thread_local! {
    /// The residual image of the last extraction on this thread, reused.
    static RESID: std::cell::Cell<Vec<f32>> = const { std::cell::Cell::new(Vec::new()) };
    /// The smoothed image of the last extraction on this thread, reused.
    static SMOOTHED: std::cell::Cell<Vec<f32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// Largest residual buffer kept between calls (pixels): 64 MB.
const KEEP_BUFFER_PIXELS: usize = 16 << 20;

/// Rows of at least this many pixels each make one parallel task.
const ROWS_TASK_PIXELS: usize = 65_536;

/// `f(j, row, list)` over the rows of `out` (`width` a row), in parallel over bands of rows
/// for large images: the lists concatenated in row order, and whether every call returned true.
fn for_row_bands(
    out: &mut [f32],
    width: usize,
    f: impl Fn(usize, &mut [f32], &mut Vec<usize>) -> bool + Sync + Send,
) -> (Vec<usize>, bool) {
    let rows_per_band = (ROWS_TASK_PIXELS / width.max(1)).max(1);
    let parts = map_bands(out, rows_per_band * width, |b, chunk| {
        let mut list = Vec::new();
        let mut ok = true;
        for (r, row) in chunk.chunks_mut(width).enumerate() {
            ok &= f(b * rows_per_band + r, row, &mut list);
        }
        (list, ok)
    });
    let ok = parts.iter().all(|p| p.1);
    (parts.into_iter().flat_map(|p| p.0).collect(), ok)
}

/// `f(b, band)` over the bands of `band` values of `out`, in parallel when there are several.
fn map_bands<R: Send>(
    out: &mut [f32],
    band: usize,
    f: impl Fn(usize, &mut [f32]) -> R + Sync + Send,
) -> Vec<R> {
    #[cfg(feature = "parallel")]
    if out.len() > band {
        use rayon::prelude::*;
        return out
            .par_chunks_mut(band)
            .enumerate()
            .map(|(b, c)| f(b, c))
            .collect();
    }
    out.chunks_mut(band)
        .enumerate()
        .map(|(b, c)| f(b, c))
        .collect()
}

/// `f` over items, in parallel when there are many.
fn map_items<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    #[cfg(feature = "parallel")]
    if items.len() > 16 {
        use rayon::prelude::*;
        return items.par_iter().map(f).collect();
    }
    items.iter().map(f).collect()
}

fn check(len: usize, width: usize, height: usize, config: &ExtractConfig) -> Result<()> {
    if width < 3 || height < 3 || width > 100_000 || height > 100_000 {
        return Err(Error::invalid_input(format!(
            "an image must be between 3 and 100000 pixels on each side, got {width} x {height}"
        )));
    }
    if len != width * height {
        return Err(Error::invalid_input(format!(
            "the buffer holds {len} pixels, not {width} x {height}"
        )));
    }
    let c = config;
    if !(c.threshold_sigma.is_finite() && c.threshold_sigma > 0.0 && c.threshold_sigma <= 1000.0) {
        return Err(Error::invalid_input(format!(
            "threshold_sigma must be in (0, 1000], got {}",
            c.threshold_sigma
        )));
    }
    if !(4..=4096).contains(&c.background_block) {
        return Err(Error::invalid_input(format!(
            "background_block must be 4 to 4096 pixels, got {}",
            c.background_block
        )));
    }
    if c.min_pixels == 0 || c.max_spots == 0 || c.max_spots > 1_000_000 {
        return Err(Error::invalid_input(
            "min_pixels must be at least 1 and max_spots in 1..=1000000",
        ));
    }
    if c.saturation.is_some_and(|s| !s.is_finite())
        || c.max_elongation.is_nan()
        || c.max_elongation < 1.0
    {
        return Err(Error::invalid_input(
            "saturation must be finite and max_elongation at least 1",
        ));
    }
    if !(c.hot_pixel_ratio.is_finite() && (0.0..1.0).contains(&c.hot_pixel_ratio)) {
        return Err(Error::invalid_input(format!(
            "hot_pixel_ratio must be in [0, 1), got {}",
            c.hot_pixel_ratio
        )));
    }
    if !(c.filter_sigma_px.is_finite() && (0.0..=10.0).contains(&c.filter_sigma_px)) {
        return Err(Error::invalid_input(format!(
            "filter_sigma_px must be in [0, 10] pixels, got {}",
            c.filter_sigma_px
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
