//! Calibrate simulated wide-angle cameras from their own identified frames, as a user would:
//! identify with the nominal camera (field of view across the width, principal point at the
//! centre, no distortion), calibrate from the matches, then identify again with the camera found.
//! While the camera found names more stars, the frames are identified and calibrated again.
//! Prints, per lens, the identified frames and wrong ids before and after, the frames and
//! matches of the final fit, the fitted intrinsics against the truth (errors, and the chosen
//! distortion terms' errors in units of their 1σ), the RMS residual per axis before and after
//! against the centroid noise, and the time of the first fit. `STARID_SEED_BASE` changes the
//! frames, `STARID_VERBOSE` prints each identification.
//!
//! `cargo run --release --example calibrate -- [FRAMES] [NOISE_PX]` (defaults 20 and 0.2)
#![allow(clippy::print_stdout)]

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use starid_core::calibrate::{calibrate, CalibrationConfig, CalibrationFrame, Intrinsic};
use starid_core::{simulate, Camera, Catalog, IdentifyConfig, SimConfig, Solver};

struct Lens {
    fov_deg: f64,
    k: [f64; 3],
    p: [f64; 2],
    offset_px: [f64; 2],
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let frames: u64 = a
        .get(1)
        .map_or(20, |s| s.parse().expect("a number of frames"));
    let noise: f64 = a
        .get(2)
        .map_or(0.2, |s| s.parse().expect("a noise in pixels"));
    let catalog = Arc::new(Catalog::bundled());
    let (w, h) = (1280.0, 1024.0);
    let lenses = [
        Lens {
            fov_deg: 20.0,
            k: [-0.2, 0.0, 0.0],
            p: [4e-4, -3e-4],
            offset_px: [20.0, 0.0],
        },
        Lens {
            fov_deg: 30.0,
            k: [-0.15, 0.02, 0.0],
            p: [-5e-4, 6e-4],
            offset_px: [-14.0, 14.0],
        },
        Lens {
            fov_deg: 40.0,
            k: [-0.2, 0.03, 0.0],
            p: [1e-3, 5e-4],
            offset_px: [0.0, -20.0],
        },
        Lens {
            fov_deg: 60.0,
            k: [-0.2, 0.04, -0.005],
            p: [-8e-4, -8e-4],
            offset_px: [14.0, 14.0],
        },
    ];
    println!(
        "lens | identified before | wrong | calibrated from | f err % | pp err px | k1 k2 k3 p1 p2 err/σ | rms before px | rms after px (noise {noise}) | clipped | identified after | wrong | fit ms"
    );
    for lens in &lenses {
        let nominal = Camera::from_fov(lens.fov_deg.to_radians(), w, h).expect("camera");
        let truth = nominal
            .with_principal_point(0.5 * w + lens.offset_px[0], 0.5 * h + lens.offset_px[1])
            .and_then(|c| c.with_k1(lens.k[0]))
            .and_then(|c| c.with_higher_distortion([lens.k[1], lens.k[2], lens.p[0], lens.p[1]]))
            .expect("lens");
        let solver = Solver::for_camera(catalog.clone(), &nominal.with_k1(-0.3).expect("widest"))
            .expect("index");
        let config = IdentifyConfig {
            focal_check: std::env::var_os("STARID_NO_FOCAL_CHECK").is_none(),
            ..IdentifyConfig::default()
        };
        let sim = SimConfig {
            noise_px: noise,
            mag_noise: 0.1,
            ..Default::default()
        };
        let base: u64 = std::env::var("STARID_SEED_BASE")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1000);
        let sims: Vec<_> = (0..frames)
            .map(|seed| simulate(&catalog, &truth, &sim, base + seed).expect("frame"))
            .collect();
        let run = |camera: &Camera| -> (Vec<Option<CalibrationFrame>>, usize) {
            let mut wrong = 0;
            let out = sims
                .iter()
                .map(|f| {
                    let r = solver
                        .identify(&f.centroids, Some(&f.magnitudes), camera, &config)
                        .expect("identify");
                    let attitude = r.r_icrs_to_cam.filter(|_| r.status == starid_core::Status::Identified)?;
                    let (mut pixels, mut stars) = (Vec::new(), Vec::new());
                    let wrong_before = wrong;
                    for ((c, got), want) in f.centroids.iter().zip(&r.catalog_index).zip(&f.catalog_index) {
                        if let Some(s) = got {
                            wrong += usize::from(Some(*s) != *want);
                            pixels.push(*c);
                            stars.push(catalog.vectors()[*s as usize]);
                        }
                    }
                    if std::env::var_os("STARID_VERBOSE").is_some() {
                        println!(
                            "  frame: {} spots, {} real, {} named, {} wrong, f {:?} k1 {:?} p {:.2e} sigma {:.3}",
                            f.centroids.len(),
                            f.real_stars(),
                            pixels.len(),
                            wrong - wrong_before,
                            r.focal_length_px,
                            r.k1,
                            r.false_match_probability,
                            r.centroid_sigma_px
                        );
                    }
                    Some(CalibrationFrame { pixels, stars, attitude, mirrored: r.mirrored })
                })
                .collect();
            (out, wrong)
        };
        let (before, wrong_before) = run(&nominal);
        let usable: Vec<CalibrationFrame> = before.iter().flatten().cloned().collect();
        let t = Instant::now();
        let cal = calibrate(&usable, &nominal, &CalibrationConfig::default()).expect("calibration");
        let fit_ms = t.elapsed().as_secs_f64() * 1e3;
        let (mut after, mut wrong_after) = run(&cal.camera);
        let mut cal = cal;
        // Identify and calibrate again with the camera found, while that names more stars.
        for _ in 0..3 {
            let named = |fs: &[Option<CalibrationFrame>]| {
                fs.iter().flatten().map(|f| f.pixels.len()).sum::<usize>()
            };
            let usable: Vec<CalibrationFrame> = after.iter().flatten().cloned().collect();
            let next =
                calibrate(&usable, &nominal, &CalibrationConfig::default()).expect("calibration");
            let (again, wrong_again) = run(&next.camera);
            if named(&again) <= named(&after) {
                break;
            }
            (cal, after, wrong_after) = (next, again, wrong_again);
        }
        let sig = cal.sigmas();
        let value = |p: Intrinsic, c: &Camera| match p {
            Intrinsic::FocalLength => c.focal_length_px,
            Intrinsic::Cx => c.principal_point_px[0],
            Intrinsic::Cy => c.principal_point_px[1],
            Intrinsic::K1 => c.k1,
            Intrinsic::K2 => c.k2,
            Intrinsic::K3 => c.k3,
            Intrinsic::P1 => c.p1,
            Intrinsic::P2 => c.p2,
        };
        let in_sigma: Vec<String> = cal
            .intrinsics
            .iter()
            .zip(&sig)
            .skip(3)
            .map(|(p, s)| {
                format!(
                    "{} {:+.1}",
                    p.name(),
                    (value(*p, &cal.camera) - value(*p, &truth)) / s
                )
            })
            .collect();
        let pp = Vector3::new(
            cal.camera.principal_point_px[0] - truth.principal_point_px[0],
            cal.camera.principal_point_px[1] - truth.principal_point_px[1],
            0.0,
        );
        println!(
            "{:.0}° k1 {} | {}/{frames} | {wrong_before} | {} frames, {} matches | {:+.4} (1σ {:.4}) | {:.3} (1σ {:.3}, {:.3}) | {} | {:.3} | {:.3} | {} | {}/{frames} | {wrong_after} | {fit_ms:.1}",
            lens.fov_deg,
            lens.k[0],
            before.iter().flatten().count(),
            cal.attitudes.len(),
            cal.n_inliers() + cal.n_clipped(),
            100.0 * (cal.camera.focal_length_px / truth.focal_length_px - 1.0),
            100.0 * sig[0] / truth.focal_length_px,
            pp.norm(),
            sig[1],
            sig[2],
            in_sigma.join(" "),
            cal.rms_before_px,
            cal.rms_px,
            cal.n_clipped(),
            after.iter().flatten().count(),
        );
    }
}
