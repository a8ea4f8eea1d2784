//! Cache files: a second render of the same scene (another view, crop or machine) reuses the records.
//!
//! Layout, little-endian: magic `PMICACHE`, version u32, scene fingerprint u64 (the caller's hash of
//! whatever makes records valid), parameters, index bounds, stage count u32, record count u64, the stages
//! (u32 each: the record count after pass A and after each round of pass B; see
//! [`IrradianceCache::stages`]), records (33 × f32 each), then FNV-1a 64 of every preceding byte.
//! Lengths are checked against the count before anything is allocated, and every field is validated, so
//! a bad file is an error, never a panic. Magic, version, checksum and the bounded read are
//! [`pmbase::container`]'s, shared with photon-map files.
#![forbid(unsafe_code)]

use std::io::Read;
use std::path::Path;

use pmbase::container::{Format, OpenError, PrefixError, Reader, CHECKSUM_BYTES, PREFIX_BYTES};

use crate::cache::IrradianceCache;
use crate::error::{Error, Result};
use crate::params::{CacheParams, Weighting};
use crate::record::{Record, RECORD_FLOATS};

pub(crate) const FILE_VERSION: u32 = 3;
/// magic 8 + version 4 + fingerprint 8 + params 24 + bounds 24 + stage count 4 + record count 8.
pub const HEADER_BYTES: usize = 80;
/// Most stages a file holds (pass A and the rounds of pass B: 4, 8, 16, … samples up to 100 000).
pub(crate) const MAX_STAGES: usize = 64;
const RECORD_BYTES: usize = RECORD_FLOATS * 4;
/// Largest cache file read: 32 million records (a cache holds thousands to a few million).
pub(crate) const MAX_FILE_BYTES: u64 = HEADER_BYTES as u64
    + 4 * MAX_STAGES as u64
    + (32 << 20) * RECORD_BYTES as u64
    + CHECKSUM_BYTES as u64;

/// The container: the checksum covers every byte before it.
const FORMAT: Format = Format {
    magic: *b"PMICACHE",
    checksum_from: 0,
    max_file_bytes: MAX_FILE_BYTES,
};

/// FNV-1a 64, the files' checksum (the root crate fingerprints scenes with it too).
pub use pmbase::container::fnv1a64;

fn write_params(out: &mut Vec<u8>, p: &CacheParams) {
    out.extend_from_slice(&p.accuracy.to_le_bytes());
    out.push(match p.weight {
        Weighting::TabellionLamorlette => 0,
        Weighting::Ward => 1,
    });
    out.push(p.neighbor_clamping as u8);
    out.push(p.gradients as u8);
    out.push(p.pass_b_accuracy.is_some() as u8);
    out.extend_from_slice(&p.min_spacing_px.to_le_bytes());
    out.extend_from_slice(&p.max_spacing_px.to_le_bytes());
    out.extend_from_slice(&p.pass_b_accuracy.unwrap_or(0.0).to_le_bytes());
    // Adaptive caching's Weber threshold, 0 when off.
    out.extend_from_slice(&p.adaptive.unwrap_or(0.0).to_le_bytes());
}

fn read_params(c: &mut Reader) -> Result<CacheParams> {
    let accuracy = c.f32();
    let weight = match c.u8() {
        0 => Weighting::TabellionLamorlette,
        1 => Weighting::Ward,
        w => {
            return Err(Error::InvalidParams(format!(
                "unknown weighting {w} in cache file"
            )))
        }
    };
    let flag = |v: u8, name: &str| match v {
        0 => Ok(false),
        1 => Ok(true),
        _ => Err(Error::InvalidParams(format!(
            "flag {name} = {v} in cache file"
        ))),
    };
    let neighbor_clamping = flag(c.u8(), "neighbor_clamping")?;
    let gradients = flag(c.u8(), "gradients")?;
    let has_b = flag(c.u8(), "pass_b_accuracy")?;
    let (min_spacing_px, max_spacing_px, b, adaptive) = (c.f32(), c.f32(), c.f32(), c.f32());
    let p = CacheParams {
        accuracy,
        weight,
        neighbor_clamping,
        gradients,
        min_spacing_px,
        max_spacing_px,
        pass_b_accuracy: has_b.then_some(b),
        adaptive: (adaptive != 0.0).then_some(adaptive),
    };
    p.validate()?;
    Ok(p)
}

/// Largest irradiance or gradient component a record read from a file may hold: interpolation sums
/// weighted records, and values near f32's limit (3.4e38) overflowed to inf pixels. No scene within
/// the loader's limits comes near it.
pub const MAX_RECORD_VALUE: f32 = 1e30;

/// Why a record read from a file cannot be used, if it cannot.
fn record_problem(r: &Record) -> Option<&'static str> {
    let vecs_finite = [r.pos, r.normal, r.e, r.dir]
        .iter()
        .chain(&r.grad_r)
        .chain(&r.grad_t)
        .all(|v| v.is_finite());
    if !vecs_finite {
        return Some("non-finite vector");
    }
    let vecs_bounded = [r.e]
        .iter()
        .chain(&r.grad_r)
        .chain(&r.grad_t)
        .all(|v| v.abs().max_element() <= MAX_RECORD_VALUE);
    if !vecs_bounded {
        return Some("irradiance or gradient beyond 1e30");
    }
    if (r.normal.length() - 1.0).abs() > 1e-3 {
        return Some("normal is not unit length");
    }
    if r.e.min_element() < 0.0 {
        return Some("negative irradiance");
    }
    if r.r_harmonic.is_nan() || r.r_harmonic < 0.0 {
        return Some("invalid harmonic distance");
    }
    if !(r.r_clamped.is_finite()
        && r.r_clamped > 0.0
        && r.pixel_world.is_finite()
        && r.pixel_world > 0.0)
    {
        return Some("invalid radius or pixel footprint");
    }
    None
}

/// Checks the header at the start of `bytes` (magic, version, stage count) against the length of the
/// file, `available` bytes, and returns its stage and record counts.
fn check_layout(bytes: &[u8], available: u64) -> Result<(usize, u64)> {
    let truncated = |what, needed: u64| Error::Truncated {
        what,
        needed,
        available,
    };
    let version = FORMAT.version(bytes).map_err(|e| match e {
        PrefixError::BadMagic => Error::BadMagic,
        PrefixError::Truncated => truncated("magic and version", PREFIX_BYTES as u64),
    })?;
    if version != FILE_VERSION {
        return Err(Error::UnsupportedVersion {
            found: version,
            supported: FILE_VERSION,
        });
    }
    if bytes.len() < HEADER_BYTES || available < (HEADER_BYTES + CHECKSUM_BYTES) as u64 {
        return Err(truncated("header", (HEADER_BYTES + CHECKSUM_BYTES) as u64));
    }
    let n_stages = Reader::new(bytes, HEADER_BYTES - 12).u32() as usize;
    if n_stages > MAX_STAGES {
        return Err(Error::InvalidParams(format!(
            "{n_stages} stages in cache file (at most {MAX_STAGES})"
        )));
    }
    let count = Reader::new(bytes, HEADER_BYTES - 8).u64();
    let needed = (count as u128) * RECORD_BYTES as u128
        + (HEADER_BYTES + 4 * n_stages + CHECKSUM_BYTES) as u128;
    if needed != available as u128 {
        return Err(truncated("records", needed.min(u64::MAX as u128) as u64));
    }
    Ok((n_stages, count))
}

impl IrradianceCache {
    /// Serialise the cache; `fingerprint` identifies the scene the records belong to.
    pub fn to_bytes(&self, fingerprint: u64) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            HEADER_BYTES + 4 * MAX_STAGES + self.records.len() * RECORD_BYTES + CHECKSUM_BYTES,
        );
        out.extend_from_slice(&FORMAT.prefix(FILE_VERSION));
        out.extend_from_slice(&fingerprint.to_le_bytes());
        write_params(&mut out, &self.params);
        for v in [self.bounds.0, self.bounds.1] {
            v.to_array()
                .iter()
                .for_each(|f| out.extend_from_slice(&f.to_le_bytes()));
        }
        let stages = &self.stages[..self.stages.len().min(MAX_STAGES)];
        out.extend_from_slice(&(stages.len() as u32).to_le_bytes());
        out.extend_from_slice(&(self.records.len() as u64).to_le_bytes());
        stages
            .iter()
            .for_each(|n| out.extend_from_slice(&n.to_le_bytes()));
        for r in &self.records {
            r.to_floats()
                .iter()
                .for_each(|f| out.extend_from_slice(&f.to_le_bytes()));
        }
        let sum = FORMAT.checksum(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Read a cache written by [`to_bytes`](Self::to_bytes) for the scene with `fingerprint`.
    pub fn from_bytes(bytes: &[u8], fingerprint: u64) -> Result<Self> {
        let (n_stages, count) = check_layout(bytes, bytes.len() as u64)?;
        FORMAT
            .verify_checksum(bytes)
            .map_err(|m| Error::ChecksumMismatch {
                stored: m.stored,
                computed: m.computed,
            })?;
        let mut c = Reader::new(bytes, PREFIX_BYTES);
        let found = c.u64();
        if found != fingerprint {
            return Err(Error::FingerprintMismatch {
                expected: fingerprint,
                found,
            });
        }
        let params = read_params(&mut c)?;
        let (lo, hi) = (c.vec3(), c.vec3());
        let mut cache = IrradianceCache::new(lo, hi, params)?;
        c.u32(); // stage count, read above
        c.u64(); // record count, read above
        let stages: Vec<u32> = (0..n_stages).map(|_| c.u32()).collect();
        if stages.windows(2).any(|w| w[0] > w[1])
            || stages.last().is_some_and(|&n| n as u64 > count)
        {
            return Err(Error::InvalidParams(format!(
                "cache file stages {stages:?} are not record counts in order (of {count})"
            )));
        }
        cache
            .records
            .try_reserve_exact(count as usize)
            .map_err(|_| Error::OutOfMemory {
                bytes: count.saturating_mul(std::mem::size_of::<Record>() as u64),
            })?;
        for index in 0..count {
            let mut floats = [0f32; RECORD_FLOATS];
            floats.iter_mut().for_each(|f| *f = c.f32());
            let rec = Record::from_floats(&floats);
            if let Some(reason) = record_problem(&rec) {
                return Err(Error::CorruptRecord { index, reason });
            }
            cache.push_raw(rec);
        }
        cache.stages = stages;
        cache.frozen = cache.len();
        Ok(cache)
    }

    /// Read a cache file for the scene with `fingerprint`: only a regular file (a FIFO would block, a
    /// device never end) of at most `MAX_FILE_BYTES`, whose header agrees with its length and whose
    /// checksum, streamed from the disk, matches — before its records are allocated.
    pub fn load(path: &Path, fingerprint: u64) -> Result<Self> {
        let open_error = |e| match e {
            OpenError::Io(e) => Error::Io(e),
            OpenError::NotRegularFile => Error::NotRegularFile,
            OpenError::TooLarge { bytes, limit } => Error::TooLarge { bytes, limit },
            OpenError::Checksum(m) => Error::ChecksumMismatch {
                stored: m.stored,
                computed: m.computed,
            },
            OpenError::OutOfMemory { bytes } => Error::OutOfMemory { bytes },
        };
        let (mut file, len) = FORMAT.open(path).map_err(open_error)?;
        let mut header = Vec::new();
        (&mut file)
            .take(HEADER_BYTES as u64)
            .read_to_end(&mut header)?;
        check_layout(&header, len)?;
        FORMAT.verify_file(&mut file, len).map_err(open_error)?;
        let bytes = FORMAT.read_open(file, len).map_err(open_error)?;
        Self::from_bytes(&bytes, fingerprint)
    }
}
