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
    /// Each level half the one before in each direction ([`shrink`]), the first half the texture.
    mips: Vec<Level>,
}

/// One level of a texture's mip pyramid.
struct Level {
    width: u32,
    height: u32,
    texels: Vec<Vec3>,
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
    let wanted = direct
        .file_name()
        .ok_or_else(not_found)?
        .to_string_lossy()
        .to_lowercase();
    let same_name = |p: &PathBuf| {
        p.file_name()
            .is_some_and(|f| f.to_string_lossy().to_lowercase() == wanted)
    };
    let candidates: Vec<PathBuf> = std::fs::read_dir(&parent)
        .map_err(|_| not_found())?
        .flatten()
        .map(|e| e.path())
        .filter(same_name)
        .collect();
    match candidates.iter().find(|p| p.is_file()) {
        Some(p) => Ok(p.clone()),
        None if direct.exists() || !candidates.is_empty() => Err("is not a regular file".into()),
        None => Err(not_found()),
    }
}

/// An image's pixels as floats, its size in the header checked against [`MAX_TEXTURE_PIXELS`] and the
/// memory decoding takes against the address space left (images loaded before it hold theirs) before
/// any pixel is decoded.
pub(crate) fn decode(path: &Path) -> Result<oiio::ImageData, String> {
    let (width, height, channels) = oiio::image_size(path)?;
    let n_pixels = width as u64 * height as u64;
    if n_pixels > MAX_TEXTURE_PIXELS || channels == 0 {
        return Err(format!(
            "{width}×{height} pixels × {channels} channels: more than the limit of {MAX_TEXTURE_PIXELS} pixels (8192×8192)"
        ));
    }
    // Decoding holds the library's floats and their copy, then the copy, the texels and their
    // mip levels (a third as many again).
    let floats = 4 * channels.min(64) as u64;
    let peak = n_pixels * (2 * floats).max(floats + 16);
    crate::memory::check_address_space(
        &format!("decoding its {width}×{height} pixels × {channels} channels"),
        peak,
    )?;
    let img = oiio::read(path)?;
    if img.channels == 0 {
        return Err("image has no channels".into());
    }
    Ok(img)
}

impl Texture {
    /// Loads an 8-bit (sRGB-encoded) or float (linear) image, checked as [`decode`] checks it.
    /// Grey and grey+alpha images are grey (alpha is ignored).
    pub fn load(path: &Path) -> Result<Texture, String> {
        let img = decode(path)?;
        let is_float = matches!(
            path.extension()
                .and_then(|e| e.to_str())
                .map(str::to_lowercase)
                .as_deref(),
            Some("exr" | "hdr")
        );
        let nc = img.channels as usize;
        let texels = img
            .data
            .chunks_exact(nc)
            .map(|px| {
                let v = if nc >= 3 {
                    Vec3::new(px[0], px[1], px[2])
                } else {
                    Vec3::splat(px[0])
                };
                if is_float {
                    v
                } else {
                    Vec3::new(
                        srgb_to_linear(v.x),
                        srgb_to_linear(v.y),
                        srgb_to_linear(v.z),
                    )
                }
            })
            .collect::<Vec<Vec3>>();
        // A texture is an albedo, held to [0, 1] as `Kd` is: a float texel of 5 made a wall 12×
        // brighter without a word.
        let width = img.width.max(1) as usize;
        if let Some((i, t)) = texels
            .iter()
            .enumerate()
            .find(|(_, t)| !(t.min_element() >= 0.0 && t.max_element() <= 1.0))
        {
            return Err(format!(
                "texel ({}, {}) is ({}, {}, {}): an albedo must be in [0, 1]",
                i % width,
                i / width,
                t.x,
                t.y,
                t.z
            ));
        }
        Ok(Texture::new(
            path.to_path_buf(),
            img.width,
            img.height,
            texels,
        ))
    }

    /// A texture of `width` × `height` linear texels (top row first) and its mip pyramid.
    pub fn new(path: PathBuf, width: u32, height: u32, texels: Vec<Vec3>) -> Texture {
        let mut mips: Vec<Level> = Vec::new();
        let (mut w, mut h) = (width, height);
        while w > 1 || h > 1 {
            let below = mips.last().map_or(&texels[..], |l| &l.texels[..]);
            let level = shrink(below, w, h);
            (w, h) = (level.width, level.height);
            mips.push(level);
        }
        Texture {
            path,
            width,
            height,
            texels,
            mips,
        }
    }

    /// The texture averaged over about `width` texels around `uv` (trilinear between the mip levels
    /// whose texels are nearest that size); bilinear when `width` is a texel or less.
    pub fn lookup_filtered(&self, uv: Vec2, width: f32) -> Vec3 {
        let lod = width.max(1.0).log2();
        if !(lod > 0.0) || self.mips.is_empty() {
            return self.lookup(uv);
        }
        let lod = lod.min(self.mips.len() as f32);
        let (k, f) = (lod.floor() as usize, lod.fract());
        let level = |k: usize| -> Vec3 {
            match k {
                0 => self.lookup(uv),
                _ => {
                    let l = &self.mips[(k - 1).min(self.mips.len() - 1)];
                    bilinear(&l.texels, l.width as usize, l.height as usize, uv)
                }
            }
        };
        if f == 0.0 {
            level(k)
        } else {
            level(k) * (1.0 - f) + level(k + 1) * f
        }
    }

    /// Bilinear lookup; OBJ's v runs upward, image rows downward.
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        bilinear(&self.texels, self.width as usize, self.height as usize, uv)
    }
}

/// `texels` (`w` × `h`) averaged down to ⌈w/2⌉ × ⌈h/2⌉. Each texel of the result covers w / ⌈w/2⌉
/// texels across and h / ⌈h/2⌉ down, each weighted by how much of it it covers: with an odd size no
/// texel counts twice, and the level's mean is the texture's.
fn shrink(texels: &[Vec3], w: u32, h: u32) -> Level {
    let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
    let (across, down) = (cover(w, nw), cover(h, nh));
    let (w, nw) = (w as usize, nw as usize);
    let mut rows = vec![Vec3::ZERO; nw * h as usize];
    for y in 0..h as usize {
        for (i, taps) in across.iter().enumerate() {
            rows[y * nw + i] = taps.iter().map(|&(j, f)| texels[y * w + j] * f).sum();
        }
    }
    let mut out = vec![Vec3::ZERO; nw * nh as usize];
    for (k, taps) in down.iter().enumerate() {
        for x in 0..nw {
            out[k * nw + x] = taps.iter().map(|&(j, f)| rows[j * nw + x] * f).sum();
        }
    }
    Level {
        width: nw as u32,
        height: nh,
        texels: out,
    }
}

/// For each of `m` equal cells over `n` texels in a row: the texels it overlaps, each with the part of
/// the cell it fills (summing to 1).
fn cover(n: u32, m: u32) -> Vec<Vec<(usize, f32)>> {
    let span = n as f64 / m as f64;
    (0..m)
        .map(|i| {
            let (a, b) = (i as f64 * span, (i + 1) as f64 * span);
            (a.floor() as usize..(b.ceil() as usize).min(n as usize))
                .map(|j| (j, ((b.min(j as f64 + 1.0) - a.max(j as f64)) / span) as f32))
                .filter(|&(_, f)| f > 0.0)
                .collect()
        })
        .collect()
}

/// Bilinear lookup in `texels` (`w` × `h`, top row first, wrapping); OBJ's v runs upward, image rows
/// downward. Colours and masks (one value a texel) alike.
pub(crate) fn bilinear<T>(texels: &[T], w: usize, h: usize, uv: Vec2) -> T
where
    T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    // x ∈ [−0.5, w − 0.5] (w − 0.5 at most, or w if the wrap rounds up to 1): the four texels are
    // wrapped by a comparison each, not by an integer division each.
    let x = wrap_unit(uv.x) * w as f32 - 0.5;
    let y = (1.0 - wrap_unit(uv.y)) * h as f32 - 0.5;
    if !(x >= -0.5 && x <= w as f32 && y >= -0.5 && y <= h as f32) {
        return texels[0];
    }
    // x + 1 > 0, so truncation is floor.
    let (xi, yi) = ((x + 1.0) as usize, (y + 1.0) as usize);
    let (fx, fy) = (x + 1.0 - xi as f32, y + 1.0 - yi as f32);
    let (i0, i1, j0, j1) = (
        wrap(xi, w),
        wrap(xi + 1, w),
        wrap(yi, h) * w,
        wrap(yi + 1, h) * w,
    );
    let t = texels;
    (t[j0 + i0] * (1.0 - fx) + t[j0 + i1] * fx) * (1.0 - fy)
        + (t[j1 + i0] * (1.0 - fx) + t[j1 + i1] * fx) * fy
}

/// `u` wrapped into [0, 1] as `u.rem_euclid(1.0)` wraps it, to the bit, without its call to `fmodf`:
/// `u − ⌊u⌋` is exact where `u % 1` is, and for negative `u` both round the same sum `u + ⌈−u⌉`.
#[inline]
fn wrap_unit(u: f32) -> f32 {
    u - u.floor()
}

/// Texel index `i − 1` wrapped into `0..n`, for `i` in `0..=n + 2`.
#[inline]
fn wrap(i: usize, n: usize) -> usize {
    match i {
        0 => n - 1,
        i if i <= n => i - 1,
        i => (i - 1 - n) % n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    /// The bilinear lookup with wrapping by `rem_euclid`, as it was written first.
    fn by_division(t: &Texture, uv: Vec2) -> Vec3 {
        let (w, h) = (t.width as i64, t.height as i64);
        let x = uv.x.rem_euclid(1.0) * w as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let at = |i: i64, j: i64| t.texels[(j.rem_euclid(h) * w + i.rem_euclid(w)) as usize];
        let (i, j) = (x0 as i64, y0 as i64);
        (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
            + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy
    }

    #[test]
    fn the_wrap_is_rem_euclid_to_the_bit() {
        let mut rng = Rng::new(3);
        let edges = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            1e-30,
            -1e-30,
            -1e-8,
            1e-8,
            3.0e7,
            -3.0e7,
            8388607.5,
            -8388607.5,
            0.99999994,
            -0.99999994,
            f32::MAX,
            f32::MIN,
        ];
        let random =
            (0..100_000).map(|_| (rng.uniform() - 0.5) * 10f32.powi((rng.uniform() * 8.0) as i32));
        for u in edges.into_iter().chain(random) {
            let (a, b) = (wrap_unit(u), u.rem_euclid(1.0));
            // Zero's sign aside (it reads the same texel), the same value.
            assert!(a == b, "{u}: {a} against {b}");
        }
    }

    #[test]
    fn a_filtered_lookup_averages_over_its_width() {
        // A 64² checker of single texels: read at a point, black or white; over 4 texels, grey.
        let texels = (0..64 * 64)
            .map(|i| Vec3::splat(((i % 64 + i / 64) % 2) as f32))
            .collect();
        let t = Texture::new(PathBuf::from("checker"), 64, 64, texels);
        let uv = Vec2::new(10.5 / 64.0, 1.0 - 20.5 / 64.0);
        assert_eq!(t.lookup_filtered(uv, 1.0), t.lookup(uv));
        assert_eq!(t.lookup(uv), Vec3::ZERO);
        for width in [4.0, 6.0, 64.0, 1e6] {
            let v = t.lookup_filtered(uv, width);
            assert!(
                (v - Vec3::splat(0.5)).abs().max_element() < 1e-6,
                "{width}: {v}"
            );
        }
        // Odd sizes: every level keeps the texture's mean (a 3×1 texture of 0, 0, 1 reads 1/3 from
        // afar, not what its last texel counted twice would give).
        let t = Texture::new(
            PathBuf::from("odd"),
            3,
            1,
            vec![Vec3::ZERO, Vec3::ZERO, Vec3::ONE],
        );
        assert!((t.lookup_filtered(Vec2::new(0.5, 0.5), 1e6).x - 1.0 / 3.0).abs() < 1e-6);
        let mut rng = Rng::new(9);
        let (w, h) = (100u32, 37u32);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|_| Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()))
            .collect();
        let mean = texels.iter().sum::<Vec3>() / (w * h) as f32;
        let t = Texture::new(PathBuf::from("random"), w, h, texels);
        for l in &t.mips {
            let m = l.texels.iter().sum::<Vec3>() / (l.width * l.height) as f32;
            assert!(
                (m - mean).abs().max_element() < 1e-5,
                "{}×{}: {m} against {mean}",
                l.width,
                l.height
            );
        }
        assert_eq!(t.mips.last().map(|l| (l.width, l.height)), Some((1, 1)));
    }

    #[test]
    fn lookup_wraps_like_the_division_form() {
        let mut rng = Rng::new(3);
        for (w, h) in [(1, 1), (1, 3), (2, 2), (3, 7), (16, 5)] {
            let texels = (0..w * h)
                .map(|i| Vec3::new(i as f32, (i * i) as f32, 1.0))
                .collect();
            let t = Texture::new(PathBuf::new(), w, h, texels);
            let edges = [0.0, 1.0, -1e-9, 1.0 - 1e-9, 0.5 / w as f32, -3.0, 7.25];
            let uvs = edges
                .iter()
                .flat_map(|&u| edges.iter().map(move |&v| Vec2::new(u, v)));
            for uv in uvs.chain(
                (0..2000).map(|_| Vec2::new(rng.uniform() * 8.0 - 4.0, rng.uniform() * 8.0 - 4.0)),
            ) {
                let (a, b) = (t.lookup(uv), by_division(&t, uv));
                assert!(
                    (a - b).abs().max_element() <= 1e-3 * (1.0 + b.abs().max_element()),
                    "{w}×{h} at {uv}: {a} vs {b}"
                );
            }
            assert!(t.lookup(Vec2::new(f32::NAN, 0.5)).is_finite());
        }
    }
}
