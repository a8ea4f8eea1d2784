//! Where a sequence's outputs land on disk, to find two that would be one file before any is written:
//! each path's folder resolved (symlinks, `..`), its name kept, and every frame's landings kept as
//! 128-bit hashes with the frame and option that made them (about 25 bytes per output and frame).

use std::collections::HashMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};

use pmrender::error::{option, Result};

/// Folders resolved so far are forgotten past this many (a `#` in a folder makes one per frame).
const MAX_DIRS: usize = 4096;

/// The options whose outputs are compared, by index (kept in a landing's record).
pub(super) const OPTIONS: [&str; 4] = ["-o", "--png", "--stats", "--cache-image"];

/// Every landing so far: its hash → frame × 8 + option index (the summary: frame `u32::MAX >> 3`).
#[derive(Default)]
pub(super) struct Landings {
    dirs: HashMap<PathBuf, PathBuf>,
    seen: HashMap<u128, u32>,
}

/// The frame number a sequence's summary is recorded under.
const SUMMARY: u32 = u32::MAX >> 3;

impl Landings {
    /// Records where output `opt` (an index of [`OPTIONS`]) of frame `f` lands (`None`: the sequence
    /// summary); refused when an earlier output lands on the same file.
    pub(super) fn add(&mut self, opt: usize, f: Option<u32>, path: &Path) -> Result<()> {
        let at = self.resolve(path);
        let record = f.unwrap_or(SUMMARY).min(SUMMARY) * 8 + opt as u32;
        match self.seen.insert(hash128(&at), record) {
            Some(earlier) if earlier != record => {
                let (g, other) = (earlier / 8, OPTIONS[(earlier % 8) as usize]);
                let name = |frame: u32| match frame {
                    SUMMARY => "the sequence summary".to_string(),
                    n => format!("frame {n}"),
                };
                Err(option(
                    OPTIONS[opt],
                    format!(
                        "'{}' ({}) is the file {other} names for {}: one would replace the other",
                        path.display(),
                        name(f.unwrap_or(SUMMARY)),
                        name(g)
                    ),
                ))
            }
            _ => Ok(()),
        }
    }

    /// `p` with its folder resolved as the file system will (symlinks, `.` and `..`).
    fn resolve(&mut self, p: &Path) -> PathBuf {
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if self.dirs.len() >= MAX_DIRS {
            self.dirs.clear();
        }
        let dir = self
            .dirs
            .entry(parent.to_path_buf())
            .or_insert_with(|| std::fs::canonicalize(parent).unwrap_or_else(|_| parent.into()));
        match p.file_name() {
            Some(name) => dir.join(name),
            None => dir.clone(),
        }
    }
}

/// Two independent SipHash values of the path: a false match is out of reach for any sequence.
fn hash128(p: &Path) -> u128 {
    let mut a = DefaultHasher::new();
    p.hash(&mut a);
    let mut b = DefaultHasher::new();
    (0x9e37_79b9_u32, p).hash(&mut b);
    (u128::from(a.finish()) << 64) | u128::from(b.finish())
}
