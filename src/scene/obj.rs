//! OBJ/MTL loading through `tobj`, after the line-by-line check of [`objcheck`](super::objcheck) that
//! gives errors a line number (tobj's own errors carry none).

use std::collections::HashMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::input::{read_text, MAX_OBJ_BYTES};
use super::objcheck::check_obj;
use crate::error::{in_file, Result};

/// One OBJ file's triangles, with per-vertex attributes unified by tobj's `single_index`.
pub struct ObjData {
    pub models: Vec<ObjModel>,
    pub materials: Vec<tobj::Material>,
    pub mtl_dir: PathBuf,
    /// Where each material's `Ke` was given (MTL file and line).
    pub ke_at: HashMap<String, (PathBuf, usize)>,
    /// The `usemtl` names no library defines, with the OBJ line of each one's first use.
    pub undefined: Vec<(String, usize)>,
}

pub struct ObjModel {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals; empty when the OBJ gives none for this model.
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
    pub material: Option<usize>,
}

pub fn load(path: &Path) -> Result<ObjData> {
    let text = read_text(path, "OBJ file", MAX_OBJ_BYTES, Some(b'#'))?;
    let checked = check_obj(path, &text)?;
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // The check rewrote `mtllib` statements to indices into the libraries it read.
    let libraries = &checked.libraries;
    let load_mtl = |name: &Path| {
        let lib = name
            .to_str()
            .and_then(|k| k.parse::<usize>().ok())
            .and_then(|k| libraries.get(k));
        match lib {
            Some((_, mtl)) => tobj::load_mtl_buf(&mut Cursor::new(mtl.as_bytes())),
            None => Err(tobj::LoadError::OpenFileFailed),
        }
    };
    // tobj can panic on inputs the check does not foresee; that is still bad input, not a crash.
    let loaded = std::panic::catch_unwind(|| {
        tobj::load_obj_buf(&mut Cursor::new(checked.text.as_bytes()), &opts, load_mtl)
    })
    .map_err(|_| in_file(path, "OBJ/MTL could not be parsed (malformed statement)"))?;
    let (models, materials) = loaded.map_err(|e| in_file(path, format!("OBJ: {e}")))?;
    let materials = materials.map_err(|e| in_file(path, format!("MTL: {e}")))?;
    let models = models
        .into_iter()
        .map(|m| {
            let mesh = m.mesh;
            let v3 = |a: &[f32]| {
                a.chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2]))
                    .collect::<Vec<_>>()
            };
            let positions = v3(&mesh.positions);
            let indices = without_repeated_triangles(&positions, mesh.indices);
            ObjModel {
                positions,
                normals: v3(&mesh.normals),
                uvs: mesh
                    .texcoords
                    .chunks_exact(2)
                    .map(|c| Vec2::new(c[0], c[1]))
                    .collect(),
                indices,
                material: mesh.material_id,
            }
        })
        .collect();
    Ok(ObjData {
        models,
        materials,
        mtl_dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        ke_at: checked.ke_at,
        undefined: checked.undefined,
    })
}

/// `indices` (triangles) without the triangles that repeat an earlier one of the model: the same three
/// positions in the same winding. A repeat adds nothing to the image, but a stack of them is one place
/// a ray must test every one of: one face line of 3 M vertex references fanned into 333 k copies of a
/// triangle took 74 s at 32².
fn without_repeated_triangles(positions: &[Vec3], indices: Vec<u32>) -> Vec<u32> {
    let key = |f: &[u32]| {
        let v = [0, 1, 2].map(|k| {
            positions
                .get(f[k] as usize)
                .map_or([u32::MAX; 3], |p| p.to_array().map(f32::to_bits))
        });
        // The rotation starting at the least vertex: one key per winding.
        let first = (0..3).min_by_key(|&k| v[k]).unwrap_or(0);
        [v[first], v[(first + 1) % 3], v[(first + 2) % 3]]
    };
    let mut seen = std::collections::HashSet::with_capacity(indices.len() / 3);
    let mut kept = Vec::with_capacity(indices.len());
    for f in indices.chunks_exact(3) {
        if seen.insert(key(f)) {
            kept.extend_from_slice(f);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_triangles_are_dropped_in_either_rotation_not_when_flipped() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO];
        let indices = vec![0, 1, 2, 1, 2, 0, 3, 1, 2, 0, 2, 1, 0, 1, 2];
        assert_eq!(
            without_repeated_triangles(&positions, indices),
            vec![0, 1, 2, 0, 2, 1]
        );
    }
}
