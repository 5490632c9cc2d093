//! Turn the frames of a recording into tactile images, the way a robot's per-frame loop would:
//! everything is prepared once, then each frame costs about 0.1 ms and allocates nothing.
//!
//! ```text
//! cargo run --release -p skin-examples --example tactile_images
//! ```
//! Uses the fixture forearm and its recording of four touches; writes the brightest frame to
//! `tactile_image.png` in the current folder.

use skin_core::format::{load_link, recording};
use skin_core::image::{ImageSize, ImageView};
use skin_geom::{FlattenOptions, Grid, Normalisation, Rasterizer, TactileImager, TactileMap};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm");
    let link = load_link(&fixtures.join("layout.json"))?.value;
    let rec = recording::read(&fixtures.join("touches.txt"))?;

    // Once per link: the map, the 1 mm grid on it, the image pipeline (grey levels scaled to the
    // contact's peak, erosion/dilation, resized to the 68 x 100 input of the hand classifier).
    let map = TactileMap::flatten(&link, &FlattenOptions::default())?;
    let raster = Rasterizer::new(&map, Grid::StepMm(1.0))?;
    let mut imager = TactileImager::new(
        raster,
        Normalisation::ContactMax,
        true,
        Some(ImageSize::MODEL_DEFAULT),
    )?;

    // Readings come in the recording's taxel order; this fixture records them in layout order.
    assert_eq!(rec.taxel_ids, link.ids());
    let mut pressures = vec![0.0f32; link.taxels.len()];
    let mut best = (0.0f32, Vec::new());
    for frame in &rec.frames {
        // Readings under 10 counts are noise (the active-set threshold).
        for (p, &v) in pressures.iter_mut().zip(&frame.values) {
            *p = if v > 10.0 { v } else { 0.0 };
        }
        let grey = imager.process(&pressures)?.to_vec();
        let peak = imager.pressure_image().iter().copied().fold(0.0, f32::max);
        if peak > best.0 {
            best = (peak, grey);
        }
    }
    let image = ImageView::new(&best.1, imager.output_size())?;
    skin_geom::write_png("tactile_image.png".as_ref(), image)?;
    println!(
        "{} frames; the strongest touch ({:.0} counts) is in tactile_image.png",
        rec.frames.len(),
        best.0
    );
    Ok(())
}
