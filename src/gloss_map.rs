//! A glossy material's maps (MTL `map_Ks`, `map_Ns`): per-texel scales of its lobe's colour and
//! exponent.
//!
//! `map_Ks` is a colour texture (8-bit sRGB-decoded, as `map_Kd`): the lobe's colour is `Ks` times its
//! texel, so Kd + Ks ≤ 1 still holds. `map_Ns` is data, read as stored (its grey value): the exponent
//! is `Ns` times its value. A material whose exponent varies so is left out of the radiance cache,
//! which holds one lobe per material: at the points the camera sees, its lobe is sampled with the
//! texel's exponent. Past a glossy bounce or at a final gather's end, where the glossy texels of the
//! photon map answer, the lobe keeps the material's own `Ns`.

use glam::{Vec2, Vec3};

use crate::cutout::Mask;
use crate::material::Bsdf;
use crate::scene::limits::MAX_EXPONENT;
use crate::texture::Texture;

pub struct GlossMaps {
    pub specular: Option<std::sync::Arc<Texture>>,
    pub exponent: Option<std::sync::Arc<Mask>>,
}

impl GlossMaps {
    /// `bsdf` (a glossy one; others are returned as they are) with its lobe scaled at `uv`.
    pub fn apply(&self, bsdf: &Bsdf, uv: Vec2) -> Bsdf {
        let mut b = bsdf.clone();
        if let Bsdf::Glossy {
            specular, exponent, ..
        } = &mut b
        {
            if let Some(t) = &self.specular {
                *specular *= t.lookup(uv).clamp(Vec3::ZERO, Vec3::ONE);
            }
            if let Some(m) = &self.exponent {
                *exponent = (*exponent * m.value(uv)).clamp(0.0, MAX_EXPONENT);
            }
        }
        b
    }
}
