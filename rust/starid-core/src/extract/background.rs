//! The background under the stars: block medians interpolated between block centres, and the
//! noise measured around it.

use super::*;

/// Median of a slice (reorders it); 0 for an empty one.
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
        // A few pixels in a thousand rise above it: listed only in rows that have any.
        if over > 0 {
            list.extend(
                (0..width)
                    .filter(|&i| out[i] > th[i])
                    .map(|i| j * width + i),
            );
        }
        bad == 0
    }

    /// The threshold rows' value at pixel `(i, j)`, as [`Background::subtract_row`] reads it.
    pub(super) fn threshold_at(&self, thr: &[Vec<f32>], i: usize, j: usize) -> f32 {
        let (y0, y1, t) = self.row_weights[j];
        thr[if t < 0.5 { y0 } else { y1 }][i]
    }

    /// 1.4826 × the median absolute deviation of the image less its background, over a grid
    /// of about 16 384 pixels (odd steps, so that no pattern of the sensor's lines aliases).
    pub(super) fn robust_sigma<T: Pixel>(&self, img: &[T], width: usize, height: usize) -> f64 {
        let step = (((width * height) as f64 / 16_384.0).sqrt() as usize).max(1) | 1;
        let mut s: Vec<f32> = Vec::with_capacity((width / step + 1) * (height / step + 1));
        for j in (step / 2..height).step_by(step) {
            let (y0, y1, ty) = interp(&self.cy, j as f64 + 0.5);
            let (a, b, t) = (&self.rows[y0], &self.rows[y1], ty as f32);
            for i in (step / 2..width).step_by(step) {
                let x = img[j * width + i].to_f32() - (a[i] + (b[i] - a[i]) * t);
                if x.is_finite() {
                    s.push(x);
                }
            }
        }
        let m = median(&mut s);
        for v in &mut s {
            *v = (*v - m).abs();
        }
        1.4826 * f64::from(median(&mut s))
    }

    /// The median of the block medians.
    pub(super) fn level(&self) -> f64 {
        let mut g = self.grid.clone();
        f64::from(median(&mut g))
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
