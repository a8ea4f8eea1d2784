//! The files a sequence's scenes read — OBJ files (with their MTL libraries) and the images their
//! materials name (textures, `map_d` masks, glossy maps, bump and normal maps) — each read once and
//! held for the whole run: a frame where a mesh moved is built again from them, not from the files, so
//! that a file edited (or removed) while the sequence renders changes no frame and refuses none.

use std::collections::HashMap;
use std::hash::Hash;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use super::obj::{self, ObjData};
use crate::bump::BumpMap;
use crate::cutout::Mask;
use crate::error::Result;
use crate::texture::Texture;

/// An image as a material names it: the directory its name is relative to, the name, and how it is
/// read (the same file read as a mask and as a map of values is two entries).
#[derive(Clone, PartialEq, Eq, Hash)]
pub(super) struct ImageKey {
    pub dir: PathBuf,
    pub name: String,
    pub read_as: String,
}

/// An image read, with the file its name resolved to.
pub(super) type HeldImage<T> = (PathBuf, Arc<T>);

type Held<K, V> = Mutex<HashMap<K, V>>;

/// Each OBJ and image read so far.
#[derive(Default)]
pub struct HeldInputs {
    objs: Held<PathBuf, Arc<ObjData>>,
    textures: Held<ImageKey, HeldImage<Texture>>,
    masks: Held<ImageKey, HeldImage<Mask>>,
    bumps: Held<ImageKey, HeldImage<BumpMap>>,
}

impl std::fmt::Debug for HeldInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "HeldInputs {{ {} OBJ files, {} textures, {} masks, {} bump maps }}",
            len(&self.objs),
            len(&self.textures),
            len(&self.masks),
            len(&self.bumps)
        )
    }
}

fn len<K, V>(held: &Held<K, V>) -> usize {
    held.lock().map_or(0, |m| m.len())
}

/// The value at `key` in `held`, made by `read` the first time it is asked for (an error is not held:
/// it is returned, and the next ask reads again).
fn get_or_read<K: Eq + Hash, V: Clone>(
    held: &Held<K, V>,
    key: K,
    read: impl FnOnce() -> Result<V>,
) -> Result<V> {
    // A poisoned lock only means another thread panicked while inserting: the map is whole.
    let mut map = held.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(v) = map.get(&key) {
        return Ok(v.clone());
    }
    let v = read()?;
    map.insert(key, v.clone());
    Ok(v)
}

impl HeldInputs {
    /// The OBJ at `path`, read (and checked) the first time it is asked for.
    pub(super) fn obj(&self, path: &Path) -> Result<Arc<ObjData>> {
        get_or_read(&self.objs, path.to_path_buf(), || {
            Ok(Arc::new(obj::load(path)?))
        })
    }

    /// The colour texture `key` names (`map_Kd`, `map_Ks`), read by `read` the first time.
    pub(super) fn texture(
        &self,
        key: ImageKey,
        read: impl FnOnce() -> Result<(PathBuf, Texture)>,
    ) -> Result<HeldImage<Texture>> {
        get_or_read(&self.textures, key, || {
            read().map(|(p, t)| (p, Arc::new(t)))
        })
    }

    /// The mask or map of values `key` names (`map_d`, `map_Ns`), read by `read` the first time.
    pub(super) fn mask(
        &self,
        key: ImageKey,
        read: impl FnOnce() -> Result<(PathBuf, Mask)>,
    ) -> Result<HeldImage<Mask>> {
        get_or_read(&self.masks, key, || read().map(|(p, m)| (p, Arc::new(m))))
    }

    /// The bump or normal map `key` names, read by `read` the first time.
    pub(super) fn bump(
        &self,
        key: ImageKey,
        read: impl FnOnce() -> Result<(PathBuf, BumpMap)>,
    ) -> Result<HeldImage<BumpMap>> {
        get_or_read(&self.bumps, key, || read().map(|(p, b)| (p, Arc::new(b))))
    }
}
