//! `load_file`: a scene file read once — a still's scene built, an animation's keys checked — with
//! the command line's overrides kept for every render of it.

use std::path::PathBuf;
use std::sync::Arc;

use pmrender::scene::{self, Animation};
use pyo3::prelude::*;

use crate::errors::to_py;
use crate::options::Settings;

/// A loaded scene (from `load_file`): a still, or an animated scene's keys.
#[pyclass(frozen, module = "pmrender")]
pub struct Scene {
    pub path: PathBuf,
    pub kind: Kind,
    /// The overrides given to `load_file`.
    pub settings: Settings,
    /// An animated scene's first frame's scene, built when a walk's frame is first rendered: the
    /// scene every frame of a walk shares.
    pub walk_scene: std::sync::OnceLock<Arc<scene::Scene>>,
}

pub enum Kind {
    Still(Arc<scene::Scene>),
    Animated(Arc<Animation>),
}

#[pymethods]
impl Scene {
    /// The scene file's path.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The number of frames of an animated scene; None for a still.
    #[getter]
    fn frames(&self) -> Option<u32> {
        match &self.kind {
            Kind::Still(_) => None,
            Kind::Animated(a) => Some(a.frames()),
        }
    }

    /// The image's (width, height) as the file and load_file's overrides set it (an animated
    /// scene's: its first frame's).
    #[getter]
    fn size(&self) -> Option<(u32, u32)> {
        let camera = match &self.kind {
            Kind::Still(s) => s.camera.clone(),
            Kind::Animated(a) => scene::frame_camera(a, 0).ok()?,
        };
        Some((
            self.settings.width.map_or(camera.width, |w| w as u32),
            self.settings.height.map_or(camera.height, |h| h as u32),
        ))
    }

    /// The triangles of a still scene; None for an animated one.
    #[getter]
    fn triangles(&self) -> Option<usize> {
        match &self.kind {
            Kind::Still(s) => Some(s.geometry.triangles.len()),
            Kind::Animated(_) => None,
        }
    }

    fn __repr__(&self) -> String {
        match &self.kind {
            Kind::Still(s) => format!(
                "<pmrender.Scene '{}': {} triangles, {} lights>",
                self.path.display(),
                s.geometry.triangles.len(),
                s.lights.len()
            ),
            Kind::Animated(a) => format!(
                "<pmrender.Scene '{}': animated, {} frames>",
                self.path.display(),
                a.frames()
            ),
        }
    }
}

impl Scene {
    /// The still scene, or a `ValueError` saying what to call for an animated one.
    /// An animated scene's keys, or an error naming the still scene.
    pub fn animation(&self) -> PyResult<&Arc<Animation>> {
        match &self.kind {
            Kind::Animated(a) => Ok(a),
            Kind::Still(_) => Err(pyo3::exceptions::PyValueError::new_err(format!(
                "'{}' has no [animation]: render it without frame",
                self.path.display()
            ))),
        }
    }

    /// The scene a walk's frames share (its first frame's), built once.
    pub fn walk_scene(&self, anim: &Animation) -> pmrender::error::Result<Arc<scene::Scene>> {
        if let Some(s) = self.walk_scene.get() {
            return Ok(s.clone());
        }
        let built = Arc::new(scene::load_frame(anim, 0)?);
        Ok(self.walk_scene.get_or_init(|| built).clone())
    }

    pub fn still(&self) -> PyResult<&Arc<scene::Scene>> {
        match &self.kind {
            Kind::Still(s) => Ok(s),
            Kind::Animated(_) => Err(pyo3::exceptions::PyValueError::new_err(format!(
                "'{}' is animated: render its frames with render_sequence",
                self.path.display()
            ))),
        }
    }
}

#[pyfunction]
#[pyo3(signature = (path, *, method=None, spp=None, noise=None, aa_spp=None, width=None,
                    height=None, seed=None, crop=None, max_memory=None))]
#[allow(clippy::too_many_arguments)]
pub fn load_file(
    py: Python<'_>,
    path: PathBuf,
    method: Option<String>,
    spp: Option<i64>,
    noise: Option<f64>,
    aa_spp: Option<i64>,
    width: Option<i64>,
    height: Option<i64>,
    seed: Option<u64>,
    crop: Option<(u32, u32, u32, u32)>,
    max_memory: Option<String>,
) -> PyResult<Scene> {
    let settings = Settings {
        method,
        spp,
        noise,
        aa_spp,
        width,
        height,
        seed,
        crop,
        max_memory,
    };
    // The overrides are checked now, so that a bad one is refused before any render.
    settings.options()?;
    let kind = py
        .detach(|| match scene::load_animation(&path)? {
            Some(anim) => Ok(Kind::Animated(Arc::new(anim))),
            None => scene::load(&path).map(|s| Kind::Still(Arc::new(s))),
        })
        .map_err(to_py)?;
    Ok(Scene {
        path,
        kind,
        settings,
        walk_scene: std::sync::OnceLock::new(),
    })
}
