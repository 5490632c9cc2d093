//! `skin degrade`: faulty versions of a tactile map for robustness studies.

use anyhow::{Result, bail};
use skin_geom::{BlindSpots, Decimation};
use std::path::PathBuf;

/// Make a degraded tactile map, as the thesis' robustness study does (Ch. 5).
///
/// Blind spots (Test A): --blind-spots N --radius-mm R zeroes every taxel within R millimetres
/// (on the map) of N random taxels; the map keeps its triangles and lists the zeroed taxels, which
/// `skin image` then shows as reading nothing. Removal (Test B): --remove FRACTION removes that
/// fraction of the taxels and re-triangulates the rest on the map (no re-flattening); for one
/// seed, a larger fraction removes a superset of a smaller one's taxels. The same --seed gives the
/// same map, byte for byte.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Tactile map (JSON from `skin flatten`), or a layout to flatten first.
    #[arg(long, value_name = "MAP.json")]
    map: PathBuf,
    /// Number of blind spots.
    #[arg(long, value_name = "N", requires = "radius_mm", conflicts_with = "remove", value_parser = crate::numbers::count::<1, 1_000_000>)]
    blind_spots: Option<usize>,
    /// Radius of each blind spot, millimetres.
    #[arg(long, value_name = "R", requires = "blind_spots", value_parser = crate::numbers::above(0.0, 1e4))]
    radius_mm: Option<f64>,
    /// Fraction of the taxels to remove, 0 to 1 (0.1 = 10 %).
    #[arg(long, value_name = "FRACTION", value_parser = crate::numbers::within(0.0, 1.0))]
    remove: Option<f64>,
    /// Seed of the random pattern.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Where to write the degraded map.
    #[arg(short, long, value_name = "OUT.json")]
    output: PathBuf,
    /// Also draw it to this SVG file.
    #[arg(long, value_name = "MAP.svg")]
    svg: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let inputs = crate::output::Inputs::new([&args.map]);
    crate::output::replaceable(&inputs, Some(&args.output), crate::output::Kind::Map)?;
    crate::output::replaceable(&inputs, args.svg.as_deref(), crate::output::Kind::Svg)?;
    inputs.check_outputs(&[("-o", Some(&args.output)), ("--svg", args.svg.as_deref())])?;
    let map = crate::shared::load_map(&args.map)?;
    let degraded = match (args.blind_spots, args.radius_mm, args.remove) {
        (Some(spots), Some(radius_mm), None) => {
            let d = BlindSpots {
                spots,
                radius_mm,
                seed: args.seed,
            }
            .apply(&map)?;
            crate::say!(
                "{}: {spots} blind spot(s) of {radius_mm} mm (seed {}): {} of {} taxels read zero",
                args.map.display(),
                args.seed,
                d.zeroed.len(),
                d.ids.len()
            );
            d
        }
        (None, None, Some(fraction)) => {
            let d = Decimation {
                fraction,
                seed: args.seed,
            }
            .apply(&map)?;
            crate::say!(
                "{}: {:.0} % removed (seed {}): {} of {} taxels left, {} triangles",
                args.map.display(),
                100.0 * fraction,
                args.seed,
                d.ids.len(),
                map.ids.len(),
                d.faces.len()
            );
            d
        }
        _ => bail!("give either --blind-spots N --radius-mm R, or --remove FRACTION"),
    };
    crate::output::write_file(&args.output, degraded.to_json().as_bytes(), &inputs)?;
    crate::say!("wrote {}", args.output.display());
    if let Some(svg) = &args.svg {
        crate::output::write_file(svg, degraded.to_svg().as_bytes(), &inputs)?;
        crate::say!("wrote {}", svg.display());
    }
    Ok(())
}
