//! Splitting a blend into its stars, and cleaning hot pixels before detection.

use super::background::median;
use super::{DEBLEND_MAX_PIXELS, DEBLEND_MAX_SADDLE};

/// The index of the peak nearest pixel `k`.
pub(super) fn nearest_peak(peaks: &[usize], k: usize, width: usize) -> usize {
    let (x, y) = ((k % width) as f64, (k / width) as f64);
    (0..peaks.len())
        .min_by(|&p, &q| {
            let d = |m: usize| ((peaks[m] % width) as f64 - x).hypot((peaks[m] / width) as f64 - y);
            d(p).total_cmp(&d(q))
        })
        .unwrap_or(0)
}

/// The parts of a component with two or three distinct peaks (see
/// [`super::ExtractConfig::deblend`]), each pixel with its nearest peak, and the peaks; empty when it
/// is one spot.
pub(super) fn deblend(
    resid: &[f32],
    width: usize,
    height: usize,
    comp: &[usize],
    min_peak: f64,
) -> (Vec<Vec<usize>>, Vec<usize>) {
    let none = (Vec::new(), Vec::new());
    if comp.len() < 5 || comp.len() > DEBLEND_MAX_PIXELS {
        return none;
    }
    let v = |k: usize| f64::from(resid[k]);
    // Local maxima of the component, high enough above the threshold.
    let mut peaks: Vec<usize> = comp
        .iter()
        .copied()
        .filter(|&k| {
            let (i, j) = ((k % width) as isize, (k / width) as isize);
            v(k) >= min_peak
                && (-1..=1isize).all(|dj| {
                    (-1..=1isize).all(|di| {
                        let (ni, nj) = (i + di, j + dj);
                        if (di == 0 && dj == 0)
                            || ni < 0
                            || nj < 0
                            || ni >= width as isize
                            || nj >= height as isize
                        {
                            return true;
                        }
                        let nk = nj as usize * width + ni as usize;
                        // Ties go to the lower index, so a flat top is one peak.
                        v(nk) < v(k) || (v(nk) == v(k) && nk > k)
                    })
                })
        })
        .collect();
    if peaks.len() < 2 || peaks.len() > 3 {
        return none;
    }
    peaks.sort_by(|&a, &b| v(b).total_cmp(&v(a)));
    // Every pair must be separated by a dip: the lowest pixel on the straight line between
    // them (sampled at half-pixel steps) below a fraction of the fainter peak.
    let xy = |k: usize| ((k % width) as f64, (k / width) as f64);
    for a in 0..peaks.len() {
        for b in a + 1..peaks.len() {
            let ((xa, ya), (xb, yb)) = (xy(peaks[a]), xy(peaks[b]));
            let steps = (2.0 * (xb - xa).hypot(yb - ya)).ceil() as usize;
            let lowest = (1..steps)
                .map(|s| {
                    let t = s as f64 / steps as f64;
                    let (x, y) = ((xa + t * (xb - xa)).round(), (ya + t * (yb - ya)).round());
                    v(y as usize * width + x as usize)
                })
                .fold(f64::INFINITY, f64::min);
            // (`lowest` is finite: the line's pixels are in the image.)
            if lowest >= DEBLEND_MAX_SADDLE * v(peaks[b]) {
                return none;
            }
        }
    }
    let mut parts = vec![Vec::new(); peaks.len()];
    for &k in comp {
        parts[nearest_peak(&peaks, k, width)].push(k);
    }
    (parts, peaks)
}

/// Replace hot pixels among `candidates` (pixels above `floor`) with no neighbour holding
/// `ratio` of their signal by the median of their neighbours; returns how many.
pub(super) fn clean_hot_pixels(
    resid: &mut [f32],
    width: usize,
    height: usize,
    candidates: &[usize],
    floor: f64,
    ratio: f64,
) -> usize {
    if ratio <= 0.0 {
        return 0;
    }
    let floor = floor.max(f64::MIN_POSITIVE);
    let mut hot = Vec::new();
    let mut nb = [0.0f32; 8];
    for &k in candidates {
        let (i, j) = (k % width, k / width);
        let v = f64::from(resid[k]);
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
            hot.push((k, median(&mut nb[..n])));
        }
    }
    for &(k, m) in &hot {
        resid[k] = m;
    }
    hot.len()
}
