//! Frames of a batch run in parallel, each on its own, until a cancel flag is raised: the
//! batches of hinted and unknown-field frames (the batch of a known camera, which learns a zero
//! point across its frames, is [`Solver::identify_batch_until`](super::Solver::identify_batch_until)).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use super::*;

use crate::error::{Error, Result};

/// `f(0), …, f(n − 1)` in order, on up to `threads` threads (`None`: all cores), or
/// [`ErrorKind::Cancelled`](crate::ErrorKind) once `cancel` is raised: frames not yet begun are
/// skipped, so the call ends within one frame's time of it.
///
/// ```
/// use std::sync::atomic::AtomicBool;
/// let squares = starid_core::identify::map_frames(5, None, &AtomicBool::new(false), |i| i * i).unwrap();
/// assert_eq!(squares, vec![0, 1, 4, 9, 16]);
/// assert!(starid_core::identify::map_frames(5, None, &AtomicBool::new(true), |i| i).is_err());
/// ```
pub fn map_frames<T, F>(
    n: usize,
    threads: Option<usize>,
    cancel: &AtomicBool,
    f: F,
) -> Result<Vec<T>>
where
    T: Send,
    F: Fn(usize) -> T + Sync + Send,
{
    if threads == Some(0) {
        return Err(Error::invalid_input(
            "threads must be at least 1 (or None for all cores)",
        ));
    }
    let one = |i: usize| (!cancel.load(Ordering::Relaxed)).then(|| f(i));
    let all = || -> Vec<Option<T>> {
        #[cfg(feature = "parallel")]
        if threads != Some(1) && n > 1 {
            use rayon::prelude::*;
            // One frame a task: frames of one batch may differ a thousandfold in cost.
            return (0..n).into_par_iter().with_max_len(1).map(one).collect();
        }
        (0..n).map(one).collect()
    };
    #[cfg(feature = "parallel")]
    let out = match threads.filter(|&t| t > 1) {
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::invalid_input(format!("cannot start {t} threads: {e}")))?
            .install(all),
        None => all(),
    };
    #[cfg(not(feature = "parallel"))]
    let out = all();
    if cancel.load(Ordering::Relaxed) {
        return Err(Error::cancelled());
    }
    Ok(out
        .into_iter()
        .map(|r| r.expect("every frame ran"))
        .collect())
}

/// The centroid noise (px) pooled frames' residual samples
/// ([`Identification::noise_sample_px`]) give: their median over 1.1774, the median of a
/// Rayleigh distribution of unit σ; `None` from fewer than [`NOISE_LEARN_MIN_FRAMES`] frames.
pub(crate) fn agreed_noise(samples: impl IntoIterator<Item = Vec<f64>>) -> Option<f64> {
    let mut frames = 0;
    let mut d = Vec::new();
    for s in samples {
        frames += 1;
        d.extend(s);
    }
    (frames >= NOISE_LEARN_MIN_FRAMES && !d.is_empty())
        .then(|| stats::median_in_place(&mut d) / 1.1774)
}

/// One frame of a batch: its centroids and, optionally, their magnitudes.
pub type FrameRef<'a> = (&'a [[f64; 2]], Option<&'a [f64]>);

impl Solver {
    /// The zero point a batch's identified frames agree on, and the magnitude tolerance to
    /// search with it: at least [`ZERO_POINT_MIN_FRAMES`] frames with magnitudes measure one
    /// ([`Identification::zero_point`]), at most a third of them lie more than
    /// [`ZERO_POINT_AGREE_MAG`] from the median, which is the answer; the tolerance is
    /// [`ZERO_POINT_TOLERANCE_SIGMAS`] times the agreeing frames' median spread, within the
    /// configured tolerance and [`ZERO_POINT_MAX_TOLERANCE_MAG`]. `None` when nothing agrees.
    pub(crate) fn learn_zero_point(
        &self,
        frames: &[FrameRef<'_>],
        out: &[Identification],
        config: &IdentifyConfig,
    ) -> Option<(f64, f64)> {
        let (z, s): (Vec<f64>, Vec<f64>) = frames
            .iter()
            .zip(out)
            .filter(|(_, id)| id.is_identified())
            .filter_map(|(f, id)| id.zero_point(f.1?, &self.catalog))
            .unzip();
        agreed_zero_point(&z, &s, config.mag_tolerance)
    }

    /// The centroid noise (px) a batch's frames identified with a wide margin agree on: the
    /// median of their residuals (each scaled by `sqrt(2m / (2m − 3))` for the attitude's three
    /// degrees of freedom among `m` matches) over 1.1774, the median of a Rayleigh distribution
    /// of unit σ. From at least [`NOISE_LEARN_MIN_FRAMES`] frames of at least
    /// [`NOISE_LEARN_MIN_MATCHES`] verified matches; `None` otherwise.
    pub(crate) fn learn_noise(&self, out: &[Identification], camera: &Camera) -> Option<f64> {
        agreed_noise(
            out.iter()
                .map(|id| id.noise_sample_px(id.focal_length_px.unwrap_or(camera.focal_length_px)))
                .filter(|d| !d.is_empty()),
        )
    }

    /// The focal length (px) a batch's identified frames agree on, where the given camera's is
    /// off: at least [`FOCAL_LEARN_MIN_FRAMES`] frames report one
    /// ([`Identification::focal_length_px`]), and two thirds of all identified frames lie
    /// within three of their standard errors (at least [`scale::FOCAL_SCALE_MIN`] of it) of the
    /// reports' median, which is the answer. A frame identified with the camera's own focal
    /// length counts as reporting that. `None` when nothing agrees or the median is the
    /// camera's own within [`scale::FOCAL_SCALE_MIN`]. With it, the median standard error of
    /// the reports that agree.
    pub(crate) fn learn_focal_length(
        out: &[Identification],
        camera: &Camera,
    ) -> Option<(f64, f64)> {
        let f0 = camera.focal_length_px;
        let identified: Vec<(f64, f64)> = out
            .iter()
            .filter(|id| id.is_identified())
            .map(|id| match id.focal_length_px {
                Some(f) if f.is_finite() && f > 0.0 => (f, id.focal_sigma_px),
                _ => (f0, 0.0),
            })
            .collect();
        let mut reported: Vec<f64> = identified
            .iter()
            .filter(|(f, _)| *f != f0)
            .map(|p| p.0)
            .collect();
        if reported.len() < FOCAL_LEARN_MIN_FRAMES {
            return None;
        }
        let median = stats::median_in_place(&mut reported);
        let near = |(f, se): &(f64, f64)| {
            let se = if se.is_finite() { *se } else { 0.0 };
            (f - median).abs() <= (3.0 * se).max(scale::FOCAL_SCALE_MIN * median)
        };
        let agree = identified.iter().filter(|p| near(p)).count();
        let mut se: Vec<f64> = identified
            .iter()
            .filter(|p| p.0 != f0 && near(p) && p.1.is_finite())
            .map(|p| p.1)
            .collect();
        let se = if se.is_empty() {
            f64::NAN
        } else {
            stats::median_in_place(&mut se)
        };
        (3 * agree >= 2 * identified.len() && (median / f0 - 1.0).abs() > scale::FOCAL_SCALE_MIN)
            .then_some((median, se))
    }

    /// Identify many frames of one camera, in parallel when the `parallel` feature is on and
    /// `threads` is not 1 (`None`: all cores). Results come in input order and do not depend on
    /// the thread count. A malformed frame does not stop the batch: its result has status
    /// [`Status::InvalidInput`] and the reason in [`Identification::message`].
    ///
    /// # Errors
    /// `InvalidInput` when `config` is invalid or the thread pool cannot start.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// let frames: Vec<_> = (0..4).map(|s| simulate(&cat, &cam, &SimConfig::default(), s).unwrap()).collect();
    /// let refs: Vec<_> = frames.iter().map(|f| (f.centroids.as_slice(), Some(f.magnitudes.as_slice()))).collect();
    /// let ids = solver.identify_batch(&refs, &cam, &IdentifyConfig::default(), None).unwrap();
    /// assert_eq!(ids.len(), 4);
    /// ```
    pub fn identify_batch(
        &self,
        frames: &[FrameRef<'_>],
        camera: &Camera,
        config: &IdentifyConfig,
        threads: Option<usize>,
    ) -> Result<Vec<Identification>> {
        self.identify_batch_until(frames, camera, config, threads, &AtomicBool::new(false))
    }

    /// As [`Solver::identify_batch`], checking `cancel` before each frame: once it is set, the
    /// batch returns `ErrorKind::Cancelled` within about one frame's time per thread (a frame
    /// ends within the search's work budget) plus a chunk's bookkeeping. Frames run in chunks
    /// of [`BATCH_CHUNK`], so a cancelled batch of millions allocates only what it finished.
    ///
    /// # Errors
    /// As [`Solver::identify_batch`]; `Cancelled` once `cancel` is set.
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// use std::sync::atomic::AtomicBool;
    /// let frames: Vec<_> = (0..4).map(|s| simulate(&cat, &cam, &SimConfig::default(), s).unwrap()).collect();
    /// let refs: Vec<_> = frames.iter().map(|f| (f.centroids.as_slice(), None)).collect();
    /// let stop = AtomicBool::new(true); // already cancelled
    /// let e = solver.identify_batch_until(&refs, &cam, &IdentifyConfig::default(), None, &stop).unwrap_err();
    /// assert_eq!(e.kind(), &starid_core::ErrorKind::Cancelled);
    /// ```
    pub fn identify_batch_until(
        &self,
        frames: &[FrameRef<'_>],
        camera: &Camera,
        config: &IdentifyConfig,
        threads: Option<usize>,
        cancel: &AtomicBool,
    ) -> Result<Vec<Identification>> {
        config.validate()?;
        // Without the `parallel` feature every batch runs on the calling thread.
        #[cfg(not(feature = "parallel"))]
        let _ = threads;
        let one = |f: &FrameRef<'_>, camera: &Camera, config: &IdentifyConfig| -> Identification {
            if cancel.load(Ordering::Relaxed) {
                // Nothing is looked at; the chunk's end reports the cancellation.
                return Identification::unidentified(Status::NoMatch, 0, 0, Duration::ZERO);
            }
            self.identify(f.0, f.1, camera, config)
                .unwrap_or_else(|e| Identification::invalid_input(f.0.len(), e.to_string()))
        };
        // The frames `which` picks (all of them: `None`), identified with `camera` and `config`.
        let run = |which: Option<&[usize]>,
                   camera: &Camera,
                   config: &IdentifyConfig|
         -> Result<Vec<Identification>> {
            let total = which.map_or(frames.len(), <[usize]>::len);
            let mut out = Vec::with_capacity(total.min(BATCH_CHUNK));
            let mut start = 0;
            while start < total {
                let end = (start + BATCH_CHUNK).min(total);
                if cancel.load(Ordering::Relaxed) {
                    return Err(Error::cancelled());
                }
                let frame = |k: usize| &frames[which.map_or(k, |w| w[k])];
                #[cfg(feature = "parallel")]
                if threads != Some(1) && end - start > 1 {
                    use rayon::prelude::*;
                    out.par_extend(
                        (start..end)
                            .into_par_iter()
                            .map(|k| one(frame(k), camera, config)),
                    );
                    start = end;
                    continue;
                }
                out.extend((start..end).map(|k| one(frame(k), camera, config)));
                start = end;
            }
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::cancelled());
            }
            Ok(out)
        };
        // The frames `redo` searched again with `config`: a frame identified now takes the new
        // result, marked by `mark`; either way its time and hypotheses count both searches.
        let again = |out: &mut [Identification],
                     redo: &[usize],
                     camera: &Camera,
                     config: &IdentifyConfig,
                     mark: &dyn Fn(&mut Identification)|
         -> Result<()> {
            for (i, mut id) in redo.iter().zip(run(Some(redo), camera, config)?) {
                id.elapsed += out[*i].elapsed;
                id.hypotheses += out[*i].hypotheses;
                if id.is_identified() {
                    mark(&mut id);
                    out[*i] = id;
                } else {
                    out[*i].elapsed = id.elapsed;
                    out[*i].hypotheses = id.hypotheses;
                }
            }
            Ok(())
        };
        let failed = |out: &[Identification]| -> Vec<usize> {
            (0..frames.len())
                .filter(|&i| matches!(out[i].status, Status::NoMatch | Status::SearchLimit))
                .collect()
        };
        let both = || -> Result<Vec<Identification>> {
            let mut out = run(None, camera, config)?;
            // A focal length the identified frames agree on, where the given field was an
            // estimate (a tolerance) and off: the frames nothing identified are searched again
            // at it, as a field known (a frame's own search within the tolerance looks from the
            // given focal length, and may spend its budget before reaching the true one).
            let mut camera = *camera;
            let redo = failed(&out);
            if config.fov_tolerance > 0.0
                && config.focal_check
                && camera.is_ideal()
                && !redo.is_empty()
            {
                if let Some((f, se)) = Self::learn_focal_length(&out, &camera) {
                    camera.focal_length_px = f;
                    let known = IdentifyConfig {
                        fov_tolerance: 0.0,
                        ..config.clone()
                    };
                    again(&mut out, &redo, &camera, &known, &|id| {
                        if id.focal_length_px.is_none() {
                            id.focal_length_px = Some(f);
                            id.focal_sigma_px = se;
                        }
                    })?;
                }
            }
            let camera = &camera;
            // A zero point the identified frames agree on: the frames with magnitudes nothing
            // identified without it are searched again, magnitude-gated (nothing is measured
            // while every frame with magnitudes is identified).
            let mut config = config.clone();
            let mut learned_offset = None;
            let with_magnitudes: Vec<usize> = failed(&out)
                .into_iter()
                .filter(|&i| frames[i].1.is_some())
                .collect();
            if config.learn_zero_point && !with_magnitudes.is_empty() {
                if let Some(learned) = self
                    .learn_zero_point(frames, &out, &config)
                    .and_then(|zp| config.with_learned_zero_point(zp))
                {
                    let offset = learned.mag_offset;
                    again(&mut out, &with_magnitudes, camera, &learned, &|id| {
                        id.learned_mag_offset = offset;
                    })?;
                    learned_offset = offset;
                    config = learned;
                }
            }
            // A centroid noise the frames identified with a wide margin agree on, tighter than
            // the ladder's first step: the frames still unidentified are searched again with it
            // alone (a tighter radius lets fewer stars pass the bound).
            let redo = failed(&out);
            if !config.learn_noise || config.centroid_sigma_px.is_some() || redo.is_empty() {
                return Ok(out);
            }
            let Some(sigma) = self
                .learn_noise(&out, camera)
                .filter(|&s| s < NOISE_LEARN_BELOW_LADDER * SIGMA_LADDER_PX[0] && s > 0.0)
            else {
                return Ok(out);
            };
            let learned = IdentifyConfig {
                centroid_sigma_px: Some(sigma),
                noise_fallback: false,
                ..config.clone()
            };
            again(&mut out, &redo, camera, &learned, &|id| {
                id.learned_sigma_px = Some(sigma);
                id.noise_source = NoiseSource::Learned;
                id.learned_mag_offset = learned_offset;
            })?;
            Ok(out)
        };
        #[cfg(feature = "parallel")]
        if let Some(t) = threads.filter(|&t| t > 1) {
            return rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::invalid_input(format!("cannot start {t} threads: {e}")))?
                .install(both);
        }
        both()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An identified frame that reports focal length `f` (None: the camera's own).
    fn frame(f: Option<f64>, se: f64) -> Identification {
        let mut id = Identification::unidentified(Status::Identified, 10, 1, Duration::ZERO);
        id.focal_length_px = f;
        id.focal_sigma_px = if f.is_some() { se } else { f64::NAN };
        id
    }

    #[test]
    fn the_focal_length_is_learned_only_where_the_identified_frames_agree() {
        let cam = Camera::from_focal_length(1000.0, 1000.0, 800.0).unwrap();
        let off = |f: f64| frame(Some(f), 0.5);
        // Three frames at 1030 px agree, one at the camera's own does not stop them.
        let agree = [off(1030.0), off(1030.4), off(1029.7), frame(None, 0.0)];
        let (f, se) = Solver::learn_focal_length(&agree, &cam).unwrap();
        assert!((f - 1030.0).abs() < 1e-9 && (se - 0.5).abs() < 1e-9);
        // Two reports are too few; unidentified frames count for nothing.
        let mut few = vec![off(1030.0), off(1030.0)];
        assert!(Solver::learn_focal_length(&few, &cam).is_none());
        few.push(Identification::unidentified(
            Status::NoMatch,
            5,
            0,
            Duration::ZERO,
        ));
        assert!(Solver::learn_focal_length(&few, &cam).is_none());
        // Most frames identified at the camera's own focal length: it stands.
        let mut own = vec![off(1030.0), off(1030.0), off(1030.0)];
        own.extend((0..3).map(|_| frame(None, 0.0)));
        assert!(Solver::learn_focal_length(&own, &cam).is_none());
        // Reports that scatter beyond their errors teach nothing.
        let scatter = [off(1010.0), off(1030.0), off(1050.0)];
        assert!(Solver::learn_focal_length(&scatter, &cam).is_none());
        // Agreeing on the camera's own focal length changes nothing.
        let same = [off(1000.2), off(1000.1), off(1000.3)];
        assert!(Solver::learn_focal_length(&same, &cam).is_none());
    }
}
