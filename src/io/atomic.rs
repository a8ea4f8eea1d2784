//! Atomic file writes: write beside the target under a temporary name, then rename over it, so that a
//! failed or interrupted write never leaves a partial or truncated output.

use std::path::{Path, PathBuf};

use crate::error::{option, runtime, Result};

/// A temporary path in the target's directory that keeps the target's extension (image writers pick the
/// format from it).
pub fn temp_path(target: &Path) -> PathBuf {
    let name = target.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = target.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    target.with_file_name(format!(".{name}.{}.tmp{ext}", std::process::id()))
}

/// Checks before rendering that `target` can be created, so a bad path fails in a second, not after
/// a long render. `opt` names the option for the message.
pub fn check_writable(target: &Path, opt: &str) -> Result<()> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(option(opt, format!("directory '{}' does not exist", dir.display())));
    }
    if target.is_dir() {
        return Err(option(opt, format!("'{}' is a directory", target.display())));
    }
    let probe = temp_path(target);
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(option(opt, format!("cannot write '{}': {e}", target.display()))),
    }
}

/// Runs `write` on a temporary path and renames the result onto `target`.
pub fn write_atomically(target: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    let tmp = temp_path(target);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(runtime(format!("cannot write '{}': {e}", target.display())));
    }
    std::fs::rename(&tmp, target).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        runtime(format!("cannot write '{}': {e}", target.display()))
    })
}

pub fn write_bytes(target: &Path, bytes: &[u8]) -> Result<()> {
    write_atomically(target, |tmp| std::fs::write(tmp, bytes).map_err(|e| e.to_string()))
}
