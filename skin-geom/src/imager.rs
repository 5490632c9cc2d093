//! The whole per-frame image path of one link: interpolate, grey, erode and dilate, resize.

use crate::morphology::Morphology;
use crate::raster::{Grid, Normalisation, Rasterizer};
use crate::resize::Resizer;
use crate::{Error, Result, TactileMap};
use skin_core::image::ImageSize;

/// The whole per-frame image path of one link, with its buffers: interpolate, convert to grey,
/// optionally erode (disk r = 2) then dilate (disk r = 4) (thesis Ch. 4.5), optionally resize
/// (68 x 100 for the hand classifier, App. C). [`TactileImager::process`] allocates nothing.
#[derive(Debug, Clone)]
pub struct TactileImager {
    raster: Rasterizer,
    norm: Normalisation,
    morphology: Option<Morphology>,
    resizer: Option<Resizer>,
    pressure: Vec<f32>,
    grey: Vec<u8>,
    morphed: Vec<u8>,
    resized: Vec<u8>,
}

impl TactileImager {
    /// Erosion radius before dilation, pixels (thesis Ch. 4.5).
    pub const EROSION_RADIUS: usize = 2;
    /// Dilation radius, pixels (thesis Ch. 4.5).
    pub const DILATION_RADIUS: usize = 4;

    /// An imager for `raster`, with grey normalisation `norm`, optional erosion/dilation, and an
    /// optional output size (the raster's own without one).
    pub fn new(
        raster: Rasterizer,
        norm: Normalisation,
        morphology: bool,
        size: Option<ImageSize>,
    ) -> Result<Self> {
        let (rows, cols) = (raster.rows(), raster.cols());
        let resizer = match size {
            Some(s) if (s.rows, s.cols) != (rows, cols) => Some(Resizer::new(rows, cols, s.rows, s.cols)?),
            _ => None,
        };
        let out_len = size.map_or(rows * cols, ImageSize::pixels);
        Ok(TactileImager {
            morphology: morphology.then(|| Morphology::new(rows, cols, Self::DILATION_RADIUS)),
            pressure: vec![0.0; rows * cols],
            grey: vec![0; rows * cols],
            morphed: vec![0; rows * cols],
            resized: vec![0; out_len],
            raster,
            norm,
            resizer,
        })
    }

    /// The image a hand classifier or segmenter reads (thesis Ch. 4.5, App. C): `map` on a grid
    /// of `step_mm` millimetres (1 for the shipped models), grey by the contact's own maximum,
    /// eroded then dilated, resized to `size` (68 x 100 for HandsNet).
    pub fn for_model(map: &TactileMap, step_mm: f64, size: ImageSize) -> Result<Self> {
        TactileImager::new(
            Rasterizer::new(map, Grid::StepMm(step_mm))?,
            Normalisation::ContactMax,
            true,
            Some(size),
        )
    }

    /// The rasterizer.
    pub fn raster(&self) -> &Rasterizer {
        &self.raster
    }

    /// Output image size.
    pub fn output_size(&self) -> ImageSize {
        match &self.resizer {
            Some(r) => r.output_size(),
            None => ImageSize {
                rows: self.raster.rows(),
                cols: self.raster.cols(),
            },
        }
    }

    /// Processes one frame and returns the grey image, row-major, of [`Self::output_size`].
    pub fn process(&mut self, pressures: &[f32]) -> Result<&[u8]> {
        self.raster
            .render_grey(pressures, self.norm, &mut self.pressure, &mut self.grey)?;
        if let Some(m) = &mut self.morphology {
            m.erode(&self.grey, Self::EROSION_RADIUS, &mut self.morphed);
            m.dilate(&self.morphed, Self::DILATION_RADIUS, &mut self.grey);
        }
        let current: &[u8] = &self.grey;
        match &mut self.resizer {
            Some(r) => {
                r.resize(current, &mut self.resized);
                Ok(&self.resized)
            }
            None => Ok(current),
        }
    }

    /// As [`Self::process`], the image written into `out` (of [`Self::output_size`]). An imager
    /// with neither morphology nor resizing renders straight into `out`, with no copy (many
    /// frames into one caller's buffer); then [`Self::last_output`] is not updated.
    pub fn process_into(&mut self, pressures: &[f32], out: &mut [u8]) -> Result<()> {
        let expected = self.output_size().pixels();
        if out.len() != expected {
            return Err(Error::Length {
                what: "pixels of the output image",
                got: out.len(),
                expected,
            });
        }
        if self.morphology.is_none() && self.resizer.is_none() {
            return self
                .raster
                .render_grey(pressures, self.norm, &mut self.pressure, out);
        }
        let grey = self.process(pressures)?;
        out.copy_from_slice(grey);
        Ok(())
    }

    /// The grey image [`Self::process`] last returned (black before the first frame).
    pub fn last_output(&self) -> &[u8] {
        if self.resizer.is_some() {
            &self.resized
        } else {
            &self.grey
        }
    }

    /// The pressure image K of the last processed frame (real pressures, before grey conversion).
    pub fn pressure_image(&self) -> &[f32] {
        &self.pressure
    }
}
