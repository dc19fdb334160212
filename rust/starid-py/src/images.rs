//! Centroid extraction and the image simulator.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyReadonlyArray2, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use starid_core::extract::{extract, ExtractConfig};
use starid_core::simulate::{render, RenderConfig};
use starid_core::{simulate as sim, FalseStarMags};

use crate::camera::PyCamera;
use crate::catalog::PyCatalog;
use crate::errors::InvalidInputError;
use crate::{outcome, run_core};

/// One value of every spot as a numpy array.
fn column<'py, T: numpy::Element>(
    py: Python<'py>,
    spots: &[starid_core::extract::Spot],
    f: impl Fn(&starid_core::extract::Spot) -> T,
) -> Bound<'py, numpy::PyArray1<T>> {
    spots.iter().map(f).collect::<Vec<T>>().into_pyarray(py)
}

/// Extraction over a borrowed numpy image of pixel type `T` (read in place when C-contiguous
/// and no calibration is due), less `dark` and over `flat` where given.
fn extract_array<T: starid_core::extract::Pixel + numpy::Element>(
    py: Python<'_>,
    image: &PyReadonlyArray2<'_, T>,
    dark: Option<&[f32]>,
    flat: Option<&[f32]>,
    cfg: &ExtractConfig,
) -> PyResult<starid_core::extract::Extraction> {
    let view = image.as_array();
    let (h, w) = (view.nrows(), view.ncols());
    // Read in place only in C order (a column-major array's flat data runs down the columns).
    let copy: Vec<T>;
    let pixels: &[T] = match image.as_slice().ok().filter(|_| image.is_c_contiguous()) {
        Some(pixels) => pixels,
        None => {
            copy = view.iter().copied().collect();
            &copy
        }
    };
    run_core(py, || {
        match starid_core::extract::apply_calibration(pixels, dark, flat)? {
            Some(calibrated) => extract(&calibrated, w, h, cfg),
            None => extract(pixels, w, h, cfg),
        }
    })
}

/// A dark or flat frame's values in row-major order, refused unless it has the image's shape.
fn calibration_frame(
    name: &str,
    frame: Option<&PyReadonlyArray2<'_, f32>>,
    image: &Bound<'_, PyAny>,
) -> PyResult<Option<Vec<f32>>> {
    let Some(frame) = frame else {
        return Ok(None);
    };
    let shape: Vec<usize> = image.getattr("shape")?.extract()?;
    if frame.shape() != shape.as_slice() {
        let dims = |s: &[usize]| {
            s.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        };
        return Err(InvalidInputError::new_err(format!(
            "{name} has shape ({}), the image ({})",
            dims(frame.shape()),
            dims(&shape)
        )));
    }
    Ok(Some(frame.as_array().iter().copied().collect()))
}

/// The luminance of a colour image (H, W, 3 or 4) of pixel type `T`, as float32 (H, W).
fn luminance_array<'py, T: starid_core::extract::Pixel + numpy::Element>(
    py: Python<'py>,
    image: &PyReadonlyArray3<'py, T>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    let view = image.as_array();
    let (h, w, c) = view.dim();
    let grey = match image.as_slice().ok().filter(|_| image.is_c_contiguous()) {
        Some(pixels) => run_core(py, || starid_core::extract::luminance(pixels, c))?,
        None => {
            let pixels: Vec<T> = view.iter().copied().collect();
            run_core(py, move || starid_core::extract::luminance(&pixels, c))?
        }
    };
    Ok(Array2::from_shape_vec((h, w), grey)
        .expect("one value a pixel")
        .into_pyarray(py))
}

/// A PNG file as a 2-D array: grey as stored (uint8, uint16), colour as its luminance
/// (float32); over `max_pixels` pixels refused from the header.
#[pyfunction]
pub fn read_png(
    py: Python<'_>,
    path: std::path::PathBuf,
    max_pixels: usize,
) -> PyResult<Py<PyAny>> {
    use starid_core::image::Pixels;
    let img = run_core(py, move || {
        let bytes = std::fs::read(&path).map_err(starid_core::Error::from)?;
        starid_core::image::read_png(&bytes, max_pixels)
    })?;
    let shape = (img.height, img.width);
    let bad = |_| InvalidInputError::new_err("a PNG whose pixels do not fill its size");
    Ok(match img.pixels {
        Pixels::U8(v) => Array2::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any()
            .unbind(),
        Pixels::U16(v) => Array2::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any()
            .unbind(),
        Pixels::F32(v) => Array2::from_shape_vec(shape, v)
            .map_err(bad)?
            .into_pyarray(py)
            .into_any()
            .unbind(),
    })
}

/// The extraction settings' defaults, the core's [`ExtractConfig::default`]: name → value.
#[pyfunction]
pub fn extract_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = ExtractConfig::default();
    let out = PyDict::new(py);
    out.set_item("threshold_sigma", d.threshold_sigma)?;
    out.set_item("background_block", d.background_block)?;
    out.set_item("min_pixels", d.min_pixels)?;
    out.set_item("max_spots", d.max_spots)?;
    out.set_item("saturation", d.saturation)?;
    out.set_item("max_elongation", d.max_elongation)?;
    out.set_item("drop_flagged", d.drop_flagged)?;
    out.set_item("hot_pixel_ratio", d.hot_pixel_ratio)?;
    out.set_item("deblend", d.deblend)?;
    out.set_item("filter_sigma_px", d.filter_sigma_px)?;
    Ok(out)
}

/// Colour to luminance (ITU-R 601 weights): a (H, W, 3 or 4) array of uint8, uint16 or float32
/// as a (H, W) float32 image, in one pass.
#[pyfunction]
pub fn luminance<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyArray2<f32>>> {
    if let Ok(a) = image.extract::<PyReadonlyArray3<'py, u8>>() {
        luminance_array(py, &a)
    } else if let Ok(a) = image.extract::<PyReadonlyArray3<'py, u16>>() {
        luminance_array(py, &a)
    } else if let Ok(a) = image.extract::<PyReadonlyArray3<'py, f32>>() {
        luminance_array(py, &a)
    } else {
        Err(InvalidInputError::new_err(
            "a colour image must be a 3-D array (H, W, 3 or 4) of uint8, uint16 or float32",
        ))
    }
}

/// The spots of a 2-D image (uint8, uint16 or float32, row-major), less `dark` and over `flat`
/// (float32 frames of its shape) where given ([`starid_core::extract::apply_calibration`]):
/// dict of arrays, brightest first, with their instrumental magnitudes. A setting left None
/// takes the core's default ([`ExtractConfig::default`], listed by [`extract_defaults`]).
#[pyfunction]
#[pyo3(signature = (image, dark=None, flat=None, threshold_sigma=None, background_block=None, min_pixels=None,
                    max_spots=None, saturation=None, max_elongation=None, drop_flagged=None,
                    hot_pixel_ratio=None, deblend=None, filter_sigma_px=None))]
#[allow(clippy::too_many_arguments)]
pub fn extract_centroids<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    dark: Option<PyReadonlyArray2<'py, f32>>,
    flat: Option<PyReadonlyArray2<'py, f32>>,
    threshold_sigma: Option<f64>,
    background_block: Option<usize>,
    min_pixels: Option<usize>,
    max_spots: Option<usize>,
    saturation: Option<f64>,
    max_elongation: Option<f64>,
    drop_flagged: Option<bool>,
    hot_pixel_ratio: Option<f64>,
    deblend: Option<bool>,
    filter_sigma_px: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = ExtractConfig::default();
    let cfg = ExtractConfig {
        threshold_sigma: threshold_sigma.unwrap_or(d.threshold_sigma),
        background_block: background_block.unwrap_or(d.background_block),
        min_pixels: min_pixels.unwrap_or(d.min_pixels),
        max_spots: max_spots.unwrap_or(d.max_spots),
        saturation: saturation.or(d.saturation),
        max_elongation: max_elongation.unwrap_or(d.max_elongation),
        drop_flagged: drop_flagged.unwrap_or(d.drop_flagged),
        hot_pixel_ratio: hot_pixel_ratio.unwrap_or(d.hot_pixel_ratio),
        deblend: deblend.unwrap_or(d.deblend),
        filter_sigma_px: filter_sigma_px.unwrap_or(d.filter_sigma_px),
    };
    let dark = calibration_frame("dark", dark.as_ref(), image)?;
    let flat = calibration_frame("flat", flat.as_ref(), image)?;
    let (dark, flat) = (dark.as_deref(), flat.as_deref());
    let ex = if let Ok(a) = image.extract::<PyReadonlyArray2<'py, u16>>() {
        extract_array(py, &a, dark, flat, &cfg)?
    } else if let Ok(a) = image.extract::<PyReadonlyArray2<'py, u8>>() {
        extract_array(py, &a, dark, flat, &cfg)?
    } else if let Ok(a) = image.extract::<PyReadonlyArray2<'py, f32>>() {
        extract_array(py, &a, dark, flat, &cfg)?
    } else {
        return Err(InvalidInputError::new_err(
            "image must be a 2-D array of uint8, uint16 or float32",
        ));
    };
    let d = PyDict::new(py);
    let n = ex.spots.len();
    let xy: Vec<f64> = ex.spots.iter().flat_map(|s| [s.x, s.y]).collect();
    d.set_item(
        "xy",
        Array2::from_shape_vec((n, 2), xy)
            .expect("2 columns")
            .into_pyarray(py),
    )?;
    let spots = &ex.spots;
    d.set_item("flux", column(py, spots, |s| s.flux))?;
    d.set_item(
        "magnitudes",
        column(py, spots, starid_core::extract::Spot::magnitude),
    )?;
    d.set_item("peak", column(py, spots, |s| s.peak))?;
    d.set_item("pixels", column(py, spots, |s| i64::from(s.pixels)))?;
    d.set_item("elongation", column(py, spots, |s| s.elongation))?;
    d.set_item("flags", column(py, spots, |s| s.flags))?;
    d.set_item("background", ex.background)?;
    d.set_item("noise_sigma", ex.noise_sigma)?;
    d.set_item("dropped", ex.dropped)?;
    d.set_item("hot_pixels", ex.hot_pixels)?;
    Ok(d)
}

/// The rendering settings' defaults, the core's [`RenderConfig::default`]: name → value.
#[pyfunction]
pub fn render_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = RenderConfig::default();
    let out = PyDict::new(py);
    out.set_item("psf_sigma_px", d.psf_sigma_px)?;
    out.set_item("zero_point_e", d.zero_point_e)?;
    out.set_item("background_e", d.background_e)?;
    out.set_item("gradient_e", d.gradient_e)?;
    out.set_item("read_noise_e", d.read_noise_e)?;
    out.set_item("hot_pixels", d.hot_pixels)?;
    out.set_item("hot_pixel_e", d.hot_pixel_e)?;
    out.set_item("full_well_e", d.full_well_e)?;
    out.set_item("gain_e_per_dn", d.gain_e_per_dn)?;
    out.set_item("bits", d.bits)?;
    out.set_item("clip_background", d.clip_background)?;
    out.set_item("foreground", d.foreground)?;
    Ok(out)
}

/// Simulate a frame and render it to pixels: `(image (H, W) float32, frame dict)`. A rendering
/// setting left None takes the core's default ([`RenderConfig::default`]).
#[pyfunction]
#[pyo3(signature = (catalog, camera, seed, mag_limit=None, false_stars=0, psf_sigma_px=None,
                    zero_point_e=None, background_e=None, gradient_e=None, read_noise_e=None,
                    hot_pixels=None, hot_pixel_e=None, trail=None, full_well_e=None,
                    gain_e_per_dn=None, bits=None, clip_background=None, foreground=None))]
pub fn simulate_image<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    camera: &Bound<'py, PyCamera>,
    seed: u64,
    mag_limit: Option<f64>,
    false_stars: usize,
    psf_sigma_px: Option<f64>,
    zero_point_e: Option<f64>,
    background_e: Option<f64>,
    gradient_e: Option<f64>,
    read_noise_e: Option<f64>,
    hot_pixels: Option<usize>,
    hot_pixel_e: Option<f64>,
    trail: Option<([f64; 4], f64)>,
    full_well_e: Option<f64>,
    gain_e_per_dn: Option<f64>,
    bits: Option<u32>,
    clip_background: Option<bool>,
    foreground: Option<f64>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f32>>, Bound<'py, PyDict>)> {
    let cam = camera.get().inner;
    let d = RenderConfig::default();
    let rc = RenderConfig {
        psf_sigma_px: psf_sigma_px.unwrap_or(d.psf_sigma_px),
        zero_point_e: zero_point_e.unwrap_or(d.zero_point_e),
        background_e: background_e.unwrap_or(d.background_e),
        gradient_e: gradient_e.unwrap_or(d.gradient_e),
        read_noise_e: read_noise_e.unwrap_or(d.read_noise_e),
        hot_pixels: hot_pixels.unwrap_or(d.hot_pixels),
        hot_pixel_e: hot_pixel_e.unwrap_or(d.hot_pixel_e),
        trail,
        full_well_e: full_well_e.unwrap_or(d.full_well_e),
        gain_e_per_dn: gain_e_per_dn.unwrap_or(d.gain_e_per_dn),
        bits: bits.unwrap_or(d.bits),
        clip_background: clip_background.unwrap_or(d.clip_background),
        foreground: foreground.unwrap_or(d.foreground),
    };
    if rc.hot_pixels > 1_000_000 || false_stars > 100_000 {
        return Err(InvalidInputError::new_err(
            "hot_pixels at most 1000000 and false_stars at most 100000",
        ));
    }
    let cfg = sim::SimConfig {
        mag_limit,
        false_stars,
        false_star_mags: FalseStarMags::FromCatalog,
        ..Default::default()
    };
    let cat = catalog.get().inner.clone();
    let (frame, img) = run_core(py, move || {
        let frame = sim::simulate(&cat, &cam, &cfg, seed)?;
        let img = render(&frame, &cam, &rc, seed)?;
        Ok((frame, img))
    })?;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let d = outcome::frame(py, &catalog.get().inner, &frame)?;
    Ok((
        Array2::from_shape_vec((h, w), img)
            .expect("H x W")
            .into_pyarray(py),
        d,
    ))
}
