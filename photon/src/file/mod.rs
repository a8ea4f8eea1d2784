//! Photon-map files: the global, caustic and volume maps with the trace parameters, so that another
//! render of the same scene can skip the photon pass.
//!
//! Layout (little-endian): magic `PMPHOTON`, version u32, flags u32, then u64s — scene fingerprint,
//! seed, target global, target caustic, max paths, paths emitted, global paths, caustic paths, number of
//! global photons, caustic photons, irradiance points — then a max radius f32 and 4 zero bytes, then (version 5) six u64s for participating media — target volume, target volume caustic,
//! volume paths, volume caustic paths, number of volume photons, volume caustic photons — (160-byte
//! header; version 4 files, 112 bytes without the media words, are still read); then the photons
//! (13 f32 each: pos, wi, power, normal, kind: 0 caustic, 1 indirect, 2 direct) of the global, caustic,
//! volume and volume caustic maps (a volume photon's normal is zero) and the irradiance points (13 f32
//! each); then an FNV-1a 64 checksum of everything between the magic and it. Irradiance points (a
//! precomputed irradiance the renderer no longer makes: it bakes an atlas) are never written, and
//! skipped where a file of an earlier release holds them (their count 0, the max radius 0).
//! Loading checks magic, version, that the counts match the file length, the checksum (streamed from
//! the disk: all three before allocating; allocations that fail are errors, not aborts), then the scene fingerprint, then every value: positions finite, directions and normals unit
//! length, power and irradiance finite and non-negative, the max radius positive (a file edited with its
//! checksum recomputed is still refused), and — against what the loading scene allows ([`Plausible`]) —
//! no photon beyond the scene's coordinate limit or carrying more power than its lights can give it. Only regular files up to [`MAX_FILE_BYTES`] are opened.
//! Kd-trees are rebuilt on load. Magic, version, checksum and the bounded read are
//! [`pmbase::container`]'s, shared with cache files.
#![forbid(unsafe_code)]

use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

use glam::Vec3;
use pmbase::container::{
    self, Format, OpenError, PrefixError, Reader, CHECKSUM_BYTES, MAGIC_BYTES,
};

use crate::error::{Error, Result};
use crate::map::{Photon, PhotonMap};
use crate::trace::{PhotonMaps, PhotonTargets, TraceStats};

mod read;

use read::Header;
pub use read::{read_maps, read_maps_within};

pub const MAGIC: [u8; 8] = *b"PMPHOTON";
pub(crate) const VERSION: u32 = 5;
/// The header of a version-5 file; a version-4 one is [`HEADER_BYTES_V4`].
const HEADER_BYTES: usize = 160;
const HEADER_BYTES_V4: usize = 112;
const PHOTON_BYTES: u64 = 52;
const POINT_BYTES: u64 = 52;
const HAS_GLOBAL: u32 = 1;
const HAS_CAUSTIC: u32 = 2;
const HAS_PRECOMPUTED: u32 = 4;
const HAS_VOLUME: u32 = 8;
const HAS_VOLUME_CAUSTIC: u32 = 16;
/// Largest photon-map file read: 100 million photons in each map and as many irradiance points.
pub const MAX_FILE_BYTES: u64 =
    HEADER_BYTES as u64 + 100_000_000 * (4 * PHOTON_BYTES + POINT_BYTES) + CHECKSUM_BYTES as u64;

/// The container: the checksum covers everything after the magic.
const FORMAT: Format = Format {
    magic: MAGIC,
    checksum_from: MAGIC_BYTES,
    max_file_bytes: MAX_FILE_BYTES,
};

/// What produced the maps: the caller's scene fingerprint and the trace parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapsInfo {
    pub fingerprint: u64,
    pub seed: u64,
    pub targets: PhotonTargets,
    pub n_paths_emitted: u64,
    pub n_global_paths: u64,
    pub n_caustic_paths: u64,
    pub n_volume_paths: u64,
    pub n_volume_caustic_paths: u64,
}

impl MapsInfo {
    pub fn new(
        fingerprint: u64,
        seed: u64,
        targets: PhotonTargets,
        stats: &TraceStats,
    ) -> MapsInfo {
        MapsInfo {
            fingerprint,
            seed,
            targets,
            n_paths_emitted: stats.n_paths_emitted,
            n_global_paths: stats.n_global_paths,
            n_caustic_paths: stats.n_caustic_paths,
            n_volume_paths: stats.n_volume_paths,
            n_volume_caustic_paths: stats.n_volume_caustic_paths,
        }
    }
}

/// What the scene loading a file allows its photons to be. The checksum only proves that the file is
/// what was written; these bounds refuse values no trace of the scene writes (a photon of 1e30 W).
#[derive(Clone, Copy, Debug)]
pub struct Plausible {
    /// The most power (W, in any channel) one photon path may carry. A photon holds its path's power
    /// over the paths its map was normalised by, so its power times those paths must stay below.
    pub max_path_power: f64,
    /// The largest |coordinate| of a photon's position.
    pub max_coord: f32,
}

impl Plausible {
    /// No bound beyond the values being finite.
    pub const ANY: Plausible = Plausible {
        max_path_power: f64::INFINITY,
        max_coord: f32::INFINITY,
    };
}

/// The contents of a photon-map file.
pub struct LoadedMaps {
    pub info: MapsInfo,
    pub maps: PhotonMaps,
}

/// Writes the file format to `w`.
pub fn write_maps<W: Write>(w: W, info: &MapsInfo, maps: &PhotonMaps) -> std::io::Result<()> {
    let mut h = FORMAT.writer(w, VERSION)?;
    let global = maps.global.as_ref().map_or(&[][..], |m| m.photons());
    let caustic = maps.caustic.as_ref().map_or(&[][..], |m| m.photons());
    let volume = maps.volume.as_ref().map_or(&[][..], |m| m.photons());
    let volume_caustic = maps
        .volume_caustic
        .as_ref()
        .map_or(&[][..], |m| m.photons());
    let flags = maps.global.as_ref().map_or(0, |_| HAS_GLOBAL)
        | maps.caustic.as_ref().map_or(0, |_| HAS_CAUSTIC)
        | maps.volume.as_ref().map_or(0, |_| HAS_VOLUME)
        | maps
            .volume_caustic
            .as_ref()
            .map_or(0, |_| HAS_VOLUME_CAUSTIC);
    h.write_all(&flags.to_le_bytes())?;
    let t = &info.targets;
    for v in [
        info.fingerprint,
        info.seed,
        t.global as u64,
        t.caustic as u64,
        t.max_paths,
        info.n_paths_emitted,
        info.n_global_paths,
        info.n_caustic_paths,
        global.len() as u64,
        caustic.len() as u64,
        0,
    ] {
        h.write_all(&v.to_le_bytes())?;
    }
    h.write_all(&0.0f32.to_le_bytes())?;
    h.write_all(&[0u8; 4])?;
    for v in [
        t.volume as u64,
        t.volume_caustic as u64,
        info.n_volume_paths,
        info.n_volume_caustic_paths,
        volume.len() as u64,
        volume_caustic.len() as u64,
    ] {
        h.write_all(&v.to_le_bytes())?;
    }
    for ph in global
        .iter()
        .chain(caustic)
        .chain(volume)
        .chain(volume_caustic)
    {
        write_vecs(&mut h, &[ph.pos, ph.wi, ph.power, ph.normal])?;
        h.write_all(
            &(if ph.direct {
                2.0f32
            } else {
                ph.indirect as u8 as f32
            })
            .to_le_bytes(),
        )?;
    }
    h.finish()?.flush()
}

fn write_vecs<W: Write>(w: &mut W, vs: &[Vec3]) -> std::io::Result<()> {
    let mut buf = [0u8; 48];
    for (i, x) in vs.iter().flat_map(|v| v.to_array()).enumerate() {
        buf[4 * i..4 * i + 4].copy_from_slice(&x.to_le_bytes());
    }
    w.write_all(&buf[..12 * vs.len()])
}

/// Saves to `path` (through a temporary file renamed into place).
pub fn save(path: &Path, info: &MapsInfo, maps: &PhotonMaps) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let file = File::create(&tmp).map_err(io)?;
    write_maps(BufWriter::new(file), info, maps).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Loads from `path`; the file must have been made for `expected_fingerprint`, its photons within
/// `plausible`.
pub fn load(path: &Path, expected_fingerprint: u64, plausible: &Plausible) -> Result<LoadedMaps> {
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let open_error = |e| match e {
        OpenError::Io(source) => io(source),
        OpenError::NotRegularFile => Error::NotRegularFile {
            path: path.to_path_buf(),
        },
        OpenError::TooLarge { bytes, limit } => Error::TooLarge {
            path: path.to_path_buf(),
            bytes,
            limit,
        },
        OpenError::Checksum(_) => Error::Checksum,
        OpenError::OutOfMemory { bytes } => Error::OutOfMemory { bytes },
    };
    let (mut file, actual) = FORMAT.open(path).map_err(open_error)?;
    let mut header = vec![0u8; HEADER_BYTES.min(actual as usize)];
    file.read_exact(&mut header).map_err(io)?;
    let expected = Header::parse(&header)?.file_len()?;
    if expected != actual {
        return Err(Error::BadLength { expected, actual });
    }
    // The counts agree with the length; a damaged file is still refused before they are allocated.
    FORMAT.verify_file(&mut file, actual).map_err(open_error)?;
    let bytes = FORMAT.read_open(file, actual).map_err(open_error)?;
    read_maps_within(&bytes, expected_fingerprint, plausible)
}
