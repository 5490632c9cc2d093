//! Flatten a link's skin into a tactile map and print how much it distorts.
//!
//! ```text
//! cargo run --release -p skin-examples --example flatten_link [LAYOUT.json]
//! ```
//! Without an argument it uses the project's fixture forearm (715 taxels on a half cylinder).

use skin_core::format;
use skin_geom::{FlattenOptions, MeshSource, TactileMap};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let path = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json"));
    // Any layout the project reads: its own JSON, Cyskin calibration JSON, or an iCub taxel file.
    let link = format::load_link(&path)?.value;
    let map = TactileMap::flatten(&link, &FlattenOptions::default())?;

    let (w, h) = map.extent();
    println!(
        "{}: {} taxels -> {:.0} x {:.0} mm tactile map",
        link.name,
        link.taxels.len(),
        w * 1e3,
        h * 1e3
    );
    if let Some(MeshSource::Triangulated { chart }) = map.report.source {
        println!("triangulated in the {chart}");
    }
    println!("{}", map.report.distortion);
    // Each taxel has one point on the map, in metres.
    println!(
        "taxel {} is at ({:.4}, {:.4}) m on the map",
        map.ids[0], map.points[0].x, map.points[0].y
    );
    Ok(())
}
