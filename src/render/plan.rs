//! The `plan` phase: one render's settings resolved from the scene and the command line. The scene's
//! tables were checked when it was loaded; what depends on the image size (record spacings) or on the
//! geometry (photon counts and radii) is derived here, and cannot fail.

use std::sync::atomic::AtomicBool;

use gather::GatherParams;
use icache::media::MediaCache;
use icache::CacheParams;

use super::files::FileOptions;
use super::tiles::{Sampling, Window};
use super::Options;
use crate::camera::Camera;
use crate::error::{option, Result};
use crate::integrator::pm::{IndirectSource, OtherViews, PmContext};
use crate::photons::{PhotonData, PhotonSettings};
use crate::scene::{Method, Scene};

/// Resolved settings of one render.
#[derive(Clone)]
pub struct Plan {
    pub method: Method,
    pub spp: u32,
    /// Adaptive sampling's noise target (0: `spp` everywhere).
    pub noise: f32,
    /// Under a noise target, the most samples of a pixel whose samples made no Monte Carlo estimate.
    pub aa_spp: u32,
    /// Past `aa_spp`, the layers whose noise decides ([`past_aa_layers`]); `Some` exactly in the
    /// renders whose samples carry stratified lobe points (scenes with glossy lobes, photon-map methods).
    pub past_aa_layers: Option<u32>,
    pub seed: u64,
    pub width: u32,
    pub height: u32,
    pub window: Window,
    /// The scene's camera at the image size.
    pub camera: Camera,
    /// `[render.photons]` with the scene's defaults (read by the photon-map methods).
    pub photons: PhotonSettings,
    /// `[render.icache]` for the image size (read by `pm`).
    pub cache: CacheParams,
    /// Pass A visits every n-th pixel in x and y ([`crate::scene::IcacheSettings::pass_a_stride`]).
    pub pass_a_stride: u32,
    /// Pass A visits the lattice of every other pixel and the pixels between only near its gaps
    /// ([`icache::PassAPixels::LatticeThenGaps`]): a sequence's frame whose camera moved, its cache
    /// holding the records of earlier views.
    pub pass_a_gaps_only: bool,
    /// Rays per final gather (`pm`'s records and `pm-fg`'s samples).
    pub gather: GatherParams,
    /// `pm` chooses its gathers' rays after pass A (the file gives no `rays`; a two-pass fill, not a
    /// loaded cache): pass A gathers with `gather`'s [`crate::render::gather_rays::BASE_RAYS`].
    pub choose_rays: bool,
    /// A window held to a lower noise target ([`Sampling::finer`]); `None` in a still.
    pub finer: Option<(Window, f32)>,
    /// Where in its pixel pass A traces a lattice pixel's points, as a shift (in pixels, each in
    /// [0, 1)) of the centre and the corner it traces unshifted: 0 but in a progressive render's later
    /// passes, whose records then land elsewhere ([`super::progressive`]).
    pub pass_a_shift: [f32; 2],
    /// Pass A's checks of points its records already cover: `None` but in a progressive render's
    /// later passes ([`super::progressive`]).
    pub cache_validation: Option<icache::Validation>,
}

/// Default noise target of the photon-map methods (chosen from the speed×accuracy chart; README).
pub const DEFAULT_NOISE: f32 = 0.04;
/// Default `aa_spp`: the most samples of a pixel whose samples differ only by where they fall in it.
/// Its light (delta lights, cached and photon-map irradiance) is then a smooth function of the point,
/// and what more samples would resolve is a texture's or an edge's coverage of the pixel, which nobody
/// sees as noise: letting those pixels go on to `spp` costs much shading time for little gain.
pub const DEFAULT_AA_SPP: u32 = 32;

/// The width, in pixels, over which a camera sample reads the texture where its ray first lands (a
/// box of mip levels about that many texels wide). A pixel's samples then differ less by where they
/// fall among a texture's small details, and adaptive sampling stops sooner; the extra blur is a
/// quarter of a pixel. Against the path-traced references at 128² a quarter of a pixel lowered the
/// error on Sibenik and Sponza alike, half a pixel blurred Sponza's (docs/validation.md).
pub const TEXTURE_FILTER: f32 = 0.25;

impl Plan {
    pub fn sampling(&self) -> Sampling {
        Sampling {
            spp: self.spp,
            noise: self.noise,
            aa_spp: self.aa_spp,
            past_aa_layers: self.past_aa_layers,
            lobe_points: self.past_aa_layers.is_some(),
            finer: self.finer,
        }
    }

    /// The photon-map methods' integrator, reading soft indirect light from `source` (its gathers take
    /// the plan's rays: pass B's may differ, chosen by pass A).
    pub fn pm_context<'a>(
        &self,
        scene: &'a Scene,
        photons: &'a PhotonData<'a>,
        media_cache: Option<&'a MediaCache>,
        source: IndirectSource<'a>,
        cancel: &'a AtomicBool,
    ) -> PmContext<'a> {
        PmContext {
            scene,
            photons,
            media_cache,
            source,
            gather: self.gather,
            max_depth: scene.settings.max_depth,
            seed: self.seed,
            cancel,
            defer_misses: false,
            radiance: None,
            foreign: OtherViews::default(),
            texture_filter: TEXTURE_FILTER * self.camera.pixel_angle(),
            pixel_angle: self.camera.pixel_angle(),
            pass_a_shift: self.pass_a_shift,
        }
    }
}

/// The method `opts` or else the scene asks for (`pm` by default).
pub fn method(scene: &Scene, opts: &Options) -> Method {
    opts.method.or(scene.settings.method).unwrap_or(Method::Pm)
}

/// The settings of a render of `scene` by `opts`, seen by `camera` (a sequence's frame's), else by the
/// scene's.
pub fn plan(scene: &Scene, opts: &Options, camera: Option<&Camera>) -> Result<Plan> {
    let method = method(scene, opts);
    if scene.lights.is_empty() && !method.is_occlusion() {
        return Err(crate::error::at_line(
            &scene.path,
            1,
            format!(
                "the scene has no lights (add a [[light]] or a material with Ke > 0): method {} \
                 needs light; ao and ao-direct render geometry alone",
                method.name()
            ),
        ));
    }
    check_photon_files(method, &opts.files)?;
    let spp = opts.spp.or(scene.settings.spp).unwrap_or(match method {
        // Chosen from measurements against the Mitsuba reference of the caustic scene (README); for
        // the photon-map methods the most a pixel with Monte Carlo estimates (area lights, glass,
        // glossy, media) takes under the noise target: the others stop at `aa_spp`.
        Method::Path => 64,
        Method::Pm | Method::Photons => 128,
        Method::PmFg => 4,
        // Gathers at every sample, of rays that stop at the occlusion distance and read nothing.
        Method::AoDirect => 16,
        Method::Ao => 128,
    });
    let aa_spp = opts
        .aa_spp
        .or(scene.settings.aa_spp)
        .unwrap_or(DEFAULT_AA_SPP)
        .min(spp);
    // Adaptive sampling by default for the photon-map methods, whose pixels mostly converge in a few
    // samples (point lights, diffuse walls, smooth cached irradiance); `path` keeps fixed sample counts
    // (it is the reference, and its charts are drawn per spp).
    let noise = opts.noise.or(scene.settings.noise).unwrap_or(match method {
        Method::Path => 0.0,
        Method::Pm | Method::Photons | Method::PmFg | Method::Ao | Method::AoDirect => {
            DEFAULT_NOISE
        }
    });
    let width = opts.width.unwrap_or(scene.camera.width);
    let height = opts.height.unwrap_or(scene.camera.height);
    let window = match opts.crop {
        None => Window::full(width, height),
        Some(w) => {
            if w.x0 >= w.x1 || w.y0 >= w.y1 || w.x1 > width || w.y1 > height {
                return Err(option(
                    "--crop",
                    format!(
                        "window {} {} {} {} is empty or outside the {width}×{height} image",
                        w.x0, w.y0, w.x1, w.y1
                    ),
                ));
            }
            w
        }
    };
    let icache = &scene.settings.icache;
    if method == Method::Ao && icache.fill == crate::scene::FillMode::OnePass {
        return Err(option(
            "--method",
            "ao fills its cache in two passes ([render.icache] fill = \"one-pass\" is pm's alone)",
        ));
    }
    let choose_rays = method == Method::Pm
        && !icache.rays_given
        && icache.fill == crate::scene::FillMode::TwoPass
        && opts.files.load_cache.is_none();
    Ok(Plan {
        method,
        spp,
        noise,
        aa_spp,
        past_aa_layers: past_aa_layers(scene, method),
        seed: opts.seed.unwrap_or(scene.settings.seed),
        width,
        height,
        window,
        camera: camera
            .unwrap_or(&scene.camera)
            .with_resolution(width, height),
        photons: PhotonSettings::resolve(scene),
        cache: icache.for_method(method, width, height),
        pass_a_stride: icache.pass_a_stride(width, height),
        pass_a_gaps_only: false,
        gather: GatherParams {
            rays: if choose_rays {
                crate::render::gather_rays::BASE_RAYS
            } else {
                icache.rays
            },
        },
        choose_rays,
        finer: None,
        pass_a_shift: [0.0; 2],
        cache_validation: None,
    })
}

/// In a scene with glossy lobes, the photon-map methods' layers whose noise decides whether a pixel
/// goes on past `aa_spp`: those holding Monte Carlo estimates — the glossy lobe's sample, mirror and
/// glass paths, the media, the direct light where area lights are sampled, and `pm-fg`'s per-sample
/// gathers. Not the caustic and soft indirect light read from maps and caches, nor the direct light of
/// point, spot and directional lights: their samples differ only by where they fall in the pixel,
/// which `aa_spp` already stops. The emission's samples differ only so too, but an emitter is so much
/// brighter than what surrounds it that a pixel on its edge is still far off at `aa_spp`; it counts (a
/// pixel inside an emitter or away from one has no spread in it). Judged by the beauty, every textured
/// pixel a glossy lobe made Monte Carlo went on to `spp` for its texture's sake. Elsewhere (`None`) the beauty
/// decides, as validated.
fn past_aa_layers(scene: &Scene, method: Method) -> Option<u32> {
    let layout = crate::integrator::terms::Layout::of(scene);
    if !method.uses_photon_maps() || !layout.glossy {
        return None;
    }
    let names = layout.names();
    let monte_carlo = |name: &str| match name {
        "direct" => scene.lights.has_area(),
        "indirect" => method == Method::PmFg,
        "caustic" => false,
        _ => true,
    };
    Some(
        names
            .iter()
            .enumerate()
            .filter(|(_, n)| monte_carlo(n))
            .fold(0, |m, (i, _)| m | 1 << i),
    )
}

/// Photon-map files that would do nothing are refused rather than left unwritten or unread without a
/// word: `path` traces no photon maps, and maps loaded from a file are not traced again (save or dump
/// them from the render that traced them).
fn check_photon_files(method: Method, files: &FileOptions) -> Result<()> {
    let given = [
        ("--save-photons", files.save_photons.is_some()),
        ("--dump-photons", files.dump_photons.is_some()),
        ("--load-photons", files.load_photons.is_some()),
    ];
    if let Some((opt, _)) = given
        .iter()
        .find(|(_, g)| *g)
        .filter(|_| !method.uses_photon_maps())
    {
        return Err(option(
            opt,
            format!(
                "method {} traces no photon maps (choose pm, pm-fg or photons)",
                method.name()
            ),
        ));
    }
    if files.load_photons.is_some() {
        if let Some((opt, _)) = given[..2].iter().find(|(_, g)| *g) {
            return Err(option(
                opt,
                "the maps come from --load-photons and are not traced again: save or dump them \
                 from the render that traced them",
            ));
        }
    }
    Ok(())
}
