//! The binary file container of photon-map and cache files.
//!
//! Layout, little-endian: an 8-byte magic, a u32 version, the format's own header and body, then an
//! FNV-1a 64 checksum of the bytes from [`Format::checksum_from`] up to it. The checksum catches damage;
//! a parser still validates every value it reads (a file edited with its checksum recomputed must be
//! refused too), reading fields through [`Reader`] after checking the length the header implies, so
//! that a bad file is an error, never a panic or a huge allocation.
//!
//! Files are read only when regular (opening a FIFO blocks, a device may never end) and at most the
//! format's [`Format::max_file_bytes`] long.
#![forbid(unsafe_code)]

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::path::Path;

use glam::Vec3;

/// Length of the magic that starts a file.
pub const MAGIC_BYTES: usize = 8;
/// Length of the magic and the version after it.
pub const PREFIX_BYTES: usize = MAGIC_BYTES + 4;
/// Length of the checksum that ends a file.
pub const CHECKSUM_BYTES: usize = 8;

/// A binary file format: what starts its files, what its checksum covers and how large a file is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Format {
    pub magic: [u8; MAGIC_BYTES],
    /// The first byte the checksum covers: 0 (the magic too) or [`MAGIC_BYTES`] (from the version on).
    pub checksum_from: usize,
    /// Largest file [`open`](Self::open) and [`read`](Self::read) accept.
    pub max_file_bytes: u64,
}

/// Why a file's first bytes are not the magic and a version.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrefixError {
    /// The first [`MAGIC_BYTES`] bytes are another format's.
    BadMagic,
    /// Fewer than [`PREFIX_BYTES`] bytes, the magic ones (if any) this format's.
    Truncated,
}

/// Why a file was not opened or read.
#[derive(Debug)]
pub enum OpenError {
    Io(io::Error),
    /// A directory, FIFO, device or socket.
    NotRegularFile,
    /// Larger than [`Format::max_file_bytes`].
    TooLarge {
        bytes: u64,
        limit: u64,
    },
    /// The checksum does not match (streamed from the disk, before the file is held in memory).
    Checksum(ChecksumMismatch),
    /// No memory for the file's `bytes`: the allocation failed and was not retried.
    OutOfMemory {
        bytes: u64,
    },
}

impl From<io::Error> for OpenError {
    fn from(e: io::Error) -> Self {
        OpenError::Io(e)
    }
}

/// A checksum that does not match the bytes it covers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChecksumMismatch {
    pub stored: u64,
    pub computed: u64,
}

impl Format {
    /// The magic and `version`, as a file starts.
    pub fn prefix(&self, version: u32) -> [u8; PREFIX_BYTES] {
        let mut out = [0u8; PREFIX_BYTES];
        out[..MAGIC_BYTES].copy_from_slice(&self.magic);
        out[MAGIC_BYTES..].copy_from_slice(&version.to_le_bytes());
        out
    }

    /// The version of the file starting with `bytes` (whatever its value: the caller knows which it
    /// reads).
    pub fn version(&self, bytes: &[u8]) -> Result<u32, PrefixError> {
        if bytes.len() >= MAGIC_BYTES && bytes[..MAGIC_BYTES] != self.magic {
            return Err(PrefixError::BadMagic);
        }
        if bytes.len() < PREFIX_BYTES {
            return Err(PrefixError::Truncated);
        }
        Ok(Reader::new(bytes, MAGIC_BYTES).u32())
    }

    /// The checksum of a file whose bytes before the checksum are `body`.
    pub fn checksum(&self, body: &[u8]) -> u64 {
        fnv1a64(body.get(self.checksum_from..).unwrap_or(&[]))
    }

    /// Checks the checksum that ends `file` (whose length the caller has checked).
    pub fn verify_checksum(&self, file: &[u8]) -> Result<(), ChecksumMismatch> {
        let body_end = file.len().saturating_sub(CHECKSUM_BYTES);
        let stored = Reader::new(file, body_end).u64();
        let computed = self.checksum(&file[..body_end]);
        if stored == computed {
            Ok(())
        } else {
            Err(ChecksumMismatch { stored, computed })
        }
    }

    /// Starts a file of `version` on `w`: the header and body go through the returned writer, whose
    /// [`finish`](ChecksumWriter::finish) appends the checksum.
    pub fn writer<W: Write>(&self, mut w: W, version: u32) -> io::Result<ChecksumWriter<W>> {
        let prefix = self.prefix(version);
        let (outside, covered) = prefix.split_at(self.checksum_from.min(PREFIX_BYTES));
        w.write_all(outside)?;
        let mut w = ChecksumWriter::new(w);
        w.write_all(covered)?;
        Ok(w)
    }

    /// Opens `path` if it is a regular file of at most [`max_file_bytes`](Self::max_file_bytes), with
    /// its length.
    pub fn open(&self, path: &Path) -> Result<(File, u64), OpenError> {
        let meta = std::fs::metadata(path)?;
        if !meta.is_file() {
            return Err(OpenError::NotRegularFile);
        }
        self.check_size(meta.len())?;
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        Ok((file, len))
    }

    /// The bytes of `path`, as [`open`](Self::open) accepts it; a file that grows past the limit while
    /// it is read is refused too.
    pub fn read(&self, path: &Path) -> Result<Vec<u8>, OpenError> {
        let (file, len) = self.open(path)?;
        self.read_open(file, len)
    }

    /// The rest of `file` (`len` bytes from its start, as [`open`](Self::open) measured it), in a
    /// buffer whose allocation may fail with [`OpenError::OutOfMemory`] rather than abort.
    pub fn read_open(&self, file: File, len: u64) -> Result<Vec<u8>, OpenError> {
        let mut bytes = Vec::new();
        bytes
            .try_reserve_exact(len as usize)
            .map_err(|_| OpenError::OutOfMemory { bytes: len })?;
        file.take(self.max_file_bytes + 1).read_to_end(&mut bytes)?;
        self.check_size(bytes.len() as u64)?;
        Ok(bytes)
    }

    /// Checks the checksum ending `file`, `len` bytes long, reading it in small pieces — so that a
    /// damaged file whose header claims a large count is refused before that count is allocated —
    /// then rewinds it.
    pub fn verify_file(&self, file: &mut File, len: u64) -> Result<(), OpenError> {
        let body = len.saturating_sub(CHECKSUM_BYTES as u64);
        file.seek(SeekFrom::Start(0))?;
        let mut hash = Fnv1a::new();
        let mut buf = vec![0u8; 1 << 20];
        let mut at = 0u64;
        while at < body {
            let n = buf.len().min((body - at) as usize);
            file.read_exact(&mut buf[..n])?;
            let from = (self.checksum_from as u64).saturating_sub(at).min(n as u64) as usize;
            hash.update(&buf[from..n]);
            at += n as u64;
        }
        let mut stored = [0u8; CHECKSUM_BYTES];
        file.read_exact(&mut stored)?;
        file.seek(SeekFrom::Start(0))?;
        let (stored, computed) = (u64::from_le_bytes(stored), hash.finish());
        if stored == computed {
            Ok(())
        } else {
            Err(OpenError::Checksum(ChecksumMismatch { stored, computed }))
        }
    }

    fn check_size(&self, bytes: u64) -> Result<(), OpenError> {
        if bytes > self.max_file_bytes {
            return Err(OpenError::TooLarge {
                bytes,
                limit: self.max_file_bytes,
            });
        }
        Ok(())
    }
}

/// FNV-1a, 64 bit, fed in pieces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a(u64);

impl Fnv1a {
    pub const fn new() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }

    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub fn finish(&self) -> u64 {
        self.0
    }
}

impl Default for Fnv1a {
    fn default() -> Self {
        Self::new()
    }
}

/// FNV-1a 64 of `bytes`.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a::new();
    h.update(bytes);
    h.finish()
}

/// A writer that checksums every byte written through it.
pub struct ChecksumWriter<W> {
    inner: W,
    hash: Fnv1a,
}

impl<W: Write> ChecksumWriter<W> {
    pub fn new(inner: W) -> Self {
        ChecksumWriter {
            inner,
            hash: Fnv1a::new(),
        }
    }

    /// Appends the checksum of everything written so far and returns the inner writer (not flushed).
    pub fn finish(mut self) -> io::Result<W> {
        self.inner.write_all(&self.hash.finish().to_le_bytes())?;
        Ok(self.inner)
    }
}

impl<W: Write> Write for ChecksumWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// Little-endian fields read in order from a slice whose length the caller has checked; reads past
/// its end give zero bytes rather than a panic.
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Reads `bytes` from byte `at` on.
    pub fn new(bytes: &'a [u8], at: usize) -> Self {
        Reader { bytes, at }
    }

    /// The next byte to read.
    pub fn position(&self) -> usize {
        self.at
    }

    pub fn skip(&mut self, n: usize) {
        self.at = self.at.saturating_add(n);
    }

    pub fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        if let Some(src) = self
            .at
            .checked_add(N)
            .and_then(|end| self.bytes.get(self.at..end))
        {
            out.copy_from_slice(src);
        }
        self.skip(N);
        out
    }

    pub fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }

    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }

    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }

    pub fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }

    pub fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FORMAT: Format = Format {
        magic: *b"TESTFILE",
        checksum_from: MAGIC_BYTES,
        max_file_bytes: 64,
    };

    #[test]
    fn fnv1a_matches_its_reference_values() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        let mut h = Fnv1a::new();
        h.update(b"foo");
        h.update(b"bar");
        assert_eq!(h.finish(), fnv1a64(b"foobar"));
    }

    #[test]
    fn written_files_read_back_and_damage_is_caught() {
        let mut w = FORMAT.writer(Vec::new(), 7).unwrap();
        w.write_all(&1.5f32.to_le_bytes()).unwrap();
        let file = w.finish().unwrap();
        assert_eq!(file.len(), PREFIX_BYTES + 4 + CHECKSUM_BYTES);
        assert_eq!(FORMAT.version(&file), Ok(7));
        assert_eq!(FORMAT.verify_checksum(&file), Ok(()));
        assert_eq!(Reader::new(&file, PREFIX_BYTES).f32(), 1.5);
        // The magic is outside this format's checksum; the version is inside.
        let mut other = file.clone();
        other[0] = b'X';
        assert_eq!(FORMAT.verify_checksum(&other), Ok(()));
        assert_eq!(FORMAT.version(&other), Err(PrefixError::BadMagic));
        other[MAGIC_BYTES] ^= 1;
        assert!(FORMAT.verify_checksum(&other).is_err());
        assert_eq!(FORMAT.version(&file[..10]), Err(PrefixError::Truncated));
    }

    #[test]
    fn reads_past_the_end_give_zeros() {
        let mut r = Reader::new(&[1, 0, 0], 0);
        assert_eq!(r.u32(), 0);
        assert_eq!(r.position(), 4);
        assert_eq!(Reader::new(&[1, 0, 0, 0], 0).u32(), 1);
    }

    #[test]
    fn only_small_regular_files_are_read() {
        let dir = std::env::temp_dir().join(format!("pmbase-container-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        assert!(matches!(FORMAT.read(&dir), Err(OpenError::NotRegularFile)));
        let path = dir.join("f");
        std::fs::write(&path, [0u8; 65]).unwrap();
        assert!(matches!(
            FORMAT.read(&path),
            Err(OpenError::TooLarge {
                bytes: 65,
                limit: 64
            })
        ));
        std::fs::write(&path, [0u8; 64]).unwrap();
        assert_eq!(FORMAT.read(&path).unwrap().len(), 64);
        // Streamed, the checksum agrees with the one over the bytes in memory.
        let mut w = FORMAT.writer(Vec::new(), 7).unwrap();
        w.write_all(&[3u8; 40]).unwrap();
        let mut good = w.finish().unwrap();
        std::fs::write(&path, &good).unwrap();
        let (mut file, len) = FORMAT.open(&path).unwrap();
        assert!(FORMAT.verify_file(&mut file, len).is_ok());
        assert_eq!(FORMAT.read_open(file, len).unwrap(), good);
        good[20] ^= 1;
        std::fs::write(&path, &good).unwrap();
        let (mut file, len) = FORMAT.open(&path).unwrap();
        assert!(matches!(
            FORMAT.verify_file(&mut file, len),
            Err(OpenError::Checksum(_))
        ));
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(matches!(FORMAT.read(&path), Err(OpenError::Io(_))));
    }
}
