//! Log–log line charts written as PNG (convergence and speed–accuracy charts): decade grid lines with
//! tick labels, one coloured polyline with markers per series; the series' names and numbers go in the
//! table written beside the chart.

mod font;

use std::path::Path;

use glam::Vec3;

use crate::error::Result;
use crate::io::output::{write_png, Image};

/// One polyline; its name goes in the table beside the chart, with its colour from [`PALETTE`].
pub struct Series {
    pub points: Vec<(f64, f64)>,
}

/// Colours of the series, in order (also listed in the table beside the chart).
pub const PALETTE: [(&str, [f32; 3]); 6] = [
    ("blue", [0.12, 0.47, 0.71]),
    ("orange", [1.0, 0.5, 0.05]),
    ("green", [0.17, 0.63, 0.17]),
    ("red", [0.84, 0.15, 0.16]),
    ("purple", [0.58, 0.4, 0.74]),
    ("brown", [0.55, 0.34, 0.29]),
];

struct Canvas {
    img: Image,
}

impl Canvas {
    fn set(&mut self, x: i32, y: i32, c: Vec3) {
        if x >= 0 && y >= 0 && (x as u32) < self.img.width && (y as u32) < self.img.height {
            self.img.pixels[(y as u32 * self.img.width + x as u32) as usize] = c;
        }
    }

    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: Vec3, thick: i32) {
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()) as i32).max(1);
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            let (x, y) = (x0 + (x1 - x0) * t, y0 + (y1 - y0) * t);
            for d in -(thick / 2)..=(thick / 2) {
                for e in -(thick / 2)..=(thick / 2) {
                    self.set(x as i32 + d, y as i32 + e, c);
                }
            }
        }
    }
}

fn decades(lo: f64, hi: f64) -> (f64, f64) {
    (
        lo.log10().floor(),
        hi.log10().ceil().max(lo.log10().floor() + 1.0),
    )
}

fn label(exp: f64) -> String {
    format!("1e{}", exp as i32)
}

/// Draws the series on log–log axes, marking with a ring the points of `front` (e.g. a Pareto front).
pub fn log_log_png(path: &Path, series: &[Series], front: &[(f64, f64)]) -> Result<()> {
    let (w, h) = (800u32, 560u32);
    let (left, right, top, bottom) = (70.0, 20.0, 20.0, 50.0);
    let pts: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
        .collect();
    let mut c = Canvas {
        img: Image {
            width: w,
            height: h,
            pixels: vec![Vec3::ONE; (w * h) as usize],
        },
    };
    if pts.is_empty() {
        return write_png(path, &c.img);
    }
    let (x_lo, x_hi) = decades(
        pts.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p.0).fold(0.0, f64::max),
    );
    let (y_lo, y_hi) = decades(
        pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
        pts.iter().map(|p| p.1).fold(0.0, f64::max),
    );
    let px = |x: f64| left + (x.log10() - x_lo) / (x_hi - x_lo) * (w as f64 - left - right);
    let py = |y: f64| top + (y_hi - y.log10()) / (y_hi - y_lo) * (h as f64 - top - bottom);
    let grey = Vec3::splat(0.85);
    let black = Vec3::ZERO;
    for e in (x_lo as i32)..=(x_hi as i32) {
        let x = px(10f64.powi(e));
        c.line((x, top), (x, h as f64 - bottom), grey, 1);
        let s = label(e as f64);
        font::draw_text(
            &s,
            x as i32 - font::text_width(&s, 2) / 2,
            h as i32 - bottom as i32 + 10,
            2,
            &mut |a, b| c.set(a, b, black),
        );
    }
    for e in (y_lo as i32)..=(y_hi as i32) {
        let y = py(10f64.powi(e));
        c.line((left, y), (w as f64 - right, y), grey, 1);
        let s = label(e as f64);
        font::draw_text(&s, 4, y as i32 - 5, 2, &mut |a, b| c.set(a, b, black));
    }
    c.line((left, top), (left, h as f64 - bottom), black, 1);
    c.line(
        (left, h as f64 - bottom),
        (w as f64 - right, h as f64 - bottom),
        black,
        1,
    );
    for (k, s) in series.iter().enumerate() {
        let col = Vec3::from(PALETTE[k % PALETTE.len()].1);
        let valid: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| *x > 0.0 && *y > 0.0)
            .collect();
        for pair in valid.windows(2) {
            c.line(
                (px(pair[0].0), py(pair[0].1)),
                (px(pair[1].0), py(pair[1].1)),
                col,
                2,
            );
        }
        for &(x, y) in &valid {
            for d in -3..=3 {
                c.line(
                    (px(x) - 3.0, py(y) + d as f64),
                    (px(x) + 3.0, py(y) + d as f64),
                    col,
                    1,
                );
            }
        }
    }
    for &(x, y) in front {
        let (cx, cy) = (px(x), py(y));
        for i in 0..64 {
            let a = i as f64 / 64.0 * std::f64::consts::TAU;
            c.set(
                (cx + 7.0 * a.cos()) as i32,
                (cy + 7.0 * a.sin()) as i32,
                black,
            );
        }
    }
    write_png(path, &c.img)
}
