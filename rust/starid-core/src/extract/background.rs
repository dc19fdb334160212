//! The background under the stars: block medians interpolated between block centres, and the
//! noise measured around it.

use super::*;

/// Median of a slice, the upper middle value of an even count; 0 for an empty one. Reorders
/// the slice: the values before the middle are no larger than it.
pub(super) fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// The background: block medians, interpolated bilinearly between block centres.
pub(super) struct Background {
    /// Per grid row, the background along x (bilinear between the block centres).
    pub(super) rows: Vec<Vec<f32>>,
    /// Per grid row, the local noise σ along x (the same interpolation).
    pub(super) noise_rows: Vec<Vec<f32>>,
    /// Block centres along y.
    pub(super) cy: Vec<f64>,
    /// Per image row, its two grid rows and the weight of the second.
    pub(super) row_weights: Vec<(usize, usize, f32)>,
    /// The block medians.
    pub(super) grid: Vec<f32>,
}

impl Background {
    pub(super) fn new<T: Pixel>(img: &[T], width: usize, height: usize, block: usize) -> Self {
        let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
        let block_row = |by: usize| -> Vec<(f32, f32)> {
            let mut buf: Vec<f32> = Vec::with_capacity(block * block / 16 + block);
            (0..bw)
                .map(|bx| {
                    buf.clear();
                    // Every fourth row and column: a sixteenth of the pixels (64 of a 32-pixel
                    // block) give the median within a sixth of the noise, and the interpolation
                    // between four blocks averages that down.
                    for j in ((by * block)..((by + 1) * block).min(height)).step_by(4) {
                        buf.extend(
                            img[j * width + bx * block..j * width + ((bx + 1) * block).min(width)]
                                .iter()
                                .step_by(4)
                                .map(|p| p.to_f32()),
                        );
                    }
                    // The median partitions the samples: the quartiles are the medians of the two
                    // halves, and σ = IQR / 1.349 (robust to a star in the block).
                    let k = buf.len() / 2;
                    let m = median(&mut buf);
                    let (lo, hi) = buf.split_at_mut(k);
                    let q1 = median(lo);
                    let q3 = if hi.len() > 1 {
                        median(&mut hi[1..])
                    } else {
                        m
                    };
                    (m, (q3 - q1) / 1.349)
                })
                .collect()
        };
        let grid_rows: Vec<usize> = (0..bh).collect();
        let cells: Vec<(f32, f32)> = map_items(&grid_rows, |&by| block_row(by))
            .into_iter()
            .flatten()
            .collect();
        let grid: Vec<f32> = cells.iter().map(|c| c.0).collect();
        // The local noise, each block's the median over it and its neighbours (a star or a
        // trail in one block does not raise it).
        let noise: Vec<f32> = (0..bh * bw)
            .map(|k| {
                let (bx, by) = ((k % bw) as isize, (k / bw) as isize);
                let mut near = [0.0f32; 9];
                let mut n = 0;
                for dy in -1..=1isize {
                    for dx in -1..=1isize {
                        let (x, y) = (bx + dx, by + dy);
                        if x >= 0 && y >= 0 && (x as usize) < bw && (y as usize) < bh {
                            near[n] = cells[y as usize * bw + x as usize].1;
                            n += 1;
                        }
                    }
                }
                median(&mut near[..n])
            })
            .collect();
        let centre = |b: usize, n: usize| {
            ((b * block) as f64 + 0.5 * ((block.min(n - b * block)) as f64)).min(n as f64)
        };
        let cx: Vec<f64> = (0..bw).map(|b| centre(b, width)).collect();
        let cy: Vec<f64> = (0..bh).map(|b| centre(b, height)).collect();
        let xs: Vec<(usize, usize, f64)> =
            (0..width).map(|i| interp(&cx, i as f64 + 0.5)).collect();
        let along_x = |g: &[f32]| -> Vec<Vec<f32>> {
            (0..bh)
                .map(|y| {
                    xs.iter()
                        .map(|&(x0, x1, tx)| {
                            (f64::from(g[y * bw + x0]) * (1.0 - tx)
                                + f64::from(g[y * bw + x1]) * tx) as f32
                        })
                        .collect()
                })
                .collect()
        };
        let rows = along_x(&grid);
        let noise_rows = along_x(&noise);
        let row_weights = (0..height)
            .map(|j| {
                let (y0, y1, t) = interp(&cy, j as f64 + 0.5);
                (y0, y1, t as f32)
            })
            .collect();
        Self {
            rows,
            noise_rows,
            cy,
            row_weights,
            grid,
        }
    }

    /// Per grid row, the detection threshold along x: `k` local noise σ, never below `floor`
    /// (the global threshold): the local noise only raises it, where the background is bright
    /// and the shot noise with it, never lowers it (a background clipped at zero has none).
    pub(super) fn thresholds(&self, k: f32, floor: f32) -> Vec<Vec<f32>> {
        self.noise_rows
            .iter()
            .map(|r| r.iter().map(|&s| (k * s).max(floor)).collect())
            .collect()
    }

    /// `out = img − background` along row `j`; the pixels above the threshold rows `thr` (of
    /// the nearer grid row) pushed on `list`; whether all values are finite.
    pub(super) fn subtract_row<T: Pixel>(
        &self,
        img: &[T],
        thr: &[Vec<f32>],
        j: usize,
        out: &mut [f32],
        list: &mut Vec<usize>,
    ) -> bool {
        let width = out.len();
        let (y0, y1, t) = self.row_weights[j];
        let (a, b) = (&self.rows[y0][..width], &self.rows[y1][..width]);
        let th = &thr[if t < 0.5 { y0 } else { y1 }][..width];
        let src = &img[j * width..(j + 1) * width];
        // Integer counts, not a float maximum: the loop vectorises.
        let (mut over, mut bad) = (0u32, 0u32);
        for i in 0..width {
            let v = src[i].to_f32() - (a[i] + (b[i] - a[i]) * t);
            out[i] = v;
            over += u32::from(v > th[i]);
            bad |= u32::from(!v.is_finite());
        }
        if over > 0 {
            list_above(out, th, j, list);
        }
        bad == 0
    }

    /// The threshold row of image row `j`, as [`Background::subtract_row`] reads it.
    pub(super) fn threshold_row<'a>(&self, thr: &'a [Vec<f32>], j: usize) -> &'a [f32] {
        let (y0, y1, t) = self.row_weights[j];
        &thr[if t < 0.5 { y0 } else { y1 }]
    }

    /// The threshold rows' value at pixel `(i, j)`, as [`Background::subtract_row`] reads it.
    pub(super) fn threshold_at(&self, thr: &[Vec<f32>], i: usize, j: usize) -> f32 {
        let (y0, y1, t) = self.row_weights[j];
        thr[if t < 0.5 { y0 } else { y1 }][i]
    }

    /// The noise σ of the image less its background, over a grid of about 16 384 pixels (odd
    /// steps, so that no pattern of the sensor's lines aliases), from its quantiles
    /// ([`spread_sigma`]; the share of samples at the image's lowest value tells whether the
    /// background was clipped).
    /// The median and σ of an image already less its background (a smoothed one), from the
    /// sparse grid of pixels [`Background::robust_sigma`] reads: σ is the spread from the
    /// median to the 84th percentile, which holds where the background was clipped below its
    /// median (smoothing blurs the clipped level, so the quartiles would read it too narrow,
    /// and lifts the level to the clipped noise's mean, which the median follows).
    pub(super) fn sample_level_sigma(
        &self,
        img: &[f32],
        width: usize,
        height: usize,
    ) -> (f64, f64) {
        let step = (((width * height) as f64 / 16_384.0).sqrt() as usize).max(1) | 1;
        let mut s: Vec<f32> = (step / 2..height)
            .step_by(step)
            .flat_map(|j| {
                (step / 2..width)
                    .step_by(step)
                    .map(move |i| img[j * width + i])
            })
            .collect();
        if s.is_empty() {
            return (0.0, 0.0);
        }
        s.sort_unstable_by(f32::total_cmp);
        let q = |p: f64| f64::from(s[((p * s.len() as f64) as usize).min(s.len() - 1)]);
        (q(0.5), (q(normal_cdf_one_sigma()) - q(0.5)).max(0.0))
    }

    pub(super) fn robust_sigma<T: Pixel>(&self, img: &[T], width: usize, height: usize) -> f64 {
        let step = (((width * height) as f64 / 16_384.0).sqrt() as usize).max(1) | 1;
        let mut s: Vec<f32> = Vec::with_capacity((width / step + 1) * (height / step + 1));
        let (mut lowest, mut at_lowest) = (f32::INFINITY, 0usize);
        for j in (step / 2..height).step_by(step) {
            let (y0, y1, ty) = interp(&self.cy, j as f64 + 0.5);
            let (a, b, t) = (&self.rows[y0], &self.rows[y1], ty as f32);
            for i in (step / 2..width).step_by(step) {
                let raw = img[j * width + i].to_f32();
                if raw < lowest {
                    (lowest, at_lowest) = (raw, 1);
                } else if raw == lowest {
                    at_lowest += 1;
                }
                let x = raw - (a[i] + (b[i] - a[i]) * t);
                if x.is_finite() {
                    s.push(x);
                }
            }
        }
        if s.is_empty() {
            return 0.0;
        }
        let clipped = at_lowest as f64 / s.len() as f64;
        spread_sigma(&mut s, clipped)
    }

    /// The median of the block medians.
    pub(super) fn level(&self) -> f64 {
        let mut g = self.grid.clone();
        f64::from(median(&mut g))
    }
}

/// The noise σ about a point `(x, y)`: the spread ([`spread_sigma`]) of every second pixel of
/// the window of side `block` centred on it (clipped to the image), less the pixels within
/// `exclude` of it (a spot's own), read as [`Background::robust_sigma`] reads the frame's.
pub(super) fn local_sigma<T: Pixel>(
    img: &[T],
    (width, height): (usize, usize),
    block: usize,
    (x, y): (f64, f64),
    exclude: f64,
) -> f64 {
    let half = (block / 2) as f64;
    let span = |c: f64, n: usize| {
        let lo = (c - half).floor().max(0.0) as usize;
        let hi = ((c + half).ceil() as usize).min(n);
        (lo.min(hi), hi)
    };
    let ((x0, x1), (y0, y1)) = (span(x, width), span(y, height));
    let mut s: Vec<f32> = Vec::with_capacity((block / 2 + 1) * (block / 2 + 1));
    let (mut lowest, mut at_lowest) = (f32::INFINITY, 0usize);
    for j in (y0..y1).step_by(2) {
        let dy = j as f64 + 0.5 - y;
        for i in (x0..x1).step_by(2) {
            let dx = i as f64 + 0.5 - x;
            if dx * dx + dy * dy <= exclude * exclude {
                continue;
            }
            let v = img[j * width + i].to_f32();
            if !v.is_finite() {
                continue;
            }
            if v < lowest {
                (lowest, at_lowest) = (v, 1);
            } else if v == lowest {
                at_lowest += 1;
            }
            s.push(v);
        }
    }
    if s.len() < 8 {
        return 0.0;
    }
    let clipped = at_lowest as f64 / s.len() as f64;
    spread_sigma(&mut s, clipped)
}

/// Pixels this near a spot's centroid are its own, not its surroundings ([`local_sigma`]).
pub(super) const SPOT_EXCLUSION_PX: f64 = 4.0;

/// Most windows [`typical_local_sigma`] reads.
const TYPICAL_WINDOWS: usize = 64;

/// The noise [`local_sigma`] reads at a typical place of the image: its median over windows
/// on a grid across it (at most [`TYPICAL_WINDOWS`]). Clutter over less than half the frame
/// (a tree, a roof) leaves it the sky's, where the frame's own σ takes some of the clutter in.
pub(super) fn typical_local_sigma<T: Pixel>(
    img: &[T],
    (width, height): (usize, usize),
    block: usize,
) -> f64 {
    let spacing = (((width * height) as f64 / TYPICAL_WINDOWS as f64)
        .sqrt()
        .ceil() as usize)
        .max(block)
        .max(1);
    let centres: Vec<(f64, f64)> = (spacing / 2..height.max(1))
        .step_by(spacing)
        .flat_map(|j| {
            (spacing / 2..width.max(1))
                .step_by(spacing)
                .map(move |i| (i as f64, j as f64))
        })
        .collect();
    let mut s: Vec<f32> = map_items(&centres, |&p| {
        local_sigma(img, (width, height), block, p, 0.0) as f32
    });
    f64::from(median(&mut s))
}

/// Share of the sampled pixels at the image's lowest value from which the background counts
/// as clipped. An unclipped background's lowest value is a lone tail sample: a few in ten
/// thousand hold it, or a few in a hundred where coarse quantisation piles the tail onto one
/// level (and there the upper quantiles measure the same σ).
pub(super) const CLIPPED_SHARE: f64 = 0.08;

/// The pixels of row `j` (`row`, a row of the image) above their thresholds `th`, as indices
/// into the image, appended to `list`. A few pixels in a thousand rise above it: callers
/// count first and list only rows that have any.
pub(super) fn list_above(row: &[f32], th: &[f32], j: usize, list: &mut Vec<usize>) {
    let width = row.len();
    list.extend(
        (0..width)
            .filter(|&i| row[i] > th[i])
            .map(|i| j * width + i),
    );
}

/// The σ of samples `s` (reordered) of a Gaussian, from two of their quantiles: the quartiles
/// (σ = IQR / 1.349, robust to the stars among them) or, where the background was clipped
/// (`clipped`, the share of samples at the lowest value, at least [`CLIPPED_SHARE`]: frames
/// whose background was subtracted and cut at zero), two quantiles above the clipped ones:
/// the median and the third quartile where less than half is clipped (a distribution clipped
/// below its median keeps it), higher ones where more is. Quantiles are read across the width
/// of the samples' levels ([`tied_quantile`]), so that quantised pixels do not round the
/// spread to whole levels: a noise of a third of a level still measures about that, where the
/// median absolute deviation reads 0.
pub(super) fn spread_sigma(s: &mut [f32], clipped: f64) -> f64 {
    s.sort_unstable_by(f32::total_cmp);
    let (pa, pb) = if clipped >= CLIPPED_SHARE {
        let pa = (clipped + 0.1).clamp(0.5, 0.9);
        (pa, 0.5 * (pa + 1.0))
    } else {
        (0.25, 0.75)
    };
    let step = level_step(s);
    let spread = tied_quantile(s, pb, step) - tied_quantile(s, pa, step);
    (spread / (normal_quantile(pb) - normal_quantile(pa))).max(0.0)
}

/// The `p` quantile of sorted samples whose values come in levels `step` apart, a run of equal
/// values spread evenly over its level's width (`v ± step / 2`): quantised pixels keep their
/// spread instead of rounding it to whole levels. For continuous samples `step` is tiny and
/// this is the plain quantile.
pub(super) fn tied_quantile(sorted: &[f32], p: f64, step: f64) -> f64 {
    let n = sorted.len();
    let rank = (p * n as f64).clamp(0.0, n as f64);
    let v = sorted[(rank as usize).min(n - 1)];
    let lo = sorted.partition_point(|&x| x < v);
    let hi = sorted.partition_point(|&x| x <= v);
    let t = ((rank - lo as f64) / (hi - lo) as f64).clamp(0.0, 1.0);
    f64::from(v) + (t - 0.5) * step
}

/// The spacing of the levels of sorted samples: the smallest gap between distinct values (0
/// where all are equal).
fn level_step(sorted: &[f32]) -> f64 {
    let gap = sorted
        .windows(2)
        .map(|w| f64::from(w[1] - w[0]))
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    if gap.is_finite() {
        gap
    } else {
        0.0
    }
}

/// Φ(1): the share of a Gaussian below one σ above its mean.
fn normal_cdf_one_sigma() -> f64 {
    0.841_344_746
}

/// The standard normal quantile Φ⁻¹(p) for p in (0, 1): Acklam's rational approximation
/// (relative error below 1.2·10⁻⁹).
pub(super) fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// The two centres around `p` and the weight of the second (clamped at the ends).
pub(super) fn interp(c: &[f64], p: f64) -> (usize, usize, f64) {
    if c.len() == 1 || p <= c[0] {
        return (0, 0, 0.0);
    }
    let last = c.len() - 1;
    if p >= c[last] {
        return (last, last, 0.0);
    }
    let k = c.partition_point(|&v| v <= p) - 1;
    (k, k + 1, (p - c[k]) / (c[k + 1] - c[k]))
}
