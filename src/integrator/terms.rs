//! The five terms of Jensen's split, each its own EXR layer; beauty is their sum.

use glam::Vec3;

pub const TERM_NAMES: [&str; 5] = ["emission", "direct", "specular", "caustic", "indirect"];

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Terms {
    pub emission: Vec3,
    pub direct: Vec3,
    pub specular: Vec3,
    pub caustic: Vec3,
    pub indirect: Vec3,
}

impl Terms {
    pub fn sum(&self) -> Vec3 {
        self.emission + self.direct + self.specular + self.caustic + self.indirect
    }

    pub fn to_layers(self) -> Vec<Vec3> {
        vec![self.emission, self.direct, self.specular, self.caustic, self.indirect]
    }
}
