//! `[render.icache]`: the irradiance cache's settings checked, with defaults scaled to the image.

use icache::{CacheParams, Weighting};

use super::context::Ctx;
use super::file::IcacheDesc;
use super::Method;
use crate::error::Result;

/// How `pm` fills its irradiance cache (`[render.icache] fill`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FillMode {
    /// Pass A fills in hierarchical order, pass B only reads (the default).
    TwoPass,
    /// Ward's original lazy fill in scanline order: each pixel sees only the records made before it.
    /// Slower (sequential gathers) and with order artifacts; kept to measure what the two-pass fill removes.
    OnePass,
}

/// Image side up to which the default record spacings are the pixel counts of `CacheParams`; above it
/// they grow with the image, so that a 1000² render does not place records 3 px apart: fewer records
/// at the same accuracy, as the records' screen size matters less than their spacing in the scene.
pub const SPACING_REFERENCE_SIDE: u32 = 512;

/// `ao`'s default `accuracy`: occlusion changes sharply near contacts, where records interpolated
/// at `pm`'s 0.5 left the image about 1 % too open against `ao-direct` (blinds room 1.009–1.010,
/// Cornell box 1.014 at 64 × 48); at 0.25 the blinds room's mean was within 0.4 %. Its rays read
/// nothing at their ends, so the records this adds cost little.
pub const AO_ACCURACY: f32 = 0.25;

/// `[render.icache]` checked: the cache parameters (defaults where the file gives none), the gather
/// ray count and the fill mode.
#[derive(Clone, Debug, PartialEq)]
pub struct IcacheSettings {
    /// Spacings the file does not give are the defaults at [`SPACING_REFERENCE_SIDE`]; see [`Self::for_image`].
    params: CacheParams,
    min_spacing_given: bool,
    /// Whether the file gives `accuracy` (else `ao` takes its own default, see [`Self::for_method`]).
    accuracy_given: bool,
    /// Whether the file gives `pass_b_accuracy`.
    pass_b_accuracy_given: bool,
    max_spacing_given: bool,
    /// Rays per final gather: the file's `rays`, else [`gather::DEFAULT_RAYS`] (`pm-fg`'s gathers; `pm`
    /// chooses its own then, see [`Self::rays_given`]).
    pub rays: usize,
    /// Whether the file gives `rays`. If not, `pm` sets its gathers' rays from the noise its pass-A
    /// gathers show (`render::gather_rays`).
    pub rays_given: bool,
    pub fill: FillMode,
    /// Media radiance-cache records extrapolated by their gradients (`media_gradients`, default true).
    media_gradients: bool,
    /// Volume estimates along camera rays (media records; `photons` and `pm-fg` at each step) aware of
    /// what their point sees (`media_visibility`, default true):
    /// see [`Self::media_visibility`].
    media_visibility: bool,
    /// `pass_a_stride` as given; see [`Self::pass_a_stride`].
    pass_a_stride: Option<u32>,
    /// Pass B leaves out the records an occluder hides from the lookup point (`visibility`, default
    /// false): see [`Self::visibility`].
    visibility: bool,
    /// The radiance cache on glossy surfaces (`radiance_cache`, default true).
    pub radiance_cache: bool,
    /// An animated scene's frames share one cache (`temporal`, default true); `false` renders each
    /// frame as a still of its own.
    pub temporal: bool,
    /// Harmonic bands every cached lobe keeps (`radiance_bands`); `None`: all ten (see
    /// `integrator::radiance_cache`).
    pub radiance_bands: Option<usize>,
}

impl IcacheSettings {
    pub(crate) fn media_gradients(&self) -> bool {
        self.media_gradients
    }

    /// Whether volume estimates along camera rays (the media cache's records; `photons` and `pm-fg`
    /// at each step) leave out photons behind occluders and fit the power over
    /// the kernel's visible part (`volume_lattice::estimate_within`): a plain kernel near a wall or a
    /// medium's boundary counts the empty side and reads low.
    pub(crate) fn media_visibility(&self) -> bool {
        self.media_visibility
    }

    /// Whether each pass-B lookup tests, with a shadow ray, that the records it would interpolate are
    /// in view of the point, so that records past a column or moulding do not lend it their more open
    /// hemisphere, at the cost of a shadow ray per record.
    pub(crate) fn visibility(&self) -> bool {
        self.visibility
    }

    /// Pass A visits every n-th pixel in x and y: the file's `pass_a_stride`, else the least spacing of
    /// records (`min_spacing_px` for the image, see [`Self::for_image`]) in units of its 3 px default,
    /// rounded — 1 up to 767², 2 from 768². Large images fill at a lower resolution first, which
    /// saves time at the same accuracy; pass B covers the pixels between with records of their own.
    pub(crate) fn pass_a_stride(&self, width: u32, height: u32) -> u32 {
        self.pass_a_stride.unwrap_or_else(|| {
            let spacing = self.for_image(width, height).min_spacing_px;
            ((spacing / CacheParams::default().min_spacing_px).round() as u32).max(1)
        })
    }

    /// Whether pass A of a sequence's frame whose camera moved visits the lattice of every other pixel
    /// and the pixels between only where the lattice found a gap ([`icache::PassAPixels`]): where the
    /// file gives no `pass_a_stride`, a still of the image visits every pixel, and the image is larger
    /// than [`SPACING_REFERENCE_SIDE`] across: records are then more than 3 px apart, and gaps narrower
    /// than the lattice are rare (on smaller images they were not: docs/benchmarks.md).
    pub(crate) fn pass_a_gaps_only(&self, width: u32, height: u32) -> bool {
        self.pass_a_stride.is_none()
            && self.pass_a_stride(width, height) == 1
            && width.max(height) > SPACING_REFERENCE_SIDE
    }

    /// The cache parameters for a `width` × `height` image: default spacings grow with an image larger
    /// than [`SPACING_REFERENCE_SIDE`]; spacings the file gives stay. A given `max_spacing_px` below the
    /// grown default minimum lowers that minimum (checked at load against the ungrown one).
    pub(crate) fn for_image(&self, width: u32, height: u32) -> CacheParams {
        let mut p = self.params;
        let scale = (width.max(height) as f32 / SPACING_REFERENCE_SIDE as f32).max(1.0);
        if !self.min_spacing_given {
            p.min_spacing_px *= scale;
            if self.max_spacing_given {
                p.min_spacing_px = p.min_spacing_px.min(p.max_spacing_px);
            }
        }
        if !self.max_spacing_given {
            p.max_spacing_px *= scale;
        }
        p
    }

    /// [`Self::for_image`] for `method`: `ao`'s accuracy, where the file gives none, is
    /// [`AO_ACCURACY`] (its pass-B reach scaled with it).
    pub(crate) fn for_method(&self, method: Method, width: u32, height: u32) -> CacheParams {
        let mut p = self.for_image(width, height);
        if method == Method::Ao && !self.accuracy_given {
            p.accuracy = AO_ACCURACY;
            if !self.pass_b_accuracy_given {
                p.pass_b_accuracy = Some(icache::params::PASS_B_REACH * AO_ACCURACY);
            }
        }
        p
    }
}

/// `[render.icache]`: the numbers (see [`check_icache`]), then the weighting and the fill by name.
pub(super) fn icache(cx: &Ctx, d: &IcacheDesc) -> Result<IcacheSettings> {
    check_icache(cx, d)?;
    let err = |key: &str, msg: String| cx.err("render.icache", 0, key, msg);
    let defaults = CacheParams::default();
    let weight = match d.weight.as_deref() {
        None => defaults.weight,
        Some("tl") => Weighting::TabellionLamorlette,
        Some("ward") => Weighting::Ward,
        Some(other) => {
            return Err(err(
                "weight",
                format!("unknown weighting '{other}' (tl | ward)"),
            ))
        }
    };
    let fill = match d.fill.as_deref() {
        None | Some("two-pass") => FillMode::TwoPass,
        Some("one-pass") => FillMode::OnePass,
        Some(other) => {
            return Err(err(
                "fill",
                format!("unknown fill '{other}' (two-pass | one-pass)"),
            ))
        }
    };
    // Adaptive caching lives in the two-pass fill: asked for with the one-pass fill it would do nothing.
    if fill == FillMode::OnePass {
        let asked = [
            ("adaptive", d.adaptive == Some(true)),
            ("adaptive_threshold", d.adaptive_threshold.is_some()),
        ];
        if let Some((key, _)) = asked.iter().find(|(_, a)| *a) {
            return Err(err(
                key,
                "adaptive caching needs fill = \"two-pass\"; with fill = \"one-pass\" it would do \
                 nothing"
                    .into(),
            ));
        }
    }
    let accuracy = d.accuracy.unwrap_or(defaults.accuracy);
    let params = CacheParams {
        accuracy,
        weight,
        neighbor_clamping: d.neighbor_clamping.unwrap_or(defaults.neighbor_clamping),
        gradients: d.gradients.unwrap_or(defaults.gradients),
        min_spacing_px: d.min_spacing_px.unwrap_or(defaults.min_spacing_px),
        max_spacing_px: d.max_spacing_px.unwrap_or(defaults.max_spacing_px),
        pass_b_accuracy: Some(
            d.pass_b_accuracy
                .unwrap_or(icache::params::PASS_B_REACH * accuracy),
        ),
        // Adaptive caching: on with `adaptive = true` or a threshold; it lives in the two-pass fill.
        adaptive: match fill {
            FillMode::TwoPass if d.adaptive.unwrap_or(d.adaptive_threshold.is_some()) => Some(
                d.adaptive_threshold
                    .unwrap_or(icache::params::DEFAULT_WEBER),
            ),
            _ => None,
        },
    };
    // What `check_icache` has not caught yet (a check added to `CacheParams` later).
    params
        .validate()
        .map_err(|e| err("accuracy", e.to_string()))?;
    let rays = d.rays.map_or(gather::DEFAULT_RAYS, |r| r as usize);
    let media_gradients = d.media_gradients.unwrap_or(true);
    let media_visibility = d.media_visibility.unwrap_or(true);
    let pass_a_stride = d.pass_a_stride.map(|s| s as u32);
    let visibility = d.visibility.unwrap_or(false);
    Ok(IcacheSettings {
        radiance_cache: d.radiance_cache.unwrap_or(true),
        temporal: d.temporal.unwrap_or(true),
        radiance_bands: d.radiance_bands.map(|b| b as usize),
        params,
        min_spacing_given: d.min_spacing_px.is_some(),
        accuracy_given: d.accuracy.is_some(),
        pass_b_accuracy_given: d.pass_b_accuracy.is_some(),
        max_spacing_given: d.max_spacing_px.is_some(),
        rays,
        rays_given: d.rays.is_some(),
        fill,
        media_gradients,
        media_visibility,
        pass_a_stride,
        visibility,
    })
}

/// Most final-gather rays. A gather's noise falls as 1/√rays and is below 1 % at a few thousand; past
/// 65536 the fill only takes longer (a 32² render makes ~150 gathers: 1 M rays each took 73 s).
pub const MAX_GATHER_RAYS: i64 = 65_536;

/// The least reach of a record, `accuracy` × `min_spacing_px`, in pixels. A record reaching less than a
/// pixel leaves the samples between records uncovered: pass B makes a record for nearly every sample,
/// and the records, their neighbour lists and the time grow as 1/reach² (accuracy 0.01 took 20
/// records per pixel and 780 MB at 32²; 0.1 × 3 px, the least Ward's practice uses, 1 and 190 MB).
pub const MIN_RECORD_REACH_PX: f32 = 0.3;

/// `[render.icache]` numbers, each blamed on its own key: accuracies and spacings positive and finite,
/// `min_spacing_px ≤ max_spacing_px`, a record's least reach at least [`MIN_RECORD_REACH_PX`],
/// `pass_b_accuracy ≥ accuracy` (defaults fill the keys not given; pass B's is 1.5 times the accuracy
/// given).
fn check_icache(cx: &Ctx, d: &IcacheDesc) -> Result<()> {
    let err = |key: &str, msg: String| cx.err("render.icache", 0, key, msg);
    let defaults = icache::CacheParams::default();
    for (key, v) in [
        ("accuracy", d.accuracy),
        ("pass_b_accuracy", d.pass_b_accuracy),
        ("min_spacing_px", d.min_spacing_px),
        ("max_spacing_px", d.max_spacing_px),
        ("adaptive_threshold", d.adaptive_threshold),
    ] {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => {
                return Err(err(key, format!("{x} must be a positive number")))
            }
            _ => {}
        }
    }
    let min = d.min_spacing_px.unwrap_or(defaults.min_spacing_px);
    let max = d.max_spacing_px.unwrap_or(defaults.max_spacing_px);
    if min > max {
        let key = if d.min_spacing_px.is_some() {
            "min_spacing_px"
        } else {
            "max_spacing_px"
        };
        return Err(err(
            key,
            format!("min_spacing_px = {min} is larger than max_spacing_px = {max}"),
        ));
    }
    let a = d.accuracy.unwrap_or(defaults.accuracy);
    if a * min < MIN_RECORD_REACH_PX {
        let key = if d.accuracy.is_some() {
            "accuracy"
        } else {
            "min_spacing_px"
        };
        let num = |x: f32| {
            if x != 0.0 && x.abs() < 1e-3 {
                format!("{x:e}")
            } else {
                format!("{x}")
            }
        };
        return Err(err(
            key,
            format!(
                "accuracy × min_spacing_px = {} × {} = {} px: a record must reach at least \
                 {MIN_RECORD_REACH_PX} px",
                num(a),
                num(min),
                num(a * min)
            ),
        ));
    }
    if let Some(b) = d.pass_b_accuracy.filter(|&b| b < a) {
        return Err(err(
            "pass_b_accuracy",
            format!("pass_b_accuracy = {b} is smaller than accuracy = {a}"),
        ));
    }
    if let Some(b) = d.radiance_bands.filter(|b| !(2..=10).contains(b)) {
        return Err(err("radiance_bands", format!("{b} must be in 2..=10")));
    }
    if let Some(s) = d.pass_a_stride.filter(|s| !(1..=64).contains(s)) {
        return Err(err("pass_a_stride", format!("{s} must be in 1..=64")));
    }
    match d.rays {
        Some(r) if !(4..=MAX_GATHER_RAYS).contains(&r) => {
            Err(err("rays", format!("{r} must be in 4..={MAX_GATHER_RAYS}")))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn icache(min: Option<f32>, max: Option<f32>) -> IcacheSettings {
        let d = CacheParams::default();
        let params = CacheParams {
            min_spacing_px: min.unwrap_or(d.min_spacing_px),
            max_spacing_px: max.unwrap_or(d.max_spacing_px),
            ..d
        };
        IcacheSettings {
            params,
            min_spacing_given: min.is_some(),
            accuracy_given: false,
            pass_b_accuracy_given: false,
            max_spacing_given: max.is_some(),
            rays: 500,
            rays_given: false,
            fill: FillMode::TwoPass,
            media_gradients: true,
            media_visibility: true,
            pass_a_stride: None,
            visibility: false,
            radiance_cache: true,
            temporal: true,
            radiance_bands: None,
        }
    }

    #[test]
    fn default_spacings_grow_with_the_image_and_given_ones_stay() {
        let p = icache(None, None).for_image(1024, 256);
        assert_eq!((p.min_spacing_px, p.max_spacing_px), (6.0, 40.0));
        assert_eq!(
            icache(None, None).for_image(512, 512),
            CacheParams::default()
        );
        let p = icache(Some(2.0), None).for_image(2048, 2048);
        assert_eq!((p.min_spacing_px, p.max_spacing_px), (2.0, 80.0));
        // A given maximum below the grown default minimum lowers the minimum: valid at any size.
        let p = icache(None, Some(5.0)).for_image(2048, 2048);
        assert_eq!((p.min_spacing_px, p.max_spacing_px), (5.0, 5.0));
        assert!(p.validate().is_ok());
    }
}
