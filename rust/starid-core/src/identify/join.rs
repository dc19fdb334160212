//! The catalogue-triangle join's structures: adjacency lists filled for the stars a walk asks
//! about, the marks that say which stars those are (bytes, or bits for large catalogues), and
//! the per-thread memo of the binomial tails every pass computes again.

use crate::kvector::Pairs;

pub(super) const NONE: u32 = u32::MAX;

/// Slots of a [`TailMemo`].
pub(super) const TAIL_MEMO_SLOTS: usize = 512;

/// The last values of a few functions of `(count, probability)` that every pass computes again
/// with the same arguments (the confirmations a step needs, the best tail a frame can reach),
/// remembered per thread: a binomial tail costs about as much as a triangle's join. A slot
/// holds one argument pair; a different one replaces it, so the values are exactly those computed.
pub(super) struct TailMemo {
    pub(super) slots: Vec<(u64, usize, f64)>,
}

impl Default for TailMemo {
    fn default() -> Self {
        Self {
            slots: vec![(u64::MAX, usize::MAX, 0.0); TAIL_MEMO_SLOTS],
        }
    }
}

impl TailMemo {
    /// `compute()`, the value of function `which` at `(count, p)`, remembered.
    pub(super) fn get_or(
        &mut self,
        which: u64,
        count: usize,
        p: f64,
        compute: impl FnOnce() -> f64,
    ) -> f64 {
        // `which` in the top bit (a probability's bits never set it: p ≥ 0).
        let key = p.to_bits() | (which << 63);
        let h = (key ^ (key >> 29) ^ (count as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
            .wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let slot = &mut self.slots[(h >> 55) as usize % TAIL_MEMO_SLOTS];
        if slot.0 != key || slot.1 != count {
            *slot = (key, count, compute());
        }
        slot.2
    }
}

/// Stars a 16-bit pair index can name.
pub(super) const NARROW_STARS: usize = 1 << 16;

/// Largest catalogue whose per-star marks are bytes (16 kB, half the first-level cache); a
/// larger one marks in bits, whose shifts cost instructions but whose kilobytes stay in the
/// cache where 41 kB of bytes (a catalogue to magnitude 8) would not. In callgrind's cache
/// simulation (32 kB first level, 512 kB second), marks alone (before the walk read them),
/// against 32-bit marks: S1 (8 000 stars, 1 000
/// frames) with bytes 1.07 → 0.73 million first-level misses, instructions 35.8 → 35.6
/// million (bits: 0.58 million misses, 37.9 million instructions); K2 (41 000 stars, 300
/// scenes) with bits 10.2 → 5.9 million first-level and 2.4 → 1.8 million second-level
/// misses for 148 → 176 million instructions (bytes: 8.2 and 2.0 million misses, 152 million
/// instructions).
pub(super) const BYTE_MARKS_MAX_STARS: usize = 16_384;

/// Adjacency lists of a set of catalogue pairs (both orientations) as linked lists indexed by
/// catalogue star: O(1) to look up, O(pairs) to fill and to reset, no sorting.
#[derive(Default)]
pub(super) struct Adjacency {
    pub(super) head: Vec<u32>,
    pub(super) next: Vec<u32>,
    pub(super) partner: Vec<u32>,
    pub(super) touched: Vec<u32>,
    /// Per catalogue star: the fill that last wanted its list (see `fill_for`).
    pub(super) wanted: Vec<u32>,
    pub(super) fills: u32,
    /// A narrow fill's marks of the 16-bit stars it wants, in bytes or bits (see
    /// [`BYTE_MARKS_MAX_STARS`]).
    pub(super) narrow_bytes: Option<Box<ByteMarks>>,
    pub(super) narrow_bits: Option<Box<BitMarks>>,
    /// Whether the last fill left its byte marks set, with 2 at the wanted stars that got a
    /// list. The walk asks them which stars hold a list instead of `head` (the walked stars'
    /// marks are in the cache from the fill; `head`'s 32 kB for the bundled catalogue were not:
    /// 100 misses per S1 frame in callgrind's simulation), then clears them with the same pairs
    /// ([`Adjacency::clear_marks`]). (Bit marks keeping a second bit for the lists cost K2 12 %
    /// more instructions for 17 % fewer first-level misses: they are cleared by the fill.)
    pub(super) bytes_live: bool,
}

/// Per 16-bit star, one byte: 1 wanted, 2 wanted and listed, else 0.
pub(super) struct ByteMarks([u8; NARROW_STARS]);

impl ByteMarks {
    /// Whether `s` is wanted and has a list.
    #[inline]
    pub(super) fn has_list(&self, s: u16) -> bool {
        self.0[usize::from(s)] == 2
    }
}

/// Per 16-bit star, a bit: wanted.
pub(super) struct BitMarks([u64; NARROW_STARS / 64]);

/// The marks of a narrow fill: bytes or bits (see [`BYTE_MARKS_MAX_STARS`]).
pub(super) trait Marks {
    /// `s` is wanted.
    fn set(&mut self, s: u16);
    /// `s`, wanted, has a list now.
    fn listed(&mut self, s: u16);
    /// Whether `s` is wanted.
    fn get(&self, s: u16) -> bool;
    /// Clear `s` and whatever shares its storage (all of it wanted).
    fn clear(&mut self, s: u16);
}

impl Marks for ByteMarks {
    #[inline]
    fn set(&mut self, s: u16) {
        self.0[usize::from(s)] = 1;
    }
    #[inline]
    fn listed(&mut self, s: u16) {
        self.0[usize::from(s)] = 2;
    }
    #[inline]
    fn get(&self, s: u16) -> bool {
        self.0[usize::from(s)] != 0
    }
    #[inline]
    fn clear(&mut self, s: u16) {
        self.0[usize::from(s)] = 0;
    }
}

impl Marks for BitMarks {
    #[inline]
    fn set(&mut self, s: u16) {
        self.0[usize::from(s >> 6)] |= 1 << (s & 63);
    }
    #[inline]
    fn listed(&mut self, _: u16) {}
    #[inline]
    fn get(&self, s: u16) -> bool {
        (self.0[usize::from(s >> 6)] >> (s & 63)) & 1 != 0
    }
    #[inline]
    fn clear(&mut self, s: u16) {
        self.0[usize::from(s >> 6)] = 0;
    }
}

impl Adjacency {
    /// Empty the lists, sized for a catalogue of `n_cat` stars.
    pub(super) fn reset(&mut self, n_cat: usize) {
        for &s in &self.touched {
            self.head[s as usize] = NONE;
        }
        // Marks no walk cleared: all of them (never on the search's path).
        if self.bytes_live {
            if let Some(m) = self.narrow_bytes.as_mut() {
                m.0.fill(0);
            }
            self.bytes_live = false;
        }
        if self.head.len() != n_cat {
            self.head.clear();
            self.head.resize(n_cat, NONE);
        }
        self.touched.clear();
        self.next.clear();
        self.partner.clear();
    }

    /// Empty the lists for a new fill that keeps only the lists of stars [`Adjacency::want`]ed:
    /// `partners` may be asked only about those (it answers nothing for the others). The lists
    /// held are those a fill of every star would hold, in the same order; the pairs of stars no
    /// one asks about (most of them) are passed over with a look-up and no push.
    pub(super) fn start(&mut self, n_cat: usize) {
        self.reset(n_cat);
        if self.wanted.len() != n_cat || self.fills == u32::MAX {
            self.wanted.clear();
            self.wanted.resize(n_cat, 0);
            self.fills = 0;
        }
        self.fills += 1;
    }

    /// Keep the list of `star` in this fill.
    #[inline]
    pub(super) fn want(&mut self, star: u32) {
        self.wanted[star as usize] = self.fills;
    }

    /// `partner` onto the list of `star`, if that list is kept.
    #[inline]
    pub(super) fn push_wanted(&mut self, star: u32, partner: u32) {
        if self.wanted[star as usize] == self.fills {
            self.push(star, partner);
        }
    }

    /// [`Adjacency::fill_for`] of an index's ranges: a narrow index's (16-bit stars) read as
    /// slices, without a bounds check per pair.
    pub(super) fn fill_ranges(&mut self, pairs: Pairs<'_>, wanted: Pairs<'_>, n_cat: usize) {
        match (pairs, wanted) {
            (Pairs::Narrow(p), Pairs::Narrow(w)) => {
                self.fill_narrow(p.as_slice(), w.as_slice(), n_cat)
            }
            (p, w) => self.fill_for(p, w, n_cat),
        }
    }

    /// [`Adjacency::fill_for`] of 16-bit pairs. The stars wanted are marked in bytes or bits
    /// (see [`BYTE_MARKS_MAX_STARS`]), not by the 32-bit fill numbers of `fill_for`: a pair's
    /// two look-ups are random reads over the catalogue, and over 32 kB of marks (the bundled
    /// catalogue's) they missed the cache about once per pair (callgrind's cache simulation:
    /// 290 misses per S1 frame, a third of all).
    #[inline(never)]
    pub(super) fn fill_narrow(&mut self, pairs: &[[u16; 2]], wanted: &[[u16; 2]], n_cat: usize) {
        self.start(n_cat);
        if n_cat > BYTE_MARKS_MAX_STARS {
            let mut marks = self
                .narrow_bits
                .take()
                .unwrap_or_else(|| Box::new(BitMarks([0; NARROW_STARS / 64])));
            self.fill_narrow_with(&mut *marks, pairs, wanted);
            // Bit marks are not kept for the walk (see `bytes_live`).
            for &[p, q] in wanted {
                marks.clear(p);
                marks.clear(q);
            }
            self.narrow_bits = Some(marks);
        } else {
            let mut marks = self
                .narrow_bytes
                .take()
                .unwrap_or_else(|| Box::new(ByteMarks([0; NARROW_STARS])));
            self.fill_narrow_with(&mut *marks, pairs, wanted);
            self.narrow_bytes = Some(marks);
            self.bytes_live = true;
        }
    }

    /// `fill_narrow` with its marks.
    #[inline(always)]
    pub(super) fn fill_narrow_with<M: Marks>(
        &mut self,
        marks: &mut M,
        pairs: &[[u16; 2]],
        wanted: &[[u16; 2]],
    ) {
        let Self {
            head,
            next,
            partner,
            touched,
            ..
        } = self;
        for &[p, q] in wanted {
            marks.set(p);
            marks.set(q);
        }
        // `Adjacency::push`, on the fields borrowed apart from the marks. (Through one function
        // shared with `push`, the S1 search ran 0.4 % more instructions: callgrind.)
        let mut push = |marks: &mut M, star: u16, other: u16| {
            let h = &mut head[usize::from(star)];
            if *h == NONE {
                touched.push(u32::from(star));
                marks.listed(star);
            }
            next.push(*h);
            partner.push(u32::from(other));
            *h = (partner.len() - 1) as u32;
        };
        for &[p, q] in pairs {
            let (wp, wq) = (marks.get(p), marks.get(q));
            if wp {
                push(marks, p, q);
            }
            if wq {
                push(marks, q, p);
            }
        }
    }

    /// The lists of `pairs` (both orientations) at the stars of the pairs `wanted`.
    // Out of line: inlined into the search loop it ran about 1 % more instructions (callgrind).
    #[inline(never)]
    pub(super) fn fill_for(
        &mut self,
        pairs: impl Iterator<Item = [u32; 2]>,
        wanted: impl Iterator<Item = [u32; 2]>,
        n_cat: usize,
    ) {
        self.start(n_cat);
        let fill = self.fills;
        for [p, q] in wanted {
            self.wanted[p as usize] = fill;
            self.wanted[q as usize] = fill;
        }
        for [p, q] in pairs {
            if self.wanted[p as usize] == fill {
                self.push(p, q);
            }
            if self.wanted[q as usize] == fill {
                self.push(q, p);
            }
        }
    }

    #[inline]
    pub(super) fn push(&mut self, star: u32, partner: u32) {
        let h = &mut self.head[star as usize];
        if *h == NONE {
            self.touched.push(star);
        }
        self.next.push(*h);
        self.partner.push(partner);
        *h = (self.partner.len() - 1) as u32;
    }

    /// Whether the list of `star` holds any partner.
    #[inline]
    pub(super) fn has_partners(&self, star: u32) -> bool {
        self.head[star as usize] != NONE
    }

    /// The byte marks the last fill left set, if it was a byte-marked narrow fill that wanted
    /// any star: 2 at a wanted star with a list, 1 at one without, 0 at any other star (which
    /// holds no list to ask about).
    #[inline]
    pub(super) fn live_marks(&self) -> Option<&ByteMarks> {
        if self.bytes_live {
            self.narrow_bytes.as_deref()
        } else {
            None
        }
    }

    /// Clear the marks the last fill left set, given the pairs it wanted.
    pub(super) fn clear_marks(&mut self, wanted: Pairs<'_>) {
        if let (true, Some(m), Pairs::Narrow(w)) =
            (self.bytes_live, self.narrow_bytes.as_mut(), wanted)
        {
            for &[p, q] in w {
                m.clear(p);
                m.clear(q);
            }
            self.bytes_live = false;
        }
    }

    #[inline]
    pub(super) fn partners(&self, star: u32) -> impl Iterator<Item = u32> + '_ {
        let mut at = self.head[star as usize];
        std::iter::from_fn(move || {
            (at != NONE).then(|| {
                let p = self.partner[at as usize];
                at = self.next[at as usize];
                p
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::binomial_tail;

    #[test]
    fn a_tail_memo_answers_what_it_was_asked_to_compute() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(8);
        let mut memo = TailMemo::default();
        // Far more argument pairs than slots, each asked twice: collisions must recompute.
        let args: Vec<(u64, usize, f64)> = (0..4 * TAIL_MEMO_SLOTS)
            .map(|_| {
                (
                    rng.random_range(0..2),
                    rng.random_range(0..200),
                    rng.random_range(0.0..1.0),
                )
            })
            .collect();
        let f = |w: u64, c: usize, p: f64| binomial_tail(c, c / 3 + w as usize, p);
        for _ in 0..2 {
            for &(w, c, p) in &args {
                assert_eq!(memo.get_or(w, c, p, || f(w, c, p)), f(w, c, p));
            }
        }
        // The function's tag tells two values at the same arguments apart.
        assert_eq!(memo.get_or(0, 5, 0.25, || 1.0), 1.0);
        assert_eq!(memo.get_or(1, 5, 0.25, || 2.0), 2.0);
    }

    #[test]
    fn a_fill_for_some_stars_holds_their_whole_lists_in_order() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut adj = Adjacency::default();
        // A small catalogue (byte marks on the 16-bit path) and one past BYTE_MARKS_MAX_STARS
        // (bit marks), each with 300 stars in its pairs: neighbours in a word of bits too.
        for trial in 0..400 {
            let n_cat = if trial < 200 { 300 } else { 40_000 };
            let stars: Vec<u32> = if n_cat == 300 {
                (0..300).collect()
            } else {
                (0..300)
                    .map(|i| {
                        if i % 3 == 0 {
                            rng.random_range(0..n_cat as u32)
                        } else {
                            rng.random_range(20_000..20_200)
                        }
                    })
                    .collect()
            };
            let pair = |rng: &mut rand::rngs::StdRng| {
                [
                    stars[rng.random_range(0..stars.len())],
                    stars[rng.random_range(0..stars.len())],
                ]
            };
            let pairs: Vec<[u32; 2]> = (0..rng.random_range(0..400))
                .map(|_| pair(&mut rng))
                .collect();
            let wanted: Vec<[u32; 2]> = (0..rng.random_range(0..20))
                .map(|_| pair(&mut rng))
                .collect();
            // The 16-bit path (every bundled catalogue's) on odd trials: the same lists.
            if trial % 2 == 1 {
                let narrow = |v: &[[u32; 2]]| -> Vec<[u16; 2]> {
                    v.iter().map(|p| p.map(|i| i as u16)).collect()
                };
                let (p16, w16) = (narrow(&pairs), narrow(&wanted));
                adj.fill_ranges(Pairs::Narrow(p16.iter()), Pairs::Narrow(w16.iter()), n_cat);
            } else {
                adj.fill_for(pairs.iter().copied(), wanted.iter().copied(), n_cat);
            }
            for &star in wanted.iter().flatten() {
                // Partners as a fill of every star lists them: the latest pair first.
                let want: Vec<u32> = pairs
                    .iter()
                    .rev()
                    .flat_map(|&[p, q]| {
                        // Pushed (p, q) then (q, p): reversed, (q, p) comes first.
                        [(q == star).then_some(p), (p == star).then_some(q)]
                    })
                    .flatten()
                    .collect();
                let got: Vec<u32> = adj.partners(star).collect();
                assert_eq!(got, want, "trial {trial}, star {star}");
                assert_eq!(adj.has_partners(star), !want.is_empty());
            }
            // The others hold nothing: no mark is left from an earlier fill.
            for &star in &stars {
                if !wanted.iter().flatten().any(|&w| w == star) {
                    assert!(!adj.has_partners(star), "trial {trial}, star {star}");
                }
            }
            // A narrow fill's marks say the same of the wanted stars (what the walk asks).
            if trial % 2 == 1 && !wanted.is_empty() {
                for &star in wanted.iter().flatten() {
                    // Bit marks (the large catalogue) are cleared by the fill.
                    if let Some(m) = adj.live_marks() {
                        assert_eq!(
                            m.has_list(star as u16),
                            adj.has_partners(star),
                            "trial {trial}, star {star}"
                        );
                    } else {
                        assert!(n_cat > BYTE_MARKS_MAX_STARS, "trial {trial}: no marks left");
                    }
                }
                // Cleared by the walk's pairs on some trials, by the next fill's reset on the
                // others: either way the next fill starts clean (checked above).
                if trial % 4 == 1 {
                    let w16: Vec<[u16; 2]> = wanted.iter().map(|p| p.map(|i| i as u16)).collect();
                    adj.clear_marks(Pairs::Narrow(w16.iter()));
                    assert!(adj.live_marks().is_none());
                }
            }
        }
    }
}
