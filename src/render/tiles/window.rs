//! A rectangle of pixels, the unit the tile loop and a sequence's windows are given in.

/// A rectangle of pixels [x0, x1) × [y0, y1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Window {
    /// The smallest window holding both (an empty one adds nothing).
    pub fn union(self, o: Window) -> Window {
        if o.x0 >= o.x1 || o.y0 >= o.y1 {
            return self;
        }
        if self.x0 >= self.x1 || self.y0 >= self.y1 {
            return o;
        }
        Window {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    /// Whether pixel (`x`, `y`) lies in the window.
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    pub fn full(width: u32, height: u32) -> Window {
        Window {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    pub fn n_pixels(&self) -> u64 {
        (self.x1 - self.x0) as u64 * (self.y1 - self.y0) as u64
    }
}
