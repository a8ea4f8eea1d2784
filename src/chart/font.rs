//! A 3×5 pixel font for chart tick labels: digits, '.', '-', 'e', and a few letters for axis names.

/// Rows top to bottom, 3 bits each (bit 2 = left column).
fn glyph(c: char) -> Option<[u8; 5]> {
    Some(match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        '-' => [0, 0, 7, 0, 0],
        'e' => [0, 7, 7, 4, 7],
        's' => [0, 7, 4, 1, 7],
        'x' => [0, 5, 2, 5, 0],
        ' ' => [0, 0, 0, 0, 0],
        _ => return None,
    })
}

/// Calls `set(x, y)` for every lit pixel of `text` drawn at (x0, y0), each font pixel `scale`² pixels.
pub fn draw_text(text: &str, x0: i32, y0: i32, scale: i32, set: &mut dyn FnMut(i32, i32)) {
    for (i, c) in text.chars().enumerate() {
        let Some(g) = glyph(c) else { continue };
        let cx = x0 + i as i32 * 4 * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..scale {
                        for dx in 0..scale {
                            set(cx + col * scale + dx, y0 + row as i32 * scale + dy);
                        }
                    }
                }
            }
        }
    }
}

/// Width in pixels of `text` at `scale`.
pub fn text_width(text: &str, scale: i32) -> i32 {
    text.chars().count() as i32 * 4 * scale
}
