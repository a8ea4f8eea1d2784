//! The terms of Jensen's split, each its own EXR layer; beauty is their sum. Scenes with participating
//! media add two: light scattered once in a medium toward the camera (ray-marched with light samples)
//! and light scattered more than once (the volume photon map).

use glam::Vec3;

pub const TERM_NAMES: [&str; 5] = ["emission", "direct", "specular", "caustic", "indirect"];
pub const MEDIA_TERM_NAMES: [&str; 7] = [
    "emission",
    "direct",
    "specular",
    "caustic",
    "indirect",
    "media_single",
    "media_multiple",
];

/// The layer names of a render with (or without) media.
pub fn term_names(media: bool) -> &'static [&'static str] {
    if media {
        &MEDIA_TERM_NAMES
    } else {
        &TERM_NAMES
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    pub emission: Vec3,
    pub direct: Vec3,
    pub specular: Vec3,
    pub caustic: Vec3,
    pub indirect: Vec3,
    pub media_single: Vec3,
    pub media_multiple: Vec3,
}

impl Terms {
    pub fn sum(&self) -> Vec3 {
        let surface = self.emission + self.direct + self.specular + self.caustic + self.indirect;
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
            media_single: self.media_single * tr,
            media_multiple: self.media_multiple * tr,
        }
    }

    pub fn to_layers(self, media: bool) -> LayerValues {
        let values = [
            self.emission,
            self.direct,
            self.specular,
            self.caustic,
            self.indirect,
            self.media_single,
            self.media_multiple,
        ];
        LayerValues {
            values,
            len: if media { 7 } else { 5 },
        }
    }
}

/// One sample's value per image layer, without an allocation: `len` of them (the photon-map methods'
/// five terms, seven with media; `path`'s one radiance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerValues {
    values: [Vec3; 7],
    len: usize,
}

impl LayerValues {
    /// A single layer (`path`).
    pub fn one(v: Vec3) -> LayerValues {
        let mut values = [Vec3::ZERO; 7];
        values[0] = v;
        LayerValues { values, len: 1 }
    }

    pub fn as_slice(&self) -> &[Vec3] {
        &self.values[..self.len]
    }
}

impl IntoIterator for LayerValues {
    type Item = Vec3;
    type IntoIter = std::iter::Take<std::array::IntoIter<Vec3, 7>>;

    fn into_iter(self) -> Self::IntoIter {
        self.values.into_iter().take(self.len)
    }
}
