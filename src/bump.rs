//! Bump and normal maps (MTL `bump`, `map_bump`, `map_Bump`, `norm`): a shading normal turned per
//! texel.
//!
//! A **height map** displaces the surface along its shading normal by `scale · h(u, v)` world units
//! (`scale` is `-bm`, 1 when absent), as pbrt's and Mitsuba 3's `bumpmap` read it: the bumped normal is
//! that of the displaced surface, ∂p/∂u + n ∂d/∂u crossed with ∂p/∂v + n ∂d/∂v, the height's derivatives
//! taken across one texel of the bilinear lookup. A **normal map** holds tangent-space normals encoded
//! as `2c − 1` per channel, read as stored (not sRGB-decoded), x along ∂p/∂u, y along ∂p/∂v (OpenGL's
//! and Blender's green up), z along the shading normal; `-bm` is its strength, as Blender's normal map
//! node has it: n ← normalize(n + strength (n_mapped − n)).
//!
//! Blender writes both under `map_Bump`, so the image decides: one that is grey (one or two channels,
//! or every texel's channels within 2/255 of each other) is a height map; a colour image whose texels
//! decode, nine in ten of them or more, to vectors of length 0.8–1.2 pointing to +z, with a mean z of
//! 0.5 or more, is a normal map (a flat one is (128, 128, 255), a height map's colours are seldom unit
//! vectors); any other colour image is a height map of its channels' mean. `norm` is always a normal
//! map and needs a colour image.
//!
//! A normal map's tangent is the one MikkTSpace gives the vertices ([`crate::tangents`]), interpolated
//! and made orthogonal to the interpolated shading normal, the bitangent `sign · n × t`; a height map
//! reads the triangle's own ∂p/∂u and ∂p/∂v (its slopes are per unit of u and v, as pbrt's and
//! Mitsuba's are).

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::cutout::Mask;
use crate::geometry::Geometry;
use crate::texture::{bilinear, decode};

/// Which MTL statement named the map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Statement {
    /// `bump`, `map_bump`, `map_Bump`: a height map or a normal map, as the image is.
    Bump,
    /// `norm`: a normal map.
    Norm,
}

pub enum BumpMap {
    Height {
        /// The file it was read from.
        path: PathBuf,
        heights: Mask,
        /// World units of displacement per unit of the map's value (`-bm`); `None` (no `-bm`): the
        /// map's full range is [`RELIEF_TEXELS`] of its texels' widths on the surface.
        scale: Option<f32>,
    },
    Normal {
        path: PathBuf,
        width: u32,
        height: u32,
        /// Decoded tangent-space vectors (2c − 1), top row first.
        texels: Vec<Vec3>,
        /// `-bm`: 0 leaves the normal as it is, 1 takes the map's.
        strength: f32,
    },
}

/// The relief of a height map whose statement gives no `-bm`, in widths of its texels on the surface:
/// a step over its whole range from one texel to the next tilts the normal by atan(RELIEF_TEXELS / 2).
/// Exporters write heights without a scale (Sibenik's and Sponza's MTLs give none), and one scene
/// unit per unit of value — the MTL reading that pbrt and Mitsuba take with a scale of 1 — makes
/// walls of a scene in metres slopes of hundreds: Sibenik rendered 38 % dark, Sponza 26 %. Relative to
/// the texels, the same asset has the same bumps at any scene scale.
pub const RELIEF_TEXELS: f32 = 1.0;

/// Channels within this of each other make a texel grey (8-bit rounding of a grey image's colours).
const GREY_TOLERANCE: f32 = 2.0 / 255.0;

impl BumpMap {
    /// Reads the map `statement` names from `path`, `bm` its `-bm` value.
    pub fn load(path: &Path, statement: Statement, bm: Option<f32>) -> Result<BumpMap, String> {
        if let Some(bm) = bm.filter(|b| !b.is_finite()) {
            return Err(format!("-bm {bm} is not a finite number"));
        }
        let img = decode(path)?;
        let nc = img.channels as usize;
        if let Some(i) = img.data.iter().position(|v| !v.is_finite()) {
            let w = img.width.max(1) as usize;
            let px = i / nc;
            return Err(format!(
                "texel ({}, {}) is not a finite number",
                px % w,
                px / w
            ));
        }
        let rgb: Vec<Vec3> = if nc >= 3 {
            img.data
                .chunks_exact(nc)
                .map(|px| Vec3::new(px[0], px[1], px[2]))
                .collect()
        } else {
            Vec::new()
        };
        let normal = match statement {
            Statement::Norm if rgb.is_empty() => {
                return Err("a normal map (norm) needs a colour image (RGB)".into())
            }
            Statement::Norm => true,
            Statement::Bump => !rgb.is_empty() && looks_like_normal_map(&rgb),
        };
        if normal {
            return Ok(BumpMap::Normal {
                path: path.to_path_buf(),
                width: img.width,
                height: img.height,
                texels: rgb.iter().map(|c| *c * 2.0 - Vec3::ONE).collect(),
                strength: bm.unwrap_or(1.0).max(0.0),
            });
        }
        Ok(BumpMap::Height {
            path: path.to_path_buf(),
            heights: Mask::load_values(path, false)?,
            scale: bm,
        })
    }

    /// The image file the map was read from.
    pub fn path(&self) -> &Path {
        match self {
            BumpMap::Height { path, .. } | BumpMap::Normal { path, .. } => path,
        }
    }

    /// The bumped shading normal at `uv` of a surface with unit shading normal `n` and texture
    /// derivatives `dpdu`, `dpdv`; a normal map's tangent frame is `tangent` (the vertices' interpolated
    /// tangent and the bitangent's sign) where given, else `dpdu` with the mapping's handedness. `n`
    /// itself where the result would not be a unit vector on `n`'s side.
    pub fn normal(
        &self,
        n: Vec3,
        (dpdu, dpdv): (Vec3, Vec3),
        tangent: Option<(Vec3, f32)>,
        uv: Vec2,
    ) -> Vec3 {
        let bumped = match self {
            BumpMap::Height { heights, scale, .. } => {
                let (w, h) = (heights.width.max(1) as f32, heights.height.max(1) as f32);
                let (du, dv) = (1.0 / w, 1.0 / h);
                let at = |d: Vec2| heights.value(uv + d);
                // World units per unit of value, along u and along v.
                let (su, sv) = match scale {
                    Some(s) => (*s, *s),
                    None => (
                        RELIEF_TEXELS * dpdu.length() * du,
                        RELIEF_TEXELS * dpdv.length() * dv,
                    ),
                };
                let grad_u = su * (at(Vec2::new(du, 0.0)) - at(Vec2::new(-du, 0.0))) / (2.0 * du);
                let grad_v = sv * (at(Vec2::new(0.0, dv)) - at(Vec2::new(0.0, -dv))) / (2.0 * dv);
                let su = dpdu + n * (grad_u - n.dot(dpdu));
                let sv = dpdv + n * (grad_v - n.dot(dpdv));
                let m = su.cross(sv).normalize_or_zero();
                if m.dot(n) < 0.0 {
                    -m
                } else {
                    m
                }
            }
            BumpMap::Normal {
                width,
                height,
                texels,
                strength,
                ..
            } => {
                let (along, sign) = tangent.unwrap_or_else(|| {
                    let right = n.cross(dpdu).dot(dpdv) >= 0.0;
                    (dpdu, if right { 1.0 } else { -1.0 })
                });
                // Gram–Schmidt: the tangent orthogonal to the interpolated normal.
                let t = (along - n * n.dot(along)).normalize_or_zero();
                if t == Vec3::ZERO {
                    return n;
                }
                let b = sign * n.cross(t);
                let c = bilinear(texels, *width as usize, *height as usize, uv);
                let mapped = (t * c.x + b * c.y + n * c.z).normalize_or_zero();
                if mapped == Vec3::ZERO {
                    return n;
                }
                (n + (mapped - n) * *strength).normalize_or_zero()
            }
        };
        if bumped.is_finite() && bumped.dot(n) > 0.0 {
            bumped
        } else {
            n
        }
    }

    /// A hash of the map's values and settings (for the scene's fingerprint).
    pub fn fingerprint(&self) -> u64 {
        let mut bytes = Vec::new();
        match self {
            BumpMap::Height { heights, scale, .. } => {
                bytes.push(0u8);
                bytes.extend(scale.map_or(f32::NAN, |s| s).to_bits().to_le_bytes());
                bytes.extend(heights.width.to_le_bytes());
                bytes.extend(heights.values.iter().flat_map(|v| v.to_le_bytes()));
            }
            BumpMap::Normal {
                width,
                texels,
                strength,
                ..
            } => {
                bytes.push(1u8);
                bytes.extend(strength.to_le_bytes());
                bytes.extend(width.to_le_bytes());
                bytes.extend(
                    texels
                        .iter()
                        .flat_map(|c| c.to_array())
                        .flat_map(|v| v.to_le_bytes()),
                );
            }
        }
        icache::file::fnv1a64(&bytes)
    }

    /// A normal map's texels with its strength applied, RGB as an image stores them (`(n + 1) / 2`,
    /// top row first): the map a reader without a strength (Mitsuba 3's `normalmap`) reads to turn
    /// normals as [`BumpMap::normal`] does — the same at texel centres; between them the blend comes
    /// before the bilinear lookup instead of after it. `None` for a height map.
    pub fn encoded_at_strength(&self) -> Option<Vec<f32>> {
        let BumpMap::Normal {
            texels, strength, ..
        } = self
        else {
            return None;
        };
        // Tangent space: the unbumped normal is +z, and `normal`'s fallbacks keep it.
        let turned = |c: Vec3| {
            let mapped = c.normalize_or_zero();
            if mapped == Vec3::ZERO {
                return Vec3::Z;
            }
            let n = (Vec3::Z + (mapped - Vec3::Z) * *strength).normalize_or_zero();
            if n.is_finite() && n.z > 0.0 {
                n
            } else {
                Vec3::Z
            }
        };
        Some(
            texels
                .iter()
                .flat_map(|&c| ((turned(c) + Vec3::ONE) * 0.5).to_array())
                .collect(),
        )
    }
}

/// Whether the colour texels `rgb` (as stored, in [0, 1]) are those of a tangent-space normal map
/// (see the module's header).
fn looks_like_normal_map(rgb: &[Vec3]) -> bool {
    let grey = rgb
        .iter()
        .all(|c| c.max_element() - c.min_element() <= GREY_TOLERANCE);
    if grey || rgb.is_empty() {
        return false;
    }
    let (mut n_unit, mut sum_z) = (0usize, 0.0f64);
    for c in rgb {
        let v = *c * 2.0 - Vec3::ONE;
        let len = v.length();
        n_unit += ((0.8..=1.2).contains(&len) && v.z > 0.0) as usize;
        sum_z += v.z as f64;
    }
    n_unit * 10 >= rgb.len() * 9 && sum_z >= 0.5 * rgb.len() as f64
}

/// ∂p/∂u and ∂p/∂v over triangle `tri` of `g` from its texture coordinates; `None` for a triangle
/// without them or whose mapping is degenerate (all three corners on one line in texture space).
pub fn uv_tangents(g: &Geometry, tri: u32) -> Option<(Vec3, Vec3)> {
    let t = g.triangles.get(tri as usize)?;
    if !t.has_uv {
        return None;
    }
    let [p0, p1, p2] = t.v.map(|i| g.positions[i as usize]);
    let [t0, t1, t2] = t.v.map(|i| g.uvs[i as usize]);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (d1, d2) = (t1 - t0, t2 - t0);
    let det = d1.x * d2.y - d2.x * d1.y;
    if !(det.abs() > 1e-20) {
        return None;
    }
    let dpdu = (e1 * d2.y - e2 * d1.y) / det;
    let dpdv = (e2 * d1.x - e1 * d2.x) / det;
    (dpdu.is_finite() && dpdv.is_finite()).then_some((dpdu, dpdv))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normal_map(c: Vec3, strength: f32) -> BumpMap {
        BumpMap::Normal {
            path: PathBuf::new(),
            width: 1,
            height: 1,
            texels: vec![c * 2.0 - Vec3::ONE],
            strength,
        }
    }

    /// A flat normal map leaves the normal; a tilted texel turns it toward ∂p/∂u (x) and ∂p/∂v (y),
    /// and strength 0 leaves it.
    #[test]
    fn normal_maps_turn_the_normal_in_the_uv_frame() {
        let (n, dpdu, dpdv) = (Vec3::Y, Vec3::X * 2.0, -Vec3::Z * 3.0);
        let flat = normal_map(Vec3::new(0.5, 0.5, 1.0), 1.0);
        assert!((flat.normal(n, (dpdu, dpdv), None, Vec2::splat(0.3)) - n).length() < 1e-6);
        let (s, c) = 25f32.to_radians().sin_cos();
        let tilted = normal_map(Vec3::new(0.5 + 0.5 * s, 0.5, 0.5 + 0.5 * c), 1.0);
        let m = tilted.normal(n, (dpdu, dpdv), None, Vec2::ZERO);
        assert!((m - Vec3::new(s, c, 0.0)).length() < 1e-5, "{m}");
        let m = normal_map(Vec3::new(0.5, 0.5 + 0.5 * s, 0.5 + 0.5 * c), 1.0).normal(
            n,
            (dpdu, dpdv),
            None,
            Vec2::ZERO,
        );
        assert!((m - Vec3::new(0.0, c, -s)).length() < 1e-5, "{m}");
        let none = normal_map(Vec3::new(0.5 + 0.5 * s, 0.5, 0.5 + 0.5 * c), 0.0);
        assert!((none.normal(n, (dpdu, dpdv), None, Vec2::ZERO) - n).length() < 1e-6);
        // A texel that decodes to nothing, or below the surface, leaves the normal.
        let zero = normal_map(Vec3::splat(0.5), 1.0);
        assert_eq!(zero.normal(n, (dpdu, dpdv), None, Vec2::ZERO), n);
        let under = normal_map(Vec3::new(0.5, 0.5, 0.0), 1.0);
        assert_eq!(under.normal(n, (dpdu, dpdv), None, Vec2::ZERO), n);
    }

    /// The texels `encoded_at_strength` bakes, decoded and normalized (as Mitsuba's `normalmap` reads
    /// them), are the normals `normal` gives at their centres; strength 0 bakes a flat map.
    #[test]
    fn baked_strength_matches_the_blend_at_texel_centres() {
        let texels = vec![Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.3, 0.5, 0.6)];
        let map = |strength| BumpMap::Normal {
            path: PathBuf::new(),
            width: 2,
            height: 1,
            texels: texels.clone(),
            strength,
        };
        let half = map(0.5);
        let baked = half.encoded_at_strength().unwrap();
        for (i, c) in baked.chunks_exact(3).enumerate() {
            let read = (Vec3::from_slice(c) * 2.0 - Vec3::ONE).normalize();
            let uv = Vec2::new((i as f32 + 0.5) / 2.0, 0.5);
            let ours = half.normal(Vec3::Z, (Vec3::X, Vec3::Y), None, uv);
            assert!((read - ours).length() < 1e-5, "texel {i}: {read} vs {ours}");
            assert!(
                (ours - Vec3::Z).length() > 0.1,
                "texel {i} not turned: {ours}"
            );
        }
        let flat = map(0.0).encoded_at_strength().unwrap();
        assert_eq!(flat, [0.5, 0.5, 1.0, 0.5, 0.5, 1.0]);
    }

    /// A height ramp h = u over a plane with ∂p/∂u = L x̂ and scale s has slope s/L along x.
    #[test]
    fn a_height_ramp_tilts_the_normal_by_its_slope() {
        let w = 64;
        let heights = Mask {
            width: w,
            height: 2,
            values: (0..2)
                .flat_map(|_| (0..w).map(|i| (i as f32 + 0.5) / w as f32))
                .collect(),
            plain_grey: true,
        };
        let map = BumpMap::Height {
            path: PathBuf::new(),
            heights,
            scale: Some(0.5),
        };
        let (n, dpdu, dpdv) = (Vec3::Y, Vec3::X * 2.0, -Vec3::Z * 2.0);
        let m = map.normal(n, (dpdu, dpdv), None, Vec2::new(0.5, 0.5));
        let slope = 0.5 / 2.0;
        let want = Vec3::new(-slope, 1.0, 0.0).normalize();
        assert!((m - want).length() < 1e-4, "{m} {want}");
    }

    #[test]
    fn grey_and_colour_images_are_told_apart() {
        let flat = [Vec3::new(0.5, 0.5, 1.0); 16];
        assert!(looks_like_normal_map(&flat));
        // Grey of any value, even one whose (2c − 1, …) is a unit vector (c ≈ 0.789).
        assert!(!looks_like_normal_map(&[Vec3::splat(0.789); 16]));
        // A colour texture is no normal map.
        let colours: Vec<Vec3> = (0..16)
            .map(|i| Vec3::new(i as f32 / 15.0, 0.3, 0.8 - i as f32 / 30.0))
            .collect();
        assert!(!looks_like_normal_map(&colours));
    }
}
