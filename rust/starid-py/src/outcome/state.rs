//! Pickling a result: its plain values as a tuple, and the result rebuilt from them (checked:
//! a tuple from elsewhere is refused with a reason, not trusted).

use std::sync::OnceLock;

use nalgebra::Rotation3;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use starid_core::{NoiseSource, Status};

use super::{matrix3, PyIdentification, Spots};

/// The plain values of an [`PyIdentification`], for pickling.
pub(super) type State = (
    String,
    Vec<i64>,
    Vec<f64>,
    Option<Vec<f64>>,
    bool,
    f64,
    usize,
    [f64; 20],
    usize,
    String,
    Option<String>,
    (bool, bool, Option<String>, SpotState, String),
);

/// The spots of a pickled result: centroids, magnitudes, and each spot's star (ra, dec, mag).
type SpotState = (Vec<[f64; 2]>, Option<Vec<f64>>, Vec<[f64; 3]>);

impl PyIdentification {
    /// The result of a malformed frame of a batch: status `invalid_input`, `message` saying
    /// what is wrong, `n` spots all unnamed, every measure NaN or zero.
    pub(super) fn invalid_input(message: String, n: usize) -> PyResult<Self> {
        let nan = f64::NAN;
        let floats = [
            nan, nan, 0.0, nan, nan, nan, nan, 0.0, nan, nan, nan, nan, nan, nan, 0.0, 0.0, 0.0,
            0.0, nan, nan,
        ];
        Self::from_state((
            Status::InvalidInput.as_str().to_string(),
            vec![-1; n],
            vec![nan; n],
            None,
            false,
            1.0,
            0,
            floats,
            0,
            "auto".to_string(),
            Some(message),
            (
                false,
                false,
                None,
                (Vec::new(), None, Vec::new()),
                NoiseSource::None.as_str().to_string(),
            ),
        ))
    }

    /// The plain values, for `__reduce__`.
    pub(super) fn state(&self) -> State {
        let me = self;
        (
            me.status.to_string(),
            me.ids.clone(),
            me.residuals_arcsec.clone(),
            me.rotation.map(|r| matrix3(&r).into_raw_vec_and_offset().0),
            me.mirrored,
            me.false_match_probability,
            me.n_matched,
            [
                me.centroid_sigma_px,
                me.match_radius_arcsec,
                me.time_s,
                me.fov_deg,
                me.focal_px,
                me.focal_sigma_px,
                me.learned_mag_offset.unwrap_or(f64::NAN),
                me.k1,
                me.sensor[0],
                me.sensor[1],
                me.sensor[2],
                me.sensor[3],
                me.times()[0],
                me.times()[1],
                me.higher[0],
                me.higher[1],
                me.higher[2],
                me.higher[3],
                me.noise_step_px,
                me.learned_sigma_px.unwrap_or(f64::NAN),
            ],
            me.hypotheses,
            me.method.to_string(),
            me.message.clone(),
            (
                me.hinted,
                me.verified,
                me.catalog.clone(),
                (
                    me.spots.xy.clone(),
                    me.spots.magnitudes.clone(),
                    me.spots.stars(me.ids.len()).to_vec(),
                ),
                me.noise_source.to_string(),
            ),
        )
    }

    /// The result of `state`'s values.
    pub(super) fn from_state(state: State) -> PyResult<Self> {
        let (
            status,
            ids,
            residuals_arcsec,
            rotation,
            mirrored,
            fmp,
            n_matched,
            floats,
            hypotheses,
            method,
            message,
            (hinted, verified, catalog, (xy, magnitudes, stars), noise_source),
        ) = state;
        let noise_source = [
            NoiseSource::None,
            NoiseSource::Ladder,
            NoiseSource::Stated,
            NoiseSource::Widened,
            NoiseSource::Narrowed,
            NoiseSource::Learned,
        ]
        .into_iter()
        .map(|s| s.as_str())
        .find(|s| *s == noise_source)
        .ok_or_else(|| PyValueError::new_err(format!("unknown noise source {noise_source:?}")))?;
        let method = starid_core::Method::from_name(&method)
            .map_err(|e| PyValueError::new_err(e.to_string()))?
            .name();
        let status = [
            Status::Identified,
            Status::NoMatch,
            Status::SearchLimit,
            Status::Timeout,
            Status::TooFewStars,
            Status::InvalidInput,
        ]
        .into_iter()
        .map(|s| s.as_str())
        .find(|s| *s == status)
        .ok_or_else(|| PyValueError::new_err(format!("unknown status {status:?}")))?;
        let rotation = match rotation {
            None => None,
            Some(m) if m.len() == 9 => Some(Rotation3::from_matrix_unchecked(
                nalgebra::Matrix3::from_row_slice(&m),
            )),
            Some(m) => {
                return Err(PyValueError::new_err(format!(
                    "a rotation has 9 entries, got {}",
                    m.len()
                )))
            }
        };
        if ids.len() != residuals_arcsec.len() {
            return Err(PyValueError::new_err("ids and residuals differ in length"));
        }
        if !(xy.is_empty() || xy.len() == ids.len())
            || magnitudes.as_ref().is_some_and(|m| m.len() != ids.len())
            || !(stars.is_empty() || stars.len() == ids.len())
        {
            return Err(PyValueError::new_err("spots and ids differ in length"));
        }
        let stars = if stars.is_empty() {
            vec![[f64::NAN; 3]; ids.len()]
        } else {
            stars
        };
        let [centroid_sigma_px, match_radius_arcsec, time_s, fov_deg, focal_px, focal_sigma_px, learned, k1, w, h, cx, cy, read_s, extract_s, k2, k3, p1, p2, noise_step_px, learned_sigma] =
            floats;
        Ok(Self {
            status,
            method,
            message,
            hinted,
            verified,
            catalog,
            ids,
            residuals_arcsec,
            rotation,
            mirrored,
            false_match_probability: fmp,
            n_matched,
            centroid_sigma_px,
            match_radius_arcsec,
            hypotheses,
            time_s,
            fov_deg,
            focal_px,
            focal_sigma_px,
            learned_mag_offset: (!learned.is_nan()).then_some(learned),
            noise_step_px,
            noise_source,
            learned_sigma_px: (!learned_sigma.is_nan()).then_some(learned_sigma),
            k1,
            higher: [k2, k3, p1, p2],
            ids_array: PyOnceLock::new(),
            residuals_array: PyOnceLock::new(),
            radec_roll: OnceLock::new(),
            spots: Spots {
                xy,
                magnitudes,
                stars: OnceLock::from(stars),
                ..Spots::default()
            },
            sensor: [w, h, cx, cy],
            read_extract_s: if read_s.is_nan() && extract_s.is_nan() {
                OnceLock::new()
            } else {
                OnceLock::from([read_s, extract_s])
            },
        })
    }
}
