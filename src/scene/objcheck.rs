//! A line-by-line check of OBJ and MTL text before `tobj` parses it, so that every mistake is reported as
//! `file:line: what` (tobj's own errors carry no line and it panics on some inputs), and the text that
//! tobj reads is rewritten into the subset it handles: one material library per `mtllib` statement,
//! `vt u` as `vt u 0`, `Kd g` as `Kd g g g`, comments removed.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::input::{read_text, MAX_MTL_BYTES};
use super::limits::{self, MAX_EXPONENT, MAX_IOR};
use crate::error::{at_line, relative_to, Error, Result};

/// An OBJ file after the check, with its material libraries.
pub struct CheckedObj {
    /// The OBJ text for tobj; `mtllib K` names `libraries[K]`.
    pub text: String,
    /// Each material library: its path and its text for tobj.
    pub libraries: Vec<(PathBuf, String)>,
    /// Where each material's `Ke` was given (MTL file and line), for messages about light power.
    pub ke_at: HashMap<String, (PathBuf, usize)>,
    /// The `usemtl` names no library defines, with the OBJ line of each one's first use: the default
    /// material stands in for them, each warned about unless the scene file defines it (see
    /// [`define_missing`]).
    pub undefined: Vec<(String, usize)>,
}

/// The statement without its comment: `#` at the start or after white space begins one.
fn strip_comment(line: &str) -> &str {
    let bytes = line.as_bytes();
    let cut = (0..bytes.len())
        .find(|&i| bytes[i] == b'#' && (i == 0 || bytes[i - 1].is_ascii_whitespace()));
    cut.map_or(line, |i| &line[..i])
}

/// The finite numbers after a tag; an error names the first token that is not one.
fn numbers(path: &Path, line_no: usize, tag: &str, words: &[&str]) -> Result<Vec<f32>> {
    words
        .iter()
        .map(|tok| match tok.parse::<f32>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(at_line(
                path,
                line_no,
                format!("{tag}: non-finite number '{tok}'"),
            )),
            Err(_) => Err(at_line(
                path,
                line_no,
                format!("{tag}: '{tok}' is not a number"),
            )),
        })
        .collect()
}

/// Checks an OBJ file and the material libraries it names.
pub fn check_obj(path: &Path, text: &str) -> Result<CheckedObj> {
    let mut out = CheckedObj {
        text: String::with_capacity(text.len()),
        libraries: Vec::new(),
        ke_at: HashMap::new(),
        undefined: Vec::new(),
    };
    let mut counts = [0i64; 3];
    let mut used: Vec<(String, usize)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = strip_comment(raw);
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(&tag) = words.first() else {
            out.text.push('\n');
            continue;
        };
        let args = &words[1..];
        match tag {
            "v" | "vt" | "vn" => {
                let v = numbers(path, line_no, tag, args)?;
                let ok = match tag {
                    "v" => {
                        matches!(v.len(), 3 | 6)
                            || (v.len() == 4
                                && v[3] != 0.0
                                && v[..3].iter().all(|x| (x / v[3]).is_finite()))
                    }
                    "vt" => (1..=3).contains(&v.len()),
                    _ => v.len() == 3,
                };
                if !ok {
                    let want = match tag {
                        "v" => "x y z, optionally a non-zero w or r g b",
                        "vt" => "u, optionally v and w",
                        _ => "x y z",
                    };
                    return Err(at_line(
                        path,
                        line_no,
                        format!("'{tag}' needs {want}; found {} number(s)", v.len()),
                    ));
                }
                counts[["v", "vt", "vn"]
                    .iter()
                    .position(|t| *t == tag)
                    .unwrap_or(0)] += 1;
                if tag == "vt" && v.len() == 1 {
                    out.text.push_str(&format!("vt {} 0\n", args[0]));
                    continue;
                }
            }
            "f" => check_face(path, line_no, args, counts)?,
            "usemtl" if args.is_empty() => {
                return Err(at_line(path, line_no, "'usemtl' needs a material name"))
            }
            "usemtl" => {
                let name = line.trim()["usemtl".len()..].trim();
                if !used.iter().any(|(u, _)| u == name) {
                    used.push((name.to_string(), line_no));
                }
            }
            "mtllib" => {
                for lib in libraries(path, line_no, line)? {
                    let mtl_text = read_text(&lib, "material library", MAX_MTL_BYTES, Some(b'#'))?;
                    let (checked, ke_at) = check_mtl(&lib, &mtl_text)?;
                    out.text
                        .push_str(&format!("mtllib {}\n", out.libraries.len()));
                    out.libraries.push((lib, checked));
                    out.ke_at.extend(ke_at);
                }
                continue;
            }
            _ => {}
        }
        out.text.push_str(line);
        out.text.push('\n');
    }
    define_missing(path, &mut out, &used);
    Ok(out)
}

/// Gives each `usemtl` name that no library defines the default material (diffuse 0.8) under its own
/// name, in a library of its own read first, so that a scene's `[materials.NAME]` can define it:
/// McGuire's CornellBox-Glossy.mtl lacks the `light` its OBJ uses. The names are kept in
/// `out.undefined`: without such a table the scene warns about each (a misspelt name would silently
/// render grey).
fn define_missing(path: &Path, out: &mut CheckedObj, used: &[(String, usize)]) {
    let defined: std::collections::HashSet<&str> = out
        .libraries
        .iter()
        .flat_map(|(_, text)| text.lines())
        .filter_map(|l| l.trim().strip_prefix("newmtl"))
        .map(str::trim)
        .collect();
    out.undefined = used
        .iter()
        .filter(|(u, _)| !defined.contains(u.as_str()))
        .cloned()
        .collect();
    if out.undefined.is_empty() {
        return;
    }
    let missing: String = out
        .undefined
        .iter()
        .map(|(u, _)| format!("newmtl {u}\nKd 0.8 0.8 0.8\n"))
        .collect();
    out.text = format!("mtllib {}\n{}", out.libraries.len(), out.text);
    out.libraries.push((path.to_path_buf(), missing));
}

/// The files an `mtllib` statement names: the whole rest of the line when that is a file (names may
/// hold spaces), otherwise each word (the OBJ specification allows several libraries).
fn libraries(path: &Path, line_no: usize, line: &str) -> Result<Vec<PathBuf>> {
    let rest = line.trim_start()["mtllib".len()..].trim();
    if rest.is_empty() {
        return Err(at_line(path, line_no, "'mtllib' needs a file name"));
    }
    let whole = relative_to(path, rest);
    if whole.is_file() {
        return Ok(vec![whole]);
    }
    rest.split_whitespace()
        .map(|name| {
            let lib = relative_to(path, name);
            if lib.is_file() {
                Ok(lib)
            } else if lib.exists() {
                Err(at_line(
                    path,
                    line_no,
                    format!("material library '{}' is not a regular file", lib.display()),
                ))
            } else {
                Err(at_line(
                    path,
                    line_no,
                    format!("material library '{}' not found", lib.display()),
                ))
            }
        })
        .collect()
}

/// Face corners `v`, `v/vt`, `v//vn`, `v/vt/vn` with indices in range (negative ones count back).
fn check_face(path: &Path, line_no: usize, corners: &[&str], counts: [i64; 3]) -> Result<()> {
    if corners.len() < 3 {
        return Err(at_line(path, line_no, "a face needs at least 3 vertices"));
    }
    for c in corners {
        for (slot, part) in c.split('/').enumerate() {
            if part.is_empty() {
                continue;
            }
            let count = counts.get(slot).copied().unwrap_or(0);
            let idx: i64 = part
                .parse()
                .map_err(|_| at_line(path, line_no, format!("bad face index '{part}'")))?;
            let resolved = if idx < 0 { count + idx + 1 } else { idx };
            if idx == 0 || resolved < 1 || resolved > count {
                let what = ["vertex", "texture coordinate", "normal"][slot.min(2)];
                return Err(at_line(
                    path,
                    line_no,
                    format!("face {what} index {idx} out of range (1..={count} defined so far)"),
                ));
            }
        }
    }
    Ok(())
}

type KeAt = HashMap<String, (PathBuf, usize)>;

/// Checks an MTL file: every number finite, colours with 1 or 3 values, and each value in its range
/// (`Kd`, `Ks`, `Tf` in [0, 1]; `Ke` in [0, MAX_EMISSION]; `Ns` in [0, MAX_EXPONENT]; `Ni` in [0, MAX_IOR]).
/// Returns the text for tobj and where each material's `Ke` was set.
pub fn check_mtl(path: &Path, text: &str) -> Result<(String, KeAt)> {
    let mut out = String::with_capacity(text.len());
    let mut ke_at = KeAt::new();
    let mut material = String::new();
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = strip_comment(raw);
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(&tag) = words.first() else {
            out.push('\n');
            continue;
        };
        let err = |msg: String| -> Error { at_line(path, line_no, format!("{tag}: {msg}")) };
        let args = &words[1..];
        match tag {
            "newmtl" => {
                material = line.trim()["newmtl".len()..].trim().to_string();
                if material.is_empty() {
                    return Err(err("needs a material name".into()));
                }
            }
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                let v = numbers(path, line_no, tag, args)?;
                let rgb = match v[..] {
                    [g] => [g; 3],
                    [r, g, b] => [r, g, b],
                    _ => return Err(err(format!("needs 1 or 3 numbers, found {}", v.len()))),
                };
                let problem = match tag {
                    "Kd" | "Ks" | "Tf" => limits::unit_interval(rgb),
                    "Ke" => limits::emission(rgb),
                    _ => None,
                };
                if let Some(p) = problem {
                    return Err(err(p));
                }
                if tag == "Ke" {
                    ke_at.insert(material.clone(), (path.to_path_buf(), line_no));
                }
                out.push_str(&format!("{tag} {} {} {}\n", rgb[0], rgb[1], rgb[2]));
                continue;
            }
            "Ns" | "Ni" | "d" | "Tr" => {
                let v = numbers(path, line_no, tag, args)?;
                let [x] = v[..] else {
                    return Err(err(format!("needs 1 number, found {}", v.len())));
                };
                let max = match tag {
                    "Ns" => MAX_EXPONENT,
                    "Ni" => MAX_IOR,
                    _ => 1.0,
                };
                if !(0.0..=max).contains(&x) {
                    return Err(err(format!("{x} is outside [0, {max}]")));
                }
            }
            "illum" if !matches!(args, [n] if n.parse::<u8>().is_ok_and(|n| n <= 10)) => {
                return Err(err("needs one illumination model number 0..=10".into()));
            }
            t if (t.starts_with("map_")
                || t == "bump"
                || t == "disp"
                || t == "decal"
                || t == "refl")
                && args.is_empty() =>
            {
                return Err(err("needs a file name".into()));
            }
            t if !is_mtl_statement(t) => {
                return Err(at_line(path, line_no, unknown_statement(t)));
            }
            _ => {}
        }
        out.push_str(line);
        out.push('\n');
    }
    Ok((out, ke_at))
}

/// The MTL statements of the format and its common extensions (PBR, Blender's exports); others are
/// refused as the scene file refuses an unknown key: a misspelt `kd` would give the default material
/// without a word, and a file that is no MTL at all (`mtllib /etc/passwd`) would read as empty.
const MTL_STATEMENTS: &[&str] = &[
    "newmtl",
    "Ka",
    "Kd",
    "Ks",
    "Ke",
    "Tf",
    "Ns",
    "Ni",
    "d",
    "Tr",
    "illum",
    "bump",
    "disp",
    "decal",
    "refl",
    "sharpness",
    "Pr",
    "Pm",
    "Ps",
    "Pc",
    "Pcr",
    "aniso",
    "anisor",
    "norm",
];

fn is_mtl_statement(tag: &str) -> bool {
    MTL_STATEMENTS.contains(&tag) || tag.starts_with("map_")
}

fn unknown_statement(tag: &str) -> String {
    let shown: String = tag.chars().take(40).collect();
    match MTL_STATEMENTS.iter().find(|s| s.eq_ignore_ascii_case(tag)) {
        Some(known) => {
            format!("unknown statement '{shown}' (statements are case-sensitive: '{known}'?)")
        }
        None => format!("unknown statement '{shown}' (is this an MTL file?)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obj_err(text: &str) -> String {
        check_obj(Path::new("m.obj"), text)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    }

    #[test]
    fn a_usemtl_name_no_library_defines_gets_the_default_material() {
        let c = check_obj(Path::new("m.obj"), "v 0 0 0\nusemtl light\nusemtl light\n").unwrap();
        assert!(c.text.starts_with("mtllib 0\n"), "{}", c.text);
        assert_eq!(c.libraries.len(), 1);
        assert_eq!(c.libraries[0].1, "newmtl light\nKd 0.8 0.8 0.8\n");
        assert_eq!(c.undefined, [("light".to_string(), 2)]);
        let c = check_obj(Path::new("m.obj"), "v 0 0 0\n").unwrap();
        assert!(c.libraries.is_empty());
    }

    #[test]
    fn vertices_need_three_coordinates() {
        assert!(obj_err("v 0 0 0\nv 1 0\n").starts_with("m.obj:2:"));
        assert!(obj_err("v\n").starts_with("m.obj:1:"));
        assert!(obj_err("v 1 2 3 4 5 6 7\n").starts_with("m.obj:1:"));
        assert!(obj_err("v 1 2 3 0\n").starts_with("m.obj:1:"));
        assert_eq!(
            obj_err("v 1 2 3 # a comment\nv 1 2 3 1\nv 1 2 3 0.5 0.5 0.5\nvt 0.5\nvt 0.5 0.5 0\n"),
            ""
        );
        let c = check_obj(Path::new("m.obj"), "vt 0.5\n")
            .ok()
            .map(|c| c.text);
        assert_eq!(c.as_deref(), Some("vt 0.5 0\n"));
    }

    #[test]
    fn unknown_mtl_statements_are_refused_with_their_line() {
        let err = |text: &str| {
            check_mtl(Path::new("m.mtl"), text)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        let e = err("newmtl a\nkd 0.5 0.5 0.5\n");
        assert!(
            e.contains("m.mtl:2") && e.contains("'kd'") && e.contains("'Kd'?"),
            "{e}"
        );
        let e = err("newmtl a\nKd 0.5 0.5 0.5\nKx 1\n");
        assert!(e.contains("m.mtl:3") && e.contains("'Kx'"), "{e}");
        let e = err("root:x:0:0:root:/root:/bin/bash\n");
        assert!(e.contains("m.mtl:1") && e.contains("MTL file"), "{e}");
        let ok = "newmtl a\nNs 10\nKa 0 0 0\nKd 0.5\nKs 0\nKe 0 0 0\nNi 1.5\nd 1\nTr 0\nTf 1 1 1\n\
                  illum 2\nmap_Kd a.png\nmap_bump b.png\nbump b.png\nPr 0.5\nnorm n.png\n";
        assert_eq!(err(ok), "");
    }

    #[test]
    fn mtl_values_are_in_range() {
        let mtl_err = |t: &str| {
            check_mtl(Path::new("m.mtl"), t)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        for bad in [
            "Kd -1 -1 -1",
            "Kd 5 5 5",
            "Kd 1e30 0 0",
            "Ks -1 0 0",
            "Tf -2 1 1",
            "Ke 3e38 3e38 3e38",
            "Ke -1 0 0",
            "Ns 1e9",
            "Ni -1",
            "Kd 0.5 0.5",
            "illum x",
        ] {
            let e = mtl_err(&format!("newmtl a\n{bad}\n"));
            assert!(e.starts_with("m.mtl:2:"), "{bad}: {e}");
        }
        let (text, ke) = check_mtl(Path::new("m.mtl"), "newmtl a\nKd 0.5\nKe 10 10 10\n").unwrap();
        assert_eq!(text, "newmtl a\nKd 0.5 0.5 0.5\nKe 10 10 10\n");
        assert_eq!(ke.get("a").map(|k| k.1), Some(3));
    }
}
