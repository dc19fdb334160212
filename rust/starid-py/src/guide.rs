//! Guide-star selection and metrics (`starid.guide`).

use numpy::IntoPyArray;
use pyo3::prelude::*;

use crate::errors::InvalidInputError;
use pyo3::types::PyDict;
use starid_core::guide::{self, DoubleRule, Field, QtmRule};

use crate::catalog::PyCatalog;
use crate::run_core;

fn positive_deg(name: &str, value: Option<f64>) -> PyResult<f64> {
    match value {
        Some(v) => Ok(v.to_radians()),
        None => Err(InvalidInputError::new_err(format!(
            "this method needs {name}"
        ))),
    }
}

/// Select guide stars: `method` is "magnitude" (mag_limit), "doubles" (separation_deg,
/// merge), "rectangle" (cell_deg), "qtm" or "qtm-weighted" (level).
#[pyfunction]
#[pyo3(signature = (catalog, method, *, mag_limit=None, separation_deg=None, merge=false,
                    cell_deg=None, level=None))]
pub fn guide_select(
    py: Python<'_>,
    catalog: &PyCatalog,
    method: &str,
    mag_limit: Option<f64>,
    separation_deg: Option<f64>,
    merge: bool,
    cell_deg: Option<f64>,
    level: Option<u32>,
) -> PyResult<PyCatalog> {
    let cat = catalog.inner.clone();
    let selected = match method {
        "magnitude" => {
            let limit = mag_limit
                .ok_or_else(|| InvalidInputError::new_err("method 'magnitude' needs mag_limit"))?;
            run_core(py, move || guide::select_magnitude(&cat, limit))?
        }
        "doubles" => {
            let sep = positive_deg("separation_deg", separation_deg)?;
            let rule = if merge {
                DoubleRule::Merge
            } else {
                DoubleRule::KeepBrighter
            };
            run_core(py, move || guide::thin_doubles(&cat, sep, rule))?
        }
        "rectangle" => {
            let cell = positive_deg("cell_deg", cell_deg)?;
            run_core(py, move || guide::select_rectangle(&cat, cell))?
        }
        "qtm" | "qtm-weighted" => {
            let level = level.ok_or_else(|| {
                InvalidInputError::new_err(format!("method '{method}' needs level"))
            })?;
            let rule = if method == "qtm" {
                QtmRule::Brightest
            } else {
                QtmRule::Weighted
            };
            run_core(py, move || guide::select_qtm(&cat, level, rule))?
        }
        other => {
            return Err(InvalidInputError::new_err(format!(
                "unknown selection method {other:?}; use 'magnitude', 'doubles', 'rectangle', \
                 'qtm' or 'qtm-weighted'"
            )))
        }
    };
    Ok(PyCatalog::wrap(selected))
}

fn parse_field(field: &str, fov_deg: f64) -> PyResult<Field> {
    let fov_rad = fov_deg.to_radians();
    match field {
        "circle" => Ok(Field::Circle { fov_rad }),
        "square" => Ok(Field::Square { fov_rad }),
        other => Err(InvalidInputError::new_err(format!(
            "field must be 'circle' or 'square', got {other:?}"
        ))),
    }
}

/// Monte Carlo histogram of stars per field: entry k counts fields with exactly k stars.
#[pyfunction]
pub fn guide_field_counts<'py>(
    py: Python<'py>,
    catalog: &PyCatalog,
    fov_deg: f64,
    trials: usize,
    seed: u64,
    field: &str,
) -> PyResult<Bound<'py, numpy::PyArray1<u64>>> {
    let field = parse_field(field, fov_deg)?;
    let cat = catalog.inner.clone();
    let hist = run_core(py, move || {
        guide::field_star_counts(&cat, field, trials, seed)
    })?;
    Ok(hist.into_pyarray(py))
}

/// Metrics of a guide catalogue for circular or square fields of `fov_deg`.
#[pyfunction]
#[pyo3(signature = (catalog, fov_deg, trials, seed, field, k_max=10))]
pub fn guide_metrics<'py>(
    py: Python<'py>,
    catalog: &PyCatalog,
    fov_deg: f64,
    trials: usize,
    seed: u64,
    field: &str,
    k_max: usize,
) -> PyResult<Bound<'py, PyDict>> {
    if k_max > 10_000 {
        return Err(InvalidInputError::new_err(format!(
            "k_max must be at most 10000, got {k_max}"
        )));
    }
    let field = parse_field(field, fov_deg)?;
    let cat = catalog.inner.clone();
    let m = run_core(py, move || guide::metrics(&cat, field, trials, seed))?;
    let d = PyDict::new(py);
    d.set_item("count", m.count)?;
    d.set_item("nn_min_deg", m.nn_min_rad.to_degrees())?;
    d.set_item("nn_mean_deg", m.nn_mean_rad.to_degrees())?;
    d.set_item("nn_std_deg", m.nn_std_rad.to_degrees())?;
    d.set_item("p_at_least_3", m.p_at_least(3))?;
    let p_at_least = PyDict::new(py);
    for k in 1..=k_max {
        p_at_least.set_item(k, m.p_at_least(k))?;
    }
    d.set_item("p_at_least", p_at_least)?;
    d.set_item("mean_stars_per_field", m.mean_stars_per_field())?;
    d.set_item("trials", m.trials())?;
    d.set_item(
        "stars_per_field",
        m.stars_per_field.clone().into_pyarray(py),
    )?;
    d.set_item("pairs", m.pairs)?;
    d.set_item("index_bytes", m.index_bytes)?;
    Ok(d)
}

/// Nearest-neighbour angle of every star, degrees.
#[pyfunction]
pub fn guide_nearest_neighbours<'py>(
    py: Python<'py>,
    catalog: &PyCatalog,
) -> PyResult<Bound<'py, numpy::PyArray1<f64>>> {
    let cat = catalog.inner.clone();
    let nn = run_core(py, move || guide::nearest_neighbour_angles(&cat))?;
    Ok(nn
        .into_iter()
        .map(f64::to_degrees)
        .collect::<Vec<_>>()
        .into_pyarray(py))
}

/// The smallest field holding at least `k` stars in a fraction `p` of random pointings, degrees.
#[pyfunction]
#[pyo3(signature = (catalog, p, k, field, trials, seed, lo_deg, hi_deg, tol_deg))]
pub fn guide_fov_for_coverage(
    py: Python<'_>,
    catalog: &PyCatalog,
    p: f64,
    k: usize,
    field: &str,
    trials: usize,
    seed: u64,
    lo_deg: f64,
    hi_deg: f64,
    tol_deg: f64,
) -> PyResult<f64> {
    let shape = parse_field(field, 1.0)?;
    let cat = catalog.inner.clone();
    let fov = run_core(py, move || {
        guide::fov_for_coverage(
            &cat,
            shape,
            p,
            k,
            trials,
            seed,
            lo_deg.to_radians(),
            hi_deg.to_radians(),
            tol_deg.to_radians(),
        )
    })?;
    Ok(fov.to_degrees())
}

/// Number of triangles of QTM level `level`: `8 * 4**(level - 1)`.
#[pyfunction]
pub fn guide_qtm_triangle_count(level: u32) -> PyResult<u64> {
    if !(1..=30).contains(&level) {
        return Err(InvalidInputError::new_err(format!(
            "the QTM level must be in 1..=30, got {level}"
        )));
    }
    Ok(guide::qtm_triangle_count(level))
}
