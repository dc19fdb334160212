//! Pair indexes kept on disk, so that a new process reads in milliseconds what took a few
//! hundred to build: one file per catalogue and index angle, named by the catalogue's content,
//! so that a changed catalogue never finds the files of another.
//!
//! A file holds a header (format, catalogue key, star count), the pair index and the bright
//! pair index (k-vectors and pairs), the star densities of the false-match bound (the sparsest
//! field's and the sky map's), little-endian, and a checksum of all of it (CRC-32). A file that
//! does not read back whole and consistent is ignored and rebuilt; a directory that cannot be
//! written only means the index is not kept.

use std::io::Read;
use std::path::{Path, PathBuf};

use super::PairIndexes;
use crate::catalog::Catalog;
use crate::kvector::{PairIndex, PairStore};
use crate::sky::DensityMap;

/// Version of the index file layout and of what the indexes hold; files of another are not read.
pub const INDEX_FILE_FORMAT: u32 = 4;

/// Indexes with fewer pairs are not written: they build in milliseconds.
pub const MIN_STORED_PAIRS: usize = 100_000;

const MAGIC: &[u8; 8] = b"STARIDPX";

/// A 64-bit key of a catalogue's content (ids, directions, magnitudes, in order): index files
/// are named by it.
///
/// # Example
/// ```
/// use starid_core::identify::catalog_key;
/// let a = starid_core::simulate::random_catalog(500, 1.0, 6.0, 1).unwrap();
/// let b = starid_core::simulate::random_catalog(500, 1.0, 6.0, 2).unwrap();
/// assert_eq!(catalog_key(&a), catalog_key(&a.clone()));
/// assert_ne!(catalog_key(&a), catalog_key(&b));
/// ```
pub fn catalog_key(catalog: &Catalog) -> u64 {
    let mut h = Hash::default();
    h.word(catalog.len() as u64);
    for &id in catalog.ids() {
        h.word(id as u64);
    }
    for v in catalog.vectors() {
        for x in v.iter() {
            h.word(x.to_bits());
        }
    }
    for m in catalog.mag() {
        h.word(m.to_bits());
    }
    h.0
}

/// A word-at-a-time hash (a splitmix64 finaliser over a rotating state).
#[derive(Default)]
struct Hash(u64);

impl Hash {
    #[inline]
    fn word(&mut self, w: u64) {
        let mut z = self.0.rotate_left(23) ^ w;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        self.0 = z ^ (z >> 31);
    }
}

/// The file holding the indexes of catalogue `key` up to `max_angle_rad`, in `dir`.
fn file_name(key: u64, max_angle_rad: f64) -> String {
    format!(
        "pairs-v{INDEX_FILE_FORMAT}-{key:016x}-{}.idx",
        (max_angle_rad * 1e9).round() as u64
    )
}

/// The index files in `dir` of catalogue `key`, with their index angles.
fn files_of(dir: &Path, key: u64) -> Vec<(f64, PathBuf)> {
    let prefix = format!("pairs-v{INDEX_FILE_FORMAT}-{key:016x}-");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| {
            let e = e.ok()?;
            let name = e.file_name();
            let nrad: u64 = name
                .to_str()?
                .strip_prefix(&prefix)?
                .strip_suffix(".idx")?
                .parse()
                .ok()?;
            Some((nrad as f64 * 1e-9, e.path()))
        })
        .collect()
}

/// The smallest stored index of `catalog` (key `key`) in `dir` covering `max_angle_rad` and at
/// most `max_oversize` times it, read and checked; `None` when there is none that reads back.
pub(crate) fn load(
    dir: &Path,
    catalog: &Catalog,
    key: u64,
    max_angle_rad: f64,
    max_oversize: f64,
) -> Option<(PairIndexes, PathBuf)> {
    let mut files: Vec<(f64, PathBuf)> = files_of(dir, key)
        .into_iter()
        .filter(|&(a, _)| a >= max_angle_rad && a <= max_oversize * max_angle_rad)
        .collect();
    files.sort_by(|a, b| a.0.total_cmp(&b.0));
    files.into_iter().find_map(|(_, path)| {
        let indexes = read(&path, key, catalog.len())?;
        (indexes.pairs.max_angle_rad() >= max_angle_rad).then_some((indexes, path))
    })
}

/// Write `indexes` of catalogue `key` to `dir` (created if need be), through a temporary file
/// renamed into place so that a reader never sees half a file. Returns the file's path.
///
/// # Errors
/// Any I/O error; the caller goes on without the file.
pub(crate) fn save(
    dir: &Path,
    key: u64,
    n_stars: usize,
    indexes: &PairIndexes,
) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let name = file_name(key, indexes.pairs.max_angle_rad());
    let path = dir.join(&name);
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::write(&tmp, encode(key, n_stars, indexes))
        .and_then(|()| std::fs::rename(&tmp, &path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    } else {
        remove_other_formats(dir);
    }
    written.map(|()| path)
}

/// Delete the index files in `dir` of another format than [`INDEX_FILE_FORMAT`]: no version of
/// starid reads what an upgrade left behind, and the deepest catalogues' files are tens of MB.
/// (A process of an older version reading one at the time keeps what it has open; failures are
/// ignored.)
fn remove_other_formats(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let ours = format!("pairs-v{INDEX_FILE_FORMAT}-");
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else {
            continue;
        };
        let other_format = name
            .strip_prefix("pairs-v")
            .and_then(|rest| rest.split_once('-'))
            .is_some_and(|(v, _)| !v.is_empty() && v.bytes().all(|b| b.is_ascii_digit()));
        if other_format && !name.starts_with(&ours) && name.ends_with(".idx") {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

fn encode(key: u64, n_stars: usize, indexes: &PairIndexes) -> Vec<u8> {
    let mut out = Vec::with_capacity(
        64 + indexes.pairs.memory_bytes()
            + indexes
                .bright_pairs
                .as_ref()
                .map_or(0, PairIndex::memory_bytes),
    );
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&u64::from(INDEX_FILE_FORMAT).to_le_bytes());
    out.extend_from_slice(&key.to_le_bytes());
    out.extend_from_slice(&(n_stars as u64).to_le_bytes());
    put_index(&mut out, &indexes.pairs);
    match &indexes.bright_pairs {
        Some(b) => {
            out.extend_from_slice(&1u64.to_le_bytes());
            put_index(&mut out, b);
        }
        None => out.extend_from_slice(&0u64.to_le_bytes()),
    }
    out.extend_from_slice(&indexes.min_density_sr.to_le_bytes());
    match &indexes.density {
        Some(d) => {
            let (g, radius, per_sr) = d.stored_parts();
            for w in [1u64, g as u64] {
                out.extend_from_slice(&w.to_le_bytes());
            }
            out.extend_from_slice(&radius.to_le_bytes());
            per_sr
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_le_bytes()));
        }
        None => out.extend_from_slice(&0u64.to_le_bytes()),
    }
    out.extend_from_slice(&u64::from(crc32fast::hash(&out)).to_le_bytes());
    out
}

fn put_index(out: &mut Vec<u8>, index: &PairIndex) {
    let (pairs, k, slope, intercept) = index.stored_parts();
    let (wide, n_pairs) = match pairs {
        PairStore::Narrow(p) => (0u64, p.len()),
        PairStore::Wide(p) => (1u64, p.len()),
    };
    for w in [wide, n_pairs as u64, k.len() as u64] {
        out.extend_from_slice(&w.to_le_bytes());
    }
    for x in [index.max_angle_rad(), slope, intercept] {
        out.extend_from_slice(&x.to_le_bytes());
    }
    match pairs {
        PairStore::Narrow(p) => p
            .iter()
            .flatten()
            .for_each(|i| out.extend_from_slice(&i.to_le_bytes())),
        PairStore::Wide(p) => p
            .iter()
            .flatten()
            .for_each(|i| out.extend_from_slice(&i.to_le_bytes())),
    }
    k.iter()
        .for_each(|i| out.extend_from_slice(&i.to_le_bytes()));
}

/// The indexes the file at `path` holds, if it is whole, of this format, of catalogue `key` of
/// `n_stars` stars, and consistent. Each column is read straight into its own vector, and
/// summed piece by piece while the piece is fresh in the cache.
fn read(path: &Path, key: u64, n_stars: usize) -> Option<PairIndexes> {
    let file = std::fs::File::open(path).ok()?;
    let len = file.metadata().ok()?.len();
    let mut r = Reader {
        file,
        left: len.checked_sub(8)?,
        sum: crc32fast::Hasher::new(),
    };
    let header_ok = r.word()? == u64::from_le_bytes(*MAGIC)
        && r.word()? == u64::from(INDEX_FILE_FORMAT)
        && r.word()? == key
        && r.word()? == n_stars as u64;
    if !header_ok {
        return None;
    }
    let pairs = r.index(n_stars)?;
    let bright_pairs = match r.word()? {
        0 => None,
        1 => Some(r.index(n_stars)?),
        _ => return None,
    };
    let min_density_sr = r.float()?;
    let density = match r.word()? {
        0 => None,
        1 => {
            let g = usize::try_from(r.word()?).ok()?;
            let radius = r.float()?;
            let n = g.checked_mul(g)?.checked_mul(6)?;
            let per_sr = r.column::<f32>(n)?;
            Some(DensityMap::from_stored_parts(g, radius, per_sr)?)
        }
        _ => return None,
    };
    // All of the body read, then the checksum, then nothing more.
    if r.left != 0 {
        return None;
    }
    let mut sum = [0u8; 8];
    r.file.read_exact(&mut sum).ok()?;
    let at_end = matches!(r.file.read(&mut [0u8; 1]), Ok(0));
    let sound = at_end
        && u64::from_le_bytes(sum) == u64::from(r.sum.finalize())
        && min_density_sr.is_finite()
        && min_density_sr > 0.0;
    sound.then_some(PairIndexes {
        pairs,
        bright_pairs,
        min_density_sr,
        density,
    })
}

/// A file's body read in order, summed as it goes; `left` is what the body has still to give,
/// so that a count read from a damaged header never asks for more than the file holds.
struct Reader {
    file: std::fs::File,
    left: u64,
    sum: crc32fast::Hasher,
}

/// Bytes read and summed at a time: small enough to stay in the cache between the two.
const READ_PIECE: usize = 1 << 18;

impl Reader {
    fn fill(&mut self, out: &mut [u8]) -> Option<()> {
        self.left = self.left.checked_sub(out.len() as u64)?;
        for piece in out.chunks_mut(READ_PIECE) {
            self.file.read_exact(piece).ok()?;
            self.sum.update(piece);
        }
        Some(())
    }

    fn word(&mut self) -> Option<u64> {
        let mut w = [0u8; 8];
        self.fill(&mut w)?;
        Some(u64::from_le_bytes(w))
    }

    fn float(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.word()?))
    }

    /// `n` values stored little-endian, read into a vector of their own.
    fn column<T: bytemuck::Pod + LittleEndian>(&mut self, n: usize) -> Option<Vec<T>> {
        let bytes = n.checked_mul(std::mem::size_of::<T>())?;
        if bytes as u64 > self.left {
            return None;
        }
        let mut out = vec![T::zeroed(); n];
        self.fill(bytemuck::cast_slice_mut::<T, u8>(&mut out))?;
        if cfg!(target_endian = "big") {
            out.iter_mut().for_each(LittleEndian::swap_from_le);
        }
        Some(out)
    }

    fn index(&mut self, n_stars: usize) -> Option<PairIndex> {
        let wide = self.word()?;
        let n_pairs = usize::try_from(self.word()?).ok()?;
        let n_k = usize::try_from(self.word()?).ok()?;
        let (max_angle, slope, intercept) = (self.float()?, self.float()?, self.float()?);
        let pairs = match wide {
            0 => PairStore::Narrow(self.column::<[u16; 2]>(n_pairs)?),
            1 => PairStore::Wide(self.column::<[u32; 2]>(n_pairs)?),
            _ => return None,
        };
        let k: Vec<u32> = self.column(n_k)?;
        PairIndex::from_stored_parts(max_angle, pairs, k, [slope, intercept], n_stars)
    }
}

/// Values of a column whose stored little-endian bytes a big-endian machine swaps.
trait LittleEndian {
    fn swap_from_le(&mut self);
}

impl LittleEndian for u32 {
    fn swap_from_le(&mut self) {
        *self = u32::from_le(*self);
    }
}

impl LittleEndian for f32 {
    fn swap_from_le(&mut self) {
        *self = f32::from_bits(u32::from_le(self.to_bits()));
    }
}

impl<T: LittleEndian> LittleEndian for [T; 2] {
    fn swap_from_le(&mut self) {
        self.iter_mut().for_each(LittleEndian::swap_from_le);
    }
}

impl LittleEndian for u16 {
    fn swap_from_le(&mut self) {
        *self = u16::from_le(*self);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("starid-stored-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn indexes_read_back_as_written() {
        for n in [3000, crate::kvector::NARROW_PAIR_STARS + 10] {
            let cat = crate::simulate::random_catalog(n, 1.0, 6.0, 3).unwrap();
            let built = PairIndexes::build(&cat, 0.05).unwrap();
            let d = dir(&format!("round-{n}"));
            let key = catalog_key(&cat);
            let path = save(&d, key, cat.len(), &built).unwrap();
            let (read, from) = load(&d, &cat, key, 0.045, 1.25).unwrap();
            assert_eq!(from, path);
            assert_eq!(read, built);
            // Too large for a much narrower field, too small for a wider one.
            assert!(load(&d, &cat, key, 0.03, 1.25).is_none());
            assert!(load(&d, &cat, key, 0.06, 1.25).is_none());
            std::fs::remove_dir_all(&d).unwrap();
        }
        // A field wide enough for a map of the sky's star density keeps it too.
        let cat = crate::simulate::random_catalog(3000, 1.0, 6.0, 3).unwrap();
        let built = PairIndexes::build(&cat, 0.3).unwrap();
        assert!(built.density.is_some());
        let d = dir("density");
        let key = catalog_key(&cat);
        save(&d, key, cat.len(), &built).unwrap();
        assert_eq!(load(&d, &cat, key, 0.3, 1.25).unwrap().0, built);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_damaged_or_foreign_file_is_not_read() {
        let cat = crate::simulate::random_catalog(3000, 1.0, 6.0, 4).unwrap();
        let built = PairIndexes::build(&cat, 0.05).unwrap();
        let d = dir("damaged");
        let key = catalog_key(&cat);
        let path = save(&d, key, cat.len(), &built).unwrap();
        let good = std::fs::read(&path).unwrap();
        // Any flipped byte, and any truncation, is caught.
        for at in [0, 9, 20, 40, good.len() / 2, good.len() - 1] {
            let mut bad = good.clone();
            bad[at] ^= 0x10;
            std::fs::write(&path, &bad).unwrap();
            assert!(
                load(&d, &cat, key, 0.05, 1.25).is_none(),
                "flipped byte {at}"
            );
        }
        std::fs::write(&path, &good[..good.len() - 3]).unwrap();
        assert!(load(&d, &cat, key, 0.05, 1.25).is_none());
        // Another catalogue of the same size does not take this one's file, even renamed.
        std::fs::write(&path, &good).unwrap();
        let other = crate::simulate::random_catalog(3000, 1.0, 6.0, 5).unwrap();
        let other_key = catalog_key(&other);
        std::fs::rename(&path, d.join(file_name(other_key, 0.05))).unwrap();
        assert!(load(&d, &other, other_key, 0.05, 1.25).is_none());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn writing_an_index_deletes_the_files_of_older_formats_and_nothing_else() {
        let cat = crate::simulate::random_catalog(3000, 1.0, 6.0, 7).unwrap();
        let built = PairIndexes::build(&cat, 0.05).unwrap();
        let d = dir("formats");
        std::fs::create_dir_all(&d).unwrap();
        let old = d.join("pairs-v3-0123456789abcdef-50000000.idx");
        let foreign = ["notes.txt", "pairs-vX-1.idx", "pairs-v3-1.dat"].map(|n| d.join(n));
        for p in foreign.iter().chain([&old]) {
            std::fs::write(p, b"x").unwrap();
        }
        let key = catalog_key(&cat);
        let path = save(&d, key, cat.len(), &built).unwrap();
        assert!(!old.exists());
        assert!(path.exists() && foreign.iter().all(|p| p.exists()));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_catalogue_changed_in_one_magnitude_has_another_key() {
        let cat = crate::simulate::random_catalog(3000, 1.0, 6.0, 6).unwrap();
        let mut mag = cat.mag().to_vec();
        mag[1234] += 0.001;
        let ra: Vec<f64> = cat.ra_rad().iter().map(|r| r.to_degrees()).collect();
        let dec: Vec<f64> = cat.dec_rad().iter().map(|r| r.to_degrees()).collect();
        let changed = Catalog::new(cat.ids().to_vec(), &ra, &dec, mag).unwrap();
        let same = Catalog::new(cat.ids().to_vec(), &ra, &dec, cat.mag().to_vec()).unwrap();
        let again = Catalog::new(cat.ids().to_vec(), &ra, &dec, cat.mag().to_vec()).unwrap();
        assert_eq!(catalog_key(&same), catalog_key(&again));
        assert_ne!(catalog_key(&changed), catalog_key(&same));
    }
}
