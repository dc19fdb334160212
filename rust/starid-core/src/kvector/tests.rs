//! The k-vector's unit tests.

use super::*;

#[test]
fn bucket_sort_orders_keys_as_a_comparison_sort() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let max = 0.3f64;
    for n in [0usize, 1, 31, 1000, 20_000] {
        let mut keys: Vec<u64> = (0..n)
            .map(|_| {
                // Repeated separations, both ends, and one rounded just past the maximum.
                let a = match rng.random_range(0..10) {
                    0 => 0.0f32,
                    1 => max as f32,
                    2 => f32::from_bits((max as f32).to_bits() + 1),
                    3 => 0.1,
                    _ => rng.random_range(0.0..max) as f32,
                };
                let (i, j) = (
                    rng.random_range(0..60_000u64),
                    rng.random_range(0..60_000u64),
                );
                (u64::from(a.to_bits()) << 32) | (i << 16) | j
            })
            .collect();
        let mut expected = keys.clone();
        expected.sort_unstable();
        sort_keys(&mut keys, max);
        assert_eq!(keys, expected, "{n} keys");
    }
}

#[test]
fn range_holds_every_answer_and_nothing_beyond_its_slack() {
    // Separations with repeats, gaps and both ends.
    let angles: Vec<f32> = (0..400u32)
        .map(|i| 0.1 + 0.001 * (i - i % 3) as f32 + if i > 300 { 0.2 } else { 0.0 })
        .collect();
    let pairs = PairStore::Wide((0..400).map(|i| [i, i + 1]).collect());
    let idx = PairIndex::from_sorted(&angles, pairs, 1.0);
    let slack = idx.slack_rad();
    for (lo, hi) in [
        (0.2, 0.2),
        (0.0, 1.0),
        (0.25, 0.31),
        (0.39, 0.52),
        (0.1, 0.1),
        (0.699, 0.8),
    ] {
        let (all, sure) = idx.range_parts(lo, hi);
        assert!(all.start <= sure.start && sure.end <= all.end);
        for (i, &a) in angles.iter().enumerate() {
            let a = f64::from(a);
            if (lo..=hi).contains(&a) {
                assert!(all.contains(&i), "{lo}..{hi} misses {a}");
            }
            if all.contains(&i) {
                assert!(a >= lo - slack && a <= hi + slack, "{lo}..{hi} holds {a}");
            }
            if sure.contains(&i) {
                assert!(
                    a >= lo - 1e-7 && a <= hi + 1e-7,
                    "{lo}..{hi} is sure of {a}"
                );
            }
        }
    }
    for (lo, hi) in [
        (0.3, 0.2),
        (-1.0, 0.05),
        (0.9, 1.0),
        (f64::NAN, 0.2),
        (0.2, f64::NAN),
    ] {
        assert!(idx.range(lo, hi).is_empty(), "{lo}..{hi}");
    }
}

#[test]
fn packed_keys_sort_the_pairs_as_the_comparison_does() {
    // The narrow build sorts packed integers; the order must be (separation by total_cmp,
    // then the two stars), as the tuple comparison gives it. Repeated separations (a grid
    // of stars) make the stars decide often.
    for (cat, max) in [
        (
            crate::simulate::random_catalog(3000, 1.0, 6.0, 4).unwrap(),
            0.2,
        ),
        (
            crate::simulate::random_catalog(20, 1.0, 6.0, 5).unwrap(),
            3.0,
        ),
    ] {
        let idx = PairIndex::build(&cat, max).unwrap();
        let mut entries = neighbour_pairs(&cat, max, None, |a, i, j| (a, [i, j]));
        entries.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        assert_eq!(idx.len(), entries.len());
        assert!(idx.pairs(0..idx.len()).eq(entries.iter().map(|e| e.1)));
    }
    // An 8 x 8 grid half a degree apart, near the equator: many equal separations.
    let grid = Catalog::new(
        (1..=64).collect(),
        &(0..64).map(|i| f64::from(i % 8) * 0.5).collect::<Vec<_>>(),
        &(0..64).map(|i| f64::from(i / 8) * 0.5).collect::<Vec<_>>(),
        vec![5.0; 64],
    )
    .unwrap();
    let idx = PairIndex::build(&grid, 0.2).unwrap();
    let mut entries = neighbour_pairs(&grid, 0.2, None, |a, i, j| (a, [i, j]));
    assert_eq!(entries.len(), 64 * 63 / 2);
    entries.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    assert!(entries.windows(2).any(|w| w[0].0 == w[1].0));
    assert!(idx.pairs(0..idx.len()).eq(entries.iter().map(|e| e.1)));
}

#[test]
fn narrow_and_wide_storage_hold_the_same_pairs() {
    let small = crate::simulate::random_catalog(3000, 1.0, 6.0, 9).unwrap();
    let narrow = PairIndex::build(&small, 0.1).unwrap();
    assert!(matches!(narrow.pairs, PairStore::Narrow(_)));
    let all: Vec<[u32; 2]> = narrow.pairs(0..narrow.len()).collect();
    let v = small.vectors();
    let angles: Vec<f32> = all
        .iter()
        .map(|&[i, j]| crate::geometry::angle_between(&v[i as usize], &v[j as usize]) as f32)
        .collect();
    let wide = PairIndex::from_sorted(&angles, PairStore::Wide(all.clone()), 0.1);
    for (lo, hi) in [(0.0, 0.1), (0.03, 0.031), (0.05, 0.2)] {
        let (a, b) = (narrow.range(lo, hi), wide.range(lo, hi));
        assert_eq!(a, b);
        assert!(narrow.pairs(a.clone()).eq(wide.pairs(b)));
        assert_eq!(narrow.pairs(a.clone()).len(), a.len());
    }
    assert_eq!(narrow.memory_bytes() + 4 * all.len(), wide.memory_bytes());
    assert_eq!(
        narrow.memory_bytes(),
        PairIndex::memory_bytes_for(all.len(), 3000)
    );
    // Past 65 536 stars, indices take 32 bits.
    let big = crate::simulate::random_catalog(NARROW_PAIR_STARS + 10, 1.0, 6.0, 9).unwrap();
    let idx = PairIndex::build(&big, 0.004).unwrap();
    assert!(matches!(idx.pairs, PairStore::Wide(_)));
    assert!(idx
        .pairs(0..idx.len())
        .any(|p| p[1] as usize >= NARROW_PAIR_STARS));
    assert_eq!(
        idx.memory_bytes(),
        PairIndex::memory_bytes_for(idx.len(), big.len())
    );
}
