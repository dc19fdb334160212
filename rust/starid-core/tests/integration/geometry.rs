use proptest::prelude::*;
use starid_core::attitude::wahba_svd;
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
}
