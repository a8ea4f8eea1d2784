//! The BSDF element of a material for `export-mitsuba`: Mitsuba 3's plugin of its model, inside a
//! `bumpmap` or `normalmap` for a bump or normal map and a `mask` for a cutout, and the images
//! those wrappers read where Mitsuba cannot read the scene's own as we do.

use std::borrow::Cow;
use std::path::Path;

use super::{rgb, xml_attr, Body, File};
use crate::material::Bsdf;
use crate::scene::Scene;

/// A bitmap texture element named `name` reading texture `t` (Mitsuba's defaults, bilinear and
/// repeating, are ours).
fn bitmap(scene: &Scene, t: usize, name: &str) -> String {
    format!(
        r#"<texture type="bitmap" name="{name}"><string name="filename" value="{}"/></texture>"#,
        file_name(&scene.textures[t].path)
    )
}

/// `path` as written into an XML attribute: absolute where it can be, as the scene's maps are, and
/// escaped ([`xml_attr`]).
fn file_name(path: &Path) -> String {
    let path = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    xml_attr(&path.display().to_string()).into_owned()
}

/// Material `m`'s BSDF, inside Mitsuba 3's `mask` where it has a cutout (`map_d`), outermost so
/// that a bump or normal map's wrapper is inside it ([`bumped_bsdf_xml`]). The mask's opacity is
/// the mask's image, read raw, bilinearly and wrapping as ours; an image Mitsuba would read other
/// values from (alpha, which its `bitmap` drops, or colour, of which it takes the luminance where we
/// take the mean) is replaced by `mask_<m>.exr` of our values, pushed to `images`. Ours cuts below
/// [`crate::cutout::THRESHOLD`] (0.5) where Mitsuba's `mask` passes a ray with probability
/// 1 − opacity: the same for a mask of 0s and 1s, but for the blend across the edges of its texels.
pub(super) fn bsdf_xml<'a>(scene: &'a Scene, m: usize, images: &mut Vec<File<'a>>) -> String {
    let inner = bumped_bsdf_xml(scene, m, images);
    let Some((path, mask)) = scene.cutout(m) else {
        return inner;
    };
    let file = if mask.plain_grey {
        file_name(path)
    } else {
        let name = format!("mask_{m}.exr");
        images.push((
            name.clone(),
            Body::Image {
                width: mask.width,
                height: mask.height,
                channels: &["Y"],
                values: Cow::Borrowed(&mask.values),
            },
        ));
        name
    };
    format!(
        r#"<bsdf type="mask"><texture type="bitmap" name="opacity"><boolean name="raw" value="true"/><string name="filter_type" value="bilinear"/><string name="wrap_mode" value="repeat"/><string name="filename" value="{file}"/></texture>{inner}</bsdf>"#
    )
}

/// Material `m`'s BSDF, inside Mitsuba 3's `bumpmap` (its scale our `-bm`) or `normalmap` where it
/// has a bump or normal map, the image read raw (not sRGB-decoded) as ours is; a height map read from
/// a colour image (ours is its channels' mean) is written as `height_<m>.exr` of our values. Mitsuba's
/// `normalmap` has no strength: a normal map of strength (`-bm`) other than 1 is written as
/// `normal_<m>.exr`, its texels turned by that strength ([`crate::bump::BumpMap::encoded_at_strength`]),
/// pushed to `images`.
fn bumped_bsdf_xml<'a>(scene: &'a Scene, m: usize, images: &mut Vec<File<'a>>) -> String {
    let inner = surface_bsdf_xml(scene, m);
    let Some(map) = scene.bump_map(m) else {
        return inner;
    };
    let raw = |name: &str, file: &str| {
        format!(
            r#"<texture type="bitmap"{name}><boolean name="raw" value="true"/><string name="filename" value="{file}"/></texture>"#
        )
    };
    match map {
        crate::bump::BumpMap::Height { scale, heights, .. } => {
            let scale = scale.unwrap_or_else(|| relief_scale(scene, m, heights.width));
            // Ours is a colour image's channel mean, Mitsuba's its luminance: ours is written out.
            let file = if heights.plain_grey {
                file_name(map.path())
            } else {
                let name = format!("height_{m}.exr");
                images.push((
                    name.clone(),
                    Body::Image {
                        width: heights.width,
                        height: heights.height,
                        channels: &["Y"],
                        values: Cow::Borrowed(&heights.values),
                    },
                ));
                name
            };
            format!(
                r#"<bsdf type="bumpmap">{}<float name="scale" value="{scale}"/>{inner}</bsdf>"#,
                raw("", &file)
            )
        }
        crate::bump::BumpMap::Normal {
            width,
            height,
            strength,
            ..
        } => {
            let baked = if *strength != 1.0 {
                map.encoded_at_strength()
            } else {
                None
            };
            let file = match baked {
                Some(values) => {
                    let name = format!("normal_{m}.exr");
                    images.push((
                        name.clone(),
                        Body::Image {
                            width: *width,
                            height: *height,
                            channels: &["R", "G", "B"],
                            values: Cow::Owned(values),
                        },
                    ));
                    name
                }
                None => file_name(map.path()),
            };
            format!(
                r#"<bsdf type="normalmap">{}{inner}</bsdf>"#,
                raw(r#" name="normalmap""#, &file)
            )
        }
    }
}

/// The world scale Mitsuba's `bumpmap` needs for material `m`'s height map of `width` texels when its
/// MTL gave no `-bm` (ours is relative to the texels: [`crate::bump::RELIEF_TEXELS`]): its mean texel
/// width over the material's triangles, which is exact where their mapping is uniform.
fn relief_scale(scene: &Scene, m: usize, width: u32) -> f32 {
    let g = &scene.geometry;
    let (sum, n) = g
        .triangles
        .iter()
        .enumerate()
        .filter(|(_, t)| t.material as usize == m)
        .filter_map(|(i, _)| crate::bump::uv_tangents(g, i as u32))
        .fold((0.0f64, 0u64), |(s, n), (dpdu, _)| {
            (s + f64::from(dpdu.length()), n + 1)
        });
    let mean = if n == 0 { 0.0 } else { sum / n as f64 };
    (f64::from(crate::bump::RELIEF_TEXELS) * mean / f64::from(width.max(1))) as f32
}

/// Material `m`'s BSDF without its bump map.
fn surface_bsdf_xml(scene: &Scene, m: usize) -> String {
    let mat = &scene.materials[m];
    match &mat.bsdf {
        Bsdf::Diffuse { albedo, texture } => {
            let refl = match texture {
                Some(t) => bitmap(scene, *t, "reflectance"),
                None => rgb("reflectance", *albedo),
            };
            format!(r#"<bsdf type="twosided"><bsdf type="diffuse">{refl}</bsdf></bsdf>"#)
        }
        Bsdf::Mirror { reflectance } => format!(
            r#"<bsdf type="twosided"><bsdf type="conductor"><string name="material" value="none"/>{}</bsdf></bsdf>"#,
            rgb("specular_reflectance", *reflectance)
        ),
        Bsdf::Glass { ior, transmittance } => format!(
            r#"<bsdf type="dielectric"><float name="int_ior" value="{ior}"/><float name="ext_ior" value="1"/>{}</bsdf>"#,
            rgb("specular_transmittance", *transmittance)
        ),
        Bsdf::Glossy {
            albedo,
            specular,
            exponent,
            texture,
            texel_scale,
        } => {
            // pm_phong's parameters (tools/mref_phong.py): colours as strings, the texture nested.
            let tex = match texture {
                Some(t) => format!(
                    r#"{}<float name="texture_scale" value="{texel_scale}"/>"#,
                    bitmap(scene, *t, "texture")
                ),
                None => String::new(),
            };
            format!(
                r#"<bsdf type="pm_phong"><string name="albedo" value="{} {} {}"/><string name="specular" value="{} {} {}"/><float name="exponent" value="{exponent}"/>{tex}</bsdf>"#,
                albedo.x, albedo.y, albedo.z, specular.x, specular.y, specular.z
            )
        }
        Bsdf::Null => r#"<bsdf type="null"/>"#.into(),
    }
}
