//! PNG files: 8-bit grey or sRGB pictures with text chunks, written
//! atomically (the colour of previews: `io::srgb`).

use std::io::BufWriter;
use std::path::Path;

use crate::error::{Error, Result};
use crate::io::atomic::write_atomic;

/// Writes an 8-bit PNG (`channels` = 1 grey or 3 RGB) with text chunks.
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    channels: usize,
    pixels: &[u8],
    text: &[(&str, String)],
) -> Result<()> {
    let fail = |m: String| Error::io(path, std::io::Error::other(m));
    let mut bytes = Vec::new();
    {
        let mut encoder = png::Encoder::new(BufWriter::new(&mut bytes), width as u32, height as u32);
        encoder.set_color(if channels == 3 {
            png::ColorType::Rgb
        } else {
            png::ColorType::Grayscale
        });
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        for (k, v) in text {
            encoder
                .add_text_chunk(k.to_string(), v.clone())
                .map_err(|e| fail(e.to_string()))?;
        }
        let mut writer = encoder.write_header().map_err(|e| fail(e.to_string()))?;
        writer.write_image_data(pixels).map_err(|e| fail(e.to_string()))?;
    }
    write_atomic(path, &bytes)
}
