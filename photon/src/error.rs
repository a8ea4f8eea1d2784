//! Errors of the photon pass: FLANN failures, a photon pass that stores nothing, and photon-map files.
#![forbid(unsafe_code)]

use std::path::PathBuf;

/// Everything that can go wrong in this crate.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("FLANN failed to {0}")]
    Flann(&'static str),
    #[error("{n_points} points exceed FLANN's C API limit (i32 row count)")]
    TooManyPoints { n_points: usize },
    #[error("point {index} has a non-finite coordinate")]
    NonFinitePoint { index: usize },
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    #[error(
        "no photon was stored after {n_paths_emitted} paths: light reaches no diffuse surface"
    )]
    NothingStored { n_paths_emitted: u64 },
    #[error("cancelled")]
    Cancelled,
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("not a regular file")]
    NotRegularFile { path: PathBuf },
    #[error("{bytes} bytes, larger than the limit for a photon-map file ({limit} bytes)")]
    TooLarge {
        path: PathBuf,
        bytes: u64,
        limit: u64,
    },
    #[error("not a photon-map file (bad magic)")]
    BadMagic,
    #[error("photon-map file version {found}, this build reads version {expected}")]
    UnsupportedVersion { found: u32, expected: u32 },
    #[error("photon-map file is truncated or has trailing bytes: header implies {expected} bytes, file has {actual}")]
    BadLength { expected: u64, actual: u64 },
    #[error("photon-map file checksum mismatch (file damaged)")]
    Checksum,
    #[error("photon-map file was made for another scene (fingerprint {found:#018x}, expected {expected:#018x})")]
    SceneMismatch { found: u64, expected: u64 },
    #[error("not enough memory to read the photon-map file ({bytes} bytes)")]
    OutOfMemory { bytes: u64 },
    #[error("photon-map file is corrupt: {0}")]
    Corrupt(String),
}

pub type Result<T> = std::result::Result<T, Error>;
