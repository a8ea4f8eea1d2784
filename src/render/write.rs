//! The `write_outputs` phase: every output of a render staged in one [`OutputSet`] and renamed into
//! place only when all are written and no signal came; any failure or signal leaves none of them (and
//! no temporary file).

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use super::files::{cache_image, dump_photons, save_cache, save_photons};
use super::{RenderOutput, RenderStats};
use crate::error::{Error, Result};
use crate::io::atomic::OutputSet;
use crate::io::output::{stage_exr, stage_png, Layers};
use crate::stats::Report;

/// Where each output goes (`None`: not wanted).
#[derive(Clone, Debug, Default)]
pub struct OutputPaths {
    pub exr: PathBuf,
    pub png: Option<PathBuf>,
    pub stats: Option<PathBuf>,
    pub save_photons: Option<PathBuf>,
    pub dump_photons: Option<PathBuf>,
    pub save_cache: Option<PathBuf>,
    pub cache_image: Option<PathBuf>,
}

/// Writes every output, all or nothing (a saved cache marked with the scene's `fingerprint`); returns the report of `stats` with this phase's time added (the
/// one saved as `--stats`). `cancel` is read between files.
pub fn write_outputs(
    paths: &OutputPaths,
    fingerprint: u64,
    out: &RenderOutput,
    mut stats: RenderStats,
    cancel: &AtomicBool,
) -> Result<Report> {
    let interrupted = || {
        if cancel.load(Ordering::SeqCst) {
            Err(Error::Interrupted)
        } else {
            Ok(())
        }
    };
    let t = Instant::now();
    let mut set = OutputSet::new();
    interrupted()?;
    let layers = Layers {
        beauty: &out.beauty,
        named: out.layers.iter().map(|(n, i)| (*n, i)).collect(),
    };
    stage_exr(&mut set, &paths.exr, &layers)?;
    interrupted()?;
    if let Some(p) = &paths.png {
        stage_png(&mut set, p, &out.beauty)?;
        interrupted()?;
    }
    match &out.cache {
        None if paths.save_cache.is_some() || paths.cache_image.is_some() => {
            eprintln!("pmrender: note: no irradiance cache with this method; --save-cache/--cache-image ignored")
        }
        None => {}
        Some(c) => {
            if let Some(p) = &paths.save_cache {
                save_cache(&mut set, p, c, fingerprint)?;
                interrupted()?;
            }
            if let Some(p) = &paths.cache_image {
                cache_image(
                    &mut set,
                    p,
                    &out.beauty,
                    c,
                    &out.camera,
                    (&out.media_records, &out.radiance_records),
                )?;
                interrupted()?;
            }
        }
    }
    if let Some(photons) = &out.photons {
        if let Some(p) = &paths.save_photons {
            save_photons(&mut set, p, photons)?;
            interrupted()?;
        }
        if let Some(p) = &paths.dump_photons {
            dump_photons(&mut set, p, &photons.maps)?;
            interrupted()?;
        }
    }
    stats.write_outputs_s = Some(t.elapsed().as_secs_f64());
    let report = stats.report();
    if let Some(p) = &paths.stats {
        let json = serde_json::to_string_pretty(&report.to_json())
            .map_err(|e| Error::Runtime(e.to_string()))?;
        set.stage_bytes(p, json.as_bytes())?;
    }
    interrupted()?;
    set.commit()?;
    Ok(report)
}

/// Writes the summary of a sequence (`frames`: one object per frame written) atomically, with the
/// totals: frames written, photon traces, render and wall-clock seconds, peak memory.
pub fn write_sequence_summary(
    path: &std::path::Path,
    frames: &[serde_json::Value],
    wall_s: f64,
    complete: bool,
) -> Result<()> {
    let render_s: f64 = frames.iter().filter_map(|r| r["time_s"].as_f64()).sum();
    let traced = frames.iter().filter(|r| r["photons"] == "traced").count();
    let total = |k: &str| frames.iter().filter_map(|r| r[k].as_u64()).sum::<u64>();
    let json = serde_json::json!({
        "frames": frames,
        "frames_written": frames.len(),
        "complete": complete,
        "photon_traces": traced,
        "records_regathered": total("records_regathered"),
        "records_replaced": total("records_replaced"),
        "records_carried": total("records_carried"),
        "records_dropped": total("records_dropped"),
        "records_gone": total("records_gone"),
        "records_at_end": frames.last().map_or(serde_json::Value::Null, |r| r["records_after"].clone()),
        "pixels_kept": total("pixels_kept"),
        "pixels_relit": total("pixels_relit"),
        "render_s": render_s,
        "wall_s": wall_s,
        // The kernel updates the high-water mark lazily: a frame's own reading may exceed a later one.
        "peak_rss_bytes": frames
            .iter()
            .filter_map(|r| r["memory_peak_rss_bytes"].as_u64())
            .fold(crate::stats::peak_rss_bytes(), u64::max),
    });
    let text = serde_json::to_string_pretty(&json).map_err(|e| Error::Runtime(e.to_string()))?;
    let mut set = OutputSet::new();
    set.stage_bytes(path, text.as_bytes())?;
    set.commit()
}

/// Writes an image made elsewhere (a farm's tiles pasted together) as `write_outputs` writes a
/// render's: the layered EXR, and the PNG if asked, both or neither.
pub fn write_images(
    exr: &std::path::Path,
    png: Option<&std::path::Path>,
    beauty: &crate::io::output::Image,
    named: &[(&str, &crate::io::output::Image)],
) -> Result<()> {
    let mut set = OutputSet::new();
    let layers = Layers {
        beauty,
        named: named.to_vec(),
    };
    stage_exr(&mut set, exr, &layers)?;
    if let Some(p) = png {
        stage_png(&mut set, p, beauty)?;
    }
    set.commit()
}
