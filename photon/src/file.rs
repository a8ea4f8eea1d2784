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

struct Header {
    flags: u32,
    /// The 11 words of version 4, then the 6 media words of version 5 (zero in a version-4 file).
    words: [u64; 17],
    /// Where the photons start: [`HEADER_BYTES`], or [`HEADER_BYTES_V4`].
    len: usize,
}

impl Header {
    fn parse(bytes: &[u8]) -> Result<Header> {
        let version = FORMAT.version(bytes).map_err(|e| match e {
            PrefixError::BadMagic => Error::BadMagic,
            PrefixError::Truncated => Error::BadLength {
                expected: (HEADER_BYTES + CHECKSUM_BYTES) as u64,
                actual: bytes.len() as u64,
            },
        })?;
        let len = match version {
            VERSION => HEADER_BYTES,
            4 => HEADER_BYTES_V4,
            _ => {
                return Err(Error::UnsupportedVersion {
                    found: version,
                    expected: VERSION,
                })
            }
        };
        if bytes.len() < len {
            return Err(Error::BadLength {
                expected: (len + CHECKSUM_BYTES) as u64,
                actual: bytes.len() as u64,
            });
        }
        let mut r = Reader::new(bytes, container::PREFIX_BYTES);
        let flags = r.u32();
        let mut words = [0u64; 17];
        words[..11].iter_mut().for_each(|w| *w = r.u64());
        r.skip(8); // an earlier release's max radius of its irradiance points, and zero
        if len == HEADER_BYTES {
            words[11..].iter_mut().for_each(|w| *w = r.u64());
        }
        Ok(Header { flags, words, len })
    }

    /// Photons of the global, caustic, volume and volume caustic maps, and irradiance points.
    fn counts(&self) -> (u64, u64, u64, u64, u64) {
        (
            self.words[8],
            self.words[9],
            self.words[15],
            self.words[16],
            self.words[10],
        )
    }

    /// The file length the counts imply (overflow is corruption).
    fn file_len(&self) -> Result<u64> {
        let (g, c, v, w, p) = self.counts();
        let photons = g
            .checked_add(c)
            .and_then(|n| n.checked_add(v))
            .and_then(|n| n.checked_add(w))
            .and_then(|n| n.checked_mul(PHOTON_BYTES));
        let points = p.checked_mul(POINT_BYTES);
        photons
            .zip(points)
            .and_then(|(a, b)| a.checked_add(b))
            .and_then(|n| n.checked_add((self.len + CHECKSUM_BYTES) as u64))
            .ok_or_else(|| Error::Corrupt("photon counts overflow".into()))
    }
}

fn is_unit(v: Vec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() < 1e-3
}

/// The map a photon is read into: whether its photons are in a medium (a zero normal, not a unit one)
/// and the paths its powers were normalised by.
#[derive(Clone, Copy)]
struct MapKind {
    in_medium: bool,
    n_paths: u64,
}

/// Why a photon read from a file cannot be used (the checksum only proves it is what was written).
fn photon_problem(ph: &Photon, flag: f32, map: MapKind, plausible: &Plausible) -> Option<String> {
    let path_power = ph.power.max_element() as f64 * map.n_paths.max(1) as f64;
    let why = if !ph.pos.is_finite() {
        "position is not finite"
    } else if !is_unit(ph.wi) {
        "direction is not a unit vector"
    } else if !(ph.power.is_finite() && ph.power.min_element() >= 0.0) {
        "power is not finite and non-negative"
    } else if !map.in_medium && !is_unit(ph.normal) {
        "normal is not a unit vector"
    } else if map.in_medium && ph.normal != Vec3::ZERO {
        "a volume photon's normal is not zero"
    } else if flag != 0.0 && flag != 1.0 && flag != 2.0 {
        "kind is not 0 (caustic), 1 (indirect) or 2 (direct)"
    } else if ph.pos.abs().max_element() > plausible.max_coord {
        return Some(format!(
            "position {} is beyond the scene's coordinate limit ±{:e}",
            ph.pos, plausible.max_coord
        ));
    } else if path_power > plausible.max_path_power {
        return Some(format!(
            "power {:e} W over the map's {} paths is {path_power:e} W for one path, more than the \
             scene's lights can give it ({:e} W)",
            ph.power.max_element(),
            map.n_paths,
            plausible.max_path_power
        ));
    } else {
        return None;
    };
    Some(why.to_string())
}

/// Parses a whole file held in memory, with no bound on its photons but their values being finite.
pub fn read_maps(bytes: &[u8], expected_fingerprint: u64) -> Result<LoadedMaps> {
    read_maps_within(bytes, expected_fingerprint, &Plausible::ANY)
}

/// Parses a whole file held in memory; its photons must be within `plausible`.
pub fn read_maps_within(
    bytes: &[u8],
    expected_fingerprint: u64,
    plausible: &Plausible,
) -> Result<LoadedMaps> {
    let header = Header::parse(bytes)?;
    let expected = header.file_len()?;
    if expected != bytes.len() as u64 {
        return Err(Error::BadLength {
            expected,
            actual: bytes.len() as u64,
        });
    }
    FORMAT.verify_checksum(bytes).map_err(|_| Error::Checksum)?;
    let w = header.words;
    if w[0] != expected_fingerprint {
        return Err(Error::SceneMismatch {
            found: w[0],
            expected: expected_fingerprint,
        });
    }
    let (n_global, n_caustic, n_volume, n_volume_caustic, n_points) = header.counts();
    let flag = |f: u32| header.flags & f != 0;
    if (!flag(HAS_GLOBAL) && n_global > 0)
        || (!flag(HAS_CAUSTIC) && n_caustic > 0)
        || (!flag(HAS_VOLUME) && n_volume > 0)
        || (!flag(HAS_VOLUME_CAUSTIC) && n_volume_caustic > 0)
        || (!flag(HAS_PRECOMPUTED) && n_points > 0)
    {
        return Err(Error::Corrupt(
            "photons present for a map flagged absent".into(),
        ));
    }
    let info = MapsInfo {
        fingerprint: w[0],
        seed: w[1],
        targets: PhotonTargets {
            global: w[2] as usize,
            caustic: w[3] as usize,
            volume: w[11] as usize,
            volume_caustic: w[12] as usize,
            max_paths: w[4],
        },
        n_paths_emitted: w[5],
        n_global_paths: w[6],
        n_caustic_paths: w[7],
        n_volume_paths: w[13],
        n_volume_caustic_paths: w[14],
    };
    let mut floats = Reader::new(bytes, header.len);
    let mut next = || floats.f32();
    let mut read_photons = |name: &str, n: u64, map: MapKind| -> Result<Vec<Photon>> {
        let mut photons = Vec::new();
        photons
            .try_reserve_exact(n as usize)
            .map_err(|_| Error::OutOfMemory {
                bytes: n.saturating_mul(std::mem::size_of::<Photon>() as u64),
            })?;
        (0..n)
            .map(|index| {
                let mut v = || Vec3::new(next(), next(), next());
                let (pos, wi, power, normal) = (v(), v(), v(), v());
                let flag = next();
                let photon = Photon {
                    pos,
                    wi,
                    power,
                    normal,
                    indirect: flag == 1.0,
                    direct: flag == 2.0,
                };
                match photon_problem(&photon, flag, map, plausible) {
                    Some(why) => Err(Error::Corrupt(format!("{name} photon {index}: {why}"))),
                    None => Ok(photon),
                }
            })
            .try_for_each(|photon| photon.map(|p| photons.push(p)))?;
        Ok(photons)
    };
    let kind = |in_medium: bool, n_paths: u64| MapKind { in_medium, n_paths };
    let global = read_photons("global", n_global, kind(false, info.n_global_paths))?;
    let caustic = read_photons("caustic", n_caustic, kind(false, info.n_caustic_paths))?;
    let volume = read_photons("volume", n_volume, kind(true, info.n_volume_paths))?;
    let volume_caustic = read_photons(
        "volume caustic",
        n_volume_caustic,
        kind(true, info.n_volume_caustic_paths),
    )?;
    // What follows is an earlier release's irradiance points (covered by the checksum), unused.
    let corrupt = |e: Error| Error::Corrupt(format!("cannot rebuild a kd-tree: {e}"));
    let map = |present: bool, photons: Vec<Photon>| -> Result<Option<PhotonMap>> {
        if present {
            PhotonMap::new(photons).map(Some).map_err(corrupt)
        } else {
            Ok(None)
        }
    };
    let maps = PhotonMaps {
        global: map(flag(HAS_GLOBAL), global)?,
        caustic: map(flag(HAS_CAUSTIC), caustic)?,
        volume: map(flag(HAS_VOLUME), volume)?,
        volume_caustic: map(flag(HAS_VOLUME_CAUSTIC), volume_caustic)?,
    };
    Ok(LoadedMaps { info, maps })
}
