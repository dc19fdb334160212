//! The plan of a search: which passes (index, spots, noise step, magnitude gate, budget) one
//! identification runs, in order.

use super::*;

impl Solver {
    /// The passes of one identification, in order.
    ///
    /// Pyramid passes run in the order of the noise ladder, whose last (loosest) step comes last
    /// for both indexes: its wide tolerances find coincidences and verify with a wide radius, so
    /// it is the last resort. With magnitudes, each earlier step first tries the brightest few
    /// stars against the locally bright stars only: cheap, and it nearly always succeeds. With a
    /// known zero point (`mag_offset`), a magnitude-gated pass over every centroid follows: it
    /// finds the few real stars among many false ones.
    pub(crate) fn passes(
        &self,
        n: usize,
        ladder: &[f64],
        has_mags: bool,
        gated: bool,
        config: &IdentifyConfig,
        passes: &mut Vec<Pass>,
    ) {
        let (last, early) = ladder.split_last().expect("the ladder has a step");
        let pass = |bright: bool, stars: usize, sigma_px: f64, cap: usize| Pass {
            bright,
            gated: false,
            tight: false,
            pairs_budget: usize::MAX,
            stars,
            sigma_px,
            cap,
            method: Method::Pyramid,
            closing: false,
        };
        // The brightest few at the loosest step: cheap, and the last resort of a frame whose
        // gated passes spent the budget (see CLOSING_LOOSE_PAIRS).
        let closing_pass = Pass {
            closing: true,
            ..pass(true, BRIGHT_SEARCH_STARS, *last, usize::MAX)
        };
        passes.clear();
        if config.method == Method::Voting || config.method.is_seed() {
            for &s in ladder {
                passes.push(Pass {
                    gated: gated && config.method == Method::Voting,
                    method: config.method,
                    ..pass(false, n.min(HOSTILE_SEARCH_STARS), s, usize::MAX)
                });
            }
            return;
        }
        // Without magnitudes, the input order is taken as brightness order (extractors list
        // spots brightest first) unless the configuration says it is not: the cheap pass over the
        // first few spots runs then too.
        let bright = self.bright_pairs.is_some() && (has_mags || config.brightness_order);
        // Crowded frames need more triangles before an all-real one comes up: the tighter steps
        // try a fixed share of the search stars' triangles there.
        let s = n.min(config.max_search_stars);
        let triangles_per_step =
            TRIANGLES_PER_STEP.max(s * (s - 1) * (s - 2) / 6 / CROWDED_TRIANGLE_SHARE);
        if bright {
            passes.extend(
                early
                    .iter()
                    .map(|&s| pass(true, BRIGHT_SEARCH_STARS, s, usize::MAX)),
            );
            // Without a magnitude gate (the order alone, or magnitudes of unknown zero point),
            // false spots among the brightest few can hide a sparse field's stars: the locally
            // bright pairs once more, over more spots, before the whole index (see
            // BRIGHT_WIDE_SEARCH_STARS).
            if !gated && n > BRIGHT_SEARCH_STARS && n <= config.max_search_stars {
                let tightest = early.first().copied().unwrap_or(*last);
                passes.push(pass(true, BRIGHT_WIDE_SEARCH_STARS, tightest, usize::MAX));
            }
        }
        if gated && config.method == Method::Auto && n > BRIGHT_SEARCH_STARS {
            // The tightest step over every spot; looser ones over the brightest
            // HOSTILE_LOOSE_STARS only (their wider tolerances multiply the candidates).
            // The gated steps: all but the loosest of the ladder (or the one given).
            let gated_steps: &[f64] = if early.is_empty() { ladder } else { early };
            // First the tight magnitude window at the tightest step, then the configured one.
            passes.push(Pass {
                gated: true,
                tight: true,
                pairs_budget: HOSTILE_PAIRS_PER_STEP / 2,
                method: Method::Auto,
                ..pass(
                    false,
                    n.min(HOSTILE_SEARCH_STARS),
                    gated_steps[0],
                    HOSTILE_TRIANGLES,
                )
            });
            passes.extend(gated_steps.iter().enumerate().map(|(k, &s)| Pass {
                gated: true,
                pairs_budget: if k == 0 {
                    HOSTILE_PAIRS_PER_STEP / 2
                } else {
                    HOSTILE_PAIRS_PER_STEP / 8
                },
                method: Method::Auto,
                ..pass(
                    false,
                    n.min(if k == 0 {
                        HOSTILE_SEARCH_STARS
                    } else {
                        HOSTILE_LOOSE_STARS
                    }),
                    s,
                    HOSTILE_TRIANGLES,
                )
            }));
            // A crowded frame whose calibrated magnitudes found nothing: the ungated passes
            // over its brightest spots, the fallback for magnitudes that mislead, would mostly
            // try false stars; they are left out beyond this many spots.
            // The brightest few at the loosest step still close the search.
            if n > HOSTILE_FALLBACK_MAX_SPOTS {
                if bright && !early.is_empty() {
                    passes.push(closing_pass);
                }
                return;
            }
        }
        passes.extend(
            early
                .iter()
                .map(|&s| pass(false, config.max_search_stars, s, triangles_per_step)),
        );
        if bright {
            passes.push(closing_pass);
        }
        // The loosest step, the last resort, on a share of the budget (see LOOSEST_STEP_SHARE).
        passes.push(Pass {
            pairs_budget: if early.is_empty() {
                usize::MAX
            } else {
                config.max_pairs_visited / LOOSEST_STEP_SHARE
            },
            ..pass(false, config.max_search_stars, *last, usize::MAX)
        });
        for p in passes.iter_mut() {
            p.stars = p.stars.min(n);
        }
    }
}

/// One pass of the search.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pass {
    /// Search the pairs of locally bright stars only.
    pub(crate) bright: bool,
    /// Gate catalogue stars by magnitude.
    pub(crate) gated: bool,
    /// With the tight window ([`TIGHT_MAG_FRACTION`] of `mag_tolerance`).
    pub(crate) tight: bool,
    /// Catalogue pairs the pass may visit (gated passes, and the loosest step's full pass).
    pub(crate) pairs_budget: usize,
    /// Brightest centroids that form triangles.
    pub(crate) stars: usize,
    /// Centroid noise of the step, pixels.
    pub(crate) sigma_px: f64,
    /// Most triangles tried.
    pub(crate) cap: usize,
    /// The method the pass runs (and reports).
    pub(crate) method: Method,
    /// The loosest step's bright pass, which still runs when gated passes spent the budget
    /// (see [`CLOSING_LOOSE_PAIRS`]).
    pub(crate) closing: bool,
}
