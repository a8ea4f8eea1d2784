//! The statistics report of a render: its rows, phase by phase, as the table and the JSON show them.

use super::*;

impl RenderStats {
    /// The report: pbrt-style rows, in the order of the printed table.
    pub fn report(&self) -> Report {
        let mut r = Report::default();
        r.text(
            "Render",
            "Method",
            "render.method",
            self.setup.method.name(),
        );
        if let Some(f) = &self.frame {
            frame_rows(&mut r, f);
        }
        if let Some(p) = &self.photons {
            photon_rows(&mut r, p);
        }
        if let Some(f) = &self.fill {
            if let Some(t) = f.time_s {
                let label = if f.one_pass {
                    "Fill cache (one pass)"
                } else {
                    "Fill cache (pass A)"
                };
                r.seconds("Time", label, "time.fill_cache_s", t);
            }
        }
        if let Some(m) = &self.media_fill {
            r.seconds(
                "Time",
                "Fill media cache (pass A)",
                "time.fill_media_s",
                m.time_s,
            );
        }
        r.seconds("Time", "Shade", "time.shade_s", self.shade.time_s);
        if self.setup.method.uses_photon_maps() {
            self.photon_method_rows(&mut r);
        } else if self.setup.method.is_occlusion() {
            self.cache_and_gather_rows(&mut r);
        }
        if let Some(p) = &self.progressive {
            progressive_rows(&mut r, p);
        }
        r.seconds("Time", "Total", "time.total_s", self.total_s);
        self.ray_rows(&mut r);
        self.image_rows(&mut r);
        let c = self.counters();
        r.count(
            "Rare events",
            "NaN or negative radiance",
            "rare.nan_or_negative",
            c.nan_or_negative,
        );
        r.count(
            "Rare events",
            "Zero-pdf samples",
            "rare.zero_pdf",
            c.zero_pdf,
        );
        r.count(
            "Rare events",
            "Rays given up at the boundary-crossing limit",
            "rare.crossings_given_up",
            self.crossings_given_up,
        );
        for (title, key, n) in [
            ("Triangles", "scene.triangles", self.setup.n_triangles),
            (
                "Degenerate triangles dropped",
                "scene.degenerate_triangles",
                self.setup.n_degenerate,
            ),
            ("Lights", "scene.lights", self.setup.n_lights),
            ("Warnings", "scene.warnings", self.warnings().len() as u64),
        ] {
            r.count("Scene", title, key, n);
        }
        r.text(
            "Scene",
            "Ray kernels (Embree's instruction set)",
            "scene.ray_isa",
            self.setup.ray_isa,
        );
        r.bytes(
            "Memory",
            "Peak resident set",
            "memory.peak_rss_bytes",
            self.peak_rss_bytes,
        );
        if let Some(t) = self.write_outputs_s {
            r.seconds("Time", "Write outputs", "time.write_outputs_s", t);
        }
        r
    }

    /// Atlas, cache, final-gather and k-NN rows of the photon-map methods.
    fn photon_method_rows(&self, r: &mut Report) {
        let (shade, fill) = (&self.shade.counters, self.fill_counters());
        if let Some(s) = &self.atlas {
            atlas_rows(r, s);
        }
        if let Some((estimated, cells)) = self.volume_grid {
            r.count(
                "Photons",
                "Volume grid cells (for final-gather rays)",
                "photons.volume_grid_cells",
                cells as u64,
            );
            r.count(
                "Photons",
                "Volume grid cells estimated",
                "photons.volume_grid_estimates",
                estimated as u64,
            );
        }
        if let (Some(f), Some((records, bytes))) = (&self.media_fill, self.media_cache) {
            media_cache_rows(r, f, records, bytes, shade);
        }
        if let Some(g) = &self.glossy {
            glossy_rows(r, g);
        }
        self.cache_and_gather_rows(r);
        r.count(
            "Photons",
            "k-NN estimates while rendering (caustic, indirect)",
            "photons.estimates",
            fill.photon_estimates + shade.photon_estimates,
        );
    }

    /// The irradiance cache's rows (where there is one), the final gathers' and the shading's rays.
    fn cache_and_gather_rows(&self, r: &mut Report) {
        let (shade, fill) = (&self.shade.counters, self.fill_counters());
        if let (Some(cs), Some(f)) = (&self.cache, &self.fill) {
            if f.n_loaded > 0 {
                r.count(
                    "Irradiance cache",
                    "Records loaded from file",
                    "icache.records_loaded",
                    f.n_loaded,
                );
            }
            cache_rows(
                r,
                cs,
                &f.fill,
                fill.gather_rays + shade.gather_rays,
                &self.shade,
            );
        }
        self.gather_rows(r, &fill, shade);
        r.count(
            "Rays",
            "Rays while shading (camera, bounce, shadow, pass-B gathers)",
            "rays.shade",
            shade.rays + shade.shadow_rays,
        );
    }

    /// The final gathers' rows: gathers and rays in the fill and the shading, the rays chosen, the
    /// gathers' own noise.
    fn gather_rows(&self, r: &mut Report, fill: &SampleCounters, shade: &SampleCounters) {
        r.count(
            "Final gather",
            "Gathers",
            "gather.gathers",
            fill.gathers + shade.gathers,
        );
        r.count(
            "Final gather",
            "Gather rays",
            "gather.rays",
            fill.gather_rays + shade.gather_rays,
        );
        r.count(
            "Final gather",
            "Gather rays in the cache fill",
            "gather.rays_fill",
            fill.gather_rays,
        );
        if let Some((noise, rounds)) = self.fill.as_ref().and_then(|f| f.rays_choice) {
            let base = crate::render::gather_rays::BASE_RAYS;
            let title = format!(
                "Predicted gather-noise variance at {base} rays (target {:.0e})",
                crate::render::gather_rays::NOISE_TARGET
            );
            r.value(
                "Final gather",
                &title,
                "gather.predicted_noise",
                serde_json::Value::from(noise),
                format!("{noise:.2e}"),
            );
            r.count(
                "Final gather",
                "Rays per gather (chosen from that prediction)",
                "gather.rays_chosen",
                crate::render::gather_rays::rays_for_rounds(rounds) as u64,
            );
        }
        let mut noise = fill.gather_noise;
        noise += shade.gather_noise;
        if let (Some(mean), Some(p50), Some(p90)) =
            (noise.mean(), noise.quantile(0.5), noise.quantile(0.9))
        {
            r.number(
                "Final gather",
                "Gather noise: mean relative std error of E (own rays)",
                "gather.rel_err_mean",
                mean,
            );
            r.number(
                "Final gather",
                "Gather noise: median, at most",
                "gather.rel_err_p50",
                p50 as f64,
            );
            r.number(
                "Final gather",
                "Gather noise: 90th percentile, at most",
                "gather.rel_err_p90",
                p90 as f64,
            );
        }
    }

    /// Rays of the cache fill and the shading; their rate over the time of those two phases (the photon
    /// pass traces its own paths and is reported in its own rows).
    fn ray_rows(&self, r: &mut Report) {
        let c = self.counters();
        let rays = c.rays + c.shadow_rays;
        let seconds = self.shade.time_s + self.fill.as_ref().and_then(|f| f.time_s).unwrap_or(0.0);
        r.count("Rays", "Total", "rays.total", rays);
        r.count("Rays", "Camera and bounce rays", "rays.closest_hit", c.rays);
        r.count("Rays", "Shadow rays", "rays.shadow", c.shadow_rays);
        r.number(
            "Rays",
            "Rays per second",
            "rays.per_s",
            rays as f64 / seconds.max(1e-9),
        );
    }

    fn image_rows(&self, r: &mut Report) {
        let (s, n) = (&self.setup, &self.shade.samples);
        r.count("Image", "Width", "image.width", s.width as u64);
        r.count("Image", "Height", "image.height", s.height as u64);
        r.count(
            "Image",
            "Samples per pixel (most)",
            "image.spp",
            s.spp as u64,
        );
        r.number(
            "Image",
            "Noise target (0: fixed spp)",
            "image.noise",
            s.noise as f64,
        );
        if s.noise > 0.0 {
            r.count(
                "Image",
                "Samples per pixel without Monte Carlo estimates (most)",
                "image.aa_spp",
                s.aa_spp as u64,
            );
            r.count(
                "Image",
                "Monte Carlo pixels (area lights, glass, glossy, media)",
                "image.pixels_monte_carlo",
                n.monte_carlo_pixels,
            );
        }
        r.number(
            "Image",
            "Samples per pixel (mean)",
            "image.spp_mean",
            n.samples as f64 / n.pixels.max(1) as f64,
        );
        r.count(
            "Image",
            "Pixels at the sample limit",
            "image.pixels_at_limit",
            n.at_limit,
        );
        r.count("Image", "Samples", "image.samples", n.samples);
    }
}

/// A progressive render's passes: how many, why it stopped, the radius reached, the photons traced
/// and the noise left in each layer.
fn progressive_rows(r: &mut Report, p: &ProgressiveStats) {
    let cat = "Progressive";
    r.count(cat, "Passes", "progressive.passes", p.pass_s.len() as u64);
    r.text(cat, "Stopped by", "progressive.stopped", p.stopped.name());
    if let Some(b) = p.budget_s {
        r.seconds(cat, "Time budget", "progressive.budget_s", b);
    }
    if let Some(&last) = p.pass_s.last() {
        r.seconds(cat, "Last pass", "progressive.last_pass_s", last);
    }
    if let Some(f) = p.radius_fraction {
        r.number(
            cat,
            "Photon radius reached (of the first pass's)",
            "progressive.radius_fraction",
            f,
        );
        r.count(
            cat,
            "Photon paths traced",
            "progressive.photon_paths",
            p.photon_paths,
        );
        r.count(
            cat,
            "Photons stored",
            "progressive.photons_stored",
            p.photons_stored,
        );
    }
    for (layer, e) in &p.noise_relmse {
        r.value(
            cat,
            &format!("Noise relMSE, {layer} (spread between passes)"),
            &format!("progressive.noise_relmse.{layer}"),
            serde_json::Value::from(*e),
            format!("{e:.2e}"),
        );
    }
}
