//! Tactile images as the crates hand them to each other: one size type with one parser and one
//! limit, a borrowed view of row-major pixels, and the owned image a view is taken from (as a
//! `Vec` is to a slice).
//!
//! ```
//! use skin_core::image::{ImageSize, ImageView};
//! let size: ImageSize = "68x100".parse()?;
//! assert_eq!(size, ImageSize::MODEL_DEFAULT);
//! let pixels = vec![0u8; size.pixels()];
//! let view = ImageView::new(&pixels, size)?;
//! assert_eq!(view.row(67).len(), 100);
//! # Ok::<(), skin_core::image::ImageSizeError>(())
//! ```

use std::fmt;
use std::str::FromStr;

/// The size of a tactile image, pixels: `rows` high, `cols` wide. A size a user gives (a flag,
/// a file) is checked by [`ImageSize::new`] or parsed: each side 1 to [`ImageSize::MAX_SIDE`]
/// pixels. A stitched canvas, bounded by its pixel count instead, may be longer on a side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ImageSize {
    /// Rows (height).
    pub rows: usize,
    /// Columns (width).
    pub cols: usize,
}

/// Why a size or a view was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ImageSizeError {
    /// Not `ROWSxCOLS` with two whole numbers.
    #[error("image size {given:?} must be ROWSxCOLS, e.g. 68x100")]
    Syntax {
        /// The text given.
        given: String,
    },
    /// A side of 0 or past [`ImageSize::MAX_SIDE`].
    #[error("image size {rows}x{cols}: each side must be 1 to {max} pixels", max = ImageSize::MAX_SIDE)]
    OutOfRange {
        /// Rows asked for.
        rows: u64,
        /// Columns asked for.
        cols: u64,
    },
    /// A view whose pixels do not fill its size.
    #[error("an image of {rows}x{cols} needs {} pixels, {len} given", rows * cols)]
    Length {
        /// Rows of the view.
        rows: usize,
        /// Columns of the view.
        cols: usize,
        /// Pixels given.
        len: usize,
    },
}

impl ImageSize {
    /// The largest side of a tactile image, pixels: 4096 x 4096 is 16.7 million pixels, 16 MB
    /// as 8-bit grey, which bounds what a size read from a user's file or flag may allocate.
    pub const MAX_SIDE: usize = 4096;

    /// The input of the shipped models (HandsNet and the part segmenter): 68 rows, 100 columns.
    pub const MODEL_DEFAULT: ImageSize = ImageSize { rows: 68, cols: 100 };

    /// `rows x cols`, each side checked against [`ImageSize::MAX_SIDE`].
    pub fn new(rows: usize, cols: usize) -> Result<ImageSize, ImageSizeError> {
        let ok = |s: usize| (1..=Self::MAX_SIDE).contains(&s);
        match ok(rows) && ok(cols) {
            true => Ok(ImageSize { rows, cols }),
            false => Err(ImageSizeError::OutOfRange {
                rows: rows as u64,
                cols: cols as u64,
            }),
        }
    }

    /// Pixels in an image of this size.
    pub fn pixels(self) -> usize {
        self.rows * self.cols
    }
}

impl Default for ImageSize {
    fn default() -> Self {
        Self::MODEL_DEFAULT
    }
}

impl fmt::Display for ImageSize {
    /// `ROWSxCOLS`, as it is parsed.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.rows, self.cols)
    }
}

impl FromStr for ImageSize {
    type Err = ImageSizeError;

    /// `ROWSxCOLS` (`X` too, spaces around the numbers allowed), each side 1 to 4096.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let syntax = || ImageSizeError::Syntax { given: s.to_owned() };
        let (r, c) = s.split_once(['x', 'X']).ok_or_else(syntax)?;
        let side = |t: &str| t.trim().parse::<u64>().map_err(|_| syntax());
        let (rows, cols) = (side(r)?, side(c)?);
        let max = Self::MAX_SIDE as u64;
        match (1..=max).contains(&rows) && (1..=max).contains(&cols) {
            true => Ok(ImageSize {
                rows: rows as usize,
                cols: cols as usize,
            }),
            false => Err(ImageSizeError::OutOfRange { rows, cols }),
        }
    }
}

/// A borrowed row-major image: `size.rows * size.cols` pixels, row 0 first.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImageView<'a, T> {
    pixels: &'a [T],
    size: ImageSize,
}

impl<'a, T> ImageView<'a, T> {
    /// A view of `pixels` as an image of `size`; refused unless the pixels fill it exactly.
    pub fn new(pixels: &'a [T], size: ImageSize) -> Result<Self, ImageSizeError> {
        match pixels.len() == size.pixels() {
            true => Ok(ImageView { pixels, size }),
            false => Err(ImageSizeError::Length {
                rows: size.rows,
                cols: size.cols,
                len: pixels.len(),
            }),
        }
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &'a [T] {
        self.pixels
    }

    /// The image's size.
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// Row `r` (panics past the last row, as slice indexing does).
    pub fn row(&self, r: usize) -> &'a [T] {
        &self.pixels[r * self.size.cols..(r + 1) * self.size.cols]
    }
}

/// An owned row-major image: its pixels always fill its size, so its [`view`](Image::view) is
/// never refused. The empty image (0 x 0, no pixels) is its default: no image yet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image<T> {
    pixels: Vec<T>,
    size: ImageSize,
}

impl<T> Image<T> {
    /// `pixels` as an image of `size`; refused unless they fill it exactly.
    pub fn new(pixels: Vec<T>, size: ImageSize) -> Result<Self, ImageSizeError> {
        ImageView::new(&pixels, size)?;
        Ok(Image { pixels, size })
    }

    /// The image, borrowed.
    pub fn view(&self) -> ImageView<'_, T> {
        ImageView {
            pixels: &self.pixels,
            size: self.size,
        }
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &[T] {
        &self.pixels
    }

    /// The image's size.
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// Whether the image has no pixels (the default: no image yet).
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// The pixels, row-major, and the image gone.
    pub fn into_pixels(self) -> Vec<T> {
        self.pixels
    }
}

impl<T: Clone> Image<T> {
    /// Makes this image a copy of `view`, reusing its buffer (no allocation once it is large
    /// enough).
    pub fn set(&mut self, view: ImageView<'_, T>) {
        self.pixels.clear();
        self.pixels.extend_from_slice(view.pixels());
        self.size = view.size();
    }
}

impl<T> Default for Image<T> {
    fn default() -> Self {
        Image {
            pixels: Vec::new(),
            size: ImageSize { rows: 0, cols: 0 },
        }
    }
}

impl<T: Clone> From<ImageView<'_, T>> for Image<T> {
    fn from(view: ImageView<'_, T>) -> Self {
        Image {
            pixels: view.pixels().to_vec(),
            size: view.size(),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;

    #[test]
    fn parses_and_prints_sizes() {
        assert_eq!("68x100".parse(), Ok(ImageSize::MODEL_DEFAULT));
        assert_eq!(" 4 X 5 ".parse(), Ok(ImageSize { rows: 4, cols: 5 }));
        assert_eq!(ImageSize::MODEL_DEFAULT.to_string(), "68x100");
        for bad in ["68", "x", "68x", "-1x5", "1.5x2", "68x100x3", ""] {
            assert!(
                matches!(bad.parse::<ImageSize>(), Err(ImageSizeError::Syntax { .. })),
                "{bad}"
            );
        }
        for bad in ["0x5", "5x0", "4097x1", "100000x100000", "99999999999999999999x1"] {
            let e = bad.parse::<ImageSize>().unwrap_err().to_string();
            assert!(e.contains("4096") || e.contains("ROWSxCOLS"), "{bad}: {e}");
        }
        assert!("4096x4096".parse::<ImageSize>().is_ok());
        assert!(ImageSize::new(4097, 1).is_err());
        assert!(ImageSize::new(0, 1).is_err());
    }

    #[test]
    fn a_view_is_exactly_its_size() {
        let px = [1u8, 2, 3, 4, 5, 6];
        let v = ImageView::new(&px, ImageSize { rows: 2, cols: 3 }).unwrap();
        assert_eq!(v.row(1), &[4, 5, 6]);
        assert!(ImageView::new(&px[..5], ImageSize { rows: 2, cols: 3 }).is_err());
        assert!(ImageView::new(&px, ImageSize { rows: 3, cols: 3 }).is_err());
    }

    #[test]
    fn an_owned_image_is_exactly_its_size() {
        let size = ImageSize { rows: 2, cols: 3 };
        let mut image = Image::new(vec![1u8, 2, 3, 4, 5, 6], size).unwrap();
        assert_eq!(image.view().row(1), &[4, 5, 6]);
        assert!(Image::new(vec![0u8; 5], size).is_err());
        let empty = Image::<u8>::default();
        assert!(empty.is_empty() && empty.view().pixels().is_empty());
        let small = [9u8, 8];
        image.set(ImageView::new(&small, ImageSize { rows: 1, cols: 2 }).unwrap());
        assert_eq!(
            (image.size(), image.pixels()),
            (ImageSize { rows: 1, cols: 2 }, &small[..])
        );
        assert_eq!(Image::from(image.view()), image);
    }
}
