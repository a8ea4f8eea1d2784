//! OBJ/MTL loading through `tobj`, after a line-by-line check that gives errors a line number
//! (tobj's own errors carry none): non-finite coordinates, out-of-range face indices, missing MTL files.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{at_line, in_file, relative_to, Result};

/// One OBJ file's triangles, with per-vertex attributes unified by tobj's `single_index`.
pub struct ObjData {
    pub models: Vec<ObjModel>,
    pub materials: Vec<tobj::Material>,
    pub mtl_dir: PathBuf,
}

pub struct ObjModel {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals; empty when the OBJ gives none for this model.
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<u32>,
    pub material: Option<usize>,
}

/// Checks what tobj would reject or accept silently, so that the user gets `file:line: what`.
fn precheck(path: &Path, text: &str) -> Result<()> {
    let (mut nv, mut nt, mut nn) = (0i64, 0i64, 0i64);
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let mut it = raw.split_whitespace();
        let Some(tag) = it.next() else { continue };
        match tag {
            "v" | "vt" | "vn" => {
                for tok in it.take(3) {
                    match tok.parse::<f32>() {
                        Ok(x) if x.is_finite() => {}
                        Ok(_) => return Err(at_line(path, line_no, format!("non-finite coordinate '{tok}'"))),
                        Err(_) => return Err(at_line(path, line_no, format!("'{tok}' is not a number"))),
                    }
                }
                match tag {
                    "v" => nv += 1,
                    "vt" => nt += 1,
                    _ => nn += 1,
                }
            }
            "f" => {
                let corners: Vec<&str> = it.collect();
                if corners.len() < 3 {
                    return Err(at_line(path, line_no, "a face needs at least 3 vertices"));
                }
                for c in corners {
                    for (slot, part) in c.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let count = [nv, nt, nn].get(slot).copied().unwrap_or(0);
                        let idx: i64 = part
                            .parse()
                            .map_err(|_| at_line(path, line_no, format!("bad face index '{part}'")))?;
                        let resolved = if idx < 0 { count + idx + 1 } else { idx };
                        if idx == 0 || resolved < 1 || resolved > count {
                            let what = ["vertex", "texture coordinate", "normal"][slot.min(2)];
                            return Err(at_line(
                                path,
                                line_no,
                                format!("face {what} index {idx} out of range (1..={count} defined so far)"),
                            ));
                        }
                    }
                }
            }
            "mtllib" => {
                let name = raw.trim_start()[6..].trim();
                let mtl = relative_to(path, name);
                if !mtl.is_file() {
                    return Err(at_line(path, line_no, format!("material library '{}' not found", mtl.display())));
                }
                let mtl_text = std::fs::read_to_string(&mtl).map_err(|e| in_file(&mtl, e))?;
                precheck_mtl(&mtl, &mtl_text)?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// Numbers in an MTL must be finite; tobj would otherwise accept `Kd nan`.
fn precheck_mtl(path: &Path, text: &str) -> Result<()> {
    for (i, raw) in text.lines().enumerate() {
        let mut it = raw.split_whitespace();
        let Some(tag) = it.next() else { continue };
        if matches!(tag, "Kd" | "Ks" | "Ke" | "Ka" | "Tf" | "Ns" | "Ni") {
            let mut n = 0;
            for tok in it {
                if tok.starts_with('#') {
                    break;
                }
                match tok.parse::<f32>() {
                    Ok(x) if x.is_finite() => n += 1,
                    _ => return Err(at_line(path, i + 1, format!("{tag}: '{tok}' is not a finite number"))),
                }
            }
            let want = if matches!(tag, "Ns" | "Ni") { 1 } else { 3 };
            if n < want {
                return Err(at_line(path, i + 1, format!("{tag} needs {want} number(s), found {n}")));
            }
        }
    }
    Ok(())
}

pub fn load(path: &Path) -> Result<ObjData> {
    let text = std::fs::read_to_string(path).map_err(|e| in_file(path, format!("cannot read OBJ: {e}")))?;
    precheck(path, &text)?;
    let opts = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    // tobj can panic on inputs the check above does not foresee; that is still bad input, not a crash.
    let loaded = std::panic::catch_unwind(|| tobj::load_obj(path, &opts))
        .map_err(|_| in_file(path, "OBJ/MTL could not be parsed (malformed statement)"))?;
    let (models, materials) = loaded.map_err(|e| in_file(path, format!("OBJ: {e}")))?;
    let materials = materials.map_err(|e| in_file(path, format!("MTL: {e}")))?;
    let models = models
        .into_iter()
        .map(|m| {
            let mesh = m.mesh;
            let v3 = |a: &[f32]| a.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
            ObjModel {
                positions: v3(&mesh.positions),
                normals: v3(&mesh.normals),
                uvs: mesh.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect(),
                indices: mesh.indices,
                material: mesh.material_id,
            }
        })
        .collect();
    Ok(ObjData {
        models,
        materials,
        mtl_dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
    })
}
