//! Core results → Python: the native `Identification` class, and dicts of plain values and numpy
//! arrays (moved, not copied) for simulated frames and pointing fits.

use std::sync::{Arc, OnceLock};

use nalgebra::Rotation3;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;
use starid_core::{geometry, Camera, Catalog, Identification, SimFrame};

/// Arcseconds in a radian.
pub(crate) const ARCSEC_PER_RAD: f64 = 180.0 / std::f64::consts::PI * 3600.0;

use starid_core::geometry::{quaternion_wxyz, unit_to_radec};

mod columns;
mod state;
pub use columns::{frame, result_columns};
use state::State;

/// A rotation's 3×3 matrix as an ndarray.
pub(crate) fn matrix3(r: &Rotation3<f64>) -> Array2<f64> {
    let m = r.matrix();
    Array2::from_shape_fn((3, 3), |(i, j)| m[(i, j)])
}

/// A bool as Python writes it (for `__repr__`).
pub(crate) fn py_bool(b: bool) -> &'static str {
    if b {
        "True"
    } else {
        "False"
    }
}

/// `rotation_matrix` (3×3) and `quaternion` (`[w, x, y, z]`, w ≥ 0) of a rotation.
pub fn put_rotation(d: &Bound<'_, PyDict>, r: &Rotation3<f64>) -> PyResult<()> {
    let py = d.py();
    d.set_item("rotation_matrix", matrix3(r).into_pyarray(py))?;
    d.set_item("quaternion", quaternion_wxyz(r).to_vec().into_pyarray(py))
}

fn put_attitude(d: &Bound<'_, PyDict>, r: &Rotation3<f64>) -> PyResult<()> {
    let (ra, dec, roll) = geometry::radec_roll_from_attitude(r);
    d.set_item("ra_deg", ra.to_degrees())?;
    d.set_item("dec_deg", dec.to_degrees())?;
    d.set_item("roll_deg", roll.to_degrees())?;
    put_rotation(d, r)
}

fn ids_of(catalog: &Catalog, index: &[Option<u32>]) -> Vec<i64> {
    index
        .iter()
        .map(|c| c.map_or(-1, |c| catalog.ids()[c as usize]))
        .collect()
}

/// The result of identifying one frame (immutable).
///
/// Attributes
/// ----------
/// ids : ndarray of int64
///     Catalogue id of each input centroid, in input order; -1 where unidentified.
/// ok : bool
///     Whether a verified solution was found. When False every id is -1.
/// status : str
///     ``"identified"``, ``"no_match"``, ``"search_limit"`` (a search budget ran out),
///     ``"timeout"``, ``"too_few_stars"`` (fewer than 4 centroids: nothing to search), and in
///     ``identify_many`` ``"invalid_input"`` (a malformed frame; see ``message``) or
///     ``"cancelled"``.
/// message : str or None
///     Why a frame of ``identify_many`` is ``"invalid_input"``; None otherwise.
/// method : str
///     The method whose hypothesis verified (``"pyramid"``, ``"voting"``, ``"auto"`` for the
///     magnitude-gated search of the default method); the configured one when not ``ok``.
/// ra_deg, dec_deg, roll_deg : float
///     Boresight and roll (NaN unless ``ok``). At roll 0 image-up (-y) points to celestial
///     north and east is left; increasing roll turns the camera's +x axis toward +y.
/// boresight_radec_deg : (float, float)
///     ``(ra_deg, dec_deg)``.
/// quaternion : ndarray (4,) or None
///     Rotation ICRS -> camera as ``[w, x, y, z]`` (scalar first, w >= 0).
/// rotation_matrix : ndarray (3, 3) or None
///     ``v_cam = R @ v_icrs``; its rows are the camera axes in ICRS.
/// residuals_arcsec : ndarray of float
///     Angle between each centroid's direction and its catalogue star; NaN where unidentified.
/// mirrored : bool
///     The frame is mirrored (an odd number of reflections). The attitude is then that of the
///     image with its x axis reversed (``x -> W - x``).
/// false_match_probability : float
///     Bound on the probability that this solution is a false match (1 when not ``ok``, and
///     for a raw answer).
/// catalog : str or None
///     The name of the catalogue the ids come from (with ``catalog=None``, the one chosen for
///     the field of view: the bundled Hipparcos to Hp 6.5, or to Hp 8 for narrow fields).
/// verified : bool
///     The answer passed the shared verification. False when not ``ok``, and for a method's
///     raw answer with ``verify=False`` (benchmarks and research only): such ids may be wrong.
/// n_matched : int
///     Number of identified centroids.
/// centroid_sigma_px : float
///     Centroid noise estimated from the residuals (1 sigma per axis, pixels).
/// match_radius_arcsec : float
///     Radius within which centroids were matched to stars.
/// hypotheses : int
///     Catalogue-triangle hypotheses tested.
/// time_s : float
///     Time spent identifying (inside the Rust core; excludes Python overhead).
/// fov_deg, focal_px : float
///     The camera's field of view across the width and its focal length in pixels: the given
///     ones, or the estimates when the field of view was unknown (NaN when not ``ok``) or the
///     given one proved off (the focal check, ``IdentifyConfig.focal_check``).
/// focal_sigma_px : float
///     1 sigma of the estimated focal length (NaN when the given one was used).
/// k1 : float
///     The radial distortion of the camera the solution was found with: the given camera's, or
///     the one the focal check found when the given one proved off (0 without a camera).
/// noise_step_px : float
///     The centroid noise (1 sigma per axis, pixels) the solution was verified at: tried as a
///     hypothesis the residuals can refuse (NaN when not ``ok``).
/// noise_source : str
///     Where ``noise_step_px`` came from: ``"ladder"`` (no noise stated; the default steps),
///     ``"stated"`` (``centroid_sigma_px``, borne out by the residuals), ``"widened"`` (the
///     stated noise refused as too small; a looser step), ``"narrowed"`` (a tighter step of the
///     default ladder, tried before a stated noise that was larger), ``"learned"`` (the noise
///     ``identify_many`` learned from its frames), ``"none"`` when not ``ok``.
/// learned_sigma_px : float or None
///     In ``identify_many``, the centroid noise the batch learned and searched this frame again
///     with (``IdentifyConfig.learn_noise``); None for a frame identified as given.
/// learned_mag_offset : float or None
///     In ``identify_many``, the magnitude zero point the batch learned from its other frames
///     and identified this frame with, magnitude-gated, after a search without it found nothing
///     (``IdentifyConfig.learn_zero_point``); None for a frame identified as given.
///
/// Plain values are computed once; the arrays are made on first access and kept, so a call
/// builds no dict and runs no Python constructor.
#[pyclass(frozen, name = "Identification", module = "starid")]
pub struct PyIdentification {
    status: &'static str,
    method: &'static str,
    message: Option<String>,
    hinted: bool,
    verified: bool,
    catalog: Option<String>,
    ids: Vec<i64>,
    residuals_arcsec: Vec<f64>,
    rotation: Option<Rotation3<f64>>,
    mirrored: bool,
    false_match_probability: f64,
    n_matched: usize,
    centroid_sigma_px: f64,
    match_radius_arcsec: f64,
    hypotheses: usize,
    time_s: f64,
    fov_deg: f64,
    focal_px: f64,
    focal_sigma_px: f64,
    learned_mag_offset: Option<f64>,
    noise_step_px: f64,
    noise_source: &'static str,
    learned_sigma_px: Option<f64>,
    k1: f64,
    /// The camera's distortion beyond `k1`: `[k2, k3, p1, p2]`.
    higher: [f64; 4],
    ids_array: PyOnceLock<Py<PyArray1<i64>>>,
    residuals_array: PyOnceLock<Py<PyArray1<f64>>>,
    /// `(ra, dec, roll)` in degrees, computed on the first read of any of them.
    radec_roll: OnceLock<(f64, f64, f64)>,
    /// The spots and their stars: the per-spot table.
    spots: Spots,
    /// The sensor's width and height and the principal point, pixels (NaN when unknown).
    sensor: [f64; 4],
    /// Seconds spent reading the image and extracting its spots: set once, by the call that
    /// read the image (unset, NaN, for centroids given).
    read_extract_s: OnceLock<[f64; 2]>,
}

/// The spots a result was identified from, and the catalogue its ids name: what the per-spot
/// table (`Identification.table()`) reads.
#[derive(Default)]
struct Spots {
    xy: Vec<[f64; 2]>,
    magnitudes: Option<Vec<f64>>,
    catalog: Option<Arc<Catalog>>,
    index: Vec<Option<u32>>,
    /// `[ra_deg, dec_deg, mag]` of each spot's star, NaN where unnamed: made on first use (or
    /// restored by unpickling, without the catalogue).
    stars: OnceLock<Vec<[f64; 3]>>,
}

impl Spots {
    fn stars(&self, n: usize) -> &[[f64; 3]] {
        self.stars.get_or_init(|| {
            let nan = [f64::NAN; 3];
            let Some(cat) = &self.catalog else {
                return vec![nan; n];
            };
            self.index
                .iter()
                .map(|c| {
                    c.map_or(nan, |c| {
                        let c = c as usize;
                        let (ra, dec) = unit_to_radec(&cat.vectors()[c]);
                        let ra = ra.to_degrees().rem_euclid(360.0);
                        [ra, dec.to_degrees(), cat.mag()[c]]
                    })
                })
                .collect()
        })
    }
}

impl PyIdentification {
    /// Prefix a batch frame's message with its place, `frame i: ` (a message the core wrote
    /// about the frame does not know which frame it was).
    pub(crate) fn name_frame(&mut self, i: usize) {
        if let Some(m) = &self.message {
            if !m.starts_with("frame ") {
                self.message = Some(format!("frame {i}: {m}"));
            }
        }
    }

    /// From a core result; `camera` is the one used (or estimated), `focal_sigma_px` the 1σ of
    /// an estimated focal length (NaN when it was given).
    pub fn new(
        catalog: &crate::catalog::PyCatalog,
        id: Identification,
        camera: &Camera,
        focal_sigma_px: f64,
    ) -> Self {
        // The result's own vectors become the Python object's: no copies.
        let mut residuals_arcsec = id.residuals_rad;
        for r in &mut residuals_arcsec {
            *r *= ARCSEC_PER_RAD;
        }
        // The focal check's focal length, where it replaced the camera's.
        let (camera, focal_sigma_px) = match id.focal_length_px {
            Some(f) => (
                &Camera {
                    focal_length_px: f,
                    k1: id.k1.unwrap_or(camera.k1),
                    ..*camera
                },
                id.focal_sigma_px,
            ),
            None => (camera, focal_sigma_px),
        };
        Self {
            status: id.status.as_str(),
            method: id.method.name(),
            message: id.message,
            hinted: id.hinted,
            verified: id.verified,
            catalog: catalog.name(),
            ids: ids_of(&catalog.inner, &id.catalog_index),
            residuals_arcsec,
            rotation: id.r_icrs_to_cam,
            mirrored: id.mirrored,
            false_match_probability: id.false_match_probability,
            n_matched: id.matched,
            centroid_sigma_px: id.centroid_sigma_px,
            match_radius_arcsec: id.match_radius_rad * ARCSEC_PER_RAD,
            hypotheses: id.hypotheses,
            time_s: id.elapsed.as_secs_f64(),
            fov_deg: camera.fov_rad().to_degrees(),
            focal_px: camera.focal_length_px,
            focal_sigma_px,
            learned_mag_offset: id.learned_mag_offset,
            noise_step_px: id.noise_step_px,
            noise_source: id.noise_source.as_str(),
            learned_sigma_px: id.learned_sigma_px,
            k1: camera.k1,
            higher: camera.higher_distortion(),
            ids_array: PyOnceLock::new(),
            residuals_array: PyOnceLock::new(),
            radec_roll: OnceLock::new(),
            spots: Spots {
                catalog: Some(catalog.inner.clone()),
                index: id.catalog_index,
                ..Spots::default()
            },
            sensor: [
                camera.width_px,
                camera.height_px,
                camera.principal_point_px[0],
                camera.principal_point_px[1],
            ],
            read_extract_s: OnceLock::new(),
        }
    }

    /// The same result, keeping the spots it was identified from (their pixel positions and
    /// magnitudes, for the per-spot table).
    pub fn with_spots(mut self, xy: Vec<[f64; 2]>, magnitudes: Option<Vec<f64>>) -> Self {
        self.spots.xy = xy;
        self.spots.magnitudes = magnitudes;
        self
    }

    fn times(&self) -> [f64; 2] {
        self.read_extract_s.get().copied().unwrap_or([f64::NAN; 2])
    }

    fn radec_roll_deg(&self) -> (f64, f64, f64) {
        *self.radec_roll.get_or_init(|| {
            self.rotation
                .as_ref()
                .map_or((f64::NAN, f64::NAN, f64::NAN), |r| {
                    let (ra, dec, roll) = geometry::radec_roll_from_attitude(r);
                    (ra.to_degrees(), dec.to_degrees(), roll.to_degrees())
                })
        })
    }
}

/// Three float columns, one value a spot.
type Columns3<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// NaN as None: JSON has no NaN.
fn json_float(py: Python<'_>, v: f64) -> PyResult<Py<PyAny>> {
    Ok(if v.is_nan() {
        py.None()
    } else {
        v.into_pyobject(py)?.into_any().unbind()
    })
}

#[pymethods]
impl PyIdentification {
    /// Catalogue id of each input centroid, in input order; -1 where unidentified.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.ids_array
            .get_or_init(py, || self.ids.clone().into_pyarray(py).unbind())
            .bind(py)
            .clone()
    }
    /// Whether a verified solution was found; when False every id is -1.
    #[getter]
    fn ok(&self) -> bool {
        self.rotation.is_some()
    }
    /// `identified`, `no_match`, `search_limit` or `timeout`.
    #[getter]
    fn status(&self) -> &'static str {
        self.status
    }

    #[getter]
    fn method(&self) -> &'static str {
        self.method
    }

    #[getter]
    fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }
    #[getter]
    fn ra_deg(&self) -> f64 {
        self.radec_roll_deg().0
    }
    #[getter]
    fn dec_deg(&self) -> f64 {
        self.radec_roll_deg().1
    }
    #[getter]
    fn roll_deg(&self) -> f64 {
        self.radec_roll_deg().2
    }
    /// `(ra_deg, dec_deg)` of the boresight.
    #[getter]
    fn boresight_radec_deg(&self) -> (f64, f64) {
        let (ra, dec, _) = self.radec_roll_deg();
        (ra, dec)
    }
    /// Rotation ICRS → camera as `[w, x, y, z]`, w ≥ 0; None unless `ok`.
    #[getter]
    fn quaternion<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.rotation
            .as_ref()
            .map(|r| quaternion_wxyz(r).to_vec().into_pyarray(py))
    }
    /// `v_cam = R @ v_icrs`; None unless `ok`.
    #[getter]
    fn rotation_matrix<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray2<f64>>> {
        self.rotation.as_ref().map(|r| matrix3(r).into_pyarray(py))
    }
    /// Angle between each centroid's direction and its star, arcseconds; NaN where unidentified.
    #[getter]
    fn residuals_arcsec<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.residuals_array
            .get_or_init(py, || {
                self.residuals_arcsec.clone().into_pyarray(py).unbind()
            })
            .bind(py)
            .clone()
    }
    #[getter]
    fn mirrored(&self) -> bool {
        self.mirrored
    }
    /// Found from an attitude hint (tracking); False for lost in space, including a hinted
    /// call's fallback.
    #[getter]
    fn hinted(&self) -> bool {
        self.hinted
    }
    /// The name of the catalogue the ids come from (None for an unnamed one).
    #[getter]
    fn catalog(&self) -> Option<String> {
        self.catalog.clone()
    }
    /// Passed the shared verification (False for a raw answer of ``verify=False`` and when not
    /// ``ok``).
    #[getter]
    fn verified(&self) -> bool {
        self.verified
    }
    #[getter]
    fn false_match_probability(&self) -> f64 {
        self.false_match_probability
    }
    #[getter]
    fn n_matched(&self) -> usize {
        self.n_matched
    }
    #[getter]
    fn centroid_sigma_px(&self) -> f64 {
        self.centroid_sigma_px
    }
    #[getter]
    fn match_radius_arcsec(&self) -> f64 {
        self.match_radius_arcsec
    }
    #[getter]
    fn hypotheses(&self) -> usize {
        self.hypotheses
    }
    /// Time spent identifying inside the Rust core (excludes Python overhead), seconds.
    #[getter]
    fn time_s(&self) -> f64 {
        self.time_s
    }
    #[getter]
    fn fov_deg(&self) -> f64 {
        self.fov_deg
    }
    #[getter]
    fn focal_px(&self) -> f64 {
        self.focal_px
    }
    #[getter]
    fn focal_sigma_px(&self) -> f64 {
        self.focal_sigma_px
    }
    #[getter]
    fn learned_mag_offset(&self) -> Option<f64> {
        self.learned_mag_offset
    }
    #[getter]
    fn noise_step_px(&self) -> f64 {
        self.noise_step_px
    }
    #[getter]
    fn noise_source(&self) -> &'static str {
        self.noise_source
    }
    #[getter]
    fn learned_sigma_px(&self) -> Option<f64> {
        self.learned_sigma_px
    }
    #[getter]
    fn k1(&self) -> f64 {
        self.k1
    }

    /// Seconds spent reading the image file (NaN for centroids or an array given).
    #[getter]
    fn read_s(&self) -> f64 {
        self.times()[0]
    }

    /// Seconds spent extracting the image's spots (NaN for centroids given). ``time_s`` is the
    /// identification's own time.
    #[getter]
    fn extract_s(&self) -> f64 {
        self.times()[1]
    }

    /// Record the image's read and extraction times (once: the call that read the image sets
    /// them on the result it made); returns the result.
    fn _with_times(slf: Bound<'_, Self>, read_s: f64, extract_s: f64) -> Bound<'_, Self> {
        let _ = slf.get().read_extract_s.set([read_s, extract_s]);
        slf
    }

    /// The sensor's ``(width, height)`` in pixels (NaN for a result that does not know it).
    #[getter]
    fn image_size(&self) -> (f64, f64) {
        (self.sensor[0], self.sensor[1])
    }

    /// The camera's principal point ``(x, y)`` in pixels (the sensor centre unless the camera
    /// said otherwise).
    #[getter]
    fn principal_point(&self) -> (f64, f64) {
        (self.sensor[2], self.sensor[3])
    }

    /// The camera the solution was found with (the given one, with the focal length and ``k1``
    /// the focal check found where it replaced them; the one estimated for an unknown field),
    /// or None when no focal length is known.
    #[getter]
    fn camera(&self) -> Option<crate::camera::PyCamera> {
        let [w, h, cx, cy] = self.sensor;
        let cam = starid_core::Camera::from_focal_length(self.focal_px, w, h)
            .and_then(|c| c.with_principal_point(cx, cy))
            .and_then(|c| c.with_k1(self.k1))
            .and_then(|c| c.with_higher_distortion(self.higher))
            .ok()?;
        Some(crate::camera::PyCamera { inner: cam })
    }

    /// The FITS WCS keywords of the solution (TAN, or TAN-SIP with lens distortion), as a dict:
    /// see :func:`starid.wcs.wcs_header`.
    fn wcs_header<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let me = slf.get();
        slf.py()
            .import("starid.wcs")?
            .call_method1("wcs_header", (slf, (me.sensor[0], me.sensor[1])))
    }

    /// The solution's ``astropy.wcs.WCS`` (``pip install "starid-solver[fits]"``).
    fn wcs<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        let me = slf.get();
        slf.py()
            .import("starid.wcs")?
            .call_method1("wcs", (slf, (me.sensor[0], me.sensor[1])))
    }

    /// The spots' pixel positions (N, 2), as they were given (the extractor's for an image);
    /// empty (0, 2) for a result that does not know them.
    #[getter]
    fn xy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let xy = &self.spots.xy;
        Ok(Array2::from_shape_fn((xy.len(), 2), |(i, j)| xy[i][j]).into_pyarray(py))
    }

    /// The spots' magnitudes as they were given (an image's are instrumental), or None.
    #[getter]
    fn magnitudes<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.spots
            .magnitudes
            .as_ref()
            .map(|m| m.clone().into_pyarray(py))
    }

    /// `(ra_deg, dec_deg, mag)` arrays of each spot's catalogue star, NaN where unnamed.
    fn _star_columns<'py>(&self, py: Python<'py>) -> Columns3<'py> {
        let stars = self.spots.stars(self.ids.len());
        let col = |k: usize| {
            stars
                .iter()
                .map(|s| s[k])
                .collect::<Vec<f64>>()
                .into_pyarray(py)
        };
        (col(0), col(1), col(2))
    }

    /// One row per spot: ``x, y, catalog_id, ra_deg, dec_deg, catalog_mag, mag, residual_arcsec``
    /// (catalogue columns NaN and id -1 where unnamed; ``mag`` the spot's own, NaN without
    /// magnitudes), as a numpy structured array. Pixel positions follow starid's convention
    /// (pixel centres at i + 0.5).
    fn table<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("starid._table")?
            .call_method1("spot_table", (slf,))
    }

    /// :meth:`table` as a pandas DataFrame (``pip install pandas``).
    fn to_pandas<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("starid._table")?
            .call_method1("to_pandas", (slf,))
    }

    /// :meth:`table` as an astropy Table with a ``coord`` SkyCoord column
    /// (``pip install "starid-solver[fits]"``).
    fn to_astropy<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyAny>> {
        slf.py()
            .import("starid._table")?
            .call_method1("to_astropy", (slf,))
    }

    /// Pickling (multiprocessing returns results this way): the plain values, rebuilt by
    /// `_from_state`.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (State,))> {
        let state = slf.get().state();
        Ok((slf.get_type().getattr("_from_state")?, (state,)))
    }

    #[staticmethod]
    fn _from_state(state: State) -> PyResult<Self> {
        Self::from_state(state)
    }

    /// The result of a malformed frame of a batch: status ``invalid_input``, ``message`` saying
    /// what is wrong, ``n`` spots all unnamed.
    #[staticmethod]
    fn _invalid_input(message: String, n: usize) -> PyResult<Self> {
        Self::invalid_input(message, n)
    }

    /// This result as a search made of several stages reports it: another status (unless
    /// None), the time of all the stages, the false-match bound times ``bound_factor`` (a union
    /// bound, at most 1) and the focal length's uncertainty (unless None).
    #[pyo3(signature = (status, time_s, bound_factor, focal_sigma_px=None))]
    fn _restated(
        &self,
        status: Option<String>,
        time_s: f64,
        bound_factor: f64,
        focal_sigma_px: Option<f64>,
    ) -> PyResult<Self> {
        let mut state = self.state();
        if let Some(s) = status {
            state.0 = s;
        }
        state.5 = (state.5 * bound_factor).min(1.0);
        state.7[2] = time_s;
        if let Some(f) = focal_sigma_px {
            state.7[5] = f;
        }
        Self::from_state(state)
    }

    /// Plain Python values (lists, floats, None for NaN), ready for `json.dumps`.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let (ra, dec, roll) = self.radec_roll_deg();
        d.set_item("ids", &self.ids)?;
        d.set_item("ok", self.ok())?;
        d.set_item("status", self.status)?;
        d.set_item("method", self.method)?;
        d.set_item("message", self.message.as_deref())?;
        d.set_item("hinted", self.hinted)?;
        d.set_item("verified", self.verified)?;
        d.set_item("catalog", self.catalog.as_deref())?;
        d.set_item("ra_deg", json_float(py, ra)?)?;
        d.set_item("dec_deg", json_float(py, dec)?)?;
        d.set_item("roll_deg", json_float(py, roll)?)?;
        d.set_item(
            "quaternion",
            self.rotation.as_ref().map(|r| quaternion_wxyz(r).to_vec()),
        )?;
        d.set_item(
            "rotation_matrix",
            self.rotation.as_ref().map(|r| {
                let m = r.matrix();
                (0..3)
                    .map(|i| vec![m[(i, 0)], m[(i, 1)], m[(i, 2)]])
                    .collect::<Vec<_>>()
            }),
        )?;
        let residuals = self
            .residuals_arcsec
            .iter()
            .map(|&v| json_float(py, v))
            .collect::<PyResult<Vec<_>>>()?;
        d.set_item("residuals_arcsec", residuals)?;
        d.set_item("mirrored", self.mirrored)?;
        d.set_item("false_match_probability", self.false_match_probability)?;
        d.set_item("n_matched", self.n_matched)?;
        d.set_item("centroid_sigma_px", json_float(py, self.centroid_sigma_px)?)?;
        d.set_item(
            "match_radius_arcsec",
            json_float(py, self.match_radius_arcsec)?,
        )?;
        d.set_item("hypotheses", self.hypotheses)?;
        d.set_item("time_s", self.time_s)?;
        d.set_item("fov_deg", json_float(py, self.fov_deg)?)?;
        d.set_item("focal_px", json_float(py, self.focal_px)?)?;
        d.set_item("focal_sigma_px", json_float(py, self.focal_sigma_px)?)?;
        d.set_item("learned_mag_offset", self.learned_mag_offset)?;
        d.set_item("noise_step_px", json_float(py, self.noise_step_px)?)?;
        d.set_item("noise_source", self.noise_source)?;
        d.set_item("learned_sigma_px", self.learned_sigma_px)?;
        d.set_item("k1", self.k1)?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let n = self.ids.len();
        if !self.ok() {
            return format!(
                "Identification(ok=False, status='{}', 0/{n} stars identified, {} hypotheses, time {:.3} ms)",
                self.status,
                self.hypotheses,
                self.time_s * 1e3
            );
        }
        let (ra, dec, roll) = self.radec_roll_deg();
        let (sum_sq, k) = self
            .residuals_arcsec
            .iter()
            .filter(|v| !v.is_nan())
            .fold((0.0, 0usize), |(s, k), v| (s + v * v, k + 1));
        let rms = (sum_sq / k.max(1) as f64).sqrt();
        let fov = if self.focal_sigma_px.is_nan() {
            String::new()
        } else {
            format!("fov={:.4} deg (estimated), ", self.fov_deg)
        };
        format!(
            "Identification(ok=True, {}/{n} stars identified, ra={ra:.5} deg, dec={dec:+.5} deg, roll={roll:.4} deg, \
             mirrored={}, {fov}rms residual {rms:.2} arcsec, P(false match) <= {:.1e}, time {:.3} ms)",
            self.n_matched,
            py_bool(self.mirrored),
            self.false_match_probability,
            self.time_s * 1e3
        )
    }
}
