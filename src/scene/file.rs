//! The TOML scene file: its schema (unknown keys are errors) and the mapping of parse errors to lines.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use crate::error::{at_line, Result};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub version: Option<i64>,
    pub camera: CameraDesc,
    #[serde(default)]
    pub mesh: Vec<MeshDesc>,
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDesc>,
    #[serde(default)]
    pub light: Vec<LightDesc>,
    #[serde(default)]
    pub render: RenderDesc,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov: f32,
    pub width: i64,
    pub height: i64,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    pub obj: String,
    pub scale: Option<Scale>,
    pub rotate: Option<[f32; 3]>,
    pub translate: Option<[f32; 3]>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialDesc {
    #[serde(rename = "type")]
    pub kind: Option<String>,
    pub albedo: Option<[f32; 3]>,
    pub texture: Option<String>,
    pub reflectance: Option<[f32; 3]>,
    pub ior: Option<f32>,
    pub transmittance: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub exponent: Option<f32>,
    pub emission: Option<[f32; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    #[serde(rename = "type")]
    pub kind: String,
    pub position: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub intensity: Option<[f32; 3]>,
    pub cone_angle: Option<f32>,
    pub falloff_start: Option<f32>,
    pub direction: Option<[f32; 3]>,
    pub irradiance: Option<[f32; 3]>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    pub method: Option<String>,
    pub spp: Option<i64>,
    pub seed: Option<u64>,
    pub max_depth: Option<i64>,
    pub photons: Option<PhotonsDesc>,
    pub icache: Option<IcacheDesc>,
}

/// `[render.photons]`: photon-map settings; every value has a scene-derived default.
#[derive(Debug, Default, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct PhotonsDesc {
    pub global: Option<i64>,
    pub caustic: Option<i64>,
    pub lookup: Option<i64>,
    pub max_radius: Option<f32>,
    pub precompute_every: Option<i64>,
    pub caustic_filter: Option<String>,
}

/// `[render.icache]`: irradiance-cache settings; every value has a default.
#[derive(Debug, Default, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub struct IcacheDesc {
    pub accuracy: Option<f32>,
    pub rays: Option<i64>,
    pub min_spacing_px: Option<f32>,
    pub max_spacing_px: Option<f32>,
    pub weight: Option<String>,
    pub neighbor_clamping: Option<bool>,
    pub gradients: Option<bool>,
    pub pass_b_accuracy: Option<f32>,
    pub fill: Option<String>,
}

/// Parses the scene file text; errors name the file and line.
pub fn parse(path: &Path, text: &str) -> Result<SceneFile> {
    toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of_offset(text, s.start)).unwrap_or(1);
        at_line(path, line, e.message().trim().replace('\n', "; "))
    })
}

pub fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

/// The line on which `key` is set inside the table `[table]` (or `[[table]]` number `index`), for
/// messages about values that parsed but are out of range. Falls back to the table's line, then 1.
pub fn line_of_key(text: &str, table: &str, index: usize, key: &str) -> usize {
    let mut in_table = table.is_empty();
    let mut seen = 0usize;
    let mut table_line = 1;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.starts_with('[') {
            let name = line.trim_start_matches('[').split(']').next().unwrap_or("").trim();
            if name == table {
                in_table = seen == index;
                seen += 1;
                if in_table {
                    table_line = i + 1;
                }
            } else {
                in_table = false;
            }
            continue;
        }
        if in_table {
            let k = line.split('=').next().unwrap_or("").trim();
            if k == key {
                return i + 1;
            }
        }
    }
    table_line
}
