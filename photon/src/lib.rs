//! Photon pass: emission and tracing of photons, global and caustic photon maps over FLANN kd-trees,
//! density estimates and precomputed irradiance.
pub mod sampling;
