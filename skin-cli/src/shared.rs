//! What several commands share: reading layouts, maps, recordings and poses as the commands
//! take them, the images a model reads, the names images get, and the CAN traffic tallies of
//! `replay` and `live`. A command imports from here, never from another command.

use anyhow::{Context, Result, bail};
use skin_can::{AssemblyStats, BusMap};
use skin_core::format::poses::Postures;
use skin_core::format::{icub, recording};
use skin_core::{LinkSkin, Recording};
use skin_geom::{TactileImager, TactileMap, load_mesh_file};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

#[cfg(feature = "onnx")]
pub(crate) use models::{ModelInputs, Scale, input_scale, read_model_image};

/// All links of a skin-layout/1 file, or the one link of any other layout file.
pub(crate) fn load_links(path: &Path) -> Result<Vec<LinkSkin>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    if text.contains("skin-layout/") {
        return Ok(skin_core::format::load_links(path)?);
    }
    Ok(vec![crate::shared::load_input(path)?])
}

pub(crate) fn load_input(path: &Path) -> Result<LinkSkin> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    match ext.as_str() {
        "obj" | "gltf" | "glb" => {
            let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
            Ok(load_mesh_file(path)?.into_link(name)?)
        }
        "txt" => {
            let read = icub::read(path, icub::Duplicates::Merge)?;
            crate::say!(
                "{}: {} taxel rows, {} unused (all-zero) rows dropped",
                path.display(),
                read.skin.taxels.len()
                    + read.zero_slots.len()
                    + read.duplicates.iter().map(|g| g.slots.len() - 1).sum::<usize>(),
                read.zero_slots.len()
            );
            if !read.duplicates.is_empty() {
                let merged: usize = read.duplicates.iter().map(|g| g.slots.len() - 1).sum();
                crate::say!(
                    "duplicated positions: {} groups, {merged} taxels merged into the first of their group:",
                    read.duplicates.len()
                );
                for g in &read.duplicates {
                    crate::say!("  lines {:?} (taxels {:?})", g.lines, g.slots);
                }
            }
            Ok(read.skin)
        }
        "json" => Ok(skin_core::format::load_link(path)?),
        _ => bail!(
            "{}: unknown layout format (expected .json, .txt, .obj, .gltf or .glb)",
            path.display()
        ),
    }
}

/// One recording, with its readings reordered to map order.
pub(crate) struct Input {
    /// The recording.
    pub(crate) path: PathBuf,
    pub(crate) dir: PathBuf,
    pub(crate) rec: Recording,
    pub(crate) columns: Vec<usize>,
    /// Each frame's image file name: `frame_<number>.png`, and `frame_<number>_dup<k>.png` for
    /// the k-th repeat of a frame number (a recording joined from two, a counter reset).
    pub(crate) names: Vec<String>,
}

/// Image names for `frame_numbers`: repeats get a suffix instead of overwriting an image.
pub(crate) fn frame_names(frame_numbers: &[u64]) -> (Vec<String>, usize) {
    let mut seen: HashMap<u64, usize> = HashMap::new();
    let mut repeats = 0;
    let names = frame_numbers
        .iter()
        .map(|&n| {
            let k = seen.entry(n).or_default();
            *k += 1;
            if *k == 1 {
                format!("frame_{n:05}.png")
            } else {
                repeats += 1;
                format!("frame_{n:05}_dup{}.png", *k - 1)
            }
        })
        .collect();
    (names, repeats)
}

/// Reads a tactile map, or flattens a layout given instead of one.
pub(crate) fn load_map(path: &Path) -> Result<TactileMap> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    if text.contains(skin_geom::MAP_FORMAT) || text.contains("\"tactile_maps\"") {
        return Ok(TactileMap::read(path)?);
    }
    let link = crate::shared::load_input(path)?;
    let map = TactileMap::flatten(&link, &skin_geom::FlattenOptions::default())
        .with_context(|| format!("{}", path.display()))?;
    let (w, h) = map.extent();
    crate::say!(
        "{}: a layout, flattened to a {:.0} x {:.0} mm tactile map (mean angle error {:.3} deg); save it with `skin flatten` to skip this step",
        path.display(),
        w * 1e3,
        h * 1e3,
        map.report.distortion.angle_error_mean_deg
    );
    Ok(map)
}

/// Runs `each(input, frame, pressures, grey)` on every frame of `inputs` with a reading above
/// `threshold` (readings at or below it count as zero), imaged by `imager`; returns how many
/// frames had no contact.
pub(crate) fn each_touched_frame(
    inputs: &[Input],
    imager: &mut TactileImager,
    threshold: f32,
    mut each: impl FnMut(&Input, usize, &[f32], &[u8]) -> Result<()>,
) -> Result<usize> {
    let mut pressures = vec![0.0f32; imager.raster().taxel_count()];
    let mut quiet = 0usize;
    for input in inputs {
        for (f, frame) in input.rec.frames.iter().enumerate() {
            let mut any = false;
            for (p, &c) in pressures.iter_mut().zip(&input.columns) {
                let v = frame.values[c];
                *p = if v > threshold { v } else { 0.0 };
                any |= *p > 0.0;
            }
            if !any {
                quiet += 1;
                continue;
            }
            let grey = imager.process(&pressures)?;
            each(input, f, &pressures, grey)?;
        }
    }
    Ok(quiet)
}

/// One output name per input: its file stem, prefixed with its folder's name where two inputs
/// share a stem; an error where even that leaves two alike (nothing is written over another).
pub(crate) fn output_names(paths: &[PathBuf]) -> Result<Vec<String>> {
    let stem = |p: &Path| {
        p.file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("input")
            .to_string()
    };
    let mut count: HashMap<String, usize> = HashMap::new();
    for p in paths {
        *count.entry(stem(p)).or_default() += 1;
    }
    let mut used: HashMap<String, &Path> = HashMap::new();
    let mut names = Vec::with_capacity(paths.len());
    for p in paths {
        let mut name = stem(p);
        if count[&name] > 1 {
            let parent = p
                .parent()
                .and_then(|d| d.file_name())
                .and_then(|s| s.to_str())
                .unwrap_or("input");
            name = format!("{parent}_{name}");
        }
        if let Some(first) = used.insert(name.clone(), p) {
            bail!(
                "{} and {}: both would be written as {name}; give inputs distinct names (or list each once)",
                first.display(),
                p.display()
            );
        }
        names.push(name);
    }
    Ok(names)
}

/// Reads the recordings and maps their columns onto the map's taxels; names each output folder
/// after the recording (with its parent folder when two recordings share a name).
pub(crate) fn load_inputs(paths: &[PathBuf], map: &TactileMap, out: &Path) -> Result<Vec<Input>> {
    let names = output_names(paths)?;
    let mut inputs = Vec::with_capacity(paths.len());
    for p in paths {
        let rec = recording::read(p)?;
        let index: HashMap<_, _> = rec.taxel_ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        let mut columns = Vec::with_capacity(map.ids.len());
        let mut missing = Vec::new();
        for id in &map.ids {
            match index.get(id) {
                Some(&c) => columns.push(c),
                None => missing.push(id.0),
            }
        }
        if !missing.is_empty() {
            bail!(
                "{}: {} taxel(s) of the map are not in the recording (first: {:?}); is it a recording of this link?",
                p.display(),
                missing.len(),
                &missing[..missing.len().min(5)]
            );
        }
        let extra = rec.taxel_ids.len() - map.ids.len().min(rec.taxel_ids.len());
        if extra > 0 {
            crate::say!(
                "{}: {extra} reading column(s) are not taxels of the map and are ignored",
                p.display()
            );
        }
        let name = names[inputs.len()].clone();
        let (files, repeats) = frame_names(&rec.frame_numbers);
        if repeats > 0 {
            crate::say!(
                "{}: {repeats} frame number(s) repeat an earlier frame's; their images are named frame_<number>_dup<k>.png",
                p.display()
            );
        }
        inputs.push(Input {
            path: p.clone(),
            dir: out.join(name),
            rec,
            columns,
            names: files,
        });
    }
    Ok(inputs)
}

/// Reads the postures of `poses`, which must name the links of `layout` (`names`), in order.
pub(crate) fn read_postures(
    poses: &std::path::Path,
    layout: &std::path::Path,
    names: &[&str],
) -> Result<Postures> {
    let postures = Postures::read(poses)?;
    if postures.links != names {
        bail!(
            "{}: links {:?}, but the layout {} has {:?} (same names, same order)",
            poses.display(),
            postures.links,
            layout.display(),
            names
        );
    }
    Ok(postures)
}

/// Prints what a run lost (nothing when nothing was).
pub(crate) fn say_report(tally: &skin_can::ModuleTally, map: &BusMap, stats: &AssemblyStats) {
    let report = tally.report(map, stats).to_string();
    if !report.is_empty() {
        crate::say!("{report}");
    }
}

/// The model commands' inputs (feature `onnx`).
#[cfg(feature = "onnx")]
mod models {
    use anyhow::{Context, Result, bail};
    use skin_learn::classify::InputScale;
    use std::path::PathBuf;

    /// The model and what it runs on, for `skin classify` and `skin segment`.
    #[derive(clap::Args)]
    pub(crate) struct ModelInputs {
        /// The ONNX model.
        #[arg(long, value_name = "MODEL.onnx")]
        pub(crate) model: PathBuf,
        /// PNG images, or recordings with --map.
        #[arg(required = true, value_name = "INPUTS")]
        pub(crate) inputs: Vec<PathBuf>,
        /// Tactile map (or layout) of the recordings: run the model on their touched frames.
        #[arg(long, value_name = "MAP.json")]
        pub(crate) map: Option<PathBuf>,
        /// With --map: readings at or below this count as no contact (the recording's units).
        #[arg(long, default_value_t = 10.0, value_parser = crate::numbers::within(-1e9, 1e9))]
        pub(crate) threshold: f64,
        /// Grey levels as the model expects them: 255 (0..255) or 1 (0..1). Default: what the
        /// model card (MODEL.md beside MODEL.onnx) says, else 255.
        #[arg(long, value_enum)]
        pub(crate) input_scale: Option<Scale>,
    }

    /// How the model expects grey levels.
    #[derive(Clone, Copy, clap::ValueEnum)]
    pub(crate) enum Scale {
        /// 0..255 as floats.
        #[value(name = "255")]
        Bytes,
        /// 0..1.
        #[value(name = "1")]
        Unit,
    }

    /// A grey PNG of the model's input size (rows, cols), as row-major pixels.
    pub(crate) fn read_model_image(path: &std::path::Path, (h, w): (usize, usize)) -> Result<Vec<u8>> {
        let img = image::open(path).with_context(|| format!("cannot read {} as an image", path.display()))?;
        // A colour or 16-bit image is not a tactile image: converting it would hide the mistake.
        if img.color() != image::ColorType::L8 {
            bail!(
                "{}: a {:?} image; the model takes 8-bit grey tactile images (make them with `skin image`)",
                path.display(),
                img.color()
            );
        }
        let img = img.into_luma8();
        let (iw, ih) = img.dimensions();
        if (ih as usize, iw as usize) != (h, w) {
            bail!(
                "{}: {ih} x {iw} px, the model takes {h} x {w} (make images of that size with `skin image --size {h}x{w}`)",
                path.display()
            );
        }
        Ok(img.into_raw())
    }

    /// The input scaling: as given, else as the model card says, else 0..255 (the MATLAB HandsNet).
    pub(crate) fn input_scale(model: &std::path::Path, given: Option<Scale>) -> InputScale {
        match given {
            Some(Scale::Unit) => InputScale::Unit,
            Some(Scale::Bytes) => InputScale::Bytes,
            None => InputScale::for_model(model),
        }
    }
}
