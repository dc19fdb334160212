//! `Solver`: a catalogue with its pair indexes, and the search of one frame over them (its passes: `plan`).

use super::*;

/// A catalogue with its pair index: everything identification needs. Immutable and `Sync`:
/// share one across threads.
#[derive(Debug, Clone)]
pub struct Solver {
    pub(super) catalog: Arc<Catalog>,
    pub(super) pairs: PairIndex,
    /// Pairs among the locally bright stars; `None` when they are most of the catalogue.
    pub(super) bright_pairs: Option<PairIndex>,
    /// Catalogue magnitudes as `f32`, for the magnitude gate of the search's inner loops.
    pub(super) mag32: Vec<f32>,
    /// The same, ascending, with a bin table for counts below a magnitude.
    pub(super) mag_sorted: SortedMags,
    /// Catalogue stars per steradian in the sparsest field (cones of half the index's angle).
    pub(super) min_density_sr: f64,
    /// Catalogue stars per steradian around any direction (cones of half the index's angle),
    /// for the false-match bound of every verification; `None` for narrow fields, which count
    /// their cone instead.
    pub(super) density: Option<DensityMap>,
    /// The pair index split by magnitude, built on the first magnitude-gated pass.
    pub(super) mag_pairs: std::sync::OnceLock<MagPairIndex>,
    /// The source documents' tables, built on first use.
    pub(super) seed_tables: std::sync::OnceLock<SeedTables>,
    /// Stars per steradian around a catalogue pair (see [`Solver::pair_weighted_density`]).
    pub(super) pair_density: std::sync::OnceLock<f64>,
    /// How often a catalogue triangle has its field to itself, per camera (see `empty`).
    pub(super) empty_fields: super::empty::EmptyFieldCache,
    pub(super) build_time: Duration,
    /// The index file the pair indexes were read from or written to, if any.
    pub(super) file: Option<std::path::PathBuf>,
}

/// The pair indexes of a [`Solver`] with the star densities its bound reads: what takes time
/// to build, and what an index file keeps.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct PairIndexes {
    pub(crate) pairs: PairIndex,
    /// Pairs among the locally bright stars; `None` when they are most of the catalogue.
    pub(crate) bright_pairs: Option<PairIndex>,
    /// As [`Solver::min_density_sr`](Solver).
    pub(crate) min_density_sr: f64,
    /// As [`Solver::density`](Solver).
    pub(crate) density: Option<DensityMap>,
}

impl PairIndexes {
    /// Index `catalog` for frames whose stars are at most `max_angle_rad` apart.
    pub(crate) fn build(catalog: &Catalog, max_angle_rad: f64) -> Result<Self> {
        // A deep catalogue: index the brightest stars only (the guide stars); verification
        // still matches every centroid against the whole catalogue.
        let n_cat = catalog.len() as f64;
        let expected = 0.25 * n_cat * n_cat * (1.0 - max_angle_rad.cos());
        let guide: Option<Vec<bool>> = (expected > MAX_INDEX_PAIRS as f64).then(|| {
            let keep =
                (MAX_INDEX_PAIRS as f64 / (0.25 * (1.0 - max_angle_rad.cos()))).sqrt() as usize;
            let mut mags: Vec<f64> = catalog.mag().to_vec();
            mags.sort_unstable_by(f64::total_cmp);
            let limit = mags[keep.clamp(1, mags.len()) - 1];
            catalog.mag().iter().map(|&m| m <= limit).collect()
        });
        let pairs = PairIndex::build_among(catalog, max_angle_rad, guide.as_deref())?;
        // Half the width of a square field of this diagonal.
        let mut members =
            catalog.locally_bright(max_angle_rad / (2.0 * SQRT_2), BRIGHT_MAX_BRIGHTER);
        if let Some(g) = &guide {
            for (m, &k) in members.iter_mut().zip(g) {
                *m &= k;
            }
        }
        let bright = members.iter().filter(|&&m| m).count();
        let bright_pairs = if 5 * bright < 4 * catalog.len() {
            Some(PairIndex::build_among(
                catalog,
                max_angle_rad,
                Some(&members),
            )?)
        } else {
            None
        };
        let min_density_sr = sparsest_density(catalog, 0.5 * max_angle_rad);
        let density = DensityMap::new(0.5 * max_angle_rad, |v| {
            catalog.count_in_cone(v, 0.5 * max_angle_rad)
        });
        Ok(Self {
            pairs,
            bright_pairs,
            min_density_sr,
            density,
        })
    }
}

impl Solver {
    /// Index `catalog` for frames whose stars are at most `max_angle_rad` apart (a frame's
    /// diagonal field of view, see [`Camera::diagonal_fov_rad`]).
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.pair_index().len() > 0);
    /// ```
    pub fn new(catalog: Arc<Catalog>, max_angle_rad: f64) -> Result<Self> {
        let t = Instant::now();
        let indexes = PairIndexes::build(&catalog, max_angle_rad)?;
        Ok(Self::with_indexes(catalog, indexes, t.elapsed(), None))
    }

    /// A solver over pair indexes already built (or read from an index file, `file`), which
    /// took `build_time`.
    pub(super) fn with_indexes(
        catalog: Arc<Catalog>,
        indexes: PairIndexes,
        build_time: Duration,
        file: Option<std::path::PathBuf>,
    ) -> Self {
        let mag32: Vec<f32> = catalog.mag().iter().map(|&m| m as f32).collect();
        let mag_sorted = SortedMags::new(&mag32);
        Self {
            catalog,
            pairs: indexes.pairs,
            bright_pairs: indexes.bright_pairs,
            min_density_sr: indexes.min_density_sr,
            density: indexes.density,
            mag32,
            mag_sorted,
            mag_pairs: std::sync::OnceLock::new(),
            seed_tables: std::sync::OnceLock::new(),
            pair_density: std::sync::OnceLock::new(),
            empty_fields: Default::default(),
            build_time,
            file,
        }
    }

    /// Index `catalog` for frames of `camera`.
    ///
    /// # Errors
    /// As [`PairIndex::build`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let cam = starid_core::Camera::from_fov(0.2, 512.0, 512.0).unwrap();
    /// let solver = starid_core::Solver::for_camera(std::sync::Arc::new(cat), &cam).unwrap();
    /// assert!(solver.pair_index().max_angle_rad() >= cam.diagonal_fov_rad());
    /// ```
    pub fn for_camera(catalog: Arc<Catalog>, camera: &Camera) -> Result<Self> {
        Self::new(catalog, camera.diagonal_fov_rad())
    }

    /// The catalogue.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.catalog().len(), 3000);
    /// ```
    pub fn catalog(&self) -> &Arc<Catalog> {
        &self.catalog
    }

    /// The pair index.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.pair_index().max_angle_rad() >= 0.3);
    /// ```
    pub fn pair_index(&self) -> &PairIndex {
        &self.pairs
    }

    /// The pair index over locally bright stars only, searched first when magnitudes are
    /// given (`None` when those stars are most of the catalogue).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// if let Some(b) = solver.bright_pair_index() {
    ///     assert!(b.len() < solver.pair_index().len());
    /// }
    /// ```
    pub fn bright_pair_index(&self) -> Option<&PairIndex> {
        self.bright_pairs.as_ref()
    }

    /// Heap memory of the indexes in bytes: the pair indexes, the density map, and the
    /// magnitude-split index and the source documents' tables once built.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.memory_bytes() >= solver.pair_index().memory_bytes());
    /// ```
    pub fn memory_bytes(&self) -> usize {
        self.pairs.memory_bytes()
            + self
                .bright_pairs
                .as_ref()
                .map_or(0, PairIndex::memory_bytes)
            + self.mag_pairs.get().map_or(0, MagPairIndex::memory_bytes)
            + self.seed_tables_bytes()
            + self.density.as_ref().map_or(0, DensityMap::memory_bytes)
    }

    /// Memory of the source documents' tables, bytes; 0 until a method of theirs (or
    /// [`Solver::seed_tables`]) builds them.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.seed_tables_bytes(), 0);
    /// solver.seed_tables();
    /// assert!(solver.seed_tables_bytes() > 0);
    /// ```
    pub fn seed_tables_bytes(&self) -> usize {
        self.seed_tables.get().map_or(0, SeedTables::memory_bytes)
    }

    /// Memory of the magnitude-split index, bytes; 0 until a gated search (or
    /// [`Solver::mag_pair_index`]) builds it.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert_eq!(solver.magnitude_index_bytes(), 0);
    /// solver.mag_pair_index();
    /// assert!(solver.magnitude_index_bytes() > 0);
    /// ```
    pub fn magnitude_index_bytes(&self) -> usize {
        self.mag_pairs.get().map_or(0, MagPairIndex::memory_bytes)
    }

    /// Mean over `windows` of the fraction of catalogue stars no fainter than each window's
    /// faint end: the stars a centroid may match in verification.
    pub(crate) fn window_fraction(&self, windows: &[[f32; 2]]) -> f64 {
        let sorted = &self.mag_sorted;
        let n = sorted.len().max(1) as f64;
        let total: f64 = windows
            .iter()
            .map(|w| sorted.count_at_most(w[1]) as f64 / n)
            .sum();
        (total / windows.len().max(1) as f64).clamp(1.0 / n, 1.0)
    }

    /// The pair index split by magnitude bins, for magnitude-gated searches (built on first use,
    /// once, whichever thread asks first).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.mag_pair_index().memory_bytes() > 0); // built on first use
    /// ```
    pub fn mag_pair_index(&self) -> &MagPairIndex {
        self.mag_pairs
            .get_or_init(|| MagPairIndex::build(&self.pairs, self.catalog.vectors(), &self.mag32))
    }

    /// The tables of the source documents' methods (neighbours, line angles, angle sums, ring
    /// counts) for square fields of the index's diagonal, built on first use, once.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// let t = solver.seed_tables();
    /// assert!(t.ring_bytes() == 3 * 3000 && t.angle_sum_bytes() > 0);
    /// ```
    pub fn seed_tables(&self) -> &SeedTables {
        self.seed_tables
            .get_or_init(|| SeedTables::build(&self.catalog, self.pairs.max_angle_rad() / SQRT_2))
    }

    /// The database `method` searches: `(bytes, build time)`. Pyramid, voting, angular
    /// distance and distance voting search the pair indexes (and the magnitude index once
    /// built); the other source documents' methods their own tables (built now if needed).
    ///
    /// # Example
    /// ```
    /// use starid_core::Method;
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// let (pairs, _) = solver.method_database(Method::AngularDistance);
    /// let (rings, _) = solver.method_database(Method::RadialVote);
    /// assert!(rings < pairs);
    /// ```
    pub fn method_database(&self, method: Method) -> (usize, Duration) {
        match method {
            Method::StarLineAngle => {
                let t = self.seed_tables();
                (t.star_line_angle_bytes(), t.neighbour_build_time())
            }
            Method::AngleSum => {
                let t = self.seed_tables();
                (t.angle_sum_bytes(), t.neighbour_build_time())
            }
            Method::RadialVote => {
                let t = self.seed_tables();
                (t.ring_bytes(), t.ring_build_time())
            }
            Method::AngularDistance | Method::DistanceVote => {
                (self.pairs.memory_bytes(), self.build_time)
            }
            _ => (self.memory_bytes(), self.build_time),
        }
    }

    /// Catalogue stars per steradian in the sparsest field of the sky (cones of half the
    /// index's angle, sampled at 2000 directions): what the search's early stop assumes.
    pub(crate) fn min_density_sr(&self) -> f64 {
        self.min_density_sr
    }

    /// Catalogue magnitudes as `f32`.
    pub(crate) fn mag_f32(&self) -> &[f32] {
        &self.mag32
    }

    /// Time it took to build the pair indexes (or to read them from an index file).
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.build_time().as_secs_f64() < 60.0);
    /// ```
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// The index file its pair indexes were read from or written to (see
    /// [`SolverCache::solver_stored`]); `None` when they were built and not stored.
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(3000, 1.0, 6.0, 1).unwrap();
    /// let solver = starid_core::Solver::new(std::sync::Arc::new(cat), 0.3).unwrap();
    /// assert!(solver.index_file().is_none());
    /// ```
    pub fn index_file(&self) -> Option<&std::path::Path> {
        self.file.as_deref()
    }

    /// Identify the stars of one frame.
    ///
    /// `centroids` are pixel `(x, y)`, x right, y down, origin at the sensor's top-left corner;
    /// `magnitudes`, when given, one instrument magnitude per centroid (smaller is brighter), in
    /// any zero point: their order decides which stars are searched first (among the locally
    /// bright catalogue stars, then among all), and a match far brighter than its catalogue
    /// star is dropped ([`MAG_BRIGHTER_LIMIT`]).
    ///
    /// With [`IdentifyConfig::focal_check`] (the default), a verified solution that leaves spots
    /// unnamed is checked for a focal length off; a significant one sends the frame back to the
    /// search with the focal length the residuals imply (see [`scale`]), and the result then
    /// carries it in [`Identification::focal_length_px`].
    ///
    /// # Errors
    /// `InvalidInput` for fewer than [`MIN_CENTROIDS`] or more than [`MAX_CENTROIDS`] centroids,
    /// non-finite or duplicate centroids, centroids off the sensor, magnitudes of the wrong
    /// length or non-finite, or an invalid `config`. A frame that cannot be identified is not
    /// an error: see [`Identification::status`].
    ///
    /// # Example
    /// ```
    /// use starid_core::{simulate, Camera, IdentifyConfig, SimConfig, Solver};
    /// let cat = std::sync::Arc::new(starid_core::simulate::random_catalog(8000, 1.0, 6.5, 2).unwrap());
    /// let cam = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
    /// let solver = Solver::for_camera(cat.clone(), &cam).unwrap();
    ///
    /// let frame = simulate(&cat, &cam, &SimConfig { noise_px: 0.2, ..Default::default() }, 3).unwrap();
    /// let id = solver.identify(&frame.centroids, Some(&frame.magnitudes), &cam, &IdentifyConfig::default()).unwrap();
    /// assert!(id.is_identified());
    /// for (got, truth) in id.catalog_index.iter().zip(&frame.catalog_index) {
    ///     assert!(got.is_none() || got == truth); // never a wrong id
    /// }
    /// ```
    pub fn identify(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
    ) -> Result<Identification> {
        self.identify_with(centroids, magnitudes, camera, config, true)
    }

    /// [`Solver::identify`]; `lone` false for a camera a search found rather than the one
    /// given: the lone-triangle test (whose bound counts one camera) is not tried then.
    pub(crate) fn identify_with(
        &self,
        centroids: &[[f64; 2]],
        magnitudes: Option<&[f64]>,
        camera: &Camera,
        config: &IdentifyConfig,
        lone: bool,
    ) -> Result<Identification> {
        let call = Call::checked(centroids, magnitudes, camera, config)?;
        let start = call.start;
        // A field given as an estimate: a short search at the focal length given, then the
        // search within the tolerance's range, and only then the rest of the budget at the
        // focal length given (a field a few percent off would spend it all to find nothing).
        // (The short search's solution is the full one's: the search tries hypotheses in the
        // same order whatever its budget.)
        let (shortest, longest) = config.focal_range_px(camera);
        let mut ranged = None;
        let mut quick_found = None;
        if lone && shortest < longest && config.max_pairs_visited > QUICK_FIRST_PAIRS {
            let quick = IdentifyConfig {
                max_pairs_visited: QUICK_FIRST_PAIRS,
                ..config.clone()
            };
            let first = self.search_frame(Call {
                config: &quick,
                ..call
            })?;
            if first.verified {
                quick_found = Some(first);
            } else {
                let mut found = Identification::unidentified(
                    Status::NoMatch,
                    centroids.len(),
                    0,
                    start.elapsed(),
                );
                ranged = self.search_within_tolerance(call, &mut found, None, false)?;
                if found.verified {
                    found.hypotheses += first.hypotheses;
                    found.noise_source = NoiseSource::of(config, &found);
                    found.elapsed = start.elapsed();
                    return Ok(found);
                }
            }
        }
        let mut id = match quick_found {
            Some(id) => id,
            None => self.search_frame(call)?,
        };
        // Three stars among false spots: the triangle's own evidence, where its bound allows.
        let searched = matches!(id.status, Status::NoMatch | Status::SearchLimit);
        if lone && (searched || (id.status == Status::TooFewStars && centroids.len() == 3)) {
            if let Some(found) = self.search_lone(call) {
                id = found;
            }
        }
        // A solution that names every spot leaves no star out by a focal error worth a search.
        if config.focal_check && id.verified && id.matched < centroids.len() {
            self.check_focal(call, &mut id)?;
        }
        self.count_scale_freedom(&mut id, call);
        if self.field_in_doubt(&id, call) {
            self.search_within_tolerance(call, &mut id, ranged, true)?;
        }
        // A frame still unnamed when its time ran out says so, not that nothing matched (the
        // searches within the tolerance stop at the time limit, or are not begun after it).
        let spent = config.timeout.is_some_and(|t| start.elapsed() >= t);
        if spent && matches!(id.status, Status::NoMatch | Status::SearchLimit) {
            id.status = Status::Timeout;
        }
        id.noise_source = NoiseSource::of(config, &id);
        id.elapsed = start.elapsed();
        Ok(id)
    }

    /// One search of a validated frame with the camera as given.
    pub(crate) fn search_frame(&self, call: Call<'_>) -> Result<Identification> {
        let (centroids, magnitudes, _, config, start) = call.parts();
        let n = centroids.len();
        if n < MIN_CENTROIDS {
            let mut id = Identification::unidentified(Status::TooFewStars, n, 0, start.elapsed());
            id.method = config.method;
            return Ok(id);
        }
        // The frame's buffers come from the thread's scratch and go back to it at the end.
        let (mut scratch, mut frame) = take_prepared(&call);
        let FrameBuffers {
            obs,
            obs_mirrored,
            order,
            passes,
        } = &mut frame;
        let ladder = config.search_ladder(&SIGMA_LADDER_PX);
        let gated = self.magnitudes_fit(magnitudes, config);
        self.passes(n, &ladder, magnitudes.is_some(), gated, config, passes);
        // Catalogue-magnitude windows of each centroid (known zero point): the tight one first
        // (fewer hypotheses compete, so a solution of few stars can pass the bound), then the
        // configured one.
        let windows = |tol: f64| -> Option<Vec<[f32; 2]>> {
            match (magnitudes, config.mag_offset) {
                (Some(m), Some(off)) if gated => {
                    Some(m.iter().map(|&mi| magnitude_window(mi, off, tol)).collect())
                }
                _ => None,
            }
        };
        // Made when a gated pass first needs them (most frames end in the bright pass before).
        let gate = std::cell::OnceCell::new();
        let gate_tight = std::cell::OnceCell::new();
        let fraction =
            |g: &Option<Vec<[f32; 2]>>| g.as_deref().map_or(1.0, |g| self.window_fraction(g));
        let mut gated_ran = false;
        let mut fraction_normal = None;
        let stride = passes
            .iter()
            .filter(|p| !p.gated)
            .map(|p| p.stars)
            .max()
            .unwrap_or(3)
            .min(n);
        scratch.forget_angles(stride);
        let mut search = Search::of_call(self, call, [obs, obs_mirrored], order, scratch, stride);
        let mut status = Status::NoMatch;
        // Set when the gated passes spent the budget: only the closing pass runs then.
        let mut closing_only = false;
        for &pass in passes.iter() {
            if closing_only && !pass.closing {
                continue;
            }
            search.pairs = if pass.bright {
                self.bright_pairs.as_ref().unwrap_or(&self.pairs)
            } else {
                &self.pairs
            };
            let (gate, gate_tight) = if pass.gated {
                (
                    gate.get_or_init(|| windows(config.mag_tolerance)),
                    gate_tight.get_or_init(|| windows(TIGHT_MAG_FRACTION * config.mag_tolerance)),
                )
            } else {
                (&None, &None)
            };
            if pass.gated {
                search.gate_fraction = *fraction_normal.get_or_insert_with(|| fraction(gate));
                // Gated passes search more stars: a wider angle cache.
                let wide = pass.stars.min(n);
                if wide > search.stride {
                    search.stride = wide;
                    search.scratch.forget_angles(wide);
                }
            }
            search.gate = if pass.gated { gate.as_deref() } else { None };
            search.gen_gate = if pass.gated && pass.tight {
                gate_tight.as_deref()
            } else {
                None
            };
            if pass.gated {
                let stride = search.stride;
                search.scratch.side_cache.reset(stride);
            }
            // After gated passes (a crowded frame with calibrated magnitudes), the ungated
            // passes that follow, the fallback for magnitudes that mislead, get a budget too.
            search.pass_pairs_limit = if closing_only {
                search.pairs_visited.saturating_add(CLOSING_LOOSE_PAIRS)
            } else if pass.gated {
                gated_ran = true;
                search.pairs_visited.saturating_add(pass.pairs_budget)
            } else if gated_ran {
                // After gated passes (calibrated magnitudes, nothing found), the ungated passes
                // are a short fallback: a frame whose magnitudes mislead should say so
                // (`mag_offset: None`) and is then searched without the gate, in full.
                search.pairs_visited.saturating_add(FALLBACK_PAIRS_PER_STEP)
            } else if n > config.max_search_stars {
                // A crowded frame searched by its brightest spots alone: most are false, and a
                // search that has not found an all-real triangle yet seldom will.
                search
                    .pairs_visited
                    .saturating_add(CROWDED_PAIRS_PER_STEP.min(pass.pairs_budget))
            } else {
                // A pass's own budget (the loosest step's: see LOOSEST_STEP_SHARE), if any.
                search.pairs_visited.saturating_add(pass.pairs_budget)
            };
            search.method = pass.method;
            let work_before = search.pairs_visited;
            let found = match pass.method {
                Method::Voting => search.vote(pass.stars, pass.sigma_px),
                m if m.is_seed() => search.seed(m, pass.stars, pass.sigma_px),
                _ => search.run(pass.stars, pass.sigma_px, pass.cap),
            };
            if pass.gated {
                search.gated_work += search.pairs_visited - work_before;
            }
            match found {
                Ok(Some(v)) => {
                    let hypotheses = search.hypotheses;
                    let method = search.method;
                    let mut scratch = search.scratch;
                    scratch.frame = frame;
                    return_scratch(scratch);
                    let mut id = v.into_identification(hypotheses, start.elapsed());
                    id.method = method;
                    return Ok(id);
                }
                Ok(None) => {}
                Err(SearchLimit(Status::SearchLimit)) if pass.gated && !closing_only => {
                    // The budget, spent by the gated passes (whose work then no longer counts
                    // against it, as above): the closing pass still runs.
                    status = Status::SearchLimit;
                    closing_only = true;
                }
                Err(SearchLimit(why)) => {
                    status = why;
                    break;
                }
            }
        }
        let hypotheses = search.hypotheses;
        let mut scratch = search.scratch;
        scratch.frame = frame;
        return_scratch(scratch);
        let mut id = Identification::unidentified(status, n, hypotheses, start.elapsed());
        id.method = config.method;
        Ok(id)
    }

    /// Whether the centroids' magnitudes fit the catalogue's system (after `mag_offset`): most
    /// centroids' windows hold catalogue stars. An arbitrary instrument zero point (or
    /// magnitudes that mislead) puts them outside, and the frame is searched without the gate.
    pub(crate) fn magnitudes_fit(
        &self,
        magnitudes: Option<&[f64]>,
        config: &IdentifyConfig,
    ) -> bool {
        match (magnitudes, config.mag_offset) {
            (Some(m), Some(off)) => {
                let tol = config.mag_tolerance;
                let sorted = &self.mag_sorted;
                // More than half the centroids have a catalogue star in their window: stop
                // counting once that is known.
                let need = m.len() / 2 + 1;
                m.iter()
                    .filter(|&&mi| {
                        let [lo, hi] = magnitude_window(mi, off, tol);
                        sorted.first_at_least(lo).is_some_and(|x| x <= hi)
                    })
                    .take(need)
                    .count()
                    >= need
            }
            _ => false,
        }
    }
}

/// The early stop's density: this quantile (per mille) of the fields' star counts.
pub(crate) const SPARSE_QUANTILE_PERMILLE: usize = 50;

/// Stars per steradian in the sparsest of 2000 cones of `radius_rad` spread evenly over the
/// sky (a Fibonacci lattice), at least one star per cone.
pub(crate) fn sparsest_density(catalog: &Catalog, radius_rad: f64) -> f64 {
    pub(crate) const CONES: usize = 2000;
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut counts: Vec<usize> = (0..CONES)
        .map(|k| {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / CONES as f64;
            let rho = (1.0 - z * z).sqrt();
            let phi = golden * k as f64;
            let v = Vector3::new(rho * phi.cos(), rho * phi.sin(), z);
            catalog.count_in_cone(&v, radius_rad)
        })
        .collect();
    counts.sort_unstable();
    let least = counts[CONES * SPARSE_QUANTILE_PERMILLE / 1000].max(1);
    least as f64 / (2.0 * std::f64::consts::PI * (1.0 - radius_rad.cos()))
}
