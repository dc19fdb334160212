//! The numbers behind the false-match bound: medians and order statistics in place, and the
//! binomial tail.

/// The median of `v` (reordered): the middle value, for an even count the mean of the two middle
/// ones; by insertion sort up to [`MEDIAN_INSERTION_MAX`] values, else by selection with no full
/// sort. `v` must not be empty.
pub(crate) fn median_in_place(v: &mut [f64]) -> f64 {
    let k = v.len();
    if k <= MEDIAN_INSERTION_MAX {
        // A few dozen values (the matches of a frame): sorted by insertion, cheaper than a
        // selection at this size; the same two middle values either way.
        insertion_sort(v);
        return if k % 2 == 0 {
            0.5 * (v[k / 2 - 1] + v[k / 2])
        } else {
            v[k / 2]
        };
    }
    let upper = *v.select_nth_unstable_by(k / 2, f64::total_cmp).1;
    let lower = if k % 2 == 0 {
        v[..k / 2].iter().copied().fold(f64::NEG_INFINITY, f64::max)
    } else {
        upper
    };
    0.5 * (lower + upper)
}

/// The `k`-th smallest of `v` (0-based; reordered): by insertion sort up to
/// [`MEDIAN_INSERTION_MAX`] values, else by selection. `k` must be below `v.len()`, and `v` must
/// hold no NaN (the two ways then agree on the value).
pub(crate) fn kth_in_place(v: &mut [f64], k: usize) -> f64 {
    if v.len() <= MEDIAN_INSERTION_MAX {
        insertion_sort(v);
        v[k]
    } else {
        *v.select_nth_unstable_by(k, f64::total_cmp).1
    }
}

/// Sort a few values ascending in place (no NaN).
#[inline]
pub(super) fn insertion_sort(v: &mut [f64]) {
    for i in 1..v.len() {
        let x = v[i];
        let mut j = i;
        while j > 0 && v[j - 1] > x {
            v[j] = v[j - 1];
            j -= 1;
        }
        v[j] = x;
    }
}

/// Most values [`median_in_place`] sorts by insertion.
pub(super) const MEDIAN_INSERTION_MAX: usize = 32;

/// Largest `n` whose `ln n!` is tabled for [`ln_choose`].
pub(super) const LN_FACTORIAL_TABLE: usize = 4096;

/// `ln C(n, m)`, from `ln k!` for each of its three factorials.
pub(super) fn ln_choose(n: usize, m: usize) -> f64 {
    ln_factorial(n) - ln_factorial(m) - ln_factorial(n - m)
}

/// `ln k!`: from a table (built once) up to [`LN_FACTORIAL_TABLE`], past it by Stirling's series,
/// whose first omitted term there is below 1e-22: a frame of 100 000 spots costs no more than
/// one of 100.
pub(super) fn ln_factorial(k: usize) -> f64 {
    static TABLE: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    if k <= LN_FACTORIAL_TABLE {
        let t = TABLE.get_or_init(|| {
            let mut t = vec![0.0; LN_FACTORIAL_TABLE + 1];
            for k in 1..=LN_FACTORIAL_TABLE {
                t[k] = t[k - 1] + (k as f64).ln();
            }
            t
        });
        return t[k];
    }
    let x = k as f64;
    let inv = 1.0 / x;
    let inv2 = inv * inv;
    x * x.ln() - x
        + 0.5 * (std::f64::consts::TAU * x).ln()
        + inv * (1.0 / 12.0 - inv2 * (1.0 / 360.0 - inv2 / 1260.0))
}

/// `P(X ≥ m)` for `X ~ Binomial(n, p)`, summed in log space.
pub(crate) fn binomial_tail(n: usize, m: usize, p: f64) -> f64 {
    if m == 0 {
        return 1.0;
    }
    if m > n || p <= 0.0 {
        return 0.0;
    }
    if p >= 1.0 {
        return 1.0;
    }
    let (nf, mf) = (n as f64, m as f64);
    // Summing upwards from m loses everything to underflow when m lies far below the mean (the
    // first terms are ~0 while the mass sits near n·p): there, use the complement,
    // P(X ≥ m) = 1 − P(X ≤ m − 1) = 1 − P(n − X ≥ n − m + 1), n − X ~ Bin(n, 1 − p).
    if mf <= nf * p {
        return (1.0 - binomial_tail(n, n - m + 1, 1.0 - p)).clamp(0.0, 1.0);
    }
    let ln_choose = ln_choose(n, m);
    let mut term = (ln_choose + mf * p.ln() + (nf - mf) * (-p).ln_1p()).exp();
    let ratio = p / (1.0 - p);
    let mut sum = 0.0;
    for k in m..=n {
        sum += term;
        let next = term * (nf - k as f64) / (k as f64 + 1.0) * ratio;
        // (`<=`: a first term that underflowed to 0 ends the sum at once, not after n − m terms
        // of nothing; past the mode the terms only shrink.)
        if next <= sum * 1e-17 && (nf - k as f64) / (k as f64 + 1.0) * ratio < 1.0 {
            break;
        }
        term = next;
    }
    sum.min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ln_factorial_past_the_table_continues_the_sum() {
        let mut sum: f64 = (1..=LN_FACTORIAL_TABLE).map(|k| (k as f64).ln()).sum();
        for k in LN_FACTORIAL_TABLE + 1..LN_FACTORIAL_TABLE + 50 {
            sum += (k as f64).ln();
            assert!((ln_factorial(k) - sum).abs() < 1e-9 * sum, "k = {k}");
        }
        assert!((ln_choose(100_000, 50_000) - 69_308.735_799_4).abs() < 1e-6);
    }

    /// `len` values with ties and signed zeros: every `period`-th value 0, the next −0, the rest
    /// uniform in ±`half_range` rounded to multiples of 1/`steps`.
    fn tied_values(
        rng: &mut rand::rngs::StdRng,
        len: usize,
        period: usize,
        half_range: f64,
        steps: f64,
    ) -> Vec<f64> {
        use rand::Rng;
        (0..len)
            .map(|i| match i % period {
                0 => 0.0,
                1 => -0.0,
                _ => (rng.random_range(-half_range..half_range) * steps).round() / steps,
            })
            .collect()
    }

    #[test]
    fn median_is_the_middle_of_the_sorted_values_at_every_size() {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(11);
        // Both sides of MEDIAN_INSERTION_MAX, with ties and signed zeros.
        for k in 1..=80usize {
            for _ in 0..20 {
                let v = tied_values(&mut rng, k, 5, 4.0, 8.0);
                let mut sorted = v.clone();
                sorted.sort_by(f64::total_cmp);
                let want = if k % 2 == 0 {
                    0.5 * (sorted[k / 2 - 1] + sorted[k / 2])
                } else {
                    sorted[k / 2]
                };
                let got = median_in_place(&mut v.clone());
                assert_eq!(got, want, "k = {k}: {v:?}");
            }
        }
    }

    #[test]
    fn kth_is_the_sorted_values_kth_at_every_size_and_rank() {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(12);
        // Both sides of MEDIAN_INSERTION_MAX, with ties and signed zeros, every rank.
        for len in 1..=70usize {
            let v = tied_values(&mut rng, len, 7, 3.0, 4.0);
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            for (k, &want) in sorted.iter().enumerate() {
                assert_eq!(kth_in_place(&mut v.clone(), k), want, "k = {k}: {v:?}");
            }
        }
    }
}
