//! Diffuse colour textures (`map_Kd`), read with OpenImageIO and sampled bilinearly with wrapping.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::io::oiio;

pub struct Texture {
    /// The file it was read from.
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// Linear RGB, top row first.
    pub texels: Vec<Vec3>,
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Finds `name` in `dir`, also when the MTL spells the file name with another letter case.
pub fn resolve(dir: &Path, name: &str) -> Option<PathBuf> {
    let name = name.replace('\\', "/");
    let direct = dir.join(&name);
    if direct.is_file() {
        return Some(direct);
    }
    let wanted = direct.file_name()?.to_string_lossy().to_lowercase();
    let parent = direct.parent()?;
    std::fs::read_dir(parent).ok()?.flatten().map(|e| e.path()).find(|p| {
        p.file_name().map(|f| f.to_string_lossy().to_lowercase() == wanted).unwrap_or(false)
    })
}

impl Texture {
    /// Loads an 8-bit (sRGB-encoded) or float (linear) image.
    pub fn load(path: &Path) -> Result<Texture, String> {
        let img = oiio::read(path)?;
        let is_float = matches!(path.extension().and_then(|e| e.to_str()).map(str::to_lowercase).as_deref(), Some("exr" | "hdr"));
        let nc = img.channels as usize;
        let texels = img
            .data
            .chunks_exact(nc)
            .map(|px| {
                let c = |k: usize| px[k.min(nc - 1)];
                let v = Vec3::new(c(0), c(1), c(2));
                if is_float {
                    v
                } else {
                    Vec3::new(srgb_to_linear(v.x), srgb_to_linear(v.y), srgb_to_linear(v.z))
                }
            })
            .collect();
        Ok(Texture { path: path.to_path_buf(), width: img.width, height: img.height, texels })
    }

    /// Bilinear lookup; OBJ's v runs upward, image rows downward.
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x.rem_euclid(1.0) * w as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h as f32 - 0.5;
        if !x.is_finite() || !y.is_finite() {
            return self.texels[0];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: i64, j: i64| self.texels[(j.rem_euclid(h) * w + i.rem_euclid(w)) as usize];
        let (i, j) = (x0 as i64, y0 as i64);
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy) + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }
}
