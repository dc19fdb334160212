//! The matched filter detection runs on: a separable Gaussian, kept inside the image.

use super::{for_row_bands, KEEP_BUFFER_PIXELS};

thread_local! {
    /// The column-smoothed image of the last extraction on this thread, reused.
    static COLUMNS: std::cell::Cell<Vec<f32>> = const { std::cell::Cell::new(Vec::new()) };
}

/// `img` (`width` a row) convolved with a normalised Gaussian of `sigma_px`, truncated at 2σ
/// (enough for detection), into `out` (resized): separable, a column pass then a row pass,
/// each over bands of rows in parallel and vectorised along the rows. Near the edges the
/// kernel keeps its taps inside the image, scaled so that white noise keeps the σ it has
/// inside (fewer pixels average less): a border pixel is not a likelier detection than any
/// other.
pub(super) fn gaussian_filter(
    img: &[f32],
    width: usize,
    height: usize,
    sigma_px: f64,
    out: &mut Vec<f32>,
) {
    let r = (2.0 * sigma_px).ceil().max(1.0) as usize;
    let w: Vec<f64> = (0..=2 * r)
        .map(|t| (-0.5 * ((t as f64 - r as f64) / sigma_px).powi(2)).exp())
        .collect();
    let total: f64 = w.iter().sum();
    let w: Vec<f32> = w.iter().map(|x| (x / total) as f32).collect();
    let sq_all: f32 = w.iter().map(|x| x * x).sum();
    // Taps of position `i` of `n` inside the image, and the scale that keeps the noise.
    let taps = |i: usize, n: usize| {
        let lo = r.saturating_sub(i);
        let hi = (2 * r).min(n - 1 + r - i);
        let sq: f32 = w[lo..=hi].iter().map(|x| x * x).sum();
        (lo, hi, (sq_all / sq).sqrt())
    };
    // Columns: each output row a weighted sum of whole input rows.
    // (Buffers of the right size are reused as they are: every value is written.)
    let mut cols: Vec<f32> = COLUMNS.with(|c| c.take());
    cols.resize(img.len(), 0.0);
    for_row_bands(&mut cols, width, |j, dst, _| {
        let (lo, hi, scale) = taps(j, height);
        let row = |t: usize| &img[(j + t - r) * width..(j + t - r + 1) * width];
        if hi - lo == 4 {
            let taps: [f32; 5] = std::array::from_fn(|t| w[lo + t] * scale);
            sum5(dst, std::array::from_fn(|t| row(lo + t)), taps);
            return true;
        }
        for (d, &v) in dst.iter_mut().zip(row(lo)) {
            *d = w[lo] * scale * v;
        }
        for (t, &wt) in w.iter().enumerate().take(hi + 1).skip(lo + 1) {
            let wt = wt * scale;
            for (d, &v) in dst.iter_mut().zip(row(t)) {
                *d += wt * v;
            }
        }
        true
    });
    // Rows: each output row a weighted sum of shifted copies of its column-smoothed row.
    out.resize(img.len(), 0.0);
    let inner = width.saturating_sub(2 * r);
    for_row_bands(out, width, |j, dst, _| {
        let src = &cols[j * width..(j + 1) * width];
        if inner > 0 && w.len() == 5 {
            let taps: [f32; 5] = std::array::from_fn(|t| w[t]);
            sum5(
                &mut dst[r..r + inner],
                std::array::from_fn(|t| &src[t..t + inner]),
                taps,
            );
        } else if inner > 0 {
            for (d, &v) in dst[r..r + inner].iter_mut().zip(&src[..inner]) {
                *d = w[0] * v;
            }
            for (t, &wt) in w.iter().enumerate().skip(1) {
                for (d, &v) in dst[r..r + inner].iter_mut().zip(&src[t..t + inner]) {
                    *d += wt * v;
                }
            }
        }
        let left = r.min(width);
        for i in (0..left).chain(left.max(r + inner)..width) {
            let (lo, hi, scale) = taps(i, width);
            dst[i] = scale * (lo..=hi).map(|t| w[t] * src[i + t - r]).sum::<f32>();
        }
        true
    });
    if cols.capacity() <= KEEP_BUFFER_PIXELS {
        COLUMNS.with(|c| c.replace(cols));
    }
}

/// `dst[i] = Σ taps[t] · src[t][i]` in one sweep (the default filter's five taps): one write
/// per value, vectorised along the row.
fn sum5(dst: &mut [f32], src: [&[f32]; 5], taps: [f32; 5]) {
    let n = dst.len();
    let [a, b, c, d, e] = src.map(|s| &s[..n]);
    for (i, out) in dst.iter_mut().enumerate() {
        *out = taps[0] * a[i] + taps[1] * b[i] + taps[2] * c[i] + taps[3] * d[i] + taps[4] * e[i];
    }
}
