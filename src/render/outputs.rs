//! Checks on output paths, made before anything is rendered: each output must name a file (not a
//! directory, not a path ending in `/`, not a device or FIFO) in an existing, writable directory; no two
//! outputs may name the same file, and no output may name a file the render reads (scene, OBJ, MTL,
//! texture, photon or cache file). Paths are compared canonicalised and by inode, so `./a.exr`, a
//! symbolic link or a hard link to an input are caught too.

use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

use crate::error::{option, relative_to, Result};
use crate::io::atomic::temp_path;

/// One output: the option that names it and its path.
pub type Output<'a> = (&'static str, &'a Path);

/// The checks that need no scene: the path's form, its directory, and that it can be created.
pub fn check_output(opt: &str, path: &Path) -> Result<()> {
    check_target(opt, path)?;
    probe_writable(opt, path)
}

/// `path` names a file, in a directory that exists, that is not a directory or another kind of file.
pub fn check_target(opt: &str, path: &Path) -> Result<()> {
    let raw = path.as_os_str().as_bytes();
    let name = path.file_name();
    if raw.is_empty() || raw.ends_with(b"/") || name.is_none() || raw.ends_with(b"/.") {
        return Err(option(
            opt,
            format!("'{}' does not name a file", path.display()),
        ));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(option(
            opt,
            format!("directory '{}' does not exist", dir.display()),
        ));
    }
    if let Ok(meta) = std::fs::metadata(path) {
        if meta.is_dir() {
            return Err(option(opt, format!("'{}' is a directory", path.display())));
        }
        if !meta.is_file() {
            return Err(option(
                opt,
                format!("'{}' is not a regular file", path.display()),
            ));
        }
    }
    Ok(())
}

/// A file of `path`'s name length can be created in its directory (a file created and removed at once).
pub fn probe_writable(opt: &str, path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path.file_name();
    let probe = probe_path(path);
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) if e.raw_os_error() == Some(libc::ENAMETOOLONG) => Err(option(
            opt,
            format!(
                "the file name is {} bytes, longer than the file system of '{}' allows",
                name.map_or(0, |n| n.len()),
                dir.display()
            ),
        )),
        Err(e) => Err(option(
            opt,
            format!("cannot write in '{}': {e}", dir.display()),
        )),
    }
}

/// A file beside `path` to create and remove at once: a temporary name, padded to the length of the
/// output's own name when that is longer, so that a name the file system cannot hold (over NAME_MAX) is
/// refused now and not at the final rename, after the render.
fn probe_path(path: &Path) -> PathBuf {
    let tmp = temp_path(path);
    let len = |p: &Path| p.file_name().map_or(0, |n| n.len());
    let short = len(path).saturating_sub(len(&tmp));
    if short == 0 {
        return tmp;
    }
    let mut name = tmp.file_name().unwrap_or_default().to_os_string();
    name.push("x".repeat(short));
    tmp.with_file_name(name)
}

/// Where a path points: its canonical form (the parent's, plus the name, when it does not exist yet)
/// and, when it exists, its (device, inode).
struct Identity {
    canonical: Option<PathBuf>,
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Identity {
        let inode = std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()));
        let canonical = std::fs::canonicalize(path).ok().or_else(|| {
            let dir = match path.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            Some(std::fs::canonicalize(dir).ok()?.join(path.file_name()?))
        });
        Identity { canonical, inode }
    }

    fn same(&self, other: &Identity) -> bool {
        (self.canonical.is_some() && self.canonical == other.canonical)
            || (self.inode.is_some() && self.inode == other.inode)
    }
}

/// Refuses two outputs naming one file, and an output naming one of `inputs` (what, path).
pub fn check_distinct(outputs: &[Output], inputs: &[(String, PathBuf)]) -> Result<()> {
    check_distinct_from(outputs, &KnownInputs::new(inputs))
}

/// A command's input files with where each points, found once for the outputs of many frames.
pub struct KnownInputs(Vec<(String, PathBuf, Identity)>);

impl KnownInputs {
    pub fn new(inputs: &[(String, PathBuf)]) -> KnownInputs {
        KnownInputs(
            inputs
                .iter()
                .map(|(what, p)| (what.clone(), p.clone(), Identity::of(p)))
                .collect(),
        )
    }
}

/// [`check_distinct`] against inputs whose identities are known.
pub fn check_distinct_from(outputs: &[Output], inputs: &KnownInputs) -> Result<()> {
    let ids: Vec<Identity> = outputs.iter().map(|(_, p)| Identity::of(p)).collect();
    for (i, (opt, path)) in outputs.iter().enumerate() {
        if let Some(j) = (0..i).find(|&j| ids[j].same(&ids[i])) {
            return Err(option(
                opt,
                format!(
                    "'{}' is also the output of {}",
                    path.display(),
                    outputs[j].0
                ),
            ));
        }
        for (what, input, id) in &inputs.0 {
            if ids[i].same(id) {
                return Err(option(
                    opt,
                    format!(
                        "'{}' would overwrite the {what} '{}'",
                        path.display(),
                        input.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The files a scene reads: the scene file, its OBJs, their MTLs and every texture those (or the scene's
/// material overrides) name. Read from the files a successful `scene::load` has just accepted; a
/// name that cannot be resolved is left out (the loader would have refused a missing file).
pub fn scene_inputs(scene_path: &Path) -> Vec<(String, PathBuf)> {
    let mut inputs = vec![("scene file".to_string(), scene_path.to_path_buf())];
    let Ok(text) = std::fs::read_to_string(scene_path) else {
        return inputs;
    };
    let Ok(desc) = crate::scene::file::parse(scene_path, &text) else {
        return inputs;
    };
    let scene_dir = scene_path.parent().unwrap_or(Path::new(".")).to_path_buf();
    for m in &desc.materials {
        if let Some(t) =
            m.1.texture
                .as_deref()
                .and_then(|t| crate::texture::resolve(&scene_dir, t).ok())
        {
            inputs.push(("texture".into(), t));
        }
    }
    for mesh in &desc.mesh {
        let obj = relative_to(scene_path, &mesh.obj);
        let obj_text = std::fs::read(&obj)
            .map(|b| String::from_utf8_lossy(&b).into_owned())
            .unwrap_or_default();
        inputs.push(("OBJ file".into(), obj.clone()));
        for name in directive_args(&obj_text, |k| k == "mtllib") {
            let mtl = relative_to(&obj, &name);
            let mtl_text = std::fs::read(&mtl)
                .map(|b| String::from_utf8_lossy(&b).into_owned())
                .unwrap_or_default();
            let mtl_dir = mtl.parent().unwrap_or(Path::new(".")).to_path_buf();
            for tex in directive_args(&mtl_text, |k| {
                k.starts_with("map_") || matches!(k, "bump" | "disp" | "decal" | "refl")
            }) {
                if let Ok(t) = crate::texture::resolve(&mtl_dir, &tex) {
                    inputs.push(("texture".into(), t));
                }
            }
            inputs.push(("MTL file".into(), mtl));
        }
    }
    inputs
}

/// For each line whose keyword passes `keep`: every argument, and the whole rest of the line (a name
/// with spaces), so that whatever the loader made of the line is covered.
fn directive_args(text: &str, keep: impl Fn(&str) -> bool) -> Vec<String> {
    let mut out = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        if !keep(&key.to_ascii_lowercase()) {
            continue;
        }
        let args: Vec<&str> = words.collect();
        out.extend(args.iter().map(|a| a.to_string()));
        if args.len() > 1 {
            out.push(args.join(" "));
        }
    }
    out
}
