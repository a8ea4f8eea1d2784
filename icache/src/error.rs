//! The crate's error type: invalid parameters and unreadable cache files.
#![forbid(unsafe_code)]

/// Everything that can go wrong in `icache`.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("invalid cache parameters: {0}")]
    InvalidParams(String),
    #[error("invalid cache bounds: {0}")]
    InvalidBounds(String),
    #[error("i/o error on cache file: {0}")]
    Io(#[from] std::io::Error),
    #[error("cache file is not a regular file")]
    NotRegularFile,
    #[error("cache file has {bytes} bytes, more than the limit of {limit}")]
    TooLarge { bytes: u64, limit: u64 },
    #[error("not an irradiance cache file (bad magic)")]
    BadMagic,
    #[error("unsupported cache file version {found} (this build reads {supported})")]
    UnsupportedVersion { found: u32, supported: u32 },
    #[error("cache file was made for another scene (fingerprint {found:#018x}, expected {expected:#018x})")]
    FingerprintMismatch { expected: u64, found: u64 },
    #[error("cache file truncated or padded: {what} needs {needed} bytes, file has {available}")]
    Truncated {
        what: &'static str,
        needed: u64,
        available: u64,
    },
    #[error("cache file checksum mismatch (stored {stored:#018x}, computed {computed:#018x})")]
    ChecksumMismatch { stored: u64, computed: u64 },
    #[error("not enough memory to read the cache file ({bytes} bytes)")]
    OutOfMemory { bytes: u64 },
    #[error("cache file record {index} is invalid: {reason}")]
    CorruptRecord { index: u64, reason: &'static str },
}

pub type Result<T> = std::result::Result<T, Error>;
