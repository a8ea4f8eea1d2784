//! `pmrender._native`: the renderer as a Python extension module, wrapped by the `pmrender` package
//! (`python/pmrender/__init__.py`), which turns its byte buffers into numpy arrays and its JSON into
//! dictionaries. Every render runs on a worker thread with the GIL released; the calling thread
//! holds the GIL only to deliver progress and to notice Ctrl-C ([`run`]).

use pyo3::prelude::*;

mod bake;
mod converge;
mod errors;
mod options;
mod result;
mod run;
mod scene;
mod sequence;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SceneError", m.py().get_type::<errors::SceneError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<result::RenderResult>()?;
    m.add_class::<bake::Bake>()?;
    m.add_class::<sequence::Frames>()?;
    m.add_function(wrap_pyfunction!(scene::load_file, m)?)?;
    m.add_function(wrap_pyfunction!(result::render, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake, m)?)?;
    m.add_function(wrap_pyfunction!(bake::load_bake, m)?)?;
    m.add_function(wrap_pyfunction!(sequence::render_sequence, m)?)?;
    m.add_function(wrap_pyfunction!(converge::converge, m)?)?;
    m.add_function(wrap_pyfunction!(result::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(result::write_exr, m)?)?;
    m.add_function(wrap_pyfunction!(result::tile_windows, m)?)?;
    m.add_function(wrap_pyfunction!(bake::bake_from_bytes, m)?)?;
    Ok(())
}
