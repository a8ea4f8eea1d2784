//! Ray-tracing acceleration (Embree 3).
pub mod embree;
mod embree_sys;
