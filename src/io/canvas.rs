//! A small RGB raster for plots written as PNG: points, lines and text in
//! a 3×5 pixel digit font (digits, '.', '-', '+', 'e'), drawn twice the
//! size. Drawing outside the raster is clipped.

/// An RGB raster, row-major, 3 bytes per pixel.
pub struct Canvas {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<u8>,
}

impl Canvas {
    /// A white raster.
    pub fn new(width: usize, height: usize) -> Canvas {
        Canvas {
            width,
            height,
            pixels: vec![255; width * height * 3],
        }
    }

    pub fn set(&mut self, x: i64, y: i64, rgb: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            let i = 3 * (y as usize * self.width + x as usize);
            self.pixels[i..i + 3].copy_from_slice(&rgb);
        }
    }

    pub fn hline(&mut self, x0: i64, x1: i64, y: i64, rgb: [u8; 3]) {
        for x in x0.min(x1)..=x0.max(x1) {
            self.set(x, y, rgb);
        }
    }

    pub fn vline(&mut self, x: i64, y0: i64, y1: i64, rgb: [u8; 3]) {
        for y in y0.min(y1)..=y0.max(y1) {
            self.set(x, y, rgb);
        }
    }

    /// Text in the 3×5 font, scaled ×2, top-left at (x, y); 8 pixels per
    /// character.
    pub fn text(&mut self, x: i64, y: i64, s: &str, rgb: [u8; 3]) {
        for (k, c) in s.chars().enumerate() {
            let rows = glyph(c);
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..3 {
                    if bits & (0b100 >> col) != 0 {
                        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            self.set(x + 8 * k as i64 + 2 * col + dx, y + 2 * r as i64 + dy, rgb);
                        }
                    }
                }
            }
        }
    }
}

/// A 3×5 glyph, one row per entry, bit 2 = left column.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b111, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        '+' => [0b000, 0b010, 0b111, 0b010, 0b000],
        'e' => [0b000, 0b111, 0b111, 0b100, 0b111],
        _ => [0; 5],
    }
}
