//! The terms of Jensen's split, each its own EXR layer; beauty is their sum. Scenes with glossy
//! materials add one (the light their lobes reflect); scenes with participating media add two: light scattered once in a medium toward the camera (ray-marched with light samples)
//! and light scattered more than once (the volume photon map).

use glam::Vec3;

/// Which optional layers a render has: `glossy` in scenes with glossy materials, the media's two in
/// scenes with participating media.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub glossy: bool,
    pub media: bool,
}

/// Where the soft indirect light is among the layers of every layout.
pub const INDIRECT_LAYER: usize = 4;

impl Layout {
    pub fn of(scene: &crate::scene::Scene) -> Layout {
        Layout {
            glossy: scene.has_glossy(),
            media: scene.media.is_some(),
        }
    }

    /// The layer names, in the order of [`Terms::to_layers`].
    pub fn names(self) -> Vec<&'static str> {
        let mut names = vec!["emission", "direct", "specular", "caustic", "indirect"];
        debug_assert_eq!(names[INDIRECT_LAYER], "indirect");
        if self.glossy {
            names.push("glossy");
        }
        if self.media {
            names.extend(["media_single", "media_multiple"]);
        }
        names
    }

    /// How many layers there are.
    pub fn count(self) -> usize {
        5 + self.glossy as usize + 2 * self.media as usize
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    pub emission: Vec3,
    pub direct: Vec3,
    pub specular: Vec3,
    pub caustic: Vec3,
    pub indirect: Vec3,
    /// Light the glossy lobes of visible surfaces reflect, other than what light sampling gives to
    /// `direct`.
    pub glossy: Vec3,
    pub media_single: Vec3,
    pub media_multiple: Vec3,
}

impl Terms {
    pub fn sum(&self) -> Vec3 {
        let surface = self.emission
            + self.direct
            + self.specular
            + self.caustic
            + self.indirect
            + self.glossy;
        if self.media_single == Vec3::ZERO && self.media_multiple == Vec3::ZERO {
            surface
        } else {
            surface + self.media_single + self.media_multiple
        }
    }

    /// Every term times `tr` (the transmittance in front of the surface they leave).
    pub fn scaled(self, tr: Vec3) -> Terms {
        Terms {
            emission: self.emission * tr,
            direct: self.direct * tr,
            specular: self.specular * tr,
            caustic: self.caustic * tr,
            indirect: self.indirect * tr,
            glossy: self.glossy * tr,
            media_single: self.media_single * tr,
            media_multiple: self.media_multiple * tr,
        }
    }

    pub fn to_layers(self, layout: Layout) -> LayerValues {
        let mut values = [Vec3::ZERO; MAX_LAYERS];
        values[..5].copy_from_slice(&[
            self.emission,
            self.direct,
            self.specular,
            self.caustic,
            self.indirect,
        ]);
        let mut len = 5;
        if layout.glossy {
            values[len] = self.glossy;
            len += 1;
        }
        if layout.media {
            values[len] = self.media_single;
            values[len + 1] = self.media_multiple;
            len += 2;
        }
        LayerValues { values, len }
    }
}

/// Layers at most (every optional one present).
pub(crate) const MAX_LAYERS: usize = 8;

/// One sample's value per image layer, without an allocation: `len` of them (the photon-map methods'
/// terms, see [`Layout`]; `path`'s one radiance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerValues {
    values: [Vec3; MAX_LAYERS],
    len: usize,
}

impl LayerValues {
    /// A single layer (`path`).
    pub fn one(v: Vec3) -> LayerValues {
        let mut values = [Vec3::ZERO; MAX_LAYERS];
        values[0] = v;
        LayerValues { values, len: 1 }
    }

    pub fn as_slice(&self) -> &[Vec3] {
        &self.values[..self.len]
    }
}

impl IntoIterator for LayerValues {
    type Item = Vec3;
    type IntoIter = std::iter::Take<std::array::IntoIter<Vec3, MAX_LAYERS>>;

    fn into_iter(self) -> Self::IntoIter {
        self.values.into_iter().take(self.len)
    }
}
