//! The MTL → material mapping and the scene file's `[materials.NAME]` overrides.

use std::path::Path;

use glam::Vec3;

use super::file::MaterialDesc;
use super::limits::{self, MAX_EXPONENT, MAX_IOR};
use crate::bump::Statement;
use crate::error::{at_line, Error, Result};
use crate::material::{Bsdf, Material};

fn v3(a: Option<[f32; 3]>) -> Option<Vec3> {
    a.map(Vec3::from_array)
}

fn param3(m: &tobj::Material, key: &str) -> Option<Vec3> {
    let s = m.unknown_param.get(key)?;
    let v: Vec<f32> = s
        .split_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    match v.len() {
        1 => Some(Vec3::splat(v[0])),
        n if n >= 3 => Some(Vec3::new(v[0], v[1], v[2])),
        _ => None,
    }
}

/// The image files an MTL material names that the renderer reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MtlMaps {
    /// `map_Kd`, the diffuse colour (of diffuse and glossy materials).
    pub kd: Option<String>,
    /// `map_d`, a cutout mask (of any material).
    pub d: Option<String>,
    /// `map_Ks` and `map_Ns`, scales of the glossy lobe's colour and exponent (of glossy materials).
    pub ks: Option<String>,
    pub ns: Option<String>,
    /// `norm`, else `bump`/`map_bump`/`map_Bump`: a normal or height map (of any material but `null`).
    pub bump: Option<BumpStatement>,
}

/// A bump or normal map statement: its file, which statement it was and its `-bm` value (`None`
/// when absent or not a number).
#[derive(Clone, Debug, PartialEq)]
pub struct BumpStatement {
    pub file: String,
    pub statement: Statement,
    pub bm: Option<f32>,
}

/// The value of option `name` (`-bm`) among a texture statement's options, when it is a number.
pub fn map_option(arg: &str, name: &str) -> Option<f32> {
    let options = &arg.trim()[..arg.trim().len() - map_file(arg).len()];
    let mut words = options.split_whitespace();
    words.find(|w| *w == name)?;
    words.next()?.parse().ok()
}

/// The bump statement of an MTL material: `norm` when given (explicitly a normal map), else `bump`
/// (tobj keeps the last of `bump`, `map_bump`, `map_Bump`).
fn bump_statement(m: &tobj::Material) -> Option<BumpStatement> {
    let (arg, statement) = match m.unknown_param.get("norm") {
        Some(a) => (a.as_str(), Statement::Norm),
        None => (m.normal_texture.as_deref()?, Statement::Bump),
    };
    let file = map_file(arg);
    (!file.is_empty()).then(|| BumpStatement {
        file: file.to_string(),
        statement,
        bm: map_option(arg, "-bm").filter(|b| b.is_finite()),
    })
}

/// The file a texture statement names, after its options (`-clamp on`, `-bm 0.5`, `-o u v w`, …):
/// the rest of the statement from the first word that is not an option or an option's value (a file
/// name may hold spaces).
pub fn map_file(arg: &str) -> &str {
    let mut rest = arg.trim();
    loop {
        let mut words = rest.split_whitespace();
        let Some(option) = words.next().filter(|w| w.starts_with('-')) else {
            return rest;
        };
        // Values each option takes: -o, -s and -t up to three numbers, -mm two, the others one.
        let (least, most) = match option {
            "-o" | "-s" | "-t" => (1, 3),
            "-mm" => (2, 2),
            "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan"
            | "-texres" | "-type" => (1, 1),
            _ => return rest,
        };
        let mut n_values = 0;
        let mut after = &rest[option.len()..];
        while n_values < most {
            let trimmed = after.trim_start();
            let Some(word) = trimmed.split_whitespace().next() else {
                break;
            };
            if n_values >= least && word.parse::<f32>().is_err() {
                break;
            }
            after = &trimmed[word.len()..];
            n_values += 1;
        }
        rest = after.trim_start();
    }
}

/// A texture statement's file, when it names one.
fn map_path(statement: &Option<String>) -> Option<String> {
    let name = map_file(statement.as_deref()?);
    (!name.is_empty()).then(|| name.to_string())
}

/// The MTL mapping: Ke > 0 → emission; illum 3/5 → mirror; 4/6/7 → glass; Ks > 0 with Ns > 1 →
/// glossy; otherwise diffuse. Returns the material and the image files it reads (`map_Kd` for
/// diffuse and glossy, `map_d` and a bump map for any, `map_Ks` and `map_Ns` for glossy once
/// overrides are applied).
pub fn from_mtl(m: &tobj::Material) -> (Material, MtlMaps) {
    let kd = v3(m.diffuse).unwrap_or(Vec3::splat(0.8));
    let ks = v3(m.specular).unwrap_or(Vec3::ZERO);
    // The MTL check has put every colour in its range already.
    let emission = v3(m.emissive)
        .or_else(|| param3(m, "Ke"))
        .unwrap_or(Vec3::ZERO);
    let ns = m.shininess.unwrap_or(0.0);
    let bsdf = match m.illumination_model {
        Some(3) | Some(5) => Bsdf::Mirror { reflectance: ks },
        Some(4) | Some(6) | Some(7) => {
            let ni = m.optical_density.unwrap_or(1.5);
            Bsdf::Glass {
                ior: if ni <= 1.0 { 1.5 } else { ni },
                transmittance: param3(m, "Tf").unwrap_or(Vec3::ONE),
            }
        }
        _ if ks.max_element() > 0.0 && ns > 1.0 => glossy(kd, ks, ns),
        _ => Bsdf::Diffuse {
            albedo: kd,
            texture: None,
        },
    };
    let maps = MtlMaps {
        kd: match bsdf {
            Bsdf::Diffuse { .. } | Bsdf::Glossy { .. } => map_path(&m.diffuse_texture),
            _ => None,
        },
        d: map_path(&m.dissolve_texture),
        ks: map_path(&m.specular_texture),
        ns: map_path(&m.shininess_texture),
        bump: bump_statement(m),
    };
    (
        Material {
            name: m.name.clone(),
            bsdf,
            emission,
        },
        maps,
    )
}

/// Modified Phong, scaled down where kd + ks would reflect more than it receives.
fn glossy(kd: Vec3, ks: Vec3, exponent: f32) -> Bsdf {
    let total = (kd + ks).max_element();
    let s = if total > 1.0 { 1.0 / total } else { 1.0 };
    Bsdf::Glossy {
        albedo: kd * s,
        specular: ks * s,
        exponent,
        texture: None,
        texel_scale: s,
    }
}

/// Applies `[materials.NAME]` on top of the MTL material. Returns the new texture path, if set.
/// `line_of(key)` is the scene file's line of that key in this material's table.
pub fn apply_override(
    scene: &Path,
    line_of: &dyn Fn(&str) -> usize,
    mat: &mut Material,
    d: &MaterialDesc,
) -> Result<Option<String>> {
    let name = mat.name.clone();
    let key_err = |key: &str, msg: String| -> Error {
        at_line(
            scene,
            line_of(key),
            format!("materials.{name}.{key}: {msg}"),
        )
    };
    let err = |msg: String| -> Error {
        at_line(scene, line_of("type"), format!("materials.{name}: {msg}"))
    };
    let kind = d
        .kind
        .clone()
        .unwrap_or_else(|| type_name(&mat.bsdf).into());
    let Some(allowed) = allowed_keys(&kind) else {
        return Err(err(format!(
            "unknown type '{kind}' (diffuse | mirror | glass | glossy | null)"
        )));
    };
    let given = [
        ("albedo", d.albedo.is_some()),
        ("texture", d.texture.is_some()),
        ("reflectance", d.reflectance.is_some()),
        ("ior", d.ior.is_some()),
        ("transmittance", d.transmittance.is_some()),
        ("specular", d.specular.is_some()),
        ("exponent", d.exponent.is_some()),
    ];
    if let Some((k, _)) = given.iter().find(|(k, g)| *g && !allowed.contains(k)) {
        return Err(err(format!("key '{k}' does not apply to type '{kind}'")));
    }
    for (k, v) in [
        ("albedo", d.albedo),
        ("reflectance", d.reflectance),
        ("transmittance", d.transmittance),
        ("specular", d.specular),
    ] {
        if let Some(p) = v.and_then(limits::unit_interval) {
            return Err(key_err(k, p));
        }
    }
    if let Some(p) = d.emission.and_then(limits::emission) {
        return Err(key_err("emission", p));
    }
    if kind == "null" && v3(d.emission).unwrap_or(mat.emission) != Vec3::ZERO {
        return Err(err(
            "a 'null' medium boundary cannot emit (set no emission, and no Ke in the MTL)".into(),
        ));
    }
    let (bsdf, texture) = overridden_bsdf(&kind, d, &mat.bsdf, &key_err)?;
    mat.bsdf = bsdf;
    if let Some(e) = d.emission {
        mat.emission = Vec3::from_array(e);
    }
    Ok(texture)
}

/// The scene file's name of a BSDF's type.
fn type_name(bsdf: &Bsdf) -> &'static str {
    match bsdf {
        Bsdf::Diffuse { .. } => "diffuse",
        Bsdf::Mirror { .. } => "mirror",
        Bsdf::Glass { .. } => "glass",
        Bsdf::Glossy { .. } => "glossy",
        Bsdf::Null => "null",
    }
}

/// The keys a material type takes besides `type` and `emission`; `None` for an unknown type.
fn allowed_keys(kind: &str) -> Option<&'static [&'static str]> {
    Some(match kind {
        "diffuse" => &["albedo", "texture"],
        "mirror" => &["reflectance"],
        "glass" => &["ior", "transmittance"],
        "glossy" => &["albedo", "specular", "exponent", "texture"],
        "null" => &[],
        _ => return None,
    })
}

/// The BSDF of type `kind` (one [`allowed_keys`] knows) with the override's values, and its texture
/// path. Keys not given keep the `old` BSDF's values when it has that type, else take its diffuse
/// and specular colours or the defaults.
fn overridden_bsdf(
    kind: &str,
    d: &MaterialDesc,
    old: &Bsdf,
    key_err: &dyn Fn(&str, String) -> Error,
) -> Result<(Bsdf, Option<String>)> {
    let (kd, ks, ns) = match old {
        Bsdf::Diffuse { albedo, .. } => (*albedo, Vec3::ZERO, 1.0),
        Bsdf::Glossy {
            albedo,
            specular,
            exponent,
            ..
        } => (*albedo, *specular, *exponent),
        _ => (Vec3::splat(0.8), Vec3::ZERO, 1.0),
    };
    let mirror_r = match *old {
        Bsdf::Mirror { reflectance } => Some(reflectance),
        _ => None,
    };
    let (glass_ior, glass_t) = match *old {
        Bsdf::Glass { ior, transmittance } => (Some(ior), Some(transmittance)),
        _ => (None, None),
    };
    let mut texture = None;
    let bsdf = match kind {
        "null" => Bsdf::Null,
        "diffuse" => {
            texture = d.texture.clone();
            Bsdf::Diffuse {
                albedo: v3(d.albedo).unwrap_or(kd),
                texture: None,
            }
        }
        "mirror" => Bsdf::Mirror {
            reflectance: v3(d.reflectance)
                .or(mirror_r)
                .unwrap_or(if ks.max_element() > 0.0 {
                    ks
                } else {
                    Vec3::ONE
                }),
        },
        "glass" => {
            let ior = d.ior.or(glass_ior).unwrap_or(1.5);
            if !(ior > 1.0 && ior <= MAX_IOR) {
                return Err(key_err("ior", format!("{ior} is outside (1, {MAX_IOR}]")));
            }
            Bsdf::Glass {
                ior,
                transmittance: v3(d.transmittance).or(glass_t).unwrap_or(Vec3::ONE),
            }
        }
        _ => {
            texture = d.texture.clone();
            let exponent = d.exponent.unwrap_or(ns.max(1.0));
            if !(0.0..=MAX_EXPONENT).contains(&exponent) {
                return Err(key_err(
                    "exponent",
                    format!("{exponent} is outside [0, {MAX_EXPONENT:e}]"),
                ));
            }
            // A texel stands for Kd: when Kd is the old glossy one, it was scaled down once already.
            let old_scale = match *old {
                Bsdf::Glossy { texel_scale, .. } if d.albedo.is_none() => texel_scale,
                _ => 1.0,
            };
            let mut bsdf = glossy(
                v3(d.albedo).unwrap_or(kd),
                v3(d.specular).unwrap_or(ks),
                exponent,
            );
            if let Bsdf::Glossy { texel_scale, .. } = &mut bsdf {
                *texel_scale *= old_scale;
            }
            bsdf
        }
    };
    Ok((bsdf, texture))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Blender-style material (`Ks 0.5`, `Ns 250`, `illum 2`, `map_Kd`) is glossy and keeps its
    /// texture, read as the diffuse colour scaled by the factor that brought Kd + Ks to 1; a `glossy`
    /// override takes a texture as a diffuse one does, and a type change drops it unless given.
    #[test]
    fn glossy_materials_keep_their_texture() {
        let d = tempfile::tempdir().unwrap();
        let w = |name: &str, text: &str| std::fs::write(d.path().join(name), text).unwrap();
        // Two quads facing +z, side by side, each with its own material.
        w(
            "m.obj",
            "mtllib m.mtl\nv -2 -1 0\nv 0 -1 0\nv 0 1 0\nv -2 1 0\nv 0 -1 0\nv 2 -1 0\nv 2 1 0\nv 0 1 0\n\
             vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             usemtl blender\nf 1/1 2/2 3/3 4/4\nusemtl plain\nf 5/1 6/2 7/3 8/4\n",
        );
        w(
            "m.mtl",
            "newmtl blender\nKd 0.8 0.8 0.8\nKs 0.5 0.5 0.5\nNs 250\nillum 2\nmap_Kd grey.ppm\n\
             newmtl plain\nKd 0.5 0.5 0.5\nmap_Kd grey.ppm\n",
        );
        // sRGB 128: linear 0.2158.
        w("grey.ppm", "P3\n1 1\n255\n128 128 128\n");
        let scene = |overrides: &str| {
            w(
                "s.toml",
                &format!(
                    "[camera]\neye = [0.0, 0.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 60.0\n\
                     width = 8\nheight = 8\n[[mesh]]\nobj = \"m.obj\"\n\
                     [[light]]\ntype = \"point\"\nposition = [0.0, 0.0, 2.0]\n\
                     intensity = [1.0, 1.0, 1.0]\n{overrides}"
                ),
            );
            crate::scene::load(&d.path().join("s.toml")).unwrap()
        };
        let eye = Vec3::new(0.0, 0.0, 4.0);
        let albedo_at = |s: &crate::scene::Scene, x: f32| {
            let hit = s.intersect(eye, (Vec3::new(x, 0.0, 0.0) - eye).normalize());
            s.albedo(&hit.expect("the ray hits a quad"))
        };
        let grey = 0.21586;
        let s = scene("");
        let blender = s.materials.iter().find(|m| m.name == "blender").unwrap();
        let Bsdf::Glossy {
            texture: Some(_),
            texel_scale,
            specular,
            ..
        } = blender.bsdf
        else {
            panic!("{:?}", blender.bsdf);
        };
        assert!((texel_scale - 1.0 / 1.3).abs() < 1e-6);
        assert!((specular.x - 0.5 / 1.3).abs() < 1e-6);
        let a = albedo_at(&s, -1.0);
        assert!((a.x - grey / 1.3).abs() < 1e-3, "{a}");
        assert!((albedo_at(&s, 1.0).x - grey).abs() < 1e-3);
        // A diffuse material made glossy keeps a texture only when the override gives one; the texel
        // is scaled as its Kd: 0.5 + 0.75 → 1/1.25.
        let s = scene("[materials.plain]\ntype = \"glossy\"\nspecular = [0.75, 0.75, 0.75]\nexponent = 20.0\n");
        assert!((albedo_at(&s, 1.0).x - 0.5 / 1.25).abs() < 1e-5);
        let s = scene(
            "[materials.plain]\ntype = \"glossy\"\nspecular = [0.75, 0.75, 0.75]\nexponent = 20.0\n\
             texture = \"grey.ppm\"\n",
        );
        assert!((albedo_at(&s, 1.0).x - grey / 1.25).abs() < 1e-3);
        // Glossy kept glossy keeps its texture, and Kd's first scaling: 0.8/1.3 + 0.5/1.3 = 1, so the
        // override scales no further.
        let s = scene("[materials.blender]\nexponent = 40.0\n");
        assert!((albedo_at(&s, -1.0).x - grey / 1.3).abs() < 1e-3);
        // Glossy made diffuse drops it unless given.
        let s = scene("[materials.blender]\ntype = \"diffuse\"\n");
        assert!((albedo_at(&s, -1.0).x - 0.8 / 1.3).abs() < 1e-5);
    }

    #[test]
    fn texture_options_are_skipped() {
        for (statement, file) in [
            ("leaf.png", "leaf.png"),
            ("-clamp on leaf.png", "leaf.png"),
            ("-bm 0.5 -imfchan m my leaf.png", "my leaf.png"),
            ("-o 0.5 -s 2 2 1 leaf.png", "leaf.png"),
            ("-s 2 2 leaf.png", "leaf.png"),
            ("-mm 0 1 -type sphere leaf.png", "leaf.png"),
            ("-unknown leaf.png", "-unknown leaf.png"),
            ("-clamp", ""),
        ] {
            assert_eq!(map_file(statement), file, "{statement}");
        }
        assert_eq!(map_option("-bm 0.25 -clamp on n.png", "-bm"), Some(0.25));
        assert_eq!(map_option("-clamp on -bm 2 my n.png", "-bm"), Some(2.0));
        assert_eq!(map_option("n.png", "-bm"), None);
        assert_eq!(map_option("-bm x n.png", "-bm"), None);
        // A file named -bm is no option.
        assert_eq!(map_option("-unknown -bm 3", "-bm"), None);
    }

    #[test]
    fn overrides_keep_the_values_they_do_not_set() {
        let mut glass = Material {
            name: "g".into(),
            bsdf: Bsdf::Glass {
                ior: 2.5,
                transmittance: Vec3::splat(0.1),
            },
            emission: Vec3::ZERO,
        };
        let d = MaterialDesc {
            transmittance: Some([1.0; 3]),
            ..Default::default()
        };
        apply_override(Path::new("s.toml"), &|_| 1, &mut glass, &d).unwrap();
        assert_eq!(
            glass.bsdf,
            Bsdf::Glass {
                ior: 2.5,
                transmittance: Vec3::ONE
            }
        );
        let mut mirror = Material {
            name: "m".into(),
            bsdf: Bsdf::Mirror {
                reflectance: Vec3::splat(0.9),
            },
            emission: Vec3::ZERO,
        };
        let d = MaterialDesc {
            emission: Some([1.0; 3]),
            ..Default::default()
        };
        apply_override(Path::new("s.toml"), &|_| 1, &mut mirror, &d).unwrap();
        assert_eq!(
            mirror.bsdf,
            Bsdf::Mirror {
                reflectance: Vec3::splat(0.9)
            }
        );
        assert_eq!(mirror.emission, Vec3::ONE);
        let d = MaterialDesc {
            kind: Some("glass".into()),
            reflectance: Some([1.0; 3]),
            ..Default::default()
        };
        assert!(apply_override(Path::new("s.toml"), &|_| 1, &mut mirror, &d).is_err());
        for bad in [[10.0; 3], [-0.1, 0.5, 0.5], [f32::NAN, 0.0, 0.0]] {
            let d = MaterialDesc {
                kind: Some("diffuse".into()),
                albedo: Some(bad),
                ..Default::default()
            };
            let e = apply_override(
                Path::new("s.toml"),
                &|k| if k == "albedo" { 7 } else { 1 },
                &mut mirror,
                &d,
            )
            .unwrap_err();
            assert!(
                e.to_string().starts_with("s.toml:7: materials.m.albedo:"),
                "{e}"
            );
        }
    }
}
