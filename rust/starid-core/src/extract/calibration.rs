//! Dark and flat frames, and pixels with no value: the image [`super::extract`] reads.

use super::Pixel;
use crate::error::{Error, Result};

/// The image calibrated for extraction, as `f32`: `dark` (a dark or median frame) subtracted,
/// `flat` divided out, normalised to the median of its finite values (a flat pixel that is not
/// positive leaves its pixel without a value), then every pixel without a finite value (a
/// background masked or clipped to NaN, a dead flat pixel) set to the median of the finite
/// ones. `None` where there is nothing to do (no dark, no flat, every pixel finite): the image
/// is read as it is. `dark` and `flat` hold one value per pixel, in the image's order.
///
/// # Errors
/// `InvalidInput` when `dark` or `flat` does not hold one value per pixel, when the flat has no
/// positive median, or when no pixel of the calibrated image is finite.
///
/// # Example
/// ```
/// use starid_core::extract::apply_calibration;
/// let image = [110u16, 120, 130, 140];
/// let dark = [10.0f32; 4];
/// let flat = [1.0f32, 1.0, 2.0, 2.0]; // median 1.5
/// let out = apply_calibration(&image, Some(&dark), Some(&flat)).unwrap().unwrap();
/// assert_eq!(out, vec![150.0, 165.0, 90.0, 97.5]);
/// assert!(apply_calibration(&image, None, None).unwrap().is_none());
/// let masked = [1.0f32, f32::NAN, 3.0, 5.0];
/// assert_eq!(apply_calibration(&masked, None, None).unwrap().unwrap(), vec![1.0, 3.0, 3.0, 5.0]);
/// ```
pub fn apply_calibration<T: Pixel>(
    pixels: &[T],
    dark: Option<&[f32]>,
    flat: Option<&[f32]>,
) -> Result<Option<Vec<f32>>> {
    for (name, frame) in [("dark", dark), ("flat", flat)] {
        if let Some(f) = frame.filter(|f| f.len() != pixels.len()) {
            return Err(Error::invalid_input(format!(
                "the {name} frame holds {} pixels, the image {}",
                f.len(),
                pixels.len()
            )));
        }
    }
    if dark.is_none()
        && flat.is_none()
        && !(T::FLOAT && pixels.iter().any(|p| !p.to_f32().is_finite()))
    {
        return Ok(None);
    }
    let scale = match flat {
        None => None,
        Some(f) => {
            let level = median(f.iter().copied().filter(|v| v.is_finite()).collect());
            if !level.is_some_and(|m| m > 0.0) {
                return Err(Error::invalid_input(
                    "the flat frame must have a positive median",
                ));
            }
            level
        }
    };
    let mut out: Vec<f32> = pixels
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let v = p.to_f32() - dark.map_or(0.0, |d| d[k]);
            match (flat, scale) {
                (Some(f), Some(m)) if f[k] > 0.0 => v * (m / f[k]),
                (Some(_), _) => f32::NAN,
                _ => v,
            }
        })
        .collect();
    if out.iter().any(|v| !v.is_finite()) {
        let Some(fill) = median(out.iter().copied().filter(|v| v.is_finite()).collect()) else {
            return Err(Error::invalid_input(
                "no pixel of the calibrated image is finite",
            ));
        };
        for v in out.iter_mut().filter(|v| !v.is_finite()) {
            *v = fill;
        }
    }
    Ok(Some(out))
}

/// The median of finite values (the mean of the middle two of an even count); None when empty.
fn median(mut values: Vec<f32>) -> Option<f32> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    // The upper middle one; the extraction's median leaves the smaller half before it.
    let hi = super::background::median(&mut values);
    if n % 2 == 1 {
        return Some(hi);
    }
    let lo = values[..n / 2]
        .iter()
        .copied()
        .fold(f32::NEG_INFINITY, f32::max);
    Some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dark_and_flat_of_the_wrong_size_or_no_level_are_refused() {
        let img = [1u8; 9];
        let short = [0.0f32; 8];
        assert!(apply_calibration(&img, Some(&short), None).is_err());
        assert!(apply_calibration(&img, None, Some(&short)).is_err());
        let dead = [0.0f32; 9];
        assert!(apply_calibration(&img, None, Some(&dead)).is_err());
        let none = [f32::NAN; 9];
        assert!(apply_calibration(&none, None, None).is_err());
    }

    #[test]
    fn a_flat_pixel_that_is_not_positive_takes_the_median() {
        let img = [10.0f32, 20.0, 30.0, 40.0, 50.0];
        let flat = [1.0f32, 1.0, 0.0, 1.0, 1.0];
        let out = apply_calibration(&img, None, Some(&flat)).unwrap().unwrap();
        assert_eq!(out, vec![10.0, 20.0, 30.0, 40.0, 50.0]);
    }

    #[test]
    fn median_of_even_and_odd_counts() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(median(Vec::new()), None);
    }
}
