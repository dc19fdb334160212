use proptest::prelude::*;
use starid_core::attitude::{triad, wahba_from, wahba_svd};
use starid_core::geometry::{
    angle_between, attitude_from_radec_roll, radec_roll_from_attitude, radec_to_unit, unit_to_radec,
};

use super::strategies::{config, rotation, unit_vector};

proptest! {
    #![proptest_config(config())]

    #[test]
    fn separation_is_symmetric_and_bounded(a in unit_vector(), b in unit_vector()) {
        let (ab, ba) = (angle_between(&a, &b), angle_between(&b, &a));
        prop_assert!((ab - ba).abs() < 1e-15);
        prop_assert!((0.0..=std::f64::consts::PI).contains(&ab));
    }

    #[test]
    fn radec_round_trips(v in unit_vector()) {
        let (ra, dec) = unit_to_radec(&v);
        prop_assert!((radec_to_unit(ra, dec) - v).norm() < 1e-12);
    }

    #[test]
    fn attitude_parametrisation_round_trips(ra in 0.0..std::f64::consts::TAU, dec in -1.5..1.5f64, roll in 0.0..std::f64::consts::TAU) {
        let r = attitude_from_radec_roll(ra, dec, roll);
        let (ra2, dec2, roll2) = radec_roll_from_attitude(&r);
        let back = attitude_from_radec_roll(ra2, dec2, roll2);
        prop_assert!((back.matrix() - r.matrix()).norm() < 1e-9);
        prop_assert!((dec2 - dec).abs() < 1e-9);
    }

    #[test]
    fn wahba_recovers_random_rotations(r in rotation(), refs in proptest::collection::vec(unit_vector(), 3..12)) {
        let obs: Vec<_> = refs.iter().map(|v| r * v).collect();
        // Three or more random directions fix a rotation unless they are (nearly) collinear.
        prop_assume!(refs.iter().any(|v| v.cross(&refs[0]).norm() > 1e-3 && v.cross(&refs[1]).norm() > 1e-3));
        let est = wahba_svd(&obs, &refs).expect("a rotation");
        let err = (est.matrix() - r.matrix()).norm();
        prop_assert!(err < 1e-9, "error {}", err);
    }

    /// Gauss–Newton from a TRIAD start reaches the Wahba optimum on noisy, narrow-field data
    /// (directions within a few degrees of the boresight, where roll is weakly determined).
    #[test]
    fn gauss_newton_wahba_equals_svd(
        r in rotation(),
        offsets in proptest::collection::vec((-0.1f64..0.1, -0.1f64..0.1), 3..30),
        noise in proptest::collection::vec((-1e-4f64..1e-4, -1e-4f64..1e-4), 30),
    ) {
        let obs: Vec<_> = offsets
            .iter()
            .zip(&noise)
            .map(|(&(x, y), &(nx, ny))| nalgebra::Vector3::new(x + nx, y + ny, 1.0).normalize())
            .collect();
        let refs: Vec<_> = offsets
            .iter()
            .map(|&(x, y)| r.inverse_transform_vector(&nalgebra::Vector3::new(x, y, 1.0).normalize()))
            .collect();
        let start = triad(&obs[0], &obs[1], &refs[0], &refs[1]);
        prop_assume!(start.is_some() && (obs[0] - obs[1]).norm() > 1e-3);
        prop_assume!(obs.iter().any(|o| (o - obs[0]).cross(&(obs[1] - obs[0])).norm() > 1e-4));
        let svd = wahba_svd(&obs, &refs).expect("a rotation");
        let gn = wahba_from(&obs, &refs, &start.unwrap()).expect("a rotation");
        let cost = |q: &nalgebra::Rotation3<f64>| -> f64 {
            obs.iter().zip(&refs).map(|(b, c)| (b - q * c).norm_squared()).sum()
        };
        // Never a worse fit than the SVD (which itself loses digits when roll is weakly fixed)...
        prop_assert!(cost(&gn) <= cost(&svd) * (1.0 + 1e-9) + 1e-24, "cost GN {:e} > SVD {:e}", cost(&gn), cost(&svd));
        // ...and the same rotation to the SVD's precision.
        let diff = starid_core::geometry::rotation_angle_between(&svd, &gn);
        prop_assert!(diff < 1e-7, "Gauss-Newton and SVD differ by {} rad", diff);
    }
}
