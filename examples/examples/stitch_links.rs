//! Stitch the tactile maps of two links joined by a joint into one tactile image, posture by
//! posture (thesis Ch. 6).
//!
//! ```text
//! cargo run --release -p skin-examples --example stitch_links
//! ```
//! Uses the fixture arm: a forearm and a wrist joined by a roll joint. Each link is flattened once;
//! every control cycle, the stitcher takes the link poses (from the robot's kinematics) and moves
//! the wrist's map so that the skin across the joint keeps its 3D distances. Here the wrist rolls
//! from -0.5 to +0.5 rad in 1,000 small steps, as a 1 kHz loop would see it.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use skin_core::format::native;
use skin_geom::{
    Deadline, FlattenOptions, JointMode, StitchOptions, StitchedRasterizer, Stitcher, TactileMap,
};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm");
    let layout = native::read_layout(&fixtures.join("layout.json"))?;
    let maps = layout
        .links
        .iter()
        .map(|l| TactileMap::flatten(l, &FlattenOptions::default()))
        .collect::<Result<Vec<_>, _>>()?;

    // The wrist's pose for a roll angle (in a robot, from forward kinematics).
    let poses = |roll: f64| {
        vec![
            Isometry3::identity(),
            Isometry3::from_parts(
                Translation3::new(0.0, 0.342, 0.0),
                UnitQuaternion::from_axis_angle(&Vector3::y_axis(), roll),
            ),
        ]
    };
    // Set up at the middle of the joint's range; a roll slides the wrist's map without turning
    // it, so after the first solve only the translation is solved.
    let mut stitcher = Stitcher::new(maps.clone(), &poses(0.0), StitchOptions::default())?;
    let first = stitcher.update(&poses(0.0), Deadline::Iterations(100))?;
    stitcher.set_mode(
        0,
        JointMode::TranslationOnly {
            angle: first.joints[0].placement.angle,
        },
    );

    let mut raster = StitchedRasterizer::new(&maps, 1.0)?;
    // The sweep starts far from the set-up posture: solve that first posture afresh.
    stitcher.reset(&poses(-0.5))?;
    let started = Instant::now();
    let mut worst_iterations = 0;
    let mut last = first;
    for k in 0..=1000 {
        let roll = -0.5 + f64::from(k) / 1000.0;
        // Each cycle gets a budget; the best placement so far comes back even if it runs out.
        last = stitcher.update(&poses(roll), Deadline::Iterations(10))?;
        worst_iterations = worst_iterations.max(last.joints[0].iterations);
    }
    let per_cycle = started.elapsed() / 1001;
    raster.place(&last.placements, &last.bridges)?;
    println!(
        "1001 cycles, {per_cycle:?} each (at most {worst_iterations} iterations); at +0.5 rad the wrist map sits at {:.1} mm, {:.1} mm; stitched image {} x {} px",
        last.placements[1].offset.x * 1e3,
        last.placements[1].offset.y * 1e3,
        raster.rows(),
        raster.cols()
    );
    Ok(())
}
