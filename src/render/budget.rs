//! The memory a render will need, computed before anything large is allocated, against a budget: a
//! request that cannot fit is refused with both numbers instead of aborting half-way on a failed
//! allocation.
//!
//! The budget is `--max-memory`, else the `PMRENDER_MAX_MEMORY` environment variable, else 75 % of the
//! physical RAM (`MemTotal` in /proc/meminfo, or the cgroup's memory limit when smaller; 8 GiB when
//! neither can be read); what the process already holds (the scene, its textures, a reference image)
//! counts against it. Whatever the budget, the estimate must also fit in the address space left under
//! `RLIMIT_AS` ([`crate::memory`]): past it an allocation aborts. The estimates are upper bounds of the
//! peaks, per item:
//! - image: every full-size layer (beauty + terms, 12 B per pixel each), adaptive sampling's sums, the
//!   interleaved EXR buffer and the PNG/cache-image copies, over the whole image even with `--crop`
//!   (other pixels are black);
//! - photon maps: [`PHOTON_PEAK_BYTES`] per stored photon while tracing and building, or 3 × the size
//!   of a `--load-photons` file;
//! - irradiance cache: pass A keeps the shading points of every pixel of the image
//!   ([`FILL_BYTES_PER_PIXEL`]), or 3 × the size of a `--load-cache` file;
//! - shading memos: each pixel remembers the soft indirect light of the surfaces it sees while it takes
//!   samples ([`MEMO_BYTES_PER_PIXEL`], after pass A has freed its points: the larger of the two counts).

use std::path::Path;

use super::{Options, Plan};
use crate::error::{Error, Result};
use crate::integrator::MEMO_BYTES_PER_PIXEL;
use crate::memory;
use crate::scene::{Method, Scene};

pub use crate::scene::{MAX_SIDE, MAX_SPP};
/// Peak bytes per stored photon: the photon (56 B) in a growing vector (capacity up to 2×, and the old
/// buffer during a reallocation), and FLANN's copy and tree.
pub const PHOTON_PEAK_BYTES: u64 = 240;
/// Pass-A bytes per pixel: the pixel's range (8 B), the visiting order (8 B), the repair sweeps' flag
/// (1 B) and its shading points, each kept with the hit its gather starts from (28 + 56 B; allowing 2.8
/// points per pixel, more than one through glass).
pub const FILL_BYTES_PER_PIXEL: u64 = 8 + 8 + 1 + 28 * 84 / 10;
/// Share of the physical RAM the default budget allows.
pub const DEFAULT_FRACTION: f64 = 0.75;

/// Parses a size such as `8G`, `512M`, `64k` or a plain byte count.
pub fn parse_size(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, unit) = match t.char_indices().find(|(_, c)| c.is_ascii_alphabetic()) {
        Some((i, _)) => (&t[..i], t[i..].to_ascii_lowercase()),
        None => (t, String::new()),
    };
    let scale: u64 = match unit.trim_end_matches("ib").trim_end_matches('b') {
        "" => 1,
        "k" => 1 << 10,
        "m" => 1 << 20,
        "g" => 1 << 30,
        "t" => 1 << 40,
        _ => return None,
    };
    let x: f64 = digits.trim().parse().ok()?;
    (x.is_finite() && x > 0.0 && x * (scale as f64) < 1.8e19).then_some((x * scale as f64) as u64)
}

/// The `PMRENDER_MAX_MEMORY` environment variable: `None` when unset or empty, an error naming it
/// when it is not a size (a budget the user meant to set is not silently replaced by the default).
pub fn env_max_memory() -> Result<Option<u64>> {
    const VAR: &str = "PMRENDER_MAX_MEMORY";
    match std::env::var_os(VAR) {
        None => Ok(None),
        Some(v) if v.is_empty() => Ok(None),
        Some(v) => {
            let text = v.to_string_lossy();
            parse_size(&text).map(Some).ok_or_else(|| {
                Error::Input(format!(
                    "environment variable {VAR}: '{text}' is not a size (e.g. 8G, 512M)"
                ))
            })
        }
    }
}

/// The budget and where it came from (for the message).
pub fn budget(opts: &Options) -> Result<(u64, String)> {
    if let Some(b) = opts.max_memory {
        return Ok((b, "--max-memory".into()));
    }
    if let Some(b) = env_max_memory()? {
        return Ok((b, "PMRENDER_MAX_MEMORY".into()));
    }
    Ok(match memory::physical_memory() {
        Some(ram) => (
            (ram as f64 * DEFAULT_FRACTION) as u64,
            format!("75 % of {} RAM; raise it with --max-memory", human(ram)),
        ),
        None => (8 << 30, "RAM unknown; raise it with --max-memory".into()),
    })
}

pub use crate::memory::human;

fn file_len(path: Option<&Path>) -> u64 {
    path.and_then(|p| std::fs::metadata(p).ok())
        .map_or(0, |m| m.len())
}

/// A volume-lattice record in its lazily filled slot (none where the lattice point has no record).
const MEDIA_RECORD_BYTES: u64 = std::mem::size_of::<
    std::sync::OnceLock<Option<crate::photons::volume_lattice::LatticeRecord>>,
>() as u64;

/// What the render will need, item by item (name, bytes).
pub fn estimate(scene: &Scene, plan: &Plan, opts: &Options) -> Vec<(String, u64)> {
    let pixels = plan.width as u64 * plan.height as u64;
    let photon_method = plan.method.uses_photon_maps();
    let n_images: u64 = if photon_method {
        1 + crate::integrator::terms::Layout::of(scene).count() as u64
    } else {
        1
    };
    // Layers (12 B) + the EXR's interleaved floats (12 B per image) + PNG (3 B) + cache image (15 B) +
    // adaptive sampling's sums.
    let image = pixels.saturating_mul(24 * n_images + 18 + super::tiles::SUMS_BYTES_PER_PIXEL);
    let mut items = vec![(
        format!(
            "image {}×{} with {n_images} layer(s)",
            plan.width, plan.height
        ),
        image,
    )];
    if photon_method {
        items.extend(photon_items(scene, plan, opts, pixels));
    }
    let memos = pixels.saturating_mul(MEMO_BYTES_PER_PIXEL);
    if plan.method.uses_cache() {
        let cache = match &opts.files.load_cache {
            Some(p) => file_len(Some(p)).saturating_mul(3),
            None => pixels.saturating_mul(FILL_BYTES_PER_PIXEL),
        };
        let name = match &opts.files.load_cache {
            Some(p) => format!(
                "irradiance cache from {} (--load-cache), or shading memos",
                p.display()
            ),
            None => "irradiance cache fill, then shading memos".into(),
        };
        items.push((name, cache.max(memos)));
    } else if plan.method == Method::Photons {
        items.push(("shading memos".into(), memos));
    }
    items
}

/// The photon-map methods' items: the maps (traced or loaded), the irradiance atlas, the glossy
/// texels and the media's records, for an image of `pixels`.
fn photon_items(scene: &Scene, plan: &Plan, opts: &Options, pixels: u64) -> Vec<(String, u64)> {
    let mut items = Vec::new();
    let photons = match &opts.files.load_photons {
        Some(p) => file_len(Some(p)).saturating_mul(3),
        None => {
            let s = &plan.photons;
            (s.global as u64
                + s.caustic as u64
                + s.volume as u64
                + s.volume_caustic as u64
                + 4 * photon::trace::MAX_DEPTH as u64)
                .saturating_mul(PHOTON_PEAK_BYTES)
        }
    };
    let name = match &opts.files.load_photons {
        Some(p) => format!("photon maps from {} (--load-photons)", p.display()),
        None => "photon maps".into(),
    };
    items.push((name, photons));
    // The irradiance atlas: at most MAX_TEXEL_SLOTS slots (and as many caustic slots with a caustic
    // map), and a grid per triangle.
    let slot =
        std::mem::size_of::<std::sync::OnceLock<crate::photons::atlas::TexelIrradiance>>() as u64;
    let caustic_slot = std::mem::size_of::<std::sync::OnceLock<(glam::Vec3, bool)>>() as u64;
    let slot_bytes = if plan.photons.caustic > 0 {
        slot + caustic_slot
    } else {
        slot
    };
    let atlas = crate::photons::atlas::MAX_TEXEL_SLOTS * slot_bytes
        + scene.geometry.triangles.len() as u64 * 64;
    items.push(("irradiance atlas".into(), atlas));
    if scene.has_glossy() {
        // Glossy texels: a slot per texel, and the harmonics of those rays reach (about two per
        // pixel on an all-glossy Sponza; counted as four).
        let texels = crate::photons::atlas::MAX_TEXEL_SLOTS;
        let estimated = texels.min(4 * pixels);
        items.push((
            "glossy texels".into(),
            texels * 16 + estimated * crate::photons::GLOSSY_TEXEL_BYTES,
        ));
    }
    if scene.media.is_some() {
        items.extend(media_items(plan));
    }
    items
}

/// The media's items: the final-gather rays' lattice, what its cells see, and `pm`'s media
/// radiance cache.
fn media_items(plan: &Plan) -> Vec<(String, u64)> {
    let mut items = Vec::new();
    // The final-gather rays' lattice of at most MAX_RECORDS (a record and its lock), and for `pm`
    // the media cache's records (each with a few index entries) and pass A's points.
    items.push((
        "media records".into(),
        crate::photons::volume_lattice::MAX_RECORDS * MEDIA_RECORD_BYTES,
    ));
    // What the cells of the estimates' coarse lattice see, once measured.
    items.push((
        "media surroundings".into(),
        crate::photons::volume_lattice::MAX_SEEN_CELLS
            * (std::mem::size_of::<crate::photons::volume_lattice::Surroundings>() as u64 + 16),
    ));
    if plan.method == Method::Pm {
        let cache = icache::media::MAX_RECORDS as u64
            * (std::mem::size_of::<icache::media::VolumeRecord>() as u64 + 64);
        // Points are gathered with a sort key, then copied out: both lists at the peak.
        let point = std::mem::size_of::<icache::media::MediaPoint>() as u64;
        let points = crate::photons::media_fill::MAX_POINTS as u64 * (2 * point + 4);
        items.push(("media radiance cache".into(), cache + points));
    }
    items
}

/// Refuses (exit 2) a render whose estimate, with what the process already holds (the scene, its
/// textures, a reference image), exceeds the budget — or exceeds the address space left under
/// `RLIMIT_AS` whatever the budget, since an allocation past it aborts.
pub fn check(scene: &Scene, plan: &Plan, opts: &Options) -> Result<()> {
    check_held(scene, plan, opts, memory::resident())
}

/// [`check`] with `held` bytes already held: a sequence's frames count what the process held before
/// its first frame, since what the frames before left (their caches, maps and images, or the pages
/// the allocator kept of them) is what this frame's estimate counts again.
pub fn check_held(scene: &Scene, plan: &Plan, opts: &Options, held: u64) -> Result<()> {
    let items = estimate(scene, plan, opts);
    let need = items.iter().fold(0u64, |a, (_, b)| a.saturating_add(*b));
    let (limit, source) = budget(opts)?;
    let (over, raise) = match memory::address_space_left() {
        Some(left) if need > left => (
            format!(
                "more than the {} of address space left under the process's limit of {} (ulimit -v)",
                human(left),
                human(memory::address_space_limit().unwrap_or(0))
            ),
            "raise ulimit -v",
        ),
        _ if need.saturating_add(held) > limit => (
            format!(
                "with the {} already held, over the memory budget of {} ({source})",
                human(held),
                human(limit)
            ),
            "raise --max-memory",
        ),
        _ => return Ok(()),
    };
    let parts: Vec<String> = items
        .iter()
        .filter(|(_, b)| *b > 0)
        .map(|(n, b)| format!("{n}: {}", human(*b)))
        .collect();
    // The scene named, and what to change: the image's size, the photon counts, or the limit.
    Err(Error::Input(format!(
        "{}: memory: the render needs about {} ({}), {over}; render less (--width, --height, \
         --crop, or the scene's photon counts) or {raise}",
        scene.path.display(),
        human(need),
        parts.join(", "),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("8G"), Some(8 << 30));
        assert_eq!(parse_size("512MiB"), Some(512 << 20));
        assert_eq!(parse_size("1.5k"), Some(1536));
        assert_eq!(parse_size("1000"), Some(1000));
        for bad in ["", "G", "-1G", "0", "3X", "nan", "1e30T"] {
            assert_eq!(parse_size(bad), None, "{bad}");
        }
    }
}
