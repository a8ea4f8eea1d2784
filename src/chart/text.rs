//! The charts' text, laid out and rasterised with `ab_glyph` from the DejaVu Sans bundled in
//! `assets/fonts/`, so that every machine writes the same pixels.
//!
//! Plotters' own `ab_glyph` text places each glyph without its side bearing, which spaces letters
//! unevenly ("con vergence"); here each glyph sits at its advance, kerned, at sub-pixel positions.

use ab_glyph::{point, Font, FontRef, PxScale, ScaleFont};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::{register_font, FontStyle};

use super::{drawing, Area};
use crate::error::{runtime, Result};

const DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The bundled font. It is also registered with plotters (as `sans-serif`), which lays out its
/// (empty) tick labels with it and would otherwise fail to.
pub fn font() -> Result<FontRef<'static>> {
    let unreadable = || runtime("chart: the bundled font DejaVuSans.ttf cannot be read");
    register_font("sans-serif", FontStyle::Normal, DEJAVU_SANS).map_err(|_| unreadable())?;
    FontRef::try_from_slice(DEJAVU_SANS).map_err(|_| unreadable())
}

/// Text of one size and colour.
#[derive(Clone, Copy)]
pub struct Style<'f> {
    pub font: &'f FontRef<'static>,
    pub size_px: f32,
    pub colour: RGBColor,
}

impl Style<'_> {
    /// Advance width of `text` in pixels.
    pub fn width(&self, text: &str) -> f32 {
        let scaled = self.font.as_scaled(PxScale::from(self.size_px));
        let mut caret = 0.0;
        let mut prev = None;
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(p) = prev {
                caret += scaled.kern(p, id);
            }
            caret += scaled.h_advance(id);
            prev = Some(id);
        }
        caret
    }

    /// Draws `text` on `area` with its anchor point at `at` (pixels of `area`); `upright` turns it a
    /// quarter turn anticlockwise (a y-axis title), the anchor then read along the turned text.
    pub fn draw(
        &self,
        area: &Area,
        text: &str,
        at: (i32, i32),
        (h, v): (HPos, VPos),
        upright: bool,
    ) -> Result<()> {
        let scale = PxScale::from(self.size_px);
        let scaled = self.font.as_scaled(scale);
        let x0 = match h {
            HPos::Left => 0.0,
            HPos::Center => -self.width(text) / 2.0,
            HPos::Right => -self.width(text),
        };
        // Baseline below the anchor: Center is the middle of the digits and capitals.
        let baseline = match v {
            VPos::Top => scaled.ascent(),
            VPos::Center => scaled.ascent() * 0.39,
            VPos::Bottom => scaled.descent(),
        };
        let mut caret = x0;
        let mut prev = None;
        for c in text.chars() {
            let id = scaled.glyph_id(c);
            if let Some(p) = prev {
                caret += scaled.kern(p, id);
            }
            let glyph = id.with_scale_and_position(scale, point(caret, baseline));
            caret += scaled.h_advance(id);
            prev = Some(id);
            let Some(outline) = self.font.outline_glyph(glyph) else {
                continue;
            };
            let min = outline.px_bounds().min;
            let mut pixels = Vec::new();
            outline.draw(|x, y, coverage| {
                let (dx, dy) = (min.x as i32 + x as i32, min.y as i32 + y as i32);
                let (dx, dy) = if upright { (dy, -dx) } else { (dx, dy) };
                pixels.push(((at.0 + dx, at.1 + dy), coverage.min(1.0)));
            });
            for (p, coverage) in pixels {
                area.draw_pixel(p, &self.colour.mix(coverage as f64))
                    .map_err(drawing)?;
            }
        }
        Ok(())
    }

    /// Splits `text` into lines no wider than `width_px` (a word wider than that stays whole).
    pub fn wrap(&self, text: &str, width_px: f32) -> Vec<String> {
        let mut lines = Vec::new();
        let mut line = String::new();
        for word in text.split_whitespace() {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if line.is_empty() || self.width(&candidate) <= width_px {
                line = candidate;
            } else {
                lines.push(std::mem::replace(&mut line, word.to_string()));
            }
        }
        if !line.is_empty() {
            lines.push(line);
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_to_the_width_and_keeps_every_word() {
        let font = font().unwrap();
        let style = Style {
            font: &font,
            size_px: 16.0,
            colour: BLACK,
        };
        let text = "relMSE against photons ".repeat(30);
        let lines = style.wrap(&text, 300.0);
        assert!(lines.len() > 3);
        assert!(lines.iter().all(|l| style.width(l) <= 300.0));
        assert_eq!(lines.join(" "), text.trim_end());
    }

    #[test]
    fn width_grows_with_text_and_size() {
        let font = font().unwrap();
        let at = |size_px| Style {
            font: &font,
            size_px,
            colour: BLACK,
        };
        assert!(at(16.0).width("10⁴") > at(16.0).width("10"));
        assert!((at(32.0).width("slope −0.52") / at(16.0).width("slope −0.52") - 2.0).abs() < 0.01);
        assert_eq!(at(16.0).width(""), 0.0);
    }
}
