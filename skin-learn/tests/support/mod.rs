//! What the skin-learn tests share: the bundled forearm and the shipped models.

#![allow(dead_code, clippy::unwrap_used)] // each test file uses part of it; a failed set-up should stop the test

pub mod elastic_probe;
pub mod memory;

use skin_geom::{FlattenOptions, TactileMap};
use std::path::{Path, PathBuf};

/// A shipped model (fixtures/models).
pub fn model(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/models")
        .join(name)
}

/// The bundled forearm's layout, flattened as `skin synth` does.
pub fn forearm() -> TactileMap {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json");
    let link = skin_core::format::load_link(&path).unwrap().value;
    TactileMap::flatten(&link, &FlattenOptions::default()).unwrap()
}

use skin_core::image::{ImageSize, ImageView};
use skin_learn::model::{Classes, HandClassifier, ModelError, Models, PartSegmenter};

/// A rule-based hand classifier for tests that need decisions without a model runtime: a wide
/// press (at least `hand_pixels` lit pixels of the 68 x 100 image) is a hand, anything smaller
/// is not.
pub struct ByArea {
    pub hand_pixels: usize,
}

impl HandClassifier for ByArea {
    fn input_size(&self) -> ImageSize {
        ImageSize::MODEL_DEFAULT
    }

    fn classify(&mut self, image: ImageView<'_, u8>) -> Result<Vec<f32>, ModelError> {
        let lit = image.pixels().iter().filter(|&&p| p > 0).count();
        let hand = if lit >= self.hand_pixels { 0.9 } else { 0.1 };
        Ok(vec![hand, 1.0 - hand])
    }
}

/// A rule-based part segmenter: every lit pixel of the left fifth of the image is the thumb,
/// the rest the palm.
pub struct ThumbAndPalm;

impl PartSegmenter for ThumbAndPalm {
    fn input_size(&self) -> ImageSize {
        ImageSize::MODEL_DEFAULT
    }

    fn segment(&mut self, image: ImageView<'_, u8>) -> Result<Vec<u8>, ModelError> {
        let cols = image.size().cols;
        Ok(image
            .pixels()
            .iter()
            .enumerate()
            .map(|(i, &p)| match (p, i % cols < cols / 5) {
                (0, _) => 0,
                (_, true) => 1,
                (_, false) => 6,
            })
            .collect())
    }
}

/// The rule-based models: hand or not by area, then thumb and palm.
pub fn rule_models() -> Models {
    let classes = Classes::new(["hand", "non_hand"], Some(0));
    Models::new(ByArea { hand_pixels: 50 }, classes).with_segmenter(ThumbAndPalm)
}
