use starid_core::simulate::{simulate_sequence, SequenceConfig, SimConfig};
use starid_core::tracking::{TrackMode, Tracker, TrackerConfig, CONFIRM_UNSEEN_FRAMES};
use starid_core::{Camera, ErrorKind, IdentifyConfig, SimFrame, Solver};

use super::strategies::bundled;

fn camera_12() -> Camera {
    Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap()
}

fn solver_12() -> &'static Solver {
    static S: std::sync::OnceLock<Solver> = std::sync::OnceLock::new();
    S.get_or_init(|| Solver::for_camera(bundled(), &camera_12()).unwrap())
}

/// Where `star` falls on the sensor of frame `f` (its true attitude and handedness).
fn pixel_of(f: &SimFrame, star: u32, cam: &Camera) -> Option<[f64; 2]> {
    let v = bundled().vectors()[star as usize];
    let (mut x, y) = cam.cam_to_pixel(&(f.r_icrs_to_cam * v))?;
    if f.mirrored {
        x = cam.width_px - x;
    }
    Some([x, y])
}

/// A false spot placed on `star` (too faint for the camera) in frame `f`: returns the spot's
/// index.
fn spot_on(f: &mut SimFrame, star: u32, cam: &Camera) -> usize {
    let [x, y] = pixel_of(f, star, cam).expect("the star is in front");
    f.centroids.push([x + 0.1, y - 0.1]);
    f.magnitudes.push(bundled().mag()[star as usize]);
    f.catalog_index.push(None);
    f.centroids.len() - 1
}

#[test]
fn a_false_spot_on_a_star_the_camera_never_saw_waits_for_a_second_frame() {
    let (cat, cam, solver) = (bundled(), camera_12(), solver_12());
    let limit = 6.0;
    let seq = simulate_sequence(
        &cat,
        &cam,
        &SequenceConfig {
            frames: 24,
            rate_rad_s: 0.3f64.to_radians(),
            frame: SimConfig {
                mag_limit: Some(limit),
                noise_px: 0.2,
                mag_noise: 0.05,
                ..Default::default()
            },
            ..Default::default()
        },
        11,
    )
    .unwrap();
    // A star too faint to be imaged that stays well inside the sensor the whole time.
    let inside = |p: Option<[f64; 2]>| {
        p.is_some_and(|[x, y]| (40.0..472.0).contains(&x) && (40.0..472.0).contains(&y))
    };
    let faint = (0..cat.len() as u32)
        .filter(|&s| cat.mag()[s as usize] > limit + 0.15)
        .find(|&s| seq.iter().all(|f| inside(pixel_of(&f.frame, s, &cam))))
        .expect("a faint star inside the field");
    let first = CONFIRM_UNSEEN_FRAMES as usize + 2;
    let run = |config: TrackerConfig| -> Vec<Option<u32>> {
        let mut tracker = Tracker::new(config, IdentifyConfig::default()).unwrap();
        let mut named = Vec::new();
        for (i, f) in seq.iter().enumerate().take(first + 2) {
            let mut frame = f.frame.clone();
            let spot = (i >= first).then(|| spot_on(&mut frame, faint, &cam));
            let step = tracker
                .update(
                    solver,
                    &frame.centroids,
                    Some(&frame.magnitudes),
                    &cam,
                    f.t_s,
                )
                .unwrap();
            assert!(step.identification.is_identified(), "frame {i}");
            assert_eq!(step.mode == TrackMode::Tracking, i > 0, "frame {i}");
            // The real stars are never named wrongly.
            for (got, want) in step
                .identification
                .catalog_index
                .iter()
                .zip(&frame.catalog_index)
            {
                assert!(got.is_none() || got == want || Some(*got) == spot.map(|_| Some(faint)));
            }
            if let Some(o) = spot {
                named.push(step.identification.catalog_index[o]);
            }
        }
        named
    };
    // Without the rule the false spot is named after the faint star at once: the case is real.
    let off = run(TrackerConfig {
        confirm_unseen_frames: None,
        ..TrackerConfig::default()
    });
    assert_eq!(off, vec![Some(faint), Some(faint)]);
    // With it, the first frame holds it back; a second frame in a row that matches it names it.
    let on = run(TrackerConfig::default());
    assert_eq!(on, vec![None, Some(faint)]);
}

#[test]
fn confirm_unseen_frames_of_zero_is_refused() {
    let err = Tracker::new(
        TrackerConfig {
            confirm_unseen_frames: Some(0),
            ..TrackerConfig::default()
        },
        IdentifyConfig::default(),
    )
    .unwrap_err();
    assert_eq!(*err.kind(), ErrorKind::InvalidInput);
    assert!(err.to_string().contains("confirm_unseen_frames"));
}
