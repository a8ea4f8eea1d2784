//! The render's image outputs: a layered float EXR (beauty in R,G,B; each term as `name.R` …) and an
//! sRGB PNG of the beauty, both written atomically.
#![forbid(unsafe_code)]

use std::path::Path;

use glam::Vec3;

use super::atomic::OutputSet;
use super::oiio::{self, Pixels};
use crate::error::Result;

/// An RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

impl Image {
    pub(crate) fn new(width: u32, height: u32) -> Image {
        Image {
            width,
            height,
            pixels: vec![Vec3::ZERO; width as usize * height as usize],
        }
    }
}

/// Beauty plus named layers (e.g. `direct`, `caustic`).
pub(crate) struct Layers<'a> {
    pub beauty: &'a Image,
    pub named: Vec<(&'a str, &'a Image)>,
}

/// Stages the layered EXR in `set` (renamed into place when the set commits).
pub(crate) fn stage_exr(set: &mut OutputSet, path: &Path, layers: &Layers) -> Result<()> {
    let (w, h) = (layers.beauty.width, layers.beauty.height);
    let mut names: Vec<String> = vec!["R".into(), "G".into(), "B".into()];
    for (n, _) in &layers.named {
        for c in ["R", "G", "B"] {
            names.push(format!("{n}.{c}"));
        }
    }
    let images: Vec<&Image> = std::iter::once(layers.beauty)
        .chain(layers.named.iter().map(|(_, i)| *i))
        .collect();
    let mut data = Vec::with_capacity(w as usize * h as usize * names.len());
    for i in 0..(w as usize * h as usize) {
        for img in &images {
            data.extend_from_slice(&img.pixels[i].to_array());
        }
    }
    let name_refs: Vec<&str> = names.iter().map(String::as_str).collect();
    set.stage(path, |tmp| {
        oiio::write(tmp, w, h, &name_refs, Pixels::F32(&data))
    })
}

fn srgb_encode(x: f32) -> u8 {
    let x = if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Stages the sRGB PNG of `image` in `set`.
pub(crate) fn stage_png(set: &mut OutputSet, path: &Path, image: &Image) -> Result<()> {
    let data: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(srgb_encode))
        .collect();
    set.stage(path, |tmp| {
        oiio::write(
            tmp,
            image.width,
            image.height,
            &["R", "G", "B"],
            Pixels::U8(&data),
        )
    })
}

/// Reads an EXR written by us (or any RGB image): the beauty layer, or the layer `name` (`name.R` …).
/// The decoded image's size is checked against the address space left before any pixel is read.
pub fn read_layer(path: &Path, name: Option<&str>) -> std::result::Result<Image, String> {
    let names = oiio::channel_names(path)?;
    let (w, h, c) = oiio::image_size(path)?;
    // The library's floats and their copy, then the copy and the layer's pixels.
    let floats = 4 * c as u64;
    crate::memory::check_address_space(
        &format!("reading its {w}×{h} pixels × {c} channels"),
        w as u64 * h as u64 * (2 * floats).max(floats + 12),
    )?;
    let img = oiio::read(path)?;
    let find = |c: &str| -> std::result::Result<usize, String> {
        let full = match name {
            Some(n) => format!("{n}.{c}"),
            None => c.to_string(),
        };
        names
            .iter()
            .position(|x| *x == full)
            .ok_or_else(|| format!("{}: no channel '{full}'", path.display()))
    };
    let (r, g, b) = (find("R")?, find("G")?, find("B")?);
    let nc = img.channels as usize;
    let pixels = img
        .data
        .chunks_exact(nc)
        .map(|px| Vec3::new(px[r], px[g], px[b]))
        .collect();
    Ok(Image {
        width: img.width,
        height: img.height,
        pixels,
    })
}
