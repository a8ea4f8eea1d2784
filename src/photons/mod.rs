//! The photon maps as the render uses them: settings with scene-derived defaults, tracing the maps, and
//! the services built over them that the integrators read — the irradiance atlas and its glossy
//! texels, the disc coverage of estimates, the volume lattice and the media radiance cache's estimates.

pub mod atlas;
pub mod coverage;
mod glossy_texels;
mod lookup;
pub mod media_fill;
mod photon_scene;
mod settings;
pub(crate) mod texel_track;
pub mod volume_lattice;

pub use glossy_texels::TEXEL_BYTES as GLOSSY_TEXEL_BYTES;
pub use lookup::{atlas_k, GatherHit, GatherLobe, PhotonData};
pub use settings::{PhotonSettings, DEFAULT_PHOTONS_PER_TEXEL};
