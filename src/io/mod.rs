//! Files in and out: OpenImageIO shim, atomic writes, image outputs.
pub(crate) mod atomic;
pub mod oiio;
pub mod output;
