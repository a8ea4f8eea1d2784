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

/// Largest texture, in pixels (8192 × 8192), checked from the file's header before it is decoded.
pub const MAX_TEXTURE_PIXELS: u64 = 1 << 26;

/// Finds the regular file `name` in `dir`, also when the MTL spells the file name with another letter
/// case. Directories, devices and FIFOs are never returned: reading them could block or never end.
pub fn resolve(dir: &Path, name: &str) -> Result<PathBuf, String> {
    let name = name.replace('\\', "/");
    let direct = dir.join(&name);
    if direct.is_file() {
        return Ok(direct);
    }
    let parent = match direct.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let not_found = || format!("not found in '{}'", parent.display());
    let wanted = direct.file_name().ok_or_else(not_found)?.to_string_lossy().to_lowercase();
    let same_name = |p: &PathBuf| p.file_name().is_some_and(|f| f.to_string_lossy().to_lowercase() == wanted);
    let candidates: Vec<PathBuf> = std::fs::read_dir(&parent).map_err(|_| not_found())?.flatten().map(|e| e.path()).filter(same_name).collect();
    match candidates.iter().find(|p| p.is_file()) {
        Some(p) => Ok(p.clone()),
        None if direct.exists() || !candidates.is_empty() => Err("is not a regular file".into()),
        None => Err(not_found()),
    }
}

impl Texture {
    /// Loads an 8-bit (sRGB-encoded) or float (linear) image.
    /// Grey and grey+alpha images are grey (alpha is ignored). The size in the file's header is checked
    /// against [`MAX_TEXTURE_PIXELS`] before any pixel is decoded.
    pub fn load(path: &Path) -> Result<Texture, String> {
        let (width, height, channels) = oiio::image_size(path)?;
        let n_pixels = width as u64 * height as u64;
        if n_pixels > MAX_TEXTURE_PIXELS || channels == 0 {
            return Err(format!(
                "{width}×{height} pixels × {channels} channels: more than the limit of {MAX_TEXTURE_PIXELS} pixels (8192×8192)"
            ));
        }
        let img = oiio::read(path)?;
        if img.channels == 0 {
            return Err("image has no channels".into());
        }
        let is_float = matches!(path.extension().and_then(|e| e.to_str()).map(str::to_lowercase).as_deref(), Some("exr" | "hdr"));
        let nc = img.channels as usize;
        let texels = img
            .data
            .chunks_exact(nc)
            .map(|px| {
                let v = if nc >= 3 { Vec3::new(px[0], px[1], px[2]) } else { Vec3::splat(px[0]) };
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
