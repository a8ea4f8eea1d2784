//! Hierarchical pixel order for the fill pass: pixels sorted by the bit-reversed Morton code of (x, y).
//!
//! The first 1/4^L of the sequence is exactly the lattice of every 2^L-th pixel, and consecutive pixels
//! are far apart, so the records of one wave rarely cover each other (coarse-to-fine, nearly
//! best-candidate). The order depends only on the image size.
#![forbid(unsafe_code)]

/// Iterator over every pixel of a `width` × `height` image in hierarchical order.
#[derive(Clone, Debug)]
pub struct HierarchicalOrder {
    width: u32,
    height: u32,
    bits: u32,
    next: u64,
    end: u64,
}

impl HierarchicalOrder {
    pub fn new(width: u32, height: u32) -> Self {
        let side = width.max(height).max(1).next_power_of_two() as u64;
        let bits = side.trailing_zeros();
        HierarchicalOrder {
            width,
            height,
            bits,
            next: 0,
            end: side * side,
        }
    }
}

/// Bits 0, 2, 4, … of `m` packed together.
fn compact_even_bits(mut m: u64) -> u32 {
    m &= 0x5555_5555_5555_5555;
    m = (m | (m >> 1)) & 0x3333_3333_3333_3333;
    m = (m | (m >> 2)) & 0x0F0F_0F0F_0F0F_0F0F;
    m = (m | (m >> 4)) & 0x00FF_00FF_00FF_00FF;
    m = (m | (m >> 8)) & 0x0000_FFFF_0000_FFFF;
    m = (m | (m >> 16)) & 0x0000_0000_FFFF_FFFF;
    m as u32
}

impl Iterator for HierarchicalOrder {
    type Item = (u32, u32);

    fn next(&mut self) -> Option<(u32, u32)> {
        while self.next < self.end {
            let i = self.next;
            self.next += 1;
            let code = if self.bits == 0 {
                0
            } else {
                i.reverse_bits() >> (64 - 2 * self.bits)
            };
            let (x, y) = (compact_even_bits(code), compact_even_bits(code >> 1));
            if x < self.width && y < self.height {
                return Some((x, y));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visits_every_pixel_once_coarse_first() {
        for (w, h) in [(1, 1), (7, 3), (16, 16), (33, 20)] {
            let order: Vec<_> = HierarchicalOrder::new(w, h).collect();
            assert_eq!(order.len(), (w * h) as usize);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), order.len());
            // Every pixel on the 4-pixel lattice comes before any pixel off it.
            let on = |&(x, y): &(u32, u32)| x % 4 == 0 && y % 4 == 0;
            let n_on = order.iter().filter(|p| on(p)).count();
            assert!(order[..n_on].iter().all(on), "{w}x{h}");
        }
    }
}
