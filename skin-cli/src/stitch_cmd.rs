//! `skin stitch`: the maps of a chain of links stitched at every posture, and tactile images over
//! all of them.

use crate::shared::read_postures;
use anyhow::{Context, Result};
use skin_core::format::recording;
use skin_core::image::ImageView;
use skin_core::{Columns, LinkSkin, Recording};
use skin_geom::{
    DeadTaxels, FlattenOptions, PostureChain, StitchOptions, TactileMap, dilate_disk, erode_disk, write_png,
};
use std::path::{Path, PathBuf};

/// Stitch a chain of links' tactile maps into one image per posture (thesis Ch. 6).
///
/// ARM.json is a layout of one link per element of the chain, in chain order (a skin-layout/1,
/// or a URDF's tactile sensors in the order their links first carry one); each link
/// is flattened on its own (its map never changes). POSES.json (skin-poses/1) gives every link's
/// pose over time: at each posture the boundary taxels of adjacent links are triangulated in 3D
/// and the child map is placed to keep those edges' lengths (Eq. 6.6). Each FRAMES recording
/// (a reading per taxel id; taxels it lacks are dead, reported, and the chain is stitched again
/// without them so images bridge them) becomes one stitched tactile image per frame, using the
/// posture in effect at the frame's time: OUT/<recording>/frame_<n>.png. Prints each
/// posture's solve: edges, cost, iterations, and how well the stitched edges keep their 3D length.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Layout of the chain (project JSON, links in chain order).
    #[arg(long, value_name = "ARM.json")]
    layout: PathBuf,
    /// Link poses over time (skin-poses/1).
    #[arg(long, value_name = "POSES.json")]
    poses: PathBuf,
    /// Recordings to turn into stitched tactile images.
    #[arg(value_name = "FRAMES")]
    frames: Vec<PathBuf>,
    /// Output folder: created if missing; an existing one is written into only if it holds an
    /// earlier output of `skin stitch` (or with --force).
    #[arg(short, long, value_name = "DIR")]
    output: PathBuf,
    /// Write into an output folder that holds other files: only the files this command writes
    /// are replaced, everything else stays.
    #[arg(long)]
    force: bool,
    /// Pixel side, millimetres (0.01 to 1000).
    #[arg(long, default_value_t = 1.0, value_name = "MM", value_parser = crate::numbers::within(0.01, 1000.0))]
    step_mm: f64,
    /// Readings at or below this are no pressure, in the recording's units.
    #[arg(long, default_value_t = 0.0, value_name = "COUNTS", value_parser = crate::numbers::within(-1e9, 1e9))]
    threshold: f64,
    /// Grey erosion (disk of 2 px) then dilation (disk of 4 px), as for the classifier.
    #[arg(long)]
    morph: bool,
    /// Also draw the stitched maps of every posture: OUT/stitched_<posture>.svg.
    #[arg(long)]
    svg: bool,
    /// Cross-boundary edges longer than this are dropped, millimetres.
    #[arg(long, default_value_t = 30.0, value_name = "MM", value_parser = crate::numbers::above(0.0, 1e4))]
    max_edge_mm: f64,
}

pub fn run(args: Args) -> Result<()> {
    let sources = crate::output::Inputs::new([&args.layout, &args.poses].into_iter().chain(&args.frames));
    let out = crate::output::open_dir(&args.output, "skin stitch", args.force, &sources)?;
    let stems = crate::shared::output_names(&args.frames)?;
    let links = crate::shared::load_links(&args.layout)?;
    let names: Vec<&str> = links.iter().map(|l| l.name.as_str()).collect();
    let postures = read_postures(&args.poses, &args.layout, &names)?;
    let maps: Vec<TactileMap> = links
        .iter()
        .map(|l| {
            TactileMap::flatten(l, &FlattenOptions::default()).with_context(|| format!("link \"{}\"", l.name))
        })
        .collect::<Result<_>>()?;
    let options = StitchOptions {
        max_edge: args.max_edge_mm * 1e-3,
        ..StitchOptions::default()
    };
    // Every posture solved once (a posture is static).
    let mut chain = PostureChain::new(maps, postures, options, args.step_mm)
        .with_context(|| args.layout.display().to_string())?;
    say_solves(&chain, &names, options.max_edge);
    if args.svg {
        for (p, report) in chain.postures().postures.iter().zip(chain.solves()) {
            let name = format!("stitched_{}.svg", file_name(&p.name));
            let svg = skin_geom::stitched_svg(chain.stitcher().maps(), &report.placements);
            let _creating = skin_core::output::writing();
            std::fs::write(out.path().join(&name), svg.as_bytes())
                .with_context(|| format!("cannot write {name} in {}", args.output.display()))?;
        }
    }
    for (rec_path, stem) in args.frames.iter().zip(&stems) {
        let rec = recording::read(rec_path)?;
        let columns: Vec<Columns> = chain
            .stitcher()
            .maps()
            .iter()
            .map(|m| rec.columns(&m.ids))
            .collect();
        // Taxels without a column are dead: the chain is stitched again without them (as Test B
        // removes taxels), so images interpolate across them.
        let dead: Vec<DeadTaxels> = columns.iter().map(DeadTaxels::of_columns).collect();
        say_dead(rec_path, &links, chain.stitcher().maps(), &dead);
        chain
            .set_dead(dead)
            .with_context(|| format!("{}: the chain without the taxels it lacks", rec_path.display()))?;
        write_frames(&mut chain, (&rec, rec_path), &columns, out.path(), stem, &args)?;
        crate::say!(
            "{}: {} stitched frames -> {}",
            rec_path.display(),
            rec.frames.len(),
            args.output.join(stem).display()
        );
    }
    out.commit()?;
    if args.svg {
        crate::say!("wrote the stitched maps to {}", args.output.display());
    }
    Ok(())
}

/// Prints each joint's boundary, and each posture's solve.
fn say_solves(chain: &PostureChain, names: &[&str], max_edge: f64) {
    let stitcher = chain.stitcher();
    for j in 0..names.len().saturating_sub(1) {
        if let Some((a, b)) = stitcher.boundary(j) {
            crate::say!(
                "joint {j} ({} - {}): {} + {} boundary taxels",
                names[j],
                names[j + 1],
                a.len(),
                b.len()
            );
        }
    }
    for (p, report) in chain.postures().postures.iter().zip(chain.solves()) {
        for (j, s) in report.joints.iter().enumerate() {
            let (worst, n) = stitcher.edge_fidelity(j, &p.poses, &report.placements, max_edge);
            crate::say!(
                "posture \"{}\", joint {j}: {} edges, cost {:.3} mm^2 in {} iterations{}; stitched edges keep their 3D length within {:.1}% ({n} pairs)",
                p.name,
                s.edges,
                s.cost * 1e6,
                s.iterations,
                if s.kept_last {
                    " (no edge: last placement kept)"
                } else if s.converged {
                    ""
                } else {
                    " (not converged)"
                },
                100.0 * worst
            );
        }
    }
}

/// Says which taxels of each link the recording lacks.
fn say_dead(rec_path: &Path, links: &[LinkSkin], maps: &[TactileMap], dead: &[DeadTaxels]) {
    for ((link, d), map) in links.iter().zip(dead).zip(maps) {
        if let Some(&first) = d.indices().first() {
            crate::say!(
                "{}: {} taxel(s) of link \"{}\" are not recorded (first: {}): dead, the images bridge them",
                rec_path.display(),
                d.len(),
                link.name,
                map.ids[first]
            );
        }
    }
}

/// One stitched tactile image per frame of `rec` (`columns`: its columns of each whole map), at
/// the posture of the frame's time: `<root>/<stem>/<frame>.png`.
fn write_frames(
    chain: &mut PostureChain,
    (rec, rec_path): (&Recording, &Path),
    columns: &[Columns],
    root: &Path,
    stem: &str,
    args: &Args,
) -> Result<()> {
    let dir = root.join(stem);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot write into {}", args.output.display()))?;
    let threshold = args.threshold as f32;
    let files = crate::shared::frame_stems(rec_path, rec);
    let mut pressures: Vec<Vec<f32>> = columns.iter().map(|c| vec![0.0; c.of_taxel.len()]).collect();
    for (file, frame) in files.iter().zip(&rec.frames) {
        for (p, c) in pressures.iter_mut().zip(columns) {
            c.gather(&frame.values, threshold, p);
        }
        chain.set_frame(frame.time, &pressures, threshold)?;
        let image = chain.image()?;
        let size = image.size();
        let (rows, cols) = (size.rows, size.cols);
        let png = dir.join(format!("{file}.png"));
        let morphed;
        let image = if args.morph {
            morphed = dilate_disk(&erode_disk(image.pixels(), rows, cols, 2), rows, cols, 4);
            // Erosion and dilation keep the image's size.
            ImageView::new(&morphed, size)?
        } else {
            image
        };
        // Held while the file is created: Ctrl-C's handler waits for it (see skin-core's output).
        let _creating = skin_core::output::writing();
        write_png(&png, image)
            .with_context(|| format!("cannot write {stem}/{file}.png in {}", args.output.display()))?;
    }
    Ok(())
}

fn file_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}
