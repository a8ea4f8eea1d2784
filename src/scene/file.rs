//! The TOML scene file: its schema (unknown keys are errors) and the mapping of parse errors to lines.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Deserialize;

use crate::error::{at_line, Result};

#[derive(Clone, Debug, Deserialize)]
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
    #[serde(default)]
    pub medium: Vec<MediumDesc>,
    pub animation: Option<AnimationDesc>,
}

/// `[animation]`: the scene is a sequence of `frames` frames; `key` tables set values per frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnimationDesc {
    pub frames: i64,
}

/// `[[camera.key]]`: camera values at one frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKey {
    pub frame: i64,
    pub eye: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub up: Option<[f32; 3]>,
    pub fov: Option<f32>,
}

/// `[[mesh.key]]`: a mesh's placement at one frame.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshKey {
    pub frame: i64,
    pub scale: Option<Scale>,
    pub rotate: Option<[f32; 3]>,
    pub translate: Option<[f32; 3]>,
}

/// `[[light.key]]`: a light's values at one frame (those its type has).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightKey {
    pub frame: i64,
    pub position: Option<[f32; 3]>,
    pub target: Option<[f32; 3]>,
    pub direction: Option<[f32; 3]>,
    pub intensity: Option<[f32; 3]>,
    pub irradiance: Option<[f32; 3]>,
}

/// `[[medium]]`: a homogeneous participating medium, bounded by the meshes that name it as `interior`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    pub name: String,
    pub sigma_a: [f32; 3],
    pub sigma_s: [f32; 3],
    /// Read in double precision, so that a value that rounds to ±1 in single precision is named as given.
    pub g: Option<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub eye: [f32; 3],
    pub target: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov: f32,
    pub width: i64,
    pub height: i64,
    pub medium: Option<String>,
    #[serde(default)]
    pub key: Vec<CameraKey>,
}

#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    pub obj: String,
    pub scale: Option<Scale>,
    pub rotate: Option<[f32; 3]>,
    pub translate: Option<[f32; 3]>,
    /// The medium this closed mesh bounds.
    pub interior: Option<String>,
    #[serde(default)]
    pub key: Vec<MeshKey>,
}

#[derive(Clone, Debug, Default, Deserialize)]
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

#[derive(Clone, Debug, Deserialize)]
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
    #[serde(default)]
    pub key: Vec<LightKey>,
}

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    pub method: Option<String>,
    pub spp: Option<i64>,
    pub aa_spp: Option<i64>,
    pub noise: Option<f64>,
    pub seed: Option<u64>,
    pub max_depth: Option<i64>,
    pub ao_distance: Option<f32>,
    pub time: Option<f64>,
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
    pub adaptive: Option<bool>,
    pub adaptive_threshold: Option<f32>,
    pub media_gradients: Option<bool>,
    pub media_visibility: Option<bool>,
    pub pass_a_stride: Option<i64>,
    pub visibility: Option<bool>,
    pub radiance_cache: Option<bool>,
    pub radiance_bands: Option<i64>,
    pub temporal: Option<bool>,
}

/// Parses the scene file text; errors name the file and line.
pub fn parse(path: &Path, text: &str) -> Result<SceneFile> {
    toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of_offset(text, s.start)).unwrap_or(1);
        at_line(path, line, e.message().trim().replace('\n', "; "))
    })
}

pub fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The line on which `key` is set inside the table `table` (dotted, e.g. `render.icache`; entry `index`
/// of an array of tables such as `[[mesh]]`), for messages about values that parsed but are out of
/// range. Falls back to the deepest enclosing table or key that is present, then to line 1.
pub fn line_of_key(text: &str, table: &str, index: usize, key: &str) -> usize {
    let mut keys: Vec<&str> = table.split('.').filter(|k| !k.is_empty()).collect();
    keys.push(key);
    line_of(text, &keys, index)
}

/// The line of the value at the path `keys` (each a bare key, so names with dots or spaces work),
/// whatever TOML spelling set it: `[table]` sections, dotted keys, inline tables. An array met on the
/// way (`[[mesh]]`, or `mesh = [{ … }]`) is entered at `index`.
pub fn line_of(text: &str, keys: &[&str], index: usize) -> usize {
    line_of_path(text, keys, &[index])
}

/// [`line_of`] with an entry per array met on the way: the n-th array is entered at `indices[n]`
/// (the last index for any deeper one), e.g. `mesh.key.frame` at mesh 2, key 1.
pub fn line_of_path(text: &str, keys: &[&str], indices: &[usize]) -> usize {
    use toml_edit::{Item, TableLike, Value};
    enum Node<'a> {
        Table(&'a dyn TableLike),
        Tables(&'a toml_edit::ArrayOfTables),
        Array(&'a toml_edit::Array),
        Leaf,
    }
    fn of_value(v: &Value) -> Node<'_> {
        match v {
            Value::InlineTable(t) => Node::Table(t),
            Value::Array(a) => Node::Array(a),
            _ => Node::Leaf,
        }
    }
    fn of_item(i: &Item) -> Node<'_> {
        match i {
            Item::Table(t) => Node::Table(t),
            Item::ArrayOfTables(a) => Node::Tables(a),
            Item::Value(v) => of_value(v),
            Item::None => Node::Leaf,
        }
    }
    let Ok(doc) = toml_edit::ImDocument::parse(text) else {
        return 1;
    };
    let mut node = Node::Table(doc.as_table());
    let mut offset = None;
    let mut arrays = 0;
    let mut next_index = || {
        let i = indices.get(arrays).or(indices.last()).copied().unwrap_or(0);
        arrays += 1;
        i
    };
    for key in keys {
        // Enter an array of tables at the requested entry first.
        node = match node {
            Node::Tables(a) => match a.get(next_index()) {
                Some(t) => {
                    offset = t.span().map(|s| s.start).or(offset);
                    Node::Table(t)
                }
                None => break,
            },
            Node::Array(a) => match a.get(next_index()) {
                Some(v) => {
                    offset = v.span().map(|s| s.start).or(offset);
                    of_value(v)
                }
                None => break,
            },
            other => other,
        };
        let Node::Table(t) = node else { break };
        let Some((k, item)) = t.get_key_value(key) else {
            break;
        };
        offset = k.span().or_else(|| item.span()).map(|s| s.start).or(offset);
        node = of_item(item);
    }
    offset.map_or(1, |o| line_of_offset(text, o))
}
