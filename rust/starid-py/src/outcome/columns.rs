//! Results as other shapes: simulated frames as dicts, and many results as column arrays.

use super::*;

/// A simulated frame as a dict: `xy`, `magnitudes`, `true_ids`, `mirrored`, and the attitude.
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
    put_attitude(&d, &f.r_icrs_to_cam)?;
    Ok(d)
}

/// Column arrays of many results at once (for tables: `starid.dask`), without a Python loop
/// over frames: `status`, `method`, `message` (lists), `ok`, `mirrored` (bool arrays),
/// `ra_deg`, `dec_deg`, `roll_deg`, `fov_deg`, `focal_px`, `false_match_probability`,
/// `time_s` (float arrays), `quaternion` (N×4, NaN unless ok), `n_spots`, `n_matched` (int
/// arrays); with `spots`, also `spot_frame` (row of the result), `spot`, `catalog_id`,
/// `residual_arcsec` over every spot.
#[pyfunction]
#[pyo3(signature = (results, spots=false))]
pub fn result_columns<'py>(
    py: Python<'py>,
    results: Vec<PyRef<'py, PyIdentification>>,
    spots: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let n = results.len();
    let d = PyDict::new(py);
    let f = |g: &dyn Fn(&PyIdentification) -> f64| -> Vec<f64> {
        results.iter().map(|r| g(r)).collect()
    };
    d.set_item(
        "status",
        results.iter().map(|r| r.status).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "method",
        results.iter().map(|r| r.method).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "message",
        results
            .iter()
            .map(|r| r.message.clone())
            .collect::<Vec<_>>(),
    )?;
    d.set_item(
        "ok",
        results
            .iter()
            .map(|r| r.rotation.is_some())
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "mirrored",
        results
            .iter()
            .map(|r| r.mirrored)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    let radec: Vec<(f64, f64, f64)> = results.iter().map(|r| r.radec_roll_deg()).collect();
    d.set_item(
        "ra_deg",
        radec
            .iter()
            .map(|x| x.0)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "dec_deg",
        radec
            .iter()
            .map(|x| x.1)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "roll_deg",
        radec
            .iter()
            .map(|x| x.2)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item("fov_deg", f(&|r| r.fov_deg).into_pyarray(py))?;
    d.set_item("focal_px", f(&|r| r.focal_px).into_pyarray(py))?;
    d.set_item("k1", f(&|r| r.k1).into_pyarray(py))?;
    d.set_item(
        "learned_mag_offset",
        f(&|r| r.learned_mag_offset.unwrap_or(f64::NAN)).into_pyarray(py),
    )?;
    d.set_item(
        "false_match_probability",
        f(&|r| r.false_match_probability).into_pyarray(py),
    )?;
    d.set_item("time_s", f(&|r| r.time_s).into_pyarray(py))?;
    let q: Vec<f64> = results
        .iter()
        .flat_map(|r| r.rotation.as_ref().map_or([f64::NAN; 4], quaternion_wxyz))
        .collect();
    d.set_item(
        "quaternion",
        Array2::from_shape_vec((n, 4), q)
            .expect("4 columns")
            .into_pyarray(py),
    )?;
    d.set_item(
        "n_spots",
        results
            .iter()
            .map(|r| r.ids.len() as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    d.set_item(
        "n_matched",
        results
            .iter()
            .map(|r| r.n_matched as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py),
    )?;
    if spots {
        let total: usize = results.iter().map(|r| r.ids.len()).sum();
        let (mut frame, mut spot, mut ids, mut res) = (
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
            Vec::with_capacity(total),
        );
        for (k, r) in results.iter().enumerate() {
            for (s, (&id, &e)) in r.ids.iter().zip(&r.residuals_arcsec).enumerate() {
                frame.push(k as i64);
                spot.push(s as i64);
                ids.push(id);
                res.push(e);
            }
        }
        d.set_item("spot_frame", frame.into_pyarray(py))?;
        d.set_item("spot", spot.into_pyarray(py))?;
        d.set_item("catalog_id", ids.into_pyarray(py))?;
        d.set_item("residual_arcsec", res.into_pyarray(py))?;
    }
    Ok(d)
}
