//! What the skin-learn tests share: the bundled forearm and the shipped models.

#![allow(dead_code, clippy::unwrap_used)] // each test file uses part of it; a failed set-up should stop the test

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
