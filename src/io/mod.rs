//! Files in and out: OpenImageIO shim, atomic writes, image outputs.
pub(crate) mod atomic;
pub(crate) mod oiio;
pub mod output;
