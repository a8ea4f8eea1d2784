//! Files in and out: OpenImageIO shim, atomic writes, image outputs.
pub mod atomic;
pub mod oiio;
pub mod output;
