//! `Catalog`: the native catalogue, with a cache of the pair indexes built for it.

use std::path::PathBuf;
use std::sync::{Arc, RwLock};

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use starid_core::identify::SolverCache;
use starid_core::{Catalog, Solver};

use crate::convert;
use crate::errors::PyStaridError;
use crate::run_core;

/// The directory pair indexes are kept in across processes; `None` keeps none.
static INDEX_CACHE_DIR: RwLock<Option<PathBuf>> = RwLock::new(None);

/// Keep pair indexes in `path` from now on (`None`: keep none; indexes already in memory stay).
#[pyfunction]
#[pyo3(signature = (path))]
pub fn set_index_cache_dir(path: Option<PathBuf>) {
    *INDEX_CACHE_DIR
        .write()
        .unwrap_or_else(std::sync::PoisonError::into_inner) = path;
}

/// The directory pair indexes are kept in, or None.
#[pyfunction]
pub fn index_cache_dir() -> Option<PathBuf> {
    INDEX_CACHE_DIR
        .read()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .clone()
}

/// A star catalogue: ids, ICRS directions and magnitudes.
#[pyclass(frozen, name = "Catalog", module = "starid._starid")]
pub struct PyCatalog {
    pub inner: Arc<Catalog>,
    /// Pair indexes built for it (the core's cache: each built once).
    solvers: Arc<SolverCache>,
    /// What the Python `Catalog` calls it (results name the catalogue they used).
    name: std::sync::Mutex<Option<String>>,
}

impl PyCatalog {
    pub fn wrap(inner: Catalog) -> Self {
        let inner = Arc::new(inner);
        Self {
            solvers: Arc::new(SolverCache::new(inner.clone())),
            inner,
            name: std::sync::Mutex::new(None),
        }
    }

    /// Its name, if the Python layer gave it one.
    pub fn name(&self) -> Option<String> {
        self.name
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .clone()
    }

    /// A solver whose pair index covers `max_angle_rad`, built once (with the GIL released),
    /// or read from the index cache directory, where a new one is kept. Ctrl-C during a build
    /// raises KeyboardInterrupt at once; the build goes on in the background and is kept for
    /// the next call.
    pub fn solver(&self, py: Python<'_>, max_angle_rad: f64) -> PyResult<Arc<Solver>> {
        // A built one without releasing the GIL (a look-up); building takes long.
        match self.solvers.cached(max_angle_rad) {
            Some(s) => Ok(s),
            None => {
                let cache = self.solvers.clone();
                let dir = index_cache_dir();
                crate::batch::detached(py, move || {
                    cache.solver_stored(max_angle_rad, dir.as_deref())
                })?
                .map_err(|e| PyStaridError(e).into())
            }
        }
    }
}

#[pymethods]
impl PyCatalog {
    #[new]
    fn new(
        ids: PyReadonlyArray1<'_, i64>,
        ra_deg: PyReadonlyArray1<'_, f64>,
        dec_deg: PyReadonlyArray1<'_, f64>,
        mag: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Self> {
        let ids: Vec<i64> = ids.as_array().iter().copied().collect();
        let ra = convert::vector("ra_deg", &ra_deg, None)?;
        let dec = convert::vector("dec_deg", &dec_deg, None)?;
        let mag = convert::vector("mag", &mag, None)?;
        Ok(Self::wrap(
            Catalog::new(ids, &ra, &dec, mag).map_err(PyStaridError)?,
        ))
    }

    /// Catalogue from ICRS unit vectors (N, 3): the exact inverse of `unit_vectors`, for pickling.
    #[staticmethod]
    fn from_unit_vectors(
        ids: PyReadonlyArray1<'_, i64>,
        vectors: numpy::PyReadonlyArray2<'_, f64>,
        mag: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Self> {
        let ids: Vec<i64> = ids.as_array().iter().copied().collect();
        let v = vectors.as_array();
        if v.ncols() != 3 {
            return Err(crate::errors::InvalidInputError::new_err(format!(
                "vectors must have shape (N, 3), got {:?}",
                v.shape()
            )));
        }
        let vectors = v
            .rows()
            .into_iter()
            .map(|r| nalgebra::Vector3::new(r[0], r[1], r[2]))
            .collect();
        let mag: Vec<f64> = mag.as_array().iter().copied().collect();
        Ok(Self::wrap(
            Catalog::from_unit_vectors(ids, vectors, mag).map_err(PyStaridError)?,
        ))
    }

    /// The bundled catalogue (compiled into the core).
    #[staticmethod]
    fn bundled(py: Python<'_>) -> Self {
        Self::wrap(py.detach(Catalog::bundled))
    }

    /// The Hipparcos stars to `mag_limit` (at most 11) from the deep table compiled into the core.
    #[staticmethod]
    fn bundled_deep(py: Python<'_>, mag_limit: f64) -> PyResult<Self> {
        Ok(Self::wrap(run_core(py, move || {
            Catalog::bundled_deep(mag_limit)
        })?))
    }

    /// How many stars the bundled catalogue holds, without building it.
    #[staticmethod]
    fn bundled_len() -> usize {
        Catalog::bundled_len()
    }

    /// How many stars the deep table holds to `mag_limit`.
    #[staticmethod]
    fn bundled_deep_len(mag_limit: f64) -> PyResult<usize> {
        Catalog::bundled_deep_len(mag_limit).map_err(|e| PyStaridError(e).into())
    }

    /// Read a star table (CSV, TSV or whitespace; with or without a header).
    #[staticmethod]
    fn from_table_path(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Ok(Self::wrap(run_core(py, move || Catalog::from_path(&path))?))
    }

    /// Read the Hipparcos 2 main catalogue, magnitude-limited and moved to an epoch.
    #[staticmethod]
    fn from_hip2_path(py: Python<'_>, path: PathBuf, mag_limit: f64, epoch: f64) -> PyResult<Self> {
        Ok(Self::wrap(run_core(py, move || {
            let file = std::fs::File::open(&path).map_err(|e| {
                starid_core::Error::from(std::io::Error::new(
                    e.kind(),
                    format!("{}: {e}", path.display()),
                ))
            })?;
            Catalog::from_hip2(std::io::BufReader::new(file), mag_limit, epoch)
        })?))
    }

    fn filter_mag(&self, mag_limit: f64) -> PyResult<Self> {
        Ok(Self::wrap(
            self.inner.filter_mag(mag_limit).map_err(PyStaridError)?,
        ))
    }

    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.inner.ids().to_vec().into_pyarray(py)
    }

    #[getter]
    fn ra_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner
            .ra_rad()
            .iter()
            .map(|r| r.to_degrees())
            .collect::<Vec<_>>()
            .into_pyarray(py)
    }

    #[getter]
    fn dec_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner
            .dec_rad()
            .iter()
            .map(|r| r.to_degrees())
            .collect::<Vec<_>>()
            .into_pyarray(py)
    }

    #[getter]
    fn mag<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.mag().to_vec().into_pyarray(py)
    }

    #[getter]
    fn unit_vectors<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let flat: Vec<f64> = self
            .inner
            .vectors()
            .iter()
            .flat_map(|v| [v.x, v.y, v.z])
            .collect();
        Array2::from_shape_vec((self.inner.len(), 3), flat)
            .expect("3 columns")
            .into_pyarray(py)
    }

    /// Build (or fetch from the cache) the pair index for frames whose stars are at most
    /// `max_angle_deg` apart; returns its size and build time.
    #[pyo3(signature = (max_angle_deg, magnitude_index=false))]
    fn index_info<'py>(
        &self,
        py: Python<'py>,
        max_angle_deg: f64,
        magnitude_index: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let s = self.solver(py, max_angle_deg.to_radians())?;
        let mag_build_s = if magnitude_index {
            let solver = s.clone();
            py.detach(move || {
                let t = std::time::Instant::now();
                solver.mag_pair_index();
                t.elapsed().as_secs_f64()
            })
        } else {
            f64::NAN
        };
        let d = PyDict::new(py);
        d.set_item("pairs", s.pair_index().len())?;
        d.set_item("max_angle_deg", s.pair_index().max_angle_rad().to_degrees())?;
        d.set_item(
            "bright_pairs",
            s.bright_pair_index().map_or(0, starid_core::PairIndex::len),
        )?;
        d.set_item("memory_bytes", s.memory_bytes())?;
        d.set_item("pair_index_bytes", s.pair_index().memory_bytes())?;
        d.set_item(
            "bright_index_bytes",
            s.bright_pair_index()
                .map_or(0, starid_core::PairIndex::memory_bytes),
        )?;
        d.set_item("magnitude_index_bytes", s.magnitude_index_bytes())?;
        d.set_item("seed_tables_bytes", s.seed_tables_bytes())?;
        d.set_item("magnitude_index_build_time_s", mag_build_s)?;
        d.set_item("build_time_s", s.build_time().as_secs_f64())?;
        d.set_item("index_file", s.index_file())?;
        Ok(d)
    }

    /// The database identification method `method` searches for frames whose stars are at most
    /// `max_angle_deg` apart: its memory and build time.
    fn method_index<'py>(
        &self,
        py: Python<'py>,
        method: &str,
        max_angle_deg: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        let m = starid_core::Method::from_name(method).map_err(PyStaridError)?;
        let s = self.solver(py, max_angle_deg.to_radians())?;
        let solver = s.clone();
        let (bytes, time) = py.detach(move || solver.method_database(m));
        let d = PyDict::new(py);
        d.set_item("method", m.name())?;
        d.set_item("bytes", bytes)?;
        d.set_item("build_time_s", time.as_secs_f64())?;
        Ok(d)
    }

    /// Name it (the Python `Catalog` does, so that results can say which catalogue they used).
    fn _set_name(&self, name: Option<String>) {
        *self
            .name
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = name;
    }

    /// The row of each id (the join of identified ids with the catalogue).
    fn rows_of<'py>(
        &self,
        py: Python<'py>,
        ids: PyReadonlyArray1<'_, i64>,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let ids: Vec<i64> = ids.as_array().iter().copied().collect();
        let rows = self.inner.rows_of(&ids).map_err(PyStaridError)?;
        Ok(rows
            .into_iter()
            .map(|r| r as i64)
            .collect::<Vec<_>>()
            .into_pyarray(py))
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }
}
