//! Tactile images written as PNG files.

use crate::{Error, Result};
use image::ImageEncoder as _;

/// Encodes a row-major 8-bit grey image of `rows x cols` pixels as PNG.
pub fn encode_png(grey: &[u8], rows: usize, cols: usize) -> Result<Vec<u8>> {
    let bad = || Error::Length {
        what: "grey values for the image's pixels",
        got: grey.len(),
        expected: rows.saturating_mul(cols),
    };
    if grey.len() != rows * cols {
        return Err(bad());
    }
    let (w, h) = (
        u32::try_from(cols).map_err(|_| bad())?,
        u32::try_from(rows).map_err(|_| bad())?,
    );
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(grey, w, h, image::ExtendedColorType::L8)
        .map_err(|e| Error::Output {
            path: "PNG".into(),
            message: e.to_string(),
        })?;
    Ok(png)
}

/// Writes a row-major 8-bit grey image of `rows x cols` pixels as a PNG file.
pub fn write_png(path: &std::path::Path, grey: &[u8], rows: usize, cols: usize) -> Result<()> {
    std::fs::write(path, encode_png(grey, rows, cols)?).map_err(|e| Error::Output {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}
