//! pmrender: a two-pass photon-mapping renderer whose final gather is cached in an irradiance cache.
//!
//! The root crate loads scenes, wraps Embree, holds materials, lights and the camera, combines the terms
//! of Jensen's split, and writes images and statistics. `photon`, `gather` and `icache` are its passes.

pub mod accel;
pub mod camera;
pub mod chart;
mod chi2;
pub mod converge;
pub mod counters;
pub mod distribution;
pub mod error;
pub mod export;
pub mod geometry;
pub mod integrator;
pub mod io;
pub mod light;
pub mod material;
pub mod medium;
pub mod photons;
pub mod progress;
pub mod render;
pub mod scene;
pub mod signal;
pub mod stats;
pub mod texture;
pub mod warp;
