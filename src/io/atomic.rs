//! All-or-nothing file writes. Every output is first written under a short temporary name in its
//! target's directory ([`OutputSet::stage`]); only when all of them are written are they renamed into
//! place ([`OutputSet::commit`]). A set dropped before its commit — a failed write, an error, an
//! interrupt — removes its temporary files, and a commit that fails half-way removes what it renamed:
//! either every output appears, or none does.
#![forbid(unsafe_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{runtime, Result};

static NEXT_TEMP: AtomicU64 = AtomicU64::new(0);

/// A fresh temporary path beside `target`: `.pmr-<pid>-<n>.tmp` plus the target's extension when it
/// is a short image extension (image writers pick the format from it). At most ~40 bytes, so it stays
/// under NAME_MAX whatever the target's own name.
pub fn temp_path(target: &Path) -> PathBuf {
    let ext = target
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .filter(|e| e.len() <= 8 && e.chars().all(|c| c.is_ascii_alphanumeric()));
    let n = NEXT_TEMP.fetch_add(1, Ordering::Relaxed);
    let name = match ext {
        Some(e) => format!(".pmr-{}-{n}.tmp.{e}", std::process::id()),
        None => format!(".pmr-{}-{n}.tmp", std::process::id()),
    };
    target.with_file_name(name)
}

/// Outputs written to temporary files, renamed into place together.
#[derive(Default)]
pub struct OutputSet {
    /// (temporary, target), in staging order.
    staged: Vec<(PathBuf, PathBuf)>,
}

impl OutputSet {
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// Runs `write` on a temporary path beside `target`. On failure the temporary file is removed (and
    /// the whole set will be, when dropped).
    pub fn stage(
        &mut self,
        target: &Path,
        write: impl FnOnce(&Path) -> std::result::Result<(), String>,
    ) -> Result<()> {
        let tmp = temp_path(target);
        if let Err(e) = write(&tmp) {
            let _ = std::fs::remove_file(&tmp);
            return Err(runtime(format!("cannot write '{}': {e}", target.display())));
        }
        self.staged.push((tmp, target.to_path_buf()));
        Ok(())
    }

    pub fn stage_bytes(&mut self, target: &Path, bytes: &[u8]) -> Result<()> {
        self.stage(target, |tmp| {
            std::fs::write(tmp, bytes).map_err(|e| e.to_string())
        })
    }

    /// Renames every staged file onto its target. If one rename fails, the targets already renamed are
    /// removed and the remaining temporary files too.
    pub fn commit(mut self) -> Result<()> {
        let staged = std::mem::take(&mut self.staged);
        for (i, (tmp, target)) in staged.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, target) {
                for (_, done) in &staged[..i] {
                    let _ = std::fs::remove_file(done);
                }
                for (left, _) in &staged[i..] {
                    let _ = std::fs::remove_file(left);
                }
                return Err(runtime(format!("cannot write '{}': {e}", target.display())));
            }
        }
        Ok(())
    }
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// The directories made for a set of outputs: removed again (deepest first, each only if empty) when
/// dropped, unless [`keep`](Self::keep) is called once the outputs are in place — a command that fails
/// or is interrupted leaves no empty folder behind.
pub struct CreatedDirs {
    dirs: Vec<PathBuf>,
}

impl CreatedDirs {
    /// Makes `dir` and whichever of its ancestors are missing.
    pub fn create(dir: &Path) -> std::io::Result<CreatedDirs> {
        let missing: Vec<&Path> = dir
            .ancestors()
            .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
            .collect();
        let mut created = CreatedDirs { dirs: Vec::new() };
        for d in missing.into_iter().rev() {
            std::fs::create_dir(d)?;
            created.dirs.push(d.to_path_buf());
        }
        Ok(created)
    }

    pub fn keep(mut self) {
        self.dirs.clear();
    }
}

impl Drop for CreatedDirs {
    fn drop(&mut self) {
        for d in self.dirs.iter().rev() {
            let _ = std::fs::remove_dir(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.exr"), dir.path().join("b.json"));
        let mut set = OutputSet::new();
        set.stage_bytes(&a, b"first").unwrap();
        let r = set.stage(&b, |tmp| {
            std::fs::write(tmp, b"half").unwrap();
            Err("disk full".into())
        });
        assert!(r.is_err());
        drop(set);
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no output, no temporary file"
        );
    }

    #[test]
    fn commit_renames_all_and_temp_names_stay_short() {
        let dir = tempfile::tempdir().unwrap();
        let long = dir.path().join(format!("{}.exr", "n".repeat(240)));
        let other = dir.path().join("s.json");
        assert!(temp_path(&long).file_name().unwrap().len() < 40);
        let mut set = OutputSet::new();
        set.stage_bytes(&long, b"1").unwrap();
        set.stage_bytes(&other, b"2").unwrap();
        set.commit().unwrap();
        assert_eq!(std::fs::read(&long).unwrap(), b"1");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn directories_made_for_outputs_go_unless_kept() {
        let dir = tempfile::tempdir().unwrap();
        let deep = dir.path().join("a/b/c");
        drop(CreatedDirs::create(&deep).unwrap());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        CreatedDirs::create(&deep).unwrap().keep();
        assert!(deep.is_dir());
    }

    #[test]
    fn a_failed_rename_removes_what_was_renamed() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.json");
        let blocked = dir.path().join("sub");
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("x"), b"x").unwrap();
        let mut set = OutputSet::new();
        set.stage_bytes(&a, b"1").unwrap();
        set.stage_bytes(&blocked, b"2").unwrap(); // renaming a file over a non-empty directory fails
        assert!(set.commit().is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("sub")]);
    }
}
