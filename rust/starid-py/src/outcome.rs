//! Core results → Python dicts of plain values and numpy arrays (moved, not copied).

use nalgebra::{Rotation3, UnitQuaternion};
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use starid_core::{geometry, Camera, Catalog, Identification, SimFrame};

const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;

/// `rotation_matrix` (3×3) and `quaternion` (`[w, x, y, z]`, w ≥ 0) of a rotation.
pub fn put_rotation(d: &Bound<'_, PyDict>, r: &Rotation3<f64>) -> PyResult<()> {
    let py = d.py();
    let m = r.matrix();
    let flat: Vec<f64> = (0..3)
        .flat_map(|i| (0..3).map(move |j| m[(i, j)]))
        .collect();
    d.set_item(
        "rotation_matrix",
        Array2::from_shape_vec((3, 3), flat)
            .expect("3x3")
            .into_pyarray(py),
    )?;
    let q = UnitQuaternion::from_rotation_matrix(r);
    let s = if q.w < 0.0 { -1.0 } else { 1.0 };
    d.set_item(
        "quaternion",
        vec![s * q.w, s * q.i, s * q.j, s * q.k].into_pyarray(py),
    )
}

fn put_attitude(d: &Bound<'_, PyDict>, r: Option<&Rotation3<f64>>) -> PyResult<()> {
    let py = d.py();
    match r {
        Some(r) => {
            let (ra, dec, roll) = geometry::radec_roll_from_attitude(r);
            d.set_item("ra_deg", ra.to_degrees())?;
            d.set_item("dec_deg", dec.to_degrees())?;
            d.set_item("roll_deg", roll.to_degrees())?;
            put_rotation(d, r)?;
        }
        None => {
            d.set_item("ra_deg", f64::NAN)?;
            d.set_item("dec_deg", f64::NAN)?;
            d.set_item("roll_deg", f64::NAN)?;
            d.set_item("rotation_matrix", py.None())?;
            d.set_item("quaternion", py.None())?;
        }
    }
    Ok(())
}

fn ids_of(catalog: &Catalog, index: &[Option<u32>]) -> Vec<i64> {
    index
        .iter()
        .map(|c| c.map_or(-1, |c| catalog.ids()[c as usize]))
        .collect()
}

pub fn identification<'py>(
    py: Python<'py>,
    catalog: &Catalog,
    id: &Identification,
    camera: &Camera,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("ok", id.is_identified())?;
    d.set_item("status", id.status.as_str())?;
    d.set_item("ids", ids_of(catalog, &id.catalog_index).into_pyarray(py))?;
    d.set_item("mirrored", id.mirrored)?;
    put_attitude(&d, id.r_icrs_to_cam.as_ref())?;
    d.set_item(
        "residuals_arcsec",
        id.residuals_rad
            .iter()
            .map(|r| r * ARCSEC_PER_RAD)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item("false_match_probability", id.false_match_probability)?;
    d.set_item("n_matched", id.matched)?;
    d.set_item("centroid_sigma_px", id.centroid_sigma_px)?;
    d.set_item("match_radius_arcsec", id.match_radius_rad * ARCSEC_PER_RAD)?;
    d.set_item("hypotheses", id.hypotheses)?;
    d.set_item("time_s", id.elapsed.as_secs_f64())?;
    d.set_item("focal_px", camera.focal_length_px)?;
    d.set_item("fov_deg", camera.fov_rad().to_degrees())?;
    d.set_item("focal_sigma_px", f64::NAN)?;
    Ok(d)
}

pub fn frame<'py>(
    py: Python<'py>,
    catalog: &Catalog,
    f: &SimFrame,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let flat: Vec<f64> = f.centroids.iter().flat_map(|c| [c[0], c[1]]).collect();
    d.set_item(
        "xy",
        Array2::from_shape_vec((f.centroids.len(), 2), flat)
            .expect("2 columns")
            .into_pyarray(py),
    )?;
    d.set_item("magnitudes", f.magnitudes.clone().into_pyarray(py))?;
    d.set_item(
        "true_ids",
        ids_of(catalog, &f.catalog_index).into_pyarray(py),
    )?;
    d.set_item("mirrored", f.mirrored)?;
    put_attitude(&d, Some(&f.r_icrs_to_cam))?;
    Ok(d)
}
