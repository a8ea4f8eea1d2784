//! Reading the scene's text inputs (TOML, OBJ, MTL) safely: only regular files, at most a stated size,
//! a UTF-8 byte-order mark dropped, and text that is not UTF-8 reported at its line.

use std::io::Read;
use std::path::Path;

use crate::error::{at_line, in_file, Result};

/// Largest scene file read (bytes).
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// Largest OBJ file read (bytes).
pub const MAX_OBJ_BYTES: u64 = 1 << 30;
/// Largest MTL file read (bytes).
pub const MAX_MTL_BYTES: u64 = 64 << 20;
/// Largest texture file opened (bytes).
pub const MAX_TEXTURE_BYTES: u64 = 1 << 30;

/// Human-readable byte count for messages.
pub fn bytes_text(n: u64) -> String {
    match n {
        n if n >= 1 << 30 && n % (1 << 30) == 0 => format!("{} GiB", n >> 30),
        n if n >= 1 << 20 && n % (1 << 20) == 0 => format!("{} MiB", n >> 20),
        n => format!("{n} bytes"),
    }
}

/// Checks that `path` is a regular file (not a directory, device or FIFO, which could block or never
/// end) of at most `cap` bytes. `what` names the file's role in messages.
pub fn check_regular(path: &Path, what: &str, cap: u64) -> Result<()> {
    let meta =
        std::fs::metadata(path).map_err(|e| in_file(path, format!("cannot read {what}: {e}")))?;
    if meta.is_dir() {
        return Err(in_file(path, format!("{what} is a directory, not a file")));
    }
    if !meta.is_file() {
        return Err(in_file(path, format!("{what} is not a regular file")));
    }
    if meta.len() > cap {
        return Err(in_file(
            path,
            format!(
                "{what} is {} bytes, larger than the limit of {}",
                meta.len(),
                bytes_text(cap)
            ),
        ));
    }
    Ok(())
}

/// Reads a text input: a regular file of at most `cap` bytes, UTF-8, without a leading byte-order mark.
/// `comment` as in [`decode`].
pub fn read_text(path: &Path, what: &str, cap: u64, comment: Option<u8>) -> Result<String> {
    check_regular(path, what, cap)?;
    let file =
        std::fs::File::open(path).map_err(|e| in_file(path, format!("cannot read {what}: {e}")))?;
    let mut bytes = Vec::new();
    // The file may have grown since the check: never read more than the cap.
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| in_file(path, format!("cannot read {what}: {e}")))?;
    if bytes.len() as u64 > cap {
        return Err(in_file(
            path,
            format!("{what} is larger than the limit of {}", bytes_text(cap)),
        ));
    }
    decode(path, &bytes, comment)
}

/// UTF-8 text without a byte-order mark. Bytes that are not UTF-8 are an error at their line, except
/// inside a comment (after the byte `comment`, when given), where they are replaced: OBJ and MTL
/// exporters write Latin-1 there. TOML must be UTF-8 throughout.
pub fn decode(path: &Path, bytes: &[u8], comment: Option<u8>) -> Result<String> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if let Ok(s) = std::str::from_utf8(bytes) {
        return Ok(s.to_string());
    }
    let mut out = String::with_capacity(bytes.len());
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        if i > 0 {
            out.push('\n');
        }
        match std::str::from_utf8(line) {
            Ok(s) => out.push_str(s),
            Err(e) => {
                let good = &line[..e.valid_up_to()];
                if !comment.is_some_and(|c| good.contains(&c)) {
                    let byte = line[e.valid_up_to()];
                    let column = e.valid_up_to() + 1;
                    return Err(at_line(path, i + 1, format!("byte 0x{byte:02X} at column {column} is not UTF-8 (save the file as UTF-8)")));
                }
                out.push_str(&String::from_utf8_lossy(line));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bom_is_dropped_and_latin1_is_kept_only_in_comments() {
        let p = Path::new("x.obj");
        assert_eq!(
            decode(p, b"\xEF\xBB\xBFmtllib a.mtl\n", Some(b'#')).unwrap(),
            "mtllib a.mtl\n"
        );
        assert_eq!(
            decode(p, b"v 1 2 3\n# caf\xE9\n", Some(b'#')).unwrap(),
            "v 1 2 3\n# caf\u{FFFD}\n"
        );
        let e = decode(p, b"v 1 2 3\nusemtl caf\xE9\n", Some(b'#'))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("x.obj:2:") && e.contains("0xE9"), "{e}");
    }
}
