use std::collections::BTreeSet;

use proptest::prelude::*;
use starid_core::geometry::angle_between;
use starid_core::kvector::AngleWindow;
use starid_core::simulate::random_catalog;
use starid_core::PairIndex;

use super::strategies::config;

proptest! {
    #![proptest_config(config())]

    /// A range query returns every pair a brute-force scan finds, and nothing further outside
    /// than its slack; the exact query returns exactly them.
    #[test]
    fn range_query_equals_brute_force(
        n in 2usize..400,
        seed in any::<u64>(),
        max_angle in 0.02f64..1.0,
        queries in proptest::collection::vec((0.0f64..1.0, 0.0f64..0.05), 1..20),
    ) {
        let cat = random_catalog(n, 1.0, 6.0, seed).unwrap();
        let idx = PairIndex::build(&cat, max_angle).unwrap();
        let v = cat.vectors();
        let mut all = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let a = angle_between(&v[i], &v[j]);
                if a <= max_angle {
                    all.push((a, [i as u32, j as u32]));
                }
            }
        }
        prop_assert_eq!(idx.len(), all.len());
        let angle = |[i, j]: [u32; 2]| angle_between(&v[i as usize], &v[j as usize]);
        let slack = idx.slack_rad();
        for (frac, half_width) in queries {
            let centre = frac * max_angle;
            let (lo, hi) = (centre - half_width, centre + half_width);
            let got: BTreeSet<[u32; 2]> = idx.pairs(idx.range(lo, hi)).collect();
            // Pairs a rounding's breadth from an end may fall either way.
            let want: BTreeSet<[u32; 2]> =
                all.iter().filter(|(a, _)| *a >= lo + 1e-9 && *a <= hi - 1e-9).map(|(_, p)| *p).collect();
            prop_assert!(got.is_superset(&want));
            prop_assert!(got.iter().all(|&p| angle(p) >= lo - slack && angle(p) <= hi + slack));
            let exact: BTreeSet<[u32; 2]> =
                idx.pairs(idx.range_exact(&AngleWindow::new(lo, hi), v)).collect();
            prop_assert!(exact.is_superset(&want));
            prop_assert!(exact.iter().all(|&p| angle(p) >= lo - 1e-9 && angle(p) <= hi + 1e-9));
        }
    }
}

proptest! {
    #![proptest_config(config())]

    /// An index among some stars holds exactly the pairs of the full index whose two stars are
    /// members, and locally bright stars are those with fewer than k brighter within the radius.
    #[test]
    fn index_among_members_and_locally_bright_stars(
        n in 2usize..400,
        seed in any::<u64>(),
        max_angle in 0.05f64..0.8,
        k in 1usize..8,
    ) {
        let cat = random_catalog(n, 1.0, 6.0, seed).unwrap();
        let radius = 0.5 * max_angle;
        let bright = cat.locally_bright(radius, k);
        let v = cat.vectors();
        let m = cat.mag();
        for i in 0..n {
            let brighter = (0..n)
                .filter(|&j| j != i && angle_between(&v[i], &v[j]) <= radius)
                .filter(|&j| m[j] < m[i] || (m[j] == m[i] && j < i))
                .count();
            prop_assert_eq!(bright[i], brighter < k, "star {}", i);
        }
        let full = PairIndex::build(&cat, max_angle).unwrap();
        let among = PairIndex::build_among(&cat, max_angle, Some(&bright)).unwrap();
        let want: BTreeSet<[u32; 2]> = full
            .pairs(0..full.len())
            .filter(|p| bright[p[0] as usize] && bright[p[1] as usize])
            .collect();
        let got: BTreeSet<[u32; 2]> = among.pairs(0..among.len()).collect();
        prop_assert_eq!(got, want);
        prop_assert!(PairIndex::build_among(&cat, max_angle, Some(&bright[1..])).is_err());
    }
}

#[test]
fn rejects_absurd_angles_and_oversized_indexes() {
    let cat = random_catalog(100, 1.0, 6.0, 1).unwrap();
    assert!(PairIndex::build(&cat, 0.0).is_err());
    assert!(PairIndex::build(&cat, f64::NAN).is_err());
    assert!(PairIndex::build(&cat, 4.0).is_err());
    let big = random_catalog(40_000, 1.0, 6.0, 1).unwrap();
    let e = PairIndex::build(&big, 3.0).unwrap_err();
    assert!(e.to_string().contains("pairs"), "{e}");
}
