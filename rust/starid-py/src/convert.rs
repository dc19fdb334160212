//! numpy ↔ core conversions with shape and value checks that name the argument.

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::{Bound, PyResult};

use crate::errors::InvalidInputError;

/// An (N, 2) float64 array of pixel centroids as `[x, y]` rows.
pub fn centroids(name: &str, xy: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 2]>> {
    let shape = xy.shape();
    // An empty list is an empty frame, whatever its width.
    if shape[0] == 0 {
        return Ok(Vec::new());
    }
    if shape[1] != 2 {
        return Err(InvalidInputError::new_err(format!(
            "{name} must have shape (N, 2) holding (x, y) pixel centroids, got shape ({}, {})",
            shape[0], shape[1]
        )));
    }
    // A C-contiguous array (the common case) is read as one slice. (Only C order: numpy's
    // slice of a Fortran-ordered array holds every x before every y.)
    if xy.is_c_contiguous() {
        if let Ok(flat) = xy.as_slice() {
            return Ok(flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
        }
    }
    let a = xy.as_array();
    Ok(a.rows().into_iter().map(|r| [r[0], r[1]]).collect())
}

/// As [`centroids`], from the array itself: a C-contiguous one (the common case) is copied
/// whole by `to_vec`, which registers no borrow (the copy is made under the GIL, and the
/// borrow's bookkeeping cost more than the copy of a frame); any other through a read-only
/// borrow.
pub fn centroids_of(name: &str, xy: &Bound<'_, PyArray2<f64>>) -> PyResult<Vec<[f64; 2]>> {
    let shape = xy.shape();
    if shape[0] != 0 && shape[1] == 2 && xy.is_c_contiguous() {
        if let Ok(flat) = xy.to_vec() {
            return Ok(flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect());
        }
    }
    centroids(name, &xy.readonly())
}

/// As [`magnitudes`], from the array itself (copied as [`centroids_of`] copies).
pub fn magnitudes_of(m: &Bound<'_, PyArray1<f64>>, n: usize) -> PyResult<Vec<f64>> {
    match m.to_vec() {
        Ok(v) if v.len() == n => Ok(v),
        _ => magnitudes(&m.readonly(), n),
    }
}

/// As [`vector`], from the array itself (copied as [`centroids_of`] copies).
pub fn vector_of(
    name: &str,
    a: &Bound<'_, PyArray1<f64>>,
    len: Option<usize>,
) -> PyResult<Vec<f64>> {
    match a.to_vec() {
        Ok(v) if len.is_none_or(|n| v.len() == n) => Ok(v),
        _ => vector(name, &a.readonly(), len),
    }
}

/// A 1-D float64 array as a `Vec`, optionally checking its length.
pub fn vector(name: &str, a: &PyReadonlyArray1<'_, f64>, len: Option<usize>) -> PyResult<Vec<f64>> {
    let v: Vec<f64> = match a.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => a.as_array().iter().copied().collect(),
    };
    if let Some(n) = len {
        if v.len() != n {
            return Err(InvalidInputError::new_err(format!(
                "{name} has {} values, expected {n}",
                v.len()
            )));
        }
    }
    Ok(v)
}

/// A frame's magnitudes: one per centroid.
pub fn magnitudes(m: &PyReadonlyArray1<'_, f64>, n: usize) -> PyResult<Vec<f64>> {
    let v: Vec<f64> = match m.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => m.as_array().iter().copied().collect(),
    };
    if v.len() != n {
        return Err(InvalidInputError::new_err(format!(
            "magnitudes has {} values for {n} centroids",
            v.len()
        )));
    }
    Ok(v)
}

/// A frame as the core takes it: pixel centroids and, when given, one magnitude each.
pub type Frame = (Vec<[f64; 2]>, Option<Vec<f64>>);

/// The [`Frame`] of `xy` and `magnitudes`.
pub fn frame(
    xy: &PyReadonlyArray2<'_, f64>,
    magnitudes: Option<&PyReadonlyArray1<'_, f64>>,
) -> PyResult<Frame> {
    let centroids = centroids("xy", xy)?;
    let mags = magnitudes
        .map(|m| self::magnitudes(m, centroids.len()))
        .transpose()?;
    Ok((centroids, mags))
}
