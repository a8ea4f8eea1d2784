//! Photon-count convergence: render at several photon counts and chart the error of the image and of
//! its caustic and indirect terms against the count.
//!
//! The beauty is compared with the given reference. The terms are compared with the reference's
//! `caustic` / `indirect` layers when it has them (a pmrender EXR at a high count), else with the terms
//! of the render at the largest count (self-convergence).

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::chart::{stage_log_log_png, Level, LogLogChart, Series, PALETTE};
use crate::error::{in_file, option, Error, Result};
use crate::io::atomic::{CreatedDirs, OutputSet};
use crate::io::output::{read_layer, Image};
use crate::render::progressive::Budget;
use crate::render::{render, Options, Progress};
use crate::scene::{Method, Scene};

/// relMSE = mean over pixels and channels of (x − r)² / (r² + 0.01).
pub fn rel_mse(img: &Image, reference: &Image) -> f64 {
    let mut s = 0.0f64;
    for (a, r) in img.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (a, r) = (a[c] as f64, r[c] as f64);
            s += (a - r).powi(2) / (r * r + pmbase::REL_MSE_FLOOR);
        }
    }
    s / (3.0 * img.pixels.len().max(1) as f64)
}

/// Flicker of one pair of frames (s before t): the change between them against the reference's
/// change, relative to the reference's brightness there (`tools/flicker.py`: a static region has no
/// reference change, so its own value would be a meaningless denominator).
pub fn rel_mse_change(i_t: &Image, i_s: &Image, r_t: &Image, r_s: &Image) -> f64 {
    let mut s = 0.0f64;
    let pixels = i_t
        .pixels
        .iter()
        .zip(&i_s.pixels)
        .zip(r_t.pixels.iter().zip(&r_s.pixels));
    for ((a_t, a_s), (b_t, b_s)) in pixels {
        for c in 0..3 {
            let d_i = a_t[c] as f64 - a_s[c] as f64;
            let d_r = b_t[c] as f64 - b_s[c] as f64;
            let level = 0.5 * (b_t[c] as f64 + b_s[c] as f64);
            s += (d_i - d_r).powi(2) / (level * level + pmbase::REL_MSE_FLOOR);
        }
    }
    s / (3.0 * i_t.pixels.len().max(1) as f64)
}

/// The temporal relMSE of a sequence against a reference sequence (frame for frame): the mean of
/// [`rel_mse_change`] over consecutive pairs (0 for fewer than two frames).
pub fn temporal_rel_mse(frames: &[Image], reference: &[Image]) -> f64 {
    let n = frames.len().min(reference.len());
    if n < 2 {
        return 0.0;
    }
    (1..n)
        .map(|t| rel_mse_change(&frames[t], &frames[t - 1], &reference[t], &reference[t - 1]))
        .sum::<f64>()
        / (n - 1) as f64
}

pub struct ConvergeRow {
    /// The photon count of both maps (of each pass, in a time study).
    pub photons: usize,
    /// A time study's budget, and the passes made in it.
    pub budget_s: Option<f64>,
    pub passes: Option<u32>,
    pub time_s: f64,
    pub beauty: f64,
    pub caustic: f64,
    pub indirect: f64,
    /// This row's caustic and indirect terms are the reference of the others' (self-convergence), so
    /// they have no error (NaN).
    pub terms_are_reference: bool,
}

/// A relMSE as the terminal table and `converge.md` show it: `—` where there is none (see [`footnote`]).
pub fn fmt_rel_mse(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.5}")
    } else {
        "—".to_string()
    }
}

/// Why some cells show `—` (and the chart leaves those points out), if any do.
pub fn missing_values_note(rows: &[ConvergeRow]) -> Option<String> {
    let mut notes = Vec::new();
    if let Some(r) = rows.iter().find(|r| r.terms_are_reference) {
        let (at, others) = match r.budget_s {
            Some(b) => (format!("At the {b} s budget"), "budgets'"),
            None => (format!("At {} photons", r.photons), "counts'"),
        };
        notes.push(format!(
            "{at} the caustic and indirect terms are the reference that the other {others} \
             terms are measured against (self-convergence: the reference image has no such layers), \
             so they have no error of their own."
        ));
    }
    let missing = |x: f64| !x.is_finite();
    if rows.iter().any(|r| {
        missing(r.beauty) || (!r.terms_are_reference && (missing(r.caustic) || missing(r.indirect)))
    }) {
        let which = if notes.is_empty() {
            "No value"
        } else {
            "Other values missing"
        };
        notes.push(format!(
            "{which}: the render or the reference has no such layer."
        ));
    }
    (!notes.is_empty()).then(|| notes.join(" "))
}

/// The footnote under the terminal table and `converge.md`'s table.
pub fn footnote(rows: &[ConvergeRow]) -> Option<String> {
    missing_values_note(rows).map(|n| format!("— {n}"))
}

/// What the chart's title and dashed line name.
struct Setting {
    scene: String,
    method: Method,
    spp: u32,
    /// The reference's own relMSE noise, from the JSON beside it (`noise_relmse`).
    reference_noise: Option<f64>,
}

/// `noise_relmse` from the JSON beside `reference` (as `tools/mitsuba_reference.py` writes it), if any.
fn reference_noise(reference: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(reference.with_extension("json")).ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    json.get("noise_relmse")?
        .as_f64()
        .filter(|v| v.is_finite() && *v > 0.0)
}

fn layer<'a>(layers: &'a [(&'static str, Image)], name: &str) -> Option<&'a Image> {
    layers.iter().find(|(n, _)| *n == name).map(|(_, i)| i)
}

/// What a convergence run renders, against what, and where its outputs go.
pub struct Study<'a> {
    /// Photon counts, each the target of both the global and the caustic map.
    pub counts: &'a [usize],
    /// Time budgets in seconds, each a progressive render at the scene's photon counts (a time
    /// study, when not empty: `counts` is then unused).
    pub times: &'a [f64],
    /// The reference image (an EXR; its `caustic` and `indirect` layers are used when present).
    pub reference: &'a Path,
    pub method: Method,
    /// Where `converge.md`, `converge.json` and `converge.png` are written (`None`: only returned).
    pub out_dir: Option<&'a Path>,
}

/// Renders at each of the study's counts and writes `converge.md`, `converge.json` and
/// `converge.png` into its `out_dir` (if any). `cancel` interrupts the renders (`Interrupted`, nothing
/// written).
pub fn converge(
    scene: &mut Scene,
    study: &Study,
    opts: &Options,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<Vec<ConvergeRow>> {
    let Study {
        counts,
        times,
        reference,
        method,
        out_dir,
    } = *study;
    let reference_img = read_reference(reference)?;
    let ref_terms = ["caustic", "indirect"].map(|n| read_layer(reference, Some(n)).ok());
    let mut opts = opts.clone();
    opts.method = Some(method);
    opts.width = Some(reference_img.width);
    opts.height = Some(reference_img.height);
    let mut renders = Vec::new();
    let mut spp = 0;
    let steps: Vec<(usize, Option<f64>)> = if times.is_empty() {
        counts.iter().map(|&n| (n, None)).collect()
    } else {
        times.iter().map(|&t| (0, Some(t))).collect()
    };
    for (n, budget) in steps {
        if budget.is_none() {
            scene.settings.photons.global = Some(n);
            scene.settings.photons.caustic = Some(if scene.has_specular() { n } else { 0 });
        }
        opts.budget = Budget {
            passes: None,
            seconds: budget,
        };
        let t = Instant::now();
        let (out, stats) = render(scene, &opts, progress, cancel)?;
        spp = stats.setup.spp;
        // A photon study's row names its target; a time study's the global photons a pass stored.
        let photons = match (budget, stats.photons.as_ref()) {
            (Some(_), Some(p)) => p.trace.n_global_stored as usize,
            _ => n,
        };
        let passes = stats.progressive.as_ref().map(|p| p.pass_s.len() as u32);
        renders.push((photons, budget, passes, t.elapsed().as_secs_f64(), out));
    }
    let Some((_, _, _, _, last)) = renders.last() else {
        return Err(option("--photons", "give at least one count"));
    };
    let self_terms: Vec<Option<Image>> = ["caustic", "indirect"]
        .iter()
        .map(|n| layer(&last.layers, n).cloned())
        .collect();
    let n_renders = renders.len();
    let rows: Vec<ConvergeRow> = renders
        .iter()
        .enumerate()
        .map(|(i, (n, budget_s, passes, t, out))| {
            let term_err = |k: usize, name: &str| -> f64 {
                let r = ref_terms[k].as_ref().or(self_terms[k].as_ref());
                let is_own_reference = ref_terms[k].is_none() && i + 1 == n_renders;
                match (layer(&out.layers, name), r) {
                    (Some(a), Some(r)) if !is_own_reference => rel_mse(a, r),
                    _ => f64::NAN,
                }
            };
            ConvergeRow {
                photons: *n,
                budget_s: *budget_s,
                passes: *passes,
                time_s: *t,
                beauty: rel_mse(&out.beauty, &reference_img),
                caustic: term_err(0, "caustic"),
                indirect: term_err(1, "indirect"),
                terms_are_reference: ref_terms.iter().all(Option::is_none) && i + 1 == n_renders,
            }
        })
        .collect();
    let setting = Setting {
        scene: scene.path.file_stem().map_or_else(
            || scene.path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        ),
        method,
        spp,
        reference_noise: reference_noise(reference),
    };
    if let Some(out_dir) = out_dir {
        write_outputs(
            &rows,
            ref_terms.iter().any(Option::is_some),
            &setting,
            out_dir,
            cancel,
        )?;
    }
    Ok(rows)
}

/// The reference's beauty: an HDR image (EXR or Radiance HDR; an 8-bit PNG is no measure of radiance)
/// whose pixels are finite and non-negative (one NaN or inf makes every relMSE meaningless).
fn read_reference(reference: &Path) -> Result<Image> {
    let ext = reference
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_lowercase);
    if !matches!(ext.as_deref(), Some("exr" | "hdr")) {
        return Err(in_file(
            reference,
            "a reference must be an HDR image (.exr or .hdr): 8-bit images clip and quantise radiance",
        ));
    }
    let img = read_layer(reference, None).map_err(|e| in_file(reference, e))?;
    let width = img.width.max(1) as usize;
    if let Some((i, px)) = img
        .pixels
        .iter()
        .enumerate()
        .find(|(_, px)| !(px.is_finite() && px.min_element() >= 0.0))
    {
        return Err(in_file(
            reference,
            format!(
                "pixel ({}, {}) is ({}, {}, {}): a reference's pixels must be finite and non-negative",
                i % width,
                i / width,
                px.x,
                px.y,
                px.z
            ),
        ));
    }
    Ok(img)
}

/// Writes the three outputs into `out_dir` (made now if missing): all of them or none, and no folder
/// made for them either when one fails or `cancel` is set.
fn write_outputs(
    rows: &[ConvergeRow],
    terms_from_reference: bool,
    setting: &Setting,
    out_dir: &Path,
    cancel: &AtomicBool,
) -> Result<()> {
    let basis = if terms_from_reference {
        "the reference's layers"
    } else {
        "the render at the largest count (self-convergence)"
    };
    let timed = rows.iter().any(|r| r.budget_s.is_some());
    let (title, first_cols) = if timed {
        (
            "Time-budget convergence",
            "| budget (s) | passes | photons (global, per pass) ",
        )
    } else {
        ("Photon-count convergence", "| photons ")
    };
    let basis = basis.replace(
        "largest count",
        if timed {
            "largest budget"
        } else {
            "largest count"
        },
    );
    let mut md = format!(
        "# {title}\n\nrelMSE = mean (x − r)² / (r² + 0.01). Beauty against the reference; caustic and indirect terms against {basis}.\n\n\
         {first_cols}| time (s) | beauty relMSE | caustic relMSE | indirect relMSE |\n|{}---:|---:|---:|---:|\n",
        if timed { "---:|---:|---:|" } else { "---:|" }
    );
    let f = fmt_rel_mse;
    for r in rows {
        let first = match (r.budget_s, r.passes) {
            (Some(b), p) => format!("| {b} | {} | {} ", p.unwrap_or(0), r.photons),
            _ => format!("| {} ", r.photons),
        };
        md += &format!(
            "{first}| {:.2} | {} | {} | {} |\n",
            r.time_s,
            f(r.beauty),
            f(r.caustic),
            f(r.indirect)
        );
    }
    let noise_note = setting.reference_noise.map(|v| {
        format!(
            "Dashed line: the reference's own noise, relMSE {v:.2e} (from the JSON beside the \
             reference); the beauty's error cannot be measured below it."
        )
    });
    for note in footnote(rows).iter().chain(&noise_note) {
        md += &format!("\n{note}\n");
    }
    md += &format!(
        "\nChart `converge.png`: x = {}, y = relMSE; {} = beauty, {} = caustic, {} = indirect.\n",
        x_label(rows),
        PALETTE[0].0,
        PALETTE[1].0,
        PALETTE[2].0
    );
    let dirs = CreatedDirs::create(out_dir)
        .map_err(|e| option("-o", format!("cannot create '{}': {e}", out_dir.display())))?;
    let mut set = OutputSet::new();
    set.stage_bytes(&out_dir.join("converge.md"), md.as_bytes())?;
    let json = serde_json::json!(rows.iter().map(|r| serde_json::json!({"photons": r.photons, "budget_s": r.budget_s, "passes": r.passes, "time_s": r.time_s, "beauty": r.beauty, "caustic": r.caustic, "indirect": r.indirect})).collect::<Vec<_>>());
    set.stage_bytes(
        &out_dir.join("converge.json"),
        serde_json::to_string_pretty(&json)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    let notes: Vec<String> = missing_values_note(rows)
        .into_iter()
        .chain(noise_note)
        .collect();
    stage_chart(
        &mut set,
        rows,
        setting,
        &notes,
        &out_dir.join("converge.png"),
    )?;
    if cancel.load(Ordering::SeqCst) {
        return Err(Error::Interrupted);
    }
    set.commit()?;
    dirs.keep();
    Ok(())
}

fn stage_chart(
    set: &mut OutputSet,
    rows: &[ConvergeRow],
    setting: &Setting,
    notes: &[String],
    path: &Path,
) -> Result<()> {
    let mk = |name: &str, f: &dyn Fn(&ConvergeRow) -> f64| Series {
        name: name.into(),
        points: rows.iter().map(|r| (x_of(r), f(r))).collect(),
    };
    let series = [
        mk("beauty", &|r| r.beauty),
        mk("caustic term", &|r| r.caustic),
        mk("indirect term", &|r| r.indirect),
    ];
    let levels: Vec<Level> = setting
        .reference_noise
        .map(|y| Level {
            name: "reference's own noise".into(),
            y,
        })
        .into_iter()
        .collect();
    let chart = LogLogChart {
        title: format!(
            "{} convergence — {}, method {}, {} spp",
            if rows.iter().any(|r| r.budget_s.is_some()) {
                "Time-budget"
            } else {
                "Photon-count"
            },
            setting.scene,
            setting.method.name(),
            setting.spp
        ),
        x_label: x_label(rows),
        y_label: "relMSE",
        series: &series,
        levels: &levels,
        notes,
    };
    stage_log_log_png(set, path, &chart)
}

/// A row's place on the chart's x axis: its time budget, else its photon count.
fn x_of(r: &ConvergeRow) -> f64 {
    r.budget_s.unwrap_or(r.photons as f64)
}

fn x_label(rows: &[ConvergeRow]) -> &'static str {
    if rows.iter().any(|r| r.budget_s.is_some()) {
        "time budget (s)"
    } else {
        "photons"
    }
}
