//! Log–log charts written as PNG (the convergence chart), drawn with `plotters`: a title, axes with
//! titles and decade ticks, one coloured line with markers per series, dashed horizontal levels (e.g. a
//! reference's own noise), and below the plot a legend with each series' fitted slope and any notes.
//!
//! Text is drawn with the DejaVu Sans bundled in `assets/fonts/` (not a system font), so every machine
//! writes the same PNG.

mod axis;
mod text;

use std::path::Path;

use ab_glyph::FontRef;
use plotters::coord::CoordTranslate;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};

use self::text::Style;

use crate::error::{runtime, Result};
use crate::io::atomic::OutputSet;
use crate::io::oiio::{self, Pixels};

/// One series of the chart.
pub struct Series {
    pub name: String,
    /// `(x, y)`; points that a log axis cannot show (NaN, infinite, ≤ 0) are not drawn and are named
    /// in the legend.
    pub points: Vec<(f64, f64)>,
}

/// A dashed horizontal line across the plot, e.g. the noise of a reference image.
pub struct Level {
    pub name: String,
    pub y: f64,
}

pub struct LogLogChart<'a> {
    pub title: String,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [Series],
    pub levels: &'a [Level],
    /// Sentences printed under the legend (why a point is missing, what the levels are).
    pub notes: &'a [String],
}

/// Width and height of every chart, in pixels.
pub const SIZE: (u32, u32) = (960, 720);

/// Colours of the series, in order (matplotlib's, as in `make chart`'s figures).
pub const PALETTE: [(&str, [f32; 3]); 6] = [
    ("blue", [0.12, 0.47, 0.71]),
    ("orange", [1.0, 0.5, 0.05]),
    ("green", [0.17, 0.63, 0.17]),
    ("red", [0.84, 0.15, 0.16]),
    ("purple", [0.58, 0.4, 0.74]),
    ("brown", [0.55, 0.34, 0.29]),
];

const LEGEND_ROW_PX: i32 = 28;
const NOTE_ROW_PX: i32 = 22;
const TITLE_PX: i32 = 52;
const LEFT_PX: i32 = 104;
const GREY: RGBColor = RGBColor(100, 100, 100);

fn colour(k: usize) -> RGBColor {
    let c = PALETTE[k % PALETTE.len()]
        .1
        .map(|v| (v * 255.0).round() as u8);
    RGBColor(c[0], c[1], c[2])
}

type Area<'b> = DrawingArea<BitMapBackend<'b>, Shift>;

fn drawing<E: std::fmt::Display>(e: E) -> crate::error::Error {
    runtime(format!("chart: {e}"))
}

/// Draws `chart` into a PNG of [`SIZE`] at `path`, written atomically.
pub fn log_log_png(path: &Path, chart: &LogLogChart) -> Result<()> {
    let mut set = OutputSet::new();
    stage_log_log_png(&mut set, path, chart)?;
    set.commit()
}

/// [`log_log_png`] staged in `set`, to appear with the set's other outputs.
pub fn stage_log_log_png(set: &mut OutputSet, path: &Path, chart: &LogLogChart) -> Result<()> {
    let font = text::font()?;
    let (w, h) = SIZE;
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        draw(&root, &font, chart)?;
        root.present().map_err(drawing)?;
    }
    set.stage(path, |tmp| {
        oiio::write(tmp, w, h, &["R", "G", "B"], Pixels::U8(&rgb))
    })
}

/// One legend row: a series (colour and marker) or a level (dashed grey).
enum Key {
    Series(usize),
    Level,
}

fn draw(root: &Area, font: &FontRef<'static>, chart: &LogLogChart) -> Result<()> {
    root.fill(&WHITE).map_err(drawing)?;
    let style = |size_px, colour| Style {
        font,
        size_px,
        colour,
    };
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    style(26.0, BLACK).draw(
        root,
        &chart.title,
        (w / 2, 14),
        (HPos::Center, VPos::Top),
        false,
    )?;

    let note_style = style(16.0, GREY);
    let notes: Vec<String> = chart
        .notes
        .iter()
        .flat_map(|n| note_style.wrap(n, (w - LEFT_PX - 24) as f32))
        .collect();
    let mut rows: Vec<(Key, String)> = chart
        .series
        .iter()
        .enumerate()
        .map(|(k, s)| (Key::Series(k), axis::legend_text(s)))
        .collect();
    rows.extend(
        chart
            .levels
            .iter()
            .map(|l| (Key::Level, axis::level_text(l))),
    );
    let legend_px = 28 + LEGEND_ROW_PX * rows.len() as i32 + NOTE_ROW_PX * notes.len() as i32;
    let plot_bottom = (h - legend_px).max(TITLE_PX + 240);
    let plot = root
        .clone()
        .shrink((0, TITLE_PX), (w, plot_bottom - TITLE_PX));
    draw_plot(&plot, root, font, chart)?;

    let row_style = style(18.0, BLACK);
    let left = (HPos::Left, VPos::Center);
    let mut y = plot_bottom + 8 + LEGEND_ROW_PX / 2;
    for (key, text) in &rows {
        let x = LEFT_PX;
        match *key {
            Key::Series(k) => {
                let line = PathElement::new(vec![(x, y), (x + 44, y)], colour(k).stroke_width(3));
                root.draw(&line).map_err(drawing)?;
                draw_marker(root, k, (x + 22, y))?;
            }
            Key::Level => {
                let dash =
                    DashedPathElement::new(vec![(x, y), (x + 44, y)], 10, 6, GREY.stroke_width(2));
                root.draw(&dash).map_err(drawing)?;
            }
        }
        row_style.draw(root, text, (x + 58, y), left, false)?;
        y += LEGEND_ROW_PX;
    }
    y += 6 + NOTE_ROW_PX / 2 - LEGEND_ROW_PX / 2;
    for note in &notes {
        note_style.draw(root, note, (LEFT_PX, y), left, false)?;
        y += NOTE_ROW_PX;
    }
    Ok(())
}

/// The axes, grid, levels and series on `plot`; their text on `root` (plotters' tick labels are left
/// empty: see [`text`]).
fn draw_plot(plot: &Area, root: &Area, font: &FontRef<'static>, chart: &LogLogChart) -> Result<()> {
    let levels: Vec<&Level> = chart
        .levels
        .iter()
        .filter(|l| axis::drawable(l.y))
        .collect();
    let (x_range, y_range) = axis::ranges(chart.series, &levels);
    let mut ctx = ChartBuilder::on(plot)
        .margin_top(8)
        .margin_right(24)
        .x_label_area_size(64)
        .y_label_area_size(LEFT_PX)
        .build_cartesian_2d(
            (x_range.0..x_range.1).log_scale(),
            (y_range.0..y_range.1).log_scale(),
        )
        .map_err(drawing)?;
    ctx.configure_mesh()
        .x_labels(20)
        .y_labels(20)
        .x_label_formatter(&|_| String::new())
        .y_label_formatter(&|_| String::new())
        .bold_line_style(RGBColor(222, 222, 222))
        .light_line_style(TRANSPARENT)
        .axis_style(BLACK)
        .draw()
        .map_err(drawing)?;

    let (xs, ys) = ctx.plotting_area().get_pixel_range();
    let tick = Style {
        font,
        size_px: 17.0,
        colour: BLACK,
    };
    for v in axis::ticks(x_range) {
        let (px, _) = ctx.backend_coord(&(v, y_range.0));
        let at = (px, ys.end + 10);
        tick.draw(
            root,
            &axis::tick_label(v),
            at,
            (HPos::Center, VPos::Top),
            false,
        )?;
    }
    for v in axis::ticks(y_range) {
        let (_, py) = ctx.backend_coord(&(x_range.0, v));
        let at = (xs.start - 10, py);
        tick.draw(
            root,
            &axis::tick_label(v),
            at,
            (HPos::Right, VPos::Center),
            false,
        )?;
    }
    let title = Style {
        size_px: 20.0,
        ..tick
    };
    let centre = ((xs.start + xs.end) / 2, (ys.start + ys.end) / 2);
    let below = (centre.0, ys.end + 38);
    title.draw(root, chart.x_label, below, (HPos::Center, VPos::Top), false)?;
    let beside = (xs.start - LEFT_PX + 4, centre.1);
    title.draw(root, chart.y_label, beside, (HPos::Center, VPos::Top), true)?;

    for level in levels {
        let ends = [(x_range.0, level.y), (x_range.1, level.y)];
        ctx.draw_series(DashedLineSeries::new(ends, 10, 6, GREY.stroke_width(2)))
            .map_err(drawing)?;
    }
    for (k, s) in chart.series.iter().enumerate() {
        let points: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|&(x, y)| axis::drawable(x) && axis::drawable(y))
            .collect();
        let style = colour(k).stroke_width(3);
        ctx.draw_series(LineSeries::new(points.iter().copied(), style))
            .map_err(drawing)?;
        for &p in &points {
            draw_marker(ctx.plotting_area(), k, p)?;
        }
    }
    Ok(())
}

/// Draws a filled marker, its shape by series (circle, triangle, square, cross) so that the series
/// stay apart in greyscale print too.
fn draw_marker<CT>(area: &DrawingArea<BitMapBackend<'_>, CT>, k: usize, at: CT::From) -> Result<()>
where
    CT: CoordTranslate,
    CT::From: Clone,
{
    let (c, size) = (colour(k), 6);
    let style = c.filled();
    match k % 4 {
        0 => area.draw(&Circle::new(at, size, style)),
        1 => area.draw(&TriangleMarker::new(at, size + 2, style)),
        2 => area
            .draw(&(EmptyElement::at(at) + Rectangle::new([(-size, -size), (size, size)], style))),
        _ => area.draw(&Cross::new(at, size, c.stroke_width(3))),
    }
    .map_err(drawing)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart_with(series: &[Series], levels: &[Level], notes: &[String]) -> Vec<f32> {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("c.png");
        let chart = LogLogChart {
            title: "Convergence — test".into(),
            x_label: "photons",
            y_label: "relMSE",
            series,
            levels,
            notes,
        };
        log_log_png(&path, &chart).unwrap();
        let img = oiio::read(&path).unwrap();
        assert_eq!((img.width, img.height, img.channels), (SIZE.0, SIZE.1, 3));
        img.data
    }

    #[test]
    fn writes_a_png_of_the_stated_size_with_something_drawn() {
        let series = [
            Series {
                name: "beauty".into(),
                points: vec![(1e4, 0.02), (1e5, 0.014)],
            },
            Series {
                name: "caustic term".into(),
                points: vec![(1e4, 3e-3), (1e5, f64::NAN)],
            },
        ];
        let levels = [Level {
            name: "reference noise".into(),
            y: 7.8e-5,
        }];
        let data = chart_with(
            &series,
            &levels,
            &["A note long enough to wrap. ".repeat(8)],
        );
        let dark = data.chunks_exact(3).filter(|p| p[0] < 0.5).count();
        assert!(dark > 2000, "only {dark} dark pixels");
    }

    #[test]
    fn draws_without_any_drawable_point() {
        let series = [Series {
            name: "empty".into(),
            points: vec![(0.0, f64::NAN), (f64::INFINITY, -1.0)],
        }];
        chart_with(&series, &[], &[]);
        chart_with(&[], &[], &[]);
    }
}
