//! Photon-count convergence: render at several photon counts and chart the error of the image and of
//! its caustic and indirect terms against the count.
//!
//! The beauty is compared with the given reference. The terms are compared with the reference's
//! `caustic` / `indirect` layers when it has them (a pmrender EXR at a high count), else with the terms
//! of the render at the largest count (self-convergence).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use crate::chart::{log_log_png, Series, PALETTE};
use crate::error::{in_file, option, Result};
use crate::io::atomic::write_bytes;
use crate::io::output::{read_layer, Image};
use crate::render::{render, Options, Progress};
use crate::scene::{Method, Scene};

/// relMSE = mean over pixels and channels of (x − r)² / (r² + 0.01).
pub fn rel_mse(img: &Image, reference: &Image) -> f64 {
    let mut s = 0.0f64;
    for (a, r) in img.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (a, r) = (a[c] as f64, r[c] as f64);
            s += (a - r).powi(2) / (r * r + 0.01);
        }
    }
    s / (3.0 * img.pixels.len().max(1) as f64)
}

pub struct ConvergeRow {
    pub photons: usize,
    pub time_s: f64,
    pub beauty: f64,
    pub caustic: f64,
    pub indirect: f64,
}

fn layer<'a>(layers: &'a [(&'static str, Image)], name: &str) -> Option<&'a Image> {
    layers.iter().find(|(n, _)| *n == name).map(|(_, i)| i)
}

/// What a convergence run renders, against what, and where its outputs go.
pub struct Study<'a> {
    /// Photon counts, each the target of both the global and the caustic map.
    pub counts: &'a [usize],
    /// The reference image (an EXR; its `caustic` and `indirect` layers are used when present).
    pub reference: &'a Path,
    pub method: Method,
    /// Where `converge.md`, `converge.json` and `converge.png` are written.
    pub out_dir: &'a Path,
}

/// Renders at each of the study's counts and writes `converge.md`, `converge.json` and
/// `converge.png` into its `out_dir`. `cancel` interrupts the renders (`Interrupted`, nothing
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
        reference,
        method,
        out_dir,
    } = *study;
    let reference_img = read_layer(reference, None).map_err(|e| in_file(reference, e))?;
    let ref_terms = ["caustic", "indirect"].map(|n| read_layer(reference, Some(n)).ok());
    let mut opts = opts.clone();
    opts.method = Some(method);
    opts.width = Some(reference_img.width);
    opts.height = Some(reference_img.height);
    let mut renders = Vec::new();
    for &n in counts {
        scene.settings.photons.global = Some(n);
        scene.settings.photons.caustic = Some(if scene.has_specular() { n } else { 0 });
        let t = Instant::now();
        let (out, _) = render(scene, &opts, progress, cancel)?;
        renders.push((n, t.elapsed().as_secs_f64(), out));
    }
    let Some((_, _, last)) = renders.last() else {
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
        .map(|(i, (n, t, out))| {
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
                time_s: *t,
                beauty: rel_mse(&out.beauty, &reference_img),
                caustic: term_err(0, "caustic"),
                indirect: term_err(1, "indirect"),
            }
        })
        .collect();
    write_outputs(&rows, ref_terms.iter().any(Option::is_some), out_dir)?;
    Ok(rows)
}

fn write_outputs(rows: &[ConvergeRow], terms_from_reference: bool, out_dir: &Path) -> Result<()> {
    let basis = if terms_from_reference {
        "the reference's layers"
    } else {
        "the render at the largest count (self-convergence)"
    };
    let mut md = format!(
        "# Photon-count convergence\n\nrelMSE = mean (x − r)² / (r² + 0.01). Beauty against the reference; caustic and indirect terms against {basis}.\n\n\
         | photons | time (s) | beauty relMSE | caustic relMSE | indirect relMSE |\n|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        let f = |x: f64| {
            if x.is_finite() {
                format!("{x:.5}")
            } else {
                "—".to_string()
            }
        };
        md += &format!(
            "| {} | {:.2} | {} | {} | {} |\n",
            r.photons,
            r.time_s,
            f(r.beauty),
            f(r.caustic),
            f(r.indirect)
        );
    }
    md += &format!("\nChart `converge.png`: x = photons, y = relMSE; {} = beauty, {} = caustic, {} = indirect.\n", PALETTE[0].0, PALETTE[1].0, PALETTE[2].0);
    write_bytes(&out_dir.join("converge.md"), md.as_bytes())?;
    let json = serde_json::json!(rows.iter().map(|r| serde_json::json!({"photons": r.photons, "time_s": r.time_s, "beauty": r.beauty, "caustic": r.caustic, "indirect": r.indirect})).collect::<Vec<_>>());
    write_bytes(
        &out_dir.join("converge.json"),
        serde_json::to_string_pretty(&json)
            .unwrap_or_default()
            .as_bytes(),
    )?;
    let mk = |f: &dyn Fn(&ConvergeRow) -> f64| Series {
        points: rows.iter().map(|r| (r.photons as f64, f(r))).collect(),
    };
    let series = [mk(&|r| r.beauty), mk(&|r| r.caustic), mk(&|r| r.indirect)];
    log_log_png(&out_dir.join("converge.png"), &series, &[])
}
