//! The scene file being loaded, as the loaders of its tables see it: its path and text, so that a
//! message names the key at fault and its line.

use std::path::Path;

use super::file::line_of_key;
use crate::error::{at_line, Error};

/// The scene file being loaded, for messages that name a key and its line.
pub(super) struct Ctx<'a> {
    pub path: &'a Path,
    pub text: &'a str,
}

impl Ctx<'_> {
    pub fn err(&self, table: &str, index: usize, key: &str, msg: impl std::fmt::Display) -> Error {
        let line = line_of_key(self.text, table, index, key);
        let dotted = if table.is_empty() {
            key.to_string()
        } else {
            format!("{table}.{key}")
        };
        at_line(self.path, line, format!("{dotted}: {msg}"))
    }
}
