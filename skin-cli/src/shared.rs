//! What several commands share: reading layouts, maps, recordings and poses as the commands
//! take them, the images a model reads, the names images get, and the CAN traffic tallies of
//! `replay` and `live`. A command imports from here, never from another command.

// What only the model commands use is built with them; its imports go unused without.
#![cfg_attr(not(feature = "onnx"), allow(unused_imports))]

use anyhow::{Context, Result, bail};
use skin_can::live::LiveOptions;
use skin_can::{AssemblyStats, BusMap};
use skin_core::format::poses::Postures;
use skin_core::format::{Noted, recording};
use skin_core::{Columns, LinkSkin, Recording};
use skin_geom::{DeadTaxels, TactileImager, TactileMap};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

#[cfg(feature = "onnx")]
pub(crate) use models::{ModelInputs, Scale, input_scale, read_model_image};

/// `noted`'s value, after saying what was done to read it.
pub(crate) fn said<T>(noted: Noted<T>) -> T {
    for note in &noted.notes {
        crate::say!("{note}");
    }
    noted.value
}

/// Every link of a layout file ([`skin_geom::read_layout`]).
pub(crate) fn load_links(path: &Path) -> Result<Vec<LinkSkin>> {
    Ok(said(skin_geom::read_layout(path)?))
}

/// The link of a layout file ([`skin_geom::read_link`]).
pub(crate) fn load_input(path: &Path) -> Result<LinkSkin> {
    Ok(said(skin_geom::read_link(path)?))
}

/// A tactile map, or a layout flattened ([`skin_geom::read_map`]).
pub(crate) fn load_map(path: &Path) -> Result<TactileMap> {
    Ok(said(skin_geom::read_map(
        path,
        &skin_geom::FlattenOptions::default(),
    )?))
}

/// One recording, with its readings reordered to map order.
pub(crate) struct Input {
    /// The recording.
    #[cfg_attr(not(feature = "onnx"), allow(dead_code))] // named by the commands that run models
    pub(crate) path: PathBuf,
    pub(crate) dir: PathBuf,
    pub(crate) rec: Recording,
    pub(crate) columns: Columns,
    /// Each frame's image file name ([`Recording::frame_stems`], `.png`).
    pub(crate) names: Vec<String>,
    /// Its map, in the maps [`load_inputs`] returns: the map given, or that map without the
    /// taxels the recording has no column for (dead taxels, re-triangulated over).
    pub(crate) map: usize,
}

/// Runs `each(input, frame, pressures, grey)` on every frame of `inputs` with a reading above
/// `threshold` (readings at or below it count as zero), imaged by `imagers[input.map]`; returns
/// how many frames had no contact.
#[cfg(feature = "onnx")] // only the commands that run models use it
pub(crate) fn each_touched_frame(
    inputs: &[Input],
    imagers: &mut [TactileImager],
    threshold: f32,
    mut each: impl FnMut(&Input, usize, &[f32], &[u8]) -> Result<()>,
) -> Result<usize> {
    let mut quiet = 0usize;
    for input in inputs {
        let imager = &mut imagers[input.map];
        let mut pressures = vec![0.0f32; imager.raster().taxel_count()];
        for (f, frame) in input.rec.frames.iter().enumerate() {
            if !input.columns.gather(&frame.values, threshold, &mut pressures) {
                quiet += 1;
                continue;
            }
            let grey = imager.process(&pressures)?;
            each(input, f, &pressures, grey)?;
        }
    }
    Ok(quiet)
}

/// The imagers of a model's input (`size`) for `maps` ([`TactileImager::for_model`]).
#[cfg(feature = "onnx")] // only the commands that run models use it
pub(crate) fn model_imagers(
    maps: &[TactileMap],
    size: skin_core::image::ImageSize,
    map_path: &Path,
) -> Result<Vec<TactileImager>> {
    let imager = |m| TactileImager::for_model(m, 1.0, size).with_context(|| map_path.display().to_string());
    maps.iter().map(imager).collect()
}

/// One output name per input ([`skin_core::output::output_names`]).
pub(crate) fn output_names(paths: &[PathBuf]) -> Result<Vec<String>> {
    Ok(skin_core::output::output_names(paths)?)
}

/// Reads the recordings and maps their columns onto the map's taxels; names each output folder
/// after the recording (with its parent folder when two recordings share a name).
pub(crate) fn load_inputs(
    paths: &[PathBuf],
    map: &TactileMap,
    out: &Path,
) -> Result<(Vec<Input>, Vec<TactileMap>)> {
    let names = output_names(paths)?;
    let mut inputs = Vec::with_capacity(paths.len());
    let mut maps = vec![map.clone()];
    // One reduced map per set of dead taxels (recordings of one rig share theirs).
    let mut reduced: HashMap<DeadTaxels, usize> = HashMap::new();
    for (p, name) in paths.iter().zip(names) {
        let rec = recording::read(p)?;
        let full = rec.columns(&map.ids);
        if full.ignored > 0 {
            crate::say!(
                "{}: {} reading column(s) are not taxels of the map and are ignored",
                p.display(),
                full.ignored
            );
        }
        if full.missing.len() == map.ids.len() {
            bail!(
                "{}: none of the map's {} taxels is in the recording (first: {}); is it a recording of this link?",
                p.display(),
                map.ids.len(),
                map.ids.first().map_or(0, |id| id.0)
            );
        }
        let (k, columns) = if full.missing.is_empty() {
            (0, full)
        } else {
            let placeholders = full.missing.iter().filter(|id| id.is_placeholder()).count();
            crate::say!(
                "{}: {} taxel(s) of the map have no column in the recording ({placeholders} of them placeholders; first: {}): dead, images interpolate across them",
                p.display(),
                full.missing.len(),
                full.missing[0]
            );
            let dead = DeadTaxels::of_columns(&full);
            let k =
                match reduced.get(&dead) {
                    Some(&k) => k,
                    None => {
                        maps.push(dead.remove_from(map).with_context(|| {
                            format!("{}: the map without the taxels it lacks", p.display())
                        })?);
                        reduced.insert(dead, maps.len() - 1);
                        maps.len() - 1
                    }
                };
            (k, rec.columns(&maps[k].ids))
        };
        let stems = frame_stems(p, &rec);
        inputs.push(Input {
            path: p.clone(),
            dir: out.join(name),
            rec,
            columns,
            names: stems.into_iter().map(|s| s + ".png").collect(),
            map: k,
        });
    }
    Ok((inputs, maps))
}

/// The recording's frame file stems ([`Recording::frame_stems`]), saying how many frame
/// numbers repeat (their images get a `_dup<k>` suffix instead of overwriting).
pub(crate) fn frame_stems(path: &Path, rec: &Recording) -> Vec<String> {
    let (stems, repeats) = rec.frame_stems();
    if repeats > 0 {
        crate::say!(
            "{}: {repeats} frame number(s) repeat an earlier frame's; their images are named frame_<number>_dup<k>.png",
            path.display()
        );
    }
    stems
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

// The live acquisition of `live`, `record` and `run --can`.

pub(crate) use skin_can::recorder::LiveStep;

/// The interfaces to read: those given, else the bus map's.
pub(crate) fn interfaces(map: &BusMap, given: &[String]) -> Vec<String> {
    if given.is_empty() {
        map.buses.iter().map(|b| b.interface.clone()).collect()
    } else {
        given.to_vec()
    }
}

/// Live frames for `skin run`: reads `names` (default: the bus map's interfaces) and hands every
/// item of the acquisition, and the assembler's counts after each poll, to `each`, until Ctrl-C,
/// `duration` seconds, or `each` returns false.
pub(crate) fn each_live(
    map: &BusMap,
    names: &[String],
    master: bool,
    duration: Option<f64>,
    each: &mut dyn FnMut(LiveStep<'_>) -> bool,
) -> Result<()> {
    let period = Duration::from_millis(50);
    let options = LiveOptions {
        sync_period: master.then_some(period),
        ..LiveOptions::default()
    };
    let ports = skin_can::recorder::open_system_ports(&interfaces(map, names))?;
    crate::output::stop_gracefully();
    let stop = crate::output::stop_flag();
    let deadline = duration.map(|d| Instant::now() + Duration::from_secs_f64(d));
    let done = || stop.load(Ordering::SeqCst) || deadline.is_some_and(|d| Instant::now() >= d);
    skin_can::recorder::run_live(ports, options, map, period, done, &mut |step, _| each(step));
    Ok(())
}
