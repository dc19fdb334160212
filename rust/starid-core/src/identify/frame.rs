//! A frame prepared for search: brightness order, checks, the per-thread scratch buffers and the magnitude table.

use super::*;

/// One frame's call: its spots and their magnitudes, the camera, the settings and the instant
/// the call began (its time limit counts from it). What every search of the frame takes.
#[derive(Clone, Copy)]
pub(crate) struct Call<'a> {
    pub(crate) centroids: &'a [[f64; 2]],
    pub(crate) magnitudes: Option<&'a [f64]>,
    pub(crate) camera: &'a Camera,
    pub(crate) config: &'a IdentifyConfig,
    pub(crate) start: Instant,
}

impl<'a> Call<'a> {
    /// A call beginning now, its settings and frame checked.
    ///
    /// # Errors
    /// `InvalidInput` naming the first setting out of its domain or what is wrong with the frame.
    pub(crate) fn checked(
        centroids: &'a [[f64; 2]],
        magnitudes: Option<&'a [f64]>,
        camera: &'a Camera,
        config: &'a IdentifyConfig,
    ) -> Result<Self> {
        let start = Instant::now();
        config.validate()?;
        validate_centroids(centroids, magnitudes, camera)?;
        Ok(Call {
            centroids,
            magnitudes,
            camera,
            config,
            start,
        })
    }

    /// The same call with another camera (a focal length or distortion being tried).
    pub(crate) fn with_camera<'b>(self, camera: &'b Camera) -> Call<'b>
    where
        'a: 'b,
    {
        Call { camera, ..self }
    }

    /// Its parts: centroids, magnitudes, camera, settings, start.
    #[allow(clippy::type_complexity)]
    pub(crate) fn parts(
        self,
    ) -> (
        &'a [[f64; 2]],
        Option<&'a [f64]>,
        &'a Camera,
        &'a IdentifyConfig,
        Instant,
    ) {
        (
            self.centroids,
            self.magnitudes,
            self.camera,
            self.config,
            self.start,
        )
    }
}

/// The centroids brightest first (by magnitude, ties by index), or as given without magnitudes.
/// Into `order` (cleared first): a search keeps the buffer between calls.
pub(crate) fn brightness_order_into(n: usize, magnitudes: Option<&[f64]>, order: &mut Vec<usize>) {
    order.clear();
    let Some(m) = magnitudes else {
        order.extend(0..n);
        return;
    };
    // Each magnitude as an integer in the order of `f64::total_cmp`: sorting (key, index) pairs
    // gives the order with ties by index, each comparison as cheap as one of integers.
    let n = m.len();
    if n <= BRIGHTNESS_INSERTION_MAX {
        // A frame of a few dozen spots: an insertion sort of the indices by key (stable, so
        // ties keep their index order), with no allocation but the answer's.
        let mut keys = [0i64; BRIGHTNESS_INSERTION_MAX];
        for (k, &x) in keys.iter_mut().zip(m) {
            *k = magnitude_key(x);
        }
        let mut idx = [0u8; BRIGHTNESS_INSERTION_MAX];
        for i in 0..n {
            let k = keys[i];
            let mut j = i;
            while j > 0 && keys[usize::from(idx[j - 1])] > k {
                idx[j] = idx[j - 1];
                j -= 1;
            }
            idx[j] = i as u8;
        }
        order.extend(idx[..n].iter().map(|&i| usize::from(i)));
        return;
    }
    let mut keyed: Vec<(i64, usize)> = m
        .iter()
        .enumerate()
        .map(|(i, &x)| (magnitude_key(x), i))
        .collect();
    keyed.sort_unstable();
    order.extend(keyed.into_iter().map(|(_, i)| i));
}

/// This thread's scratch and, taken out of it, the call's frame buffers, filled: its
/// directions as seen and mirrored (x reversed) and its brightness order. Both go back with
/// `scratch.frame = frame` and [`return_scratch`].
pub(super) fn take_prepared(call: &Call<'_>) -> (Box<Scratch>, FrameBuffers) {
    let mut scratch = take_scratch();
    let mut frame = std::mem::take(&mut scratch.frame);
    directions_into(
        call.centroids,
        call.camera,
        true,
        (&mut frame.obs, &mut frame.obs_mirrored),
    );
    brightness_order_into(call.centroids.len(), call.magnitudes, &mut frame.order);
    (scratch, frame)
}

/// The camera-frame directions of `centroids` into `obs`, and (where `mirrored_too`) those of the
/// mirrored frame, x reversed, into `obs_mirrored` (left empty otherwise); both cleared first.
pub(crate) fn directions_into(
    centroids: &[[f64; 2]],
    camera: &Camera,
    mirrored_too: bool,
    (obs, obs_mirrored): (&mut Vec<Vector3<f64>>, &mut Vec<Vector3<f64>>),
) {
    obs.clear();
    obs.extend(
        centroids
            .iter()
            .map(|c| camera.pixel_to_cam(c[0], c[1], false)),
    );
    obs_mirrored.clear();
    if !mirrored_too {
        return;
    }
    if camera.is_ideal() {
        obs_mirrored.extend(obs.iter().map(|v| Vector3::new(-v.x, v.y, v.z)));
    } else {
        obs_mirrored.extend(
            centroids
                .iter()
                .map(|c| camera.pixel_to_cam(c[0], c[1], true)),
        );
    }
}

/// The first centroids of [`brightness_order_into`], found as they are asked for: a tracking search,
/// which mostly verifies from its first pair of spots, needs only the brightest two. Frames of
/// more than [`BRIGHTNESS_INSERTION_MAX`] spots are sorted whole at once.
pub(super) struct BrightnessPrefix<'b> {
    /// The magnitudes as [`brightness_order_into`]'s integer keys, while spots remain to be found.
    pub(super) keys: [i64; BRIGHTNESS_INSERTION_MAX],
    /// Spots already in `order` (bit per spot).
    pub(super) taken: u64,
    pub(super) n: usize,
    pub(super) order: &'b mut Vec<usize>,
}

impl<'b> BrightnessPrefix<'b> {
    pub(super) fn new(n: usize, magnitudes: Option<&[f64]>, order: &'b mut Vec<usize>) -> Self {
        let mut keys = [0i64; BRIGHTNESS_INSERTION_MAX];
        match magnitudes {
            Some(m) if n <= BRIGHTNESS_INSERTION_MAX => {
                order.clear();
                for (k, &x) in keys.iter_mut().zip(m) {
                    *k = magnitude_key(x);
                }
            }
            // No magnitudes (the order as given), or many spots: the whole order now.
            _ => brightness_order_into(n, magnitudes, order),
        }
        Self {
            keys,
            taken: 0,
            n,
            order,
        }
    }

    /// The brightest `len` centroids (at most all), brightest first.
    pub(super) fn first(&mut self, len: usize) -> &[usize] {
        let len = len.min(self.n);
        while self.order.len() < len {
            // The brightest spot not yet taken; ties to the lowest index, as the stable sort.
            let mut best = usize::MAX;
            for i in 0..self.n {
                if self.taken & (1 << i) == 0
                    && (best == usize::MAX || self.keys[i] < self.keys[best])
                {
                    best = i;
                }
            }
            self.taken |= 1 << best;
            self.order.push(best);
        }
        &self.order[..len]
    }
}

/// The catalogue magnitudes a spot of instrument magnitude `m` may match: `m − offset ± tolerance`
/// (the zero point `offset` and its `tolerance`), as the search's `f32` window `[lo, hi]`.
#[inline]
pub(crate) fn magnitude_window(m: f64, offset: f64, tolerance: f64) -> [f32; 2] {
    [
        (m - offset - tolerance) as f32,
        (m - offset + tolerance) as f32,
    ]
}

/// A magnitude as an integer in the order of `f64::total_cmp`.
#[inline]
pub(super) fn magnitude_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ ((((b >> 63) as u64) >> 1) as i64)
}

/// Most centroids whose duplicates [`validate_centroids`] screens by hashing (more: by sorting).
pub(super) const DUPLICATE_HASH_MAX: usize = 256;

/// Most centroids [`brightness_order_into`] sorts by insertion.
pub(super) const BRIGHTNESS_INSERTION_MAX: usize = 64;

pub(crate) fn validate_centroids(
    centroids: &[[f64; 2]],
    magnitudes: Option<&[f64]>,
    camera: &Camera,
) -> Result<()> {
    let n = centroids.len();
    if n > MAX_CENTROIDS {
        return Err(Error::invalid_input(format!(
            "too many centroids: {n} (at most {MAX_CENTROIDS})"
        )));
    }
    let (w, h) = (camera.width_px, camera.height_px);
    for (i, c) in centroids.iter().enumerate() {
        if !c[0].is_finite() || !c[1].is_finite() {
            return Err(Error::invalid_input(format!(
                "centroid {i} has a non-finite coordinate ({}, {})",
                c[0], c[1]
            )));
        }
        // A star cut by the sensor's edge can centroid a little outside it: only a point more than
        // a sensor width (height) away is an error.
        if c[0] < -w || c[0] > 2.0 * w || c[1] < -h || c[1] > 2.0 * h {
            return Err(Error::invalid_input(format!(
                "centroid {i} at ({}, {}) lies more than a sensor size outside the {w} x {h} px sensor (x right, y down, origin top-left)",
                c[0], c[1]
            )));
        }
    }
    // Duplicates: equal coordinates (−0 equals 0, hence `+ 0.0`) are equal bit patterns; up to
    // DUPLICATE_HASH_MAX centroids screened by a hash table on the stack, more sorted as integers.
    let key = |c: &[f64; 2]| ((c[0] + 0.0).to_bits(), (c[1] + 0.0).to_bits());
    let duplicate = if n <= DUPLICATE_HASH_MAX {
        // Each key sets one bit of a 4096-bit table by its hash; only a key whose bit is already
        // set is compared with the centroids before it (a 256-spot frame collides about 8 times).
        let mut seen = [0u64; 64];
        let mut dup = false;
        for (j, c) in centroids.iter().enumerate() {
            let k = key(c);
            let h =
                ((k.0 ^ k.1.rotate_left(29)).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 52) as usize;
            let (word, bit) = (h >> 6, 1u64 << (h & 63));
            if seen[word] & bit != 0 && centroids[..j].iter().any(|c| key(c) == k) {
                dup = true;
                break;
            }
            seen[word] |= bit;
        }
        dup
    } else {
        let mut keys: Vec<(u64, u64)> = centroids.iter().map(key).collect();
        keys.sort_unstable();
        keys.windows(2).any(|w| w[0] == w[1])
    };
    // Name the pair (rare: only for the error).
    let mut sorted: Vec<usize> = if duplicate {
        (0..n).collect()
    } else {
        Vec::new()
    };
    sorted.sort_unstable_by_key(|&i| key(&centroids[i]));
    for pair in sorted.windows(2) {
        let (a, b) = (centroids[pair[0]], centroids[pair[1]]);
        if key(&a) == key(&b) {
            let (i, j) = (pair[0].min(pair[1]), pair[0].max(pair[1]));
            return Err(Error::invalid_input(format!(
                "centroids {i} and {j} are duplicates at ({}, {})",
                a[0], a[1]
            )));
        }
    }
    if let Some(m) = magnitudes {
        if m.len() != n {
            return Err(Error::invalid_input(format!(
                "magnitudes has {} values for {n} centroids",
                m.len()
            )));
        }
        if let Some(i) = m.iter().position(|v| !v.is_finite()) {
            return Err(Error::invalid_input(format!(
                "magnitude {i} is not finite ({})",
                m[i]
            )));
        }
    }
    Ok(())
}

/// This thread's scratch buffers (a new set on its first call, or while another call on the
/// thread holds them).
pub(super) fn take_scratch() -> Box<Scratch> {
    SCRATCH.with(std::cell::Cell::take).unwrap_or_default()
}

/// Hand the scratch buffers back to this thread for its next call.
pub(super) fn return_scratch(scratch: Box<Scratch>) {
    SCRATCH.with(|c| c.set(Some(scratch)));
}

thread_local! {
    /// Buffers kept between calls on a thread, so identification allocates almost nothing.
    /// Boxed: a call takes and returns a pointer, not the buffers' headers (moving them in and
    /// out, and dropping the empty set left behind, cost about 1 500 instructions a call).
    static SCRATCH: std::cell::Cell<Option<Box<Scratch>>> = const { std::cell::Cell::new(None) };
}

/// Per centroid pair (search positions `a < b`, at `a * stride + b`): `(first entry, count)`
/// into `entries`, the magnitude-consistent catalogue pairs `[star of a, star of b]`;
/// `u32::MAX` until read.
#[derive(Default)]
pub(super) struct SideCache {
    pub(super) index: Vec<(u32, u32)>,
    pub(super) entries: Vec<[u32; 2]>,
}

impl SideCache {
    pub(super) fn reset(&mut self, stride: usize) {
        self.index.clear();
        self.index.resize(stride * stride, (u32::MAX, 0));
        self.entries.clear();
    }
}

/// Catalogue magnitudes ascending, with a table of where each of [`MAG_COUNT_BINS`] equal
/// magnitude bins starts: a count below a magnitude (asked per centroid on every call) is a
/// search within one bin, in cache, instead of one over the whole catalogue.
#[derive(Debug, Clone)]
pub(super) struct SortedMags {
    pub(super) sorted: Vec<f32>,
    pub(super) lo: f32,
    pub(super) scale: f32,
    /// `start[b]`: the stars of bins before `b`; `start[MAG_COUNT_BINS] = len`.
    pub(super) start: Vec<u32>,
}

/// Bins of [`SortedMags`].
pub(super) const MAG_COUNT_BINS: usize = 8192;

impl SortedMags {
    pub(super) fn new(mags: &[f32]) -> Self {
        let mut sorted = mags.to_vec();
        sorted.sort_unstable_by(f32::total_cmp);
        let (lo, hi) = (
            sorted.first().copied().unwrap_or(0.0),
            sorted.last().copied().unwrap_or(0.0),
        );
        let scale = MAG_COUNT_BINS as f32 / (hi - lo).max(1e-3);
        let mut table = Self {
            sorted,
            lo,
            scale,
            start: Vec::new(),
        };
        // The bin of a magnitude never decreases with it, so `start` is a partition of `sorted`.
        let bins: Vec<usize> = table.sorted.iter().map(|&m| table.bin(m)).collect();
        table.start = (0..=MAG_COUNT_BINS)
            .map(|b| bins.partition_point(|&x| x < b) as u32)
            .collect();
        table
    }

    pub(super) fn len(&self) -> usize {
        self.sorted.len()
    }

    #[inline]
    pub(super) fn bin(&self, m: f32) -> usize {
        // Saturating at 0 (and NaN at 0), as any `as`; 32 bits convert faster than usize.
        (((m - self.lo) * self.scale) as u32 as usize).min(MAG_COUNT_BINS - 1)
    }

    /// The smallest catalogue magnitude at least `x`, if any.
    #[inline]
    pub(super) fn first_at_least(&self, x: f32) -> Option<f32> {
        let b = self.bin(x);
        let (a, e) = (self.start[b] as usize, self.start[b + 1] as usize);
        let i = a + self.sorted[a..e].partition_point(|&m| m < x);
        self.sorted.get(i).copied()
    }

    /// Stars with a magnitude at most `x`.
    #[inline]
    pub(super) fn count_at_most(&self, x: f32) -> usize {
        let b = self.bin(x);
        let (a, e) = (self.start[b] as usize, self.start[b + 1] as usize);
        a + self.sorted[a..e].partition_point(|&m| m <= x)
    }
}
