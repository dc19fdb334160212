//! How often a catalogue triangle has its field to itself: the chance that a lone triangle
//! matched by coincidence passes the check that no clearly brighter catalogue star on the sensor
//! goes unseen (see the `lone` module).

use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

use super::Solver;
use crate::geometry::{attitude_from_radec_roll, radec_to_unit, Camera};

/// Fields of view sampled (boresights on a Fibonacci lattice, rolls by the golden angle).
const FIELDS: usize = 3000;

/// Width (mag) of the bins of the faintest star's magnitude.
const BIN_MAG: f64 = 0.25;

/// Fewest sampled triangles a bin needs to say anything (fewer: a pass fraction of 1).
const MIN_TRIANGLES: f64 = 200.0;

/// Factor on the sampled fraction for the sample's own error and the sky between the samples.
const MARGIN: f64 = 2.0;

/// Tables kept per solver (cameras and tolerances seen), the oldest dropped past this many.
const KEPT: usize = 8;

/// The fraction, by the magnitude `F` of a triangle's faintest star, of the catalogue triangles
/// on a sensor whose every other star on the sensor is no brighter than `F − tolerance`.
#[derive(Debug)]
pub(crate) struct EmptyFields {
    first_mag: f64,
    pass: Vec<f64>,
}

/// What a table depends on: the sensor (focal length, size) and the tolerance, as bits.
type Key = [u64; 4];

/// The tables a solver has made.
#[derive(Debug, Default)]
pub(crate) struct EmptyFieldCache(Mutex<Vec<(Key, Arc<EmptyFields>)>>);

impl Clone for EmptyFieldCache {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl EmptyFields {
    /// The fraction for a triangle whose faintest star has magnitude `faintest` (with the margin;
    /// 1 where the sample says too little).
    pub(crate) fn pass_fraction(&self, faintest: f64) -> f64 {
        let bin = ((faintest - self.first_mag) / BIN_MAG).floor();
        if bin < 0.0 || bin as usize >= self.pass.len() {
            return 1.0;
        }
        self.pass[bin as usize]
    }

    /// The smallest fraction of any magnitude.
    pub(crate) fn least(&self) -> f64 {
        self.pass.iter().copied().fold(1.0, f64::min)
    }
}

impl Solver {
    /// The table for `camera` and magnitude `tolerance`, made once per solver.
    pub(crate) fn empty_fields(&self, camera: &Camera, tolerance: f64) -> Arc<EmptyFields> {
        let key = [
            camera.focal_length_px.to_bits(),
            camera.width_px.to_bits(),
            camera.height_px.to_bits(),
            tolerance.to_bits(),
        ];
        let mut kept = self
            .empty_fields
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        if let Some((_, t)) = kept.iter().find(|(k, _)| *k == key) {
            return Arc::clone(t);
        }
        let table = Arc::new(self.sample_empty_fields(camera, tolerance));
        if kept.len() >= KEPT {
            kept.remove(0);
        }
        kept.push((key, Arc::clone(&table)));
        table
    }

    fn sample_empty_fields(&self, camera: &Camera, tolerance: f64) -> EmptyFields {
        let catalog = &*self.catalog;
        let (mags, vectors) = (catalog.mag(), catalog.vectors());
        let first_mag = mags.iter().copied().fold(f64::INFINITY, f64::min);
        let last_mag = mags.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let bins = (((last_mag - first_mag) / BIN_MAG).floor() as usize + 1).max(1);
        let (mut pass, mut total) = (vec![0.0; bins], vec![0.0; bins]);
        let golden = PI * (3.0 - 5f64.sqrt());
        let mut field: Vec<f64> = Vec::new();
        for i in 0..FIELDS {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / FIELDS as f64;
            let (ra, dec) = (golden * i as f64, z.asin());
            let ra = ra.rem_euclid(2.0 * PI);
            let r =
                attitude_from_radec_roll(ra, dec, (golden * 7.0 * i as f64).rem_euclid(2.0 * PI));
            let boresight = radec_to_unit(ra, dec);
            field.clear();
            catalog.for_each_in_cone(&boresight, 0.5 * camera.diagonal_fov_rad(), |star, _| {
                if let Some((x, y)) = camera.cam_to_pixel(&(r * vectors[star as usize])) {
                    if (0.0..camera.width_px).contains(&x) && (0.0..camera.height_px).contains(&y) {
                        field.push(mags[star as usize]);
                    }
                }
            });
            field.sort_unstable_by(f64::total_cmp);
            // Each star as the faintest of a triangle with two of those before it: the triangles
            // that hold every star brighter than its magnitude less the tolerance pass.
            for (k, &faintest) in field.iter().enumerate().skip(2) {
                let brighter = field[..k].partition_point(|&m| m < faintest - tolerance);
                let bin = (((faintest - first_mag) / BIN_MAG) as usize).min(bins - 1);
                total[bin] += choose2(k);
                // C(k − brighter, 2 − brighter): the rest of the triangle among the others.
                pass[bin] += match brighter {
                    0 => choose2(k),
                    1 => (k - 1) as f64,
                    2 => 1.0,
                    _ => 0.0,
                };
            }
        }
        let pass = pass
            .iter()
            .zip(&total)
            .map(|(&p, &t)| {
                if t < MIN_TRIANGLES {
                    1.0
                } else {
                    ((p + 1.0) / t * MARGIN).min(1.0)
                }
            })
            .collect();
        EmptyFields { first_mag, pass }
    }
}

/// `C(k, 2)` as a float.
fn choose2(k: usize) -> f64 {
    (k * k.saturating_sub(1)) as f64 / 2.0
}
