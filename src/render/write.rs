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

/// A sequence's summary gathered frame by frame: each frame's row spooled, as a line of JSON, to a
/// file in the temporary folder (removed when done), the totals kept as rows come, so that the
/// summary of a sequence of any length holds nothing per frame in memory.
pub struct SequenceSummary {
    spool: PathBuf,
    rows: Option<std::io::BufWriter<std::fs::File>>,
    n_frames: u64,
    render_s: f64,
    photon_traces: u64,
    totals: [u64; TOTALS.len()],
    last_after: serde_json::Value,
    peak_rss: u64,
}

/// The counts the summary sums over its frames.
const TOTALS: [&str; 8] = [
    "records_regathered",
    "records_replaced",
    "records_carried",
    "records_dropped",
    "records_unread",
    "records_gone",
    "pixels_kept",
    "pixels_relit",
];

impl SequenceSummary {
    pub fn new() -> SequenceSummary {
        static N: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let spool = std::env::temp_dir().join(format!(
            "pmrender-{}-{n}-sequence-rows.jsonl",
            std::process::id()
        ));
        SequenceSummary {
            spool,
            rows: None,
            n_frames: 0,
            render_s: 0.0,
            photon_traces: 0,
            totals: [0; TOTALS.len()],
            last_after: serde_json::Value::Null,
            peak_rss: 0,
        }
    }

    /// Adds a frame's row (`time_s`, `photons`, the counts of [`TOTALS`], `records_after`,
    /// `memory_peak_rss_bytes`).
    pub fn push(&mut self, row: &serde_json::Value) -> Result<()> {
        use std::io::Write;
        if self.rows.is_none() {
            let f = std::fs::File::create(&self.spool)
                .map_err(|e| Error::Runtime(format!("cannot spool the sequence summary: {e}")))?;
            self.rows = Some(std::io::BufWriter::new(f));
        }
        if let Some(w) = &mut self.rows {
            writeln!(w, "{row}")
                .map_err(|e| Error::Runtime(format!("cannot spool the sequence summary: {e}")))?;
        }
        self.n_frames += 1;
        self.render_s += row["time_s"].as_f64().unwrap_or(0.0);
        self.photon_traces += u64::from(row["photons"] == "traced");
        for (t, k) in self.totals.iter_mut().zip(TOTALS) {
            *t += row[k].as_u64().unwrap_or(0);
        }
        self.last_after = row["records_after"].clone();
        // The kernel updates the high-water mark lazily: a frame's own reading may exceed a later one.
        self.peak_rss = self
            .peak_rss
            .max(row["memory_peak_rss_bytes"].as_u64().unwrap_or(0));
        Ok(())
    }

    pub fn is_empty(&self) -> bool {
        self.n_frames == 0
    }

    /// The rows pushed, in order, read back from the spool.
    pub fn rows(&mut self) -> Result<impl Iterator<Item = serde_json::Value>> {
        use std::io::{BufRead, Write};
        if let Some(w) = &mut self.rows {
            w.flush()
                .map_err(|e| Error::Runtime(format!("cannot spool the sequence summary: {e}")))?;
        }
        let file = match std::fs::File::open(&self.spool) {
            Ok(f) => Some(std::io::BufReader::new(f)),
            Err(_) if self.n_frames == 0 => None,
            Err(e) => {
                return Err(Error::Runtime(format!(
                    "cannot read the spooled summary: {e}"
                )))
            }
        };
        Ok(file
            .into_iter()
            .flat_map(|f| f.lines())
            .filter_map(|l| serde_json::from_str(&l.ok()?).ok()))
    }

    /// Writes the summary to `path` atomically: every row, and the totals — frames written, photon
    /// traces, render and wall-clock seconds, peak memory.
    pub fn write(&mut self, path: &std::path::Path, wall_s: f64, complete: bool) -> Result<()> {
        use std::io::Write;
        let head = serde_json::json!({
            "frames_written": self.n_frames,
            "complete": complete,
            "photon_traces": self.photon_traces,
            "records_at_end": self.last_after,
            "render_s": self.render_s,
            "wall_s": wall_s,
            "peak_rss_bytes": self.peak_rss.max(crate::stats::peak_rss_bytes()),
        });
        let mut head = head.as_object().cloned().unwrap_or_default();
        for (t, k) in self.totals.iter().zip(TOTALS) {
            head.insert(k.to_string(), (*t).into());
        }
        let rows = self.rows()?;
        let mut set = OutputSet::new();
        set.stage(path, |tmp| {
            let mut w =
                std::io::BufWriter::new(std::fs::File::create(tmp).map_err(|e| e.to_string())?);
            let io = |e: std::io::Error| e.to_string();
            write!(w, "{{\n  \"frames\": [").map_err(io)?;
            for (i, row) in rows.enumerate() {
                write!(w, "{}\n    {row}", if i == 0 { "" } else { "," }).map_err(io)?;
            }
            write!(w, "\n  ]").map_err(io)?;
            for (k, v) in &head {
                write!(w, ",\n  {}: {v}", serde_json::Value::from(k.as_str())).map_err(io)?;
            }
            writeln!(w, "\n}}").map_err(io)?;
            w.flush().map_err(io)
        })?;
        set.commit()
    }
}

impl Default for SequenceSummary {
    fn default() -> Self {
        Self::new()
    }
}

impl Drop for SequenceSummary {
    fn drop(&mut self) {
        self.rows = None;
        let _ = std::fs::remove_file(&self.spool);
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sequence_summary_spools_its_rows_and_sums_them() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("s-sequence.json");
        let mut s = SequenceSummary::new();
        for f in 0..3u64 {
            let photons = if f == 0 { "traced" } else { "reused" };
            s.push(
                &serde_json::json!({"frame": f, "time_s": 0.5, "photons": photons,
                "records_regathered": f, "records_after": 10 + f, "memory_peak_rss_bytes": 7}),
            )
            .unwrap();
        }
        let spool = s.spool.clone();
        assert!(spool.exists());
        s.write(&out, 2.0, true).unwrap();
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(j["frames"].as_array().unwrap().len(), 3);
        assert_eq!(j["frames"][2]["frame"], 2);
        assert_eq!(
            (j["frames_written"].clone(), j["photon_traces"].clone()),
            (3.into(), 1.into())
        );
        assert_eq!(j["records_regathered"], 3);
        assert_eq!(j["records_at_end"], 12);
        assert_eq!(j["render_s"], 1.5);
        drop(s);
        assert!(!spool.exists(), "the spool outlived its summary");
    }
}
