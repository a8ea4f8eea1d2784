//! A bake kept apart from the render that made it: the traced photon maps, the irradiance cache as
//! pass A left it (with the gather rays pass A chose) and the glossy records' radiance coefficients,
//! as bytes in the photon-map and cache files' own formats. [`bake_apart`] makes one, [`render_baked`]
//! shades from it (pass B only: the same pixels as the render that would have made it), and
//! [`Baked::to_bytes`] / [`Baked::from_bytes`] are its file. The media radiance cache is not kept: it
//! is filled again from the photons, which gives the same records.
//!
//! A camera walk's bake ([`super::shared_bake`]) is the same with a cache whose records cover every
//! frame's view; it says which records each frame's view made (none for a still's).
//!
//! The file: `PMBAKE2\n`, the method's name (u32 length + UTF-8), the scene's fingerprint (u64), the
//! views its cache covers (u32; 0 for a still's) and the records each made (u64 first, u64 past the
//! last), the chosen rays (u64, 0 for none, else rays + 1), the photon-map file (u64 length + bytes), the cache
//! file (u64 length + bytes, 0 for none), the radiance coefficients (u64 count; each the three u32 bits
//! of its record's position, a u32 count and that many RGB f32 triples), then an FNV-1a hash (u64) of
//! all before it. Little-endian throughout.

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use glam::Vec3;
use icache::IrradianceCache;

use super::fill::CacheFill;
use super::photons::{build_maps, loaded_photons};
use super::shade::{beauty, KeptPixels};
use super::stats::CacheFillStats;
use super::{
    bake, budget, interrupted, media_phase, output, plan, shade_bake_foreign, Bake, Options,
    RenderOutput, RenderStats,
};
use crate::camera::Camera;
use crate::error::{in_file, Error, Result};
use crate::integrator::pm::OtherViews;
use crate::integrator::radiance_cache::RadianceCache;
use crate::io::atomic::OutputSet;
use crate::photons::PhotonData;
use crate::progress::Progress;
use crate::scene::{Method, Scene};

const MAGIC: &[u8; 8] = b"PMBAKE2\n";
/// The first version's header: a still's bake, without the count of views.
const MAGIC_1: &[u8; 8] = b"PMBAKE1\n";

/// What a render shades from, as bytes that outlive its scene's borrow.
pub struct Baked {
    pub method: Method,
    fingerprint: u64,
    /// The records each frame's view made, for a walk's bake (empty for a still's): a frame's pass
    /// B reads the others only where they are in sight.
    views: Vec<(u64, u64)>,
    chosen_rays: Option<usize>,
    photons: Vec<u8>,
    cache: Vec<u8>,
    radiance: Vec<([u32; 3], Vec<Vec3>)>,
}

/// Bakes `scene` as [`super::render`] would with `opts` (plan, budget, photon maps, media, radiance and
/// irradiance caches) and keeps the result; nothing is shaded. `path` has nothing to bake.
pub fn bake_apart(
    scene: &Scene,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(Baked, RenderStats)> {
    let start = Instant::now();
    super::progressive::refuse_in_bake(scene, opts, "a bake")?;
    let plan = plan(scene, opts, None)?;
    check_bakeable(&plan, opts)?;
    budget::check(scene, &plan, opts)?;
    let mut stats = RenderStats::new(scene, &plan);
    let files = super::files::FileOptions {
        keep_maps: true,
        ..opts.files.clone()
    };
    let bake = bake(scene, &plan, &files, &mut stats, progress, cancel)?;
    stats.finish(
        scene,
        start,
        bake.photons.as_ref(),
        bake.media_cache.as_ref(),
        bake.cache.as_ref().map(|c| &c.cache),
        bake.radiance.as_ref(),
    );
    Ok((Baked::keep(scene, plan.method, bake, Vec::new())?, stats))
}

/// Refuses a bake of a method with nothing to bake, or one asked to read photon or cache files.
pub(super) fn check_bakeable(plan: &super::Plan, opts: &Options) -> Result<()> {
    if plan.method.is_occlusion() {
        // ao's occlusion records are no irradiance: a bake's cache serves the photon-map methods,
        // which would read them as light.
        return Err(Error::Input(format!(
            "method {} has nothing to bake: a bake holds photon maps and an irradiance cache for \
             the photon-map methods, and occlusion reads no photons; save ao's occlusion cache \
             with --save-cache (Python: RenderResult.write(save_cache=...)) and render from it \
             with --load-cache",
            plan.method.name()
        )));
    }
    if !plan.method.uses_photon_maps() {
        return Err(Error::Input(format!(
            "method {} has nothing to bake: it traces no photons and fills no cache",
            plan.method.name()
        )));
    }
    if opts.files.load_photons.is_some() || opts.files.load_cache.is_some() {
        return Err(Error::Input(
            "a bake traces its photons and fills its cache: it reads no photon or cache file"
                .into(),
        ));
    }
    Ok(())
}

/// Renders `scene` from `baked` (pass B only) with `opts`, whose method must be the bake's.
pub fn render_baked(
    scene: &Scene,
    opts: &Options,
    baked: &Baked,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    render_baked_seen_by(scene, opts, baked, None, progress, cancel)
}

/// [`render_baked`] seen by a walk's frame (its camera and number), else by the scene's camera.
pub fn render_baked_seen_by(
    scene: &Scene,
    opts: &Options,
    baked: &Baked,
    view: Option<(&Camera, u32)>,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let start = Instant::now();
    let plan = plan(scene, opts, view.map(|(c, _)| c))?;
    budget::check(scene, &plan, opts)?;
    let mut ready = baked.ready(scene, &plan, cancel)?;
    let frame = view.map(|(_, f)| f);
    shade_ready(
        scene, &plan, baked, &mut ready, frame, start, progress, cancel,
    )
}

/// A bake read back to shade views from: its photon maps built and its irradiance cache loaded,
/// with the statistics of reading them. (The media cache is filled for each view: its records lie
/// along the view's rays.)
pub(super) struct Ready<'a> {
    photons: Option<PhotonData<'a>>,
    cache: Option<CacheFill>,
    stats: RenderStats,
}

/// One view (a walk's frame `frame`, else the scene's) shaded from `ready`, read from `baked`, with
/// `plan`: the view's media cache filled, then pass B over a copy of the irradiance cache (the
/// records it makes serve this view only), the maps lent and kept for the next view; the statistics
/// begun at `start`.
#[allow(clippy::too_many_arguments)]
pub(super) fn shade_ready(
    scene: &Scene,
    plan: &super::Plan,
    baked: &Baked,
    ready: &mut Ready,
    frame: Option<u32>,
    start: Instant,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let cache = ready.cache.as_ref().map(|c| CacheFill {
        cache: c.cache.clone(),
        one_pass: None,
        chosen_rays: c.chosen_rays,
    });
    let radiance = match (&cache, plan.method) {
        (Some(fill), Method::Pm) => RadianceCache::new(scene).inspect(|r| {
            for (key, c) in &baked.radiance {
                r.keep(Vec3::from_array(key.map(f32::from_bits)), c.clone());
            }
            r.attach(&fill.cache);
        }),
        _ => None,
    };
    // A walk's frame reads the records other frames' views made only where they are in sight.
    let foreign = match (&cache, frame) {
        (Some(fill), Some(f)) => OtherViews {
            fine: Some(super::shared_bake::fine_in(plan)),
            ..baked.other_views(f, fill.cache.len())?
        },
        _ => OtherViews::default(),
    };
    let mut stats = ready.stats.clone();
    let photons = ready.photons.as_ref();
    let media_cache = media_phase(scene, plan, photons, &mut stats, progress, cancel)?;
    let mut bake = Bake {
        photons: ready.photons.take(),
        photon_info: None,
        media_cache,
        radiance,
        cache,
    };
    let kept = KeptPixels::NONE;
    let shaded = shade_bake_foreign(
        scene, plan, &mut bake, kept, foreign, &mut stats, progress, cancel,
    );
    ready.photons = bake.photons.take();
    let (layers, _) = shaded?;
    let images = beauty(plan, crate::integrator::terms::Layout::of(scene), layers);
    stats.finish(
        scene,
        start,
        ready.photons.as_ref(),
        bake.media_cache.as_ref(),
        bake.cache.as_ref().map(|c| &c.cache),
        bake.radiance.as_ref(),
    );
    let mut out = output(images, bake.media_cache, plan.camera.clone());
    out.radiance_records = bake.radiance.as_ref().map_or(Vec::new(), |r| r.positions());
    out.cache = bake.cache.map(|c| c.cache);
    Ok((out, stats))
}

impl Baked {
    /// The bake read back for `scene` (for `plan`, whose method must be the bake's).
    pub(super) fn ready<'a>(
        &self,
        scene: &'a Scene,
        plan: &super::Plan,
        cancel: &AtomicBool,
    ) -> Result<Ready<'a>> {
        if plan.method != self.method {
            return Err(Error::Input(format!(
                "the bake was made for method {}, not {}",
                self.method.name(),
                plan.method.name()
            )));
        }
        if scene.fingerprint != self.fingerprint {
            return Err(Error::Input(
                "the bake was made for another scene (or this one changed since)".into(),
            ));
        }
        let mut stats = RenderStats::new(scene, plan);
        let loaded = photon::file::read_maps_within(
            &self.photons,
            scene.fingerprint,
            &super::files::plausible(scene),
        )
        .map_err(|e| Error::Input(format!("the bake's photon maps: {e}")))?;
        let (maps, s) = loaded_photons(plan, loaded, Instant::now());
        stats.photons = Some(s);
        let photons = build_maps(scene, plan, maps.maps);
        interrupted(cancel)?;
        let cache = self.cache_fill(scene, &mut stats)?;
        Ok(Ready {
            photons: Some(photons),
            cache,
            stats,
        })
    }

    /// What `bake` (of `scene` for `method`, its cache covering `views` views) holds, as bytes.
    pub(super) fn keep(
        scene: &Scene,
        method: Method,
        bake: Bake,
        views: Vec<(u64, u64)>,
    ) -> Result<Baked> {
        let mut photons = Vec::new();
        if let (Some(p), Some(info)) = (bake.photons, bake.photon_info) {
            photon::file::write_maps(&mut photons, &info, &p.into_maps())
                .map_err(|e| Error::Runtime(format!("cannot keep the photon maps: {e}")))?;
        }
        let radiance = bake.radiance.map_or(Vec::new(), |r| {
            r.coefficients()
                .into_iter()
                .map(|(k, c)| (k, c.to_vec()))
                .collect()
        });
        Ok(Baked {
            method,
            fingerprint: scene.fingerprint,
            views,
            chosen_rays: bake.cache.as_ref().and_then(|c| c.chosen_rays),
            cache: bake
                .cache
                .map_or(Vec::new(), |c| c.cache.to_bytes(scene.fingerprint)),
            photons,
            radiance,
        })
    }

    /// How many frames' views the cache's records were made for (a walk's; 0 for a still's).
    pub fn views(&self) -> u32 {
        self.views.len() as u32
    }

    /// The records of a cache of `n` made for other views than frame `f`'s.
    fn other_views(&self, f: u32, n: usize) -> Result<OtherViews<'static>> {
        let &(from, to) = self.views.get(f as usize).ok_or_else(|| {
            Error::Input(format!(
                "the bake covers {} frame(s): it has no frame {f}",
                self.views.len()
            ))
        })?;
        let (from, to) = (from as usize, to as usize);
        if from > to || to > n {
            return Err(Error::Input(
                "the bake's views name records its cache does not hold".into(),
            ));
        }
        Ok(OtherViews {
            below: from,
            from: to,
            to: n,
            ..Default::default()
        })
    }

    /// The irradiance cache as pass A left it, counted as loaded; `None` for methods without one.
    fn cache_fill(&self, scene: &Scene, stats: &mut RenderStats) -> Result<Option<CacheFill>> {
        if self.cache.is_empty() {
            return Ok(None);
        }
        let cache = IrradianceCache::from_bytes(&self.cache, scene.fingerprint)
            .map_err(|e| Error::Input(format!("the bake's irradiance cache: {e}")))?;
        stats.fill = Some(CacheFillStats {
            n_loaded: cache.len() as u64,
            ..Default::default()
        });
        Ok(Some(CacheFill {
            cache,
            one_pass: None,
            chosen_rays: self.chosen_rays,
        }))
    }

    /// Writes the bake's file at `path` (through a temporary file renamed into place).
    pub fn save(&self, path: &Path) -> Result<()> {
        let mut set = OutputSet::new();
        set.stage_bytes(path, &self.to_bytes())?;
        set.commit()
    }

    /// Reads a bake's file; a missing, unreadable or damaged one is an input error naming it.
    pub fn load(path: &Path) -> Result<Baked> {
        let unreadable = |e: std::io::Error| in_file(path, format!("cannot be read: {e}"));
        let meta = std::fs::metadata(path).map_err(unreadable)?;
        if !meta.is_file() {
            return Err(in_file(path, "is not a regular file"));
        }
        // A bake larger than the memory cannot be one this machine's renders held.
        if let Some(ram) = crate::memory::physical_memory() {
            if meta.len() > ram {
                return Err(in_file(path, "is larger than this machine's memory"));
            }
        }
        let bytes = std::fs::read(path).map_err(unreadable)?;
        Baked::from_bytes(&bytes).map_err(|e| in_file(path, e))
    }

    /// The bake's file.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        let name = self.method.name().as_bytes();
        b.extend((name.len() as u32).to_le_bytes());
        b.extend(name);
        b.extend(self.fingerprint.to_le_bytes());
        b.extend((self.views.len() as u32).to_le_bytes());
        for (from, to) in &self.views {
            b.extend(from.to_le_bytes());
            b.extend(to.to_le_bytes());
        }
        b.extend(self.chosen_rays.map_or(0, |r| r as u64 + 1).to_le_bytes());
        for part in [&self.photons, &self.cache] {
            b.extend((part.len() as u64).to_le_bytes());
            b.extend(part.iter());
        }
        b.extend((self.radiance.len() as u64).to_le_bytes());
        for (key, c) in &self.radiance {
            key.iter().for_each(|k| b.extend(k.to_le_bytes()));
            b.extend((c.len() as u32).to_le_bytes());
            for v in c {
                v.to_array().iter().for_each(|x| b.extend(x.to_le_bytes()));
            }
        }
        let hash = fnv1a(&b);
        b.extend(hash.to_le_bytes());
        b
    }

    /// A bake's file read back; what is wrong with a damaged one is said in one line. Its photons and
    /// cache are checked against the scene when it is rendered.
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Baked, String> {
        let body_len = bytes
            .len()
            .checked_sub(8)
            .filter(|_| bytes.starts_with(MAGIC) || bytes.starts_with(MAGIC_1))
            .ok_or("not a pmrender bake (no PMBAKE2 header)")?;
        let (body, hash) = bytes.split_at(body_len);
        if fnv1a(body).to_le_bytes() != hash {
            return Err("the bake is damaged (its checksum does not match)".into());
        }
        let mut r = Reader {
            bytes: body,
            at: MAGIC.len(),
        };
        let name_len = r.u32()? as usize;
        let name = std::str::from_utf8(r.take(name_len)?).map_err(|_| "a method name not UTF-8")?;
        let method = Method::parse(name).ok_or_else(|| format!("unknown method '{name}'"))?;
        let fingerprint = r.u64()?;
        let n_views = match bytes.starts_with(MAGIC_1) {
            true => 0,
            false => r.u32()? as usize,
        };
        // Each view is 16 bytes: a count past what is left is damage, found before allocating.
        if n_views.saturating_mul(16) > r.left() {
            return Err("the bake's views are cut short".into());
        }
        let views = (0..n_views)
            .map(|_| Ok((r.u64()?, r.u64()?)))
            .collect::<std::result::Result<Vec<_>, String>>()?;
        let chosen_rays = match r.u64()? {
            0 => None,
            n => Some(usize::try_from(n - 1).map_err(|_| "a ray count out of range")?),
        };
        let photons = r.part()?.to_vec();
        let cache = r.part()?.to_vec();
        let n = r.u64()?;
        let mut radiance = Vec::new();
        for _ in 0..n {
            let key = [r.u32()?, r.u32()?, r.u32()?];
            let m = r.u32()? as usize;
            // Each coefficient is 12 bytes: a count past what is left is damage, found before allocating.
            if m.saturating_mul(12) > r.left() {
                return Err("the bake's radiance coefficients are cut short".into());
            }
            let c = (0..m)
                .map(|_| Ok(Vec3::new(r.f32()?, r.f32()?, r.f32()?)))
                .collect::<std::result::Result<Vec<_>, String>>()?;
            radiance.push((key, c));
        }
        if r.left() != 0 {
            return Err("the bake has bytes past its end".into());
        }
        Ok(Baked {
            method,
            fingerprint,
            views,
            chosen_rays,
            photons,
            cache,
            radiance,
        })
    }
}

/// The bytes of a bake's file read in order, every read checked against what is left.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }
    fn take(&mut self, n: usize) -> std::result::Result<&'a [u8], String> {
        if n > self.left() {
            return Err("the bake is cut short".into());
        }
        self.at += n;
        Ok(&self.bytes[self.at - n..self.at])
    }
    fn u32(&mut self) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or([0; 4]),
        ))
    }
    fn f32(&mut self) -> std::result::Result<f32, String> {
        self.u32().map(f32::from_bits)
    }
    fn u64(&mut self) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or([0; 8]),
        ))
    }
    /// A length-prefixed part.
    fn part(&mut self) -> std::result::Result<&'a [u8], String> {
        let n = usize::try_from(self.u64()?).map_err(|_| "a part longer than memory")?;
        self.take(n)
    }
}

/// 64-bit FNV-1a: enough to tell a damaged bake from a whole one.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Baked {
        Baked {
            method: Method::Pm,
            fingerprint: 7,
            views: vec![(0, 2), (2, 5)],
            chosen_rays: Some(500),
            photons: vec![1, 2, 3],
            cache: vec![4, 5],
            radiance: vec![([1, 2, 3], vec![Vec3::new(0.5, 1.0, 2.0); 4])],
        }
    }

    #[test]
    fn a_bake_reads_back_what_it_wrote() {
        let b = Baked::from_bytes(&sample().to_bytes()).unwrap();
        assert_eq!(b.to_bytes(), sample().to_bytes());
        assert_eq!(
            (b.method, b.fingerprint, b.views(), b.chosen_rays),
            (Method::Pm, 7, 2, Some(500))
        );
        assert_eq!(b.radiance, sample().radiance);
    }

    #[test]
    fn every_damaged_or_cut_bake_is_refused_with_a_reason() {
        let good = sample().to_bytes();
        for n in 0..good.len() {
            assert!(Baked::from_bytes(&good[..n]).is_err(), "cut at {n}");
            let mut flipped = good.clone();
            flipped[n] ^= 0x40;
            assert!(Baked::from_bytes(&flipped).is_err(), "byte {n} flipped");
        }
    }

    #[test]
    fn a_length_past_the_file_is_refused_before_allocating() {
        // A whole file (its hash right) that claims 2^60 coefficients for one record.
        let mut b = sample().to_bytes();
        b.truncate(b.len() - 8);
        let count_at = b.len() - 4 * 12 - 4;
        b[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let hash = fnv1a(&b);
        b.extend(hash.to_le_bytes());
        let e = Baked::from_bytes(&b).err().unwrap();
        assert!(e.contains("cut short"), "{e}");
    }
}
