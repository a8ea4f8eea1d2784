//! The renderer's errors as Python exceptions: bad input naming a file becomes `SceneError` (a
//! `ValueError` with `.path` and `.line`), other bad input `ValueError`, runtime failures
//! `RuntimeError`, an interrupted render `KeyboardInterrupt`.

use std::path::Path;

use pmrender::error::Error;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    pmrender,
    SceneError,
    PyValueError,
    "A scene file (or a file it names) is wrong: `.path` is the file, `.line` the line (or None)."
);

/// The exception for `e`.
pub fn to_py(e: Error) -> PyErr {
    match e {
        Error::Input(msg) => match location(&msg) {
            Some((path, line)) => Python::attach(|py| {
                let err = SceneError::new_err(msg.clone());
                let value = err.value(py);
                let set = value
                    .setattr("path", path)
                    .and_then(|_| value.setattr("line", line));
                match set {
                    Ok(()) => err,
                    Err(e) => e,
                }
            }),
            None => PyValueError::new_err(msg),
        },
        Error::Runtime(msg) => PyRuntimeError::new_err(msg),
        Error::Interrupted => PyKeyboardInterrupt::new_err("render interrupted"),
    }
}

/// The file (and line) an input error's message begins with: `file:line: what` or `file: what`,
/// where `file` exists. Messages about options (`option --x: ...`) name none.
fn location(msg: &str) -> Option<(String, Option<usize>)> {
    msg.match_indices(": ").find_map(|(at, _)| {
        let head = &msg[..at];
        if Path::new(head).is_file() {
            return Some((head.to_string(), None));
        }
        let (file, line) = head.rsplit_once(':')?;
        let line = line.parse::<usize>().ok()?;
        Path::new(file)
            .is_file()
            .then(|| (file.to_string(), Some(line)))
    })
}

/// A `ValueError` about the keyword argument `name`.
pub fn bad_arg(name: &str, msg: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{name}: {msg}"))
}
