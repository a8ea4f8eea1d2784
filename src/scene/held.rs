//! The OBJ files (with their MTL libraries) a sequence's scenes read, each read once and held for
//! the whole run: a frame where a mesh moved is built again from them, not from the files, so that
//! a file edited (or removed) while the sequence renders changes no frame and refuses none.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::obj::{self, ObjData};
use crate::error::Result;

/// Each OBJ read so far, by its path as the scene names it.
#[derive(Default)]
pub struct HeldInputs {
    objs: Mutex<HashMap<PathBuf, Arc<ObjData>>>,
}

impl std::fmt::Debug for HeldInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.objs.lock().map_or(0, |o| o.len());
        write!(f, "HeldInputs {{ {n} OBJ files }}")
    }
}

impl HeldInputs {
    /// The OBJ at `path`, read (and checked) the first time it is asked for.
    pub(super) fn obj(&self, path: &Path) -> Result<Arc<ObjData>> {
        // A poisoned lock only means another thread panicked while inserting: the map is whole.
        let mut objs = self.objs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(data) = objs.get(path) {
            return Ok(data.clone());
        }
        let data = Arc::new(obj::load(path)?);
        objs.insert(path.to_path_buf(), data.clone());
        Ok(data)
    }
}
