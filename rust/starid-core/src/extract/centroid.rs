//! One component measured: a Gaussian-windowed centroid, flux, shape and flags.

use super::*;

/// Gaussian-windowed centroid (the window's σ that of the spot): starting from the moments,
/// `x ← x + 2 Σ w v (xᵢ − x) / Σ w v` with `w = exp(−r² / 2σ²)`, which reaches the noise
/// floor of a Gaussian PSF where plain moments pick up the noise of the whole window.
pub(super) fn refine_gaussian(
    resid: &[f32],
    (width, height): (usize, usize),
    x0: f64,
    y0: f64,
    spot_sigma: f64,
    owns: &dyn Fn(usize) -> bool,
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
                let k = j as usize * width + i as usize;
                if !owns(k) {
                    continue;
                }
                let v = w * f64::from(resid[k]);
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

/// Whether `(x, y)` lies within a pixel of the bounding box of the component's pixels.
pub(super) fn near_component(comp: &[usize], width: usize, x: f64, y: f64) -> bool {
    let (mut i0, mut i1, mut j0, mut j1) = (usize::MAX, 0, usize::MAX, 0);
    for &k in comp {
        let (i, j) = (k % width, k / width);
        (i0, i1, j0, j1) = (i0.min(i), i1.max(i), j0.min(j), j1.max(j));
    }
    x.is_finite()
        && y.is_finite()
        && x >= i0 as f64 - 1.0
        && x <= i1 as f64 + 2.0
        && y >= j0 as f64 - 1.0
        && y <= j1 as f64 + 2.0
}

/// Centroid, flux, shape and flags of one component.
pub(super) fn measure<T: Pixel>(
    img: &[T],
    resid: &[f32],
    width: usize,
    height: usize,
    comp: &[usize],
    config: &ExtractConfig,
    owns: &dyn Fn(usize) -> bool,
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
        raw_peak = raw_peak.max(f64::from(img[k].to_f32()));
        let (i, j) = (k % width, k / width);
        border |= i == 0 || j == 0 || i == width - 1 || j == height - 1;
    }
    // Window moments around the peak: radius from the spot's size, at least 2 px.
    let r = ((comp.len() as f64).sqrt().ceil() as isize).clamp(2, 25);
    let (pi, pj) = ((peak_k % width) as isize, (peak_k / width) as isize);
    let (mut s, mut sx, mut sy) = (0.0f64, 0.0, 0.0);
    for j in (pj - r).max(0)..=(pj + r).min(height as isize - 1) {
        for i in (pi - r).max(0)..=(pi + r).min(width as isize - 1) {
            let k = j as usize * width + i as usize;
            if !owns(k) {
                continue;
            }
            // Light only: a window of noise around a faint spot sums near zero, and dividing
            // by such a sum would throw the centroid anywhere.
            let v = f64::from(resid[k]).max(0.0);
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
    // The shape from the component's own pixels, their light only (a component detected on
    // the smoothed image holds pixels the noise took below the background): a window's
    // noise would make second moments meaningless for faint spots.
    let (mut cs, mut cx, mut cy, mut cxx, mut cyy, mut cxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
    for &k in comp {
        let v = f64::from(resid[k]).max(0.0);
        let (px, py) = ((k % width) as f64 + 0.5, (k / width) as f64 + 0.5);
        cs += v;
        cx += v * px;
        cy += v * py;
        cxx += v * px * px;
        cyy += v * py * py;
        cxy += v * px * py;
    }
    let (mx, my) = if cs > 0.0 {
        (cx / cs, cy / cs)
    } else {
        ((pi as f64) + 0.5, (pj as f64) + 0.5)
    };
    let cs = cs.max(f64::MIN_POSITIVE);
    let (vxx, vyy, vxy) = (
        cxx / cs - mx * mx + 1.0 / 12.0,
        cyy / cs - my * my + 1.0 / 12.0,
        cxy / cs - mx * my,
    );
    // Pixels above a threshold see only the core of the PSF: the window is somewhat wider.
    let (x, y) = refine_gaussian(
        resid,
        (width, height),
        x,
        y,
        1.2 * (0.5 * (vxx + vyy)).max(0.0).sqrt(),
        owns,
    );
    // A centroid is where the component's light is: one the window moved off the component's
    // box or off the image (a spot lost in noise) is its own pixels' mean, which lies inside.
    let on_image = (0.0..=width as f64).contains(&x) && (0.0..=height as f64).contains(&y);
    let (x, y) = if on_image && near_component(comp, width, x, y) {
        (x, y)
    } else {
        (mx, my)
    };
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
