//! The report's rows of each phase's statistics that need no more than that phase's part: a
//! sequence's frame, the atlas, the photon maps.

use super::*;

pub(super) fn frame_rows(r: &mut Report, f: &FrameStats) {
    r.count("Sequence", "Frame", "frame.index", f.frame as u64);
    r.text(
        "Sequence",
        "Photon maps",
        "frame.photons",
        match (f.no_photon_maps, f.photons_reused) {
            (true, _) => "none",
            (false, true) => "reused",
            (false, false) => "traced",
        },
    );
    if f.image_reused {
        r.text(
            "Sequence",
            "Image",
            "frame.image",
            "the frame before's (nothing changed)",
        );
    }
    r.count(
        "Sequence",
        "Cache records reused from earlier frames",
        "frame.records_reused",
        f.n_records_reused,
    );
    r.count(
        "Sequence",
        "Cache records dropped (too coarse for the view, or long out of it)",
        "frame.records_dropped",
        f.n_records_dropped,
    );
    r.count(
        "Sequence",
        "Of them in view but read by no pixel for as long",
        "frame.records_unread",
        f.n_records_unread,
    );
    if f.n_pixels_kept > 0 {
        r.count(
            "Sequence",
            "Pixels kept from the frame before (nothing they show changed)",
            "frame.pixels_kept",
            f.n_pixels_kept,
        );
        r.count(
            "Sequence",
            "Of them relit (only the cached light changed: indirect light scaled)",
            "frame.pixels_relit",
            f.n_pixels_relit,
        );
    }
    if let Some(t) = &f.temporal {
        temporal_rows(r, t);
    }
    r.count(
        "Sequence",
        "Cache records after the frame",
        "frame.records_after",
        f.n_records_after,
    );
}

/// What the temporal update did to a frame's records.
fn temporal_rows(r: &mut Report, t: &TemporalStats) {
    for (title, key, n) in [
        (
            "Records kept as they were (temporal gradient)",
            "frame.records_kept",
            t.n_kept,
        ),
        (
            "Records gathered again in place (expired or near a change)",
            "frame.records_regathered",
            t.n_regathered,
        ),
        (
            "Records replaced (changed beyond their noise)",
            "frame.records_replaced",
            t.n_replaced,
        ),
        (
            "Records moved with their mesh and replaced by a new gather",
            "frame.records_moved",
            t.n_moved,
        ),
        (
            "Records carried along with their mesh, irradiance kept",
            "frame.records_carried",
            t.n_carried,
        ),
        (
            "Records dropped (their surface moved)",
            "frame.records_gone",
            t.n_gone,
        ),
    ] {
        r.count("Sequence", title, key, n);
    }
    r.seconds(
        "Time",
        "Temporal update of the records",
        "time.temporal_update_s",
        t.update_s,
    );
}

/// The irradiance atlas's rows.
pub(super) fn atlas_rows(r: &mut Report, s: &AtlasStats) {
    r.count(
        "Photons",
        "Irradiance atlas texels",
        "photons.atlas_texels",
        s.slots,
    );
    r.count(
        "Photons",
        "Irradiance atlas texels estimated",
        "photons.atlas_estimates",
        s.estimates,
    );
    if s.carried > 0 {
        r.count(
            "Photons",
            "Irradiance atlas texels carried from the frame before",
            "photons.atlas_carried",
            s.carried,
        );
        r.count(
            "Photons",
            "… of them moved by the photons that entered or left their disc",
            "photons.atlas_updated",
            s.updated,
        );
    }
    r.count(
        "Photons",
        "Edge texels (direct light shaded where each ray lands)",
        "photons.atlas_edge_texels",
        s.edges,
    );
    r.count(
        "Photons",
        "Caustic estimates at texel middles (smooth caustics)",
        "photons.caustic_texel_estimates",
        s.caustic_estimates,
    );
    r.bytes(
        "Photons",
        "Memory, irradiance atlas",
        "photons.atlas_memory_bytes",
        s.memory_bytes,
    );
}

/// The photon trace's time and the maps' memory.
fn trace_cost_rows(r: &mut Report, s: &photon::TraceStats) {
    r.seconds("Photons", "Trace time", "photons.trace_s", s.trace_s);
    r.seconds(
        "Photons",
        "Build time (kd-trees)",
        "photons.build_s",
        s.global_build_s + s.caustic_build_s + s.volume_build_s,
    );
    r.bytes(
        "Photons",
        "Memory, global map",
        "photons.global_memory_bytes",
        s.global_memory_bytes,
    );
    r.bytes(
        "Photons",
        "Memory, caustic map",
        "photons.caustic_memory_bytes",
        s.caustic_memory_bytes,
    );
}

pub(super) fn photon_rows(r: &mut Report, p: &PhotonStats) {
    if p.loaded {
        r.seconds("Time", "Load photons", "time.load_photons_s", p.time_s);
    } else {
        r.seconds("Time", "Trace photons", "time.trace_photons_s", p.time_s);
    }
    let s = &p.trace;
    r.count(
        "Photons",
        "Paths emitted",
        "photons.paths_emitted",
        s.n_paths_emitted,
    );
    if s.n_paths_copied > 0 {
        r.count(
            "Photons",
            "Paths copied from the frame before (nothing that moved met them)",
            "photons.paths_copied",
            s.n_paths_copied,
        );
    }
    r.count(
        "Photons",
        "Global photons stored",
        "photons.global_stored",
        s.n_global_stored,
    );
    r.count(
        "Photons",
        "Caustic photons stored",
        "photons.caustic_stored",
        s.n_caustic_stored,
    );
    trace_cost_rows(r, s);
    if p.max_radius_volume > 0.0 {
        volume_photon_rows(r, p);
    }
    r.bytes(
        "Photons",
        "Memory",
        "photons.memory_bytes",
        s.global_memory_bytes
            + s.caustic_memory_bytes
            + s.volume_memory_bytes
            + s.volume_caustic_memory_bytes,
    );
    for (title, key, n) in [
        (
            "Paths dropped (non-finite)",
            "rare.photon_paths_dropped",
            s.n_paths_dropped,
        ),
        (
            "Caustic map stopped by its path budget",
            "photons.caustic_cut",
            s.n_caustic_cut,
        ),
        ("Lookup k", "photons.lookup", p.lookup as u64),
    ] {
        r.count("Photons", title, key, n);
    }
    r.number(
        "Photons",
        "Max radius (global)",
        "photons.max_radius_global",
        p.max_radius_global as f64,
    );
    r.number(
        "Photons",
        "Max radius (caustic)",
        "photons.max_radius_caustic",
        p.max_radius_caustic as f64,
    );
}

/// The volume photon maps' rows (scenes with media).
pub(super) fn volume_photon_rows(r: &mut Report, p: &PhotonStats) {
    let s = &p.trace;
    r.count(
        "Photons",
        "Volume photons stored",
        "photons.volume_stored",
        s.n_volume_stored,
    );
    r.count(
        "Photons",
        "Volume caustic photons stored (L S+ V)",
        "photons.volume_caustic_stored",
        s.n_volume_caustic_stored,
    );
    r.bytes(
        "Photons",
        "Memory, volume caustic map",
        "photons.volume_caustic_memory_bytes",
        s.volume_caustic_memory_bytes,
    );
    r.bytes(
        "Photons",
        "Memory, volume map",
        "photons.volume_memory_bytes",
        s.volume_memory_bytes,
    );
    r.number(
        "Photons",
        "Max radius (volume)",
        "photons.max_radius_volume",
        p.max_radius_volume as f64,
    );
    r.count(
        "Photons",
        "Global or volume map stopped by its path budget",
        "photons.media_cut",
        s.n_media_cut,
    );
}
