//! Centroid extraction: the star spots of a pixel image, brightest first.
//!
//! 1. Background: the median of each block of `background_block` × `background_block` pixels,
//!    interpolated bilinearly between block centres (copes with gradients, vignetting and
//!    moonlight); the noise: the robust σ (1.4826 × MAD) of the image less its background.
//! 2. Detection: pixels more than `threshold_sigma` σ above the background, joined into
//!    8-connected components.
//! 3. Measurement: the centroid by intensity-weighted moments over a window around the peak
//!    (background subtracted, not clipped, so the noise does not bias it), the flux over the
//!    component, the peak, the size, and the elongation from the second moments.
//! 4. Flags: single hot pixels (one pixel far above all its neighbours), saturated spots,
//!    elongated spots (trails, satellites), spots touching the border.
//!
//! Pixels follow the project's convention: pixel `(i, j)` (column, row) covers
//! `[i, i + 1) × [j, j + 1)`, so its centre is at `(i + 0.5, j + 0.5)`, x right, y down, origin at
//! the top-left corner of the sensor.

use crate::error::{Error, Result};

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
    /// Flagged spots (hot pixels, elongated) are left out of the result.
    pub drop_flagged: bool,
    /// A pixel above the threshold whose brightest neighbour holds less than this fraction of
    /// its signal is a hot pixel: it is replaced by its neighbours' median before detection,
    /// so that it neither makes a spot nor shifts a star beside it. A star's peak pixel keeps
    /// more than half its signal in its brightest neighbour down to a PSF σ of 0.6 px; 0
    /// turns the cleaning off (for undersampled optics).
    pub hot_pixel_ratio: f64,
}

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

/// The spots of an image of `width` × `height` pixels, row-major, any numeric type convertible
/// to `f32` (u8, u16, f32...).
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
pub fn extract<T: Copy + Into<f64>>(
    pixels: &[T],
    width: usize,
    height: usize,
    config: &ExtractConfig,
) -> Result<Extraction> {
    check(pixels.len(), width, height, config)?;
    let img: Vec<f32> = pixels.iter().map(|&p| p.into() as f32).collect();
    if let Some(k) = img.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid_input(format!(
            "pixel {k} (x {}, y {}) is not finite",
            k % width,
            k / width
        )));
    }
    let bg = background(&img, width, height, config.background_block);
    let mut resid: Vec<f32> = img.iter().zip(&bg).map(|(v, b)| v - b).collect();
    let sigma = robust_sigma(&resid);
    let hot_pixels = clean_hot_pixels(
        &mut resid,
        width,
        height,
        config.threshold_sigma * sigma,
        config.hot_pixel_ratio,
    );
    let mut bg_sorted: Vec<f32> = bg
        .iter()
        .step_by(((width * height) / 4096).max(1))
        .copied()
        .collect();
    let background_level = f64::from(median(&mut bg_sorted));
    // A flat, noiseless image has σ 0: nothing rises above it by chance.
    let floor = if sigma > 0.0 {
        config.threshold_sigma * sigma
    } else {
        f64::from(f32::EPSILON) * background_level.abs().max(1.0)
    };
    let above = |k: usize| f64::from(resid[k]) > floor;
    let mut label = vec![false; width * height];
    let mut stack: Vec<usize> = Vec::new();
    let mut comp: Vec<usize> = Vec::new();
    let mut spots = Vec::new();
    let mut dropped = 0;
    for start in 0..width * height {
        if label[start] || !above(start) {
            continue;
        }
        // Flood fill (8-connected).
        comp.clear();
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
        if comp.len() < config.min_pixels {
            continue;
        }
        let spot = measure(&img, &resid, width, height, &comp, config);
        if config.drop_flagged && spot.flags & (flags::HOT_PIXEL | flags::ELONGATED) != 0 {
            dropped += 1;
            continue;
        }
        spots.push(spot);
    }
    spots.sort_by(|a, b| b.flux.total_cmp(&a.flux));
    spots.truncate(config.max_spots);
    Ok(Extraction {
        spots,
        background: background_level,
        noise_sigma: sigma,
        dropped,
        hot_pixels,
    })
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
    Ok(())
}

/// Replace hot pixels (above `floor`, with no neighbour holding `ratio` of their signal) by the
/// median of their neighbours; returns how many.
fn clean_hot_pixels(
    resid: &mut [f32],
    width: usize,
    height: usize,
    floor: f64,
    ratio: f64,
) -> usize {
    if ratio <= 0.0 {
        return 0;
    }
    let floor = floor.max(f64::MIN_POSITIVE);
    let mut hot = Vec::new();
    let mut nb = [0.0f32; 8];
    for j in 0..height {
        for i in 0..width {
            let v = f64::from(resid[j * width + i]);
            if v <= floor {
                continue;
            }
            let mut n = 0;
            for dj in -1..=1isize {
                for di in -1..=1isize {
                    let (ni, nj) = (i as isize + di, j as isize + dj);
                    if (di != 0 || dj != 0)
                        && ni >= 0
                        && nj >= 0
                        && (ni as usize) < width
                        && (nj as usize) < height
                    {
                        nb[n] = resid[nj as usize * width + ni as usize];
                        n += 1;
                    }
                }
            }
            let brightest = nb[..n].iter().copied().fold(f32::NEG_INFINITY, f32::max);
            if f64::from(brightest) < ratio * v {
                hot.push((j * width + i, median(&mut nb[..n])));
            }
        }
    }
    for &(k, m) in &hot {
        resid[k] = m;
    }
    hot.len()
}

/// Median of a slice (reorders it); 0 for an empty one.
fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// 1.4826 × the median absolute deviation of a subsample.
fn robust_sigma(resid: &[f32]) -> f64 {
    let step = (resid.len() / 65_536).max(1);
    let mut s: Vec<f32> = resid.iter().step_by(step).copied().collect();
    let m = median(&mut s);
    for v in &mut s {
        *v = (*v - m).abs();
    }
    1.4826 * f64::from(median(&mut s))
}

/// Block medians, interpolated bilinearly between block centres.
fn background(img: &[f32], width: usize, height: usize, block: usize) -> Vec<f32> {
    let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
    let mut grid = vec![0.0f32; bw * bh];
    let mut buf = Vec::with_capacity(block * block);
    for by in 0..bh {
        for bx in 0..bw {
            buf.clear();
            // Every other row and column: a quarter of the pixels give the same median.
            for j in ((by * block)..((by + 1) * block).min(height)).step_by(2) {
                buf.extend(
                    img[j * width + bx * block..j * width + ((bx + 1) * block).min(width)]
                        .iter()
                        .step_by(2),
                );
            }
            grid[by * bw + bx] = median(&mut buf);
        }
    }
    let centre = |b: usize, n: usize, size: usize| {
        ((b * block) as f64 + 0.5 * ((block.min(size - b * block)) as f64)).min(n as f64)
    };
    let cx: Vec<f64> = (0..bw).map(|b| centre(b, width, width)).collect();
    let cy: Vec<f64> = (0..bh).map(|b| centre(b, height, height)).collect();
    let interp = |c: &[f64], p: f64| -> (usize, usize, f64) {
        if c.len() == 1 || p <= c[0] {
            return (0, 0, 0.0);
        }
        let last = c.len() - 1;
        if p >= c[last] {
            return (last, last, 0.0);
        }
        let k = c.partition_point(|&v| v <= p) - 1;
        (k, k + 1, (p - c[k]) / (c[k + 1] - c[k]))
    };
    let mut out = vec![0.0f32; width * height];
    let xs: Vec<(usize, usize, f64)> = (0..width).map(|i| interp(&cx, i as f64 + 0.5)).collect();
    // Each row: the background along x of the two grid rows around it, then mixed in y.
    let along_x = |y: usize| -> Vec<f32> {
        xs.iter()
            .map(|&(x0, x1, tx)| {
                (f64::from(grid[y * bw + x0]) * (1.0 - tx) + f64::from(grid[y * bw + x1]) * tx)
                    as f32
            })
            .collect()
    };
    let rows: Vec<Vec<f32>> = (0..bh).map(along_x).collect();
    for (j, row) in out.chunks_mut(width).enumerate() {
        let (y0, y1, ty) = interp(&cy, j as f64 + 0.5);
        let (a, b, t) = (&rows[y0], &rows[y1], ty as f32);
        for ((o, &u), &v) in row.iter_mut().zip(a).zip(b) {
            *o = u + (v - u) * t;
        }
    }
    out
}

/// Gaussian-windowed centroid (the window's σ that of the spot): starting from the moments,
/// `x ← x + 2 Σ w v (xᵢ − x) / Σ w v` with `w = exp(−r² / 2σ²)`, which reaches the noise
/// floor of a Gaussian PSF where plain moments pick up the noise of the whole window.
fn refine_gaussian(
    resid: &[f32],
    width: usize,
    height: usize,
    x0: f64,
    y0: f64,
    spot_sigma: f64,
) -> (f64, f64) {
    let s = spot_sigma.clamp(0.5, 5.0);
    let r = (3.0 * s).ceil() as isize + 1;
    let (mut x, mut y) = (x0, y0);
    for _ in 0..8 {
        let (ci, cj) = (x.floor() as isize, y.floor() as isize);
        let (mut sw, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
        for j in (cj - r).max(0)..=(cj + r).min(height as isize - 1) {
            let dy = j as f64 + 0.5 - y;
            for i in (ci - r).max(0)..=(ci + r).min(width as isize - 1) {
                let dx = i as f64 + 0.5 - x;
                let w = (-(dx * dx + dy * dy) / (2.0 * s * s)).exp();
                let v = w * f64::from(resid[j as usize * width + i as usize]);
                sw += v;
                sx += v * dx;
                sy += v * dy;
            }
        }
        if sw <= 0.0 {
            return (x0, y0);
        }
        let (step_x, step_y) = (2.0 * sx / sw, 2.0 * sy / sw);
        // A step beyond the window means the iteration lost the spot: keep the moments.
        if step_x.abs() > r as f64 || step_y.abs() > r as f64 {
            return (x0, y0);
        }
        x += step_x;
        y += step_y;
        if step_x.abs() < 1e-4 && step_y.abs() < 1e-4 {
            break;
        }
    }
    (x, y)
}

/// Centroid, flux, shape and flags of one component.
fn measure(
    img: &[f32],
    resid: &[f32],
    width: usize,
    height: usize,
    comp: &[usize],
    config: &ExtractConfig,
) -> Spot {
    let (mut flux, mut peak, mut peak_k) = (0.0f64, f64::NEG_INFINITY, comp[0]);
    let mut border = false;
    let mut raw_peak = f64::NEG_INFINITY;
    for &k in comp {
        let v = f64::from(resid[k]);
        flux += v;
        if v > peak {
            peak = v;
            peak_k = k;
        }
        raw_peak = raw_peak.max(f64::from(img[k]));
        let (i, j) = (k % width, k / width);
        border |= i == 0 || j == 0 || i == width - 1 || j == height - 1;
    }
    // Window moments around the peak: radius from the spot's size, at least 2 px.
    let r = ((comp.len() as f64).sqrt().ceil() as isize).clamp(2, 25);
    let (pi, pj) = ((peak_k % width) as isize, (peak_k / width) as isize);
    let (mut s, mut sx, mut sy) = (0.0f64, 0.0, 0.0);
    for j in (pj - r).max(0)..=(pj + r).min(height as isize - 1) {
        for i in (pi - r).max(0)..=(pi + r).min(width as isize - 1) {
            let v = f64::from(resid[j as usize * width + i as usize]);
            s += v;
            sx += v * (i as f64 + 0.5);
            sy += v * (j as f64 + 0.5);
        }
    }
    let (x, y) = if s > 0.0 {
        (sx / s, sy / s)
    } else {
        ((pi as f64) + 0.5, (pj as f64) + 0.5)
    };
    // The shape from the component's own pixels (all above the threshold, so positive): a
    // window's noise would make second moments meaningless for faint spots.
    let (mut cs, mut cx, mut cy, mut cxx, mut cyy, mut cxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &k in comp {
        let v = f64::from(resid[k]);
        let (px, py) = ((k % width) as f64 + 0.5, (k / width) as f64 + 0.5);
        cs += v;
        cx += v * px;
        cy += v * py;
        cxx += v * px * px;
        cyy += v * py * py;
        cxy += v * px * py;
    }
    let (mx, my) = (cx / cs, cy / cs);
    let (vxx, vyy, vxy) = (
        cxx / cs - mx * mx + 1.0 / 12.0,
        cyy / cs - my * my + 1.0 / 12.0,
        cxy / cs - mx * my,
    );
    // Pixels above a threshold see only the core of the PSF: the window is somewhat wider.
    let (x, y) = refine_gaussian(
        resid,
        width,
        height,
        x,
        y,
        1.2 * (0.5 * (vxx + vyy)).max(0.0).sqrt(),
    );
    let tr = vxx + vyy;
    let disc = ((vxx - vyy).powi(2) + 4.0 * vxy * vxy).sqrt();
    let (l1, l2) = (0.5 * (tr + disc), (0.5 * (tr - disc)).max(1e-6));
    let elongation = if l1 > 0.0 { (l1 / l2).sqrt() } else { 1.0 };
    let mut flags = 0u8;
    if border {
        flags |= flags::BORDER;
    }
    if config.saturation.is_some_and(|sat| raw_peak >= sat) {
        flags |= flags::SATURATED;
    }
    if comp.len() >= 12 && elongation > config.max_elongation {
        flags |= flags::ELONGATED;
    }
    if comp.len() <= 2 {
        // A hot pixel: its neighbours barely rise (a star's PSF spreads light around its peak).
        let mut neighbours = 0.0f64;
        let mut count = 0.0f64;
        for dj in -1..=1isize {
            for di in -1..=1isize {
                let (ni, nj) = (pi + di, pj + dj);
                if (di != 0 || dj != 0)
                    && ni >= 0
                    && nj >= 0
                    && ni < width as isize
                    && nj < height as isize
                {
                    neighbours += f64::from(resid[nj as usize * width + ni as usize]);
                    count += 1.0;
                }
            }
        }
        if neighbours / count.max(1.0) < 0.1 * peak && peak > 0.0 {
            flags |= flags::HOT_PIXEL;
        }
    }
    Spot {
        x,
        y,
        flux,
        peak,
        pixels: comp.len() as u32,
        elongation,
        flags,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{random_catalog, render, simulate, RenderConfig, SimConfig};
    use crate::{Camera, IdentifyConfig, Solver};

    #[test]
    fn rendered_frames_are_extracted_and_identified() {
        let cat = std::sync::Arc::new(random_catalog(8000, 1.0, 6.5, 4).unwrap());
        let cam = Camera::from_fov(12f64.to_radians(), 640.0, 480.0).unwrap();
        let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
        let (mut found, mut truth, mut ok, mut hot_reported) = (0, 0, 0, 0);
        let mut err2 = 0.0;
        for seed in 0..10 {
            let frame = simulate(
                &cat,
                &cam,
                &SimConfig {
                    mag_limit: Some(6.0),
                    ..Default::default()
                },
                seed,
            )
            .unwrap();
            let rc = RenderConfig {
                gradient_e: 150.0,
                hot_pixels: 20,
                trail: Some(([30.0, 400.0, 600.0, 350.0], 400.0)),
                ..Default::default()
            };
            let img = render(&frame, &cam, &rc, seed).unwrap();
            let ex = extract(&img, 640, 480, &ExtractConfig::default()).unwrap();
            // Each isolated star (no other within 8 px, off the trail and the border) found within
            // 0.3 px; blends are not split (no deblending yet) and a star on the trail goes with it.
            let trail_dist = |p: &[f64; 2]| {
                let (ax, ay, bx, by) = (30.0, 400.0, 600.0, 350.0);
                let t = (((p[0] - ax) * (bx - ax) + (p[1] - ay) * (by - ay))
                    / ((bx - ax).powi(2) + (by - ay).powi(2)))
                .clamp(0.0, 1.0);
                (p[0] - ax - t * (bx - ax)).hypot(p[1] - ay - t * (by - ay))
            };
            for p in &frame.centroids {
                let isolated = frame
                    .centroids
                    .iter()
                    .all(|q| q == p || (q[0] - p[0]).hypot(q[1] - p[1]) > 8.0)
                    && trail_dist(p) > 6.0
                    && p[0] > 3.0
                    && p[1] > 3.0
                    && p[0] < 637.0
                    && p[1] < 477.0;
                if !isolated {
                    continue;
                }
                truth += 1;
                let near = ex
                    .spots
                    .iter()
                    .map(|s| (s.x - p[0]).hypot(s.y - p[1]))
                    .fold(f64::INFINITY, f64::min);
                if near < 0.3 {
                    found += 1;
                    err2 += near * near;
                } else if std::env::var("STARID_DEBUG").is_ok() {
                    eprintln!(
                        "missed ({:.1}, {:.1}): nearest spot {near:.2} px; dropped {}",
                        p[0], p[1], ex.dropped
                    );
                }
            }
            // Spurious spots: far from every star and off the trail (hot pixels, noise).
            hot_reported += ex
                .spots
                .iter()
                .filter(|s| {
                    trail_dist(&[s.x, s.y]) > 6.0
                        && frame
                            .centroids
                            .iter()
                            .all(|p| (p[0] - s.x).hypot(p[1] - s.y) > 3.0)
                })
                .count();
            let xy: Vec<[f64; 2]> = ex.spots.iter().map(|s| [s.x, s.y]).collect();
            let mags: Vec<f64> = ex.spots.iter().map(|s| -2.5 * s.flux.log10()).collect();
            let cfg = IdentifyConfig {
                mag_offset: None,
                ..Default::default()
            };
            let id = solver.identify(&xy, Some(&mags), &cam, &cfg).unwrap();
            ok += usize::from(id.is_identified());
        }
        assert!(found as f64 >= 0.99 * truth as f64, "{found} of {truth}");
        assert!(
            (err2 / found as f64).sqrt() < 0.1,
            "rms {}",
            (err2 / found as f64).sqrt()
        );
        // 20 hot pixels a frame, none reported; at most 1 spurious spot per megapixel.
        assert!(
            hot_reported <= 3,
            "{hot_reported} spurious spots in 3.1 megapixels"
        );
        assert_eq!(ok, 10);
    }

    #[test]
    fn flat_and_noise_images_give_no_spots() {
        let flat = vec![1000u16; 100 * 80];
        assert!(extract(&flat, 100, 80, &ExtractConfig::default())
            .unwrap()
            .spots
            .is_empty());
        assert!(extract(&flat, 100, 81, &ExtractConfig::default()).is_err());
        let nan = vec![f32::NAN; 9];
        assert!(extract(&nan, 3, 3, &ExtractConfig::default()).is_err());
    }

    #[test]
    fn flipping_the_image_flips_the_centroids() {
        let (w, h) = (50usize, 40usize);
        let mut img = vec![10.0f32; w * h];
        for (k, p) in img.iter_mut().enumerate() {
            *p += ((k * 2654435761) % 7) as f32 * 0.2;
        }
        for j in 0..h {
            for i in 0..w {
                let (dx, dy) = (i as f64 + 0.5 - 12.7, j as f64 + 0.5 - 25.2);
                img[j * w + i] += (300.0 * (-(dx * dx + dy * dy) / 2.0).exp()) as f32;
            }
        }
        let mut flipped = vec![0.0f32; w * h];
        for j in 0..h {
            for i in 0..w {
                flipped[j * w + (w - 1 - i)] = img[j * w + i];
            }
        }
        let a = extract(&img, w, h, &ExtractConfig::default())
            .unwrap()
            .spots[0];
        let b = extract(&flipped, w, h, &ExtractConfig::default())
            .unwrap()
            .spots[0];
        assert!((a.x + b.x - w as f64).abs() < 1e-3 && (a.y - b.y).abs() < 1e-3);
    }
}
