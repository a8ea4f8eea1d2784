//! Cache files: a second render of the same scene (another view, crop or machine) reuses the records.
//!
//! Layout, little-endian: magic `PMICACHE`, version u32, scene fingerprint u64 (the caller's hash of
//! whatever makes records valid), parameters, index bounds, stage count u32, record count u64, the stages
//! (u32 each: the record count after pass A and after each round of pass B; see
//! [`IrradianceCache::stages`]), records (33 × f32 each), then FNV-1a 64 of every preceding byte. Lengths are checked against the count before anything is
//! allocated, and every field is validated, so a bad file is an error, never a panic.
#![forbid(unsafe_code)]

use std::path::Path;

use glam::Vec3;

use crate::cache::IrradianceCache;
use crate::error::{Error, Result};
use crate::params::{CacheParams, Weighting};
use crate::record::{Record, RECORD_FLOATS};

const MAGIC: &[u8; 8] = b"PMICACHE";
pub(crate) const FILE_VERSION: u32 = 3;
/// magic 8 + version 4 + fingerprint 8 + params 24 + bounds 24 + stage count 4 + record count 8.
pub const HEADER_BYTES: usize = 80;
/// Most stages a file holds (pass A and the rounds of pass B: 4, 8, 16, … samples up to 100 000).
pub(crate) const MAX_STAGES: usize = 64;
const RECORD_BYTES: usize = RECORD_FLOATS * 4;
const CHECKSUM_BYTES: usize = 8;
/// Largest cache file read: 32 million records (a cache holds thousands to a few million).
pub(crate) const MAX_FILE_BYTES: u64 = HEADER_BYTES as u64
    + 4 * MAX_STAGES as u64
    + (32 << 20) * RECORD_BYTES as u64
    + CHECKSUM_BYTES as u64;

/// FNV-1a, 64 bit.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// Little-endian reader over a slice whose total length was checked beforehand.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Cursor<'_> {
    fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.bytes[self.at..self.at + N]);
        self.at += N;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }
    fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }
    fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
    fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
}

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

fn read_params(c: &mut Cursor) -> Result<CacheParams> {
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

impl IrradianceCache {
    /// Serialise the cache; `fingerprint` identifies the scene the records belong to.
    pub fn to_bytes(&self, fingerprint: u64) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            HEADER_BYTES + 4 * MAX_STAGES + self.records.len() * RECORD_BYTES + CHECKSUM_BYTES,
        );
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FILE_VERSION.to_le_bytes());
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
        let sum = fnv1a64(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Read a cache written by [`to_bytes`](Self::to_bytes) for the scene with `fingerprint`.
    pub fn from_bytes(bytes: &[u8], fingerprint: u64) -> Result<Self> {
        let available = bytes.len() as u64;
        let truncated = |what, needed: u64| Error::Truncated {
            what,
            needed,
            available,
        };
        if bytes.len() < MAGIC.len() + 4 {
            return Err(if bytes.len() >= MAGIC.len() && &bytes[..8] != MAGIC {
                Error::BadMagic
            } else {
                truncated("magic and version", (MAGIC.len() + 4) as u64)
            });
        }
        let mut c = Cursor { bytes, at: 0 };
        if &c.take::<8>() != MAGIC {
            return Err(Error::BadMagic);
        }
        let version = c.u32();
        if version != FILE_VERSION {
            return Err(Error::UnsupportedVersion {
                found: version,
                supported: FILE_VERSION,
            });
        }
        if bytes.len() < HEADER_BYTES + CHECKSUM_BYTES {
            return Err(truncated("header", (HEADER_BYTES + CHECKSUM_BYTES) as u64));
        }
        let n_stages = u32::from_le_bytes(
            bytes[HEADER_BYTES - 12..HEADER_BYTES - 8]
                .try_into()
                .expect("4 bytes"),
        ) as usize;
        if n_stages > MAX_STAGES {
            return Err(Error::InvalidParams(format!(
                "{n_stages} stages in cache file (at most {MAX_STAGES})"
            )));
        }
        let count = u64::from_le_bytes(
            bytes[HEADER_BYTES - 8..HEADER_BYTES]
                .try_into()
                .expect("8 bytes"),
        );
        let needed = (count as u128) * RECORD_BYTES as u128
            + (HEADER_BYTES + 4 * n_stages + CHECKSUM_BYTES) as u128;
        if needed != available as u128 {
            return Err(truncated("records", needed.min(u64::MAX as u128) as u64));
        }
        let body = bytes.len() - CHECKSUM_BYTES;
        let stored = u64::from_le_bytes(bytes[body..].try_into().expect("8 bytes"));
        let computed = fnv1a64(&bytes[..body]);
        if stored != computed {
            return Err(Error::ChecksumMismatch { stored, computed });
        }
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
        cache.records.reserve_exact(count as usize);
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
    /// device never end) of at most `MAX_FILE_BYTES`.
    pub fn load(path: &Path, fingerprint: u64) -> Result<Self> {
        use std::io::Read;
        let meta = std::fs::metadata(path)?;
        if !meta.is_file() {
            return Err(Error::NotRegularFile);
        }
        if meta.len() > MAX_FILE_BYTES {
            return Err(Error::TooLarge {
                bytes: meta.len(),
                limit: MAX_FILE_BYTES,
            });
        }
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        std::fs::File::open(path)?
            .take(MAX_FILE_BYTES + 1)
            .read_to_end(&mut bytes)?;
        if bytes.len() as u64 > MAX_FILE_BYTES {
            return Err(Error::TooLarge {
                bytes: bytes.len() as u64,
                limit: MAX_FILE_BYTES,
            });
        }
        Self::from_bytes(&bytes, fingerprint)
    }
}
