//! Long calls that Ctrl-C stops: the work on a thread of its own while the calling thread lets
//! Python handle signals, and the batches of hinted and unknown-field frames.

use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyList;
use starid_core::identify::map_frames;
use starid_core::{Camera, Cancel, Identification};

use crate::camera::PyCamera;
use crate::catalog::PyCatalog;
use crate::convert::{self, Frame};
use crate::errors::PyStaridError;
use crate::outcome::PyIdentification;
use crate::PyIdentifyConfig;

/// How often the calling thread looks for Ctrl-C while the work runs.
const SIGNAL_CHECK: std::time::Duration = std::time::Duration::from_millis(20);

/// Where a worker thread leaves its answer (or its panic) for the caller waiting on it.
struct Slot<T> {
    value: std::sync::Mutex<Option<std::thread::Result<T>>>,
    ready: std::sync::Condvar,
}

impl<T: Send> Slot<T> {
    fn new() -> Self {
        Self {
            value: std::sync::Mutex::new(None),
            ready: std::sync::Condvar::new(),
        }
    }

    /// `work()`'s answer, or its panic, left for the waiting caller.
    fn fill(&self, work: impl FnOnce() -> T) {
        let out = std::panic::catch_unwind(std::panic::AssertUnwindSafe(work));
        *self
            .value
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(out);
        self.ready.notify_all();
    }

    /// The answer, once it is there, waiting at most `wait` (`None`: as long as it takes) with
    /// the GIL released.
    fn take(
        &self,
        py: Python<'_>,
        wait: Option<std::time::Duration>,
    ) -> Option<std::thread::Result<T>> {
        py.detach(|| {
            let guard = self
                .value
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            let mut guard = match wait {
                Some(w) => {
                    self.ready
                        .wait_timeout_while(guard, w, |v| v.is_none())
                        .unwrap_or_else(std::sync::PoisonError::into_inner)
                        .0
                }
                None => self
                    .ready
                    .wait_while(guard, |v| v.is_none())
                    .unwrap_or_else(std::sync::PoisonError::into_inner),
            };
            guard.take()
        })
    }

    /// The answer, letting Python handle signals every 20 ms meanwhile: Ctrl-C runs
    /// `on_interrupt` and raises KeyboardInterrupt.
    fn wait(&self, py: Python<'_>, on_interrupt: impl FnOnce()) -> PyResult<T> {
        loop {
            if let Err(interrupt) = py.check_signals() {
                on_interrupt();
                return Err(interrupt);
            }
            match self.take(py, Some(SIGNAL_CHECK)) {
                Some(Ok(out)) => return Ok(out),
                Some(Err(_)) => {
                    return Err(crate::errors::InvalidInputError::new_err(
                        "a starid worker thread panicked",
                    ))
                }
                None => {}
            }
        }
    }
}

/// `work(cancel)` with the GIL released, on a thread of its own, while this one lets Python
/// handle signals every 20 ms: Ctrl-C raises `cancel`, waits for the work to end (it polls the
/// flag) and raises KeyboardInterrupt. The wait ends as soon as the work does.
pub fn watched<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(&Cancel) -> T + Send,
{
    let cancel = Cancel::new();
    let slot = Slot::new();
    std::thread::scope(|scope| {
        let (cancel, slot) = (&cancel, &slot);
        scope.spawn(move || slot.fill(|| work(cancel)));
        slot.wait(py, || {
            cancel.cancel();
            slot.take(py, None);
        })
    })
}

/// `work()` with the GIL released on a thread of its own, while this one lets Python handle
/// signals every 20 ms: Ctrl-C raises KeyboardInterrupt at once and leaves the work to finish
/// in the background (for work whose result is kept anyway, such as an index build).
pub fn detached<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce() -> T + Send + 'static,
{
    let slot = std::sync::Arc::new(Slot::new());
    let theirs = slot.clone();
    std::thread::Builder::new()
        .name("starid-build".into())
        .spawn(move || theirs.fill(work))
        .map_err(|e| {
            crate::errors::InvalidInputError::new_err(format!("cannot start a thread: {e}"))
        })?;
    slot.wait(py, || {})
}

/// The frames of a batch as the core takes them; a frame that cannot be read keeps its error,
/// which becomes its `invalid_input` result.
fn read_frames(
    xys: &Bound<'_, PyList>,
    magnitudes: &Bound<'_, PyList>,
) -> PyResult<Vec<std::result::Result<Frame, String>>> {
    if magnitudes.len() != xys.len() {
        return Err(crate::errors::InvalidInputError::new_err(format!(
            "magnitudes has {} entries for {} frames",
            magnitudes.len(),
            xys.len()
        )));
    }
    xys.iter()
        .zip(magnitudes.iter())
        .map(|(xy, m)| {
            let xy: PyReadonlyArray2<'_, f64> = xy.extract()?;
            let m: Option<PyReadonlyArray1<'_, f64>> = m.extract()?;
            Ok(convert::frame(&xy, m.as_ref()).map_err(|e| e.to_string()))
        })
        .collect()
}

/// A frame's result, or its `invalid_input` result naming it.
fn per_frame(i: usize, n: usize, r: starid_core::Result<Identification>) -> Identification {
    r.unwrap_or_else(|e| invalid(i, n, &e.to_string()))
}

fn invalid(i: usize, n: usize, message: &str) -> Identification {
    Identification::invalid_input(n, format!("frame {i}: {message}"))
}

/// Python results of core results, each with the camera it was identified with and the spots
/// of its frame.
fn results<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    out: Vec<(Identification, Camera, f64)>,
    frames: Vec<std::result::Result<Frame, String>>,
) -> PyResult<Bound<'py, PyList>> {
    let cat = catalog.get();
    PyList::new(
        py,
        out.into_iter().zip(frames).map(|((id, cam, sigma), f)| {
            let r = PyIdentification::new(cat, id, &cam, sigma);
            match f {
                Ok((xy, m)) => r.with_spots(xy, m),
                Err(_) => r,
            }
        }),
    )
}

/// Frames of one camera, each with an attitude hint (`None`: lost in space), in parallel; a
/// frame or hint that cannot be read is an `invalid_input` result naming the frame.
#[pyfunction]
#[pyo3(signature = (catalog, xys, magnitudes, camera, config, hints, uncertainty_deg, fallback, threads=None))]
pub fn identify_hinted_many<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xys: &Bound<'py, PyList>,
    magnitudes: &Bound<'py, PyList>,
    camera: &Bound<'py, PyCamera>,
    config: &Bound<'py, PyIdentifyConfig>,
    hints: Vec<Option<([f64; 4], Option<bool>)>>,
    uncertainty_deg: f64,
    fallback: bool,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyList>> {
    let frames = read_frames(xys, magnitudes)?;
    if hints.len() != frames.len() {
        return Err(crate::errors::InvalidInputError::new_err(format!(
            "{} hints for {} frames",
            hints.len(),
            frames.len()
        )));
    }
    let (cam, solver, cfg) = crate::frame_setup(py, catalog, camera, config)?;
    let fallback = crate::tracking::fallback_of(fallback);
    let out = watched(py, |cancel| {
        let cfg = starid_core::IdentifyConfig {
            cancel: Some(cancel.clone()),
            ..cfg
        };
        map_frames(frames.len(), threads, cancel.flag(), |i| {
            let id = match &frames[i] {
                Err(e) => invalid(i, 0, e),
                Ok((xy, m)) => {
                    let r = match &hints[i] {
                        None => solver.identify(xy, m.as_deref(), &cam, &cfg),
                        Some((q, mirrored)) => {
                            crate::tracking::hint(*q, uncertainty_deg, *mirrored)
                                .map_err(|e| starid_core::Error::invalid_input(e.to_string()))
                                .and_then(|h| {
                                    solver.identify_hinted(
                                        xy,
                                        m.as_deref(),
                                        &cam,
                                        &cfg,
                                        &h,
                                        fallback,
                                    )
                                })
                        }
                    };
                    per_frame(i, xy.len(), r)
                }
            };
            (id, cam, f64::NAN)
        })
    })?
    .map_err(PyStaridError)?;
    results(py, catalog, out, frames)
}

/// Frames of one sensor whose field of view lies in `[fov_lo_deg, fov_hi_deg]`, in parallel; a
/// frame that cannot be read is an `invalid_input` result naming it.
#[pyfunction]
#[pyo3(signature = (catalog, xys, magnitudes, width_px, height_px, fov_lo_deg, fov_hi_deg, config, threads=None))]
pub fn identify_unknown_fov_many<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xys: &Bound<'py, PyList>,
    magnitudes: &Bound<'py, PyList>,
    width_px: f64,
    height_px: f64,
    fov_lo_deg: f64,
    fov_hi_deg: f64,
    config: &Bound<'py, PyIdentifyConfig>,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyList>> {
    let frames = read_frames(xys, magnitudes)?;
    let (solver, range, widest) = crate::pointing::unknown_fov_setup(
        py, catalog, width_px, height_px, fov_lo_deg, fov_hi_deg,
    )?;
    let cfg = config.get().inner.clone();
    let out = watched(py, |cancel| {
        let cfg = starid_core::IdentifyConfig {
            cancel: Some(cancel.clone()),
            ..cfg
        };
        map_frames(frames.len(), threads, cancel.flag(), |i| match &frames[i] {
            Err(e) => (
                invalid(i, 0, e),
                crate::pointing::focal_unknown(&widest),
                f64::NAN,
            ),
            Ok((xy, m)) => unknown_fov_frame(
                &solver,
                i,
                (xy, m.as_deref()),
                (width_px, height_px),
                range,
                &widest,
                &cfg,
            ),
        })
    })?
    .map_err(PyStaridError)?;
    results(py, catalog, out, frames)
}

/// Frame `i` searched over the focal lengths `range` of its sensor: the identification, the
/// camera found (or the focal length unknown) and the focal length's 1σ; a frame the core
/// refuses is an `invalid_input` result naming it.
fn unknown_fov_frame(
    solver: &starid_core::Solver,
    i: usize,
    (xy, magnitudes): (&[[f64; 2]], Option<&[f64]>),
    (width_px, height_px): (f64, f64),
    range: (f64, f64),
    widest: &Camera,
    config: &starid_core::IdentifyConfig,
) -> Found {
    match solver.identify_unknown_focal(xy, magnitudes, width_px, height_px, range, config) {
        Ok(r) => crate::pointing::unknown_fov_result(r, widest),
        Err(e) => (
            invalid(i, xy.len(), &e.to_string()),
            crate::pointing::focal_unknown(widest),
            f64::NAN,
        ),
    }
}

/// What a search on a thread of its own leaves: the identification, the camera found (or the
/// focal length unknown) and the focal length's 1σ.
type Found = (Identification, Camera, f64);

/// One frame searched with its field of view unknown on a thread of its own, while the caller
/// goes on (with other searches of the same frame): `result()` waits for it, `cancel()` ends it
/// at its next check.
#[pyclass(name = "PendingSearch", module = "starid._starid", frozen)]
pub struct PyPendingSearch {
    cancel: Cancel,
    slot: std::sync::Arc<Slot<Found>>,
    /// The result, once a caller has taken it from the slot (None: the search panicked).
    done: std::sync::OnceLock<Option<Found>>,
    /// Whether a caller is waiting on the slot (the others wait for it to fill `done`).
    waiting: std::sync::atomic::AtomicBool,
    catalog: Py<PyCatalog>,
    frame: Frame,
}

#[pymethods]
impl PyPendingSearch {
    /// End the search at its next check (its result is then a search cut short).
    fn cancel(&self) {
        self.cancel.cancel();
    }

    /// The search's result, waiting for it with the GIL released (Ctrl-C ends the search and
    /// raises KeyboardInterrupt).
    fn result(&self, py: Python<'_>) -> PyResult<PyIdentification> {
        use std::sync::atomic::Ordering;
        let (id, cam, sigma) = loop {
            match self.done.get() {
                Some(Some(found)) => break found.clone(),
                Some(None) => {
                    return Err(crate::errors::InvalidInputError::new_err(
                        "a starid worker thread panicked",
                    ))
                }
                None => {}
            }
            // One caller waits on the slot; another (a second Python thread) checks back every
            // millisecond with the GIL released, so that neither holds it from the other.
            if self
                .waiting
                .compare_exchange(false, true, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
            {
                let interrupted = py.check_signals();
                if interrupted.is_err() {
                    self.cancel.cancel();
                } else if let Some(taken) = self.slot.take(py, Some(SIGNAL_CHECK)) {
                    let _ = self.done.set(taken.ok());
                }
                self.waiting.store(false, Ordering::Release);
                interrupted?;
            } else {
                py.detach(|| std::thread::sleep(std::time::Duration::from_millis(1)));
                py.check_signals()?;
            }
        };
        let (xy, m) = self.frame.clone();
        Ok(PyIdentification::new(self.catalog.get(), id, &cam, sigma).with_spots(xy, m))
    }

    fn __repr__(&self) -> String {
        let state = if self.cancel.is_cancelled() {
            "cancelled"
        } else {
            "started"
        };
        format!("PendingSearch({state})")
    }
}

/// A search nobody waits for any more ends at its next check.
impl Drop for PyPendingSearch {
    fn drop(&mut self) {
        self.cancel.cancel();
    }
}

/// One frame of a sensor whose field of view lies in `[fov_lo_deg, fov_hi_deg]`, searched on a
/// thread of its own: returns at once with the search under way.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn identify_unknown_fov_start<'py>(
    py: Python<'py>,
    catalog: &Bound<'py, PyCatalog>,
    xy: PyReadonlyArray2<'py, f64>,
    magnitudes: Option<PyReadonlyArray1<'py, f64>>,
    width_px: f64,
    height_px: f64,
    fov_lo_deg: f64,
    fov_hi_deg: f64,
    config: &Bound<'py, PyIdentifyConfig>,
) -> PyResult<PyPendingSearch> {
    let frame = convert::frame(&xy, magnitudes.as_ref())?;
    let (solver, range, widest) = crate::pointing::unknown_fov_setup(
        py, catalog, width_px, height_px, fov_lo_deg, fov_hi_deg,
    )?;
    let cancel = Cancel::new();
    let cfg = starid_core::IdentifyConfig {
        cancel: Some(cancel.clone()),
        ..config.get().inner.clone()
    };
    let slot = std::sync::Arc::new(Slot::new());
    let (theirs, (xy, m)) = (slot.clone(), frame.clone());
    std::thread::Builder::new()
        .name("starid-search".into())
        .spawn(move || {
            theirs.fill(|| {
                unknown_fov_frame(
                    &solver,
                    0,
                    (&xy, m.as_deref()),
                    (width_px, height_px),
                    range,
                    &widest,
                    &cfg,
                )
            });
        })
        .map_err(|e| {
            crate::errors::InvalidInputError::new_err(format!("no thread for the search: {e}"))
        })?;
    Ok(PyPendingSearch {
        cancel,
        slot,
        done: std::sync::OnceLock::new(),
        waiting: std::sync::atomic::AtomicBool::new(false),
        catalog: catalog.clone().unbind(),
        frame,
    })
}
