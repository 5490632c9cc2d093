//! `skin segment`: which hand part pressed where, with an ONNX segmenter (thesis Ch. 4.4).

use anyhow::{Context, Result};
use skin_learn::parts::{Shares, part_contacts};
use skin_learn::segment::Segmenter;
use std::path::{Path, PathBuf};

/// Segment tactile images into hand parts with an ONNX model (tract, on the CPU).
///
/// The parts: thumb, index, middle, ring, pinkie, palm. INPUTS are 8-bit grey PNG images of the model's input size (68 x 100), or, with --map,
/// recordings whose frames are imaged by the real pipeline first (frames with no reading above
/// --threshold are skipped). Each result is written to DIR as a colour PNG (thumb red, index
/// green, middle yellow, ring blue, pinkie orange, palm purple; black: no contact) and a line
/// gives each part's share of the pressed pixels. With --map, a table per frame gives each
/// part's contact (Fig. 4.9): taxels pressed, mean reading, and the reading-weighted centroid of
/// those taxels on the 3D link (mm, link frame).
///
/// Black input pixels are background whatever the model says. The input scaling comes from the
/// model card (MODEL.md beside MODEL.onnx) unless given. Run `skin classify` first: a
/// segmenter labels any contact as hand parts. --mirrors averages each image's part scores
/// with those of its three mirror images: steadier labels at four times the inference.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    run: crate::shared::ModelInputs,
    /// Where to write the coloured part images: a folder, created if missing; an existing one
    /// is written into only if it holds an earlier output of `skin segment` (or with --force).
    #[arg(short, long, value_name = "DIR", default_value = "segments")]
    output: PathBuf,
    /// Write into an output folder that holds other files: only the files this command writes
    /// are replaced, everything else stays.
    #[arg(long)]
    force: bool,
    /// Average the part scores of each image and of its mirror images (left-right, up-down,
    /// both); for models trained on mirrored images, as the shipped ones are.
    #[arg(long)]
    mirrors: bool,
}

pub fn run(args: Args) -> Result<()> {
    let scale = crate::shared::input_scale(&args.run.model, args.run.input_scale);
    let mut net = Segmenter::load(&args.run.model, scale)?.with_mirror_averaging(args.mirrors);
    let size = net.input_size();
    let (h, w) = (size.rows, size.cols);
    let sources = crate::output::Inputs::new(
        [&args.run.model]
            .into_iter()
            .chain(&args.run.inputs)
            .chain(&args.run.map),
    );
    let out = crate::output::open_dir(&args.output, "skin segment", args.force, &sources)?;
    crate::say!(
        "{}: [N, 1, {h}, {w}] -> {} classes per pixel",
        args.run.model.display(),
        net.classes()
    );
    match &args.run.map {
        None => {
            let names = crate::shared::output_names(&args.run.inputs)?;
            for (path, name) in args.run.inputs.iter().zip(&names) {
                let img = crate::shared::read_model_image(path, (h, w))?;
                let labels = net.segment(&img)?;
                let file = format!("{name}_parts.png");
                write_colour(&out.path().join(&file), &labels, h, w)?;
                crate::say!(
                    "{}: {}  -> {}",
                    path.display(),
                    Shares::of(&labels),
                    args.output.join(&file).display()
                );
            }
        }
        Some(map_path) => {
            let map = crate::shared::load_map(map_path)?;
            let (inputs, maps) = crate::shared::load_inputs(&args.run.inputs, &map, out.path())?;
            let mut imagers = crate::shared::model_imagers(&maps, size, map_path)?;
            // The per-part table needs the grids while the imagers are busy.
            let rasters: Vec<_> = imagers.iter().map(|i| i.raster().clone()).collect();
            for input in &inputs {
                std::fs::create_dir_all(&input.dir)
                    .with_context(|| format!("cannot write into {}", args.output.display()))?;
            }
            let quiet = crate::shared::each_touched_frame(
                &inputs,
                &mut imagers,
                args.run.threshold as f32,
                |input, f, pressures, grey| {
                    let number = input.rec.frame_numbers[f];
                    let labels = net.segment(grey)?;
                    let file = input.names[f].replace(".png", "_parts.png");
                    let creating = skin_core::output::writing();
                    write_colour(&input.dir.join(file), &labels, h, w)?;
                    drop(creating);
                    crate::say!(
                        "{} frame {number} ({:.2} s): {}",
                        input.path.display(),
                        input.rec.frames[f].time,
                        Shares::of(&labels)
                    );
                    crate::say!("  part     taxels  mean reading   centroid x, y, z (mm)");
                    for pc in part_contacts(&maps[input.map], &rasters[input.map], size, &labels, pressures) {
                        let c = pc.centroid.map_or("-".to_string(), |c| {
                            format!("{:.1}, {:.1}, {:.1}", 1e3 * c.x, 1e3 * c.y, 1e3 * c.z)
                        });
                        crate::say!(
                            "  {:<8} {:>6}  {:>12.1}   {c}",
                            pc.part.name(),
                            pc.taxels,
                            pc.mean_pressure
                        );
                    }
                    Ok(())
                },
            )?;
            crate::say!("{quiet} frame(s) with no contact above {}", args.run.threshold);
        }
    }
    out.commit()?;
    crate::say!("wrote {}", args.output.display());
    Ok(())
}

fn write_colour(path: &Path, labels: &[u8], h: usize, w: usize) -> Result<()> {
    let rgb = skin_learn::parts::colour_mask(labels);
    image::save_buffer(path, &rgb, w as u32, h as u32, image::ExtendedColorType::Rgb8).with_context(|| {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        format!("cannot write {name}")
    })
}
