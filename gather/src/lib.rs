//! Final gathering for the irradiance cache: stratified cosine-weighted hemisphere sampling
//! (Ward & Heckbert 1992) returning irradiance, rotational and translational gradients, hit-distance
//! statistics and the dominant incoming direction.
//!
//! The crate knows neither Embree nor materials: the root crate passes a closure that traces one
//! gather ray and reports its radiance and hit distance.
#![forbid(unsafe_code)]
#![warn(unreachable_pub)]

mod gather;
mod gradient;
mod strata;

pub use gather::{gather, gather_batch_round, GatherParams, GatherRay, GatherResult};
pub use strata::DEFAULT_RAYS;
