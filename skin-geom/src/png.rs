//! Tactile images written as PNG files.

use crate::{Error, Result};
use image::ImageEncoder as _;
use skin_core::image::ImageView;

/// Encodes an 8-bit grey image as PNG.
pub fn encode_png(image: ImageView<'_, u8>) -> Result<Vec<u8>> {
    let size = image.size();
    let grey = image.pixels();
    // A view's sides are at most ImageSize::MAX_SIDE, far inside u32.
    let side = |n: usize| {
        u32::try_from(n).map_err(|_| Error::Length {
            what: "pixels on an image's side",
            got: n,
            expected: u32::MAX as usize,
        })
    };
    let (w, h) = (side(size.cols)?, side(size.rows)?);
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(grey, w, h, image::ExtendedColorType::L8)
        .map_err(|source| Error::Encode { source })?;
    Ok(png)
}

/// Writes an 8-bit grey image as a PNG file.
pub fn write_png(path: &std::path::Path, image: ImageView<'_, u8>) -> Result<()> {
    std::fs::write(path, encode_png(image)?).map_err(|source| Error::Output {
        path: path.to_owned(),
        source,
    })
}
