//! Cutouts: MTL `map_d` masks that make parts of triangles invisible to every ray (leaves, fences).
//!
//! A mask is read from its image's alpha channel when it has one, else from its grey value, as stored
//! (a mask is data, not a colour: no sRGB decoding). A point whose bilinear mask value is below
//! [`THRESHOLD`] is cut away. Embree skips cut hits through a filter (`accel::embree`) that asks
//! [`Cutouts::is_cut`], so camera, shadow, gather and photon rays all see the same holes; a scene without
//! masks has no filter and pays nothing.

use std::path::Path;

use glam::Vec2;

use crate::accel::embree::Cutout;
use crate::texture::{bilinear, decode};

/// Below this mask value a point is cut away.
pub const THRESHOLD: f32 = 0.5;

/// One mask image: a value per texel, top row first.
pub struct Mask {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
    /// Whether a reader that drops alpha and takes a colour texel's luminance (Mitsuba's `bitmap`)
    /// reads these values from the image: it has no alpha and its texels are grey.
    pub plain_grey: bool,
}

impl Mask {
    /// Reads a mask from `path`: the alpha channel of a grey+alpha or RGBA image, else the mean of its
    /// colour channels; checked as textures are.
    pub fn load(path: &Path) -> Result<Mask, String> {
        Self::load_values(path, true)
    }

    /// One value a texel from `path` (a map of data, as `map_Ns`): with `alpha`, the alpha channel
    /// where the image has one; else, or without it, the mean of its colour channels.
    pub fn load_values(path: &Path, alpha: bool) -> Result<Mask, String> {
        let img = decode(path)?;
        let nc = img.channels as usize;
        let alpha = match nc {
            2 if alpha => Some(1),
            n if n >= 4 && alpha => Some(3),
            _ => None,
        };
        let n_colour = match nc {
            1 | 2 => 1,
            n => n.min(3),
        };
        let values: Vec<f32> = img
            .data
            .chunks_exact(nc)
            .map(|px| match alpha {
                Some(a) => px[a],
                None => px[..n_colour].iter().sum::<f32>() / n_colour as f32,
            })
            .collect();
        let plain_grey = alpha.is_none()
            && (n_colour == 1
                || img
                    .data
                    .chunks_exact(nc)
                    .all(|px| px[..n_colour].iter().all(|&c| c == px[0])));
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let w = img.width.max(1) as usize;
            return Err(format!(
                "mask texel ({}, {}) is not a finite number",
                i % w,
                i / w
            ));
        }
        Ok(Mask {
            width: img.width,
            height: img.height,
            values,
            plain_grey,
        })
    }

    /// The mask's value at `uv` (bilinear, wrapping, as colour textures are read).
    pub fn value(&self, uv: Vec2) -> f32 {
        bilinear(&self.values, self.width as usize, self.height as usize, uv)
    }
}

/// The masked triangles of a scene: which mask each one reads and the texture coordinates of its
/// corners.
pub struct Cutouts {
    masks: Vec<std::sync::Arc<Mask>>,
    /// Per triangle of the scene, its index in `masked`, or `u32::MAX` for a triangle without a mask.
    slot: Vec<u32>,
    /// Each masked triangle's mask and corner texture coordinates.
    masked: Vec<(u32, [Vec2; 3])>,
}

impl Cutouts {
    /// The cutouts of `n_triangles` triangles, `masked` listing (triangle, mask index, corner UVs) of
    /// those with a mask; `None` when none has one (no filter at all).
    pub fn new(
        masks: Vec<std::sync::Arc<Mask>>,
        n_triangles: usize,
        masked: impl IntoIterator<Item = (usize, u32, [Vec2; 3])>,
    ) -> Option<Cutouts> {
        let mut c = Cutouts {
            masks,
            slot: vec![u32::MAX; n_triangles],
            masked: Vec::new(),
        };
        for (tri, mask, uvs) in masked {
            c.slot[tri] = c.masked.len() as u32;
            c.masked.push((mask, uvs));
        }
        (!c.masked.is_empty()).then_some(c)
    }

    /// A hash (FNV-1a) of the masks and which triangles read them, for the scene's fingerprint.
    pub fn fingerprint(&self) -> u64 {
        // Streamed, not gathered: a mask may hold tens of millions of values.
        let words = self
            .masks
            .iter()
            .flat_map(|m| {
                [m.width, m.height]
                    .into_iter()
                    .chain(m.values.iter().map(|v| v.to_bits()))
            })
            .chain(self.masked.iter().flat_map(|(mask, uvs)| {
                std::iter::once(*mask)
                    .chain(uvs.iter().flat_map(|t| t.to_array().map(f32::to_bits)))
            }))
            .chain(self.slot.iter().copied());
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in words.flat_map(u32::to_le_bytes) {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
        h
    }
}

impl Cutouts {
    /// Mask `k` of the list [`Cutouts::new`] was given.
    pub fn mask(&self, k: u32) -> &Mask {
        &self.masks[k as usize]
    }

    /// Whether a mask cuts some emissive triangle of `lights` (their samples must then skip it).
    pub fn cuts_any(&self, lights: &crate::light::Lights) -> bool {
        lights.lights.iter().any(|l| {
            matches!(l, crate::light::Light::Area { tri, .. }
                if self.slot.get(*tri as usize).is_some_and(|&k| k != u32::MAX))
        })
    }
}

/// Shared by the BVH's filter and the lights (whose samples on cut texels emit nothing).
impl Cutout for std::sync::Arc<Cutouts> {
    fn is_cut(&self, prim: u32, u: f32, v: f32) -> bool {
        self.as_ref().is_cut(prim, u, v)
    }
}

impl Cutout for Cutouts {
    fn is_cut(&self, prim: u32, u: f32, v: f32) -> bool {
        let Some(&(mask, [t0, t1, t2])) = self
            .slot
            .get(prim as usize)
            .and_then(|&k| self.masked.get(k as usize))
        else {
            return false;
        };
        let uv = t0 * (1.0 - u - v) + t1 * u + t2 * v;
        self.masks[mask as usize].value(uv) < THRESHOLD
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Alpha decides where the image has it (white RGBA, its second texel transparent); otherwise the
    /// grey value as stored: 140/255 = 0.55 stays (sRGB-decoded, 0.26, it would be cut), 100/255 cuts.
    #[test]
    fn masks_read_alpha_else_grey_as_stored() {
        let d = tempfile::tempdir().unwrap();
        let rgba = d.path().join("a.png");
        // 2×1: opaque white, then transparent white.
        crate::io::oiio::write(
            &rgba,
            2,
            1,
            &["R", "G", "B", "A"],
            crate::io::oiio::Pixels::U8(&[255, 255, 255, 255, 255, 255, 255, 0]),
        )
        .unwrap();
        let m = Mask::load(&rgba).unwrap();
        assert_eq!(m.values, vec![1.0, 0.0]);
        assert!(!m.plain_grey);
        let grey = d.path().join("g.ppm");
        std::fs::write(&grey, "P3\n2 1\n255\n140 140 140 100 100 100\n").unwrap();
        let m = Mask::load(&grey).unwrap();
        assert!((m.values[0] - 140.0 / 255.0).abs() < 1e-6, "{:?}", m.values);
        assert!(m.plain_grey);
        let colour = d.path().join("c.ppm");
        std::fs::write(&colour, "P3\n1 1\n255\n255 0 0\n").unwrap();
        assert!(!Mask::load(&colour).unwrap().plain_grey);
        let c = Cutouts::new(
            vec![std::sync::Arc::new(m)],
            3,
            [(
                1,
                0,
                [
                    Vec2::new(0.25, 0.5),
                    Vec2::new(0.25, 0.5),
                    Vec2::new(0.75, 0.5),
                ],
            )],
        )
        .unwrap();
        // Triangle 1 at its first corner reads texel 0 (kept), at its third texel 1 (cut); triangles
        // without a mask are never cut.
        assert!(!c.is_cut(1, 0.0, 0.0));
        assert!(c.is_cut(1, 0.0, 1.0));
        assert!(!c.is_cut(0, 0.0, 1.0) && !c.is_cut(2, 0.0, 1.0));
        assert!(Cutouts::new(Vec::new(), 3, []).is_none());
    }
}
