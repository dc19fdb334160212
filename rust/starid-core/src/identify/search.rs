//! The state of one search: `Search`, the hypothesis it verified (`Verified`) and why it stopped (`SearchLimit`).

use super::*;

/// The search must stop: the hypothesis budget or the time ran out.
pub(super) struct SearchLimit(pub(super) Status);

/// A frame's own buffers in a lost-in-space search: its directions, order and passes.
#[derive(Default)]
pub(super) struct FrameBuffers {
    pub(super) obs: Vec<Vector3<f64>>,
    pub(super) obs_mirrored: Vec<Vector3<f64>>,
    pub(super) order: Vec<usize>,
    pub(super) passes: Vec<Pass>,
}

/// Reusable buffers: no allocation per hypothesis.
#[derive(Default)]
pub(super) struct Scratch {
    /// The frame being searched (taken out of the scratch while the search borrows it).
    pub(super) frame: FrameBuffers,
    /// Binomial tails each pass needs again.
    pub(super) tails: join::TailMemo,
    pub(super) adj_ik: join::Adjacency,
    pub(super) triangles: Vec<[u32; 3]>,
    pub(super) matches: Vec<Option<(u32, f64)>>,
    pub(super) claim: Vec<(u32, u32, f64)>,
    pub(super) obs_matched: Vec<Vector3<f64>>,
    pub(super) ref_matched: Vec<Vector3<f64>>,
    /// The star of each centroid in the matches the attitude was last fitted to.
    pub(super) fitted: Vec<Option<u32>>,
    /// Instrument minus catalogue magnitude of the matches, then their absolute deviations.
    pub(super) mag_offsets: Vec<f64>,
    /// Angles between the search stars with their cosines and sines (`[t, cos t, sin t]`,
    /// row-major with `Search::stride`, computed when first needed), kept across the passes: the
    /// observed directions do not change between them.
    pub(super) angles: Vec<[f64; 3]>,
    /// One bit per entry of `angles`: whether it was computed for this frame. (Marking a
    /// frame's entries unknown clears these bits: writing NaN over every entry, 14 kB for 24
    /// search stars, cost 600 instructions and 90 cache misses per S1 frame.)
    pub(super) angle_known: Vec<u64>,
    /// Each centroid pair's range in the pair index of an ungated Pyramid step (row-major with
    /// `Search::stride`), and one bit per entry: whether the step has found it yet.
    pub(super) side_ranges: (Vec<[u32; 2]>, Vec<u64>),
    /// Sub-index ranges of each centroid pair of a gated pass, read once per pass.
    pub(super) side_cache: SideCache,
    /// Centroids torn between two stars in the last matching pass.
    pub(super) ambiguous: Vec<(u32, [(u32, f64); 2])>,
    /// Voting counters (centroid row × catalogue star) and the cells touched.
    pub(super) votes: Vec<u16>,
    pub(super) vote_touched: Vec<u32>,
    /// The catalogue stars near each centroid under the last attitude looked up.
    pub(super) near: near::NearCache,
    /// Which centroid claimed each catalogue star in the last matching pass.
    pub(super) claims: near::Claims,
}

impl Scratch {
    /// Room for each pair of `stride` search stars' range in the pair index, none found yet
    /// (an ungated step's index and tolerance are fixed, so each pair's is found once).
    pub(super) fn forget_side_ranges(&mut self, stride: usize) {
        let n = stride * stride;
        let ranges = &mut self.side_ranges;
        if ranges.0.len() < n {
            ranges.0.resize(n, [0; 2]);
        }
        ranges.1.clear();
        ranges.1.resize(n.div_ceil(64), 0);
    }

    /// Room for the angles of `stride` search stars, none of them known (the values left from
    /// an earlier frame are never read).
    pub(super) fn forget_angles(&mut self, stride: usize) {
        let n = stride * stride;
        if self.angles.len() < n {
            self.angles.resize(n, [f64::NAN; 3]);
        }
        self.angle_known.clear();
        self.angle_known.resize(n.div_ceil(64), 0);
    }
}

pub(super) struct Search<'a> {
    pub(super) solver: &'a Solver,
    /// The pair index of the current pass.
    pub(super) pairs: &'a PairIndex,
    pub(super) camera: &'a Camera,
    pub(super) config: &'a IdentifyConfig,
    /// Observed directions: `[as seen, x reversed]`.
    pub(super) obs: [&'a [Vector3<f64>]; 2],
    pub(super) magnitudes: Option<&'a [f64]>,
    /// Catalogue-magnitude window `[lo, hi]` of each centroid in a gated pass (verification,
    /// and hypotheses unless `gen_gate` is set).
    pub(super) gate: Option<&'a [[f32; 2]]>,
    /// A tighter window for making hypotheses only.
    pub(super) gen_gate: Option<&'a [[f32; 2]]>,
    /// Work spent in gated passes, which have budgets of their own: `max_pairs_visited` bounds
    /// the rest.
    pub(super) gated_work: usize,
    /// Search positions of the current triangle's three centroids.
    pub(super) tri_pos: [usize; 3],
    /// `pairs_visited` at which the current pass ends (the search goes on with the next).
    pub(super) pass_pairs_limit: usize,
    /// Mean over the centroids of the fraction of catalogue stars they may match (see
    /// [`Solver::window_fraction`]).
    pub(super) gate_fraction: f64,
    pub(super) order: &'a [usize],
    pub(super) hypotheses: usize,
    pub(super) pairs_visited: usize,
    pub(super) deadline: Option<Instant>,
    pub(super) scratch: Box<Scratch>,
    /// Row length of `scratch.angles`: the most search stars of any pass.
    pub(super) stride: usize,
    /// The method of the current pass.
    pub(super) method: Method,
    /// Set in hinted (tracking) identification: what the false-match bound counts instead of
    /// a search of the whole sky.
    pub(super) hint: Option<hinted::HintPrior>,
    /// Centroids the current hypothesis was built from (3 for a triangle): they match by
    /// construction, so the false-match bound counts only the others as evidence.
    pub(super) built: usize,
}

impl<'a> Search<'a> {
    /// A search over the whole pair index with no gate, hint or deadline: the passes set
    /// what they need.
    /// A search of `call`'s frame over its first `stride` spots (brightest first), within the
    /// call's time limit.
    pub(super) fn of_call(
        solver: &'a Solver,
        call: Call<'a>,
        obs: [&'a [Vector3<f64>]; 2],
        order: &'a [usize],
        scratch: Box<Scratch>,
        stride: usize,
    ) -> Self {
        let mut search = Self::new(
            solver,
            call.camera,
            call.config,
            obs,
            call.magnitudes,
            order,
            scratch,
        );
        search.stride = stride;
        search.deadline = call.config.timeout.map(|t| call.start + t);
        search
    }

    pub(super) fn new(
        solver: &'a Solver,
        camera: &'a Camera,
        config: &'a IdentifyConfig,
        obs: [&'a [Vector3<f64>]; 2],
        magnitudes: Option<&'a [f64]>,
        order: &'a [usize],
        mut scratch: Box<Scratch>,
    ) -> Self {
        // The stars near centroids are held for one search only.
        scratch.near.clear();
        Self {
            solver,
            pairs: &solver.pairs,
            camera,
            config,
            obs,
            magnitudes,
            gate: None,
            gen_gate: None,
            gate_fraction: 1.0,
            pass_pairs_limit: usize::MAX,
            tri_pos: [0; 3],
            gated_work: 0,
            order,
            hypotheses: 0,
            pairs_visited: 0,
            deadline: None,
            scratch,
            stride: 0,
            method: config.method,
            hint: None,
            built: 3,
        }
    }

    /// Fewest matches of a solution the verification reports: `min_matches`, and never fewer
    /// than a triangle and its fourth star (three stars alone are the lone-triangle test's).
    pub(super) fn min_verified(&self) -> usize {
        if self.hint.is_some() {
            // Tracking names two or three stars where its prior makes the bound pass.
            self.config.min_matches
        } else {
            self.config.min_matches.max(MIN_CENTROIDS)
        }
    }

    /// Whether the search's time is up or its caller cancelled it.
    pub(super) fn out_of_time(&self) -> bool {
        stop_now(self.deadline, self.config.cancel.as_ref())
    }
}

/// A verified solution.
pub(super) struct Verified {
    pub(super) r: Rotation3<f64>,
    pub(super) mirrored: bool,
    pub(super) matches: Vec<Option<(u32, f64)>>,
    pub(super) matched: usize,
    pub(super) sigma_px: f64,
    /// The noise hypothesis (px) the solution was verified at: the search step's.
    pub(super) step_sigma_px: f64,
    pub(super) radius_rad: f64,
    /// Binomial tail of the match count under a false hypothesis.
    pub(super) tail: f64,
    /// `tail` times the hypotheses tested (set by `accept`).
    pub(super) false_prob: f64,
    /// Passed the shared verification (false: a method's raw answer).
    pub(super) verified: bool,
    /// Raw answers: whether an attitude could be fitted to the assignment (`r` is the
    /// identity otherwise).
    pub(super) has_attitude: bool,
}

impl Verified {
    /// A method's raw answer: `matches` as it named them, the attitude fitted to them if any.
    pub(super) fn raw(
        matches: Vec<Option<(u32, f64)>>,
        fit: Option<(Rotation3<f64>, bool)>,
    ) -> Self {
        let matched = matches.iter().filter(|m| m.is_some()).count();
        Self {
            r: fit.map_or_else(Rotation3::identity, |f| f.0),
            mirrored: fit.is_some_and(|f| f.1),
            matches,
            matched,
            sigma_px: f64::NAN,
            step_sigma_px: f64::NAN,
            radius_rad: f64::NAN,
            tail: 1.0,
            false_prob: 1.0,
            verified: false,
            has_attitude: fit.is_some(),
        }
    }

    pub(super) fn into_identification(
        self,
        hypotheses: usize,
        elapsed: Duration,
    ) -> Identification {
        Identification {
            status: Status::Identified,
            catalog_index: self.matches.iter().map(|m| m.map(|(c, _)| c)).collect(),
            residuals_rad: self
                .matches
                .iter()
                .map(|m| m.map_or(f64::NAN, |(_, d)| d))
                .collect(),
            r_icrs_to_cam: self.has_attitude.then_some(self.r),
            mirrored: self.mirrored,
            false_match_probability: self.false_prob,
            matched: self.matched,
            centroid_sigma_px: self.sigma_px,
            noise_step_px: self.step_sigma_px,
            learned_sigma_px: None,
            noise_source: NoiseSource::None,
            match_radius_rad: self.radius_rad,
            hypotheses,
            elapsed,
            method: Method::Auto,
            message: None,
            hinted: false,
            verified: self.verified,
            focal_length_px: None,
            focal_sigma_px: f64::NAN,
            learned_mag_offset: None,
            k1: None,
        }
    }
}
