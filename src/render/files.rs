//! Photon-map and cache files around a render: load/save (fingerprinted), the PLY dump of the photons,
//! and the cache-record image. Saved files are staged in an [`OutputSet`] with the images, so they
//! appear only if the whole render and every write succeeded.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;
use icache::IrradianceCache;
use photon::{MapsInfo, PhotonMaps, Plausible};

use crate::camera::Camera;
use crate::error::{option, Result};
use crate::io::atomic::OutputSet;
use crate::io::output::{stage_png, Image};
use crate::scene::limits::MAX_COORD;
use crate::scene::{Method, Scene};

/// Files a render reads or writes besides its images.
#[derive(Clone, Debug, Default)]
pub struct FileOptions {
    pub save_photons: Option<PathBuf>,
    pub load_photons: Option<PathBuf>,
    pub dump_photons: Option<PathBuf>,
    pub save_cache: Option<PathBuf>,
    pub load_cache: Option<PathBuf>,
    pub cache_image: Option<PathBuf>,
    /// Keep the traced photon maps in the output though no file names them (a bake kept by the caller).
    pub keep_maps: bool,
}

impl FileOptions {
    /// Whether the traced maps outlive the render (a file saves them or the caller keeps them).
    pub fn keeps_maps(&self) -> bool {
        self.keep_maps || self.save_photons.is_some() || self.dump_photons.is_some()
    }
}

/// Traced photon maps kept for `--save-photons` / `--dump-photons`, written with the other outputs.
pub struct PhotonOutput {
    pub info: MapsInfo,
    pub maps: PhotonMaps,
}

/// How far above the lights' total power (its largest channel) one photon path's power may be. The
/// sampling weights raise it a few times — a light chosen by its mean over the channels, a spot's
/// falloff, the hero channel's weight in media (at most ×7 in the shipped and test scenes) — never by
/// orders of magnitude.
const PATH_POWER_MARGIN: f64 = 1e4;

/// What `scene` allows the photons of a file loaded for it to be.
pub fn plausible(scene: &Scene) -> Plausible {
    Plausible {
        max_path_power: PATH_POWER_MARGIN * scene.lights.total_power().max_element() as f64,
        // A point computed on a triangle at the limit may round a little past it.
        max_coord: 2.0 * MAX_COORD,
    }
}

pub fn load_photons(path: &Path, scene: &Scene) -> Result<photon::LoadedMaps> {
    photon::file::load(path, scene.fingerprint, &plausible(scene))
        .map_err(|e| option("--load-photons", format!("{}: {e}", path.display())))
}

pub fn save_photons(set: &mut OutputSet, path: &Path, p: &PhotonOutput) -> Result<()> {
    set.stage(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
        let mut w = std::io::BufWriter::new(file);
        photon::file::write_maps(&mut w, &p.info, &p.maps).map_err(|e| e.to_string())?;
        std::io::Write::flush(&mut w).map_err(|e| e.to_string())
    })
}

/// The fingerprint a cache file of `scene` rendered by `method` carries: the scene's, for `ao` with
/// its occlusion distance mixed in (occlusion records are no irradiance, and another distance's are
/// another occlusion).
pub fn cache_fingerprint(scene: &Scene, method: Method) -> u64 {
    match method {
        Method::Ao => photon::sampling::hash_keys(&[
            scene.fingerprint,
            0xa0,
            scene.ao_distance().to_bits() as u64,
        ]),
        _ => scene.fingerprint,
    }
}

pub fn load_cache(path: &Path, fingerprint: u64) -> Result<IrradianceCache> {
    IrradianceCache::load(path, fingerprint)
        .map_err(|e| option("--load-cache", format!("{}: {e}", path.display())))
}

pub fn save_cache(
    set: &mut OutputSet,
    path: &Path,
    cache: &IrradianceCache,
    fingerprint: u64,
) -> Result<()> {
    set.stage_bytes(path, &cache.to_bytes(fingerprint))
}

/// ASCII PLY of both maps: position, normal, power (W) and the map (0 global, 1 caustic), streamed to
/// the file (a text copy of millions of photons would double the memory).
pub fn dump_photons(set: &mut OutputSet, path: &Path, maps: &PhotonMaps) -> Result<()> {
    let lists: Vec<(u8, &[photon::Photon])> =
        [(0u8, maps.global.as_ref()), (1, maps.caustic.as_ref())]
            .into_iter()
            .filter_map(|(k, m)| m.map(|m| (k, m.photons())))
            .collect();
    let n: usize = lists.iter().map(|(_, l)| l.len()).sum();
    set.stage(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
        let mut w = std::io::BufWriter::new(file);
        write_ply(&mut w, n, &lists).map_err(|e| e.to_string())
    })
}

fn write_ply(
    w: &mut impl Write,
    n: usize,
    lists: &[(u8, &[photon::Photon])],
) -> std::io::Result<()> {
    write!(
        w,
        "ply\nformat ascii 1.0\ncomment pmrender photon maps\nelement vertex {n}\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nproperty float power_r\nproperty float power_g\nproperty float power_b\n\
         property uchar map\nend_header\n"
    )?;
    for (k, list) in lists {
        for p in *list {
            writeln!(
                w,
                "{} {} {} {} {} {} {:e} {:e} {:e} {k}",
                p.pos.x,
                p.pos.y,
                p.pos.z,
                p.normal.x,
                p.normal.y,
                p.normal.z,
                p.power.x,
                p.power.y,
                p.power.z
            )?;
        }
    }
    w.flush()
}

/// The beauty with a dot at every record, coloured by its radius in pixels (blue small → red large,
/// log scale between the cache's min and max spacing), ringed in white where the record also keeps a
/// glossy surface's incident light (`glossy`: the radiance cache's records); in scenes with media, a
/// white pixel at every media record in view (drawn first: surface records stay on top).
pub fn cache_image(
    set: &mut OutputSet,
    path: &Path,
    beauty: &Image,
    cache: &IrradianceCache,
    camera: &Camera,
    (media_records, glossy): (&[Vec3], &[Vec3]),
) -> Result<()> {
    let mut img = beauty.clone();
    let mut put = |px: i32, py: i32, colour: Vec3| {
        if px >= 0 && py >= 0 && (px as u32) < img.width && (py as u32) < img.height {
            img.pixels[(py as u32 * img.width + px as u32) as usize] = colour;
        }
    };
    for &q in glossy {
        if let Some((x, y)) = camera.project(q) {
            for d in -2i32..=2 {
                for (dx, dy) in [(d, -2), (d, 2), (-2, d), (2, d)] {
                    put(x as i32 + dx, y as i32 + dy, Vec3::ONE);
                }
            }
        }
    }
    for &q in media_records {
        if let Some((x, y)) = camera.project(q) {
            if x >= 0.0 && y >= 0.0 {
                put(x as i32, y as i32, Vec3::ONE);
            }
        }
    }
    let p = cache.params();
    let (lo, hi) = (
        p.min_spacing_px.max(1e-3).ln(),
        p.max_spacing_px.max(1e-3).ln(),
    );
    for r in cache.records() {
        let Some((x, y)) = camera.project(r.pos) else {
            continue;
        };
        let t = ((r.radius_px().max(1e-3).ln() - lo) / (hi - lo).max(1e-6)).clamp(0.0, 1.0);
        let colour = Vec3::new(t, 1.0 - (2.0 * t - 1.0).abs(), 1.0 - t);
        for dy in -1i32..=1 {
            for dx in -1i32..=1 {
                put(x as i32 + dx, y as i32 + dy, colour);
            }
        }
    }
    stage_png(set, path, &img)
}
