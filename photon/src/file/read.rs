//! Reading a photon-map file: its header, every value checked, the maps rebuilt.

use super::*;

pub(super) struct Header {
    pub(super) flags: u32,
    /// The 11 words of version 4, then the 6 media words of version 5 (zero in a version-4 file).
    pub(super) words: [u64; 17],
    /// Where the photons start: [`HEADER_BYTES`], or [`HEADER_BYTES_V4`].
    pub(super) len: usize,
}

impl Header {
    /// Refuses photons counted for a map the flags say is absent.
    pub(super) fn check_flags(&self) -> Result<()> {
        let (n_global, n_caustic, n_volume, n_volume_caustic, n_points) = self.counts();
        let flag = |f: u32| self.flags & f != 0;
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
        Ok(())
    }

    /// What produced the maps, as the header's words say.
    pub(super) fn info(&self) -> MapsInfo {
        let w = &self.words;
        MapsInfo {
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
        }
    }

    pub(super) fn parse(bytes: &[u8]) -> Result<Header> {
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
    pub(super) fn counts(&self) -> (u64, u64, u64, u64, u64) {
        (
            self.words[8],
            self.words[9],
            self.words[15],
            self.words[16],
            self.words[10],
        )
    }

    /// The file length the counts imply (overflow is corruption).
    pub(super) fn file_len(&self) -> Result<u64> {
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

pub(super) fn is_unit(v: Vec3) -> bool {
    v.is_finite() && (v.length() - 1.0).abs() < 1e-3
}

/// The map a photon is read into: whether its photons are in a medium (a zero normal, not a unit one)
/// and the paths its powers were normalised by.
#[derive(Clone, Copy)]
pub(super) struct MapKind {
    pub(super) in_medium: bool,
    pub(super) n_paths: u64,
}

/// Why a photon read from a file cannot be used (the checksum only proves it is what was written).
pub(super) fn photon_problem(
    ph: &Photon,
    flag: f32,
    map: MapKind,
    plausible: &Plausible,
) -> Option<String> {
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

/// One photon's 13 floats from `next` (pos, wi, power, normal, kind), and its kind's value.
fn photon_from(next: &mut impl FnMut() -> f32) -> (Photon, f32) {
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
    (photon, flag)
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
    header.check_flags()?;
    let (n_global, n_caustic, n_volume, n_volume_caustic, _) = header.counts();
    let flag = |f: u32| header.flags & f != 0;
    let info = header.info();
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
                let (photon, flag) = photon_from(&mut next);
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
