//! A still rendered as tiles shaded apart: one bake (the photon maps and pass A over the whole
//! image, [`baked::bake_apart`]), then each tile shaded from it alone ([`baked::render_baked`] with
//! the tile as its crop) and pasted into the image. The records pass B makes for a tile serve that
//! tile only, so a tiled image may differ from the untiled one where pass B made records; but it is
//! the same whoever shades the tiles, in whatever order — the command line's `--tiles N` and a farm's
//! tiles give the same pixels by construction.

use std::sync::atomic::AtomicBool;

use super::baked::{bake_apart, render_baked_seen_by, Baked};
use super::tiles::Window;
use super::{Options, RenderOutput, RenderStats};
use crate::camera::Camera;
use crate::error::{option, Result};
use crate::io::output::Image;
use crate::progress::Progress;
use crate::scene::Scene;

/// The tiles of a `width` × `height` image split `n` ways: bands of whole rows, from the top, their
/// heights differing by one row at most (no more bands than rows).
pub fn tile_windows(width: u32, height: u32, n: u32) -> Vec<Window> {
    let n = n.clamp(1, height.max(1));
    (0..n)
        .map(|i| Window {
            x0: 0,
            y0: (u64::from(height) * u64::from(i) / u64::from(n)) as u32,
            x1: width,
            y1: (u64::from(height) * u64::from(i + 1) / u64::from(n)) as u32,
        })
        .collect()
}

/// Renders `scene` as `n` tiles shaded apart from one bake; the statistics are the bake's, with the
/// tiles' shading summed.
pub fn render_tiled(
    scene: &Scene,
    opts: &Options,
    n: u32,
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    super::progressive::refuse_in_bake(scene, opts, "--tiles")?;
    if opts.crop.is_some() {
        return Err(option(
            "--tiles",
            "renders the whole image: leave out --crop",
        ));
    }
    // `path` has nothing to bake: its tiles are crops of the image.
    let baked = match super::plan::method(scene, opts).uses_photon_maps() {
        true => Some(bake_apart(scene, opts, progress, cancel)?),
        false => None,
    };
    let (baked, stats) = baked.unzip();
    shade_tiles(
        scene,
        opts,
        baked.as_ref(),
        None,
        (n, stats),
        progress,
        cancel,
    )
}

/// The image seen by a walk's frame `view` (its camera and number; else by the scene's camera) as `n` tiles, each shaded apart from
/// `baked` (for `path`: none, each tile a crop of the render) and pasted in; the statistics are
/// `stats` (the bake's; else new), with the tiles' shading summed.
pub(super) fn shade_tiles(
    scene: &Scene,
    opts: &Options,
    baked: Option<&Baked>,
    view: Option<(&Camera, u32)>,
    (n, stats): (u32, Option<RenderStats>),
    progress: &dyn Progress,
    cancel: &AtomicBool,
) -> Result<(RenderOutput, RenderStats)> {
    let camera = view.map(|(c, _)| c);
    let plan = super::plan(scene, opts, camera)?;
    let mut stats = stats.unwrap_or_else(|| RenderStats::new(scene, &plan));
    let mut image: Option<RenderOutput> = None;
    for window in tile_windows(plan.width, plan.height, n) {
        let cropped = Options {
            crop: Some(window),
            ..opts.clone()
        };
        let (tile, s) = match baked {
            Some(b) => render_baked_seen_by(scene, &cropped, b, view, progress, cancel)?,
            None => super::render_seen_by(scene, &cropped, camera, progress, cancel)?,
        };
        stats.shade.add(&s.shade);
        match &mut image {
            None => image = Some(tile),
            Some(out) => paste(out, &tile, window),
        }
    }
    stats.total_s += stats.shade.time_s;
    // At least one tile: `tile_windows` makes one or more.
    image
        .map(|out| (out, stats))
        .ok_or_else(|| option("--tiles", "no tile"))
}

/// `window`'s pixels of `tile` copied into `out` (the beauty and each layer).
fn paste(out: &mut RenderOutput, tile: &RenderOutput, window: Window) {
    copy_window(&mut out.beauty, &tile.beauty, window);
    for ((_, to), (_, from)) in out.layers.iter_mut().zip(&tile.layers) {
        copy_window(to, from, window);
    }
}

fn copy_window(to: &mut Image, from: &Image, w: Window) {
    let width = to.width as usize;
    for y in w.y0 as usize..w.y1 as usize {
        let row = y * width + w.x0 as usize..y * width + w.x1 as usize;
        to.pixels[row.clone()].copy_from_slice(&from.pixels[row]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_every_row_once() {
        for (h, n) in [(48, 4), (7, 3), (5, 9), (1, 1), (1000, 7)] {
            let t = tile_windows(64, h, n);
            assert_eq!(t.len() as u32, n.min(h));
            assert_eq!(t[0].y0, 0);
            assert_eq!(t.last().unwrap().y1, h);
            assert!(t
                .windows(2)
                .all(|p| p[0].y1 == p[1].y0 && p[0].y0 < p[0].y1));
        }
    }
}
