//! Image files the core decodes itself: PNG, 8 or 16 bits a channel (grey, grey and alpha, RGB,
//! RGBA, palette), in one pass to the pixel types extraction reads in place: grey stays `u8` or
//! `u16` as stored, colour becomes its luminance (`f32`, [`crate::extract::LUMA_WEIGHTS`]).

use crate::error::{Error, Result};
use crate::extract::{luminance, LUMA_WEIGHTS};

/// A decoded image's pixels, row-major.
#[derive(Debug, Clone, PartialEq)]
pub enum Pixels {
    /// 8-bit grey.
    U8(Vec<u8>),
    /// 16-bit grey.
    U16(Vec<u16>),
    /// The luminance of a colour image.
    F32(Vec<f32>),
}

/// A decoded image: `width` × `height` pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedImage {
    /// Pixels across.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// The pixels, row-major.
    pub pixels: Pixels,
}

/// Bytes the decoder may allocate beyond the pixels themselves (text and colour-profile chunks).
const CHUNK_BYTES: usize = 64 << 20;

/// Decode a PNG file's bytes. Images of more than `max_pixels` pixels are refused from their
/// header, before any pixel is decoded.
///
/// # Errors
/// `InvalidInput` naming what is wrong: not a PNG, truncated, corrupt, or over `max_pixels`.
///
/// # Example
/// ```
/// use starid_core::image::{read_png, Pixels};
/// // A 2 x 1 8-bit grey PNG.
/// let mut file = Vec::new();
/// let mut encoder = png::Encoder::new(&mut file, 2, 1);
/// encoder.set_color(png::ColorType::Grayscale);
/// encoder.write_header().unwrap().write_image_data(&[7, 200]).unwrap();
/// let img = read_png(&file, 100).unwrap();
/// assert_eq!((img.width, img.height, img.pixels), (2, 1, Pixels::U8(vec![7, 200])));
/// assert!(read_png(b"not a png", 100).is_err());
/// ```
pub fn read_png(bytes: &[u8], max_pixels: usize) -> Result<DecodedImage> {
    let bad = |e: png::DecodingError| Error::invalid_input(format!("not a readable PNG ({e})"));
    let limits = png::Limits {
        bytes: max_pixels.saturating_mul(8).saturating_add(CHUNK_BYTES),
    };
    let mut decoder = png::Decoder::new_with_limits(std::io::Cursor::new(bytes), limits);
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(bad)?;
    let (width, height) = {
        let info = reader.info();
        (info.width as usize, info.height as usize)
    };
    if width.saturating_mul(height) > max_pixels {
        return Err(Error::invalid_input(format!(
            "{width} x {height} pixels, over the {max_pixels}-pixel limit"
        )));
    }
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| Error::invalid_input("a PNG too large to decode"))?;
    let mut buf = vec![0u8; size];
    let out = reader.next_frame(&mut buf).map_err(bad)?;
    let channels = out.color_type.samples();
    let wide = out.bit_depth == png::BitDepth::Sixteen;
    if !wide && out.bit_depth != png::BitDepth::Eight {
        return Err(Error::invalid_input(format!(
            "a PNG of {:?} bits a channel",
            out.bit_depth
        )));
    }
    let sample = if wide { 2 } else { 1 };
    let row_bytes = width * channels * sample;
    if out.line_size != row_bytes || buf.len() < row_bytes * height {
        return Err(Error::invalid_input(
            "a PNG whose rows do not hold its width",
        ));
    }
    // Rows of 8 or 16-bit samples hold no padding: the samples run on across them.
    let samples = &buf[..row_bytes * height];
    let [wr, wg, wb] = LUMA_WEIGHTS;
    let be = |p: &[u8], k: usize| f32::from(u16::from_be_bytes([p[2 * k], p[2 * k + 1]]));
    let pixels = match (channels, wide) {
        // Grey, with or without alpha: the grey channel as stored.
        (1, false) => Pixels::U8(samples.to_vec()),
        (2, false) => Pixels::U8(samples.iter().step_by(2).copied().collect()),
        (1 | 2, true) => Pixels::U16(
            samples
                .chunks_exact(2 * channels)
                .map(|p| u16::from_be_bytes([p[0], p[1]]))
                .collect(),
        ),
        (3 | 4, false) => Pixels::F32(luminance(samples, channels)?),
        (3 | 4, true) => Pixels::F32(
            samples
                .chunks_exact(2 * channels)
                .map(|p| wr * be(p, 0) + wg * be(p, 1) + wb * be(p, 2))
                .collect(),
        ),
        _ => {
            return Err(Error::invalid_input(format!(
                "a PNG of {channels} channels"
            )))
        }
    };
    Ok(DecodedImage {
        width,
        height,
        pixels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `w` × `h` pixels of `color` at `depth`, from its raw samples (big-endian).
    fn encode(w: u32, h: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut e = png::Encoder::new(&mut out, w, h);
        e.set_color(color);
        e.set_depth(depth);
        e.write_header().unwrap().write_image_data(data).unwrap();
        out
    }

    #[test]
    fn grey_stays_as_stored_and_colour_becomes_luminance() {
        use png::{BitDepth::*, ColorType::*};
        let g8 = read_png(&encode(2, 1, Grayscale, Eight, &[3, 250]), 10).unwrap();
        assert_eq!(g8.pixels, Pixels::U8(vec![3, 250]));
        let g16 = read_png(&encode(1, 2, Grayscale, Sixteen, &[1, 2, 255, 254]), 10).unwrap();
        assert_eq!((g16.width, g16.height), (1, 2));
        assert_eq!(g16.pixels, Pixels::U16(vec![258, 65534]));
        let ga = read_png(&encode(2, 1, GrayscaleAlpha, Eight, &[9, 0, 11, 255]), 10).unwrap();
        assert_eq!(ga.pixels, Pixels::U8(vec![9, 11]));
        let rgba = read_png(&encode(1, 1, Rgba, Eight, &[100, 50, 10, 0]), 10).unwrap();
        let want = 0.299 * 100.0 + 0.587 * 50.0 + 0.114 * 10.0;
        assert!(matches!(rgba.pixels, Pixels::F32(ref v) if (v[0] - want).abs() < 1e-3));
        let rgb16 = read_png(&encode(1, 1, Rgb, Sixteen, &[1, 0, 1, 0, 1, 0]), 10).unwrap();
        assert!(matches!(rgb16.pixels, Pixels::F32(ref v) if (v[0] - 256.0).abs() < 1e-2));
    }

    #[test]
    fn broken_and_oversized_files_are_refused() {
        let ok = encode(
            4,
            4,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[0; 16],
        );
        assert!(read_png(&ok, 15).is_err());
        assert!(read_png(&ok[..ok.len() - 20], 100).is_err());
        assert!(read_png(b"not a png", 100).is_err());
        let mut flipped = ok.clone();
        let n = flipped.len();
        flipped[n - 16] ^= 0xff;
        assert!(read_png(&flipped, 100).is_err());
    }
}
